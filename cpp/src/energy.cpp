// The energy of a scene, its audit, and the contacts and forces as the last step left them
// (simulation.hpp).
#include "tsubu/simulation.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <string>
#include <vector>

#include "check.hpp"
#include "tsubu/engine/views.hpp"

namespace tsubu {

using detail::finite3;
using detail::fmt;
using detail::require;


Energy Simulation::energy_now() const {
  Energy e = sphere_energy();  // the elastic part follows, at the current positions
  if (lists_.near_offset.size() != particles_.size() + 1) return e;
  const CompiledLaw& law = this->law();
  const double *x = particles_.arrays().x.data(), *v = particles_.arrays().v.data(), *w = particles_.arrays().w.data();
  // sum v.F of the conservative forces: gravity and normal springs (+), tangential springs (-).
  // For one oscillator x'' = -w^2 x stepped as v += dt F(x)/m, x += dt v, the quantity
  // 1/2 m v^2 + 1/2 k x^2 + dt/2 v.F(x) is exactly constant whatever w dt < 2 (the energy itself
  // swings by up to 1 / (1 - (w dt/2)^2) near the bound); a tangential spring, incremented with
  // the velocity before its force acts, conserves the form with the opposite sign.
  double power = 0;
  for (std::size_t i = 0; i < particles_.size(); ++i) power += particles_.arrays().mass[i] * opt_.gravity.dot(vec3(v, i));
  measure_walls_now();
  // The tangential velocity of the contact points (1.12), levers c = r - overlap/2 (wall: cj = 0).
  auto slip = [&](const Vec3& n, const Vec3& vrel, const Vec3& spin_lever) {
    return Vec3(vrel - vrel.dot(n) * n - spin_lever.cross(n));
  };
  for (std::size_t i = 0; i < particles_.size(); ++i) {
    for (Index q = lists_.near_offset[i]; q < lists_.near_offset[i + 1]; ++q) {
      const Index j = lists_.near_partner[q];
      const Vec3 d = domain_.displacement(vec3(x, i), vec3(x, j));
      const double dist = d.norm();
      const double delta = particles_.arrays().radius[i] + particles_.arrays().radius[j] - dist;
      // (an open contact holds no tangential displacement; a sticky one may touch at delta <= 0)
      if (!(delta > 0) && !(law.sticky && contacts_.pairs.touch[q])) continue;
      const PairParams& p = pairs_(particles_.arrays().material[i], particles_.arrays().material[j]);
      const Vec3 n = d / dist, vrel = vec3(v, i) - vec3(v, j);
      const double ri = particles_.arrays().radius[i], rj = particles_.arrays().radius[j], r_eff = ri * rj / (ri + rj);
      e.elastic += law.normal_energy(p, delta, r_eff);
      power += law.elastic_force(p, delta, r_eff) * vrel.dot(n);
      if (contacts_.pairs.xi.empty()) continue;
      const double* h = contacts_.pairs.xi.data() + law.history_width * q;
      e.elastic += law.tangential_energy(p, h);
      const Vec3 lever = contact_lever(ri, delta) * vec3(w, i) + contact_lever(rj, delta) * vec3(w, j);
      power += law.tangential_stiffness(p, h) * Vec3(h[0], h[1], h[2]).dot(slip(n, vrel, lever));
    }
    for (Index k = lists_.wall_offset[i]; k < lists_.wall_offset[i + 1]; ++k) {
      const Plane& P = wall_plane_now(k);
      const double delta = P.overlap(vec3(x, i), particles_.arrays().radius[i]);
      if (!(delta > 0) && !(law.sticky && contacts_.walls.touch[k])) continue;
      const PairParams& p = pairs_(particles_.arrays().material[i], P.material);
      const double ri = particles_.arrays().radius[i];
      e.elastic += law.normal_energy(p, delta, ri);
      power += law.elastic_force(p, delta, ri) * vec3(v, i).dot(P.normal);
      if (contacts_.walls.xi.empty()) continue;
      const double* h = contacts_.walls.xi.data() + law.history_width * k;
      e.elastic += law.tangential_energy(p, h);
      power += law.tangential_stiffness(p, h) *
               Vec3(h[0], h[1], h[2]).dot(slip(P.normal, vec3(v, i), contact_lever(ri, delta) * vec3(w, i)));
    }
  }
  e.step_correction = 0.5 * run_.dt * power;
  return e;
}

// The share of the energy booked as dissipated that the audit lets the balance grow by.
constexpr double kBookingTolerance = 1.0 / 3.0;

void Simulation::check_energy(const Energy& start) const {
  const Energy now = energy_now();
  const double created = (now.total() + now.step_correction + now.dissipated) -
                         (start.total() + start.step_correction + start.dissipated);
  const double lost = now.dissipated - start.dissipated;
  // (|elastic|: an adhesive contact's spring holds a negative energy near its rest overlap.)
  const double scale = std::max(start.kinetic() + std::abs(start.elastic),
                                0.25 * (now.kinetic() + std::abs(now.elastic)));
  // With the step correction the balance of a stable run wanders only by the first-order error
  // of the booked dissipation (up to about its size just below the bound) and of contacts opening
  // and closing (a fraction of the contact energy), even for an undamped oscillation near the
  // bound. A burst ends with the pack flying apart: several times its starting energy appears as
  // kinetic energy: the threshold takes only a quarter of the energy now (a pack at rest that
  // starts to fall needs some), so that twice the start's energy created cannot hide itself.
  // Of the booked dissipation only the normal dashpot's is first-order (friction and rolling
  // book the work they do, docs/physics.md): a third of it is tolerated, above the 0.25 that one
  // damped contact at 0.95 of its bound measures; a burst that gives its energy to friction
  // books about 0.8 of what it lost as created.
  if (!(created > kBookingTolerance * std::max(lost, 0.0) + 2.0 * scale)) return;
  throw InstabilityError(
      "unstable at step " + std::to_string(run_.step) + " (t = " + fmt(run_.time) +
          " s): the energy balance grew by " + fmt(created) + " J since step " +
          std::to_string(energy_ref_step_) + " (energy dissipated meanwhile " + fmt(lost) + " J, kinetic + elastic now " +
          fmt(now.kinetic() + now.elastic) + " J) with no moving wall to supply it: the time step "
          "is too large for this packing. critical_time_step() bounds one contact; a sphere "
          "pressed by many neighbours needs less (about 0.4 of it in a squeezed pack, "
          "docs/benchmarks.md). The state at this step is kept.",
      run_.step, -1);
}

// Sums each particle's contacts as the last step did (detail::ContactSums).
template <class Out>
void Simulation::for_each_contact_sum(Out&& out) const {
  if (lists_.near_offset.size() != particles_.size() + 1) {
    for (std::size_t k = 0; k < particles_.size(); ++k) out(k, Vec3(Vec3::Zero()), Vec3(Vec3::Zero()));
    return;
  }
  detail::ContactSums sums(lists_, contacts_, particles_);
  sums.rmask = ~Index(0);  // (outside a run: every radius read, whatever the lists last held)
  const bool wall_lever = !contacts_.walls.nxft.empty(), pair_lever = !contacts_.pairs.nxft.empty();
  const bool rolling = !contacts_.pairs.roll.empty();
  for (std::size_t k = 0; k < particles_.size(); ++k) {
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
    for (int c = 0; c < 3; ++c) out[3 * particles_.rank(particles_.arrays().id[k]) + c] = F[c] + particles_.arrays().mass[k] * opt_.gravity[c];
  });
}

