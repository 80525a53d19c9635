// Basic types shared by every part of the core.
#pragma once
#include <Eigen/Core>
#include <Eigen/Geometry>
#include <cmath>
#include <cstdint>
#include <stdexcept>
#include <string>

// Contact evaluators are small and called once per contact per step: always inline them into
// the loop (gcc otherwise keeps the larger ones out of line, behind a call).
#if defined(__GNUC__)
#define TSUBU_INLINE inline __attribute__((always_inline))
#else
#define TSUBU_INLINE inline
#endif

namespace tsubu {

using Vec3 = Eigen::Vector3d;
using Index = std::int32_t;   // internal (sorted) particle index
using Id = std::int64_t;      // stable particle id: the order in which spheres were added

// Particle state is stored as flat xyz-interleaved arrays (one array per quantity); these views
// read and write one particle's triple without copying.
inline Eigen::Map<Vec3> vec3(double* a, std::size_t i) { return Eigen::Map<Vec3>(a + 3 * i); }
inline Eigen::Map<const Vec3> vec3(const double* a, std::size_t i) {
  return Eigen::Map<const Vec3>(a + 3 * i);
}

// a b + c, rounded once where the CPU fuses multiply-adds, twice where it does not. The build
// never contracts a*b+c on its own (-ffp-contract=off), so that the scalar and the vectorised
// form of a law agree bit for bit; the laws' lane arithmetic (contact/geometry.hpp) asks for
// the fused form here, explicitly, in both.
TSUBU_INLINE double mul_add(double a, double b, double c) {
#ifdef __FP_FAST_FMA
  return std::fma(a, b, c);
#else
  return a * b + c;
#endif
}

// Thrown for bad arguments from C++ callers (the Python layer checks first and names arguments).
struct InvalidArgument : std::invalid_argument {
  using std::invalid_argument::invalid_argument;
};

// Thrown, before anything is allocated or changed, for a request that cannot fit in memory
// (the Python layer raises MemoryError with the message).
struct ResourceError : std::runtime_error {
  using std::runtime_error::runtime_error;
};

// Thrown when a run becomes unstable (non-finite values, excessive overlap). The state of the
// step before the failing one is left in place.
struct InstabilityError : std::runtime_error {
  InstabilityError(const std::string& what, long step, Id particle)
      : std::runtime_error(what), step(step), particle(particle) {}
  long step;
  Id particle;
};

}  // namespace tsubu
