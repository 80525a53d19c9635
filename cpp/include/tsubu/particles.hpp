// The spheres: structure-of-arrays state (state.hpp's ParticleStore) in an internal order that
// the neighbour list re-sorts by cell at every rebuild, and the map from each sphere's stable id
// to its index now. Everything outside the engine speaks in ids; arrays in "id order" list the
// spheres by increasing id.
//
// Ids are handed out in the order of addition and the map is an array indexed by id; the rest of
// the core asks only index(id), id(index) and the id-order helpers below, so that removing or
// migrating spheres (which leaves gaps in the ids) changes this type alone.
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
  // The arrays, internal order (the engine's passes read and write them through its views).
  ParticleStore& arrays() { return s_; }
  const ParticleStore& arrays() const { return s_; }

  // The internal index of the sphere with id `id`, and the id at index k.
  Index index(Id id) const { return index_of_[static_cast<std::size_t>(id)]; }
  Id id(Index k) const { return s_.id[static_cast<std::size_t>(k)]; }
  // Whether `id` names a sphere.
  bool has(Id id) const { return id >= 0 && static_cast<std::size_t>(id) < index_of_.size(); }
  // One past the largest id handed out (the size of an id-indexed table).
  std::size_t id_bound() const { return index_of_.size(); }

  // Appends n spheres (3n positions, n radii and materials; velocities and spins may be null),
  // their masses from the materials' densities: I = 2/5 m r^2 (1.3). Checks nothing: the
  // Simulation does. Returns the id of the first.
  Id add(std::size_t n, const double* positions, const double* radii, const int* materials,
         const double* velocities, const double* angular_velocities,
         const std::vector<Material>& table);
  // Capacity for `count` spheres in all.
  void reserve(std::size_t count);

  // Checkpoints: the spheres in id order (position, velocity, spin, radius, material,
  // dissipated energy). restore() fills an empty Particles (masses from `table`, as add() does)
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
    for (std::size_t k = 0; k < n_; ++k) out[s_.id[k]] = src[k];
  }

  // Puts the spheres in the order perm (sphere perm[k] to index k) and updates the map.
  void permute(const Array<Index>& perm, Array<double>& scratch);

  // Per material (of `materials`): the lightest sphere's mass and the smallest radius; infinity
  // for a material no sphere has.
  void extremes(std::size_t materials, std::vector<double>& lightest, std::vector<double>& smallest) const;
  // The sum of the radii (the default skin is taken from their mean).
  double radius_sum() const;

  std::size_t bytes() const;

 private:
  std::size_t n_ = 0;
  ParticleStore s_;
  Array<Index> index_of_;  // id -> internal index
};

}  // namespace tsubu
