// The scene's walls, of every kind. A wall kind (plane.hpp: Plane) answers for a sphere the gap
// and the normal, the contact point and the wall's velocity there, whether it is near, and how
// far the wall has moved since a reference; Walls holds the walls of each kind, their motion, and
// answers the neighbour list's queries: which walls (and which of a wall's elements: a triangle
// mesh has many, a plane one) lie within reach of a sphere, and whether the walls have moved far
// enough since the last rebuild to need another (docs/architecture.md, "Add a wall kind").
#pragma once
#include <cstddef>
#include <cstdint>
#include <vector>

#include "../archive.hpp"
#include "../types.hpp"
#include "mesh.hpp"
#include "plane.hpp"

namespace tsubu {

// The record the contact pass reads for a wall entry (ContactView::planes, ContactView::tangent):
// a plane, or the tangent plane of a mesh contact with the mesh's motion.
using Wall = Plane;

class Walls {
 public:
  enum Kind : std::uint8_t { kPlane = 0, kMesh = 1 };

  int count() const { return static_cast<int>(planes_.size()); }
  // Appends a plane (its normal already unit length); returns its wall index.
  int add(const Plane& p);
  // Appends a mesh; `motion` holds its velocity, angular velocity and material (its centre is
  // the mesh's). Returns its wall index.
  int add_mesh(Mesh mesh, const Plane& motion);
  Kind kind(int wall) const { return Kind(kind_[static_cast<std::size_t>(wall)]); }
  bool removed(int wall) const { return removed_[static_cast<std::size_t>(wall)] != 0; }
  // Takes a wall out of the scene: it touches nothing from the next rebuild on; its index stays.
  void remove(int wall);
  // A plane's state; for a mesh, its motion record (point = centre; the normal means nothing).
  const Plane& plane(int wall) const { return planes_[static_cast<std::size_t>(wall)]; }
  const Mesh& mesh(int wall) const { return meshes_[static_cast<std::size_t>(slot_[static_cast<std::size_t>(wall)])]; }
  bool has_meshes() const { return !meshes_.empty(); }
  // Replaces a plane's whole state (checkpoints).
  void set(int wall, const Plane& p) { planes_[static_cast<std::size_t>(wall)] = p; }
  void set_motion(int wall, const Vec3& velocity, const Vec3& angular_velocity);
  // Moves a wall's centre of rotation (the wall itself does not move).
  void set_center(int wall, const Vec3& center);
  const Plane* planes() const { return planes_.data(); }
  int material(int wall) const { return plane(wall).material; }

  // Checkpoints: every wall's whole state, bit for bit (a normal is not normalised again).
  // restore() fills an empty Walls and refuses non-finite values, normals that are not unit
  // length and materials outside [0, materials).
  void save(archive::Writer& w) const;
  void restore(archive::Reader& r, int materials);

  // A servo wall moves along `direction` (unit) at gain (force - F) [m/s], at most max_speed,
  // where F is the force its contacts put on the spheres along `direction` (a confining wall
  // at a set load). Set each step by Simulation::steer_walls.
  struct Servo {
    Vec3 direction = Vec3::Zero();
    double force = 0, gain = 0, max_speed = 0;
    bool on = false;
  };
  void set_servo(int wall, const Servo& s);
  const Servo& servo(int wall) const { return servo_[static_cast<std::size_t>(wall)]; }
  bool servoed() const;

  // Whether any wall moves (the contact pass then takes the wall's velocity at the contact).
  bool moving() const;
  // One step of every wall's motion.
  void advance(double dt);

