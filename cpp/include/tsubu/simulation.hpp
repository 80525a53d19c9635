// tsubu::Simulation: rigid spheres, plane walls, materials, and the time loop.
//
// Particles are stored as structure-of-arrays in an internal order that is re-sorted by cell at
// every neighbour rebuild; every accessor speaks in stable ids (the order of addition).
#pragma once
#include <array>
#include <atomic>
#include <chrono>
#include <functional>
#include <string>
#include <utility>
#include <vector>

#include "box.hpp"
#include "material.hpp"
#include "memory.hpp"
#include "options.hpp"
#include "registry.hpp"
#include "state.hpp"
#include "types.hpp"
#include "walls/plane.hpp"

namespace tsubu {

struct Energy {
  double translational = 0, rotational = 0, gravitational = 0, elastic = 0, dissipated = 0;
  // Symplectic Euler conserves, for linear springs, not total() but total() + step_correction:
  // (dt/2) sum v.F over gravity and the normal springs (forces of the positions), minus the same
  // over the tangential springs (forces of this step's displacement, one velocity later).
  // Filled by energy_now() only.
  double step_correction = 0;
  double kinetic() const { return translational + rotational; }
  // Mechanical energy; with fixed walls, total() + dissipated stays constant.
  double total() const { return translational + rotational + gravitational + elastic; }
};

// One current contact, as evaluated at the start of the last step.
struct ContactInfo {
  Id i;           // particle id
  Id j;           // partner particle id, or -1 for a wall
  int wall;       // wall index, or -1 for a particle pair
  double overlap; // m
  Vec3 force;     // total contact force on i, N
  Vec3 torque_i;  // torque on i from this contact, N m
  Vec3 tangential_displacement;  // stored history xi, m (zero without friction)
  double reduced_radius;  // R* = r_i r_j / (r_i + r_j); a wall: r_i
  double contact_radius;  // a = sqrt(R* delta) as the Mindlin history keeps it; 0 otherwise
};

// Wall-clock time spent in each phase of the loop, summed over runs (for benchmarks).
enum class Phase { Neighbors = 0, Contacts, Integrate, Count };
const char* phase_name(Phase p);

namespace detail {
template <class Law>
struct Stepper;
struct ContactSums;
struct ContactView;
struct ParticleView;
}

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

class Simulation {
 public:
  explicit Simulation(const Options& options = Options());

  // ---- set-up ------------------------------------------------------------------------------
  int add_material(const Material& m);
  const Material& material(int index) const;
  int material_count() const { return static_cast<int>(materials_.size()); }
  // Overrides the mixed parameters of one pair of materials (both orders).
  void set_pair_parameters(int a, int b, const PairParams& p);
  PairParams pair_parameters(int a, int b) const;

  // Adds n spheres (positions, velocities, angular velocities: 3n values; radii, materials: n).
  // velocities / angular_velocities may be null (zero). Returns the id of the first.
  Id add_spheres(std::size_t n, const double* positions, const double* radii,
                 const int* materials, const double* velocities = nullptr,
                 const double* angular_velocities = nullptr);
  // Capacity for `count` spheres in all, so that adding them in batches does not regrow (and
  // fragment) the particle arrays.
  void reserve(std::size_t count);
  Id add_sphere(const Vec3& position, double radius, int material,
                const Vec3& velocity = Vec3::Zero(), const Vec3& angular_velocity = Vec3::Zero());
  int add_plane(const Vec3& point, const Vec3& normal, int material,
                const Vec3& velocity = Vec3::Zero(), const Vec3& angular_velocity = Vec3::Zero());
  void set_plane_motion(int wall, const Vec3& velocity, const Vec3& angular_velocity);
  const Plane& plane(int wall) const;
  int plane_count() const { return static_cast<int>(planes_.size()); }

  Options& options() { return opt_; }
  const Options& options() const { return opt_; }

