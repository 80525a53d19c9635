// A triangle-mesh wall (docs/geometry.md): a rigid body of triangles that spheres touch on either
// side, at a face, an edge or a vertex, whichever is nearest (Ericson, Real-Time Collision
// Detection, 2005, section 5.1.5, the Voronoi regions of a triangle).
//
// The vertices are kept in the body frame (where they were given) and the mesh moves as a rigid
// body: a point X of the body is at center + R (X - center0) in the world. Queries take a sphere
// into the body frame instead of moving the vertices, so a moving mesh costs nothing per vertex
// and its bins never change. Triangles are binned in a sparse grid of cells (body frame), so a
// query costs the triangles near the sphere, not the mesh's size.
//
// Connectivity is through shared vertices: vertices at the same coordinates are one vertex
// (canonical index, the lowest), so an STL file's separate copies join. Walls::measure uses it to
// hide the contacts a smooth surface must not have (docs/geometry.md, "Contact with triangles").
#pragma once
#include <Eigen/Geometry>
#include <array>
#include <cmath>
#include <cstdint>
#include <vector>

#include "../archive.hpp"
#include "../types.hpp"

namespace tsubu {

// The part of a triangle nearest a point: its face, an edge (two canonical vertex indices, a < b)
// or a vertex (a).
struct MeshFeature {
  enum Kind : std::int8_t { kFace = 0, kEdge = 1, kVertex = 2 };
  std::int8_t kind = kFace;
  Index a = -1, b = -1;
  bool operator==(const MeshFeature& o) const { return kind == o.kind && a == o.a && b == o.b; }
};

// A sphere centre's nearest point on one triangle: the tangent plane there (a face: the
// triangle's plane through its first vertex; an edge or vertex: the plane through the point,
// normal to the line from it to the centre) and its distance along the normal.
struct MeshPoint {
  Vec3 point, normal;
  double distance = 0;
  MeshFeature feature;
};

class Mesh {
 public:
  using Face = std::array<Index, 3>;

  Mesh() = default;
  // Vertices (world frame, now) and faces (indices into them); center: the body's reference
  // point (its centre of rotation). Checks are the caller's (Simulation::add_mesh).
  Mesh(std::vector<Vec3> vertices, std::vector<Face> faces, const Vec3& center);

  Index triangles() const { return static_cast<Index>(faces_.size()); }
  Index vertices() const { return static_cast<Index>(body_.size()); }
  const std::vector<Face>& faces() const { return faces_; }
  // The vertices where the mesh is now (world frame).
  std::vector<Vec3> world_vertices() const;
  // The canonical index of vertex v (the lowest index at the same coordinates).
  Index canonical(Index v) const { return canon_[static_cast<std::size_t>(v)]; }
  // Whether triangles s and t share a vertex.
  bool adjacent(Index s, Index t) const;
  // Whether triangle t has the feature's vertices (all of them).
  bool has(Index t, const MeshFeature& f) const;
  // The triangle's unit normal (world frame), by the right-hand rule on its vertex order.
  Vec3 face_normal(Index t) const {
    const Vec3& n = tri_[static_cast<std::size_t>(t)].n;
    return moved_ ? Vec3(rotation_ * n) : n;
  }

  // The nearest point of triangle t to x (world frame).
  MeshPoint nearest(const Vec3& x, Index t) const;
  // Whether triangle t certainly does not reach a sphere of radius r at x (a cheap lower bound
  // on their distance: the triangle's plane, and the circle about its centroid that holds it);
  // if so, `normal` is its face normal turned to x's side (world frame) and `lower` that bound.
  bool clear_of(const Vec3& x, double r, Index t, Vec3& normal, double& lower) const;
  // Distance from x to triangle t (for the lists' gap: the sphere's radius is the caller's).
  double distance(const Vec3& x, Index t) const { return nearest_body(to_body(x), t).distance; }

  // Flat patches (Walls::measure_patch): whether x lies over the inside of triangle t's face,
  // each barycentric coordinate of its projection above kInside (a margin far beyond what
  // rounding or a coplanar neighbour's tilt could move across an edge).
  static constexpr double kInside = 1e-9;
  bool over_face(const Vec3& x, Index t) const;
  // How far a point may move from x and still lie over triangle t's face as over_face() asks:
  // half the distance from x's projection to the nearest edge, where it lies well inside (each
  // barycentric coordinate above 1e-6); else 0, and 0 for a mesh that has moved (its body frame
  // is not the world's).
  double face_room(const Vec3& x, Index t) const;
  // Whether the triangles tris[0, n) are one flat sheet around x out to `reach`: all in one
  // plane (normals within 1e-12 of each other, up to sign, and every corner within 1e-10 of the
  // sheet's size of the first's plane), every edge of theirs that comes within `reach` of x
  // shared by exactly two of them, and no two overlapping. Then, while a sphere centre stays where only these
  // triangles can reach it, its one contact with them is a face contact of the triangle it
  // lies over, or sits on an edge or corner between them (docs/geometry.md, "Flat patches").
  bool flat_sheet(const Vec3& x, double reach, const Index* tris, int n) const;

