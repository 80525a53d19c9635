// The domain the particles live in. Every difference of two particles' positions goes through
// Box::displacement, every position update through Box::wrap, and the cell grid takes its extent
// from Box::grid_extent, so that a periodic box (minimum image, wrapped positions, a grid over
// the box) replaces this one type and nothing else.
#pragma once
#include <cstddef>
#include <limits>

#include "contact/geometry.hpp"
#include "types.hpp"

namespace tsubu {

// Open space: nothing bounds or wraps the particles.
struct OpenBox {
  static constexpr bool periodic = false;

  // x_i - x_j, from j to i (positions as any Eigen expression: Maps into the particle arrays
  // most often, read without a copy).
  template <class A, class B>
  TSUBU_INLINE static Vec3 displacement(const Eigen::MatrixBase<A>& xi, const Eigen::MatrixBase<B>& xj) {
    return xi - xj;
  }
  // Brings positions back into the box (open: nothing to do).
  static void wrap(double*, std::size_t) {}
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

using Box = OpenBox;

}  // namespace tsubu
