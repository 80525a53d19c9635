// tsubu::Simulation: orchestrates the parts of a scene, each a type of its own
// (docs/architecture.md): the Domain, the Particles, the Walls, the NeighborList and the
// ContactStore, with the materials and their pair table, the options, run control, the energy
// audit and checkpoints. The time loop (engine/driver.hpp) sees the parts through a World and
// asks this class, through RunHooks, only for run control, list updates, the audit and errors.
//
// Every accessor speaks in stable ids (the order of addition); arrays are in id order.
#pragma once
#include <array>
#include <atomic>
#include <chrono>
#include <functional>
#include <iosfwd>
#include <string>
#include <utility>
#include <vector>

#include "archive.hpp"
#include "boundary.hpp"
#include "contact_store.hpp"
#include "domain.hpp"
#include "engine/world.hpp"
#include "material.hpp"
#include "memory.hpp"
#include "neighbor_list.hpp"
#include "observables.hpp"
#include "options.hpp"
#include "particles.hpp"
#include "registry.hpp"
#include "state.hpp"
#include "types.hpp"
#include "walls/walls.hpp"

namespace tsubu {

class Simulation : private detail::RunHooks {
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
  // Overlaps are checked when a run starts: at the first run every sphere's, later those of the
  // spheres added or moved (set_positions) and of the walls added since the last run (see
  // run()). check_overlaps = false leaves these spheres out of that check: for a caller that
  // has placed them clear of the others itself (tsubu's inserters, which add spheres during
  // runs).
  Id add_spheres(std::size_t n, const double* positions, const double* radii,
                 const int* materials, const double* velocities = nullptr,
                 const double* angular_velocities = nullptr, bool check_overlaps = true);
  // Capacity for `count` spheres in all, so that adding them in batches does not regrow (and
  // fragment) the particle arrays.
  void reserve(std::size_t count);
  // Removes the spheres with the given ids (C++ only for now). The others keep their ids, their
  // state and their contacts' history; the removed spheres' contacts end (their energy leaves
  // with them). Ids are never reused: arrays in id order then have a row per sphere left, by
  // increasing id (ids need not be 0..N-1). Throws InvalidArgument for an unknown or repeated
  // id, std::logic_error during a run.
  void remove_spheres(std::size_t count, const Id* ids);
  // ---- a rank's part of a decomposed scene (halo.cpp, docs/parallel.md) ---------------------
  // insert/drop: spheres in and out under their global ids, unlogged, contacts carried unless
  // carry is false (the caller sets them); insert's are unchecked unless check. pack/unpack:
  // x, v, w (9 values a sphere) of the ids held. The loop calls the exchange after each particle
  // pass (RunHooks::exchange_ghosts); while one is set, no passes fuse and the audit is off.
  // own_speeds: {max |v|^2, max |v - u|^2 as the particle pass and as Domain::sheared_move find
  // them} over the rank's own spheres (set_own), as one process over all. moved_bounds: the
  // lists' displacement bounds (kept through a rank's changes: it rebuilds where one process does).
  void insert_spheres(std::size_t n, const Id* ids, const double* positions, const double* radii,
                      const int* materials, const double* velocities, const double* angular_velocities,
                      const double* dissipated, bool carry = true, const std::int64_t* images = nullptr,
                      const double* slid = nullptr, bool check = false);
  void drop_spheres(std::size_t count, const Id* ids, bool carry = true);
  std::size_t pack_state(std::size_t n, const Id* ids, double* out, std::int64_t* images = nullptr,
                         double* slid = nullptr) const;  // (images: 3 a sphere, slid: 1, if given)
  std::size_t pack_halo(std::size_t n, const Id* ids, double* out) const;  // (halo.cpp)
  double unpack_halo(std::size_t n, const Id* ids, const double* in);
  using Exchange = std::function<std::array<double, 3>(double vmax2, double rel2)>;
  void set_exchange(Exchange exchange) { exchange_ = std::move(exchange); }
  bool has_exchange() const { return static_cast<bool>(exchange_); }
  void set_own(std::size_t n, const Id* ids);
  std::array<double, 3> own_speeds() const;
  std::array<double, 2> moved_bounds() const { return {lists_.moved, lists_.moved_near}; }
  void set_moved_bounds(double moved, double moved_near) { lists_.moved = moved, lists_.moved_near = moved_near; }
  Id add_sphere(const Vec3& position, double radius, int material,
                const Vec3& velocity = Vec3::Zero(), const Vec3& angular_velocity = Vec3::Zero());
  int add_plane(const Vec3& point, const Vec3& normal, int material,
                const Vec3& velocity = Vec3::Zero(), const Vec3& angular_velocity = Vec3::Zero());
  // A plane that turns about `center` (add_plane: about its point).
  int add_plane(const Vec3& point, const Vec3& normal, int material, const Vec3& velocity,
                const Vec3& angular_velocity, const Vec3& center);
  // A triangle-mesh wall (docs/geometry.md): vertices (world frame) and faces (three vertex
  // indices each), moving as a rigid body with `velocity` and turning with `angular_velocity`
  // about `center`. Throws InvalidArgument naming the triangle for indices out of range, repeated
  // in a face, non-finite coordinates or a degenerate (zero-area) triangle; or for no faces.
  int add_mesh(const std::vector<Vec3>& vertices, const std::vector<Mesh::Face>& faces, int material,
               const Vec3& velocity, const Vec3& angular_velocity, const Vec3& center);
  // Moves a wall's centre of rotation (the wall stays where it is).
  void set_wall_center(int wall, const Vec3& center);

