// Tests of stopping a run early (Simulation::request_stop, run's should_stop): a stopped run
// ends at a step boundary with the state of its last step, and running the remaining steps
// gives the bits of the run that was never stopped, in a scene large enough to fuse steps.
// Also: one run at a time per Simulation.
#include <atomic>
#include <chrono>
#include <csignal>
#include <random>
#include <stdexcept>
#include <thread>
#include <vector>

#include "check.hpp"
#include "tsubu/simulation.hpp"

using namespace tsubu;

namespace {

// 67,600 frictional spheres of two sizes on a lattice with gaps, random velocities and spins,
// in a box of five fixed walls: 2^16 spheres or more with fixed walls, so runs fuse steps
// (engine/driver.hpp), and contacts with tangential history form within tens of steps.
Simulation lattice(int threads) {
  Options o;
  o.threads = threads;
  o.dt = 1e-6;
  o.skin = 0.3e-3;
  Simulation s(o);
  Material grain, stiff;
  grain.restitution = 0.5;
  grain.friction = 0.5;
  stiff.kn = 2e3;
  stiff.restitution = 0.7;
  stiff.friction = 0.3;
  const int g = s.add_material(grain), h = s.add_material(stiff);
  const int side = 26, layers = 100;
  const double spacing = 1.02e-3;
  std::mt19937_64 rng(5);
  std::uniform_real_distribution<double> radius(0.42e-3, 0.50e-3);
  std::normal_distribution<double> speed(0.0, 0.3), spin(0.0, 100.0);
  s.reserve(std::size_t(side) * side * layers);
  for (int i = 0; i < side; ++i)
    for (int j = 0; j < side; ++j)
      for (int k = 0; k < layers; ++k) {
        const Vec3 v(speed(rng), speed(rng), speed(rng)), w(spin(rng), spin(rng), spin(rng));
        s.add_sphere((Vec3(i, j, k) + Vec3::Constant(0.5)) * spacing, radius(rng),
                     i % 3 == 0 ? h : g, v, w);
      }
  s.add_plane(Vec3::Zero(), Vec3(0, 0, 1), h);
  for (int axis = 0; axis < 2; ++axis) {
    const Vec3 n = Vec3::Unit(axis);
    s.add_plane(Vec3::Zero(), n, g);
    s.add_plane(side * spacing * n, -n, h);
  }
  return s;
}

struct Snapshot {
  long step;
  double time;
  std::vector<double> x, v, w;
  std::vector<ContactInfo> contacts;
};

Snapshot snapshot(const Simulation& s) {
  Snapshot a{s.step_count(), s.time(), std::vector<double>(3 * s.size()),
             std::vector<double>(3 * s.size()), std::vector<double>(3 * s.size()), s.contacts()};
  s.get_positions(a.x.data());
  s.get_velocities(a.v.data());
  s.get_angular_velocities(a.w.data());
  return a;
}

bool same_vec(const Vec3& a, const Vec3& b) { return a == b; }

// Bit for bit: step counter, time, positions, velocities, spins, every contact with its history.
bool identical(const Snapshot& a, const Snapshot& b) {
  if (a.step != b.step || a.time != b.time || a.x != b.x || a.v != b.v || a.w != b.w ||
      a.contacts.size() != b.contacts.size())
    return false;
  for (std::size_t k = 0; k < a.contacts.size(); ++k) {
    const ContactInfo &p = a.contacts[k], &q = b.contacts[k];
    if (p.i != q.i || p.j != q.j || p.wall != q.wall || p.overlap != q.overlap ||
        !same_vec(p.force, q.force) || !same_vec(p.torque_i, q.torque_i) ||
        !same_vec(p.tangential_displacement, q.tangential_displacement))
      return false;
  }
  return true;
}

const long kSteps = 40;

// Stops at the n-th poll (polled at every chance: poll_seconds = 0); in this scene's fused
// stretch the polls come where the loop decides to fuse a step, so the stop has to turn a
// step that would have been fused into the run's last, two-pass step.
void test_stop_then_continue_is_bit_identical(const Snapshot& whole, int threads) {
  for (const int n : {2, 8, 25}) {
    Simulation s = lattice(threads);
    int polls = 0;
    const long taken = s.run(kSteps, [&] { return ++polls == n; }, 0.0);
    CHECK(taken > 0 && taken < kSteps);
    CHECK(s.stopped());
    CHECK(s.step_count() == taken);
    CHECK(!s.running());
    const Snapshot stopped = snapshot(s);
    if (n > 2) CHECK(s.fused_step_count() > 0);  // it stopped inside the fused stretch
    // The state is that of the step the run ended on: the same as a run of that many steps.
    Simulation short_run = lattice(threads);
    CHECK(short_run.run(taken) == taken);
    CHECK(identical(stopped, snapshot(short_run)));
    CHECK(s.run(kSteps - taken) == kSteps - taken);
    CHECK(!s.stopped());
    CHECK(identical(snapshot(s), whole));
  }
}

// request_stop() from another thread while the run is in progress, which that thread watches
// through step_count() and time() (readable during a run: those of a completed step).
void test_request_stop_from_another_thread(const Snapshot& whole) {
  Simulation s = lattice(2);
  std::vector<std::pair<long, double>> seen;
  std::thread stopper([&s, &seen] {
    while (!s.running()) std::this_thread::yield();
    const auto until = std::chrono::steady_clock::now() + std::chrono::seconds(20);
    while ((seen.empty() || seen.back().first < 2) && std::chrono::steady_clock::now() < until) {
      seen.emplace_back(s.step_count(), s.time());
      std::this_thread::sleep_for(std::chrono::milliseconds(1));
    }
    s.request_stop();
  });
  const long taken = s.run(100 * kSteps);
  stopper.join();
  CHECK(s.stopped());
  CHECK(taken < 100 * kSteps);
  CHECK(s.step_count() == taken);
  CHECK(!seen.empty() && seen.back().first >= 2 && seen.back().first <= taken);
  for (std::size_t k = 1; k < seen.size(); ++k)
    CHECK(seen[k].first >= seen[k - 1].first && seen[k].second >= seen[k - 1].second);
  if (taken <= kSteps) {
    s.run(kSteps - taken);
    CHECK(identical(snapshot(s), whole));
  }
}

// The signal-handler path: a handler that only calls request_stop().
Simulation* g_signalled = nullptr;
extern "C" void stop_on_signal(int) { g_signalled->request_stop(); }

void test_request_stop_from_a_signal_handler() {
  Simulation s = lattice(1);
  g_signalled = &s;
  const auto previous = std::signal(SIGINT, stop_on_signal);
  std::thread sender([&s] {
    while (!s.running()) std::this_thread::yield();
    std::this_thread::sleep_for(std::chrono::milliseconds(30));
    std::raise(SIGINT);  // the handler runs on this thread
  });
  const long taken = s.run(100 * kSteps);
  sender.join();
  std::signal(SIGINT, previous);
  CHECK(s.stopped());
  CHECK(taken < 100 * kSteps && s.step_count() == taken);
}

void test_pending_request_and_concurrent_runs() {
  Simulation s = lattice(1);
  // A request made between runs stops the next one before its first step (a run of no steps
  // leaves it), and is then gone.
  s.request_stop();
  CHECK(s.run(0) == 0);
  CHECK(!s.stopped());
  CHECK(s.run(5) == 0);
  CHECK(s.stopped() && s.step_count() == 0);
  CHECK(s.run(2) == 2);
  CHECK(!s.stopped() && s.step_count() == 2);
  // A second run of the same Simulation while one is in progress is refused.
  std::atomic<bool> refused{false};
  std::thread runner([&s] { s.run(100 * kSteps); });
  while (!s.running()) std::this_thread::yield();
  try {
    s.run(1);
  } catch (const std::logic_error&) {
    refused = true;
  }
  s.request_stop();
  runner.join();
  CHECK(refused);
  CHECK(s.stopped() && !s.running());
  CHECK(s.step_count() >= 2 && s.step_count() < 2 + 100 * kSteps);
}

}  // namespace

int main() {
  Simulation reference = lattice(1);
  reference.run(kSteps);
  CHECK(reference.fused_step_count() > kSteps / 2);  // the scene exercises the fused pass
  const Snapshot whole = snapshot(reference);
  bool history = false;
  for (const ContactInfo& c : whole.contacts) history |= c.tangential_displacement.norm() > 0;
  CHECK(history);
  test_stop_then_continue_is_bit_identical(whole, 1);
  test_stop_then_continue_is_bit_identical(whole, 2);
  test_request_stop_from_another_thread(whole);
  test_request_stop_from_a_signal_handler();
  test_pending_request_and_concurrent_runs();
  return tsubu_test::finish("test_stop");
}
