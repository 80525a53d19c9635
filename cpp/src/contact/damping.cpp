// The Hertzian damping's restitution and its inverse for a force clipped at zero.
#include <cmath>
#include <map>
#include <mutex>

#include "tsubu/contact/damping.hpp"

namespace tsubu {

double HertzDamping::restitution(double factor, bool clipped) {
  // Overlap x, approach speed u = x'. Units: m = 1, k = 4/3 E* sqrt(R*) = 1 (F = x^1.5), u(0) = 1;
  // S_n = 1.5 sqrt(x), eta = factor sqrt(1.5) x^(1/4). The undamped impact lasts 3.218 units.
  const double c = factor * std::sqrt(1.5);
  auto accel = [&](double x, double u) {
    const double xp = std::max(x, 0.0);
    double f = xp * std::sqrt(xp) + c * std::sqrt(std::sqrt(xp)) * u;
    if (clipped) f = std::max(f, 0.0);
    return -f;
  };
  const double h = 1e-4;
  double x = 0, u = 1;
  for (long k = 0; k < 2000000; ++k) {
    const double k1x = u, k1u = accel(x, u);
    const double k2x = u + 0.5 * h * k1u, k2u = accel(x + 0.5 * h * k1x, u + 0.5 * h * k1u);
    const double k3x = u + 0.5 * h * k2u, k3u = accel(x + 0.5 * h * k2x, u + 0.5 * h * k2u);
    const double k4x = u + h * k3u, k4u = accel(x + h * k3x, u + h * k3u);
    const double xn = x + h / 6 * (k1x + 2 * k2x + 2 * k3x + k4x);
    const double un = u + h / 6 * (k1u + 2 * k2u + 2 * k3u + k4u);
    if (xn <= 0 && k > 0) {  // separation within this step: the speed there, linearly
      const double s = x / (x - xn);
      return -(u + s * (un - u));
    }
    x = xn;
    u = un;
  }
  return 0;  // never separated: all energy lost
}

double HertzDamping::repulsive_factor(double e) {
  if (e >= 1) return 0;
  static std::mutex lock;
  static std::map<double, double> table;
  std::lock_guard<std::mutex> guard(lock);
  auto it = table.find(e);
  if (it != table.end()) return it->second;
  // restitution(f, clipped) falls as f grows; bracket and bisect.
  double lo = 0, hi = signed_factor(e);
  while (restitution(hi, true) > e) hi *= 2;
  for (int k = 0; k < 60 && hi - lo > 1e-12 * hi; ++k) {
    const double mid = 0.5 * (lo + hi);
    (restitution(mid, true) > e ? lo : hi) = mid;
  }
  const double f = 0.5 * (lo + hi);
  table.emplace(e, f);
  return f;
}

}  // namespace tsubu
