#include "tsubu/walls/walls.hpp"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <string>

namespace tsubu {

int Walls::add(const Plane& p) {
  planes_.push_back(p);
  return count() - 1;
}

void Walls::set_motion(int wall, const Vec3& velocity, const Vec3& angular_velocity) {
  planes_[static_cast<std::size_t>(wall)].velocity = velocity;
  planes_[static_cast<std::size_t>(wall)].angular_velocity = angular_velocity;
}

bool Walls::moving() const {
  for (const Plane& p : planes_)
    if (p.moving()) return true;
  return false;
}

void Walls::advance(double dt) {
  for (Plane& p : planes_) p.advance(dt);
}

void Walls::mark(const Vec3& lo, const Vec3& hi) {
  const std::size_t nw = planes_.size();
  point_ref_.resize(nw);
  normal_ref_.resize(nw);
  reach_ = 0;
  for (std::size_t w = 0; w < nw; ++w) {
    point_ref_[w] = planes_[w].point;
    normal_ref_[w] = planes_[w].normal;
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
    if (!p.moving()) continue;
    const double shift = p.shift_since(point_ref_[w], normal_ref_[w], reach_ + skin);
    if (moved + shift > skin) return true;
  }
  return false;
}

std::size_t Walls::bytes() const {
  return planes_.capacity() * sizeof(Plane) + (point_ref_.capacity() + normal_ref_.capacity()) * sizeof(Vec3);
}

// ---- checkpoints ------------------------------------------------------------------------------

void Walls::save(archive::Writer& w) const {
  const std::size_t n = planes_.size();
  std::vector<double> point, normal, velocity, spin;
  std::vector<std::int64_t> material;
  for (const Plane& p : planes_) {
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
}

void Walls::restore(archive::Reader& r, int materials) {
  if (!planes_.empty()) r.fail("walls can only be restored into a scene without walls");
  const std::int64_t count = r.integer("planes");
  if (count < 0) r.fail("a negative wall count");
  const std::size_t n = static_cast<std::size_t>(count);
  const std::vector<double> point = r.reals("point", 3 * n), normal = r.reals("normal", 3 * n),
                            velocity = r.reals("velocity", 3 * n), spin = r.reals("angular_velocity", 3 * n);
  const std::vector<std::int64_t> material = r.integers("material", n);
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
    add(p);
  }
}

}  // namespace tsubu
