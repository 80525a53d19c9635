// The checks of a scene before its first run and the reports of a run gone unstable.
#include "tsubu/simulation.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <string>
#include <vector>

#include "check.hpp"

namespace tsubu {

using detail::finite3;
using detail::fmt;
using detail::require;

// ---- checks and errors -------------------------------------------------------------------

void Simulation::check_initial_overlaps() const {
  const double tol = opt_.initial_overlap;
  for (std::size_t i = 0; i < particles_.size(); ++i) {
    for (Index e = lists_.pair_offset[i]; e < lists_.pair_offset[i + 1]; ++e) {
      const Index j = lists_.pair_partner[e];
      const double d = domain_.displacement(vec3(particles_.arrays().x.data(), i), vec3(particles_.arrays().x.data(), j)).norm();
      const double ov = particles_.arrays().radius[i] + particles_.arrays().radius[j] - d;
      if (ov > tol * std::min(particles_.arrays().radius[i], particles_.arrays().radius[j]))
        throw InvalidArgument("initial overlap: spheres " + std::to_string(particles_.arrays().id[i]) + " and " +
                              std::to_string(particles_.arrays().id[j]) + " overlap by " + fmt(ov) + " m (" +
                              fmt(ov / std::min(particles_.arrays().radius[i], particles_.arrays().radius[j])) +
                              " of the smaller radius; tolerance " + fmt(tol) + ")");
    }
    for (Index e = lists_.wall_offset[i]; e < lists_.wall_offset[i + 1]; ++e) {
      const Plane& p = walls_.plane(lists_.wall_index[e]);
      const double ov = p.overlap(vec3(particles_.arrays().x.data(), i), particles_.arrays().radius[i]);
      if (ov > tol * particles_.arrays().radius[i])
        throw InvalidArgument("initial overlap: sphere " + std::to_string(particles_.arrays().id[i]) + " overlaps wall " +
                              std::to_string(lists_.wall_index[e]) + " by " + fmt(ov) + " m (" +
                              fmt(ov / particles_.arrays().radius[i]) + " of its radius; tolerance " + fmt(tol) + ")");
    }
  }
}

void Simulation::report_overlap(double dt) const {
  // Error path only: find the worst offender serially (lowest id wins ties).
  double worst = -1;
  std::string what;
  Id who = -1;
  for (std::size_t i = 0; i < particles_.size(); ++i) {
    for (Index q = lists_.near_offset[i]; q < lists_.near_offset[i + 1]; ++q) {
      const Index j = lists_.near_partner[q];
      const double frac = contacts_.pairs.overlap[q] / std::min(particles_.arrays().radius[i], particles_.arrays().radius[j]);
      if (frac > worst || std::isnan(frac)) {
        worst = frac;
        who = particles_.arrays().id[i];
        what = "spheres " + std::to_string(particles_.arrays().id[i]) + " and " + std::to_string(particles_.arrays().id[j]);
      }
    }
    for (Index e = lists_.wall_offset[i]; e < lists_.wall_offset[i + 1]; ++e) {
      const double frac = contacts_.walls.overlap[e] / particles_.arrays().radius[i];
      if (frac > worst || std::isnan(frac)) {
        worst = frac;
        who = particles_.arrays().id[i];
        what = "sphere " + std::to_string(particles_.arrays().id[i]) + " and wall " + std::to_string(lists_.wall_index[e]);
      }
    }
  }
  throw InstabilityError(
      "unstable at step " + std::to_string(run_.step + 1) + " (t = " + fmt(run_.time + dt) + " s): " +
          what + " overlap by " + fmt(worst) + " of the smaller radius (limit " +
          fmt(opt_.max_overlap) +
          "); the time step is too large for the stiffness, or a particle moved too fast. "
          "The state before this step is kept.",
      run_.step + 1, who);
}

void Simulation::report_nonfinite() const {
  auto finite_entry = [](const Array<double>& a, std::size_t e) {
    return a.empty() || finite3(a.data() + 3 * e);
  };
  for (std::size_t i = 0; i < particles_.size(); ++i) {
    for (Index e = lists_.wall_offset[i]; e < lists_.wall_offset[i + 1]; ++e)
      if (!finite_entry(contacts_.walls.force, e) || !finite_entry(contacts_.walls.nxft, e) ||
          !finite_entry(contacts_.walls.roll, e))
        throw InstabilityError("unstable at step " + std::to_string(run_.step + 1) +
                                   ": non-finite contact force between sphere " +
                                   std::to_string(particles_.arrays().id[i]) + " and wall " +
                                   std::to_string(lists_.wall_index[e]) +
                                   ". The positions and velocities before this step are kept.",
                               run_.step + 1, particles_.arrays().id[i]);
    for (Index q = lists_.near_offset[i]; q < lists_.near_offset[i + 1]; ++q)
      if (!finite_entry(contacts_.pairs.force, q) || !finite_entry(contacts_.pairs.nxft, q) ||
          !finite_entry(contacts_.pairs.roll, q))
        throw InstabilityError("unstable at step " + std::to_string(run_.step + 1) +
                                   ": non-finite contact force between spheres " +
                                   std::to_string(particles_.arrays().id[i]) + " and " +
                                   std::to_string(particles_.arrays().id[lists_.near_partner[q]]) +
                                   ". The positions and velocities before this step are kept.",
                               run_.step + 1, particles_.arrays().id[i]);
  }
  throw InstabilityError("unstable: non-finite force", run_.step + 1, -1);
}

void Simulation::report_nonfinite_velocity() const {
  for (std::size_t k = 0; k < particles_.size(); ++k)
    if (!finite3(particles_.arrays().v.data() + 3 * k) || !finite3(particles_.arrays().w.data() + 3 * k))
      throw InstabilityError("unstable at step " + std::to_string(run_.step + 1) +
                                 ": non-finite velocity of sphere " + std::to_string(particles_.arrays().id[k]),
                             run_.step + 1, particles_.arrays().id[k]);
  throw InstabilityError("unstable: non-finite velocity", run_.step + 1, -1);
}
void Simulation::report_fast(double max_move) const {
  // Error path only: name the fastest sphere (lowest id wins ties); the velocities are those the
  // last step moved the spheres with.
  const ParticleStore& ps = particles_.arrays();
  double fastest = -1;
  std::size_t who = 0;
  for (std::size_t k = 0; k < particles_.size(); ++k) {
    const double v2 = vec3(ps.v.data(), k).squaredNorm();
    if (v2 > fastest || (v2 == fastest && ps.id[k] < ps.id[who])) fastest = v2, who = k;
  }
  const double speed = std::sqrt(fastest);
  throw InstabilityError(
      "unstable at step " + std::to_string(run_.step + 1) + " (t = " + fmt(run_.time + run_.dt) +
          " s): sphere " + std::to_string(ps.id[who]) + " moved " + fmt(run_.last_move) +
          " m in step " + std::to_string(run_.step) + " (at " + fmt(speed) + " m/s), more than " +
          fmt(max_move) +
          " m, the most a step may move a sphere for the overlap check to see the scene's two "
          "smallest spheres meet head on (r_a + r_b - max_overlap r_a): in steps that long "
          "spheres can pass through one another unseen. Use a dt below " + fmt(max_move / speed) +
          " s for this speed, or find what drove the sphere this fast (a dt above the stability "
          "bound, a velocity set by mistake). The state before step " + std::to_string(run_.step + 1) +
          " is kept.",
      run_.step + 1, ps.id[who]);
}

}  // namespace tsubu
