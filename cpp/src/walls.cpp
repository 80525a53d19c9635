#include "tsubu/walls/walls.hpp"

#include <algorithm>

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

}  // namespace tsubu