  // Calls visit(t) for each triangle t within r + reach of x, in increasing t.
  template <class Visit>
  void for_each_near(const Vec3& x, double r, double reach, Visit&& visit) const {
    const Vec3 X = to_body(x);
    std::vector<Index>& found = scratch();
    candidates(X, r + reach, found);
    // (The distance to a triangle's plane is a lower bound on the distance to the triangle:
    // most candidates are told by it, without the nearest point; the margin covers rounding.)
    const double bound = (r + reach) * (1.0 + 1e-9);
    for (Index t : found)
      if (std::abs(tri_[std::size_t(t)].n.dot(X - tri_[std::size_t(t)].a)) < bound &&
          nearest_body(X, t).distance < r + reach)
        visit(t);
  }

  // The body's pose: one step of rigid motion with the wall's velocity and angular velocity
  // (center moves with the velocity and the body turns about it).
  void advance(double dt, const Vec3& velocity, const Vec3& angular_velocity);
  const Vec3& center() const { return center_; }
  // Moves the centre of rotation to c; the body does not move.
  void set_center(const Vec3& c);
  // How far any point of the body within `reach` of the reference centre can have moved since
  // the pose (c0, q0).
  // (Orientations are kept as plain (w, x, y, z): an Eigen quaternion's alignment differs
  // between translation units built for different instruction sets.)
  using Orientation = std::array<double, 4>;
  double shift_since(const Vec3& c0, const Orientation& q0, double reach) const;
  const Orientation& orientation() const { return orientation_; }

  std::size_t bytes() const;
  void save(archive::Writer& w) const;
  static Mesh restore(archive::Reader& r);

 private:
  Vec3 to_body(const Vec3& x) const { return moved_ ? Vec3(center0_ + rotation_.transpose() * (x - center_)) : x; }
  Vec3 to_world(const Vec3& X) const { return moved_ ? Vec3(center_ + rotation_ * (X - center0_)) : X; }
  MeshPoint nearest_body(const Vec3& X, Index t) const;
  // X's barycentric coordinates in triangle t (body frame), each times `whole` (u: a's, v: b's,
  // w: c's), and the squares of the edges ab and ac.
  struct Weights {
    double u, v, w, whole, ab2, ac2;
  };
  Weights weights(const Vec3& X, Index t) const;
  // The triangles whose cells meet the box X +- ext, sorted, each once.
  void candidates(const Vec3& X, double ext, std::vector<Index>& out) const;
  static std::vector<Index>& scratch();
  void prepare();  // normals, canonical vertices, bins

  std::vector<Vec3> body_;     // vertices, body frame
  std::vector<Face> faces_;
  // What a query reads of triangle t, in one record (two cache lines, not five scattered ones:
  // a mesh of 1e5 triangles does not stay in cache): corners, unit normal and centroid (body
  // frame), the largest distance from the centroid to a corner, the corners' canonical vertices.
  struct Tri {
    Vec3 a, b, c, n, centroid;
    double round;
    std::array<Index, 3> canon;
  };
  std::vector<Tri> tri_;
  std::vector<Index> canon_;   // canonical vertex of each vertex
  Vec3 center0_ = Vec3::Zero(), center_ = Vec3::Zero();
  Orientation orientation_{1, 0, 0, 0};
  Eigen::Matrix3d rotation_ = Eigen::Matrix3d::Identity();
  bool moved_ = false;  // false: body frame = world frame, bit for bit
  // Bins: cells of edge h from lo (body frame), keyed (z, y, x); the occupied ones sorted by key,
  // with the triangles that meet each.
  Vec3 lo_ = Vec3::Zero();
  double h_ = 1;
  std::array<long, 3> dims_{1, 1, 1};
  std::vector<std::uint64_t> keys_;
  std::vector<Index> start_, tris_;
  std::vector<Index> dense_;  // every cell's first in tris_ (cells + 1), or empty: a sparse box
};

}  // namespace tsubu
