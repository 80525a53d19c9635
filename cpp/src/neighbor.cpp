// Linked cells with a skin (Verlet list): the half pair list, the near-wall list, the sort of
// particles by cell, and the transfer of contact history across rebuilds.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <string>
#include <vector>

#include "tsubu/simulation.hpp"

namespace tsubu {

namespace {

template <class Key>
void insertion_sort(Index* first, Index* last, Key key) {
  for (Index* a = first + 1; a < last; ++a) {
    const Index v = *a;
    const auto kv = key(v);
    Index* b = a;
    for (; b > first && key(*(b - 1)) > kv; --b) *b = *(b - 1);
    *b = v;
  }
}

// Resizes a per-entry array, growing its capacity by 1/8 rather than doubling: the lists change
// size a little at every refresh, and memory per particle is a figure we report.
template <class T>
void fit(Array<T>& a, std::size_t size, T value = T()) {
  if (size > a.capacity()) a.reserve(size + size / 8);
  a.resize(size, value);
}

}  // namespace

bool Simulation::needs_rebuild() const {
  if (!list_valid_ || opt_.rebuild_every_step) return true;
  if (2.0 * moved_ > list_skin_) return true;  // two particles closing by skin
  for (std::size_t w = 0; w < planes_.size(); ++w) {
    const Plane& p = planes_[w];
    if (!p.moving()) continue;
    const double shift =
        p.shift_since(plane_point_ref_[w], plane_normal_ref_[w], plane_reach_ + list_skin_);
    if (moved_ + shift > list_skin_) return true;
  }
  return false;
}

void Simulation::rebuild_neighbors() {
  mix_pairs();
  rebuild(true);
}

Simulation::CellGrid Simulation::plan_grid(double skin) const {
  CellGrid g;
  const std::size_t n = n_;
  if (n == 0) return g;
  box_.grid_extent(particles_.x.data(), n, g.lo, g.hi);
  const double rmax = *std::max_element(particles_.radius.begin(), particles_.radius.end());
  g.h = 2.0 * rmax + skin;  // cells no smaller than the largest cutoff
  const double max_cells = 2.0 * static_cast<double>(n) + 1000.0;
  double total = 1;
  for (int d = 0; d < 3; ++d) total *= std::floor((g.hi[d] - g.lo[d]) / g.h) + 1;
  if (total <= max_cells) {  // (false for an extent that overflows, too)
    for (int d = 0; d < 3; ++d) g.dims[d] = static_cast<long>(std::floor((g.hi[d] - g.lo[d]) / g.h)) + 1;
    return g;
  }
  // Sparse: keys are computed from halved coordinates (an extent may exceed the largest double)
  // and must fit in a long: far-flung scenes get larger cells only beyond ~1e18 cells a side.
  g.sparse = true;
  const double max_coord = std::ldexp(1.0, std::min(60, std::numeric_limits<long>::digits - 2));
  double half_extent = 0;
  for (int d = 0; d < 3; ++d) half_extent = std::max(half_extent, 0.5 * g.hi[d] - 0.5 * g.lo[d]);
  g.h = std::max(g.h, 2.0 * half_extent / max_coord);
  for (int d = 0; d < 3; ++d)
    g.dims[d] = static_cast<long>(std::floor((0.5 * g.hi[d] - 0.5 * g.lo[d]) / (0.5 * g.h))) + 1;
  return g;
}

Simulation::CellKey Simulation::cell_of(const CellGrid& g, const double* x) const {
  CellKey key;
  for (int d = 0; d < 3; ++d) {
    const double c = g.sparse ? (0.5 * x[d] - 0.5 * g.lo[d]) / (0.5 * g.h) : (x[d] - g.lo[d]) / g.h;
    key[2 - d] = std::clamp(static_cast<long>(c), 0L, g.dims[d] - 1);
  }
  return key;
}

void Simulation::bin_by_cell(const CellGrid& g) {
  const std::size_t n = n_;
  cell_of_.resize(n);
  perm_.resize(n);
  if (!g.sparse) {  // counting sort over every cell of the box
    const long ncell = g.dims[0] * g.dims[1] * g.dims[2];
    for (std::size_t k = 0; k < n; ++k) {
      long c[3];
      for (int d = 0; d < 3; ++d)
        c[d] = std::clamp(static_cast<long>((particles_.x[3 * k + d] - g.lo[d]) / g.h), 0L, g.dims[d] - 1);
      cell_of_[k] = static_cast<Index>((c[2] * g.dims[1] + c[1]) * g.dims[0] + c[0]);
    }
    cell_start_.assign(ncell + 1, 0);
    for (std::size_t k = 0; k < n; ++k) ++cell_start_[cell_of_[k] + 1];
    for (long c = 0; c < ncell; ++c) cell_start_[c + 1] += cell_start_[c];
    Array<Index>& fill = scratch_int_;
    fill.assign(cell_start_.begin(), cell_start_.end() - 1);
    for (std::size_t k = 0; k < n; ++k) perm_[fill[cell_of_[k]]++] = static_cast<Index>(k);
    return;
  }
  // Sparse: a stable sort by key gives the order the dense grid would (cells by (z, y, x),
  // particles in a cell by index); cell_key_ lists the occupied cells.
  std::vector<CellKey> key(n);
  for (std::size_t k = 0; k < n; ++k) key[k] = cell_of(g, &particles_.x[3 * k]);
  for (std::size_t k = 0; k < n; ++k) perm_[k] = static_cast<Index>(k);
  std::stable_sort(perm_.begin(), perm_.end(), [&](Index a, Index b) { return key[a] < key[b]; });
  cell_key_.clear();
  cell_start_.clear();
  for (std::size_t s = 0; s < n; ++s) {
    const Index k = perm_[s];
    if (cell_key_.empty() || key[k] != cell_key_.back()) {
      cell_key_.push_back(key[k]);
      cell_start_.push_back(static_cast<Index>(s));
    }
    cell_of_[k] = static_cast<Index>(cell_key_.size() - 1);
  }
  cell_start_.push_back(static_cast<Index>(n));
}

namespace {
// Calls visit(cell) for each existing cell among the 27 around `key` (itself included), in the
// order of increasing (z, y, x).
template <class Grid, class Keys, class Visit>
void for_each_cell_around(const Grid& g, const Keys& keys, const std::array<std::int64_t, 3>& key, Visit&& visit) {
  const std::array<long, 3> dims{g.dims[2], g.dims[1], g.dims[0]};  // in key order (z, y, x)
  std::array<std::int64_t, 3> lo_key, hi_key;
  for (int d = 0; d < 3; ++d) {
    lo_key[d] = std::max<std::int64_t>(key[d] - 1, 0);
    hi_key[d] = std::min<std::int64_t>(key[d] + 1, dims[d] - 1);
  }
  for (std::int64_t cz = lo_key[0]; cz <= hi_key[0]; ++cz)
    for (std::int64_t cy = lo_key[1]; cy <= hi_key[1]; ++cy)
      for (std::int64_t cx = lo_key[2]; cx <= hi_key[2]; ++cx) {
        if (!g.sparse) {
          visit(static_cast<long>((cz * dims[1] + cy) * dims[2] + cx));
          continue;
        }
        const std::array<std::int64_t, 3> q{cz, cy, cx};
        const auto it = std::lower_bound(keys.begin(), keys.end(), q);
        if (it != keys.end() && *it == q) visit(static_cast<long>(it - keys.begin()));
      }
}

std::string gib(double bytes) {
  char text[32];
  std::snprintf(text, sizeof text, "%.3g GiB", bytes / (1024.0 * 1024.0 * 1024.0));
  return text;
}
}  // namespace

double Simulation::list_bytes_per_pair() const {
  // A Verlet entry (its partner) and, at worst, a near entry: owner, partner, cutoff, reverse
  // index, summation tag, touch flag, the law's cached terms and contact state (16 doubles when
  // no run has chosen a law yet), with the lists' 1/8 growth room.
  int doubles = law_ ? law_->entry_width : 0;
  for (int w : EntryStore::widths(pair_shape_)) doubles += w;
  if (!law_) doubles = std::max(doubles, 16);
  return 1.125 * (4.0 + 25.0 + 8.0 * doubles);
}

void Simulation::check_list_fits(const CellGrid& g, double skin) const {
  const std::size_t n = n_;
  const double per_pair = list_bytes_per_pair();
  const double memory = static_cast<double>(available_memory());
  const double limit = std::min<double>(std::numeric_limits<Index>::max(), memory / per_pair);
  const double nd = static_cast<double>(n);
  if (0.5 * nd * (nd - 1) <= limit) return;  // even every pair fits
  // Upper bounds from the cells: each particle meets at most the particles of its 27 cells, so
  // at most 27 times the fullest cell's count (cheap), or (when that is over) their sum.
  auto occupancy = [&](long c) { return static_cast<double>(cell_start_[c + 1] - cell_start_[c]); };
  const long cells = static_cast<long>(cell_start_.size()) - 1;
  double fullest = 0;
  for (long c = 0; c < cells; ++c) fullest = std::max(fullest, occupancy(c));
  if (0.5 * nd * 27.0 * fullest <= limit) return;
  double around_sum = 0;
  for (long c = 0; c < cells; ++c) {
    const double own = occupancy(c);
    if (own == 0) continue;
    CellKey key = g.sparse ? cell_key_[c] : CellKey{c / (g.dims[0] * g.dims[1]), (c / g.dims[0]) % g.dims[1], c % g.dims[0]};
    double around = 0;
    for_each_cell_around(g, cell_key_, key, [&](long q) { around += occupancy(q); });
    around_sum += own * around;
  }
  if (0.5 * (around_sum - nd) <= limit) return;
  // The bound is over: count the pairs closer than their cutoff (particles not yet in cell
  // order: perm_ lists each cell's), stopping as soon as the count is over too.
  const double* x = particles_.x.data();
  const double* r = particles_.radius.data();
  double count = 0;
  for (std::size_t k = 0; k < n && count <= limit; ++k) {
    const Vec3 xk = vec3(x, k);
    for_each_cell_around(g, cell_key_, cell_of(g, &x[3 * k]), [&](long c) {
      for (Index s = cell_start_[c]; s < cell_start_[c + 1]; ++s) {
        const Index j = perm_[s];
        if (particles_.id[j] <= particles_.id[k]) continue;
        const double cut = r[k] + r[j] + skin;
        if (box_.displacement(xk, vec3(x, j)).squaredNorm() < cut * cut) ++count;
      }
    });
  }
  if (count <= limit) return;
  const double rmax = *std::max_element(particles_.radius.begin(), particles_.radius.end());
  const bool by_index = std::numeric_limits<Index>::max() < memory / per_pair;
  throw ResourceError(
      "the neighbour list of " + std::to_string(n) + " spheres would hold over " +
      std::to_string(static_cast<long long>(limit)) + " pairs (over " + gib(count * per_pair) + "), " +
      (by_index ? std::string("beyond the 2^31 - 1 entries its 32-bit indices hold")
                : "beyond the " + gib(memory) + " of memory available") +
      ": the pair cutoff r_i + r_j + skin (largest radius " + std::to_string(rmax) + " m, skin " +
      std::to_string(skin) + " m) reaches too many spheres; use a smaller skin or smaller spheres");
}

void Simulation::sort_by_cell() {
  const std::size_t n = n_;
  particles_.permute(perm_, scratch_);
  index_of_.resize(n);
  for (std::size_t k = 0; k < n; ++k) index_of_[particles_.id[k]] = static_cast<Index>(k);
}

void Simulation::stash_near() {
  // Only touching entries have state: copy theirs, compactly, with rows by owner.
  const std::size_t rows = near_offset_.empty() ? 0 : near_offset_.size() - 1;
  std::size_t count = 0;
  for (double o : pair_state_.overlap) count += o > 0;
  old_near_offset_.resize(rows + 1);
  old_near_partner_id_.resize(count);
  const auto state = pair_state_.carried();
  const auto width = EntryStore::widths(pair_shape_);
  for (std::size_t k = 0; k < kEntryArrays; ++k)
    old_pair_state_[k].resize(state[k]->empty() ? 0 : count * width[k]);
  std::array<const double*, kEntryArrays> now;
  for (std::size_t k = 0; k < kEntryArrays; ++k) now[k] = state[k]->data();
  std::size_t c = 0;
  old_near_offset_[0] = 0;
  for (std::size_t i = 0; i < rows; ++i) {
    for (Index q = near_offset_[i]; q < near_offset_[i + 1]; ++q) {
      if (!(pair_state_.overlap[q] > 0)) continue;
      old_near_partner_id_[c] = particles_.id[near_partner_[q]];
      for (std::size_t k = 0; k < kEntryArrays; ++k) {
        if (old_pair_state_[k].empty()) continue;
        const std::size_t wd = width[k];
        const double* from = now[k] + wd * q;
        std::copy(from, from + wd, old_pair_state_[k].data() + wd * c);
      }
      ++c;
    }
    old_near_offset_[i + 1] = static_cast<Index>(c);
  }
}

void Simulation::rebuild(bool keep_history) {
  const std::size_t n = n_;
  const double skin = this->skin();

  // 1. Cells: the bounding box of the particles, cells no smaller than the largest cutoff. The
  //    particles are binned and the list's size checked before anything changes, so that a
  //    list that cannot fit is refused with the state as it was.
  const CellGrid grid = plan_grid(skin);
  if (n > 0) {
    bin_by_cell(grid);
    check_list_fits(grid, skin);
  }
  list_skin_ = skin;

  // 2. Set the old near and wall lists aside, in terms of ids, with their state; then put the
  //    particles in cell order.
  const std::size_t old_n = near_offset_.size() == 0 ? 0 : near_offset_.size() - 1;
  const bool transfer = keep_history && old_n > 0 && wall_offset_.size() == old_n + 1;
  if (transfer) {
    stash_near();
    old_wall_offset_.swap(wall_offset_);
    old_wall_index_.swap(wall_index_);
    old_index_of_ = index_of_;
    const auto now = wall_state_.carried();
    for (std::size_t k = 0; k < kEntryArrays; ++k) old_wall_state_[k].swap(*now[k]);
  }
  if (n > 0) sort_by_cell();
  const Vec3 lo = grid.lo, hi = grid.hi;

  // 3. Verlet half list, each pair owned by its lower id: count, prefix sum, fill, sort.
  pair_offset_.assign(n + 1, 0);
  const double* x = particles_.x.data();
  const double* r = particles_.radius.data();
  const Vec3& lo_cell = grid.lo;
  const double h = grid.h;
  const std::array<long, 3>& dims = grid.dims;
  auto for_each_neighbor = [&](Index i, auto&& visit) {
    const Vec3 xi = vec3(x, i);
    auto visit_cell = [&](long cell) {
      for (Index j = cell_start_[cell]; j < cell_start_[cell + 1]; ++j) {
        if (particles_.id[j] <= particles_.id[i]) continue;
        const double cut = r[i] + r[j] + skin;
        if (box_.displacement(xi, vec3(x, j)).squaredNorm() < cut * cut) visit(j);
      }
    };
    if (grid.sparse) {
      for_each_cell_around(grid, cell_key_, cell_of(grid, &x[3 * i]), visit_cell);
      return;
    }
    long c[3];  // the dense grid, indexed directly (the common case: kept tight)
    for (int d = 0; d < 3; ++d)
      c[d] = std::clamp(static_cast<long>((xi[d] - lo_cell[d]) / h), 0L, dims[d] - 1);
    for (long cz = std::max(c[2] - 1, 0L); cz <= std::min(c[2] + 1, dims[2] - 1); ++cz)
      for (long cy = std::max(c[1] - 1, 0L); cy <= std::min(c[1] + 1, dims[1] - 1); ++cy)
        for (long cx = std::max(c[0] - 1, 0L); cx <= std::min(c[0] + 1, dims[0] - 1); ++cx)
          visit_cell((cz * dims[1] + cy) * dims[0] + cx);
  };
  const Index ni = static_cast<Index>(n);
#pragma omp parallel for schedule(static) num_threads(threads()) if (ni >= opt_.parallel_min)
  for (Index i = 0; i < ni; ++i) {
    Index count = 0;
    for_each_neighbor(i, [&](Index) { ++count; });
    pair_offset_[i + 1] = count;
  }
  for (std::size_t i = 0; i < n; ++i) pair_offset_[i + 1] += pair_offset_[i];
  pair_partner_.resize(static_cast<std::size_t>(pair_offset_[n]));
#pragma omp parallel for schedule(static) num_threads(threads()) if (ni >= opt_.parallel_min)
  for (Index i = 0; i < ni; ++i) {
    Index e = pair_offset_[i];
    for_each_neighbor(i, [&](Index j) { pair_partner_[e++] = j; });
    insertion_sort(pair_partner_.data() + pair_offset_[i], pair_partner_.data() + pair_offset_[i + 1],
                   [&](Index j) { return particles_.id[j]; });
  }

  // 4. Near-wall list: particles within r + skin of a plane (or behind it).
  wall_offset_.assign(n + 1, 0);
  const std::size_t nw = planes_.size();
  auto near_wall = [&](std::size_t i, std::size_t w) { return planes_[w].near(vec3(x, i), r[i], skin); };
  for (std::size_t i = 0; i < n; ++i) {
    Index count = 0;
    for (std::size_t w = 0; w < nw; ++w) count += near_wall(i, w);
    wall_offset_[i + 1] = wall_offset_[i] + count;
  }
  wall_index_.resize(static_cast<std::size_t>(wall_offset_[n]));
  wall_owner_.resize(wall_index_.size());
  for (std::size_t i = 0; i < n; ++i) {
    Index e = wall_offset_[i];
    for (std::size_t w = 0; w < nw; ++w)
      if (near_wall(i, w)) {
        wall_owner_[e] = static_cast<Index>(i);
        wall_index_[e++] = static_cast<Index>(w);
      }
  }
  size_entry_buffers();
  for (Array<double>* a : wall_state_.carried()) std::fill(a->begin(), a->end(), 0.0);
  if (transfer) {  // wall contact state, by (id, wall key)
    const auto width = EntryStore::widths(wall_shape_);
    const auto state = wall_state_.carried();
    for (Index i = 0; i < ni; ++i) {
      const Id a = particles_.id[i];
      if (a >= static_cast<Id>(old_index_of_.size())) continue;  // added since
      const Index oi = old_index_of_[a];
      if (static_cast<std::size_t>(oi) >= old_n) continue;
      for (Index e = wall_offset_[i]; e < wall_offset_[i + 1]; ++e)
        for (Index q = old_wall_offset_[oi]; q < old_wall_offset_[oi + 1]; ++q)
          if (wall_key(old_wall_index_, q) == wall_key(wall_index_, e)) {
            for (std::size_t k = 0; k < kEntryArrays; ++k) {
              const Array<double>& old = old_wall_state_[k];
              Array<double>& now = *state[k];
              if (now.empty() || old.empty()) continue;  // the old or new law has no such array
              const std::size_t wd = width[k];
              std::copy(&old[wd * q], &old[wd * q] + wd, &now[wd * e]);
            }
            old_wall_state_[1][q] = 0;  // carried
            break;
          }
      for (Index q = old_wall_offset_[oi]; q < old_wall_offset_[oi + 1]; ++q)
        if (old_wall_state_[1][q] > 0)  // touching, and now beyond the skin: it opened
          particles_.dissipated[i] += spring_energy(particles_.material[i], planes_[old_wall_index_[q]].material,
                                          old_wall_state_[0], q);
    }
  }
  for (std::size_t e = 0; e < wall_state_.overlap.size(); ++e) wall_state_.touch[e] = wall_state_.overlap[e] > 0;

  // 5. The near list and its contact state.
  refresh_near(transfer, true);

  // 6. Reference state for the rebuild criterion.
  moved_ = 0;
  plane_point_ref_.resize(nw);
  plane_normal_ref_.resize(nw);
  plane_reach_ = 0;
  for (std::size_t w = 0; w < nw; ++w) {
    plane_point_ref_[w] = planes_[w].point;
    plane_normal_ref_[w] = planes_[w].normal;
    for (int corner = 0; corner < 8; ++corner) {
      const Vec3 c((corner & 1) ? hi.x() : lo.x(), (corner & 2) ? hi.y() : lo.y(),
                   (corner & 4) ? hi.z() : lo.z());
      plane_reach_ = std::max(plane_reach_, (c - planes_[w].point).norm());
    }
  }
  list_valid_ = true;
  ++rebuilds_;
}

void Simulation::refresh_near(bool transfer, bool reordered) {
  const std::size_t n = n_;
  const double* x = particles_.x.data();
  const double* r = particles_.radius.data();
  const double reach = near_skin();

  // 1. The pairs of the Verlet list within r_i + r_j + skin/10, in the Verlet list's order:
  //    counted, then stored.
  auto near = [&](std::size_t i, Index j) {
    const double cut = r[i] + r[j] + reach;
    return box_.displacement(vec3(x, i), vec3(x, j)).squaredNorm() < cut * cut;
  };
  // Rows are independent: counted and filled in parallel (the same list for any thread count).
  const long ni = static_cast<long>(n);
  const bool parallel = ni >= opt_.parallel_min;
  near_offset_.resize(n + 1);
  near_offset_[0] = 0;
#pragma omp parallel for schedule(static) num_threads(threads()) if (parallel)
  for (long i = 0; i < ni; ++i) {
    Index count = 0;
    for (Index e = pair_offset_[i]; e < pair_offset_[i + 1]; ++e) count += near(i, pair_partner_[e]);
    near_offset_[i + 1] = count;
  }
  for (std::size_t i = 0; i < n; ++i) near_offset_[i + 1] += near_offset_[i];
  const std::size_t m = static_cast<std::size_t>(near_offset_[n]);
  fit(near_owner_, m);
  fit(near_partner_, m);
  fit(near_cut2_, m);
#pragma omp parallel for schedule(static) num_threads(threads()) if (parallel)
  for (long i = 0; i < ni; ++i) {
    Index q = near_offset_[i];
    for (Index e = pair_offset_[i]; e < pair_offset_[i + 1]; ++e) {
      const Index j = pair_partner_[e];
      if (!near(i, j)) continue;
      near_owner_[q] = static_cast<Index>(i);
      near_partner_[q] = j;
      near_cut2_[q++] = (r[i] + r[j]) * (r[i] + r[j]);
    }
  }

  // 2. Contact state, carried over by (owner id, partner id): rows are sorted by partner id.
  size_entry_buffers();
  for (Array<double>* a : pair_state_.carried()) std::fill(a->begin(), a->end(), 0.0);
  const std::size_t old_n = old_near_offset_.size() == 0 ? 0 : old_near_offset_.size() - 1;
  if (transfer && old_n > 0) {
    // Only touching entries have state (an entry's results and history are zeroed when it
    // opens; a rough entry redraws its facet at first touch).
    const auto state = pair_state_.carried();
    const auto width = EntryStore::widths(pair_shape_);
    std::array<Array<double>*, kEntryArrays> now_state;
    for (std::size_t k = 0; k < kEntryArrays; ++k)
      now_state[k] = (state[k]->empty() || old_pair_state_[k].empty()) ? nullptr : state[k];
    // (the stash holds touching entries only, rows sorted by partner id)
    const Array<double>& old_overlap = old_pair_state_[1];
    // Each row writes only its own entries, its own old row and its own dissipation.
#pragma omp parallel for schedule(static) num_threads(threads()) if (parallel)
    for (long i = 0; i < ni; ++i) {
      Index oi = static_cast<Index>(i);
      if (reordered) {
        if (particles_.id[i] >= static_cast<Id>(old_index_of_.size())) continue;  // added since
        oi = old_index_of_[particles_.id[i]];
      }
      if (static_cast<std::size_t>(oi) >= old_n) continue;
      Index p = old_near_offset_[oi];
      const Index p_end = old_near_offset_[oi + 1];
      for (Index q = near_offset_[i]; q < near_offset_[i + 1] && p < p_end; ++q) {
        const Id b = particles_.id[near_partner_[q]];
        while (p < p_end && old_near_partner_id_[p] < b) ++p;
        if (p == p_end || old_near_partner_id_[p] != b || !(old_overlap[p] > 0)) continue;
        for (std::size_t k = 0; k < kEntryArrays; ++k) {
          if (!now_state[k]) continue;  // the old or new law has no such array
          const std::size_t wd = width[k];
          const double* from = old_pair_state_[k].data() + wd * p;
          std::copy(from, from + wd, now_state[k]->data() + wd * q);
        }
        old_pair_state_[1][p] = 0;  // carried
      }
      for (p = old_near_offset_[oi]; p < p_end; ++p)
        if (old_overlap[p] > 0) {  // touching, and now beyond the near list: it opened
          const Index j = index_of_[old_near_partner_id_[p]];
          particles_.dissipated[i] += spring_energy(particles_.material[i], particles_.material[j], old_pair_state_[0], p);
        }
    }
  }
  for (std::size_t q = 0; q < pair_state_.overlap.size(); ++q) pair_state_.touch[q] = pair_state_.overlap[q] > 0;

  // 3. Reverse index: for each particle, the entries where it is the partner, by owner id.
  near_rev_offset_.assign(n + 1, 0);
  for (std::size_t q = 0; q < m; ++q) ++near_rev_offset_[near_partner_[q] + 1];
  for (std::size_t i = 0; i < n; ++i) near_rev_offset_[i + 1] += near_rev_offset_[i];
  fit(near_rev_, m);
  {
    Array<Index>& fill = scratch_int_;
    fill.assign(near_rev_offset_.begin(), near_rev_offset_.end() - 1);
    for (std::size_t q = 0; q < m; ++q) near_rev_[fill[near_partner_[q]]++] = static_cast<Index>(q);
  }
#pragma omp parallel for schedule(static) num_threads(threads()) if (parallel)
  for (long i = 0; i < ni; ++i)
    if (near_rev_offset_[i + 1] - near_rev_offset_[i] > 1)
      insertion_sort(near_rev_.data() + near_rev_offset_[i], near_rev_.data() + near_rev_offset_[i + 1],
                     [&](Index q) { return particles_.id[near_owner_[q]]; });
  // 4. The near-wall entries, and the particles with entries.
  bool moving = false;
  for (const Plane& p : planes_) moving = moving || p.moving();
  wall_near_offset_.resize(n + 1);
  wall_near_offset_[0] = 0;
  wall_near_.clear();
  wall_near_.reserve(wall_index_.size());
  for (std::size_t i = 0; i < n; ++i) {
    for (Index e = wall_offset_[i]; e < wall_offset_[i + 1]; ++e) {
      const Plane& p = planes_[wall_index_[e]];
      if (moving || wall_state_.touch[e] || p.distance(vec3(x, i)) - r[i] < reach)
        wall_near_.push_back(e);
    }
    wall_near_offset_[i + 1] = static_cast<Index>(wall_near_.size());
  }
  loaded_.assign(n, 0);
  busy_.clear();
  for (std::size_t i = 0; i < n; ++i)
    if (wall_near_offset_[i + 1] > wall_near_offset_[i] || near_offset_[i + 1] > near_offset_[i] ||
        near_rev_offset_[i + 1] > near_rev_offset_[i])
      busy_.push_back(static_cast<Index>(i));
  build_sum_entries();
  measure_near();
  fit(active_, wall_near_.size());  // the walls in contact (step.hpp)
  cache_near_terms();
  moved_near_ = 0;
  ++refreshes_;
}

void Simulation::build_sum_entries() {
  const std::size_t nb = busy_.size();
  const std::size_t largest = std::max(near_partner_.size(), wall_index_.size());
  if (largest >= (std::size_t(1) << 29)) {  // no room for the tags: the particle pass loops
    sum_offset_.clear();
    sum_entry_.clear();
    return;
  }
  fit(sum_offset_, nb + 1);
  sum_offset_[0] = 0;
  for (std::size_t b = 0; b < nb; ++b) {
    const Index k = busy_[b];
    sum_offset_[b + 1] = sum_offset_[b] + (wall_near_offset_[k + 1] - wall_near_offset_[k]) +
                         (near_offset_[k + 1] - near_offset_[k]) +
                         (near_rev_offset_[k + 1] - near_rev_offset_[k]);
  }
  fit(sum_entry_, static_cast<std::size_t>(sum_offset_[nb]));
  const long nbl = static_cast<long>(nb);
#pragma omp parallel for schedule(static) num_threads(threads()) if (long(n_) >= opt_.parallel_min)
  for (long b = 0; b < nbl; ++b) {
    const Index k = busy_[b];
    std::uint32_t* out = sum_entry_.data() + sum_offset_[b];
    auto put = [&](Index e, std::uint32_t kind) { *out++ = (std::uint32_t(e) << 3) | kind; };
    for (Index p = wall_near_offset_[k]; p < wall_near_offset_[k + 1]; ++p) put(wall_near_[p], 2);
    for (Index q = near_offset_[k]; q < near_offset_[k + 1]; ++q) put(q, 0);
    for (Index p = near_rev_offset_[k]; p < near_rev_offset_[k + 1]; ++p) put(near_rev_[p], 1);
    sum_entry_[sum_offset_[b]] |= 4u;  // a busy particle has at least one entry
  }
}

void Simulation::measure_near() {
  Index below = 0, above = 0, most = 0;
  for (std::size_t q = 0; q < near_partner_.size(); ++q) {
    below = std::max(below, near_owner_[q] - near_partner_[q]);
    above = std::max(above, near_partner_[q] - near_owner_[q]);
  }
  for (const Index k : busy_)
    most = std::max(most, (wall_near_offset_[k + 1] - wall_near_offset_[k]) +
                              (near_offset_[k + 1] - near_offset_[k]) +
                              (near_rev_offset_[k + 1] - near_rev_offset_[k]));
  near_reach_below_ = below;
  near_reach_above_ = above;
  max_entries_ = most;
}

void Simulation::size_entry_buffers() {
  auto size = [](EntryStore& st, const EntryShape& shape, std::size_t entries) {
    const auto width = EntryStore::widths(shape);
    const auto arrays = st.carried();
    for (std::size_t k = 0; k < EntryStore::kFields; ++k) fit(*arrays[k], width[k] * entries);
    fit(st.touch, entries);
  };
  size(pair_state_, pair_shape_, near_partner_.size());
  size(wall_state_, wall_shape_, wall_index_.size());
}

void Simulation::cache_near_terms() {
  const CompiledLaw& law = this->law();
  const std::size_t width = law.entry_width;
  fit(near_entry_, width * near_partner_.size());
  const double *mass = particles_.mass.data(), *radius = particles_.radius.data();
  const int* material = particles_.material.data();
  for (std::size_t q = 0; q < near_partner_.size(); ++q) {
    const Index i = near_owner_[q], j = near_partner_[q];
    const double m_eff = mass[i] * mass[j] / (mass[i] + mass[j]);
    const double r_eff = radius[i] * radius[j] / (radius[i] + radius[j]);
    law.entry_terms(pairs_(material[i], material[j]), m_eff, r_eff, near_entry_.data() + width * q);
  }
}

double Simulation::spring_energy(int a, int b, const Array<double>& xi, std::size_t e) const {
  if (xi.empty()) return 0;
  const CompiledLaw& law = this->law();
  return law.tangential_energy(pairs_(a, b), xi.data() + law.history_width * e);
}

std::vector<std::array<Id, 2>> Simulation::neighbor_pairs() const {
  std::vector<std::array<Id, 2>> out;
  if (pair_offset_.size() != n_ + 1) return out;
  for (std::size_t i = 0; i < n_; ++i)
    for (Index e = pair_offset_[i]; e < pair_offset_[i + 1]; ++e)
      out.push_back({particles_.id[i], particles_.id[pair_partner_[e]]});
  std::sort(out.begin(), out.end());
  return out;
}

}  // namespace tsubu
