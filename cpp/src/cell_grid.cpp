// The neighbour list's cell grid: planning it over the particles' extent, binning the particles,
// and the check that the list it would give fits in memory (neighbor_list.hpp).
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <string>
#include <vector>

#include "list_loops.hpp"
#include "tsubu/neighbor_list.hpp"

namespace tsubu {

namespace {
// The particles' bounding box (Domain::grid_extent) and largest radius, in parts on the threads
// from list_loops::kScanRows particles (minima and maxima: the same for any split).
double extent(const NeighborList::Context& c, Vec3& lo, Vec3& hi) {
  const long n = static_cast<long>(c.particles.size());
  const ParticleStore& p = c.particles.arrays();
  const int threads = list_loops::scan_threads(c);
  if (threads <= 1 || n < list_loops::kScanRows) {
    c.domain.grid_extent(p.x.data(), n, lo, hi);
    return *std::max_element(p.radius.begin(), p.radius.begin() + n);
  }
  const double inf = std::numeric_limits<double>::infinity();
  std::vector<Vec3> part_lo(threads, Vec3::Constant(inf)), part_hi(threads, Vec3::Constant(-inf));
  std::vector<double> part_r(threads, -inf);
#pragma omp parallel num_threads(threads)
  {
    const auto [t, nt] = list_loops::part();
    const long k0 = n * t / nt, k1 = n * (t + 1) / nt;
    Vec3 my_lo, my_hi;  // (locals: the parts' entries share cache lines)
    c.domain.grid_extent(p.x.data() + 3 * k0, k1 - k0, my_lo, my_hi);
    part_lo[t] = my_lo, part_hi[t] = my_hi;
    if (k1 > k0) part_r[t] = *std::max_element(p.radius.begin() + k0, p.radius.begin() + k1);
  }
  lo = part_lo[0], hi = part_hi[0];
  for (int t = 1; t < threads; ++t) lo = lo.cwiseMin(part_lo[t]), hi = hi.cwiseMax(part_hi[t]);
  return *std::max_element(part_r.begin(), part_r.end());
}
}  // namespace

NeighborList::CellGrid NeighborList::plan_grid(const Context& c, double skin) const {
  CellGrid g;
  const std::size_t n = c.particles.size();
  if (n == 0) return g;
  const ParticleStore& p = c.particles.arrays();
  const double rmax = extent(c, g.lo, g.hi);
  g.h = 2.0 * rmax + skin;  // cells no smaller than the largest cutoff
  // A periodic box: the box and its ghosts' layer (NeighborList::ghost_margin), on a dense grid.
  const double margin = c.domain.periodic() ? ghost_margin(g.h, skin) + c.domain.excursion(p.x.data(), n) : 0.0;
  for (int d = 0; d < 3; ++d)
    if (c.domain.periodic(d)) {
      g.lo[d] = c.domain.lower()[d] - margin;
      g.hi[d] = c.domain.upper()[d] + margin;
    }
  const double max_cells = 2.0 * static_cast<double>(n) + 1000.0;
  double total = 1;
  for (int d = 0; d < 3; ++d) total *= std::floor((g.hi[d] - g.lo[d]) / g.h) + 1;
  if (total <= max_cells || c.domain.periodic()) {  // (false for an extent that overflows, too)
    for (int d = 0; d < 3; ++d) g.dims[d] = static_cast<long>(std::floor((g.hi[d] - g.lo[d]) / g.h)) + 1;
    // The axis with the most cells slowest (on a tie, the later one: z before y before x); the
    // other two in their order, x fastest.
    int slow = 2;
    for (int d = 1; d >= 0; --d)
      if (g.dims[d] > g.dims[slow]) slow = d;
    std::array<int, 3> axis{0, 1, 2};
    std::stable_partition(axis.begin(), axis.end(), [&](int a) { return a != slow; });
    g.stride[axis[0]] = 1;
    g.stride[axis[1]] = g.dims[axis[0]];
    g.stride[axis[2]] = g.dims[axis[0]] * g.dims[axis[1]];
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

NeighborList::CellKey NeighborList::cell_of(const CellGrid& g, const double* x) {
  CellKey key;
  for (int d = 0; d < 3; ++d) {
    const double c = g.sparse ? (0.5 * x[d] - 0.5 * g.lo[d]) / (0.5 * g.h) : (x[d] - g.lo[d]) / g.h;
    key[2 - d] = std::clamp(static_cast<long>(c), 0L, g.dims[d] - 1);
  }
  return key;
}

namespace {
// The dense grid's counting sort on `threads` threads, with the serial sort's result: cells
// counted and particles placed with atomic increments, then each cell's particles put back in
// index order (already so in a cell whose particles one thread placed). cell(k) is particle
// k's cell; `fill` is scratch.
template <class Cell>
void bin_dense_parallel(Cell&& cell, long ncell, int threads, Array<Index>& cell_of, Array<Index>& cell_start,
                        Array<Index>& perm, Array<Index>& fill) {
  const long n = static_cast<long>(cell_of.size());
  cell_start.resize(ncell + 1);
  fill.resize(ncell);
  Index* start = cell_start.data();
#pragma omp parallel num_threads(threads)
  {
#pragma omp for schedule(static) nowait
    for (long k = 0; k < n; ++k) cell_of[k] = cell(k);
#pragma omp for schedule(static)
    for (long q = 0; q <= ncell; ++q) start[q] = 0;
#pragma omp for schedule(static)
    for (long k = 0; k < n; ++k) {
#pragma omp atomic
      ++start[cell_of[k] + 1];
    }
  }
  list_loops::running_sums(start, ncell, threads);
#pragma omp parallel num_threads(threads)
  {
#pragma omp for schedule(static)
    for (long q = 0; q < ncell; ++q) fill[q] = start[q];
#pragma omp for schedule(static)
    for (long k = 0; k < n; ++k) {
      Index s;
#pragma omp atomic capture
      s = fill[cell_of[k]]++;
      perm[s] = static_cast<Index>(k);
    }
#pragma omp for schedule(static)
    for (long q = 0; q < ncell; ++q)
      if (start[q + 1] - start[q] > 1)
        list_loops::insertion_sort(perm.data() + start[q], perm.data() + start[q + 1], [](Index k) { return k; });
  }
}
}  // namespace

void NeighborList::bin_by_cell(const Context& ctx, const CellGrid& g) {
  const std::size_t n = ctx.particles.size();
  const double* x = ctx.particles.arrays().x.data();
  cell_of_.resize(n);
  perm_.resize(n);
  if (!g.sparse) {  // counting sort over every cell of the box
    const long ncell = g.dims[0] * g.dims[1] * g.dims[2];
    auto cell = [&](std::size_t k) {
      long c[3];
      for (int d = 0; d < 3; ++d)
        c[d] = std::clamp(static_cast<long>((x[3 * k + d] - g.lo[d]) / g.h), 0L, g.dims[d] - 1);
      return static_cast<Index>(g.index(c));
    };
    const int threads = ctx.parallel ? ctx.threads : 1;
    if (threads > 1 && static_cast<long>(n) >= list_loops::kScanRows) {
      bin_dense_parallel(cell, ncell, threads, cell_of_, cell_start_, perm_, scratch_int_);
      return;
    }
    for (std::size_t k = 0; k < n; ++k) cell_of_[k] = cell(k);
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
  for (std::size_t k = 0; k < n; ++k) key[k] = cell_of(g, &x[3 * k]);
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
std::string gib(double bytes) {
  char text[32];
  std::snprintf(text, sizeof text, "%.3g GiB", bytes / (1024.0 * 1024.0 * 1024.0));
  return text;
}
}  // namespace

double NeighborList::bytes_per_pair(const Context& c) {
  // A Verlet entry (its partner, its copy in a rebuild's per-thread parts, a refresh's mark)
  // and, at worst, a near entry: owner, partner, cutoff, reverse index, summation tag, touch
  // flag, the law's cached terms and contact state (16 doubles when no run has chosen a law
  // yet), with the lists' 1/8 growth room.
  int doubles = c.law_chosen ? c.law.entry_width : 0;
  for (int w : EntryStore::widths(c.contacts.pair_shape)) doubles += w;
  if (!c.law_chosen) doubles = std::max(doubles, 16);
  return 1.125 * (9.0 + 25.0 + 8.0 * doubles);
}

void NeighborList::check_fits(const Context& c, const CellGrid& g, double skin) const {
  const std::size_t n = c.particles.size();
  const ParticleStore& ps = c.particles.arrays();
  const double per_pair = bytes_per_pair(c);
  const double memory = static_cast<double>(available_memory());
  const double limit = std::min<double>(std::numeric_limits<Index>::max(), memory / per_pair);
  const double nd = static_cast<double>(n);
  if (0.5 * nd * (nd - 1) <= limit) return;  // even every pair fits
  // Upper bounds from the cells: each particle meets at most the particles of its 27 cells, so
  // at most 27 times the fullest cell's count (cheap), or (when that is over) their sum.
  auto occupancy = [&](long q) { return static_cast<double>(cell_start_[q + 1] - cell_start_[q]); };
  const long cells = static_cast<long>(cell_start_.size()) - 1;
  double fullest = 0;
  for (long q = 0; q < cells; ++q) fullest = std::max(fullest, occupancy(q));
  if (0.5 * nd * 27.0 * fullest <= limit) return;
  double around_sum = 0;
  for (long q = 0; q < cells; ++q) {
    const double own = occupancy(q);
    if (own == 0) continue;
    CellKey key = g.sparse ? cell_key_[q] : CellKey{(q / g.stride[2]) % g.dims[2], (q / g.stride[1]) % g.dims[1], (q / g.stride[0]) % g.dims[0]};
    double around = 0;
    for_each_cell_around(g, key, [&](long b) { around += occupancy(b); });
    around_sum += own * around;
  }
  if (0.5 * (around_sum - nd) <= limit) return;
  // The bound is over: count the pairs closer than their cutoff (particles not yet in cell
  // order: perm_ lists each cell's), stopping as soon as the count is over too.
  const double* x = ps.x.data();
  const double* r = ps.radius.data();
  double count = 0;
  for (std::size_t k = 0; k < n && count <= limit; ++k) {
    const Vec3 xk = vec3(x, k);
    for_each_cell_around(g, cell_of(g, &x[3 * k]), [&](long q) {
      for (Index s = cell_start_[q]; s < cell_start_[q + 1]; ++s) {
        const Index j = perm_[s];
        if (ps.id[j] <= ps.id[k]) continue;
        const double cut = r[k] + r[j] + skin;
        if (c.domain.displacement(xk, vec3(x, j)).squaredNorm() < cut * cut) ++count;
      }
    });
  }
  if (count <= limit) return;
  const double rmax = *std::max_element(ps.radius.begin(), ps.radius.end());
  const bool by_index = std::numeric_limits<Index>::max() < memory / per_pair;
  throw ResourceError(
      "the neighbour list of " + std::to_string(n) + " spheres would hold over " +
      std::to_string(static_cast<long long>(limit)) + " pairs (over " + gib(count * per_pair) + "), " +
      (by_index ? std::string("beyond the 2^31 - 1 entries its 32-bit indices hold")
                : "beyond the " + gib(memory) + " of memory available") +
      ": the pair cutoff r_i + r_j + skin (largest radius " + std::to_string(rmax) + " m, skin " +
      std::to_string(skin) + " m) reaches too many spheres; use a smaller skin or smaller spheres");
}

}  // namespace tsubu