  // Calls visit(wall, element) for each wall element within `reach` of touching a sphere of
  // radius r at x (or behind it), in increasing (wall, element) order. A plane has one element,
  // a mesh one per triangle.
  template <class X, class Visit>
  void for_each_near(const Eigen::MatrixBase<X>& x, double r, double reach, Visit&& visit) const {
    for (std::size_t w = 0; w < planes_.size(); ++w) {
      if (removed_[w]) continue;
      if (kind_[w] == kPlane) {
        if (planes_[w].near(x, r, reach)) visit(static_cast<Index>(w), Index(0));
      } else {
        meshes_[std::size_t(slot_[w])].for_each_near(Vec3(x), r, reach,
                                                     [&](Index t) { visit(static_cast<Index>(w), t); });
      }
    }
  }
  // The gap between a sphere of radius r at x and a wall element (negative: overlap).
  template <class X>
  double gap(const Eigen::MatrixBase<X>& x, double r, Index wall, Index element) const {
    const std::size_t w = static_cast<std::size_t>(wall);
    if (kind_[w] == kPlane) return planes_[w].distance(x) - r;
    return meshes_[std::size_t(slot_[w])].distance(Vec3(x), element) - r;
  }
  // Whether the gap is below `reach` (a mesh's far triangles are told by a cheap bound first).
  template <class X>
  bool within(const Eigen::MatrixBase<X>& x, double r, Index wall, Index element, double reach) const {
    const std::size_t w = static_cast<std::size_t>(wall);
    if (kind_[w] == kPlane) return planes_[w].distance(x) - r < reach;
    const Mesh& mesh = meshes_[std::size_t(slot_[w])];
    Vec3 normal;
    double lower;
    if (mesh.clear_of(Vec3(x), r + reach, element, normal, lower)) return false;
    return mesh.distance(Vec3(x), element) - r < reach;
  }
  // The overlap of a sphere of radius r at x with a wall element.
  template <class X>
  double overlap(const Eigen::MatrixBase<X>& x, double r, Index wall, Index element) const {
    return -gap(x, r, wall, element);
  }

  // The contact geometry of one sphere (radius r at x) with its near-wall entries entries[0, n),
  // each naming wall[e] and element[e]: tangent[e] is the plane the contact pass evaluates (a
  // plane wall itself; for a triangle the tangent plane at its nearest point, with the mesh's
  // motion and material). Of a mesh's triangles that touch the sphere, those that another hides
  // get a tangent plane clear of the sphere: an edge or vertex of a triangle whose face touches,
  // the same edge or vertex seen from another triangle, a face coplanar with a touching
  // neighbour's (docs/geometry.md, "Contact with triangles").
  // `touch` (by entry, or null): entries that touched at the last step get their nearest point
  // even when a cheap bound says they cannot touch now (a contact that slides onto the next
  // triangle hands its state over along its normal).
  // `clear` (by entry, or null; only while no wall moves): where an entry was found clear of the
  // sphere by `gap` with the sphere at `at`, it is not measured again while the sphere stays
  // within 0.9 gap of there (the triangle cannot then reach it, and its tangent plane, kept,
  // still puts it clear: the contact pass skips it as it would a fresh one); the records are
  // written here and reset by the lists (NeighborList::reset_clearance).
  struct Clearance {
    Vec3 at{0, 0, 0};
    double gap = -1;  // <= 0: measure
    bool held = false;  // skipped at the last measure: clear of the sphere, by 0.1 gap at least
  };
  void measure(const Vec3& x, double r, const Index* wall, const Index* element, const Index* entries,
               int n, Plane* tangent, const std::uint8_t* touch = nullptr, Clearance* clear = nullptr) const;
  // A flat sheet's holder entry e (triangle `element` of mesh `wall`; NeighborList::wall_sheet):
  // where the sphere lies over the inside of that triangle's face, its tangent plane and record
  // as measure() would leave them (the sheet's other triangles are then clear of the sphere or
  // hidden by this face) and true; false elsewhere, measuring nothing.
  bool measure_face(const Vec3& x, double r, Index wall, Index element, Index e, Plane* tangent,
                    const std::uint8_t* touch, Clearance* clear) const;

  // Takes the walls' positions now as the reference of the rebuild criterion, for particles
  // inside the box [lo, hi].
  void mark(const Vec3& lo, const Vec3& hi);
  // Whether a wall has moved so far since mark() that, with particles moved by up to `moved`, a
  // sphere may have come within `skin` of it unlisted.
  bool moved_beyond(double moved, double skin) const;

  std::size_t bytes() const;

 private:
  int append(const Plane& p, Kind kind, int slot);
  std::vector<Plane> planes_;
  std::vector<std::uint8_t> kind_, removed_;
  std::vector<int> slot_;  // a mesh wall's index in meshes_ (-1: a plane)
  std::vector<Mesh> meshes_;
  std::vector<Servo> servo_;
  // The rebuild criterion's reference: each plane at the last mark() (a mesh: its centre and
  // orientation), and the largest distance from a wall's point to the particles' box then.
  std::vector<Vec3> point_ref_, normal_ref_;
  std::vector<Mesh::Orientation> orientation_ref_;
  double reach_ = 0;
};

}  // namespace tsubu
