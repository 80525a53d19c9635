// The periodic box and its ghosts (domain.hpp, docs/periodic.md).
#include "tsubu/domain.hpp"

#include <cmath>

namespace tsubu {

void Domain::set_box(const Vec3& lower, const Vec3& upper, const std::array<bool, 3>& periodic) {
  lo_ = lower;
  hi_ = upper;
  periodic_ = periodic;
  any_ = periodic[0] || periodic[1] || periodic[2];
  if (!any_) {
    sheared_ = false;
    rate_ = offset_ = 0;
  }
}

void Domain::set_shear(double rate, int flow, int gradient) {
  if (!sheared_ || flow != flow_ || gradient != gradient_) offset_ = 0;
  rate_ = rate;
  flow_ = flow;
  gradient_ = gradient;
  sheared_ = true;
}

void Domain::wrap(ParticleStore& p, std::size_t n) {
  if (!any_) return;
  const double Lf = length()[flow_];
  if (sheared_) offset_ = std::fmod(offset_, Lf) + (offset_ < 0 ? Lf : 0.0);
  for (std::size_t k = 0; k < n; ++k)
    wrap_one(p.x.data() + 3 * k, p.v.data() + 3 * k, p.image.data() + 3 * k, p.slid.data() + k);
}

void Domain::wrap_one(double* x, double* v, int* image, double* slid) const {
  const Vec3 L = length();
  if (sheared_) {  // first across the sheared faces, which move the flow coordinate
    const int g = gradient_;
    const double cross = std::floor((x[g] - lo_[g]) / L[g]);
    if (cross != 0 && std::isfinite(cross)) {
      x[g] -= cross * L[g];
      x[flow_] -= cross * offset_;
      v[flow_] -= cross * rate_ * L[g];
      *slid += cross * offset_;
      image[g] += static_cast<int>(cross);
    }
  }
  for (int d = 0; d < 3; ++d) {
    if (!periodic_[d] || (sheared_ && d == gradient_)) continue;
    const double cross = std::floor((x[d] - lo_[d]) / L[d]);
    if (cross == 0 || !std::isfinite(cross)) continue;
    x[d] -= cross * L[d];
    image[d] += static_cast<int>(cross);
  }
  for (int d = 0; d < 3; ++d)  // (rounding may leave x == hi)
    if (periodic_[d] && x[d] >= hi_[d]) x[d] = lo_[d];
}

void Domain::update_ghosts(ParticleStore& p, std::size_t n, int threads) const {
  const long g = static_cast<long>(source_.size());
  if (g == 0) return;
  double* x = p.x.data();
  double* v = p.v.data();
  double* w = p.w.data();
  const Vec3 L = length();
  const double slide = offset_, speed = rate_ * L[gradient_];
#pragma omp parallel for schedule(static) num_threads(threads) if (threads > 1 && g >= 2048)
  for (long q = 0; q < g; ++q) {
    const std::size_t s = static_cast<std::size_t>(source_[q]), j = n + q;
    for (int d = 0; d < 3; ++d) {
      x[3 * j + d] = x[3 * s + d] + image_[3 * q + d] * L[d];
      v[3 * j + d] = v[3 * s + d];
      w[3 * j + d] = w[3 * s + d];
    }
    x[3 * j + flow_] += slide_[q] * slide;
    v[3 * j + flow_] += slide_[q] * speed;
  }
}

double Domain::stretch(ParticleStore& p, std::size_t n, double rate, double dt) {
  const int a = servo_.axis;
  const double before = hi_[a] - lo_[a], factor = rate * dt;
  hi_[a] = lo_[a] + before * (1 + factor);
  double* x = p.x.data();
  for (std::size_t k = 0; k < n; ++k) x[3 * k + a] += factor * (x[3 * k + a] - lo_[a]);
  // The stretch moves two spheres (or a sphere and an image) apart by factor x their separation
  // along the axis (the images' shifts stretch too): at most factor x the ghosts' reach for any
  // listed pair.
  return std::abs(factor) * reach_;
}

}  // namespace tsubu
