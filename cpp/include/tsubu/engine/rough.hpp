// Rough contacts (docs/roughness.md): the geometry of a contact whose normal is tilted at first
// touch, for pairs and for walls. The state of an entry (StochasticRoughness::state_width values):
// walls: tilt vector (3), facet offset h, first-touch step; pairs: tilted normal n' (3; zero once
// enduring), facet offset H, first-touch step, spin term S.
#pragma once
#include <algorithm>
#include <cmath>
#include <type_traits>

#include "../contact/roughness.hpp"
#include "../walls/walls.hpp"
#include "common.hpp"

namespace tsubu::detail {

template <class Law>
struct Rough {
  // A rough contact older than two contact durations is an enduring contact, not an impact: its
  // tilt is dropped, so spheres at rest do not roll down virtual facets.
  static bool enduring(const PairParams& p, const ContactScale& s, const double* st,
                       std::uint64_t step, double dt) {
    if (st[0] == 0 && st[1] == 0 && st[2] == 0) return false;
    return (double(step) - st[4]) * dt > 2.0 * Law::contact_duration(p, s);
  }

  // Rough pair: at first touch a tilted normal n' is drawn and frozen for the impact, and the
  // spheres meet a virtual facet across it: the overlap is measured along n',
  // delta' = H - n'.x_ij + S, where S integrates the spin part of the contact points' approach,
  // so that d(delta')/dt = -n'.v_cp and the normal spring keeps its energy. An enduring contact
  // (older than 2 t_c) turns back to the line of centres with the overlap kept:
  // delta' = delta + H. Returns n' (n once enduring) and sets delta' (<= 0: no contact).
  static Vec3 pair(const PairParams& p, const Vec3& n, const Vec3& xij, double delta,
                   const Vec3& vrel, const Vec3& spin, const ContactScale& scale, bool active, double* st,
                   const ContactStream& stream, double dt, double& overlap) {
    if (!active) {
      const Vec3 tilt = draw_tilt(p, n, vrel, false, stream);
      const Vec3 np = std::sqrt(1.0 - tilt.squaredNorm()) * n + tilt;
      std::copy(np.data(), np.data() + 3, st);
      st[3] = std::min(delta, -vrel.dot(np) * dt) + np.dot(xij);  // H: starts at <= one step
      st[4] = double(stream.step);
      st[5] = 0.0;
    } else if (!(st[0] == 0 && st[1] == 0 && st[2] == 0) && enduring(p, scale, st, stream.step, dt)) {
      const double current = st[3] - Eigen::Map<const Vec3>(st).dot(xij) + st[5];
      std::fill(st, st + 3, 0.0);
      st[3] = current - delta;
    }
    if (st[0] == 0 && st[1] == 0 && st[2] == 0) {  // enduring: back on the line of centres
      overlap = delta + st[3];
      return n;
    }
    const Vec3 np = Eigen::Map<const Vec3>(st);
    // The spin part of the last step's approach, with the spins that moved the spheres (as the
    // positions were moved with the new velocities: symplectic, not explicit, Euler).
    if (active) st[5] += np.dot(spin) * dt;
    overlap = st[3] - np.dot(xij) + st[5];
    return np;
  }

  // The virtual overlap of a rough pair entry (for the energy lost when it opens).
  static double pair_overlap(const double* st, const Vec3& xij, double delta) {
    if (st[0] == 0 && st[1] == 0 && st[2] == 0) return delta + st[3];
    return st[3] - Eigen::Map<const Vec3>(st).dot(xij) + st[5];
  }

  // Rough wall: the sphere meets a virtual plane (a facet) tilted by dG, fixed to the wall at
  // offset h (n'.(y - p) = h), placed at first touch so that the sphere penetrates it by at
  // most one step of approach. On entry n is the wall normal and delta the real overlap; on
  // exit they are the facet's normal and overlap (<= 0: no contact).
  static void wall(const PairParams& p, const Wall& P, const Vec3& x, double r, const Vec3& vrel,
                   const ContactScale& scale, bool active, double* st, const ContactStream& stream, double dt,
                   Vec3& n, double& delta) {
    if (!active) {
      // A facet contact starts when the sphere touches the real wall while approaching it.
      // (st[5] is unused for walls.)
      if (delta <= 0 || vrel.dot(n) >= 0) {
        delta = 0;
        return;
      }
      const Vec3 tilt = draw_tilt(p, n, vrel, true, stream);
      std::copy(tilt.data(), tilt.data() + 3, st);
      st[4] = double(stream.step);
      const Vec3 np = tilted_normal(n, st);
      const double start = std::min(delta, -vrel.dot(np) * dt);
      st[3] = P.distance(x, np) - r + start;
    } else if (enduring(p, scale, st, stream.step, dt)) {
      // Settle onto a facet parallel to the wall, with the overlap (and energy) unchanged.
      const Vec3 old = tilted_normal(n, st);
      const double overlap = r - (P.distance(x, old) - st[3]);
      std::fill(st, st + 3, 0.0);
      st[3] = P.distance(x, n) - r + overlap;
    }
    const Vec3 np = tilted_normal(n, st);
    delta = r - (P.distance(x, np) - st[3]);
    n = np;
  }
};

}  // namespace tsubu::detail