  // ---- a periodic box (domain.hpp, docs/periodic.md) ----------------------------------------
  // Periodic along the axes with periodic[d], between lower and upper; a box with no periodic
  // axis makes the domain open again.
  void set_box(const Vec3& lower, const Vec3& upper, const std::array<bool, 3>& periodic);
  // Lees–Edwards shear at `rate` (1/s): flow along axis `flow`, gradient along `gradient`.
  void set_shear(double rate, int flow, int gradient);
  const Domain& domain() const { return domain_; }
  // Per sphere in id order: the images crossed (3 each), the unwrapped position (3 each).
  void get_images(std::int64_t* out) const;
  void get_unwrapped_positions(double* out) const;
  // A pressure-controlled box (Domain::Servo): the length along `axis` follows `pressure` (Pa,
  // compression positive) at the strain rate gain (P - pressure), capped at max_rate (1/s).
  void set_pressure(double pressure, int axis, double gain, double max_rate);
  void clear_pressure();
  // The normal stress along `axis` (compression positive, Pa): the spheres' kinetic part and
  // their contacts' virial over the box volume, in id order.
  double box_pressure(int axis) const;
  // Takes a wall out: from the next run on it touches nothing; its contacts end (their energy
  // leaves with them); other walls keep their indices.
  void remove_wall(int wall);
  // Drives a wall by a target force (a servo wall, Walls::Servo): each step its velocity is
  // direction * gain * (force - F), at most max_speed, F the force its contacts put on the
  // spheres along direction (unit after normalising). A servo wall does not turn. Throws
  // InvalidArgument for a zero or non-finite direction, a negative or non-finite force, gain or
  // max_speed (max_speed also at most kMaxWallSpeed).
  void set_wall_servo(int wall, const Vec3& direction, double force, double gain, double max_speed);
  void clear_wall_servo(int wall);
  const Walls& walls() const { return walls_; }
  // The force each wall receives from the spheres (minus the sum of its contacts' forces on
  // them) and its torque about the wall's centre, as the last step evaluated them: row w for
  // wall w (zero for a removed wall).
  void wall_loads(std::vector<Vec3>& forces, std::vector<Vec3>& torques) const;
  // A wall's velocity must be finite and at most kMaxWallSpeed (InvalidArgument); a wall that
  // rotates is checked when a run starts, where the spheres are (check_wall_speeds).
  void set_plane_motion(int wall, const Vec3& velocity, const Vec3& angular_velocity);
  // Whether a sphere's near triangles of a flat sheet of a mesh stand as one near-wall entry
  // (NeighborList::wall_sheet; the same bits either way: a testing aid). Default true.
  bool mesh_sheets() const { return sheets_; }
  void set_mesh_sheets(bool on) { sheets_ = on, lists_.valid = false; }
  // How many flat sheets the near-wall list holds now.
  std::size_t mesh_sheet_count() const {
    return lists_.wall_sheet.empty() ? 0 : lists_.sheet_offset.size() - 1;
  }
  // The lists' sizes now: Verlet pairs, near pairs, the walls' reach entries, near-wall entries
  // (those with contact state), busy particles (a diagnostic for benchmarks and tests: how many
  // entries a step scans against how many touch).
  std::array<std::size_t, 5> list_sizes() const {
    return {lists_.pair_partner.size(), lists_.near_partner.size(), lists_.wall_reach_index.size(),
            lists_.wall_index.size(), lists_.busy.size()};
  }
  // The speed of light [m/s]: no wall of a Newtonian scene moves faster, and far beyond it the
  // contacts' products overflow doubles (a wall sliding at 1e150 m/s lost its friction).
  static constexpr double kMaxWallSpeed = 299792458.0;
  const Plane& plane(int wall) const;
  int plane_count() const { return walls_.count(); }
  Options& options() { return opt_; }
  const Options& options() const { return opt_; }