  // ---- time stepping -----------------------------------------------------------------------
  // The stability bound of symplectic Euler, (2.31) with spring and dashpot taken together:
  // min over the scene's contact types of 4m / (eta + sqrt(eta^2 + 4 k m)), with the reduced
  // mass of the lightest pair (walls: the lightest particle), for the normal spring and, with
  // friction, the tangential spring (which acts on m/3.5 for a sphere that can roll).
  // For a Hertzian scene, each bound is taken at the stiffest overlap of a head-on impact at
  // characteristic_speed().
  double critical_time_step() const;
  // Shortest contact duration over the scene's contact types: t_c = pi/alpha (B.3, B.5) for the
  // linear law; Hertz's t_c = 2.87 (m*^2 / (R* E*^2 v))^(1/5) at characteristic_speed().
  double contact_duration() const;
  // t_c / 50: contacts resolved by 50 steps; a Hertzian scene also keeps dt <= 0.2 x
  // rayleigh_time() (the usual bound of Hertzian DEM codes, rarely the smaller).
  double default_time_step() const;
  // The shortest Rayleigh time pi r sqrt(rho/G) / (0.1631 nu + 0.8766) over the scene's Hertzian
  // spheres (the smallest sphere of each material); infinity if it has none.
  double rayleigh_time() const;
  // The normal impact speed a Hertzian scene's bounds are taken at: options().impact_speed, or
  // twice the largest sphere speed (two spheres meeting head on), at least 1 m/s, taken at the
  // first run after spheres were last added and kept from then on (so that the default dt does
  // not change from one run to the next).
  double characteristic_speed() const;
  // Whether the scene's materials are Hertzian (given a Young's modulus); raises if it mixes
  // them with linear ones.
  bool hertzian() const;
  // The step a run uses: options().dt, or default_time_step() when that is 0.
  double time_step() const;
  // Runs `steps` steps and returns how many it took: all of them, unless a stop was requested
  // (request_stop(), or `should_stop` returning true). A stopped run returns at a step boundary,
  // after the step in progress, and leaves the state of that step (positions, velocities, spins,
  // contact history, step_count(), time() agree); a later run continues from it bit for bit as
  // if the run had not stopped. `should_stop`, if given, is called on the running thread
  // between two steps, at most once every `poll_seconds` of wall time (the Python binding checks
  // for Ctrl-C with it); it must not throw nor touch this Simulation.
  // A Simulation is used by one thread at a time, but for request_stop() and running(): a run
  // started while another thread's run of it is in progress throws std::logic_error.
  long run(long steps, const std::function<bool()>& should_stop = {}, double poll_seconds = 0.02);
  // Asks the run in progress to return after its current step (see run()). Thread-safe and
  // async-signal-safe (one lock-free atomic store): callable from another thread or a signal
  // handler. The request stays until a run stops on it (or throws): one made while no run is in
  // progress, or too late for the run in progress to see it (during its last step), stops the
  // next run before its first step.
  void request_stop() noexcept { stop_.on.store(true, std::memory_order_relaxed); }
  // Whether the last run returned before taking all its steps because a stop was requested.
  bool stopped() const { return stopped_; }
  // Whether a run is in progress (in any thread).
  bool running() const noexcept { return running_.on.load(std::memory_order_acquire); }
  long step_count() const { return step_; }
  double time() const { return time_; }
  std::string law_name() const;  // the compiled specialisation the next run uses
  // Threads a run of this scene uses: 1 below options().parallel_min spheres (or without
  // OpenMP), else options().threads or OpenMP's default.
  int threads_used() const { return static_cast<int>(n_) < opt_.parallel_min ? 1 : threads(); }

  // ---- state, in id order ------------------------------------------------------------------
  std::size_t size() const { return n_; }
  void get_positions(double* out) const { gather_by_id(particles_.x.data(), out); }
  void get_velocities(double* out) const { gather_by_id(particles_.v.data(), out); }
  void get_angular_velocities(double* out) const { gather_by_id(particles_.w.data(), out); }
  void get_forces(double* out) const;   // contact forces + m g of the last step
  void get_torques(double* out) const;  // contact torques of the last step
  void get_radii(double* out) const;
  void get_masses(double* out) const;
  void get_materials(int* out) const;
  void set_positions(const double* in);
  void set_velocities(const double* in) {
    scatter_by_id(in, particles_.v.data());
    energy_ref_valid_ = false;
  }
  void set_angular_velocities(const double* in) {
    scatter_by_id(in, particles_.w.data());
    energy_ref_valid_ = false;
  }

