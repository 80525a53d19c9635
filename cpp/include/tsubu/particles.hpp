// The spheres: structure-of-arrays state (state.hpp's ParticleStore) in an internal order that
// the neighbour list re-sorts by cell at every rebuild, and the map from each sphere's stable id
// to its index now. Everything outside the engine speaks in ids; arrays in "id order" list the
// spheres by increasing id (row rank(id)).
//
// Ids are handed out in the order of addition and never reused. A removed sphere leaves a gap:
// ids then need not be 0..N-1, and the rows of id-order arrays follow rank(id). The rest of the
// core asks only index(id), id(index), has(id), rank(id) and for_each_id, so that migrating
// spheres between processes changes this type alone.
#pragma once
#include <cstddef>
#include <vector>

#include "archive.hpp"
#include "material.hpp"
#include "memory.hpp"
#include "state.hpp"
#include "types.hpp"

namespace tsubu {

class Particles {
 public:
  std::size_t size() const { return n_; }
  // Ghost rows (a periodic box's images, domain.hpp) after the owned rows of the arrays; they
  // are not spheres of their own: size(), ids and everything in id order ignore them.
  std::size_t ghosts() const { return g_; }
  void set_ghosts(std::size_t g) { g_ = g; }
  // Keeps image counters and slides from now on (a periodic box), zero for every sphere.
  void keep_images() {
    if (s_.imaged) return;
    s_.image.assign(3 * (n_ + g_), 0);
    s_.slid.assign(n_ + g_, 0.0);
    s_.imaged = true;
  }
  void drop_ghosts() {
    if (g_ == 0) return;
    s_.for_each_field([&](auto& a, int width) { a.resize(width * n_); });
    g_ = 0;
  }
  // The arrays, internal order (the engine's passes read and write them through its views).
  ParticleStore& arrays() { return s_; }
  const ParticleStore& arrays() const { return s_; }

  // The internal index of the sphere with id `id`, and the id at index k.
  Index index(Id id) const { return index_of_[static_cast<std::size_t>(id)]; }
  Id id(Index k) const { return s_.id[static_cast<std::size_t>(k)]; }
  static constexpr Index kGone = -1;  // index_of_ of a removed sphere's id
  // Whether `id` names a sphere.
  bool has(Id id) const {
    return id >= 0 && static_cast<std::size_t>(id) < index_of_.size() &&
           index_of_[static_cast<std::size_t>(id)] != kGone;
  }
  // One past the largest id handed out (the size of an id-indexed table).
  std::size_t id_bound() const { return index_of_.size(); }
  // Whether the ids are exactly 0..N-1 (no sphere was removed).
  bool dense() const { return n_ == index_of_.size(); }
  // The row of sphere `id` in arrays in id order: the number of spheres with a lower id.
  std::size_t rank(Id id) const {
    return dense() ? static_cast<std::size_t>(id) : static_cast<std::size_t>(rank_of_[static_cast<std::size_t>(id)]);
  }
  // Calls f(id, index) for every sphere, by increasing id.
  template <class F>
  void for_each_id(F&& f) const {
    for (std::size_t id = 0; id < index_of_.size(); ++id)
      if (index_of_[id] != kGone) f(static_cast<Id>(id), index_of_[id]);
  }

  // Appends n spheres (3n positions, n radii and materials; velocities and spins may be null),
  // their masses from the materials' densities: I = 2/5 m r^2 (1.3). Checks nothing: the
  // Simulation does. Returns the id of the first.
  Id add(std::size_t n, const double* positions, const double* radii, const int* materials,
         const double* velocities, const double* angular_velocities,
         const std::vector<Material>& table);
  // Appends n spheres with the given ids (each neither present nor repeated; the Simulation
  // checks): a sphere that comes back, with the id it had, as a domain decomposition's halo
  // brings its neighbours' spheres in (docs/parallel.md). Masses as add().
  void insert(std::size_t n, const Id* ids, const double* positions, const double* radii,
              const int* materials, const double* velocities, const double* angular_velocities,
              const std::vector<Material>& table);
  // Capacity for `count` spheres in all.
  void reserve(std::size_t count);
  // Removes the spheres with the given ids (each present, each once; the Simulation checks).
  // The others keep their ids, their internal order and their state.
  void remove(const Id* ids, std::size_t count);

  // Checkpoints: the spheres in id order (id, position, velocity, spin, radius, material,
  // dissipated energy); the ids after a removal are kept as they were. restore() fills an empty Particles (masses from `table`, as add() does)
  // and refuses non-finite values, radii <= 0 and unknown materials.
  void save(archive::Writer& w) const;
  void restore(archive::Reader& r, const std::vector<Material>& table);

  // Copies a per-sphere 3-vector array from internal order to id order, and back (the latter
  // refusing non-finite values, naming the sphere).
  void gather(const double* src, double* out) const;
  void scatter(const double* in, double* dst) const;
  // A per-sphere scalar in id order.
  template <class T, class A>
  void gather_scalar(const A& src, T* out) const {
    for (std::size_t k = 0; k < n_; ++k) out[rank(s_.id[k])] = src[k];
  }

  // Puts the spheres in the order perm (sphere perm[k] to index k) and updates the map.
  void permute(const Array<Index>& perm, Array<double>& scratch, int threads = 1);

  // Per material (of `materials`): the lightest sphere's mass and the smallest radius; infinity
  // for a material no sphere has.
  void extremes(std::size_t materials, std::vector<double>& lightest, std::vector<double>& smallest) const;
  // The sum of the radii (the default skin is taken from their mean).
  double radius_sum() const;

  std::size_t bytes() const;

 private:
  std::size_t n_ = 0;
  std::size_t g_ = 0;  // ghost rows
  ParticleStore s_;
  Array<Index> index_of_;  // id -> internal index, kGone for a removed sphere
  Array<Index> rank_of_;   // id -> row in id order; only once a sphere was removed (!dense())
  void rank_ids();         // rank_of_ from index_of_
};

}  // namespace tsubu