  // ---- grains as boundaries (boundary.hpp, docs/boundaries.md) -------------------------------
  // Fixes the spheres with the given ids: from now on each moves with its velocity and spin
  // (3 values per id each; zero: glued), whatever the forces and gravity, and has infinite mass
  // to the others (a contact with it takes the free sphere's mass, as a wall contact does).
  // Fixing a fixed sphere again sets its motion anew. Throws InvalidArgument for an unknown or
  // repeated id or a motion that is not finite or faster than kMaxWallSpeed; std::logic_error
  // during a run.
  void fix_spheres(std::size_t count, const Id* ids, const double* velocities,
                   const double* angular_velocities);
  // Frees them again (a free sphere listed is ignored): they keep their velocity and spin.
  void free_spheres(std::size_t count, const Id* ids);
  const FixedSpheres& fixed_spheres() const { return fixed_; }
  // Whether each sphere is fixed (1) or free (0), in id order.
  void get_fixed(std::uint8_t* out) const;
  // Each sphere's id, in id order (the rows of the arrays in id order).
  void get_ids(Id* out) const;
  // Adds an outlet (boundary.hpp: a plane or a box; its normal is normalised here). Spheres it
  // takes are removed at the end of the step where their centre is found beyond it, and logged
  // (removed()). Returns its index. InvalidArgument for a non-finite point or a zero normal, or a
  // box with lo > hi.
  int add_outlet(const Outlet& outlet);
  const std::vector<Outlet>& outlets() const { return outlets_; }
  // Every sphere removed so far, by an outlet or by remove_spheres.
  const RemovalLog& removed() const { return removed_; }
  void set_removed(RemovalLog log) { removed_ = std::move(log); }  // (a decomposed scene gathered)

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
  // The most a step may move a sphere [m] and still let the overlap check see two spheres that
  // meet head on: a + b - min(max_overlap, 1) a for the two smallest radii a <= b (infinite
  // with fewer than two spheres). A run stops after a step that moved a sphere further.
  double max_move() const;
  // Runs `steps` steps and returns how many it took: all of them, unless a stop was requested
  // (request_stop(), or `should_stop` returning true). A stopped run returns at a step boundary,
  // after the step in progress, and leaves the state of that step (positions, velocities, spins,
  // contact history, step_count(), time() agree); a later run continues from it bit for bit as
  // if the run had not stopped. `should_stop`, if given, is called on the running thread
  // between two steps, at most once every `poll_seconds` of wall time (the Python binding checks
  // for Ctrl-C with it); it must not throw nor touch this Simulation.
  // With fixed walls the energy balance is audited every kEnergyCheck-th step and, if `audit`,
  // when the run ends (audit_run_end); a caller that cuts one run into stretches passes false
  // and calls audit_run_end after the last, so that the audit's cost (a pass over the spheres
  // and the near entries) is paid once. A step that moved a sphere further than max_move()
  // stops the run before the next step moves anything (InstabilityError, docs/physics.md).
  // A Simulation is used by one thread at a time, but for request_stop(), running(),
  // step_count() and time(): a run started while another thread's run of it is in progress
  // throws std::logic_error.
  // Before its first step a run refuses (InvalidArgument, "initial overlap: ...") overlaps
  // beyond options().initial_overlap of the smaller radius: at the first run between any
  // spheres and walls; at a later run those that involve a sphere added or moved, or a wall
  // added, since the last run, unless the change did not deepen them (a pack moved as a whole
  // keeps its contacts). A refused run takes no step, and is refused again until the overlap is
  // gone (or initial_overlap raised).
  long run(long steps, const std::function<bool()>& should_stop = {}, double poll_seconds = 0.02,
           bool audit = true);
  // The energy audit now, as a run does (check_energy): InstabilityError if the balance grew
  // since the reference the last run started from. Returns at once when there is nothing to
  // check (no run yet, walls moving, the state, gravity or pairs changed since).
  void audit_energy();
  // The audit of the end of a run that started at step `start`: audit_energy() if the run
  // passed a multiple of kRunEndAudit steps (and did not end on one of kEnergyCheck, which the
  // loop audited). So a short run that blew up is caught when it returns, and a loop of
  // one-step runs pays for one audit (about the cost of a step) per kRunEndAudit steps; the
  // rule depends on step numbers only, so a run resumed from a checkpoint is audited at the
  // same steps as the run that was not interrupted.
  void audit_run_end(long start);
  static constexpr long kRunEndAudit = 100;
  // What run() does before its first step, now: check the options and dt, mix the pair table,
  // select the law, build the neighbour lists if they are due, check the overlaps and the
  // walls' speeds. Raises what a run would raise before stepping; a run after it starts the
  // same (the Python layer calls it to look at the lists before a long run).
  void prepare_run();
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
  // Steps taken and simulated time [s]. Readable from any thread, also while another thread
  // runs: during a run they are those of a step completed (the loop publishes them between
  // steps, with relaxed atomic stores).
  long step_count() const noexcept { return shown_.step.load(std::memory_order_relaxed); }
  double time() const noexcept { return shown_.time.load(std::memory_order_relaxed); }
  std::string law_name() const;  // the compiled specialisation the next run uses
  // Threads a run of this scene uses: 1 below options().parallel_min spheres (or without
  // OpenMP), else options().threads or OpenMP's default.
  int threads_used() const {
    return static_cast<int>(particles_.size()) < opt_.parallel_min ? 1 : threads();
  }

