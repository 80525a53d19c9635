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
  require(HertzParams::used(p) == HertzParams::used(pair_parameters(a, b)),
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
  if (HertzParams::used(p)) {  // the scene's choice of a clipped force and its damping
    p.normal_floor = opt_.repulsive ? 0.0 : -std::numeric_limits<double>::infinity();
    p.finalise();
  }
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

Id Simulation::add_spheres(std::size_t n, const double* positions, const double* radii,
                           const int* materials, const double* velocities,
                           const double* angular_velocities) {
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
  const Id first = static_cast<Id>(n_);
  particles_.grow(n_ + n);
  if (n_ + n > index_of_.capacity())
    index_of_.reserve(std::max(n_ + n, index_of_.capacity() + index_of_.capacity() / 2));
  for (std::size_t k = 0; k < n; ++k) {
    const double r = radii[k];
    const double m = materials_[materials[k]].density * 4.0 / 3.0 * M_PI * r * r * r;
    for (int c = 0; c < 3; ++c) {
      particles_.x.push_back(positions[3 * k + c]);
      particles_.v.push_back(velocities ? velocities[3 * k + c] : 0.0);
      particles_.w.push_back(angular_velocities ? angular_velocities[3 * k + c] : 0.0);
    }
    particles_.radius.push_back(r);
    particles_.mass.push_back(m);
    particles_.inv_mass.push_back(1.0 / m);
    particles_.inv_inertia.push_back(1.0 / (0.4 * m * r * r));  // I = 2/5 m r^2 (1.3)
    particles_.dissipated.push_back(0.0);
    particles_.material.push_back(materials[k]);
    particles_.id.push_back(static_cast<Id>(n_));
    index_of_.push_back(static_cast<Index>(n_));
    ++n_;
  }
  list_valid_ = false;
  energy_ref_valid_ = false;
  speed_fixed_ = 0;  // taken again at the next run
  return first;
}

void Simulation::reserve(std::size_t count) {
  particles_.reserve(count);
  index_of_.reserve(count);
}

Id Simulation::add_sphere(const Vec3& position, double radius, int material,
                          const Vec3& velocity, const Vec3& angular_velocity) {
  return add_spheres(1, position.data(), &radius, &material, velocity.data(),
                     angular_velocity.data());
}

int Simulation::add_plane(const Vec3& point, const Vec3& normal, int material_index,
                          const Vec3& velocity, const Vec3& angular_velocity) {
  energy_ref_valid_ = false;
  require(point.allFinite(), "plane point is not finite");
  require(normal.allFinite() && normal.norm() > 0, "plane normal must be a non-zero finite vector");
  require(velocity.allFinite() && angular_velocity.allFinite(), "plane motion is not finite");
  material(material_index);
  Plane p;
  p.point = point;
  p.normal = normal.normalized();
  p.velocity = velocity;
  p.angular_velocity = angular_velocity;
  p.material = material_index;
  planes_.push_back(p);
  list_valid_ = false;
  return static_cast<int>(planes_.size()) - 1;
}

void Simulation::set_plane_motion(int wall, const Vec3& velocity, const Vec3& angular_velocity) {
  energy_ref_valid_ = false;
  require(wall >= 0 && wall < plane_count(), "no wall " + std::to_string(wall));
  require(velocity.allFinite() && angular_velocity.allFinite(), "plane motion is not finite");
  planes_[wall].velocity = velocity;
  planes_[wall].angular_velocity = angular_velocity;
  list_valid_ = false;  // the rebuild criterion now accounts for this wall's motion
}

const Plane& Simulation::plane(int wall) const {
  require(wall >= 0 && wall < plane_count(), "no wall " + std::to_string(wall));
  return planes_[wall];
}

void Simulation::move_planes(double dt) {
  for (Plane& p : planes_) p.advance(dt);
}

bool Simulation::walls_move() const {
  for (const Plane& p : planes_)
    if (p.moving()) return true;
  return false;
}

// ---- time step ---------------------------------------------------------------------------

// Calls f(params, scale) for every kind of contact the scene can have: each pair of particle
// materials present (reduced mass and radius of their lightest and smallest particles) and each
// particle material against each wall material (the lightest particle's mass, the smallest
// radius), at the scene's characteristic impact speed.
template <class F>
void Simulation::for_each_contact_type(F&& f) const {
  const std::size_t nm = materials_.size();
  std::vector<double> lightest(nm, std::numeric_limits<double>::infinity()), smallest = lightest;
  for (std::size_t k = 0; k < n_; ++k) {
    const int m = particles_.material[k];
    lightest[m] = std::min(lightest[m], particles_.mass[k]);
    smallest[m] = std::min(smallest[m], particles_.radius[k]);
  }
  std::vector<char> wall_material(nm, 0);
  for (const Plane& p : planes_) wall_material[p.material] = 1;
  const double speed = characteristic_speed();
  for (std::size_t a = 0; a < nm; ++a) {
    if (!std::isfinite(lightest[a])) continue;
    for (std::size_t b = a; b < nm; ++b) {
      if (!std::isfinite(lightest[b]) || n_ < 2) continue;
      const double ma = lightest[a], mb = lightest[b], ra = smallest[a], rb = smallest[b];
      f(pair_parameters(int(a), int(b)), ContactScale{ma * mb / (ma + mb), ra * rb / (ra + rb), speed});
    }
    for (std::size_t b = 0; b < nm; ++b)
      if (wall_material[b]) f(pair_parameters(int(a), int(b)), ContactScale{lightest[a], smallest[a], speed});
  }
}

double Simulation::critical_time_step() const {
  const CompiledLaw& law = find_law(law_key());
  double bound = std::numeric_limits<double>::infinity();
  for_each_contact_type(
      [&](const PairParams& p, const ContactScale& s) { bound = std::min(bound, law.critical_time_step(p, s)); });
  return bound;
}

double Simulation::contact_duration() const {
  const CompiledLaw& law = find_law(law_key());
  double tc = std::numeric_limits<double>::infinity();
  for_each_contact_type(
      [&](const PairParams& p, const ContactScale& s) { tc = std::min(tc, law.contact_duration(p, s)); });
  return tc;
}

double Simulation::default_time_step() const {
  return std::min(contact_duration() / 50.0, 0.2 * rayleigh_time());
}

double Simulation::rayleigh_time() const {
  std::vector<double> smallest(materials_.size(), std::numeric_limits<double>::infinity());
  for (std::size_t k = 0; k < n_; ++k)
    smallest[particles_.material[k]] = std::min(smallest[particles_.material[k]], particles_.radius[k]);
  double t = std::numeric_limits<double>::infinity();
  for (std::size_t a = 0; a < materials_.size(); ++a) {
    const Material& m = materials_[a];
    if (!(m.youngs_modulus > 0) || !std::isfinite(smallest[a])) continue;
    const double shear = m.youngs_modulus / (2.0 * (1.0 + m.poisson_ratio));
    t = std::min(t, M_PI * smallest[a] * std::sqrt(m.density / shear) /
                        (0.1631 * m.poisson_ratio + 0.8766));
  }
  return t;
}

double Simulation::characteristic_speed() const {
  if (opt_.impact_speed > 0) return opt_.impact_speed;
  if (speed_fixed_ > 0) return speed_fixed_;
  double v2 = 0;
  for (std::size_t k = 0; k < n_; ++k) v2 = std::max(v2, vec3(particles_.v.data(), k).squaredNorm());
  return std::max(1.0, 2.0 * std::sqrt(v2));
}

bool Simulation::hertzian() const {
  // The materials in use: spheres' and walls'.
  std::vector<char> used(materials_.size(), 0);
  for (std::size_t k = 0; k < n_; ++k) used[particles_.material[k]] = 1;
  for (const Plane& p : planes_) used[p.material] = 1;
  int hertz = -1, linear = -1;
  for (std::size_t a = 0; a < materials_.size(); ++a) {
    if (!used[a]) continue;
    (materials_[a].youngs_modulus > 0 ? hertz : linear) = static_cast<int>(a);
  }
  require(hertz < 0 || linear < 0, [&] {
    return "the scene mixes a Hertzian material (material " + std::to_string(hertz) +
           ", given youngs_modulus) with a linear one (material " + std::to_string(linear) +
           ", given kn): give every sphere and wall material youngs_modulus, or none";
  });
  return hertz >= 0;
}

double Simulation::time_step() const { return opt_.dt > 0 ? opt_.dt : default_time_step(); }

double Simulation::skin() const {
  if (opt_.skin > 0) return opt_.skin;
  if (n_ == 0) return 0;
  double sum = 0;
  for (double r : particles_.radius) sum += r;
  return 0.2 * 2.0 * sum / static_cast<double>(n_);
}

// Each slot takes the evaluator the scene needs: the simplest that gives its physics.
LawKey Simulation::law_key() const {
  bool friction = false, rolling = false, rough = false;
  const bool hertz = hertzian();
  const std::size_t nm = materials_.size();
  for (std::size_t a = 0; a < nm; ++a)
    for (std::size_t b = a; b < nm; ++b) {
      const PairParams p = pair_parameters(int(a), int(b));
      friction |= hertz ? MindlinRotate::used(p) : FrictionParams::used(p);
      rolling |= RollingParams::used(p);
      rough |= RoughnessParams::used(p);
    }
  LawKey key;
  key.normal = hertz ? NormalLaws::index_of<HertzNormal>() : NormalLaws::index_of<HookeNormal>();
  key.damping = hertz ? DampingLaws::index_of<HertzDamping>() : DampingLaws::index_of<RestitutionDamping>();
  require(!(hertz && friction && opt_.history == HistoryRule::Literal),
          "tangential_history='literal' is offered for the linear law only; Hertzian scenes use "
          "'rotate'");
  key.tangential = !friction                          ? TangentialLaws::index_of<NoTangential>()
                   : hertz ? (opt_.slip == SlipRule::Truncate ? TangentialLaws::index_of<MindlinRotateTruncate>()
                                                              : TangentialLaws::index_of<MindlinRotate>())
                   : opt_.history == HistoryRule::Literal ? TangentialLaws::index_of<TangentialLiteral>()
                   : opt_.slip == SlipRule::Truncate   ? TangentialLaws::index_of<TangentialRotateTruncate>()
                                                       : TangentialLaws::index_of<TangentialRotate>();
  key.rolling = rolling ? RollingLaws::index_of<RollingFriction>() : RollingLaws::index_of<NoRolling>();
  key.roughness =
      rough ? RoughnessLaws::index_of<StochasticRoughness>() : RoughnessLaws::index_of<NoRoughness>();
  return key;
}

std::string Simulation::law_name() const {
  return find_law(law_key()).name() + (walls_move() ? "+moving-walls" : "");
}

void Simulation::prepare_run() {
  validate_options(opt_);
  mix_pairs();
  // The default speed is taken once, at the first run after spheres were added: a scene's
  // default dt must not change between runs, or splitting a run would change its result.
  if (!(opt_.impact_speed > 0) && !(speed_fixed_ > 0)) speed_fixed_ = characteristic_speed();
  speed_ = characteristic_speed();
  dt_ = time_step();
  require(std::isfinite(dt_) && dt_ > 0, [&] {
    return n_ == 0 || materials_.empty()
               ? std::string("no time step: the scene has no possible contact to derive one from; set dt")
               : "no time step: the default dt (contact duration / 50) is " + fmt(dt_) +
                     " s for this scene (an overdamped restitution near 0, or stiffnesses, masses or "
                     "impact_speed beyond what doubles resolve, leave no finite contact duration); set dt";
  });
  const double crit = critical_time_step();
  if (dt_ > crit && !opt_.allow_unstable_dt)
    throw InvalidArgument("dt = " + fmt(dt_) + " s exceeds the stability bound " + fmt(crit) +
                          " s of (2.31) for this scene; use a smaller dt or allow_unstable_dt");
  select_law();
  if (!list_valid_) rebuild(true);
  size_entry_buffers();
  cache_near_terms();  // the pair table may have changed since the last run
  if (!ran_) check_initial_overlaps();
  ran_ = true;
}

void Simulation::select_law() {
  law_ = &find_law(law_key());
  const int moment = law_->history_width > 0 ? 3 : 0;
  pair_shape_ = {law_->history_width, law_->rough_width > 0 ? 3 : moment, law_->rolling ? 3 : 0,
                 law_->rough_width};
  wall_shape_ = {law_->history_width, moment, law_->rolling ? 3 : 0, law_->rough_width};
  sphere_material_ = n_ > 0 ? particles_.material[0] : -1;
  for (std::size_t k = 1; k < n_ && sphere_material_ >= 0; ++k)
    if (particles_.material[k] != sphere_material_) sphere_material_ = -1;
}

long Simulation::run(long steps, const std::function<bool()>& should_stop, double poll_seconds) {
  require(steps >= 0, "steps must be >= 0, got " + std::to_string(steps));
  if (running_.on.exchange(true, std::memory_order_acquire))
    throw std::logic_error("tsubu: Simulation::run: the Simulation is running in another thread");
  // However the run ends: no poll left behind, the Simulation free again; a stop request is
  // cleared by the run that stops on it (below) or that fails, and otherwise kept for the next.
  struct Finish {
    Simulation& s;
    bool failed = true;
    ~Finish() {
      s.poll_ = nullptr;
      if (failed) s.stop_.on.store(false, std::memory_order_relaxed);
      s.running_.on.store(false, std::memory_order_release);
    }
  } finish{*this};
  stopped_ = false;
  const long start = step_;
  if (n_ == 0 || steps == 0) {
    if (n_ == 0 && steps > 0 && !stop_.on.load(std::memory_order_relaxed)) {
      prepare_run();
      step_ += steps;
      time_ += steps * dt_;
    }
  } else {
    prepare_run();
    poll_ = should_stop ? &should_stop : nullptr;
    poll_every_ = std::chrono::duration_cast<std::chrono::steady_clock::duration>(
        std::chrono::duration<double>(std::max(poll_seconds, 0.0)));
    next_poll_ = std::chrono::steady_clock::now() + poll_every_;
    if (!stop_.on.load(std::memory_order_relaxed)) law_->step(*this, steps);
  }
  finish.failed = false;
  stopped_ = step_ - start < steps;
  if (stopped_) stop_.on.store(false, std::memory_order_relaxed);
  return step_ - start;
}

// ---- checks and errors -------------------------------------------------------------------

void Simulation::check_initial_overlaps() const {
  const double tol = opt_.initial_overlap;
  for (std::size_t i = 0; i < n_; ++i) {
    for (Index e = pair_offset_[i]; e < pair_offset_[i + 1]; ++e) {
      const Index j = pair_partner_[e];
      const double d = box_.displacement(vec3(particles_.x.data(), i), vec3(particles_.x.data(), j)).norm();
      const double ov = particles_.radius[i] + particles_.radius[j] - d;
      if (ov > tol * std::min(particles_.radius[i], particles_.radius[j]))
        throw InvalidArgument("initial overlap: spheres " + std::to_string(particles_.id[i]) + " and " +
                              std::to_string(particles_.id[j]) + " overlap by " + fmt(ov) + " m (" +
                              fmt(ov / std::min(particles_.radius[i], particles_.radius[j])) +
                              " of the smaller radius; tolerance " + fmt(tol) + ")");
    }
    for (Index e = wall_offset_[i]; e < wall_offset_[i + 1]; ++e) {
      const Plane& p = planes_[wall_index_[e]];
      const double ov = p.overlap(vec3(particles_.x.data(), i), particles_.radius[i]);
      if (ov > tol * particles_.radius[i])
        throw InvalidArgument("initial overlap: sphere " + std::to_string(particles_.id[i]) + " overlaps wall " +
                              std::to_string(wall_index_[e]) + " by " + fmt(ov) + " m (" +
                              fmt(ov / particles_.radius[i]) + " of its radius; tolerance " + fmt(tol) + ")");
    }
  }
}

void Simulation::report_overlap(double dt) const {
  // Error path only: find the worst offender serially (lowest id wins ties).
  double worst = -1;
  std::string what;
  Id who = -1;
  for (std::size_t i = 0; i < n_; ++i) {
    for (Index q = near_offset_[i]; q < near_offset_[i + 1]; ++q) {
      const Index j = near_partner_[q];
      const double frac = pair_state_.overlap[q] / std::min(particles_.radius[i], particles_.radius[j]);
      if (frac > worst || std::isnan(frac)) {
        worst = frac;
        who = particles_.id[i];
        what = "spheres " + std::to_string(particles_.id[i]) + " and " + std::to_string(particles_.id[j]);
      }
    }
    for (Index e = wall_offset_[i]; e < wall_offset_[i + 1]; ++e) {
      const double frac = wall_state_.overlap[e] / particles_.radius[i];
      if (frac > worst || std::isnan(frac)) {
        worst = frac;
        who = particles_.id[i];
        what = "sphere " + std::to_string(particles_.id[i]) + " and wall " + std::to_string(wall_index_[e]);
      }
    }
  }
  throw InstabilityError(
      "unstable at step " + std::to_string(step_ + 1) + " (t = " + fmt(time_ + dt) + " s): " +
          what + " overlap by " + fmt(worst) + " of the smaller radius (limit " +
          fmt(opt_.max_overlap) +
          "); the time step is too large for the stiffness, or a particle moved too fast. "
          "The state before this step is kept.",
      step_ + 1, who);
}

void Simulation::report_nonfinite() const {
  auto finite_entry = [](const Array<double>& a, std::size_t e) {
    return a.empty() || finite3(a.data() + 3 * e);
  };
  for (std::size_t i = 0; i < n_; ++i) {
    for (Index e = wall_offset_[i]; e < wall_offset_[i + 1]; ++e)
      if (!finite_entry(wall_state_.force, e) || !finite_entry(wall_state_.nxft, e) ||
          !finite_entry(wall_state_.roll, e))
        throw InstabilityError("unstable at step " + std::to_string(step_ + 1) +
                                   ": non-finite contact force between sphere " +
                                   std::to_string(particles_.id[i]) + " and wall " +
                                   std::to_string(wall_index_[e]) +
                                   ". The positions and velocities before this step are kept.",
                               step_ + 1, particles_.id[i]);
    for (Index q = near_offset_[i]; q < near_offset_[i + 1]; ++q)
      if (!finite_entry(pair_state_.force, q) || !finite_entry(pair_state_.nxft, q) ||
          !finite_entry(pair_state_.roll, q))
        throw InstabilityError("unstable at step " + std::to_string(step_ + 1) +
                                   ": non-finite contact force between spheres " +
                                   std::to_string(particles_.id[i]) + " and " +
                                   std::to_string(particles_.id[near_partner_[q]]) +
                                   ". The positions and velocities before this step are kept.",
                               step_ + 1, particles_.id[i]);
  }
  throw InstabilityError("unstable: non-finite force", step_ + 1, -1);
}

namespace {
// k_t of a stored history: a linear spring's, or Mindlin's 8 G* a with the a the history keeps.
double tangential_stiffness(const PairParams& p, const double* history, int width) {
  return width > 3 ? 8.0 * p.effective_shear_modulus * history[3] : p.kt;
}
}  // namespace

Energy Simulation::energy_now() const {
  Energy e = energy();
  e.elastic = 0;
  if (near_offset_.size() != n_ + 1) return e;
  const CompiledLaw& law = this->law();
  const double *x = particles_.x.data(), *v = particles_.v.data(), *w = particles_.w.data();
  // sum v.F of the conservative forces: gravity and normal springs (+), tangential springs (-).
  // For one oscillator x'' = -w^2 x stepped as v += dt F(x)/m, x += dt v, the quantity
  // 1/2 m v^2 + 1/2 k x^2 + dt/2 v.F(x) is exactly constant whatever w dt < 2 (the energy itself
  // swings by up to 1 / (1 - (w dt/2)^2) near the bound); a tangential spring, incremented with
  // the velocity before its force acts, conserves the form with the opposite sign.
  double power = 0;
  for (std::size_t i = 0; i < n_; ++i) power += particles_.mass[i] * opt_.gravity.dot(vec3(v, i));
  // The tangential velocity of the contact points (1.12), levers c = r - overlap/2 (wall: cj = 0).
  auto slip = [&](const Vec3& n, const Vec3& vrel, const Vec3& spin_lever) {
    return Vec3(vrel - vrel.dot(n) * n - spin_lever.cross(n));
  };
  for (std::size_t i = 0; i < n_; ++i) {
    for (Index q = near_offset_[i]; q < near_offset_[i + 1]; ++q) {
      const Index j = near_partner_[q];
      const Vec3 d = box_.displacement(vec3(x, i), vec3(x, j));
      const double dist = d.norm();
      const double delta = particles_.radius[i] + particles_.radius[j] - dist;
      if (!(delta > 0)) continue;  // (an open contact holds no tangential displacement)
      const PairParams& p = pairs_(particles_.material[i], particles_.material[j]);
      const Vec3 n = d / dist, vrel = vec3(v, i) - vec3(v, j);
      const double ri = particles_.radius[i], rj = particles_.radius[j], r_eff = ri * rj / (ri + rj);
      e.elastic += law.normal_energy(p, delta, r_eff);
      power += law.elastic_force(p, delta, r_eff) * vrel.dot(n);
      if (pair_state_.xi.empty()) continue;
      const double* h = pair_state_.xi.data() + law.history_width * q;
      e.elastic += law.tangential_energy(p, h);
      const Vec3 lever = contact_lever(ri, delta) * vec3(w, i) + contact_lever(rj, delta) * vec3(w, j);
      power += tangential_stiffness(p, h, law.history_width) * Vec3(h[0], h[1], h[2]).dot(slip(n, vrel, lever));
    }
    for (Index k = wall_offset_[i]; k < wall_offset_[i + 1]; ++k) {
      const Plane& P = planes_[wall_index_[k]];
      const double delta = P.overlap(vec3(x, i), particles_.radius[i]);
      if (!(delta > 0)) continue;
      const PairParams& p = pairs_(particles_.material[i], P.material);
      const double ri = particles_.radius[i];
      e.elastic += law.normal_energy(p, delta, ri);
      power += law.elastic_force(p, delta, ri) * vec3(v, i).dot(P.normal);
      if (wall_state_.xi.empty()) continue;
      const double* h = wall_state_.xi.data() + law.history_width * k;
      e.elastic += law.tangential_energy(p, h);
      power += tangential_stiffness(p, h, law.history_width) *
               Vec3(h[0], h[1], h[2]).dot(slip(P.normal, vec3(v, i), contact_lever(ri, delta) * vec3(w, i)));
    }
  }
  e.step_correction = 0.5 * dt_ * power;
  return e;
}

void Simulation::check_energy(const Energy& start) const {
  const Energy now = energy_now();
  const double created = (now.total() + now.step_correction + now.dissipated) -
                         (start.total() + start.step_correction + start.dissipated);
  const double lost = now.dissipated - start.dissipated;
  const double scale =
      std::max(start.kinetic() + start.elastic, 0.25 * (now.kinetic() + now.elastic));
  // With the step correction the balance of a stable run wanders only by the first-order error
  // of the booked dissipation (up to about its size just below the bound) and of contacts opening
  // and closing (a fraction of the contact energy), even for an undamped oscillation near the
  // bound. A burst ends with the pack flying apart: several times its starting energy appears as
  // kinetic energy: the threshold takes only a quarter of the energy now (a pack at rest that
  // starts to fall needs some), so that twice the start's energy created cannot hide itself.
  if (!(created > 0.5 * std::max(lost, 0.0) + 2.0 * scale)) return;
  throw InstabilityError(
      "unstable at step " + std::to_string(step_) + " (t = " + fmt(time_) +
          " s): the energy balance grew by " + fmt(created) + " J since step " +
          std::to_string(energy_ref_step_) + " (energy dissipated meanwhile " + fmt(lost) + " J, kinetic + elastic now " +
          fmt(now.kinetic() + now.elastic) + " J) with no moving wall to supply it: the time step "
          "is too large for this packing. critical_time_step() bounds one contact; a sphere "
          "pressed by many neighbours needs less (about 0.4 of it in a squeezed pack, "
          "docs/benchmarks.md). The state at this step is kept.",
      step_, -1);
}

void Simulation::report_nonfinite_velocity() const {
  for (std::size_t k = 0; k < n_; ++k)
    if (!finite3(particles_.v.data() + 3 * k) || !finite3(particles_.w.data() + 3 * k))
      throw InstabilityError("unstable at step " + std::to_string(step_ + 1) +
                                 ": non-finite velocity of sphere " + std::to_string(particles_.id[k]),
                             step_ + 1, particles_.id[k]);
  throw InstabilityError("unstable: non-finite velocity", step_ + 1, -1);
}

// ---- state access ----------------------------------------------------------------------------

void Simulation::gather_by_id(const double* src, double* out) const {
  for (std::size_t k = 0; k < n_; ++k) {
    const Id id = particles_.id[k];
    for (int c = 0; c < 3; ++c) out[3 * id + c] = src[3 * k + c];
  }
}

void Simulation::scatter_by_id(const double* in, double* dst) {
  for (std::size_t k = 0; k < n_; ++k) {
    const Id id = particles_.id[k];
    require(finite3(in + 3 * id),
            [&] { return "value for sphere " + std::to_string(id) + " is not finite"; });
  }
  for (std::size_t k = 0; k < n_; ++k) {
    const Id id = particles_.id[k];
    for (int c = 0; c < 3; ++c) dst[3 * k + c] = in[3 * id + c];
  }
}

void Simulation::set_positions(const double* in) {
  energy_ref_valid_ = false;
  scatter_by_id(in, particles_.x.data());
  list_valid_ = false;
}

// Sums each particle's contacts as the last step did (detail::ContactSums).
template <class Out>
void Simulation::for_each_contact_sum(Out&& out) const {
  if (near_offset_.size() != n_ + 1) {
    for (std::size_t k = 0; k < n_; ++k) out(k, Vec3(Vec3::Zero()), Vec3(Vec3::Zero()));
    return;
  }
  const detail::ContactSums sums(*this);
  const bool wall_lever = !wall_state_.nxft.empty(), pair_lever = !pair_state_.nxft.empty();
  const bool rolling = !pair_state_.roll.empty();
  for (std::size_t k = 0; k < n_; ++k) {
    Vec3 F = Vec3::Zero(), T = Vec3::Zero();
    const Index i = static_cast<Index>(k);
    if (rolling)
      sums.at<true, true, true>(i, F, T);
    else if (wall_lever)
      sums.at<true, true, false>(i, F, T);
    else if (pair_lever)
      sums.at<false, true, false>(i, F, T);
    else
      sums.at<false, false, false>(i, F, T);
    out(k, F, T);
  }
}

void Simulation::get_forces(double* out) const {
  for_each_contact_sum([&](std::size_t k, const Vec3& F, const Vec3&) {
    for (int c = 0; c < 3; ++c) out[3 * particles_.id[k] + c] = F[c] + particles_.mass[k] * opt_.gravity[c];
  });
}

void Simulation::get_torques(double* out) const {
  for_each_contact_sum([&](std::size_t k, const Vec3&, const Vec3& T) {
    for (int c = 0; c < 3; ++c) out[3 * particles_.id[k] + c] = T[c];
  });
}

void Simulation::get_radii(double* out) const {
  for (std::size_t k = 0; k < n_; ++k) out[particles_.id[k]] = particles_.radius[k];
}

void Simulation::get_masses(double* out) const {
  for (std::size_t k = 0; k < n_; ++k) out[particles_.id[k]] = particles_.mass[k];
}

void Simulation::get_materials(int* out) const {
  for (std::size_t k = 0; k < n_; ++k) out[particles_.id[k]] = particles_.material[k];
}

Energy Simulation::energy() const {
  Energy e;
  // Serial sums in id order: the same digits whatever the thread count.
  for (Id id = 0; id < static_cast<Id>(n_); ++id) {
    const Index k = index_of_[id];
    const double m = particles_.mass[k];
    e.translational += 0.5 * m * vec3(particles_.v.data(), k).squaredNorm();
    e.rotational += 0.5 / particles_.inv_inertia[k] * vec3(particles_.w.data(), k).squaredNorm();
    e.gravitational -= m * opt_.gravity.dot(vec3(particles_.x.data(), k));
    e.dissipated += particles_.dissipated[k];
  }
  if (!ran_) return e;
  const CompiledLaw& law = this->law();
  for (const ContactInfo& c : contacts()) {
    const int mi = particles_.material[index_of_[c.i]];
    const int mj = c.wall >= 0 ? planes_[c.wall].material : particles_.material[index_of_[c.j]];
    const PairParams& p = pairs_(mi, mj);
    e.elastic += law.normal_energy(p, c.overlap, c.reduced_radius);
    const double h[4] = {c.tangential_displacement.x(), c.tangential_displacement.y(),
                         c.tangential_displacement.z(), c.contact_radius};
    e.elastic += law.tangential_energy(p, h);
  }
  return e;
}

std::vector<ContactInfo> Simulation::contacts() const {
  std::vector<ContactInfo> out;
  if (near_offset_.size() != n_ + 1) return out;
  auto torque = [](const Array<double>& nxft, const Array<double>& roll, double r,
                   double overlap, std::size_t e) {
    Vec3 t = Vec3::Zero();
    if (!nxft.empty()) t -= contact_lever(r, overlap) * vec3(nxft.data(), e);
    if (!roll.empty()) t += r * vec3(roll.data(), e);
    return t;
  };
  const int width = law().history_width;
  auto history = [width](const Array<double>& xi, std::size_t e) {
    return xi.empty() ? Vec3(Vec3::Zero()) : Vec3(xi[width * e], xi[width * e + 1], xi[width * e + 2]);
  };
  auto size = [width](const Array<double>& xi, std::size_t e) {
    return width > 3 && !xi.empty() ? xi[width * e + 3] : 0.0;
  };
  const double* r = particles_.radius.data();
  for (std::size_t i = 0; i < n_; ++i) {
    for (Index e = near_offset_[i]; e < near_offset_[i + 1]; ++e) {
      if (!(pair_state_.overlap[e] > 0)) continue;
      out.push_back({particles_.id[i], particles_.id[near_partner_[e]], -1, pair_state_.overlap[e],
                     vec3(pair_state_.force.data(), e),
                     torque(pair_state_.nxft, pair_state_.roll, particles_.radius[i], pair_state_.overlap[e], e),
                     history(pair_state_.xi, e), r[i] * r[near_partner_[e]] / (r[i] + r[near_partner_[e]]),
                     size(pair_state_.xi, e)});
    }
    for (Index e = wall_offset_[i]; e < wall_offset_[i + 1]; ++e) {
      if (!(wall_state_.overlap[e] > 0)) continue;
      out.push_back({particles_.id[i], -1, wall_index_[e], wall_state_.overlap[e], vec3(wall_state_.force.data(), e),
                     torque(wall_state_.nxft, wall_state_.roll, particles_.radius[i], wall_state_.overlap[e], e),
                     history(wall_state_.xi, e), r[i], size(wall_state_.xi, e)});
    }
  }
  std::sort(out.begin(), out.end(), [](const ContactInfo& a, const ContactInfo& b) {
    return a.i != b.i ? a.i < b.i : (a.wall != b.wall ? a.wall < b.wall : a.j < b.j);
  });
  return out;
}

std::vector<std::pair<std::string, std::size_t>> Simulation::memory_bytes() const {
  auto bytes = [](const auto&... v) {
    return ((v.capacity() * sizeof(typename std::decay_t<decltype(v)>::value_type)) + ... + 0);
  };
  std::size_t old_state = 0;
  for (std::size_t k = 0; k < kEntryArrays; ++k)
    old_state += bytes(old_pair_state_[k]) + bytes(old_wall_state_[k]);
  return {
      {"particles", particles_.bytes() + bytes(index_of_, busy_, loaded_, sum_offset_)},
      {"verlet list", bytes(pair_offset_, pair_partner_)},
      {"near list", bytes(near_offset_, near_owner_, near_partner_, near_rev_offset_, near_rev_,
                          near_cut2_, near_entry_, sum_entry_) +
                        pair_state_.bytes()},
      {"walls", bytes(wall_offset_, wall_index_, wall_owner_, wall_near_offset_, wall_near_) +
                    wall_state_.bytes()},
      {"scratch", bytes(cell_start_, cell_of_, cell_key_, perm_, old_index_of_, active_,
                        old_near_offset_, old_wall_offset_, old_wall_index_, old_near_partner_id_,
                        scratch_, scratch_int_) +
                      old_state},
  };
}

}  // namespace tsubu