void Simulation::get_torques(double* out) const {
  for_each_contact_sum([&](std::size_t k, const Vec3&, const Vec3& T) {
    for (int c = 0; c < 3; ++c) out[3 * particles_.rank(particles_.arrays().id[k]) + c] = T[c];
  });
}

// A rank of a decomposed scene books its share of the energy (share): its own spheres (set_own)
// and the contacts they own (a pair: its lower id's owner; a wall contact: its sphere's), which
// the ranks' shares sum to once each (docs/parallel.md).
static bool books(const std::vector<char>& own, bool share, Id id) {
  return !share || (static_cast<std::size_t>(id) < own.size() && own[static_cast<std::size_t>(id)]);
}

Energy Simulation::sphere_energy(bool share) const {
  Energy e;
  // Serial sums in id order: the same digits whatever the thread count.
  const ParticleStore& ps = particles_.arrays();
  particles_.for_each_id([&](Id id, Index k) {
    if (!books(own_, share, id)) return;
    const double m = ps.mass[k];
    e.translational += 0.5 * m * vec3(ps.v.data(), k).squaredNorm();
    // (a fixed sphere's inverse inertia is 0: its own, I = 2/5 m r^2 (1.3))
    const double half_i = ps.inv_inertia[k] != 0 ? 0.5 / ps.inv_inertia[k]
                                                 : 0.5 * (0.4 * m * ps.radius[k] * ps.radius[k]);
    e.rotational += half_i * vec3(ps.w.data(), k).squaredNorm();
    e.gravitational -= m * opt_.gravity.dot(domain_.unwrapped(vec3(ps.x.data(), k), ps, k));
    e.dissipated += ps.dissipated[k];
  });
  return e;
}