  Energy energy() const;
  // energy() with the elastic part at the current positions (energy() takes it from the last
  // force evaluation, a step behind the kinetic and gravitational parts), with the step
  // correction: the balance a stability check should compare.
  Energy energy_now() const;
  std::vector<ContactInfo> contacts() const;

  // ---- checkpoints (checkpoint.cpp) ----------------------------------------------------------
  // What a checkpoint needs beyond the public setters: the counters and energy bookkeeping of
  // the run, each sphere's dissipated energy, and the state of every touching contact keyed by
  // ids. Restored onto a Simulation set up with the same materials, pair parameters, options,
  // spheres (in id order) and walls, a run continues bit for bit as the saved one would have:
  // results do not depend on the particles' internal order nor on the lists' schedule.
  struct RunState {
    long step = 0;
    double time = 0;
    bool ran = false;
    double speed_fixed = 0;
    Energy energy_ref;
    bool energy_ref_valid = false;
    long energy_ref_step = 0;
    Vec3 energy_ref_gravity = Vec3::Zero();
  };
  RunState run_state() const;
  void set_run_state(const RunState& s);
  // The touching contacts of one kind (pairs: owner id, partner id; walls: sphere id, wall
  // index), each with the carried arrays of EntryStore in its order, `widths[k]` values each.
  struct ContactState {
    std::vector<Id> owner, partner;
    std::array<std::vector<double>, EntryStore::kFields> values;
    std::array<int, EntryStore::kFields> widths{};
  };
  ContactState contact_state(bool walls) const;
  // Builds the lists and puts the saved state into them; throws InvalidArgument if a contact
  // names no sphere or wall, or if the widths are not those of the scene's law.
  void set_contact_state(const ContactState& pairs, const ContactState& walls);
  void get_dissipated(double* out) const;
  void set_dissipated(const double* in);
  // A wall's whole state, bit for bit (add_plane normalises the normal; this does not).
  void set_plane_state(int wall, const Plane& p);

  // ---- neighbour list ----------------------------------------------------------------------
  void rebuild_neighbors();
  // Pairs in the current list (ids, lower first): all pairs within r_i + r_j + skin.
  std::vector<std::array<Id, 2>> neighbor_pairs() const;
  long rebuild_count() const { return rebuilds_; }
  long near_refresh_count() const { return refreshes_; }
  // Steps whose particle pass also evaluated the next step's contacts (step.hpp, fused_pass).
  long fused_step_count() const { return fused_steps_; }
  // Bytes held by the engine's arrays (their capacity), by group: particles, verlet list, near
  // list (with the contact state), walls, scratch (kept for the next rebuild).
  std::vector<std::pair<std::string, std::size_t>> memory_bytes() const;
  // Seconds spent per phase of the loop since construction (see Phase).
  const std::array<double, int(Phase::Count)>& phase_seconds() const { return phase_seconds_; }
  double skin() const;

 private:
  template <class Law>
  friend struct detail::Stepper;
  friend struct detail::ContactSums;
  friend struct detail::ContactView;
  friend struct detail::ParticleView;

  void gather_by_id(const double* src, double* out) const;
  template <class Out>
  void for_each_contact_sum(Out&& out) const;
  void scatter_by_id(const double* in, double* dst);
  void prepare_run();
  // The compiled law of the scene now, and the entry shapes it needs.
  void select_law();
  void mix_pairs();
  void check_initial_overlaps() const;
  bool needs_rebuild() const;
  void move_planes(double dt);
  // The compiled law this scene's pairs and options select (registry.hpp).
  LawKey law_key() const;
  bool walls_move() const;
  [[noreturn]] void report_overlap(double dt) const;
  [[noreturn]] void report_nonfinite() const;
  [[noreturn]] void report_nonfinite_velocity() const;
  // Raises InstabilityError if the energy balance (mechanical + dissipated, energy_now()) grew
  // since `start` by more than half the energy dissipated meanwhile plus twice the kinetic +
  // elastic energy.
  // Every kEnergyCheck-th step (counted over all runs) of a scene with fixed walls.
  static constexpr long kEnergyCheck = 1000;
  void check_energy(const Energy& start) const;
  int threads() const;
  template <class F>
  void for_each_contact_type(F&& f) const;

