#include "tsubu/particles.hpp"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <string>

#include "check.hpp"

namespace tsubu {

Id Particles::add(std::size_t n, const double* positions, const double* radii, const int* materials,
                  const double* velocities, const double* angular_velocities,
                  const std::vector<Material>& table) {
  drop_ghosts();
  const Id first = static_cast<Id>(index_of_.size());
  const std::size_t ids = index_of_.size() + n;
  s_.grow(n_ + n);
  if (ids > index_of_.capacity()) index_of_.reserve(std::max(ids, index_of_.capacity() + index_of_.capacity() / 2));
  if (!dense()) rank_of_.reserve(ids);
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
    if (s_.imaged) {
      for (int c = 0; c < 3; ++c) s_.image.push_back(0);
      s_.slid.push_back(0.0);
    }
    if (!dense()) rank_of_.push_back(static_cast<Index>(n_));  // the largest id: the last row
    s_.id.push_back(static_cast<Id>(index_of_.size()));
    index_of_.push_back(static_cast<Index>(n_));
    ++n_;
  }
  return first;
}

void Particles::insert(std::size_t n, const Id* ids, const double* positions, const double* radii,
                       const int* materials, const double* velocities,
                       const double* angular_velocities, const std::vector<Material>& table) {
  if (n == 0) return;
  drop_ghosts();
  const std::size_t first = n_;
  add(n, positions, radii, materials, velocities, angular_velocities, table);  // ids bound.. bound+n
  index_of_.resize(index_of_.size() - n);  // (add handed out new ids: take them back)
  Id top = -1;
  for (std::size_t k = 0; k < n; ++k) top = std::max(top, ids[k]);
  if (static_cast<std::size_t>(top) >= index_of_.size()) index_of_.resize(static_cast<std::size_t>(top) + 1, kGone);
  for (std::size_t k = 0; k < n; ++k) {
    s_.id[first + k] = ids[k];
    index_of_[static_cast<std::size_t>(ids[k])] = static_cast<Index>(first + k);
  }
  if (dense()) rank_of_.clear();
  else rank_ids();
}

void Particles::reserve(std::size_t count) {
  s_.reserve(count);
  if (dense()) index_of_.reserve(count);
}

void Particles::gather(const double* src, double* out) const {
  for (std::size_t k = 0; k < n_; ++k) {
    const std::size_t row = rank(s_.id[k]);
    for (int c = 0; c < 3; ++c) out[3 * row + c] = src[3 * k + c];
  }
}

void Particles::scatter(const double* in, double* dst) const {
  for (std::size_t k = 0; k < n_; ++k) {
    const Id id = s_.id[k];
    detail::require(detail::finite3(in + 3 * rank(id)),
                    [&] { return "value for sphere " + std::to_string(id) + " is not finite"; });
  }
  for (std::size_t k = 0; k < n_; ++k) {
    const std::size_t row = rank(s_.id[k]);
    for (int c = 0; c < 3; ++c) dst[3 * k + c] = in[3 * row + c];
  }
}

void Particles::permute(const Array<Index>& perm, Array<double>& scratch, int threads) {
  s_.permute(perm, scratch, threads);
  const long n = static_cast<long>(n_);
#pragma omp parallel for schedule(static) num_threads(threads) if (threads > 1)
  for (long k = 0; k < n; ++k) index_of_[s_.id[k]] = static_cast<Index>(k);
}

void Particles::remove(const Id* ids, std::size_t count) {
  if (count == 0) return;
  for (std::size_t k = 0; k < count; ++k) index_of_[static_cast<std::size_t>(ids[k])] = kGone;
  Array<Index> keep;  // the spheres left, in their internal order
  keep.reserve(n_ - count);
  for (std::size_t k = 0; k < n_; ++k)
    if (index_of_[s_.id[k]] != kGone) keep.push_back(static_cast<Index>(k));
  Array<double> scratch;
  s_.permute(keep, scratch);  // moves row keep[k] to row k (k < kept): a stable compaction
  n_ = keep.size();
  s_.for_each_field([&](auto& a, int width) { a.resize(width * n_); });
  g_ = 0;
  for (std::size_t k = 0; k < n_; ++k) index_of_[s_.id[k]] = static_cast<Index>(k);
  rank_ids();
}

