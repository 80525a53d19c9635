// What one run of the loop works on: the parts of the scene (particles, walls, neighbour lists,
// contact state, domain, pair table, options), the run's counters, and the hooks through which
// the loop asks its orchestrator (the Simulation) for what is not the loop's business: whether
// to stop, when to rebuild the lists, the energy audit, and the error reports. The engine sees
// only this; it never includes simulation.hpp.
#pragma once
#include <array>
#include <chrono>

#include "../boundary.hpp"
#include "../contact_store.hpp"
#include "../domain.hpp"
#include "../material.hpp"
#include "../neighbor_list.hpp"
#include "../options.hpp"
#include "../particles.hpp"
#include "../walls/walls.hpp"
#include "balance.hpp"

namespace tsubu {

// Wall-clock time spent in each phase of the loop, summed over runs (for benchmarks).
enum class Phase { Neighbors = 0, Contacts, Integrate, Count };
const char* phase_name(Phase p);

// Adds the time since the previous lap to the named phase (steady clock, ~20 ns a lap).
class PhaseTimer {
 public:
  explicit PhaseTimer(std::array<double, int(Phase::Count)>& sums)
      : sums_(sums), last_(std::chrono::steady_clock::now()) {}
  void lap(Phase p) {
    const auto now = std::chrono::steady_clock::now();
    sums_[int(p)] += std::chrono::duration<double>(now - last_).count();
    last_ = now;
  }
  std::chrono::steady_clock::time_point last() const { return last_; }

 private:
  std::array<double, int(Phase::Count)>& sums_;
  std::chrono::steady_clock::time_point last_;
};

// How the step's parallel regions spent their threads, per kind of region (benchmarks/scaling.py):
// `wall`, the regions' time as the calling thread saw it; `slowest` and `mean`, the sums over
// regions of the busiest thread's and of the average thread's working time. wall - slowest is
// the cost of starting, joining and synchronising the team; slowest - mean, the imbalance.
enum class Region { Contacts = 0, Particles, Fused, Count };
struct RegionTimes {
  double wall = 0, slowest = 0, mean = 0;  // s
  long count = 0;                          // regions timed
};
const char* region_name(Region r);

// The counters of the run: where it stands, its step, and what it measured.
struct RunCounters {
  long step = 0;
  double time = 0;  // s
  double dt = 0;    // s: the step of the run in progress (or the last)
  double speed = 1;  // the characteristic impact speed when the run started, m/s
  long fused_steps = 0;  // steps whose particle pass also evaluated the next step's contacts
  // dt max|v| of the last step [m]: the farthest any sphere moved in it; 0 when not known (no
  // step yet, or the spheres' state was set since). The next step checks it against
  // World::max_move.
  double last_move = 0;
  std::array<double, int(Phase::Count)> phase_seconds{};
  std::array<RegionTimes, int(Region::Count)> regions{};
  detail::Balance balance;  // the threads' parts of the particles (balance.hpp)
};

namespace detail {

// The energy balance is audited every kEnergyCheck-th step (counted over all runs) of a scene
// with fixed walls, and when a run ends (Simulation::run, audit_energy).
constexpr long kEnergyCheck = 1000;

// What the loop asks of its orchestrator between passes.
class RunHooks {
 public:
  // Whether the run must end before its next step (a stop was requested, or the poll asked).
  virtual bool stop_due(std::chrono::steady_clock::time_point now) = 0;
  // Rebuilds or refreshes the neighbour lists if one is due.
  virtual void update_lists() = 0;
  // The energy audit: a run starts (with fixed or moving walls), a check is due.
  virtual void start_audit(bool walls_move) = 0;
  virtual void audit() = 0;
  // Sets the velocity of each servo wall from the force its contacts just put on it.
  virtual void steer_walls() = 0;
  // A pressure-controlled periodic box: stretches it toward its target stress (after a step).
  virtual void steer_box() {}
  // Raise InstabilityError naming the step and the particle.
  [[noreturn]] virtual void report_overlap(double dt) const = 0;
  [[noreturn]] virtual void report_nonfinite() const = 0;
  [[noreturn]] virtual void report_nonfinite_velocity() const = 0;
  // The last step moved a sphere further than World::max_move (RunCounters::last_move).
  [[noreturn]] virtual void report_fast(double max_move) const = 0;
  // At the end of a step of a scene with outlets (World::outlets): removes the spheres they
  // take (docs/boundaries.md).
  virtual void remove_outgoing() {}
  // After a step's particle pass (and the fixed spheres' motion) in a decomposed scene
  // (World::exchange): the halo's spheres take their owners' state, and the step's max |v|^2
  // (`vmax2`), max |v - u|^2 as the pass finds it (`rel2`) and as Domain::sheared_move does
  // (`most`, set >= 0 in a streaming box) become those of the whole scene, which the lists book.
  virtual void exchange_ghosts(double& /*vmax2*/, double& /*rel2*/, double& /*most*/) {}

 protected:
  ~RunHooks() = default;
};

struct World {
  Particles& particles;
  Walls& walls;
  NeighborList& lists;
  ContactStore& contacts;
  Domain& domain;
  const PairTable& pairs;
  const Options& options;
  RunCounters& run;
  RunHooks& hooks;
  int sphere_material;  // the one material of all spheres, else -1
  int threads;          // threads of the parallel passes (1 below options.parallel_min spheres)
  double max_move;      // m: the most a step may move a sphere (Simulation::max_move)
  FixedSpheres* fixed = nullptr;  // the fixed spheres; null when there are none
  bool outlets = false;           // whether the scene has outlets (RunHooks::remove_outgoing)
  bool exchange = false;          // a rank of a decomposed scene (RunHooks::exchange_ghosts)

  // A Lees–Edwards box without walls: the lists bound the spheres' motion relative to the mean
  // flow (Domain::sheared_bound).
  bool streaming() const { return domain.sheared() && walls.count() == 0; }
};

}  // namespace detail
}  // namespace tsubu