  Options opt_;
  std::vector<Material> materials_;
  PairTable pairs_;
  std::vector<std::array<int, 3>> overrides_key_;
  std::vector<PairParams> overrides_;
  std::vector<Plane> planes_;

  Box box_;

  // Particles (internal order).
  std::size_t n_ = 0;
  ParticleStore particles_;
  int sphere_material_ = -1;  // the one material of all spheres, else -1 (set when a run starts)
  Array<Index> index_of_;  // id -> internal index

  // Two-level neighbour list (docs/architecture.md). The Verlet list holds every pair within
  // r_i + r_j + skin, each once, owned by the lower id, an owner's partners sorted by id. The
  // near list, refreshed from it when particles may have moved by a tenth of the skin, holds
  // the pairs within r_i + r_j + skin/10 and all contact state; the step loop touches only it.
  // Its entries keep the owner order and the partner-id order of the Verlet list, and a reverse
  // index sorted by owner id lets every particle sum its contacts in an order fixed by ids:
  // bit-identical results for any thread count and any rebuild schedule.
  Array<Index> pair_offset_, pair_partner_;
  Array<Index> near_offset_, near_owner_, near_partner_, near_rev_offset_, near_rev_;
  Array<double> near_cut2_;  // (r_i + r_j)^2
  // The law's terms of each near pair (ContactLaw::entry_terms, CompiledLaw::entry_width per
  // entry: for the linear law the dashpot itself; for Hertz sqrt(R*) and the dashpot's mass
  // term), fixed while the pair is in the list: square roots saved per contact and step.
  Array<double> near_entry_;
  double speed_ = 1;  // characteristic_speed() when the run started
  double speed_fixed_ = 0;  // the default characteristic speed, fixed at the first run; 0: not yet
  // Particles with near-pair or near-wall entries: the only ones whose contacts can be summed;
  // and, per step, 1 for those with an entry in contact (set by the contact pass, cleared by
  // the particle pass).
  Array<Index> busy_;
  Array<std::uint8_t> loaded_;
  // Every busy particle's entries in the order its sums take them (ContactSums::at), flat, so
  // the particle pass of a dense scene sums them in one loop without a branch per particle:
  // (entry << 3) | (first of its particle << 2) | kind (0 owned pair, 1 reverse pair, 2 wall);
  // sum_offset_[b] is busy particle b's first. Empty if an entry index does not fit.
  Array<std::uint32_t> sum_entry_;
  Array<Index> sum_offset_;
  // For the fused pass (step.hpp): how far down and up the particle array a near pair's partner
  // lies from its owner (index distances, at most), and the most entries one particle sums.
  Index near_reach_below_ = 0, near_reach_above_ = 0, max_entries_ = 0;
  // Near-wall list: (particle, wall) entries within r + skin, by particle; they hold the wall
  // contact state. The step loop reads the subset within r + skin/10 (all of them if a wall
  // moves), refreshed with the near list: wall_near_ (entry indices, by particle).
  Array<Index> wall_offset_, wall_index_, wall_owner_, wall_near_offset_, wall_near_;
  // Per-entry contact state: history (tangential displacement), overlap, and the results of the
  // last evaluation (force on the owner, n x F_t, rolling vector), roughness; zero while not
  // touching. Arrays a law does not use are empty (shape_).
  EntryStore pair_state_, wall_state_;
  EntryShape pair_shape_, wall_shape_;
  // Neighbour-list bookkeeping: bounds on the distance any particle moved since the last Verlet
  // rebuild and since the last near-list refresh (sums of dt max|v| over the steps).
  bool list_valid_ = false;
  double list_skin_ = 0;
  double moved_ = 0, moved_near_ = 0;
  std::vector<Vec3> plane_point_ref_, plane_normal_ref_;
  double plane_reach_ = 0;           // max distance from a plane's point to the particles
  long rebuilds_ = 0, refreshes_ = 0, fused_steps_ = 0;
  std::array<double, int(Phase::Count)> phase_seconds_{};
  // Scratch reused by rebuilds and steps (no allocation once warm).
  Array<Index> cell_start_, cell_of_, perm_, old_index_of_, active_;
  // The cell grid of a rebuild (neighbor.cpp): dense (every cell of the particles' bounding box,
  // cell c = (z dims_y + y) dims_x + x) when that is at most 2 N + 1000 cells, else sparse: only
  // the occupied cells, by their sorted (z, y, x) keys in cell_key_, so that spheres kilometres
  // apart cost memory in proportion to N, not to the volume they span.
  struct CellGrid {
    Vec3 lo = Vec3::Zero(), hi = Vec3::Zero();  // the particles' bounding box
    double h = 1;                                // cell side
    std::array<long, 3> dims{1, 1, 1};
    bool sparse = false;
  };
  using CellKey = std::array<std::int64_t, 3>;
  Array<CellKey> cell_key_;
  Array<Index> old_near_offset_, old_wall_offset_, old_wall_index_;
  Array<Id> old_near_partner_id_;
  // Per-entry state carried across refreshes (EntryStore::carried). The near list's is stashed
  // compactly (touching entries only, rows by owner in old_near_offset_), the walls' whole.
  static constexpr std::size_t kEntryArrays = EntryStore::kFields;
  std::array<Array<double>, kEntryArrays> old_pair_state_, old_wall_state_;
  Array<std::uint8_t> old_touch_;
  Array<double> scratch_;
  Array<int> scratch_int_;