  // ---- state, in id order ------------------------------------------------------------------
  std::size_t size() const { return particles_.size(); }
  // (In a periodic box, positions and velocities as wrapped into it.)
  void get_positions(double* out) const { gather_wrapped(out, nullptr); }
  void get_velocities(double* out) const { gather_wrapped(nullptr, out); }
  void get_angular_velocities(double* out) const {
    particles_.gather(particles_.arrays().w.data(), out);
  }
  void get_forces(double* out) const;   // contact forces + m g of the last step
  void get_torques(double* out) const;  // contact torques of the last step
  void get_radii(double* out) const;
  void get_masses(double* out) const;
  void get_materials(int* out) const;
  void set_positions(const double* in);
  void set_velocities(const double* in) {
    particles_.scatter(in, particles_.arrays().v.data());
    energy_ref_valid_ = false;
    run_.last_move = 0;
  }
  void set_angular_velocities(const double* in) {
    particles_.scatter(in, particles_.arrays().w.data());
    energy_ref_valid_ = false;
  }

  Energy energy(bool share = false) const;  // share: a rank's (set_own; energy.cpp)
  // energy() with the elastic part at the current positions (energy() takes it from the last
  // force evaluation, a step behind the kinetic and gravitational parts), with the step
  // correction: the balance a stability check should compare.
  Energy energy_now() const;
  std::vector<ContactInfo> contacts() const;

  // ---- checkpoints (checkpoint.cpp, docs/checkpoints.md) -------------------------------------
  // The whole state of the scene as bytes: options, materials and pair overrides, spheres in id
  // order, walls, every touching contact keyed by ids, the run's counters and energy
  // bookkeeping. A Simulation made by load() from them continues bit for bit as this one would
  // have, for any thread count (set options().threads after loading to change it). Diagnostics
  // (rebuild_count(), phase_seconds(), fused_step_count()) start from zero.
  //
  // The stream: 8 bytes kCheckpointMagic, the format version (4 bytes, little-endian), the
  // length of what follows (8 bytes), then the parts' sections (archive.hpp). load() refuses a
  // stream of another magic or version, a truncated one and inconsistent contents with an
  // InvalidArgument that says which (and returns no Simulation).
  static constexpr std::uint32_t kCheckpointVersion = 2;
  static constexpr char kCheckpointMagic[9] = "\x89TSUBUc\n";
  void save(std::ostream& out) const;
  static Simulation load(std::istream& in);

