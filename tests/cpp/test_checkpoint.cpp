// Tests of checkpoints: a Simulation rebuilt from another's state (Simulation::run_state,
// contact_state and their setters: spheres in id order, contacts keyed by ids) runs on bit for
// bit as the original does, in a small scene and in one large enough to fuse steps; so does one
// that Simulation::save wrote to a stream and Simulation::load read back; a damaged stream is
// refused with a message that says what is wrong.
#include <cstdio>
#include <random>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

#include "check.hpp"
#include "tsubu/simulation.hpp"

using namespace tsubu;

namespace {

Options options(int threads) {
  Options o;
  o.threads = threads;
  o.parallel_min = 0;
  o.dt = 2e-6;
  o.seed = 11;
  return o;
}

// Frictional spheres (rough and rolling if `moving`) of two materials on a lattice with random velocities and
// spins, over a floor (sliding if `moving`) and between two walls (one turning if `moving`).
void fill(Simulation& s, int side, int layers, bool moving) {
  Material grain, stiff;
  grain.restitution = 0.5;
  grain.friction = 0.5;
  if (moving) {  // the laws that fuse no steps (engine/driver.hpp) with the walls that move
    grain.rolling_friction = 0.1;
    grain.roughness = 0.05;
  }
  stiff.kn = 2e3;
  stiff.restitution = 0.7;
  stiff.friction = 0.3;
  const int g = s.add_material(grain), h = s.add_material(stiff);
  std::mt19937_64 rng(5);
  std::uniform_real_distribution<double> radius(0.45e-3, 0.50e-3);
  std::normal_distribution<double> speed(0.0, 0.05), spin(0.0, 50.0);
  const double spacing = 1.01e-3;
  for (int i = 0; i < side; ++i)
    for (int j = 0; j < side; ++j)
      for (int k = 0; k < layers; ++k)
        s.add_sphere((Vec3(i, j, k) + Vec3::Constant(0.5)) * spacing, radius(rng), (i + k) % 3 ? g : h,
                     Vec3(speed(rng), speed(rng), speed(rng)), Vec3(spin(rng), spin(rng), spin(rng)));
  s.add_plane(Vec3::Zero(), Vec3(0, 0, 1), h, Vec3(moving ? 0.01 : 0, 0, 0));
  s.add_plane(Vec3::Zero(), Vec3(1, 0, 0), g, Vec3::Zero(), Vec3(0, moving ? 0.3 : 0, 0));
  s.add_plane(Vec3(side * spacing, 0, 0), Vec3(-1, 0, 0), g);
}

// A new Simulation with `s`'s setup and state, as a checkpoint reader builds it.
Simulation restored(const Simulation& s, int threads) {
  Simulation r(options(threads));
  for (int m = 0; m < s.material_count(); ++m) r.add_material(s.material(m));
  const std::size_t n = s.size();
  std::vector<double> x(3 * n), v(3 * n), w(3 * n), radius(n), dissipated(n);
  std::vector<int> material(n);
  s.get_positions(x.data());
  s.get_velocities(v.data());
  s.get_angular_velocities(w.data());
  s.get_radii(radius.data());
  s.get_materials(material.data());
  s.get_dissipated(dissipated.data());
  r.add_spheres(n, x.data(), radius.data(), material.data(), v.data(), w.data());
  r.set_dissipated(dissipated.data());
  for (int k = 0; k < s.plane_count(); ++k) {
    const Plane& p = s.plane(k);
    r.add_plane(p.point, p.normal, p.material, p.velocity, p.angular_velocity);
    r.set_plane_state(k, p);
  }
  r.set_contact_state(s.contact_state(false), s.contact_state(true));
  r.set_run_state(s.run_state());
  return r;
}

bool identical(const Simulation& a, const Simulation& b) {
  const std::size_t n = a.size();
  std::vector<double> xa(3 * n), xb(3 * n), va(3 * n), vb(3 * n), wa(3 * n), wb(3 * n);
  a.get_positions(xa.data());
  b.get_positions(xb.data());
  a.get_velocities(va.data());
  b.get_velocities(vb.data());
  a.get_angular_velocities(wa.data());
  b.get_angular_velocities(wb.data());
  if (a.step_count() != b.step_count() || a.time() != b.time() || xa != xb || va != vb || wa != wb)
    return false;
  const auto ca = a.contacts(), cb = b.contacts();
  if (ca.size() != cb.size()) return false;
  for (std::size_t k = 0; k < ca.size(); ++k)
    if (ca[k].i != cb[k].i || ca[k].j != cb[k].j || ca[k].wall != cb[k].wall ||
        ca[k].overlap != cb[k].overlap || ca[k].force != cb[k].force ||
        ca[k].tangential_displacement != cb[k].tangential_displacement)
      return false;
  return a.energy().dissipated == b.energy().dissipated;
}

void test_restored_runs_on_bit_for_bit(int side, int layers, long before, long after, int threads,
                                      bool moving) {
  Simulation whole(options(threads)), part(options(threads));
  fill(whole, side, layers, moving);
  fill(part, side, layers, moving);
  whole.run(before + after);
  part.run(before);
  std::printf("%zu pair, %zu wall contacts at the save\n", part.contact_state(false).owner.size(),
              part.contact_state(true).owner.size());
  CHECK(part.contact_state(false).owner.size() > 100);
  CHECK(part.contact_state(true).owner.size() > 10);
  Simulation copy = restored(part, 3 - threads);  // another thread count: the same bits
  CHECK(identical(copy, part));
  copy.run(after);
  CHECK(identical(copy, whole));
  if (!moving && side * side * layers >= 65536) {
    CHECK(copy.fused_step_count() > 0);
  }
}

void test_bad_state_is_refused() {
  Simulation s(options(1));
  fill(s, 4, 4, true);
  s.run(200);
  Simulation::ContactState pairs = s.contact_state(false);
  pairs.partner.assign(pairs.owner.size(), 0);  // partner below its owner: no such entry
  bool refused = false;
  try {
    Simulation r(options(1));
    fill(r, 4, 4, true);
    r.set_contact_state(pairs, s.contact_state(true));
  } catch (const InvalidArgument&) {
    refused = true;
  }
  CHECK(refused || pairs.owner.empty());
}

// A C++ program saves a run to a stream, loads it into a new Simulation, and both run on: the
// same bits, at another thread count too. Saving the loaded one gives the same bytes.
void test_save_and_load_through_a_stream(int threads) {
  Simulation whole(options(threads)), part(options(threads));
  fill(whole, 8, 12, true);
  fill(part, 8, 12, true);
  PairParams p = part.pair_parameters(0, 1);
  p.friction = 0.8;
  whole.set_pair_parameters(0, 1, p);
  part.set_pair_parameters(0, 1, p);
  whole.run(8000);
  part.run(6000);
  std::stringstream file;
  part.save(file);
  std::printf("%zu spheres, %zu pair and %zu wall contacts: %zu bytes\n", part.size(),
              part.contact_state(false).owner.size(), part.contact_state(true).owner.size(),
              file.str().size());
  CHECK(part.contact_state(false).owner.size() > 50);
  CHECK(part.contact_state(true).owner.size() > 10);
  Simulation copy = Simulation::load(file);
  CHECK(identical(copy, part));
  CHECK(copy.pair_parameters(0, 1).friction == 0.8);
  CHECK(copy.material_count() == 2 && copy.plane_count() == 3);
  std::stringstream again;
  copy.save(again);
  CHECK(again.str() == file.str());
  copy.options().threads = 3 - threads;
  copy.run(2000);
  part.run(2000);
  CHECK(identical(copy, whole));
  CHECK(identical(part, whole));
}

std::string load_error(const std::string& bytes) {
  std::istringstream in(bytes);
  try {
    Simulation::load(in);
  } catch (const InvalidArgument& e) {
    return e.what();
  }
  return "";
}

bool says(const std::string& message, const std::string& what) {
  const bool ok = message.find(what) != std::string::npos;
  if (!ok) std::printf("message \"%s\" does not say \"%s\"\n", message.c_str(), what.c_str());
  return ok;
}

void test_a_damaged_stream_is_refused() {
  Simulation s(options(1));
  fill(s, 4, 4, true);
  s.run(2000);
  std::stringstream file;
  s.save(file);
  const std::string bytes = file.str();
  for (std::size_t keep : {std::size_t(0), std::size_t(5), std::size_t(19), std::size_t(20),
                           std::size_t(100), bytes.size() / 2, bytes.size() - 1})
    CHECK(says(load_error(bytes.substr(0, keep)), "truncated"));
  CHECK(says(load_error(bytes + "x"), "extended"));
  CHECK(says(load_error("[simulation]\ngravity = [0, 0, -9.81]\n"), "not a tsubu checkpoint"));
  std::string newer = bytes;
  newer[8] = static_cast<char>(Simulation::kCheckpointVersion + 1);
  CHECK(says(load_error(newer), "written by a newer tsubu"));
  // Cut inside the last section with the header's length made to agree: the record is named.
  std::string cut = bytes.substr(0, bytes.size() - 30);
  const std::uint64_t length = cut.size() - 20;
  for (int k = 0; k < 8; ++k) cut[12 + k] = static_cast<char>((length >> (8 * k)) & 0xff);
  CHECK(says(load_error(cut), "record 'run' needs"));
  // A record renamed: the reader names what it expected and what it found.
  std::string renamed = bytes;
  const std::size_t at = renamed.find("dissipated");
  CHECK(at != std::string::npos);
  renamed[at] = 'D';
  CHECK(says(load_error(renamed), "section particles: expected record 'dissipated', found 'Dissipated'"));
}

}  // namespace

int main() {
  test_restored_runs_on_bit_for_bit(8, 12, 8000, 2000, 1, true);
  test_restored_runs_on_bit_for_bit(8, 12, 8000, 2000, 2, true);
  test_restored_runs_on_bit_for_bit(41, 40, 300, 20, 2, false);  // 67,240 spheres: fused steps
  test_bad_state_is_refused();
  test_save_and_load_through_a_stream(1);
  test_save_and_load_through_a_stream(2);
  test_a_damaged_stream_is_refused();
  return tsubu_test::finish("test_checkpoint");
}
