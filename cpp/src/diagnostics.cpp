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

void Simulation::check_overlaps(bool all) const {
  const double tol = opt_.initial_overlap;
  const ParticleStore& a = particles_.arrays();
  auto x = [&](Index i) { return vec3(a.x.data(), i); };
  // After the first run only the changes are checked: slot[i] >= 0 for a sphere added or moved
  // since the last run (its entry in unchecked_), and walls from walls_checked_ on.
  std::vector<Index> slot;
  if (!all) {
    slot.assign(particles_.size(), -1);
    for (std::size_t k = 0; k < unchecked_.size(); ++k)
      if (particles_.has(unchecked_[k])) slot[static_cast<std::size_t>(particles_.index(unchecked_[k]))] = static_cast<Index>(k);
  }
  auto added = [&](Index i) { return slot[i] >= 0 && std::isnan(unchecked_from_[3 * slot[i]]); };
  // A sphere's centre at the last check.
  auto before = [&](Index i) -> Vec3 {
    return slot[i] >= 0 ? Vec3(vec3(unchecked_from_.data(), slot[i])) : Vec3(x(i));
  };
  // Which change to name: an added sphere, else a moved one, else (walls) the wall.
  auto what_changed = [&](Index i, Index j) -> std::string {
    for (Index k : {j, i})
      if (k >= 0 && added(k))
        return "; sphere " + std::to_string(a.id[k]) + " was added since the last run: move it clear (or raise initial_overlap)";
    for (Index k : {j, i})
      if (k >= 0 && slot[k] >= 0)
        return "; sphere " + std::to_string(a.id[k]) + " was moved since the last run: move it clear (or raise initial_overlap)";
    return "";
  };
  // Slack for rounding when a pack moves as a whole: its overlaps are not deeper.
  constexpr double kDeeper = 1e-6;
  for (Index i = 0; i < static_cast<Index>(particles_.size()); ++i) {
    for (Index e = lists_.pair_offset[i]; e < lists_.pair_offset[i + 1]; ++e) {
      const Index j = lists_.pair_partner[e];
      // A ghost partner stands for its source, at its image's place.
      const Index sj = domain_.source(j, particles_.size());
      const Vec3 image = Vec3(x(j)) - Vec3(x(sj));
      if (!all && slot[i] < 0 && slot[sj] < 0) continue;
      const double rmin = std::min(a.radius[i], a.radius[j]);
      const double ov = a.radius[i] + a.radius[j] - domain_.displacement(x(i), x(j)).norm();
      if (!(ov > tol * rmin)) continue;
      if (!all && !added(i) && !added(sj) &&
          ov <= a.radius[i] + a.radius[j] - domain_.displacement(before(i), Vec3(before(sj) + image)).norm() + kDeeper * rmin)
        continue;  // it overlapped as much before
      throw InvalidArgument("initial overlap: spheres " + std::to_string(a.id[i]) + " and " +
                            std::to_string(a.id[j]) + " overlap by " + fmt(ov) + " m (" + fmt(ov / rmin) +
                            " of the smaller radius; tolerance " + fmt(tol) + ")" +
                            (all ? "" : what_changed(i, sj)));
    }
    for (Index e = lists_.wall_offset[i]; e < lists_.wall_offset[i + 1]; ++e) {
      const int w = lists_.wall_index[e];
      const bool new_wall = !all && w >= walls_checked_;
      if (!all && slot[i] < 0 && !new_wall) continue;
      const Index element = lists_.wall_element[e];
      const double ov = walls_.overlap(x(i), a.radius[i], w, element);
      if (!(ov > tol * a.radius[i])) continue;
      if (!all && !new_wall && !added(i) &&
          ov <= walls_.overlap(before(i), a.radius[i], w, element) + kDeeper * a.radius[i])
        continue;
      throw InvalidArgument("initial overlap: sphere " + std::to_string(a.id[i]) + " overlaps wall " +
                            std::to_string(w) + " by " + fmt(ov) + " m (" + fmt(ov / a.radius[i]) +
                            " of its radius; tolerance " + fmt(tol) + ")" +
                            (all ? std::string()
                             : new_wall ? "; wall " + std::to_string(w) + " was added since the last run: move "
                                          "the spheres clear of it (or raise initial_overlap)"
                                        : what_changed(i, -1)));
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
