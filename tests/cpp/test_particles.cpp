// Tests of Particles' id map through the Simulation: spheres removed mid-run leave the others'
// trajectories bit for bit as if the removed ones had never been there; ids are kept (not
// 0..N-1 any more), new ids are never reused, and a saved run keeps its ids.
#include <algorithm>
#include <sstream>
#include <stdexcept>
#include <vector>

#include "check.hpp"
#include "tsubu/simulation.hpp"

using namespace tsubu;

namespace {

const double kR = 0.5e-3;

// A 3 x 3 x 4 lattice of beads settling on a floor, with, when `lonely`, two beads far out on
// the floor (ids 5 and 13) that never meet the others.
Simulation pile(bool lonely) {
  Options o;
  o.dt = 2e-6;
  o.skin = 0.2e-3;
  Simulation s(o);
  Material glass;
  glass.restitution = 0.5;
  glass.friction = 0.5;
  const int g = s.add_material(glass);
  int added = 0;
  for (int k = 0; k < 4; ++k)
    for (int j = 0; j < 3; ++j)
      for (int i = 0; i < 3; ++i) {
        if (lonely && (added == 5 || added == 13)) {
          s.add_sphere(Vec3(0.05 + 0.01 * added, 0, kR), kR, g);
          ++added;
        }
        const Vec3 x(2.05 * kR * i + 1e-5 * k, 2.05 * kR * j, kR + 2.1 * kR * k);
        s.add_sphere(x, kR, g, Vec3(0.01 * (i - 1), 0.005 * (j - 1), 0));
        ++added;
      }
  s.add_plane(Vec3::Zero(), Vec3(0, 0, 1), g);
  return s;
}

std::vector<double> positions(const Simulation& s) {
  std::vector<double> x(3 * s.size());
  s.get_positions(x.data());
  return x;
}

std::vector<double> velocities(const Simulation& s) {
  std::vector<double> v(3 * s.size());
  s.get_velocities(v.data());
  return v;
}

void test_removed_spheres_leave_no_trace() {
  Simulation with = pile(true), without = pile(false);
  with.run(20000);  // 40 ms: the pile has landed and its contacts hold tangential springs
  int loaded = 0;  // pair contacts holding a tangential history when the spheres are removed
  for (const ContactInfo& c : with.contacts()) loaded += c.j >= 0 && c.tangential_displacement.norm() > 0;
  CHECK(loaded > 0);
  const Id lonely[] = {13, 5};
  with.remove_spheres(2, lonely);
  CHECK(with.size() == without.size());
  with.run(5000);
  without.run(25000);
  CHECK(positions(with) == positions(without));  // bit for bit
  CHECK(velocities(with) == velocities(without));
  bool pressed = false;
  for (const ContactInfo& c : with.contacts()) pressed |= c.j >= 0 && c.tangential_displacement.norm() > 0;
  CHECK(pressed);  // the pile's contacts carried their history through the removal
}

void test_ids_are_kept_and_never_reused() {
  Simulation s = pile(true);
  s.run(500);
  const Id gone[] = {0, 7};
  s.remove_spheres(2, gone);
  // Contacts name spheres by their ids, which no longer start at 0.
  for (const ContactInfo& c : s.contacts()) CHECK(c.i != 0 && c.i != 7 && c.j != 0 && c.j != 7);
  const std::vector<double> before = positions(s);
  const Id fresh = s.add_sphere(Vec3(0.2, 0, kR), kR, 0);
  CHECK(fresh == 38);  // 38 spheres were handed ids 0..37
  const std::vector<double> after = positions(s);
  CHECK(std::equal(before.begin(), before.end(), after.begin()));  // the new one is the last row
  CHECK(after[after.size() - 3] == 0.2);
  bool threw = false;
  try {
    s.remove_spheres(1, gone);
  } catch (const InvalidArgument&) {
    threw = true;
  }
  CHECK(threw);  // already removed
  threw = false;
  const Id twice[] = {3, 3};
  try {
    s.remove_spheres(2, twice);
  } catch (const InvalidArgument&) {
    threw = true;
  }
  CHECK(threw);
  CHECK(s.size() == 37);
}

void test_a_saved_run_keeps_its_ids() {
  Simulation s = pile(true);
  s.run(1000);
  const Id gone[] = {2, 20};
  s.remove_spheres(2, gone);
  s.run(500);
  std::stringstream file;
  s.save(file);
  Simulation copy = Simulation::load(file);
  CHECK(copy.size() == s.size());
  s.run(1000);
  copy.run(1000);
  CHECK(positions(copy) == positions(s));
  CHECK(velocities(copy) == velocities(s));
  const std::vector<ContactInfo> a = s.contacts(), b = copy.contacts();
  CHECK(a.size() == b.size());
  for (std::size_t k = 0; k < std::min(a.size(), b.size()); ++k) CHECK(a[k].i == b[k].i && a[k].j == b[k].j);
  CHECK(copy.add_sphere(Vec3(0.3, 0, kR), kR, 0) == 38);
  // With the largest id removed, its id is still not handed out again after a reload.
  const Id last[] = {38};
  copy.remove_spheres(1, last);
  std::stringstream again;
  copy.save(again);
  CHECK(Simulation::load(again).add_sphere(Vec3(0.4, 0, kR), kR, 0) == 39);
}

}  // namespace

int main() {
  test_removed_spheres_leave_no_trace();
  test_ids_are_kept_and_never_reused();
  test_a_saved_run_keeps_its_ids();
  return tsubu_test::finish("test_particles");
}
