// The Love–Weber stress of the owned spheres (docs/stress.md): Simulation::stress.
//
// Each sphere's bracket  -m v' (x) v' + sum_c (x_c - x_i) (x) f_c  is summed over its entries
// in the order the particle pass takes them (its wall entries, the pairs it owns by partner id,
// the pairs where it is the partner by owner id; a ghost partner's share goes to its source),
// and the total over the spheres in id order: the same bits for any thread count.
#include <algorithm>
#include <cmath>
#include <string>
#include <vector>

#include "tsubu/contact/geometry.hpp"
#include "tsubu/simulation.hpp"

namespace tsubu {

namespace {
// out += a (x) b, row-major.
inline void add_outer(double* out, const Vec3& a, const Vec3& b) {
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 3; ++c) out[3 * r + c] += a[r] * b[c];
}
}  // namespace

void Simulation::stress(double volume, const MeanFlow& flow, double* sigma, double* per_particle) const {
  if (!(std::isfinite(volume) && volume > 0))
    throw InvalidArgument("stress: volume must be finite and positive (m^3), got " + std::to_string(volume));
  if (!std::isfinite(flow.rate) || !std::isfinite(flow.reference))
    throw InvalidArgument("stress: the mean flow's rate and reference must be finite");
  if (flow.flow < 0 || flow.flow > 2 || flow.gradient < 0 || flow.gradient > 2 ||
      (flow.rate != 0 && flow.flow == flow.gradient))
    throw InvalidArgument("stress: the mean flow's axes must be two different axes 0, 1, 2");

  const ParticleStore& ps = particles_.arrays();
  const std::size_t n = particles_.size();
  const double* x = ps.x.data();
  const double* v = ps.v.data();
  const CompiledLaw& law = this->law();
  const bool lists = ran_ && lists_.near_offset.size() == n + 1 && lists_.near_rev_offset.size() == n + 1 &&
                     lists_.wall_offset.size() == n + 1;
  if (lists) measure_walls_now();

  // A pair entry's share of sphere `row`'s bracket: the owner's (x_c - x_i) (x) f, the
  // partner's (x_c - x_j) (x) (-f), with x_c splitting the branch vector x_i - x_j at the
  // levers' ratio (so that the two shares add to -(x_i - x_j) (x) f, to round-off).
  auto pair_share = [&](double* out, Index e, bool owner) {
    const Index i = lists_.near_owner[e], j = lists_.near_partner[e];
    const double delta = contacts_.pairs.overlap[e];
    const double ci = contact_lever(ps.radius[i], delta), cj = contact_lever(ps.radius[j], delta);
    const double s = ci / (ci + cj);
    const Vec3 branch = vec3(x, i) - vec3(x, j);  // (a ghost partner: its image, the minimum one)
    const Vec3 f = vec3(contacts_.pairs.force.data(), e);
    if (owner) add_outer(out, -s * branch, f);
    else add_outer(out, (1 - s) * branch, -f);
  };

  // Each sphere's bracket, computed in index order (memory order; on the run's threads), then
  // the total over the spheres in id order: the same additions as a walk in id order, so the
  // same bits.
  auto bracket = [&](Index i, double* out) {
    double b[9] = {0, 0, 0, 0, 0, 0, 0, 0, 0};  // (a local: kept in registers, not in `out`)
    if (lists) {
      const Vec3 xi = vec3(x, i);
      for (Index e = lists_.wall_offset[i]; e < lists_.wall_offset[i + 1]; ++e) {
        if (!touching(law, contacts_.walls.overlap[e])) continue;
        add_outer(b, wall_point_now(i, e) - xi, vec3(contacts_.walls.force.data(), e));
      }
      for (Index e = lists_.near_offset[i]; e < lists_.near_offset[i + 1]; ++e)
        if (touching(law, contacts_.pairs.overlap[e])) pair_share(b, e, true);
      for (Index p = lists_.near_rev_offset[i]; p < lists_.near_rev_offset[i + 1]; ++p) {
        const Index e = lists_.near_rev[p];
        if (touching(law, contacts_.pairs.overlap[e])) pair_share(b, e, false);
      }
    }
    Vec3 vp = vec3(v, i);
    if (flow.rate != 0) vp[flow.flow] -= flow.rate * (x[3 * i + flow.gradient] - flow.reference);
    add_outer(b, -ps.mass[i] * vp, vp);
    std::copy(b, b + 9, out);
  };
  // The brackets go to their rows in id order (into `per_particle` where asked), so that the
  // total reads them in order: a walk in id order, reading at random, took longer than the
  // brackets themselves.
  std::vector<double> rows;
  double* out = per_particle;
  if (!out) {
    rows.resize(9 * n);
    out = rows.data();
  }
  const long ni = static_cast<long>(n);
#pragma omp parallel for schedule(static) num_threads(threads_used())
  for (long i = 0; i < ni; ++i)
    bracket(static_cast<Index>(i), out + 9 * particles_.rank(particles_.id(static_cast<Index>(i))));

  double total[9] = {0, 0, 0, 0, 0, 0, 0, 0, 0};
  for (std::size_t row = 0; row < n; ++row)
    for (int k = 0; k < 9; ++k) total[k] += out[9 * row + k];
  for (int k = 0; k < 9; ++k) sigma[k] = total[k] / volume;
}

}  // namespace tsubu
