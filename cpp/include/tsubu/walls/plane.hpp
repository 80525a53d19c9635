// A plane wall a x + b y + c z + d = 0 (3.1-3.2), stored as a point and a unit normal pointing to
// the side where spheres live. It translates with `velocity` and rotates with `angular_velocity`
// about `center` (by default its point: a box of planes sharing one centre turns as one body).
// The same record holds a mesh wall's motion (mesh.hpp), and the contact pass's tangent plane
// at a mesh contact (the plane through the nearest point of a triangle, with the mesh's motion).
//
// A wall model answers, for a sphere: the gap and the normal (distance, normal_at), the contact
// point and the wall's velocity there (velocity_at), and whether the sphere is near enough to
// need a near-wall entry (near). The neighbour lists and the contact pass ask only these.
#pragma once
#include <Eigen/Geometry>

#include "../types.hpp"

namespace tsubu {

struct Plane {
  Vec3 point = Vec3::Zero();
  Vec3 normal = Vec3(0, 0, 1);
  Vec3 velocity = Vec3::Zero();
  Vec3 angular_velocity = Vec3::Zero();
  Vec3 center = Vec3::Zero();
  int material = 0;

  bool moving() const { return velocity.squaredNorm() > 0 || angular_velocity.squaredNorm() > 0; }

  // Signed distance of x from the plane along direction `dir` (the normal, or a rough facet's
  // tilted normal), positive on the spheres' side (3.1). (Positions come as any Eigen
  // expression, a Map into the particle arrays most often: no copy to a Vec3 first.)
  template <class X>
  TSUBU_INLINE double distance(const Eigen::MatrixBase<X>& x, const Vec3& dir) const {
    return dir.dot(x - point);
  }
  template <class X>
  TSUBU_INLINE double distance(const Eigen::MatrixBase<X>& x) const { return distance(x, normal); }
  // Overlap of a sphere of radius r at x, r - distance (3.1): signed, the plane is a half-space.
  template <class X>
  TSUBU_INLINE double overlap(const Eigen::MatrixBase<X>& x, double r) const { return r - distance(x); }
  // The normal at the point of the wall nearest x (a plane: everywhere the same).
  template <class X>
  TSUBU_INLINE const Vec3& normal_at(const Eigen::MatrixBase<X>&) const { return normal; }
  // The contact point of a sphere at x: lever c back along the normal n.
  TSUBU_INLINE static Vec3 contact_point(const Vec3& x, double c, const Vec3& n) { return x - c * n; }
  // The wall's velocity at point y.
  TSUBU_INLINE Vec3 velocity_at(const Vec3& y) const {
    return velocity + angular_velocity.cross(y - center);
  }
  // Whether a sphere of radius r at x is within `reach` of touching (or behind the plane).
  template <class X>
  TSUBU_INLINE bool near(const Eigen::MatrixBase<X>& x, double r, double reach) const {
    return distance(x) < r + reach;
  }

  // One step of the wall's motion.
  void advance(double dt) {
    point += dt * velocity;
    center += dt * velocity;
    const double angle = angular_velocity.norm() * dt;
    if (angle > 0) {
      const Eigen::AngleAxisd turn(angle, angular_velocity.normalized());
      normal = turn * normal;
      normal.normalize();
      if (point != center) point = center + turn * (point - center);
    }
  }
  // How far the signed distance of any point within `reach` of the reference point p0 can have
  // changed since the plane stood at (p0, n0): |n.(p - p0)| + |n - n0| reach.
  double shift_since(const Vec3& p0, const Vec3& n0, double reach) const {
    return std::abs(normal.dot(point - p0)) + (normal - n0).norm() * reach;
  }
};

}  // namespace tsubu
