// The domain the particles live in. Every difference of two particles' positions goes through
// Domain::displacement, every position update through Domain::wrap, the cell grid takes its
// extent from Domain::grid_extent and the gravitational energy its positions from
// Domain::unwrapped, so that a periodic box (minimum image, wrapped positions with integer image
// counters, a Lees-Edwards offset, a grid over the box) replaces this one type, and an MPI
// sub-domain later extends it (docs/architecture.md, "Add a boundary").
#pragma once
#include <cstddef>
#include <limits>

#include "contact/geometry.hpp"
#include "types.hpp"

namespace tsubu {

// Open space: nothing bounds or wraps the particles.
struct Domain {
  static constexpr bool periodic = false;

  // x_i - x_j, from j to i (positions as any Eigen expression: Maps into the particle arrays
  // most often, read without a copy).
  template <class A, class B>
  TSUBU_INLINE static Vec3 displacement(const Eigen::MatrixBase<A>& xi, const Eigen::MatrixBase<B>& xj) {
    return xi - xj;
  }
  // Brings positions back into the box (open: nothing to do; a periodic box also counts the
  // images crossed).
  static void wrap(double*, std::size_t) {}
  // The position of particle k as if it had never been wrapped (open: the position itself): what
  // the gravitational energy and displacements over time are measured with.
  template <class X>
  static Vec3 unwrapped(const Eigen::MatrixBase<X>& x, std::size_t /*k*/) {
    return x;
  }
  // The region the cell grid must cover: the bounding box of the n positions x.
  static void grid_extent(const double* x, std::size_t n, Vec3& lo, Vec3& hi) {
    lo = Vec3::Constant(std::numeric_limits<double>::infinity());
    hi = -lo;
    for (std::size_t k = 0; k < n; ++k) {
      lo = lo.cwiseMin(Vec3(vec3(x, k)));
      hi = hi.cwiseMax(Vec3(vec3(x, k)));
    }
  }
};

}  // namespace tsubu
