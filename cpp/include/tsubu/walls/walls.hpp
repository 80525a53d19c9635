// The scene's walls, of every kind. A wall kind (plane.hpp: Plane) answers for a sphere the gap
// and the normal, the contact point and the wall's velocity there, whether it is near, and how
// far the wall has moved since a reference; Walls holds the walls of each kind, their motion, and
// answers the neighbour list's queries: which walls (and which of a wall's elements: a triangle
// mesh has many, a plane one) lie within reach of a sphere, and whether the walls have moved far
// enough since the last rebuild to need another (docs/architecture.md, "Add a wall kind").
#pragma once
#include <cstddef>
#include <vector>

#include "../archive.hpp"
#include "../types.hpp"
#include "plane.hpp"

namespace tsubu {

// The wall kind the contact pass evaluates (ContactView::planes). Planes are the one kind today;
// a second kind (a triangle mesh) makes the pass dispatch on the kind of a near-wall entry here
// (docs/architecture.md, "Add a wall kind").
using Wall = Plane;

class Walls {
 public:
  int count() const { return static_cast<int>(planes_.size()); }
  // Appends a plane (its normal already unit length); returns its wall index.
  int add(const Plane& p);
  const Plane& plane(int wall) const { return planes_[static_cast<std::size_t>(wall)]; }
  // Replaces a wall's whole state (checkpoints) or its motion.
  void set(int wall, const Plane& p) { planes_[static_cast<std::size_t>(wall)] = p; }
  void set_motion(int wall, const Vec3& velocity, const Vec3& angular_velocity);
  const Plane* planes() const { return planes_.data(); }
  int material(int wall) const { return plane(wall).material; }

  // Checkpoints: every wall's whole state, bit for bit (a normal is not normalised again).
  // restore() fills an empty Walls and refuses non-finite values, normals that are not unit
  // length and materials outside [0, materials).
  void save(archive::Writer& w) const;
  void restore(archive::Reader& r, int materials);

  // Whether any wall moves (the contact pass then takes the wall's velocity at the contact).
  bool moving() const;
  // One step of every wall's motion.
  void advance(double dt);

  // Calls visit(wall, element) for each wall element within `reach` of touching a sphere of
  // radius r at x (or behind it), in increasing (wall, element) order.
  template <class X, class Visit>
  void for_each_near(const Eigen::MatrixBase<X>& x, double r, double reach, Visit&& visit) const {
    for (std::size_t w = 0; w < planes_.size(); ++w)
      if (planes_[w].near(x, r, reach)) visit(static_cast<Index>(w), Index(0));
  }
  // The gap between a sphere of radius r at x and a wall element (negative: overlap).
  template <class X>
  double gap(const Eigen::MatrixBase<X>& x, double r, Index wall, Index /*element*/) const {
    return planes_[static_cast<std::size_t>(wall)].distance(x) - r;
  }
  // The overlap of a sphere of radius r at x with a wall element.
  template <class X>
  double overlap(const Eigen::MatrixBase<X>& x, double r, Index wall, Index /*element*/) const {
    return planes_[static_cast<std::size_t>(wall)].overlap(x, r);
  }

  // Takes the walls' positions now as the reference of the rebuild criterion, for particles
  // inside the box [lo, hi].
  void mark(const Vec3& lo, const Vec3& hi);
  // Whether a wall has moved so far since mark() that, with particles moved by up to `moved`, a
  // sphere may have come within `skin` of it unlisted.
  bool moved_beyond(double moved, double skin) const;

  std::size_t bytes() const;

 private:
  std::vector<Plane> planes_;
  // The rebuild criterion's reference: each plane at the last mark(), and the largest distance
  // from a plane's point to the particles' box then.
  std::vector<Vec3> point_ref_, normal_ref_;
  double reach_ = 0;
};

}  // namespace tsubu