  // The pieces save() and load() write and read as sections, which the format-1 reader (tsubu's
  // Python layer) restores one by one. What a checkpoint needs beyond the public setters: the counters and energy bookkeeping of
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
    // What the next run checks for overlaps (see run()): the spheres added or moved since the
    // last run, by id, with their centres then (3 each; NaN for a sphere added since), and the
    // number of walls added since (the last ones). Saved only when not empty.
    std::vector<Id> unchecked;
    std::vector<double> unchecked_from;
    int unchecked_walls = 0;
    void save(archive::Writer& w) const;
    void restore(archive::Reader& r);
  };
  RunState run_state() const;
  void set_run_state(const RunState& s);
  // The touching contacts of one kind (pairs: owner id, partner id; walls: sphere id, wall
  // index), each with the carried arrays of EntryStore in its order, `widths[k]` values each.
  struct ContactState {
    std::vector<Id> owner, partner;
    std::vector<Index> element;  // walls: each contact's element (empty: all 0, planes)
    std::array<std::vector<double>, EntryStore::kFields> values;
    std::array<int, EntryStore::kFields> widths{};
    void save(archive::Writer& w) const;
    void restore(archive::Reader& r);
  };
  ContactState contact_state(bool walls) const;
  // Builds the lists and puts the saved state into them; throws InvalidArgument if a contact
  // names no sphere or wall, or if the widths are not those of the scene's law.
  void set_contact_state(const ContactState& pairs, const ContactState& walls, bool wrap = true);
  void get_dissipated(double* out) const;
  void set_dissipated(const double* in);
  // A wall's whole state, bit for bit (add_plane normalises the normal; this does not).
  void set_plane_state(int wall, const Plane& p);

  // ---- neighbour list ----------------------------------------------------------------------
  void rebuild_neighbors();
  // Pairs in the current list (ids, lower first): all pairs within r_i + r_j + skin.
  std::vector<std::array<Id, 2>> neighbor_pairs() const;
  long rebuild_count() const { return lists_.rebuilds; }
  std::size_t neighbor_pair_count() const { return lists_.pair_partner.size(); }  // (the Verlet list's)
  long near_refresh_count() const { return lists_.refreshes; }
  double near_reach() const { return lists_.near_skin(); }  // (m; NeighborList::near_fraction)
  // Steps whose particle pass also evaluated the next step's contacts (step.hpp, fused_pass).
  long fused_step_count() const { return run_.fused_steps; }
  // Bytes held by the engine's arrays (their capacity), by group: particles, verlet list, near
  // list (with the contact state), walls, scratch (kept for the next rebuild).
  std::vector<std::pair<std::string, std::size_t>> memory_bytes() const;
  // Seconds spent per phase of the loop since construction (see Phase).
  const std::array<double, int(Phase::Count)>& phase_seconds() const { return run_.phase_seconds; }
  // How the step's parallel regions used their threads since construction (see Region).
  const std::array<RegionTimes, int(Region::Count)>& region_seconds() const { return run_.regions; }
  double skin() const;

  // ---- stress (stress.cpp, docs/stress.md) -------------------------------------------------
  // The mean flow the kinetic part of the stress subtracts: u[flow] = rate (x[gradient] -
  // reference), the other components 0 (Lees–Edwards: the box's rate and axes, reference its
  // centre along the gradient).
  struct MeanFlow {
    double rate = 0;  // 1/s
    int flow = 0, gradient = 2;
    double reference = 0;  // m
  };
  // The Love–Weber Cauchy stress of the owned spheres in `volume` (m^3), tension positive:
  //   sigma = (1/V) sum_i [ -m_i v'_i (x) v'_i + sum_{c of i} (x_c - x_i) (x) f_c ],
  // v' = v - u(x), f_c the contact forces of the last step (forces()), x_c each contact's point
  // (a pair's splits the branch vector x_i - x_j at c_i / (c_i + c_j), c = r - overlap / 2, the
  // law's lever; a wall's is ContactInfo::wall_point). Row-major 3x3 into `sigma` (9 values);
  // `per_particle` (may be null): each sphere's bracket, sigma V, in N m, 9 values per sphere
  // in id order, which sum (in id order) to sigma V. The same bits for any thread
  // count. Throws InvalidArgument for a volume that is not finite and positive or bad axes.
  void stress(double volume, const MeanFlow& flow, double* sigma, double* per_particle = nullptr) const;