  // Run control. The flags are read and set across threads (request_stop, running); a copy of
  // a Simulation starts with them clear.
  struct Flag {
    std::atomic<bool> on{false};
    Flag() = default;
    Flag(const Flag&) {}
    Flag& operator=(const Flag&) { return *this; }
  };
  static_assert(std::atomic<bool>::is_always_lock_free, "request_stop() must be signal-safe");
  Flag stop_, running_;
  bool stopped_ = false;
  const std::function<bool()>* poll_ = nullptr;  // run()'s should_stop, while it runs
  std::chrono::steady_clock::duration poll_every_{};
  std::chrono::steady_clock::time_point next_poll_;
  // Whether the run must end before its next step: a stop was requested, or the poll (called
  // when its interval has passed by `now`) asked for one, which is then kept as a request.
  bool stop_due(std::chrono::steady_clock::time_point now) {
    if (poll_ && now >= next_poll_) {
      next_poll_ = now + poll_every_;
      if ((*poll_)()) request_stop();
    }
    return stop_.on.load(std::memory_order_relaxed);
  }

  // Run state.
  long step_ = 0;
  double time_ = 0;
  bool ran_ = false;
  double dt_ = 0;
  const CompiledLaw* law_ = nullptr;  // the law of the last run (prepare_run)
  // The law of the last run, or, before any, the one the scene selects now.
  const CompiledLaw& law() const { return law_ ? *law_ : find_law(law_key()); }
  // The energy balance the check compares with: taken when a run starts after anything that
  // changes the scene's energy from outside (state set, spheres or walls added, a wall set
  // moving, gravity or pair parameters changed), so that chunked runs are checked as one.
  Energy energy_ref_;
  bool energy_ref_valid_ = false;
  long energy_ref_step_ = 0;
  Vec3 energy_ref_gravity_ = Vec3::Zero();