void Particles::rank_ids() {
  rank_of_.assign(index_of_.size(), kGone);
  Index row = 0;
  for (std::size_t id = 0; id < index_of_.size(); ++id)
    if (index_of_[id] != kGone) rank_of_[id] = row++;
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
  for (std::size_t k = 0; k < n_; ++k) sum += s_.radius[k];  // (not the ghosts)
  return sum;
}

std::size_t Particles::bytes() const {
  return s_.bytes() + index_of_.capacity() * sizeof(Index);
}

// ---- checkpoints ------------------------------------------------------------------------------

void Particles::save(archive::Writer& w) const {
  const std::size_t n = n_;
  std::vector<double> x(3 * n), v(3 * n), spin(3 * n), radius(n), dissipated(n);
  std::vector<std::int64_t> material(n), id(n);
  for_each_id([&](Id i, Index) { id[rank(i)] = i; });
  gather(s_.x.data(), x.data());
  gather(s_.v.data(), v.data());
  gather(s_.w.data(), spin.data());
  gather_scalar(s_.radius, radius.data());
  gather_scalar(s_.dissipated, dissipated.data());
  gather_scalar(s_.material, material.data());
  w.integer("count", static_cast<std::int64_t>(n));
  w.integers("id", id);
  w.integer("id_bound", static_cast<std::int64_t>(index_of_.size()));  // ids are never reused
  w.reals("position", x);
  w.reals("velocity", v);
  w.reals("angular_velocity", spin);
  w.reals("radius", radius);
  w.integers("material", material);
  w.reals("dissipated", dissipated);
}

void Particles::restore(archive::Reader& r, const std::vector<Material>& table) {
  if (n_ != 0) r.fail("spheres can only be restored into a scene without spheres");
  const std::int64_t count = r.integer("count");
  if (count < 0) r.fail("a negative sphere count");
  const std::size_t n = static_cast<std::size_t>(count);
  const std::vector<std::int64_t> id = r.integers("id", n);
  const std::int64_t bound = r.integer("id_bound");
  for (std::size_t k = 0; k < n; ++k)
    if (id[k] < 0 || (k > 0 && id[k] <= id[k - 1]) || id[k] >= bound)
      r.fail("sphere ids must be >= 0, increasing and below id_bound " + std::to_string(bound) +
             ", got " + std::to_string(id[k]) + " after " + (k > 0 ? std::to_string(id[k - 1]) : std::string("none")));
  const std::vector<double> x = r.reals("position", 3 * n), v = r.reals("velocity", 3 * n),
                            spin = r.reals("angular_velocity", 3 * n), radius = r.reals("radius", n);
  const std::vector<std::int64_t> material = r.integers("material", n);
  const std::vector<double> dissipated = r.reals("dissipated", n);
  std::vector<int> materials(n);
  for (std::size_t k = 0; k < n; ++k) {
    for (int c = 0; c < 3; ++c)
      if (!std::isfinite(x[3 * k + c]) || !std::isfinite(v[3 * k + c]) || !std::isfinite(spin[3 * k + c]))
        r.fail("sphere " + std::to_string(k) + ": a position, velocity or spin is not finite");
    if (!(radius[k] > 0) || !std::isfinite(radius[k]) || !std::isfinite(dissipated[k]))
      r.fail("sphere " + std::to_string(k) + ": a radius <= 0 or a value that is not finite");
    if (material[k] < 0 || material[k] >= static_cast<std::int64_t>(table.size()))
      r.fail("sphere " + std::to_string(k) + " names material " + std::to_string(material[k]) +
             "; the scene has " + std::to_string(table.size()));
    materials[k] = static_cast<int>(material[k]);
  }
  add(n, x.data(), radius.data(), materials.data(), v.data(), spin.data(), table);
  for (std::size_t k = 0; k < n; ++k) s_.dissipated[k] = dissipated[k];  // (added in id order)
  if (static_cast<std::size_t>(bound) != n) {  // the gaps of removed spheres
    index_of_.assign(static_cast<std::size_t>(bound), kGone);
    for (std::size_t k = 0; k < n; ++k) {
      s_.id[k] = id[k];
      index_of_[static_cast<std::size_t>(id[k])] = static_cast<Index>(k);
    }
    rank_ids();
  }
}

}  // namespace tsubu
