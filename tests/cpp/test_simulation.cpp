// Tests of the Simulation: the contact-history map across neighbour rebuilds, determinism,
// a closed-form collision, errors as exceptions, and the overlap check of changes made after
// the first run.
#include <algorithm>
#include <cmath>
#include <random>
#include <sstream>
#include <vector>

#include "check.hpp"
#include "tsubu/simulation.hpp"

using namespace tsubu;

namespace {

const double kR = 0.5e-3;

Material glass(double e = 0.5, double mu = 0.5) {
  Material m;
  m.restitution = e;
  m.friction = mu;
  return m;
}

// Two spheres pressed together and sheared, on a floor, under gravity.
Simulation sheared_pair(bool rebuild_every_step) {
  Options o;
  o.rebuild_every_step = rebuild_every_step;
  Simulation s(o);
  const int g = s.add_material(glass());
  s.add_sphere(Vec3(0, 0, kR), kR, g, Vec3(0.01, 0, 0));
  s.add_sphere(Vec3(0.2 * kR, 0, 3 * kR - 1e-6), kR, g, Vec3(-0.02, 0, 0), Vec3(0, 50, 0));
  s.add_plane(Vec3::Zero(), Vec3(0, 0, 1), g);
  return s;
}

void test_history_survives_rebuilds() {
  Simulation a = sheared_pair(false), b = sheared_pair(true);
  a.run(3000);
  b.run(3000);
  CHECK(b.rebuild_count() > 100 * a.rebuild_count());
  std::vector<double> xa(6), xb(6), wa(6), wb(6);
  a.get_positions(xa.data());
  b.get_positions(xb.data());
  a.get_angular_velocities(wa.data());
  b.get_angular_velocities(wb.data());
  CHECK(xa == xb);  // bit for bit
  CHECK(wa == wb);
  bool loaded = false;
  for (const ContactInfo& c : a.contacts()) loaded |= c.tangential_displacement.norm() > 0;
  CHECK(loaded);  // the test exercised a real history
}

void test_history_cleared_on_separation() {
  Simulation s;
  const int g = s.add_material(glass(1.0, 0.5));
  s.options().gravity = Vec3::Zero();
  s.add_sphere(Vec3(-kR, 0, 0), kR, g, Vec3(0.05, 0.02, 0));
  s.add_sphere(Vec3(kR + 1e-7, 0.2 * kR, 0), kR, g, Vec3(-0.05, -0.02, 0));
  bool touched = false;
  for (int k = 0; k < 200; ++k) {
    s.run(1);
    for (const ContactInfo& c : s.contacts()) touched |= c.tangential_displacement.norm() > 0;
  }
  CHECK(touched);
  CHECK(s.contacts().empty());
  s.rebuild_neighbors();
  s.run(1);
  CHECK(s.contacts().empty());
}

Simulation cloud(int threads) {
  Options o;
  o.threads = threads;
  o.parallel_min = 0;  // really use the threads on this small scene
  o.gravity = Vec3(0, 0, -9.81);
  Simulation s(o);
  const int g = s.add_material(glass(0.7, 0.4));
  std::mt19937_64 rng(42);
  std::uniform_real_distribution<double> u(-1, 1);
  for (int i = 0; i < 6; ++i)
    for (int j = 0; j < 6; ++j)
      for (int k = 0; k < 8; ++k) {
        const double r = kR * (0.6 + 0.3 * (u(rng) + 1));
        s.add_sphere(Vec3(i, j, k) * 2.6 * kR + Vec3::Constant(1.5 * kR), r, g,
                     0.1 * Vec3(u(rng), u(rng), u(rng)), 100 * Vec3(u(rng), u(rng), u(rng)));
      }
  s.add_plane(Vec3::Zero(), Vec3(0, 0, 1), g);
  s.add_plane(Vec3::Zero(), Vec3(1, 0, 0), g);
  s.add_plane(Vec3(16 * kR, 0, 0), Vec3(-1, 0, 0), g);
  return s;
}

void test_thread_count_independence() {
  Simulation one = cloud(1), two = cloud(2), three = cloud(3);
  one.run(4000);
  two.run(4000);
  three.run(4000);
  std::vector<double> x1(3 * one.size()), x2(x1.size()), x3(x1.size()), v1(x1.size()), v2(x1.size());
  one.get_positions(x1.data());
  two.get_positions(x2.data());
  three.get_positions(x3.data());
  one.get_velocities(v1.data());
  two.get_velocities(v2.data());
  CHECK(x1 == x2);
  CHECK(x1 == x3);
  CHECK(v1 == v2);
  CHECK(one.contacts().size() > 0);
}

void test_head_on_restitution() {
  // e = exp(-eta pi / (2 alpha m)) (B.8), reached to O(dt) at dt = t_c/200.
  Simulation s;
  s.options().gravity = Vec3::Zero();
  const int g = s.add_material(glass(0.5, 0.0));
  s.add_sphere(Vec3(-kR, 0, 0), kR, g, Vec3(0.05, 0, 0));
  s.add_sphere(Vec3(kR, 0, 0), kR, g, Vec3(-0.05, 0, 0));
  s.options().dt = s.contact_duration() / 200;
  s.run(400);
  std::vector<double> v(6);
  s.get_velocities(v.data());
  CHECK_CLOSE((v[3] - v[0]) / 0.1, 0.5, 0.003);
  CHECK(s.law_name() == "hooke+frictionless");
}

void test_errors() {
  Simulation s;
  Material bad = glass();
  bad.restitution = 0;
  CHECK_THROWS(s.add_material(bad), InvalidArgument);
  const int g = s.add_material(glass());
  CHECK_THROWS(s.add_sphere(Vec3(0, 0, 0), -1.0, g), InvalidArgument);
  CHECK_THROWS(s.add_sphere(Vec3(NAN, 0, 0), kR, g), InvalidArgument);
  CHECK_THROWS(s.add_plane(Vec3::Zero(), Vec3::Zero(), g), InvalidArgument);
  s.add_sphere(Vec3(0, 0, kR), kR, g);
  s.add_plane(Vec3::Zero(), Vec3(0, 0, 1), g);
  s.options().dt = 1.01 * s.critical_time_step();
  CHECK_THROWS(s.run(1), InvalidArgument);  // above the bound of (2.31)
  // Forced through, a sphere dropped fast on the floor is caught as an instability.
  Simulation t;
  const int h = t.add_material(glass());
  t.add_sphere(Vec3(0, 0, 1.01 * kR), kR, h, Vec3(0, 0, -50.0));
  t.add_plane(Vec3::Zero(), Vec3(0, 0, 1), h);
  CHECK_THROWS(t.run(100000), InstabilityError);
  std::vector<double> x(3);
  t.get_positions(x.data());
  CHECK(std::isfinite(x[2]));
}

// A lone sphere 1e300 m away makes the grid sparse: the cluster keeps its pairs, bit for bit.
// A list that cannot fit throws ResourceError before the rebuild changes anything.
void test_sparse_grid_and_list_limit() {
  auto cluster = [](bool far) {
    Options o;
    o.gravity = Vec3(0, 0, -9.81);
    Simulation s(o);
    const int g = s.add_material(glass());
    for (int k = 0; k < 64; ++k)
      s.add_sphere(Vec3((k % 4) * 2.1 * kR, (k / 4 % 4) * 2.1 * kR, (k / 16 + 1) * 2.1 * kR), kR, g,
                   Vec3(0.01 * (k % 3), 0, 0));
    if (far) s.add_sphere(Vec3(1e300, 0, 1.0), kR, g);
    s.add_plane(Vec3::Zero(), Vec3(0, 0, 1), g);
    s.run(500);
    return s;
  };
  Simulation near = cluster(false), far = cluster(true);
  std::vector<double> xn(3 * 64), xf(3 * 65);
  near.get_positions(xn.data());
  far.get_positions(xf.data());
  CHECK(std::equal(xn.begin(), xn.end(), xf.begin()));
  CHECK(near.neighbor_pairs() == far.neighbor_pairs());

  Options o;
  o.skin = 1e3;
  Simulation big(o);
  const int g = big.add_material(glass());
  const int n = 20000;
  for (int k = 0; k < n; ++k) big.add_sphere(Vec3(k * 4 * kR, 0, 0), kR, g);
  CHECK_THROWS(big.rebuild_neighbors(), ResourceError);
  CHECK(big.neighbor_pairs().empty());
}

// Overlaps made after the first run (issue 26): a sphere added or moved into another, or a
// wall added through one, is refused by the next run (InvalidArgument, no step taken), also
// after a checkpoint round trip; spheres added with check_overlaps = false are not checked; a
// pair moved together keeps its overlap.
void test_overlaps_after_the_first_run() {
  auto two = [] {
    Simulation s;
    const int g = s.add_material(glass());
    s.add_sphere(Vec3(0, 0, kR), kR, g);
    s.add_sphere(Vec3(4 * kR, 0, kR), kR, g);
    s.add_plane(Vec3::Zero(), Vec3(0, 0, 1), g);
    s.options().dt = 1e-6;
    s.run(10);
    return s;
  };
  Simulation s = two();
  s.add_sphere(Vec3(-1.8 * kR, 0, kR), kR, 0);  // 0.2 r into sphere 0
  std::stringstream saved;
  s.save(saved);
  CHECK_THROWS(s.run(1), InvalidArgument);
  CHECK(s.step_count() == 10);
  Simulation loaded = Simulation::load(saved);
  CHECK_THROWS(loaded.run(1), InvalidArgument);
  std::vector<double> x(9);
  s.get_positions(x.data());
  x[6] = -3 * kR;  // moved clear
  s.set_positions(x.data());
  CHECK(s.run(1) == 1);
  x[3] = 1.8 * kR;  // sphere 1 moved 0.2 r into sphere 0
  s.set_positions(x.data());
  CHECK_THROWS(s.run(1), InvalidArgument);
  for (double dx : {0.0, 1.0}) {  // back where it was, or everything moved 1 m: accepted
    x[3] = 4 * kR;
    s.set_positions(x.data());
    for (int k = 0; k < 3; ++k) x[3 * k] += dx;
    s.set_positions(x.data());
    CHECK(s.run(1) == 1);
    s.get_positions(x.data());
  }
  Simulation w = two();
  w.add_plane(Vec3(4.9 * kR, 0, 0), Vec3(-1, 0, 0), 0);  // 0.1 r into sphere 1
  CHECK_THROWS(w.run(1), InvalidArgument);
  Simulation u = two();
  const double p[3] = {-1.8 * kR, 0, kR}, r = kR;
  const int m = 0;
  u.add_spheres(1, p, &r, &m, nullptr, nullptr, /*check_overlaps=*/false);
  CHECK(u.run(1) == 1);
}

// Grains as boundaries from C++: a glued sphere stays put under gravity and load, an outlet
// removes a falling sphere at the end of the step its centre crosses, with a log entry, and
// a checkpoint keeps both (boundary.hpp).
void test_fixed_spheres_and_outlets() {
  Simulation s;
  const int g = s.add_material(glass());
  s.add_sphere(Vec3(0, 0, 0), kR, g);
  s.add_sphere(Vec3(0, 0, 2 * kR - 1e-7), kR, g);
  s.add_sphere(Vec3(1, 0, 0), kR, g);
  const Id glued = 0;
  const double zero[3] = {0, 0, 0};
  s.fix_spheres(1, &glued, zero, zero);
  Outlet o;
  o.a = Vec3(0, 0, -0.01);
  o.b = Vec3(0, 0, 1);
  CHECK(s.add_outlet(o) == 0);
  s.options().dt = 1e-6;
  CHECK(s.run(50000) == 50000);  // 0.05 s: sphere 2 falls 12 mm, past the outlet at -10 mm
  std::vector<double> x(3 * s.size());
  s.get_positions(x.data());
  CHECK(s.size() == 2);
  CHECK(x[0] == 0 && x[1] == 0 && x[2] == 0);          // glued
  CHECK(std::abs(x[5] - (2 * kR)) < 0.05 * kR);        // resting on it
  const RemovalLog& log = s.removed();
  CHECK(log.size() == 1 && log.id[0] == 2 && log.outlet[0] == 0);
  CHECK(log.position[2] < -0.01 && log.position[2] > -0.01 - 1e-5);
  std::stringstream bytes;
  s.save(bytes);
  Simulation t = Simulation::load(bytes);
  CHECK(t.fixed_spheres().ids == std::vector<Id>{0});
  CHECK(t.outlets().size() == 1 && t.removed().id == log.id);
  const Id bad = 7;
  CHECK_THROWS(s.fix_spheres(1, &bad, zero, zero), InvalidArgument);
}

}  // namespace

int main() {
  test_history_survives_rebuilds();
  test_history_cleared_on_separation();
  test_thread_count_independence();
  test_head_on_restitution();
  test_errors();
  test_sparse_grid_and_list_limit();
  test_overlaps_after_the_first_run();
  test_fixed_spheres_and_outlets();
  return tsubu_test::finish("test_simulation");
}
