// Linked cells with a skin (Verlet list): the half pair list, the near-wall list, the sort of
// particles by cell, and the transfer of contact state across rebuilds (neighbor_list.hpp).
#include "tsubu/neighbor_list.hpp"

#include <algorithm>
#include <cmath>
#include <type_traits>
#include <vector>

#include "list_loops.hpp"

namespace tsubu {

using namespace list_loops;


void NeighborList::rebuild(const Context& c, double skin_now, bool keep_history, bool wrap) {
  // 1. Cells: the bounding box of the particles, cells no smaller than the largest cutoff. The
  //    particles are binned and the list's size checked before anything changes, so that a
  //    list that cannot fit is refused with the state as it was. (A periodic box first wraps
  //    its spheres, after the stash: only then are their cells known.)
  const bool periodic = c.domain.periodic();
  CellGrid grid;
  auto bin = [&] {
    grid = plan_grid(c, skin_now);
    if (c.particles.size() > 0) {
      bin_by_cell(c, grid);
      check_fits(c, grid, skin_now);
    }
  };
  if (!periodic) bin();
  skin = skin_now;

  // 2. Set the old near and wall lists aside, in terms of ids, with their state; then put the
  //    particles in cell order.
  const std::size_t old_n = near_offset.size() == 0 ? 0 : near_offset.size() - 1;
  const bool transfer = keep_history && old_n > 0 && wall_offset.size() == old_n + 1;
  ContactStore& cs = c.contacts;
  if (transfer) {
    cs.stash_pair_state(near_offset, near_partner, c.particles.arrays().id, c.law,
                               c.parallel ? c.threads : 1);
    stash_near_walls(c);
    old_index_of_.resize(c.particles.id_bound());
    const long ids = static_cast<long>(old_index_of_.size());
#pragma omp parallel for schedule(static) num_threads(c.threads) if (c.parallel)
    for (long id = 0; id < ids; ++id) old_index_of_[id] = c.particles.index(Id(id));
  }
  if (periodic) {
    c.particles.drop_ghosts();
    c.domain.clear_ghosts();
    if (wrap) c.domain.wrap(c.particles.arrays(), c.particles.size());
    bin();
  }
  if (c.particles.size() > 0) c.particles.permute(perm_, scratch_, c.parallel ? c.threads : 1);
  if (periodic) make_ghosts(c, grid);
  else ghost_cell_start_.clear();

  // 3. Verlet half list, each pair owned by its lower id.
  build_verlet(c, grid, skin_now);

  // 4. The walls' reach list.
  build_walls(c, skin_now);

  // 5. The near and near-wall lists and their contact state.
  refresh_near(c, transfer, true, transfer);

  // 6. Reference state for the rebuild criterion.
  moved = 0;
  c.walls.mark(grid.lo, grid.hi);
  valid = true;
  ++rebuilds;
}

void NeighborList::make_ghosts(const Context& c, const CellGrid& g) {
  const std::size_t n = c.particles.size();
  const long ncell = g.dims[0] * g.dims[1] * g.dims[2];
  auto cell = [&](const Vec3& y) {
    long k[3];
    for (int d = 0; d < 3; ++d) k[d] = std::clamp(static_cast<long>((y[d] - g.lo[d]) / g.h), 0L, g.dims[d] - 1);
    return static_cast<std::uint64_t>(g.index(k));
  };
  // (Spheres left unwrapped, as a checkpoint's restore leaves them, may stand further out.)
  const double margin = ghost_margin(g.h, skin) + c.domain.excursion(c.particles.arrays().x.data(), n);
  c.domain.make_ghosts(c.particles.arrays(), n, margin, ghost_margin(g.h, skin), cell);
  c.particles.set_ghosts(c.domain.ghosts());
  const double* x = c.particles.arrays().x.data();
  ghost_cell_start_.assign(ncell + 1, 0);
  for (std::size_t q = 0; q < c.domain.ghosts(); ++q) ++ghost_cell_start_[cell(vec3(x, n + q)) + 1];
  for (long k = 0; k < ncell; ++k) ghost_cell_start_[k + 1] += ghost_cell_start_[k];
}

void NeighborList::build_verlet(const Context& c, const CellGrid& grid, double skin_now) {
  // Count, prefix sum, fill, sort.
  const std::size_t n = c.particles.size();
  const ParticleStore& ps = c.particles.arrays();
  pair_offset.resize(n + 1);  // (rows 1..n counted below)
  pair_offset[0] = 0;
  const double* x = ps.x.data();
  const double* r = ps.radius.data();
  const Id* id = ps.id.data();
  const Vec3& lo_cell = grid.lo;
  const double h = grid.h;
  const std::array<long, 3>& dims = grid.dims;
  // The dense grid's axes from slowest to fastest, and their strides in that order.
  std::array<int, 3> axis{2, 1, 0};
  std::stable_sort(axis.begin(), axis.end(), [&](int a, int b) { return grid.stride[a] > grid.stride[b]; });
  const long stride[2] = {grid.stride[axis[0]], grid.stride[axis[1]]};  // (the fastest: 1)
  const Index halo = static_cast<Index>(n);  // the first ghost row
  const Index* ghost_start = ghost_cell_start_.empty() ? nullptr : ghost_cell_start_.data();
  // (The ghosts' loop is compiled in only where there are ghosts: an open scene's rebuild
  // pays nothing for it.)
  auto build = [&](auto ghosts) {
    constexpr bool kGhosts = decltype(ghosts)::value;
    // Row i's partners into `row` (from its start; returns their count).
    auto find_partners = [&](Index i, Array<Index>& row) {
      const Vec3 xi = vec3(x, i);
      const Id idi = id[i];
      const double ri = r[i];
      Index found = 0;
      // (Every candidate written, the count moved by both tests: no branch, where either test
      // is a coin toss for the branch predictor.)
      auto visit_range = [&](Index j0, Index j1) {
        const std::size_t room = std::size_t(found) + std::size_t(j1 - j0);
        if (row.size() < room) row.resize(2 * room);
        Index* out = row.data();
        for (Index j = j0; j < j1; ++j) {
          const double cut = ri + r[j] + skin_now;
          const bool near = c.domain.displacement(xi, vec3(x, j)).squaredNorm() < cut * cut;
          out[found] = j;
          found += (near & (id[j] > idi)) ? 1 : 0;  // (a ghost has its source's id: each pair once)
        }
      };
      // Cells [first, last], consecutive: their particles (and ghosts) are one range each.
      auto visit_cells = [&](long first, long last) {
        visit_range(cell_start_[first], cell_start_[last + 1]);
        if constexpr (kGhosts) visit_range(halo + ghost_start[first], halo + ghost_start[last + 1]);
      };
      auto visit_cell = [&](long cell) { visit_cells(cell, cell); };
      if (grid.sparse) {
        for_each_cell_around(grid, cell_of(grid, &x[3 * i]), visit_cell);
        return found;
      }
      // The dense grid, indexed directly (the common case: kept tight); the cells around in
      // increasing index order, the slowest axis outermost. The fastest axis has stride 1
      // (CellGrid::stride): its up to three cells are one run.
      long lo[3], hi[3];
      for (int a = 0; a < 3; ++a) {
        const int d = axis[a];
        const long c = std::clamp(static_cast<long>((xi[d] - lo_cell[d]) / h), 0L, dims[d] - 1);
        lo[a] = std::max(c - 1, 0L), hi[a] = std::min(c + 1, dims[d] - 1);
      }
      for (long s = lo[0]; s <= hi[0]; ++s)
        for (long m = lo[1]; m <= hi[1]; ++m) {
          const long run = s * stride[0] + m * stride[1];
          visit_cells(run + lo[2], run + hi[2]);
        }
      return found;
    };
    // One pass over the candidates (a count first, then a fill, measured each pair twice): each
    // thread appends its rows' partners, the first thread's in place, the others' to their
    // parts of verlet_parts_, which then take their places. The same list for any thread count.
    const long nl = static_cast<long>(n);
    const int most = scan_threads(c);
    if (static_cast<int>(verlet_parts_.size()) < most) verlet_parts_.resize(most);
    if (static_cast<int>(verlet_rows_.size()) < most) verlet_rows_.resize(most);
    pair_partner.clear();
    int team = 1;
    auto rows = [&](int t) { return std::array<long, 2>{nl * t / team, nl * (t + 1) / team}; };
#pragma omp parallel num_threads(most) if (most > 1)
    {
      const auto [t, nt] = list_loops::part();
#pragma omp single
      team = nt;
      Array<Index>& out = t == 0 ? pair_partner : verlet_parts_[t];
      out.clear();
      const auto [lo, hi] = rows(t);
      // (Grown by an eighth at a time, as the lists' room: a vector's doubling would hold up to
      // twice the list. Once warm, a rebuild reuses the capacity.)
      auto append = [&out](Index j) {
        if (out.size() == out.capacity()) out.reserve(out.size() + out.size() / 8 + 1024);
        out.push_back(j);
      };
      Array<Index>& row = verlet_rows_[t];
      if (row.size() < 64) row.resize(64);
      for (long i = lo; i < hi; ++i) {
        const std::size_t start = out.size();
        const Index found = find_partners(static_cast<Index>(i), row);
        for (Index k = 0; k < found; ++k) append(row[std::size_t(k)]);
        insertion_sort(out.data() + start, out.data() + out.size(), [&](Index j) { return id[j]; });
        pair_offset[i + 1] = static_cast<Index>(out.size() - start);
      }
    }
    running_sums(pair_offset.data(), nl, most);
    const std::size_t total = static_cast<std::size_t>(pair_offset[n]);
    if (total > pair_partner.capacity()) pair_partner.reserve(total + total / 8);
    pair_partner.resize(total);
#pragma omp parallel for schedule(static, 1) num_threads(most) if (team > 1)
    for (int t = 1; t < team; ++t)
      std::copy(verlet_parts_[t].begin(), verlet_parts_[t].end(), pair_partner.begin() + pair_offset[rows(t)[0]]);
  };
  if (ghost_start) build(std::true_type{});
  else build(std::false_type{});
}

void NeighborList::build_walls(const Context& c, double skin_now) {
  // The (wall, element) keys within r + skin of each sphere (or behind it).
  const std::size_t n = c.particles.size();
  ParticleStore& ps = c.particles.arrays();
  const double* x = ps.x.data();
  const double* r = ps.radius.data();
  const long ni = static_cast<long>(n);
  wall_reach_offset.resize(n + 1);  // (rows 1..n counted below)
  wall_reach_offset[0] = 0;
#pragma omp parallel for schedule(static) num_threads(c.threads) if (c.parallel)
  for (long i = 0; i < ni; ++i) {
    Index count = 0;
    c.walls.for_each_near(vec3(x, i), r[i], skin_now, [&](Index, Index) { ++count; });
    wall_reach_offset[i + 1] = count;
  }
  running_sums(wall_reach_offset.data(), ni, scan_threads(c));
  wall_reach_index.resize(static_cast<std::size_t>(wall_reach_offset[n]));
  wall_reach_element.resize(wall_reach_index.size());
#pragma omp parallel for schedule(static) num_threads(c.threads) if (c.parallel)
  for (long i = 0; i < ni; ++i) {
    Index e = wall_reach_offset[i];
    c.walls.for_each_near(vec3(x, i), r[i], skin_now, [&](Index w, Index element) {
      wall_reach_element[e] = element;
      wall_reach_index[e++] = w;
    });
  }
  list_loops::filter(ni, [&](long i) { return wall_reach_offset[i + 1] > wall_reach_offset[i]; }, wall_rows_, c);
}

void NeighborList::stash_near_walls(const Context& c) {
  ContactStore& cs = c.contacts;
  cs.stash_wall_offset.swap(wall_offset);
  cs.stash_wall_index.swap(wall_index);
  cs.stash_wall_element.swap(wall_element);
  const auto now = cs.walls.carried();
  for (std::size_t k = 0; k < ContactStore::kFields; ++k) cs.stash_walls[k].swap(*now[k]);
  clear_stash_.swap(wall_clear);
  tangent_stash_.swap(wall_tangent);
}

bool NeighborList::reaches(Index i, Index wall, Index element) const {
  if (static_cast<std::size_t>(i) + 1 >= wall_reach_offset.size()) return false;
  for (Index e = wall_reach_offset[i]; e < wall_reach_offset[i + 1]; ++e)
    if (wall_reach_index[e] == wall && wall_reach_element[e] == element) return true;
  return false;
}

namespace {

// Moves entry e of `a` (a.size() / to.size() values each) to entry to[e] <= e, dropping those
// with to[e] < 0, and trims `a` to `kept` entries.
template <class C>
void compact(C& a, const Array<Index>& to, std::size_t kept) {
  if (a.empty() || to.empty()) return;
  const std::size_t wd = a.size() / to.size();
  for (std::size_t e = 0; e < to.size(); ++e)
    if (to[e] >= 0 && static_cast<std::size_t>(to[e]) != e)
      std::copy_n(a.data() + wd * e, wd, a.data() + wd * static_cast<std::size_t>(to[e]));
  a.resize(wd * kept);
}

// Rows `offset` (over the old rows) without the rows row_to[k] < 0 and the entries to[e] < 0;
// `value` (may be null) holds an index per entry, mapped through `map` (its entries' new
// indices are to[e]). Returns the entries kept.
std::size_t drop_rows(Array<Index>& offset, const Array<Index>& row_to, Array<Index>& to,
                      const Array<Index>* value, const Array<Index>* map) {
  const std::size_t rows = row_to.size();
  to.resize(offset.empty() ? 0 : static_cast<std::size_t>(offset[rows]));
  Index kept = 0, row = 0;
  for (std::size_t k = 0; k < rows; ++k) {
    const Index begin = offset[k], end = offset[k + 1];
    if (row_to[k] >= 0) offset[row++] = kept;  // (row <= k: the old offsets ahead stay)
    for (Index e = begin; e < end; ++e)
      to[e] = (row_to[k] >= 0 && (value == nullptr || (*map)[(*value)[e]] >= 0)) ? kept++ : -1;
  }
  offset[row] = kept;
  offset.resize(static_cast<std::size_t>(row) + 1);
  return static_cast<std::size_t>(kept);
}

// Maps an index array's values through `map` after compacting it by `to`.
void remap(Array<Index>& a, const Array<Index>& to, std::size_t kept, const Array<Index>& map) {
  compact(a, to, kept);
  for (Index& v : a) v = map[v];
}

}  // namespace

void NeighborList::remove(const Context& c, const Id* gone, std::size_t count) {
  if (count == 0) return;
  Particles& particles = c.particles;
  const std::size_t old_n = particles.size();
  // Each old row's new row: the particles are compacted in order.
  Array<Index>& row_to = old_index_of_;
  row_to.assign(old_n, 0);
  for (std::size_t k = 0; k < count; ++k) row_to[static_cast<std::size_t>(particles.index(gone[k]))] = -1;
  Index next = 0;
  for (Index& r : row_to) r = r < 0 ? -1 : next++;
  particles.remove(gone, count);
  if (!built(old_n)) return;

  // The Verlet list: partners through row_to.
  Array<Index>& pair_to = scratch_int_;
  const std::size_t pairs_kept = drop_rows(pair_offset, row_to, pair_to, &pair_partner, &row_to);
  remap(pair_partner, pair_to, pairs_kept, row_to);

  // The near list and its state; the reverse index, rows by partner, through the entries' map.
  const std::size_t near_kept = drop_rows(near_offset, row_to, pair_to_, &near_partner, &row_to);
  remap(near_owner, pair_to_, near_kept, row_to);
  remap(near_partner, pair_to_, near_kept, row_to);
  remap(near_verlet_, pair_to_, near_kept, pair_to);  // (pair_to: the Verlet pairs' map)
  if (cut_mask != 0) compact(near_cut2, pair_to_, near_kept);
  if (entry_mask != 0) compact(near_entry, pair_to_, near_kept);  // (else width values, still right)
  for (Array<double>* a : c.contacts.pairs.carried()) compact(*a, pair_to_, near_kept);
  compact(c.contacts.pairs.touch, pair_to_, near_kept);
  const std::size_t rev_kept = drop_rows(near_rev_offset, row_to, pair_to, &near_rev, &pair_to_);
  remap(near_rev, pair_to, rev_kept, pair_to_);

  // The reach list; the near-wall list, its state, and the positions the step reads.
  const std::size_t reach_kept = drop_rows(wall_reach_offset, row_to, reach_to_, nullptr, nullptr);
  compact(wall_reach_index, reach_to_, reach_kept);
  compact(wall_reach_element, reach_to_, reach_kept);
  list_loops::filter(static_cast<long>(particles.size()),
                     [&](long i) { return wall_reach_offset[i + 1] > wall_reach_offset[i]; }, wall_rows_, c);
  const std::size_t walls_kept = drop_rows(wall_offset, row_to, wall_to_, nullptr, nullptr);
  compact(wall_index, wall_to_, walls_kept);
  compact(wall_element, wall_to_, walls_kept);
  remap(wall_owner, wall_to_, walls_kept, row_to);
  compact(wall_tangent, wall_to_, walls_kept);
  compact(wall_clear, wall_to_, walls_kept);
  for (Array<double>* a : c.contacts.walls.carried()) compact(*a, wall_to_, walls_kept);
  compact(c.contacts.walls.touch, wall_to_, walls_kept);
  const std::size_t subset_kept = drop_rows(wall_near_offset, row_to, pair_to, &wall_near, &wall_to_);
  remap(wall_near, pair_to, subset_kept, wall_to_);
  compact(wall_sheet, pair_to, subset_kept);  // (a removed sphere's sheets are left unread)
  // (and their entries at -1: a later removal must not map them again)
  for (Index& e : sheet_entry) e = e < 0 ? e : wall_to_[e];

  measure_reach(c);
  index_entries(c);
}

void NeighborList::refresh(const Context& c) {
  // (The Verlet list and the particles' order stand: the stash is keyed by Verlet pairs.)
  c.contacts.stash_pair_state(near_offset, near_partner, c.particles.arrays().id, c.law,
                               c.parallel ? c.threads : 1, &near_verlet_);
  stash_near_walls(c);
  refresh_near(c, true, false, true);
}

void NeighborList::rebuild_empty(const Context& c, double skin_now, bool wrap) {
  rebuild(c, skin_now, false, wrap);
}

void NeighborList::finish_restore(const Context& c) {
  clear_stash_.clear();  // (no records: every entry is measured)
  refresh_near(c, false, false, true);
}

double NeighborList::spring_energy(const Context& c, int a, int b, const Array<double>& xi, std::size_t e) {
  if (xi.empty()) return 0;
  return c.law.tangential_energy(c.pairs(a, b), xi.data() + c.law.history_width * e);
}

std::vector<std::array<Id, 2>> NeighborList::pairs_by_id(const Particles& particles) const {
  std::vector<std::array<Id, 2>> out;
  const std::size_t n = particles.size();
  if (pair_offset.size() != n + 1) return out;
  for (std::size_t i = 0; i < n; ++i)
    for (Index e = pair_offset[i]; e < pair_offset[i + 1]; ++e)
      out.push_back({particles.id(Index(i)), particles.id(pair_partner[e])});
  std::sort(out.begin(), out.end());
  return out;
}

namespace {
template <class... A>
std::size_t capacity_bytes(const A&... v) {
  return ((v.capacity() * sizeof(typename A::value_type)) + ... + 0);
}
}  // namespace

std::size_t NeighborList::verlet_bytes() const { return capacity_bytes(pair_offset, pair_partner); }
std::size_t NeighborList::near_bytes() const {
  return capacity_bytes(near_offset, near_owner, near_partner, near_rev_offset, near_rev, near_cut2,
                        near_entry, sum_entry);
}
std::size_t NeighborList::wall_bytes() const {
  return capacity_bytes(wall_reach_offset, wall_reach_index, wall_reach_element, wall_offset, wall_index,
                        wall_element, wall_owner, wall_near_offset, wall_near, wall_sheet,
                        sheet_offset, sheet_entry, sheet_slot, sheet_room);
}
std::size_t NeighborList::scratch_bytes() const {
  std::size_t parts = 0;
  for (const Array<Index>& a : verlet_parts_) parts += capacity_bytes(a);
  for (const Array<Index>& a : verlet_rows_) parts += capacity_bytes(a);
  return parts + capacity_bytes(near_kept_, near_verlet_, carry_source_,
                                carry_taken_, cell_start_, cell_of_, cell_key_, perm_, old_index_of_,
                                active, scratch_, scratch_int_, reach_to_, reach_keep_, wall_rows_,
                                sheet_mark_, wall_near_next_, sheet_rows_[0], sheet_rows_[1],
                                sheet_rows_[2], clear_stash_, tangent_stash_);
}

}  // namespace tsubu
