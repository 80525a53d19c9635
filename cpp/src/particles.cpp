#include "tsubu/particles.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <string>

#include "check.hpp"

namespace tsubu {

Id Particles::add(std::size_t n, const double* positions, const double* radii, const int* materials,
                  const double* velocities, const double* angular_velocities,
                  const std::vector<Material>& table) {
  const Id first = static_cast<Id>(n_);
  s_.grow(n_ + n);
  if (n_ + n > index_of_.capacity())
    index_of_.reserve(std::max(n_ + n, index_of_.capacity() + index_of_.capacity() / 2));
  for (std::size_t k = 0; k < n; ++k) {
    const double r = radii[k];
    const double m = table[materials[k]].density * 4.0 / 3.0 * M_PI * r * r * r;
    for (int c = 0; c < 3; ++c) {
      s_.x.push_back(positions[3 * k + c]);
      s_.v.push_back(velocities ? velocities[3 * k + c] : 0.0);
      s_.w.push_back(angular_velocities ? angular_velocities[3 * k + c] : 0.0);
    }
    s_.radius.push_back(r);
    s_.mass.push_back(m);
    s_.inv_mass.push_back(1.0 / m);
    s_.inv_inertia.push_back(1.0 / (0.4 * m * r * r));  // I = 2/5 m r^2 (1.3)
    s_.dissipated.push_back(0.0);
    s_.material.push_back(materials[k]);
    s_.id.push_back(static_cast<Id>(n_));
    index_of_.push_back(static_cast<Index>(n_));
    ++n_;
  }
  return first;
}

void Particles::reserve(std::size_t count) {
  s_.reserve(count);
  index_of_.reserve(count);
}

void Particles::gather(const double* src, double* out) const {
  for (std::size_t k = 0; k < n_; ++k) {
    const Id id = s_.id[k];
    for (int c = 0; c < 3; ++c) out[3 * id + c] = src[3 * k + c];
  }
}

void Particles::scatter(const double* in, double* dst) const {
  for (std::size_t k = 0; k < n_; ++k) {
    const Id id = s_.id[k];
    detail::require(detail::finite3(in + 3 * id),
                    [&] { return "value for sphere " + std::to_string(id) + " is not finite"; });
  }
  for (std::size_t k = 0; k < n_; ++k) {
    const Id id = s_.id[k];
    for (int c = 0; c < 3; ++c) dst[3 * k + c] = in[3 * id + c];
  }
}

void Particles::permute(const Array<Index>& perm, Array<double>& scratch) {
  s_.permute(perm, scratch);
  index_of_.resize(n_);
  for (std::size_t k = 0; k < n_; ++k) index_of_[s_.id[k]] = static_cast<Index>(k);
}

void Particles::extremes(std::size_t materials, std::vector<double>& lightest,
                         std::vector<double>& smallest) const {
  lightest.assign(materials, std::numeric_limits<double>::infinity());
  smallest = lightest;
  for (std::size_t k = 0; k < n_; ++k) {
    const int m = s_.material[k];
    lightest[m] = std::min(lightest[m], s_.mass[k]);
    smallest[m] = std::min(smallest[m], s_.radius[k]);
  }
}

double Particles::radius_sum() const {
  double sum = 0;
  for (double r : s_.radius) sum += r;
  return sum;
}

std::size_t Particles::bytes() const {
  return s_.bytes() + index_of_.capacity() * sizeof(Index);
}

}  // namespace tsubu