 private:
  // ---- RunHooks: what the loop asks between passes (engine/world.hpp) -----------------------
  // Whether the run must end before its next step: a stop was requested, or the poll (called
  // when its interval has passed by `now`) asked for one, which is then kept as a request.
  bool stop_due(std::chrono::steady_clock::time_point now) override {
    publish();  // (called between every two steps)
    if (poll_ && now >= next_poll_) {
      next_poll_ = now + poll_every_;
      if ((*poll_)()) request_stop();
    }
    return stop_.on.load(std::memory_order_relaxed);
  }
  void update_lists() override;
  // The energy balance the audit compares with is taken when a run starts after anything that
  // changes the scene's energy from outside (state set, spheres or walls added, a wall set
  // moving, gravity or pair parameters changed), so that chunked runs are checked as one.
  void start_audit(bool walls_move) override;
  // (A removal during the run leaves the reference invalid: the audit then takes it anew.)
  void audit() override {
    if (exchange_) return;
    if (!energy_ref_valid_) return start_audit(false);
    check_energy(energy_ref_);
  }
  void steer_walls() override;
  void steer_box() override;
  [[noreturn]] void report_overlap(double dt) const override;
  [[noreturn]] void report_nonfinite() const override;
  [[noreturn]] void report_nonfinite_velocity() const override;
  [[noreturn]] void report_fast(double max_move) const override;
  void remove_outgoing() override;
  void exchange_ghosts(double& vmax2, double& rel2, double& most) override {
    const std::array<double, 3> all = exchange_(vmax2, rel2);
    vmax2 = all[0], rel2 = all[1], most = domain_.sheared() ? all[2] : -1.0;
  }
  Exchange exchange_;
  std::vector<char> own_;  // (set_own: by id)
  // remove_spheres without the checks of the ids and of a run, logging the spheres removed by
  // outlet `outlet[k]` (-1: by remove_spheres).
  void remove_now(std::size_t count, const Id* ids, const int* outlet, bool log = true, bool carry = true);
  // `what`'s check of a list of ids: not during a run, each held, none twice (InvalidArgument).
  void require_held(const char* what, std::size_t count, const Id* ids) const;
  void reset_lists();  // empty lists (the spheres' indices changed), their counters kept
  // A moving wall faster than light (kMaxWallSpeed) where a sphere is: InvalidArgument.
  void check_wall_speeds() const;

  // The parts as the loop and the lists see them.
  detail::World world();
  NeighborList::Context list_context();

  template <class Out>
  void for_each_contact_sum(Out&& out) const;
  // The compiled law of the scene now, and the entry shapes it needs.
  void select_law();
  void mix_pairs();
  // Refuses (InvalidArgument) overlaps beyond options().initial_overlap: all of them (at the
  // first run), or those the changes since the last run made (unchecked_, walls_checked_).
  // Needs the lists of the current positions.
  void check_overlaps(bool all) const;
  // Records that the sphere at index i is about to move (or was just added: added = true), for
  // the overlap check of the next run.
  void mark_unchecked(Index i, bool added);
  // The compiled law this scene's pairs and options select (contact/selection.hpp).
  LawKey law_key() const;
  // Raises InstabilityError if the energy balance (mechanical + dissipated, energy_now()) grew
  // since `start` by more than a third of the energy dissipated meanwhile plus twice the kinetic +
  // elastic energy.
  void check_energy(const Energy& start) const;
  // energy() without the elastic part: the spheres' kinetic, gravitational and dissipated sums.
  Energy sphere_energy(bool share = false) const;
  int threads() const;
  template <class F>
  void for_each_contact_type(F&& f) const;
  // Calls f(entry's PairParams, i, partner j or -1, wall or -1, overlap now, r_eff, normal n,
  // relative velocity at the centres, the spins' lever part, entry index, is_wall) for every
  // near entry in contact at the current positions (energy_now()).
  template <class F>
  void for_each_touching_now(F&& f) const;

  Options opt_;
  std::vector<Material> materials_;
  PairTable pairs_;
  std::vector<std::array<int, 3>> overrides_key_;
  std::vector<PairParams> overrides_;