Energy Simulation::energy(bool share) const {
  Energy e = sphere_energy(share);
  if (!ran_) return e;
  const CompiledLaw& law = this->law();
  for (const ContactInfo& c : contacts()) {
    if (!books(own_, share, c.i)) continue;
    const int mi = particles_.arrays().material[particles_.index(c.i)];
    const int mj = c.wall >= 0 ? walls_.material(c.wall) : particles_.arrays().material[particles_.index(c.j)];
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
  if (lists_.near_offset.size() != particles_.size() + 1) return out;
  auto torque = [](const Array<double>& nxft, const Array<double>& roll, double r,
                   double overlap, std::size_t e) {
    Vec3 t = Vec3::Zero();
    if (!nxft.empty()) t -= contact_lever(r, overlap) * vec3(nxft.data(), e);
    if (!roll.empty()) t += r * vec3(roll.data(), e);
    return t;
  };
  const CompiledLaw& law = this->law();
  const int width = law.history_width;
  auto history = [width](const Array<double>& xi, std::size_t e) {
    return xi.empty() ? Vec3(Vec3::Zero()) : Vec3(xi[width * e], xi[width * e + 1], xi[width * e + 2]);
  };
  auto size = [width](const Array<double>& xi, std::size_t e) {
    return width > 3 && !xi.empty() ? xi[width * e + 3] : 0.0;
  };
  const double* r = particles_.arrays().radius.data();
  measure_walls_now();
  for (std::size_t i = 0; i < particles_.size(); ++i) {
    for (Index e = lists_.near_offset[i]; e < lists_.near_offset[i + 1]; ++e) {
      if (!touching(law, contacts_.pairs.overlap[e])) continue;
      out.push_back({particles_.arrays().id[i], particles_.arrays().id[lists_.near_partner[e]], -1, -1, contacts_.pairs.overlap[e],
                     vec3(contacts_.pairs.force.data(), e),
                     torque(contacts_.pairs.nxft, contacts_.pairs.roll, particles_.arrays().radius[i], contacts_.pairs.overlap[e], e),
                     history(contacts_.pairs.xi, e), r[i] * r[lists_.near_partner[e]] / (r[i] + r[lists_.near_partner[e]]),
                     size(contacts_.pairs.xi, e)});
      out.back().branch = vec3(particles_.arrays().x.data(), lists_.near_partner[e]) - vec3(particles_.arrays().x.data(), i);
    }
    for (Index e = lists_.wall_offset[i]; e < lists_.wall_offset[i + 1]; ++e) {
      if (!touching(law, contacts_.walls.overlap[e])) continue;
      out.push_back({particles_.arrays().id[i], -1, lists_.wall_index[e], lists_.wall_element[e], contacts_.walls.overlap[e], vec3(contacts_.walls.force.data(), e),
                     torque(contacts_.walls.nxft, contacts_.walls.roll, particles_.arrays().radius[i], contacts_.walls.overlap[e], e),
                     history(contacts_.walls.xi, e), r[i], size(contacts_.walls.xi, e)});
      out.back().wall_point = wall_point_now(Index(i), e);
    }
  }
  std::sort(out.begin(), out.end(), [](const ContactInfo& a, const ContactInfo& b) {
    return a.i != b.i ? a.i < b.i : (a.wall != b.wall ? a.wall < b.wall : a.element != b.element ? a.element < b.element : a.j < b.j);
  });
  return out;
}

void Simulation::measure_walls_now(const double* x) const {
  if (!walls_.has_meshes() || lists_.wall_offset.size() != particles_.size() + 1) return;
  const std::size_t count = lists_.wall_index.size();
  wall_planes_.resize(count);
  if (wall_entries_.size() != count) {
    wall_entries_.resize(count);
    for (std::size_t e = 0; e < count; ++e) wall_entries_[e] = static_cast<Index>(e);
  }
  const ParticleStore& ps = particles_.arrays();
  if (x == nullptr) x = ps.x.data();
  for (std::size_t i = 0; i < particles_.size(); ++i) {
    const Index lo = lists_.wall_offset[i], hi = lists_.wall_offset[i + 1];
    if (hi > lo)
      walls_.measure(vec3(x, i), ps.radius[i], lists_.wall_index.data(), lists_.wall_element.data(),
                     wall_entries_.data() + lo, int(hi - lo), wall_planes_.data(), contacts_.walls.touch.data());
  }
}

void Simulation::wall_loads(std::vector<Vec3>& forces, std::vector<Vec3>& torques) const {
  const std::size_t nw = static_cast<std::size_t>(walls_.count());
  forces.assign(nw, Vec3::Zero());
  torques.assign(nw, Vec3::Zero());
  if (lists_.wall_offset.size() != particles_.size() + 1) return;
  const ParticleStore& ps = particles_.arrays();
  const CompiledLaw& law = this->law();
  // The forces were evaluated where the spheres and walls stood before the last step's drift:
  // x - dt v (symplectic Euler: x_{n+1} = x_n + dt v_{n+1}) and each wall's centre less
  // dt times its velocity. Each contact's moment about that centre is its force's at the
  // sphere's centre plus the torque it put on the sphere (the lever c n x F_t and the rolling
  // torque, as the step stored them), so no normal is measured again.
  const double dt = run_.step > 0 ? run_.dt : 0.0;
  // Serial, in id order: the same digits whatever the thread count.
  particles_.for_each_id([&](Id, Index i) {
    for (Index e = lists_.wall_offset[i]; e < lists_.wall_offset[i + 1]; ++e) {
      if (!touching(law, contacts_.walls.overlap[e])) continue;
      const std::size_t w = std::size_t(lists_.wall_index[e]);
      const Vec3 f = vec3(contacts_.walls.force.data(), e);
      const Vec3 x = vec3(ps.x.data(), i) - dt * vec3(ps.v.data(), i);
      const Plane& wall = walls_.plane(int(w));
      const Vec3 center = wall.center - dt * wall.velocity;
      Vec3 on_sphere = (x - center).cross(f);
      if (!contacts_.walls.nxft.empty())
        on_sphere -= contact_lever(ps.radius[i], contacts_.walls.overlap[e]) * vec3(contacts_.walls.nxft.data(), e);
      if (!contacts_.walls.roll.empty()) on_sphere += ps.radius[i] * vec3(contacts_.walls.roll.data(), e);
      forces[w] -= f;
      torques[w] -= on_sphere;
    }
  });
}
}  // namespace tsubu
