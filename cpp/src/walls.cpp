#include "tsubu/walls/walls.hpp"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <string>

namespace tsubu {

int Walls::append(const Plane& p, Kind kind, int slot) {
  planes_.push_back(p);
  kind_.push_back(kind);
  removed_.push_back(0);
  slot_.push_back(slot);
  servo_.emplace_back();
  return count() - 1;
}

int Walls::add(const Plane& p) { return append(p, kPlane, -1); }

int Walls::add_mesh(Mesh mesh, const Plane& motion) {
  Plane record = motion;
  record.point = record.center = mesh.center();
  record.normal = Vec3(0, 0, 1);
  meshes_.push_back(std::move(mesh));
  return append(record, kMesh, static_cast<int>(meshes_.size()) - 1);
}

void Walls::remove(int wall) { removed_[static_cast<std::size_t>(wall)] = 1; }

void Walls::set_motion(int wall, const Vec3& velocity, const Vec3& angular_velocity) {
  planes_[static_cast<std::size_t>(wall)].velocity = velocity;
  planes_[static_cast<std::size_t>(wall)].angular_velocity = angular_velocity;
}

void Walls::set_center(int wall, const Vec3& center) {
  const std::size_t w = static_cast<std::size_t>(wall);
  planes_[w].center = center;
  if (kind_[w] == kMesh) {
    meshes_[std::size_t(slot_[w])].set_center(center);
    planes_[w].point = center;
  }
}

void Walls::set_servo(int wall, const Servo& s) { servo_[static_cast<std::size_t>(wall)] = s; }

bool Walls::servoed() const {
  for (std::size_t w = 0; w < planes_.size(); ++w)
    if (!removed_[w] && servo_[w].on) return true;
  return false;
}

bool Walls::moving() const {
  for (std::size_t w = 0; w < planes_.size(); ++w)
    if (!removed_[w] && (planes_[w].moving() || servo_[w].on)) return true;
  return false;
}

void Walls::advance(double dt) {
  for (std::size_t w = 0; w < planes_.size(); ++w) {
    if (removed_[w]) continue;
    Plane& p = planes_[w];
    p.advance(dt);
    if (kind_[w] == kMesh) meshes_[std::size_t(slot_[w])].advance(dt, p.velocity, p.angular_velocity);
  }
}

void Walls::measure(const Vec3& x, double r, const Index* wall, const Index* element, const Index* entries,
                    int n, Plane* tangent, const std::uint8_t* touch, Clearance* clear) const {
  thread_local std::vector<MeshFeature> feature;
  thread_local std::vector<std::uint8_t> live;
  feature.resize(std::size_t(n));
  live.assign(std::size_t(n), 0);
  bool any = false;
  for (int k = 0; k < n; ++k) {
    const Index e = entries[k];
    const bool touched = touch != nullptr && touch[e];
    // (Still clear: the plane kept from then lies at least 0.1 gap beyond the sphere.)
    if (clear && !touched && clear[e].gap > 0 && (x - clear[e].at).squaredNorm() < 0.81 * clear[e].gap * clear[e].gap) {
      clear[e].held = true;
      continue;  // (not live)
    }
    const std::size_t w = std::size_t(wall[e]);
    Plane& T = tangent[e];
    T = planes_[w];
    if (clear) clear[e] = {x, -1.0, false};
    if (kind_[w] != kMesh) continue;
    const Mesh& mesh = meshes_[std::size_t(slot_[w])];
    double lower = 0;
    if (!touched && mesh.clear_of(x, r, element[e], T.normal, lower)) {
      T.point = x - (2 * r + 1) * T.normal;  // clear of the sphere
      if (clear) clear[e].gap = lower - r;
      continue;  // (not live)
    }
    const MeshPoint m = mesh.nearest(x, element[e]);
    T.point = m.point;
    T.normal = m.normal;
    feature[std::size_t(k)] = m.feature;
    live[std::size_t(k)] = m.distance < r;
    any = any || live[std::size_t(k)];
    if (clear && !touched) clear[e].gap = m.distance - r;  // (<= 0 where live)
  }
  if (!any) return;
  // Hide what a smooth surface does not have. An edge or vertex is a contact only where it is
  // the nearest point of every touching triangle that holds it (a convex edge or corner); where
  // one of them has a nearer point of its own (its face, another edge), the sphere presses that
  // instead. Of the triangles that share one nearest edge or vertex, the first keeps it; of two
  // coplanar neighbours that both see their face (the centre over their shared edge), the first.
  for (int k = 0; k < n; ++k) {
    if (!live[std::size_t(k)]) continue;
    const Index ek = entries[k], w = wall[ek];
    const Mesh& mesh = meshes_[std::size_t(slot_[std::size_t(w)])];
    const MeshFeature& f = feature[std::size_t(k)];
    bool hidden = false;
    for (int j = 0; j < n && !hidden; ++j) {
      if (j == k || !live[std::size_t(j)] || wall[entries[j]] != w) continue;
      const Index tj = element[entries[j]];
      const MeshFeature& g = feature[std::size_t(j)];
      if (f.kind == MeshFeature::kFace)
        hidden = g.kind == MeshFeature::kFace && j < k && mesh.adjacent(tj, element[ek]) &&
                 tangent[entries[j]].normal.dot(tangent[ek].normal) > 1 - 1e-12;
      else
        hidden = mesh.has(tj, f) && (!(g == f) || j < k);
    }
    if (hidden) tangent[ek].point = x - (2 * r + 1) * tangent[ek].normal;  // clear of the sphere
  }
}

bool Walls::measure_face(const Vec3& x, double r, Index wall, Index element, Index e, Plane* tangent,
                         const std::uint8_t* touch, Clearance* clear) const {
  const std::size_t w = std::size_t(wall);
  const Mesh& mesh = meshes_[std::size_t(slot_[w])];
  if (!mesh.over_face(x, element)) return false;
  const MeshPoint m = mesh.nearest(x, element);
  if (m.feature.kind != MeshFeature::kFace) return false;
  Plane& T = tangent[e];
  T = planes_[w];
  T.point = m.point;
  T.normal = m.normal;
  if (clear) clear[e] = {x, touch[e] ? -1.0 : m.distance - r, false};
  return true;
}

void Walls::mark(const Vec3& lo, const Vec3& hi) {
  const std::size_t nw = planes_.size();
  point_ref_.resize(nw);
  normal_ref_.resize(nw);
  orientation_ref_.resize(nw);
  reach_ = 0;
  for (std::size_t w = 0; w < nw; ++w) {
    point_ref_[w] = planes_[w].point;
    normal_ref_[w] = planes_[w].normal;
    orientation_ref_[w] = kind_[w] == kMesh ? meshes_[std::size_t(slot_[w])].orientation()
                                            : Mesh::Orientation{1, 0, 0, 0};
    for (int corner = 0; corner < 8; ++corner) {
      const Vec3 c((corner & 1) ? hi.x() : lo.x(), (corner & 2) ? hi.y() : lo.y(),
                   (corner & 4) ? hi.z() : lo.z());
      reach_ = std::max(reach_, (c - planes_[w].point).norm());
    }
  }
}

bool Walls::moved_beyond(double moved, double skin) const {
  for (std::size_t w = 0; w < planes_.size(); ++w) {
    const Plane& p = planes_[w];
    if (removed_[w] || !p.moving()) continue;
    const double shift = kind_[w] == kMesh
                             ? meshes_[std::size_t(slot_[w])].shift_since(point_ref_[w], orientation_ref_[w], reach_ + skin)
                             : p.shift_since(point_ref_[w], normal_ref_[w], reach_ + skin);
    if (moved + shift > skin) return true;
  }
  return false;
}

std::size_t Walls::bytes() const {
  std::size_t b = planes_.capacity() * sizeof(Plane) + (point_ref_.capacity() + normal_ref_.capacity()) * sizeof(Vec3) +
                  orientation_ref_.capacity() * sizeof(Mesh::Orientation) +
                  (kind_.capacity() + removed_.capacity()) + slot_.capacity() * sizeof(int);
  for (const Mesh& m : meshes_) b += m.bytes();
  return b;
}

// ---- checkpoints ------------------------------------------------------------------------------

void Walls::save(archive::Writer& w) const {
  const std::size_t n = planes_.size();
  std::vector<double> point, normal, velocity, spin, center;
  std::vector<std::int64_t> material, kind(kind_.begin(), kind_.end()), removed(removed_.begin(), removed_.end());
  for (const Plane& p : planes_) {
    center.insert(center.end(), p.center.data(), p.center.data() + 3);
    point.insert(point.end(), p.point.data(), p.point.data() + 3);
    normal.insert(normal.end(), p.normal.data(), p.normal.data() + 3);
    velocity.insert(velocity.end(), p.velocity.data(), p.velocity.data() + 3);
    spin.insert(spin.end(), p.angular_velocity.data(), p.angular_velocity.data() + 3);
    material.push_back(p.material);
  }
  w.integer("planes", static_cast<std::int64_t>(n));
  w.reals("point", point);
  w.reals("normal", normal);
  w.reals("velocity", velocity);
  w.reals("angular_velocity", spin);
  w.integers("material", material);
  w.reals("center", center);
  w.integers("kind", kind);
  w.integers("removed", removed);
  for (std::size_t k = 0; k < n; ++k) {
    if (kind_[k] != kMesh) continue;
    archive::Writer m;
    meshes_[std::size_t(slot_[k])].save(m);
    w.section("mesh", m);
  }
  std::vector<double> servo;
  std::vector<std::int64_t> servo_on;
  for (const Servo& s : servo_) {
    servo.insert(servo.end(), {s.direction.x(), s.direction.y(), s.direction.z(), s.force, s.gain, s.max_speed});
    servo_on.push_back(s.on ? 1 : 0);
  }
  w.reals("servo", servo);
  w.integers("servo_on", servo_on);
}

void Walls::restore(archive::Reader& r, int materials) {
  if (!planes_.empty()) r.fail("walls can only be restored into a scene without walls");
  const std::int64_t count = r.integer("planes");
  if (count < 0) r.fail("a negative wall count");
  const std::size_t n = static_cast<std::size_t>(count);
  const std::vector<double> point = r.reals("point", 3 * n), normal = r.reals("normal", 3 * n),
                            velocity = r.reals("velocity", 3 * n), spin = r.reals("angular_velocity", 3 * n);
  const std::vector<std::int64_t> material = r.integers("material", n);
  // (Checkpoints before meshes: planes turning about their points.)
  const std::vector<double> center = r.next_is("center") ? r.reals("center", 3 * n) : point;
  const std::vector<std::int64_t> kind = r.next_is("kind") ? r.integers("kind", n) : std::vector<std::int64_t>(n, kPlane);
  const std::vector<std::int64_t> removed = r.next_is("removed") ? r.integers("removed", n) : std::vector<std::int64_t>(n, 0);
  for (std::size_t k = 0; k < n; ++k) {
    Plane p;
    p.point = Vec3(point[3 * k], point[3 * k + 1], point[3 * k + 2]);
    p.normal = Vec3(normal[3 * k], normal[3 * k + 1], normal[3 * k + 2]);
    p.velocity = Vec3(velocity[3 * k], velocity[3 * k + 1], velocity[3 * k + 2]);
    p.angular_velocity = Vec3(spin[3 * k], spin[3 * k + 1], spin[3 * k + 2]);
    if (!p.point.allFinite() || !p.normal.allFinite() || !p.velocity.allFinite() ||
        !p.angular_velocity.allFinite() || std::abs(p.normal.norm() - 1) >= 1e-12)
      r.fail("wall " + std::to_string(k) + ": a finite point, unit normal and motion expected");
    if (material[k] < 0 || material[k] >= materials)
      r.fail("wall " + std::to_string(k) + " names material " + std::to_string(material[k]) +
             "; the scene has " + std::to_string(materials));
    p.material = static_cast<int>(material[k]);
    p.center = Vec3(center[3 * k], center[3 * k + 1], center[3 * k + 2]);
    if (!p.center.allFinite()) r.fail("wall " + std::to_string(k) + ": a finite centre expected");
    if (kind[k] == kMesh) {
      archive::Reader section = r.section("mesh");
      Mesh mesh = Mesh::restore(section);
      section.finish();
      meshes_.push_back(std::move(mesh));
      append(p, kMesh, static_cast<int>(meshes_.size()) - 1);
    } else if (kind[k] == kPlane) {
      add(p);
    } else {
      r.fail("wall " + std::to_string(k) + " is of no known kind");
    }
    removed_.back() = removed[k] != 0;
  }
  if (r.next_is("servo")) {
    const std::vector<double> servo = r.reals("servo", 6 * n);
    const std::vector<std::int64_t> on = r.integers("servo_on", n);
    for (std::size_t k = 0; k < n; ++k) {
      Servo& s = servo_[k];
      s.direction = Vec3(servo[6 * k], servo[6 * k + 1], servo[6 * k + 2]);
      s.force = servo[6 * k + 3], s.gain = servo[6 * k + 4], s.max_speed = servo[6 * k + 5];
      s.on = on[k] != 0;
      if (!s.direction.allFinite() || !std::isfinite(s.force) || !std::isfinite(s.gain) || !std::isfinite(s.max_speed))
        r.fail("wall " + std::to_string(k) + ": a servo with non-finite settings");
    }
  }
}

}  // namespace tsubu