  // The rebuild and the near-list refresh (neighbor.cpp).
  void rebuild(bool keep_history);
  bool needs_refresh() const { return 2.0 * moved_near_ > near_skin(); }
  double near_skin() const { return 0.1 * list_skin_; }
  // Moves the near list and its state aside, the partners as ids (before a re-sort).
  void stash_near();
  // Builds the near list from the Verlet list; with `transfer`, carries the stashed state over
  // by (owner id, partner id); `reordered`: the particles were re-sorted since the stash.
  // A touching entry that does not carry over (its spheres jumped apart by more than the skin
  // in one step) has opened: its spring energy is booked as lost, as the step would have.
  void refresh_near(bool transfer, bool reordered);
  // sum_entry_ and sum_offset_ from the near list, the reverse index and the near-wall list.
  void build_sum_entries();
  // near_reach_below_, near_reach_above_ and max_entries_ from the near lists.
  void measure_near();
  // near_entry_ from the current pair table (after a refresh, or when parameters change).
  void cache_near_terms();
  // The energy a contact loses when it opens (its tangential spring; the engine releases).
  double spring_energy(int material_a, int material_b, const Array<double>& xi,
                       std::size_t e) const;
  // The key under which a near-wall entry's state is found again after a rebuild (walls: the
  // entries' wall indices, the current list's or the stashed one's).
  static WallKey wall_key(const Array<Index>& walls, Index entry) { return {walls[entry], 0}; }
  void size_entry_buffers();
  CellGrid plan_grid(double skin) const;
  CellKey cell_of(const CellGrid& g, const double* x) const;
  // Bins the particles (cell_of_, cell_start_, perm_) without moving them.
  void bin_by_cell(const CellGrid& g);
  // Throws ResourceError, before the rebuild changes anything, when the Verlet list the grid
  // would give cannot fit in memory (or in its 32-bit indices).
  void check_list_fits(const CellGrid& g, double skin) const;
  double list_bytes_per_pair() const;
  // Applies perm_: the particles in cell order.
  void sort_by_cell();
};

namespace detail {

// The contact force and torque on one particle, summed from the per-entry results in an order
// fixed by ids: its walls, the entries it owns (partners by id), the entries it is the partner
// of (owners by id). The step loop and the accessors share it, so get_forces() returns the
// forces the last step used, bit for bit.
struct ContactSums {
  const Index *woff, *wnear, *noff, *roff, *rev;
  const double *r, *wf, *wn, *wr, *wo, *pf, *pn, *pr, *po;

  explicit ContactSums(const Simulation& s)
      : woff(s.wall_near_offset_.data()), wnear(s.wall_near_.data()),
        noff(s.near_offset_.data()), roff(s.near_rev_offset_.data()), rev(s.near_rev_.data()),
        r(s.particles_.radius.data()), wf(s.wall_state_.force.data()),
        wn(s.wall_state_.nxft.data()), wr(s.wall_state_.roll.data()),
        wo(s.wall_state_.overlap.data()), pf(s.pair_state_.force.data()),
        pn(s.pair_state_.nxft.data()), pr(s.pair_state_.roll.data()),
        po(s.pair_state_.overlap.data()) {}

  // Requests particle k's offsets and velocities ahead of at(k).
  void prefetch(Index k, const double* v, const double* w) const {
    __builtin_prefetch(woff + k);
    __builtin_prefetch(noff + k);
    __builtin_prefetch(roff + k);
    __builtin_prefetch(v + 3 * k, 1);
    __builtin_prefetch(w + 3 * k, 1);
  }

  // kWallLever: walls store n x F_t; kPairLever: pairs store n x F; kRolling: rolling vectors.
  template <bool kWallLever, bool kPairLever, bool kRolling>
  void at(Index k, Vec3& F, Vec3& T) const {
    const double rk = r[k];
    for (Index p = woff[k]; p < woff[k + 1]; ++p) {
      const Index e = wnear[p];
      F += vec3(wf, e);
      if constexpr (kWallLever) T -= contact_lever(rk, wo[e]) * vec3(wn, e);  // (1.19)
      if constexpr (kRolling) T += rk * vec3(wr, e);                     // (1.20)
    }
    for (Index q = noff[k]; q < noff[k + 1]; ++q) {
      F += vec3(pf, q);
      if constexpr (kPairLever) T -= contact_lever(rk, po[q]) * vec3(pn, q);
      if constexpr (kRolling) T += rk * vec3(pr, q);
    }
    for (Index p = roff[k]; p < roff[k + 1]; ++p) {
      const Index q = rev[p];
      F -= vec3(pf, q);
      if constexpr (kPairLever) T -= contact_lever(rk, po[q]) * vec3(pn, q);
      if constexpr (kRolling) T -= rk * vec3(pr, q);
    }
  }
};

}  // namespace detail

}  // namespace tsubu
