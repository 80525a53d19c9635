// The engine's state stores: per-particle arrays and per-entry contact state, each declared once
// in a field table that resizes, reserves, permutes and counts bytes for all of them together.
// A new per-particle quantity is one line in ParticleStore::fields.
#pragma once
#include <array>
#include <cstdint>
#include <cstring>
#include <type_traits>

#include "memory.hpp"
#include "types.hpp"

namespace tsubu {

// Particles, structure of arrays, in the internal order (re-sorted by cell at each rebuild).
struct ParticleStore {
  Array<double> x, v, w;  // position, velocity, angular velocity: xyz interleaved
  Array<double> radius, mass, inv_mass, inv_inertia;
  Array<double> dissipated;  // energy lost in the contacts this particle owns, J
  Array<int> material;
  Array<Id> id;  // stable id (order of addition) of the particle at each index
  // A periodic box (domain.hpp): the images crossed along each axis, and the distance slid along
  // the flow across Lees–Edwards faces, so that x + image L + slid is the unwrapped position.
  // Kept only once a scene has had a box (`imaged`): other scenes neither hold nor move them.
  Array<int> image;
  Array<double> slid;
  bool imaged = false;

  // The field table: every array with the number of values it holds per particle.
  template <class S, class F>
  static void fields(S& s, F&& f) {
    f(s.x, 3), f(s.v, 3), f(s.w, 3);
    f(s.radius, 1), f(s.mass, 1), f(s.inv_mass, 1), f(s.inv_inertia, 1), f(s.dissipated, 1);
    f(s.material, 1), f(s.id, 1);
    if (s.imaged) f(s.image, 3), f(s.slid, 1);
  }
  template <class F>
  void for_each_field(F&& f) { fields(*this, f); }
  template <class F>
  void for_each_field(F&& f) const { fields(*this, f); }

  // Capacity for n particles, exactly.
  void reserve(std::size_t n) {
    for_each_field([&](auto& a, int width) { a.reserve(width * n); });
  }
  // Capacity for n particles in all: a large batch gets exact capacity (doubling would keep up
  // to 2x the memory per particle), many small ones grow geometrically.
  void grow(std::size_t n) {
    for_each_field([&](auto& a, int width) {
      const std::size_t need = width * n;
      if (need > a.capacity()) a.reserve(std::max(need, a.capacity() + a.capacity() / 2));
    });
  }
  // a[k] = a[perm[k]] for every field, one component at a time through a scratch of n values,
  // so that no array is duplicated and every array keeps its exact capacity; on `threads`
  // threads where `threads` > 1 (the rows shared between them).
  void permute(const Array<Index>& perm, Array<double>& scratch, int threads = 1) {
    scratch.resize(perm.size());
#pragma omp parallel num_threads(threads) if (threads > 1)
    for_each_field([&](auto& a, int width) { permute_one(a, perm, width, scratch); });
  }
  std::size_t bytes() const {
    std::size_t b = 0;
    for_each_field([&](const auto& a, int) {
      b += a.capacity() * sizeof(typename std::decay_t<decltype(a)>::value_type);
    });
    return b;
  }

  // (Inside a parallel region or not: the loops are shared with `omp for`, whose ends are
  // the barriers between the gather into the scratch and the scatter back. `scratch` holds
  // perm.size() values.)
  template <class A>
  static void permute_one(A& a, const Array<Index>& perm, int width, Array<double>& scratch) {
    using T = typename A::value_type;
    static_assert(sizeof(T) <= sizeof(double) && std::is_trivially_copyable_v<T>);
    const long n = static_cast<long>(perm.size());
    for (int c = 0; c < width; ++c) {
#pragma omp for schedule(static)
      for (long k = 0; k < n; ++k) std::memcpy(&scratch[k], &a[width * perm[k] + c], sizeof(T));
#pragma omp for schedule(static)
      for (long k = 0; k < n; ++k) std::memcpy(&a[width * k + c], &scratch[k], sizeof(T));
    }
  }
};

// Which per-entry arrays a law needs, and their widths (values per entry; 0: no array).
struct EntryShape {
  int history = 0;   // the tangential history (ContactLaw::history_width)
  int moment = 0;    // n x F_t (or, rough pairs, n x F): 3 where the law has torque from it
  int rolling = 0;   // the rolling-resistance vector
  int rough = 0;     // the roughness state (StochasticRoughness::state_width)
};

// Contact state of one kind of entry (near pairs, or near walls), per entry; zero while the
// entry does not touch. The field table lists the arrays a refresh carries from the old list to
// the new one.
struct EntryStore {
  Array<double> xi;       // tangential history
  Array<double> overlap;  // geometric overlap, m (> 0 while touching)
  Array<double> force;    // contact force on the owner, N
  Array<double> nxft;     // n x F_t
  Array<double> roll;     // rolling-resistance vector
  Array<double> rough;    // roughness state
  Array<std::uint8_t> touch;  // 1 while touching (as overlap > 0; a byte is 8x cheaper to stream)

  static constexpr std::size_t kFields = 6;
  // The carried arrays, in a fixed order: history first, overlap second.
  std::array<Array<double>*, kFields> carried() { return {&xi, &overlap, &force, &nxft, &roll, &rough}; }
  std::array<const Array<double>*, kFields> carried() const {
    return {&xi, &overlap, &force, &nxft, &roll, &rough};
  }
  static std::array<int, kFields> widths(const EntryShape& s) {
    return {s.history, 1, 3, s.moment, s.rolling, s.rough};
  }
  std::size_t bytes() const {
    std::size_t b = touch.capacity();
    for (const Array<double>* a : carried()) b += a->capacity() * sizeof(double);
    return b;
  }
};

}  // namespace tsubu