  // The parts.
  Domain domain_;
  // Positions and/or velocities in id order, wrapped into a periodic box.
  void gather_wrapped(double* x, double* v) const;
  // Refuses a periodic length below twice the neighbour reach (at run start).
  void check_box() const;
  // Checkpoints of a periodic box: the box, the shear, each sphere's images and slide, and the
  // lists' moved bounds (so that a resumed run wraps at the steps the first would have).
  void save_periodic(archive::Writer& w) const;
  void restore_periodic(archive::Reader& r);
  Particles particles_;
  Walls walls_;
  // With meshes: every near-wall entry's plane at the current positions (wall_planes_now()).
  mutable std::vector<Plane> wall_planes_;
  std::vector<double> servo_push_;  // steer_walls' scratch
  mutable std::vector<Index> wall_entries_;
  // The plane each near-wall entry's contact is on now, by entry (a plane wall's own, a mesh
  // contact's tangent plane, hidden ones clear of the sphere: Walls::measure).
  const Plane& wall_plane_now(Index e) const {
    return walls_.has_meshes() ? wall_planes_[std::size_t(e)] : walls_.plane(lists_.wall_index[std::size_t(e)]);
  }
  // A near-wall entry's contact point: the point of its plane now nearest sphere i's centre
  // (ContactInfo::wall_point, the stress' x_c; after measure_walls_now).
  Vec3 wall_point_now(Index i, Index e) const {
    const Plane& P = wall_plane_now(e);
    const Vec3 x = vec3(particles_.arrays().x.data(), i);
    return x - P.distance(x) * P.normal;
  }
  // Measures them (with meshes only) at the positions x (3 N, internal order; default the
  // spheres'); call before wall_plane_now.
  void measure_walls_now(const double* x = nullptr) const;
  NeighborList lists_;
  ContactStore contacts_;

  int sphere_material_ = -1;  // the one material of all spheres, else -1 (set when a run starts)
  double speed_fixed_ = 0;  // the default characteristic speed, fixed at the first run; 0: not yet

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

  // Run state.
  RunCounters run_;
  // run_.step and run_.time as published for other threads (step_count(), time()): between the
  // steps of a run, when it returns, and when the run state is set.
  struct Shown {
    std::atomic<long> step{0};
    std::atomic<double> time{0};
    Shown() = default;
    Shown(const Shown& o) { *this = o; }
    Shown& operator=(const Shown& o) {
      step.store(o.step.load(std::memory_order_relaxed), std::memory_order_relaxed);
      time.store(o.time.load(std::memory_order_relaxed), std::memory_order_relaxed);
      return *this;
    }
  };
  static_assert(std::atomic<long>::is_always_lock_free && std::atomic<double>::is_always_lock_free,
                "step_count() and time() are read while a run writes them");
  Shown shown_;
  void publish() noexcept {
    shown_.step.store(run_.step, std::memory_order_relaxed);
    shown_.time.store(run_.time, std::memory_order_relaxed);
  }
  bool ran_ = false;
  bool sheets_ = true;  // (mesh_sheets)
  // The changes the next run checks for overlaps (check_overlaps), made after the first run:
  // the spheres added or moved, by id, with their centres at the last check (3 each, NaN for a
  // sphere added since), whether an id is listed (by id; empty while none is), and the number
  // of walls at the last check.
  std::vector<Id> unchecked_;
  std::vector<double> unchecked_from_;
  std::vector<char> unchecked_listed_;
  int walls_checked_ = 0;
  const CompiledLaw* law_ = nullptr;  // the law of the last run (prepare_run)
  // The law of the last run, or, before any, the one the scene selects now.
  const CompiledLaw& law() const { return law_ ? *law_ : find_law(law_key()); }
  Energy energy_ref_;
  bool energy_ref_valid_ = false;
  long energy_ref_step_ = 0;
  Vec3 energy_ref_gravity_ = Vec3::Zero();
  double max_move_ = 0;  // max_move(), taken when a run starts

  // Grains as boundaries.
  FixedSpheres fixed_;
  std::vector<Outlet> outlets_;
  RemovalLog removed_;
  // The checkpoint section of the three (checkpoint.cpp; absent when all are empty).
  void save_boundaries(archive::Writer& w) const;
  void restore_boundaries(archive::Reader& r);
};

}  // namespace tsubu
