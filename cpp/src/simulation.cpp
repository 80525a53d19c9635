#include "tsubu/simulation.hpp"

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <sstream>
#include <type_traits>

#include "tsubu/registry.hpp"
#include "check.hpp"
#include "tsubu/contact/selection.hpp"

#ifdef TSUBU_HAVE_OPENMP
#include <omp.h>
#endif

namespace tsubu {

using detail::finite3;
using detail::fmt;
using detail::require;

Simulation::Simulation(const Options& options) : opt_(options) {}

const char* phase_name(Phase p) {
  static const char* names[] = {"neighbors", "contacts", "integrate"};
  return names[int(p)];
}

const char* region_name(Region r) {
  static const char* names[] = {"contacts", "particles", "fused"};
  return names[int(r)];
}

int Simulation::threads() const {
#ifdef TSUBU_HAVE_OPENMP
  return opt_.threads > 0 ? opt_.threads : omp_get_max_threads();
#else
  return 1;
#endif
}

// ---- materials ------------------------------------------------------------------------------

int Simulation::add_material(const Material& m) {
  validate_material(m);
  materials_.push_back(m);
  return static_cast<int>(materials_.size()) - 1;
}

const Material& Simulation::material(int index) const {
  require(index >= 0 && index < material_count(),
          [&] { return "no material " + std::to_string(index); });
  return materials_[index];
}

void Simulation::set_pair_parameters(int a, int b, const PairParams& p) {
  energy_ref_valid_ = false;
  material(a);
  material(b);
  validate_pair(p);
  require(laws::hertzian(p) == laws::hertzian(pair_parameters(a, b)),
          "a pair's override keeps its materials' law: effective_modulus > 0 exactly when both "
          "materials are Hertzian");
  PairParams q = p;
  q.finalise();
  for (std::size_t k = 0; k < overrides_key_.size(); ++k) {
    const auto& key = overrides_key_[k];
    if ((key[0] == a && key[1] == b) || (key[0] == b && key[1] == a)) {
      overrides_[k] = q;
      return;
    }
  }
  overrides_key_.push_back({a, b, 0});
  overrides_.push_back(q);
}

PairParams Simulation::pair_parameters(int a, int b) const {
  PairParams p;
  bool found = false;
  for (std::size_t k = 0; k < overrides_key_.size() && !found; ++k) {
    const auto& key = overrides_key_[k];
    if ((key[0] == a && key[1] == b) || (key[0] == b && key[1] == a)) p = overrides_[k], found = true;
  }
  if (!found) p = mix(material(a), material(b));
  laws::apply_options(p, opt_);  // e.g. the scene's choice of a clipped Hertzian force
  return p;
}

void Simulation::mix_pairs() {
  const std::size_t nm = materials_.size();
  pairs_.resize(nm);
  for (std::size_t a = 0; a < nm; ++a)
    for (std::size_t b = a; b < nm; ++b) {
      const PairParams p = pair_parameters(static_cast<int>(a), static_cast<int>(b));
      const double limit = RoughnessParams::limit(p.roughness_distribution);
      require(p.roughness < limit,
              "materials " + std::to_string(a) + " and " + std::to_string(b) +
                  " mix to a roughness of " + fmt(p.roughness * 180 / M_PI) +
                  " degrees, beyond the " + fmt(limit * 180 / M_PI) +
                  " degrees its distribution allows; set the pair's roughness with set_pair");
      pairs_.set(a, b, p);
    }
}

// ---- particles and walls ----------------------------------------------------------------------

namespace {

std::string wall_too_fast(double speed) {
  return "a wall's velocity of " + fmt(speed) + " m/s is faster than light (" +
         fmt(Simulation::kMaxWallSpeed) +
         " m/s): no wall of a Newtonian scene moves so fast, and far beyond it the contact forces "
         "overflow doubles; check the units of the velocity";
}

}  // namespace

Id Simulation::add_spheres(std::size_t n, const double* positions, const double* radii,
                           const int* materials, const double* velocities,
                           const double* angular_velocities, bool check_overlaps) {
  for (std::size_t k = 0; k < n; ++k) {
    require(finite3(positions + 3 * k),
            [&] { return "position of sphere " + std::to_string(k) + " is not finite"; });
    require(radii[k] > 0 && std::isfinite(radii[k]), [&] {
      return "radius of sphere " + std::to_string(k) + " must be > 0, got " + fmt(radii[k]);
    });
    material(materials[k]);
    if (velocities)
      require(finite3(velocities + 3 * k),
              [&] { return "velocity of sphere " + std::to_string(k) + " is not finite"; });
    if (angular_velocities)
      require(finite3(angular_velocities + 3 * k), [&] {
        return "angular velocity of sphere " + std::to_string(k) + " is not finite";
      });
  }
  domain_.clear_ghosts();  // (Particles::add drops their rows; the next rebuild makes them)
  const Id first = particles_.add(n, positions, radii, materials, velocities, angular_velocities, materials_);
  if (ran_ && check_overlaps)  // (the first run checks every sphere)
    for (std::size_t k = 0; k < n; ++k) mark_unchecked(particles_.index(first + static_cast<Id>(k)), true);
  lists_.valid = false;
  energy_ref_valid_ = false;
  run_.last_move = 0;
  speed_fixed_ = 0;  // taken again at the next run
  return first;
}

void Simulation::reserve(std::size_t count) { particles_.reserve(count); }

void Simulation::remove_spheres(std::size_t count, const Id* ids) {
  require_held("remove_spheres", count, ids);
  if (count == 0) return;
  const std::vector<int> by_hand(count, -1);
  remove_now(count, ids, by_hand.data());
}

Id Simulation::add_sphere(const Vec3& position, double radius, int material,
                          const Vec3& velocity, const Vec3& angular_velocity) {
  return add_spheres(1, position.data(), &radius, &material, velocity.data(),
                     angular_velocity.data());
}

int Simulation::add_plane(const Vec3& point, const Vec3& normal, int material_index,
                          const Vec3& velocity, const Vec3& angular_velocity) {
  return add_plane(point, normal, material_index, velocity, angular_velocity, point);
}

int Simulation::add_plane(const Vec3& point, const Vec3& normal, int material_index,
                          const Vec3& velocity, const Vec3& angular_velocity, const Vec3& center) {
  energy_ref_valid_ = false;
  require(point.allFinite(), "plane point is not finite");
  require(center.allFinite(), "plane center is not finite");
  require(normal.allFinite() && normal.norm() > 0, "plane normal must be a non-zero finite vector");
  require(velocity.allFinite() && angular_velocity.allFinite(), "plane motion is not finite");
  require(velocity.norm() <= kMaxWallSpeed, [&] { return wall_too_fast(velocity.norm()); });
  material(material_index);
  Plane p;
  p.point = point;
  p.normal = normal.normalized();
  p.velocity = velocity;
  p.angular_velocity = angular_velocity;
  p.center = center;
  p.material = material_index;
  const int index = walls_.add(p);
  lists_.valid = false;
  return index;
}

int Simulation::add_mesh(const std::vector<Vec3>& vertices, const std::vector<Mesh::Face>& faces,
                         int material_index, const Vec3& velocity, const Vec3& angular_velocity,
                         const Vec3& center) {
  require(!faces.empty(), "a mesh needs at least one triangle");
  for (std::size_t v = 0; v < vertices.size(); ++v)
    require(vertices[v].allFinite(), [&] { return "mesh vertex " + std::to_string(v) + " is not finite"; });
  const Index nv = static_cast<Index>(vertices.size());
  for (std::size_t t = 0; t < faces.size(); ++t) {
    const Mesh::Face& f = faces[t];
    for (Index k : f)
      require(k >= 0 && k < nv, [&] {
        return "mesh triangle " + std::to_string(t) + " names vertex " + std::to_string(k) + "; there are " +
               std::to_string(nv);
      });
    const Vec3 &a = vertices[std::size_t(f[0])], &b = vertices[std::size_t(f[1])], &c = vertices[std::size_t(f[2])];
    const double longest = std::max({(b - a).squaredNorm(), (c - b).squaredNorm(), (a - c).squaredNorm()});
    require(f[0] != f[1] && f[1] != f[2] && f[0] != f[2] && (b - a).cross(c - a).norm() > 1e-12 * longest &&
                longest > 0,
            [&] { return "mesh triangle " + std::to_string(t) + " is degenerate (no area)"; });
  }
  require(center.allFinite(), "mesh center is not finite");
  require(velocity.allFinite() && angular_velocity.allFinite(), "mesh motion is not finite");
  require(velocity.norm() <= kMaxWallSpeed, [&] { return wall_too_fast(velocity.norm()); });
  material(material_index);
  energy_ref_valid_ = false;
  Plane motion;
  motion.velocity = velocity;
  motion.angular_velocity = angular_velocity;
  motion.material = material_index;
  const int index = walls_.add_mesh(Mesh(vertices, faces, center), motion);
  lists_.valid = false;
  return index;
}

void Simulation::set_wall_center(int wall, const Vec3& center) {
  require(wall >= 0 && wall < plane_count(), "no wall " + std::to_string(wall));
  require(center.allFinite(), "wall center is not finite");
  energy_ref_valid_ = false;
  walls_.set_center(wall, center);
  lists_.valid = false;
}

void Simulation::set_wall_servo(int wall, const Vec3& direction, double force, double gain, double max_speed) {
  require(wall >= 0 && wall < plane_count(), "no wall " + std::to_string(wall));
  require(direction.allFinite() && direction.norm() > 0, "servo direction must be a non-zero finite vector");
  require(std::isfinite(force) && force >= 0, "servo force must be finite and >= 0, got " + fmt(force));
  require(std::isfinite(gain) && gain > 0, "servo gain must be finite and > 0, got " + fmt(gain));
  require(std::isfinite(max_speed) && max_speed > 0 && max_speed <= kMaxWallSpeed,
          "servo max_speed must be > 0 and at most the speed of light, got " + fmt(max_speed));
  energy_ref_valid_ = false;
  walls_.set_servo(wall, Walls::Servo{direction.normalized(), force, gain, max_speed, true});
  walls_.set_motion(wall, Vec3::Zero(), Vec3::Zero());
  lists_.valid = false;
}

void Simulation::clear_wall_servo(int wall) {
  require(wall >= 0 && wall < plane_count(), "no wall " + std::to_string(wall));
  walls_.set_servo(wall, Walls::Servo{});
  walls_.set_motion(wall, Vec3::Zero(), walls_.plane(wall).angular_velocity);
  lists_.valid = false;
}

void Simulation::steer_walls() {
  // The force each servo wall's contacts put on the spheres: its near entries in list order
  // (the same for any thread count).
  const std::size_t nw = static_cast<std::size_t>(walls_.count());
  servo_push_.assign(nw, 0.0);
  for (Index e : lists_.wall_near) {
    const std::size_t w = std::size_t(lists_.wall_index[std::size_t(e)]);
    if (walls_.servo(int(w)).on) servo_push_[w] += vec3(contacts_.walls.force.data(), e).dot(walls_.servo(int(w)).direction);
  }
  for (std::size_t w = 0; w < nw; ++w) {
    const Walls::Servo& s = walls_.servo(int(w));
    if (!s.on || walls_.removed(int(w))) continue;
    const double speed = std::clamp(s.gain * (s.force - servo_push_[w]), -s.max_speed, s.max_speed);
    walls_.set_motion(int(w), speed * s.direction, Vec3::Zero());
  }
}

void Simulation::remove_wall(int wall) {
  require(wall >= 0 && wall < plane_count(), "no wall " + std::to_string(wall));
  energy_ref_valid_ = false;
  walls_.remove(wall);
  lists_.valid = false;
}

void Simulation::set_plane_motion(int wall, const Vec3& velocity, const Vec3& angular_velocity) {
  energy_ref_valid_ = false;
  require(wall >= 0 && wall < plane_count(), "no wall " + std::to_string(wall));
  require(velocity.allFinite() && angular_velocity.allFinite(), "plane motion is not finite");
  require(velocity.norm() <= kMaxWallSpeed, [&] { return wall_too_fast(velocity.norm()); });
  walls_.set_motion(wall, velocity, angular_velocity);
  lists_.valid = false;  // the rebuild criterion now accounts for this wall's motion
}

const Plane& Simulation::plane(int wall) const {
  require(wall >= 0 && wall < plane_count(), "no wall " + std::to_string(wall));
  return walls_.plane(wall);
}
std::string Simulation::law_name() const {
  return find_law(law_key()).name() + (walls_.moving() ? "+moving-walls" : "");
}

void Simulation::prepare_run() {
  validate_options(opt_);
  mix_pairs();
  // The default speed is taken once, at the first run after spheres were added: a scene's
  // default dt must not change between runs, or splitting a run would change its result.
  if (!(opt_.impact_speed > 0) && !(speed_fixed_ > 0)) speed_fixed_ = characteristic_speed();
  run_.speed = characteristic_speed();
  run_.dt = time_step();
  require(std::isfinite(run_.dt) && run_.dt > 0, [&] {
    return particles_.size() == 0 || materials_.empty()
               ? std::string("no time step: the scene has no possible contact to derive one from; set dt")
               : "no time step: the default dt (contact duration / 50) is " + fmt(run_.dt) +
                     " s for this scene (an overdamped restitution near 0, or stiffnesses, masses or "
                     "impact_speed beyond what doubles resolve, leave no finite contact duration); set dt";
  });
  const double crit = critical_time_step();
  if (run_.dt > crit && !opt_.allow_unstable_dt)
    throw InvalidArgument("dt = " + fmt(run_.dt) + " s exceeds the stability bound " + fmt(crit) +
                          " s of (2.31) for this scene; use a smaller dt or allow_unstable_dt");
  select_law();
  if (law_->sticky) {  // a touching contact must stay in the near list: r_i + r_j + skin/10
    double rmax = 0, sep = 0;
    for (std::size_t k = 0; k < particles_.size(); ++k) rmax = std::max(rmax, particles_.arrays().radius[k]);
    for (std::size_t a = 0; a < materials_.size(); ++a)
      for (std::size_t b = a; b < materials_.size(); ++b)
        sep = std::max(sep, law_->separation(pair_parameters(int(a), int(b)), rmax));
    require(sep < 0.1 * skin(), [&] {
      return "the contacts of this scene's law " + law_->name() + " hold to a separation of " +
             fmt(sep) + " m, beyond the near list's reach skin/10 = " + fmt(0.1 * skin()) +
             " m: give a skin above " + fmt(10 * sep) + " m";
    });
  }
  check_wall_speeds();
  check_box();
  if (law_->sticky && !lists_.wall_sheet.empty()) lists_.valid = false;  // (sheets: a law that lets go at 0)
  if (!lists_.valid) lists_.rebuild(list_context(), skin(), true);
  // (velocities may have been set since: the ghosts follow)
  domain_.update_ghosts(particles_.arrays(), particles_.size());
  contacts_.size(lists_.near_partner.size(), lists_.wall_index.size());
  max_move_ = max_move();
  lists_.cache_terms(list_context());  // the pair table may have changed since the last run
  lists_.reset_clearance();  // (and the walls, or the spheres' positions)
  if (!ran_ || !unchecked_.empty() || walls_checked_ < plane_count()) check_overlaps(!ran_);
  ran_ = true;
  unchecked_.clear();
  unchecked_from_.clear();
  unchecked_listed_.clear();
  walls_checked_ = plane_count();
}

void Simulation::mark_unchecked(Index i, bool added) {
  const Id id = particles_.id(i);
  if (unchecked_listed_.size() < particles_.id_bound()) unchecked_listed_.resize(particles_.id_bound(), 0);
  char& listed = unchecked_listed_[static_cast<std::size_t>(id)];
  if (listed) return;  // (moved again: the centre at the last check is kept)
  listed = 1;
  unchecked_.push_back(id);
  for (int c = 0; c < 3; ++c)
    unchecked_from_.push_back(added ? std::numeric_limits<double>::quiet_NaN()
                                    : particles_.arrays().x[3 * static_cast<std::size_t>(i) + c]);
}

void Simulation::select_law() {
  law_ = &find_law(law_key());
  contacts_.shape_for(*law_);
  sphere_material_ = particles_.size() > 0 ? particles_.arrays().material[0] : -1;
  for (std::size_t k = 1; k < particles_.size() && sphere_material_ >= 0; ++k)
    if (particles_.arrays().material[k] != sphere_material_) sphere_material_ = -1;
}

long Simulation::run(long steps, const std::function<bool()>& should_stop, double poll_seconds,
                     bool audit) {
  require(steps >= 0, "steps must be >= 0, got " + std::to_string(steps));
  if (running_.on.exchange(true, std::memory_order_acquire))
    throw std::logic_error("tsubu: Simulation::run: the Simulation is running in another thread");
  // However the run ends: no poll left behind, the Simulation free again; a stop request is
  // cleared by the run that stops on it (below) or that fails, and otherwise kept for the next.
  struct Finish {
    Simulation& s;
    bool failed = true;
    ~Finish() {
      s.publish();
      s.poll_ = nullptr;
      if (failed) s.stop_.on.store(false, std::memory_order_relaxed);
      s.running_.on.store(false, std::memory_order_release);
    }
  } finish{*this};
  stopped_ = false;
  const long start = run_.step;
  if (particles_.size() == 0 || steps == 0) {
    if (particles_.size() == 0 && steps > 0 && !stop_.on.load(std::memory_order_relaxed)) {
      prepare_run();
      run_.step += steps;
      run_.time += steps * run_.dt;
    }
  } else {
    prepare_run();
    poll_ = should_stop ? &should_stop : nullptr;
    poll_every_ = std::chrono::duration_cast<std::chrono::steady_clock::duration>(
        std::chrono::duration<double>(std::max(poll_seconds, 0.0)));
    next_poll_ = std::chrono::steady_clock::now() + poll_every_;
    if (!stop_.on.load(std::memory_order_relaxed)) {
      detail::World w = world();
      law_->step(w, steps);
    }
    if (audit) audit_run_end(start);
  }
  finish.failed = false;
  stopped_ = run_.step - start < steps;
  if (stopped_) stop_.on.store(false, std::memory_order_relaxed);
  return run_.step - start;
}

// ---- the loop's parts and hooks -------------------------------------------------------------

detail::World Simulation::world() {
  return {particles_, walls_, lists_, contacts_,        domain_,        pairs_,
          opt_,       run_,   *this,  sphere_material_, threads_used(), max_move_,
          fixed_.empty() ? nullptr : &fixed_, !outlets_.empty(), static_cast<bool>(exchange_)};
}

NeighborList::Context Simulation::list_context() {
  return {particles_, walls_, domain_, contacts_, law(), law_ != nullptr, pairs_, threads(),
          static_cast<long>(particles_.size()) >= opt_.parallel_min, sheets_};
}

void Simulation::update_lists() {
  if (lists_.needs_rebuild(walls_, opt_.rebuild_every_step))
    lists_.rebuild(list_context(), skin(), true);
  else if (lists_.needs_refresh())
    lists_.refresh(list_context());
}

void Simulation::start_audit(bool walls_move) {
  if (walls_move) {
    energy_ref_valid_ = false;
  } else if (!energy_ref_valid_ || energy_ref_gravity_ != opt_.gravity) {
    energy_ref_ = energy_now();
    energy_ref_valid_ = true;
    energy_ref_gravity_ = opt_.gravity;
    energy_ref_step_ = run_.step;
  }
}

void Simulation::audit_energy() {
  if (exchange_ || law_ == nullptr || !energy_ref_valid_ || walls_.moving() || fixed_.moving() || energy_ref_gravity_ != opt_.gravity ||
      !lists_.built(particles_.size()) || run_.step == energy_ref_step_)
    return;
  audit();
}

void Simulation::audit_run_end(long start) {
  if (run_.step / kRunEndAudit > start / kRunEndAudit && run_.step % detail::kEnergyCheck != 0)
    audit_energy();
}

double Simulation::max_move() const {
  // The two smallest radii a <= b: of all pairs, theirs is the narrowest stretch of a head-on
  // approach over which the overlap exceeds max_overlap (m) x the smaller radius,
  // 2 (a + b - m a). Two spheres meeting head on close by at most twice the largest step: if
  // that step is at most a + b - m a, some step lands them in that stretch and the overlap
  // check sees them; a longer one can carry them through one another unseen. (A wall is a
  // half-space: a sphere cannot pass it unseen.)
  double a = std::numeric_limits<double>::infinity(), b = a;
  for (std::size_t k = 0; k < particles_.size(); ++k) {  // (not the ghosts: copies of these)
    const double r = particles_.arrays().radius[k];
    if (r < a) b = a, a = r;
    else if (r < b) b = r;
  }
  return a + b - std::min(opt_.max_overlap, 1.0) * a;  // infinite with fewer than two spheres
}

void Simulation::check_wall_speeds() const {
  const ParticleStore& ps = particles_.arrays();
  for (int k = 0; k < walls_.count(); ++k) {
    const Plane& p = walls_.plane(k);
    // (A translation was checked when it was set; a checkpoint's wall is restored as it was.)
    require(p.velocity.norm() <= kMaxWallSpeed, [&] {
      return "wall " + std::to_string(k) + ": " + wall_too_fast(p.velocity.norm());
    });
    const double spin = p.angular_velocity.norm();
    if (spin == 0) continue;
    double reach = 0;  // the farthest sphere from the wall's centre of rotation
    for (std::size_t i = 0; i < particles_.size(); ++i)
      reach = std::max(reach, (vec3(ps.x.data(), i) - p.center).norm());
    const double speed = p.velocity.norm() + spin * reach;
    require(speed <= kMaxWallSpeed, [&] {
      return "wall " + std::to_string(k) + " turns at " + fmt(spin) + " rad/s about a point " +
             fmt(reach) + " m from the farthest sphere: its surface would move at up to " +
             fmt(speed) + " m/s there, faster than light (" + fmt(kMaxWallSpeed) +
             " m/s); check the units of its angular_velocity";
    });
  }
}

void Simulation::rebuild_neighbors() {
  mix_pairs();
  lists_.rebuild(list_context(), skin(), true);
}

std::vector<std::array<Id, 2>> Simulation::neighbor_pairs() const { return lists_.pairs_by_id(particles_); }

// ---- state access ----------------------------------------------------------------------------

void Simulation::set_positions(const double* in) {
  energy_ref_valid_ = false;
  run_.last_move = 0;
  if (ran_) {  // the spheres that move are checked for overlaps at the next run
    const double* x = particles_.arrays().x.data();
    for (std::size_t k = 0; k < particles_.size(); ++k) {
      const double* to = in + 3 * particles_.rank(particles_.arrays().id[k]);
      if (to[0] != x[3 * k] || to[1] != x[3 * k + 1] || to[2] != x[3 * k + 2])
        mark_unchecked(static_cast<Index>(k), false);
    }
  }
  particles_.scatter(in, particles_.arrays().x.data());
  lists_.valid = false;
}

void Simulation::get_radii(double* out) const { particles_.gather_scalar(particles_.arrays().radius, out); }
void Simulation::get_masses(double* out) const { particles_.gather_scalar(particles_.arrays().mass, out); }
void Simulation::get_materials(int* out) const { particles_.gather_scalar(particles_.arrays().material, out); }

std::vector<std::pair<std::string, std::size_t>> Simulation::memory_bytes() const {
  auto bytes = [](const auto&... v) {
    return ((v.capacity() * sizeof(typename std::decay_t<decltype(v)>::value_type)) + ... + 0);
  };
  return {
      {"particles", particles_.bytes() + bytes(lists_.busy, lists_.loaded, lists_.sum_offset)},
      {"verlet list", lists_.verlet_bytes()},
      {"near list", lists_.near_bytes() + contacts_.pairs.bytes()},
      {"walls", lists_.wall_bytes() + contacts_.walls.bytes() + walls_.bytes()},
      {"scratch", lists_.scratch_bytes() + contacts_.stash_bytes()},
  };
}

}  // namespace tsubu
