// The near list (neighbor_list.hpp): from the Verlet list, the pairs within r_i + r_j + reach
// with their contact state carried over, the reverse index, the near-wall subset, the busy
// particles, the particle pass's flat sum list, and the law's cached terms of each entry.
#include <algorithm>
#include <cmath>
#include <vector>

#include "list_loops.hpp"
#include "tsubu/neighbor_list.hpp"

namespace tsubu {

using namespace list_loops;

void NeighborList::refresh_near(const Context& c, bool transfer, bool reordered, bool wall_transfer) {
  const std::size_t n = c.particles.size();
  ParticleStore& ps = c.particles.arrays();
  ContactStore& cs = c.contacts;
  const double* x = ps.x.data();
  const double* r = ps.radius.data();
  choose_near_fraction();
  const double reach = near_skin();

  // 1. The pairs of the Verlet list within r_i + r_j + reach, in the Verlet list's order:
  //    counted, then stored.
  auto near = [&](std::size_t i, Index j) {
    const double cut = r[i] + r[j] + reach;
    return c.domain.displacement(vec3(x, i), vec3(x, j)).squaredNorm() < cut * cut;
  };
  // Rows are independent: counted and filled in parallel (the same list for any thread count).
  // The count marks each Verlet pair kept, so that the fill does not measure it again.
  const long ni = static_cast<long>(n);
  near_offset.resize(n + 1);
  near_offset[0] = 0;
  Array<std::uint8_t>& kept = near_kept_;
  kept.resize(pair_partner.size());
#pragma omp parallel for schedule(static) num_threads(c.threads) if (c.parallel)
  for (long i = 0; i < ni; ++i) {
    Index count = 0;
    for (Index e = pair_offset[i]; e < pair_offset[i + 1]; ++e) {
      const bool in = near(i, pair_partner[e]);
      kept[e] = in;
      count += in;
    }
    near_offset[i + 1] = count;
  }
  running_sums(near_offset.data(), ni, scan_threads(c));
  const std::size_t m = static_cast<std::size_t>(near_offset[n]);
  fit_touched(near_owner, m, scan_threads(c));
  fit_touched(near_partner, m, scan_threads(c));
  const Alike alike = alike_spheres(ps, scan_threads(c));
  const bool one_radius = alike.radius;
  cut_mask = one_radius ? 0 : ~Index(0);
  fit_touched(near_cut2, one_radius ? 1 : m, scan_threads(c));
  if (one_radius) near_cut2[0] = (r[0] + r[0]) * (r[0] + r[0]);
  fit_touched(near_verlet_, m, scan_threads(c));
  // (How far a partner lies down or up the array from its owner: the reverse index's reach.)
  Index below = 0, above = 0;
#pragma omp parallel for schedule(static) num_threads(c.threads) if (c.parallel) reduction(max : below, above)
  for (long i = 0; i < ni; ++i) {
    Index q = near_offset[i];
    for (Index e = pair_offset[i]; e < pair_offset[i + 1]; ++e) {
      const Index j = pair_partner[e];
      if (!kept[e]) continue;
      near_verlet_[q] = e;
      near_owner[q] = static_cast<Index>(i);
      near_partner[q] = j;
      if (!one_radius) near_cut2[q] = (r[i] + r[j]) * (r[i] + r[j]);
      ++q;
      below = std::max(below, static_cast<Index>(i) - j);
      above = std::max(above, j - static_cast<Index>(i));
    }
  }
  reach_below = below;
  reach_above = above;

  // 2. Contact state, carried over from the stash (carry_pairs).
  refresh_walls(c, wall_transfer, reordered);  // (sizes the store's arrays, pairs' and walls')
  if (transfer && cs.stash_offset.size() > 1) {
    carry_pairs(c, reordered);
  } else {
    for (Array<double>* a : cs.pairs.carried()) zero(*a, c);
    mark_touching(cs.pairs, c);
  }

  // 3. Reverse index: for each particle, the entries where it is the partner, by owner id.
  //    (A ghost partner's entries are its source's.)
  near_rev_offset.resize(n + 1);
  near_rev_offset[0] = 0;
  fit_touched(near_rev, m, scan_threads(c));
  Array<Index>& fill = scratch_int_;
  if (scan_threads(c) > 1 && c.domain.ghosts() == 0 && ni >= kScanRows) {
    // Each thread takes the rows of a range of partners [j0, j1), reading only the entries of
    // the owners that can reach them ([j0 - above, j1 + below)), in entry order: each row is
    // filled in the order of the one-thread loop below.
    fill.resize(n);
    struct Rows {
      Index j0, j1, q0, q1;  // partners [j0, j1); the entries [q0, q1) that can reach them
    };
    auto rows = [&] {
      const auto [t, nt] = part();
      const Index j0 = static_cast<Index>(ni * t / nt), j1 = static_cast<Index>(ni * (t + 1) / nt);
      return Rows{j0, j1, near_offset[std::max<Index>(0, j0 - above)],
                  near_offset[std::min<Index>(static_cast<Index>(ni), j1 + below)]};
    };
#pragma omp parallel num_threads(c.threads)
    {
      const Rows me = rows();
      std::fill(near_rev_offset.data() + me.j0 + 1, near_rev_offset.data() + me.j1 + 1, 0);  // its rows
      for (Index q = me.q0; q < me.q1; ++q) {
        const Index j = near_partner[q];
        if (j >= me.j0 && j < me.j1) ++near_rev_offset[j + 1];
      }
    }
    running_sums(near_rev_offset.data(), ni, scan_threads(c));
#pragma omp parallel num_threads(c.threads)
    {
      const Rows me = rows();
      for (Index j = me.j0; j < me.j1; ++j) fill[j] = near_rev_offset[j];
      for (Index q = me.q0; q < me.q1; ++q) {
        const Index j = near_partner[q];
        if (j >= me.j0 && j < me.j1) near_rev[fill[j]++] = q;
      }
    }
    // (Rows filled in entry order, then sorted by owner id.)
#pragma omp parallel for schedule(static) num_threads(c.threads)
    for (long i = 0; i < ni; ++i)
      if (near_rev_offset[i + 1] - near_rev_offset[i] > 1)
        insertion_sort(near_rev.data() + near_rev_offset[i], near_rev.data() + near_rev_offset[i + 1],
                       [&](Index q) { return ps.id[near_owner[q]]; });
  } else {
    // One thread: the owners, visited in id order, fill each row in the order it keeps (by
    // owner id, then entry): no sort after.
    std::fill(near_rev_offset.begin() + 1, near_rev_offset.end(), 0);
    for (std::size_t q = 0; q < m; ++q) ++near_rev_offset[c.domain.source(near_partner[q], n) + 1];
    running_sums(near_rev_offset.data(), ni, scan_threads(c));
    fill.assign(near_rev_offset.begin(), near_rev_offset.end() - 1);
    const Id ids = static_cast<Id>(c.particles.id_bound());
    for (Id id = 0; id < ids; ++id) {
      const Index i = c.particles.index(id);
      if (i == Particles::kGone) continue;
      for (Index q = near_offset[i]; q < near_offset[i + 1]; ++q)
        near_rev[fill[c.domain.source(near_partner[q], n)]++] = q;
    }
  }
  // 4. The positions the step reads: every near-wall entry (flat sheets fold some), and the
  //    particles with entries.
  wall_near_offset.assign(wall_offset.begin(), wall_offset.end());
  fit(wall_near, wall_index.size());
  for (std::size_t e = 0; e < wall_near.size(); ++e) wall_near[e] = static_cast<Index>(e);
  gather_sheets(c);
  index_entries(c);
  cache_terms(c, alike.body);
  moved_near = 0;
  near_steps = 0;
  ++refreshes;
}

void NeighborList::carry_pairs(const Context& c, bool reordered) {
  // Only touching entries have state (an entry's results and history are zeroed when it opens;
  // a rough entry redraws its facet at first touch). Each new entry's stashed row is found
  // (source; the zero row where none), then each array is gathered in one loop.
  const long ni = static_cast<long>(c.particles.size());
  ParticleStore& ps = c.particles.arrays();
  ContactStore& cs = c.contacts;
  const Array<Index>& old_offset = cs.stash_offset;
  const Array<Id>& old_key = cs.stash_partner;
  const std::size_t old_n = old_offset.size() - 1;
  const Index none = old_offset[old_n];  // the stash's zero row
  const long m = static_cast<long>(near_partner.size());
  fit(carry_source_, static_cast<std::size_t>(m));
  fit(carry_taken_, static_cast<std::size_t>(none));
  Index* source = carry_source_.data();
  std::uint8_t* taken = carry_taken_.data();
  // A stashed contact not carried is touching and now beyond the near list: it opened.
  auto opened = [&](long i, Index p, Index j) {
    ps.dissipated[i] += spring_energy(c, ps.material[i], ps.material[j], cs.stash_pairs[0], p);
  };
  if (!reordered && cs.stash_by_verlet) {
    // A refresh: each row's stashed entries and new entries, both in Verlet-pair order, merged
    // (a map from every Verlet pair to its new entry would cost 4 bytes a Verlet pair: 13 bytes
    // a sphere at N = 1e6). Each row writes only its own entries and its own dissipation.
    const long rows = std::min(ni, static_cast<long>(old_n));
#pragma omp parallel for schedule(static) num_threads(c.threads) if (c.parallel)
    for (long i = 0; i < ni; ++i) {
      Index p = i < rows ? old_offset[i] : 0;
      const Index p_end = i < rows ? old_offset[i + 1] : 0;
      for (Index q = near_offset[i]; q < near_offset[i + 1]; ++q) {
        const Id e = near_verlet_[q];
        for (; p < p_end && old_key[p] < e; ++p) {  // (a sticky law's contact held beyond the reach)
          taken[p] = 0;
          opened(i, p, pair_partner[old_key[p]]);
        }
        const bool found = p < p_end && old_key[p] == e;
        source[q] = found ? p : none;
        if (found) taken[p++] = 1;
      }
      for (; p < p_end; ++p) {
        taken[p] = 0;
        opened(i, p, pair_partner[old_key[p]]);
      }
    }
  } else {
    // After a rebuild: rows merged by partner id (both sorted by it). Each row writes only its
    // own entries, its own old row and its own dissipation.
#pragma omp parallel for schedule(static) num_threads(c.threads) if (c.parallel)
    for (long i = 0; i < ni; ++i) {
      std::fill(source + near_offset[i], source + near_offset[i + 1], none);
      Index oi = static_cast<Index>(i);
      if (reordered) {
        if (ps.id[i] >= static_cast<Id>(old_index_of_.size())) continue;  // added since
        oi = old_index_of_[ps.id[i]];
      }
      if (oi < 0 || static_cast<std::size_t>(oi) >= old_n) continue;
      Index p = old_offset[oi];
      const Index p_end = old_offset[oi + 1];
      std::fill(taken + p, taken + p_end, std::uint8_t(0));
      for (Index q = near_offset[i]; q < near_offset[i + 1] && p < p_end; ++q) {
        const Id b = ps.id[near_partner[q]];
        while (p < p_end && old_key[p] < b) ++p;
        if (p == p_end || old_key[p] != b) continue;
        source[q] = p;
        taken[p++] = 1;
      }
      for (p = old_offset[oi]; p < p_end; ++p)
        if (!taken[p]) opened(i, p, c.particles.index(old_key[p]));
    }
  }
  const auto state = cs.pairs.carried();
  const auto width = EntryStore::widths(cs.pair_shape);
  const std::size_t rows = static_cast<std::size_t>(none) + 1;
  for (std::size_t k = 0; k < ContactStore::kFields; ++k) {
    if (state[k]->empty()) continue;
    if (cs.stash_pairs[k].size() != rows * static_cast<std::size_t>(width[k]))
      zero(*state[k], c);  // (the old law's array has another shape, or there was none)
    else
      gather_rows(state[k]->data(), cs.stash_pairs[k].data(), source, m, width[k], scan_threads(c));
  }
  std::uint8_t* touch = cs.pairs.touch.data();
#pragma omp parallel for schedule(static) num_threads(c.threads) if (c.parallel)
  for (long q = 0; q < m; ++q) touch[q] = source[q] != none;
}

// A wider near list is refreshed less often but scanned at every step. Per step, with f the
// reach as a fraction of the skin: the scan costs about c_s N_near(f), N_near(f) ~ N_0 + k f
// (k: the Verlet pairs per unit f beyond the last reach, taken as evenly spread up to the
// skin), and refreshes c_r N_verlet / T(f), T(f) = f skin / (2 u) steps with u the moved
// bound's growth per step since the last refresh. The sum is least at
// f = sqrt((c_r / c_s) N_verlet 2 u / (skin k)). c_r / c_s = kRefreshCost was measured on the
// Lees–Edwards shear cell (docs/benchmarks.md, "Lees–Edwards shear against LAMMPS"). The lists'
// contents and every result are the same for any reach: only the work changes.
void NeighborList::choose_near_fraction() {
  constexpr double kRefreshCost = 4.0;
  const double verlet = pair_offset.empty() ? 0.0 : double(pair_offset.back());
  const double near = near_offset.empty() ? 0.0 : double(near_offset.back());
  const double shell = (verlet - near) / (1.0 - near_fraction);
  if (near_steps <= 0 || !(moved_near > 0) || !(skin > 0) || !(shell > 0)) return;
  const double per_step = moved_near / double(near_steps);
  const double f = std::sqrt(kRefreshCost * verlet * 2.0 * per_step / (skin * shell));
  near_fraction = std::isfinite(f) ? std::clamp(f, kNearMin, kNearMax) : kNearMin;
}

void NeighborList::refresh_walls(const Context& c, bool transfer, bool reordered) {
  const std::size_t n = c.particles.size();
  const long ni = static_cast<long>(n);
  ParticleStore& ps = c.particles.arrays();
  ContactStore& cs = c.contacts;
  const double* x = ps.x.data();
  const double* r = ps.radius.data();
  const double reach = near_skin();
  const bool moving = c.walls.moving();
  // The stash (the last near-wall list, stash_near_walls; or a checkpoint's contacts): rows by
  // old index, keys, state. Its touching entries stay in the list, with their state.
  const std::size_t old_n = transfer && !cs.stash_wall_offset.empty() ? cs.stash_wall_offset.size() - 1 : 0;
  const Array<double>& old_overlap = cs.stash_walls[1];
  auto old_row = [&](long i) -> Index {
    if (old_n == 0) return -1;
    Index oi = static_cast<Index>(i);
    if (reordered) {
      if (ps.id[i] >= static_cast<Id>(old_index_of_.size())) return -1;  // added since
      oi = old_index_of_[ps.id[i]];
    }
    return oi >= 0 && static_cast<std::size_t>(oi) < old_n ? oi : -1;
  };
  // The stashed entry of old row oi with key (w, element), or -1 (rows are short: a scan).
  auto stashed = [&](Index oi, Index w, Index element) -> Index {
    if (oi < 0) return -1;
    for (Index q = cs.stash_wall_offset[oi]; q < cs.stash_wall_offset[oi + 1]; ++q)
      if (cs.stash_wall_index[q] == w && cs.stash_wall_element[q] == element) return q;
    return -1;
  };
  auto keeps = [&](long i, Index e, Index q) {
    return moving || (q >= 0 && touching(c.law, old_overlap[q])) ||
           c.walls.within(vec3(x, i), r[i], wall_reach_index[e], wall_reach_element[e], reach);
  };
  // 1. Counted, then written, the rows shared between the threads; reach_keep_: each reach
  //    entry's stashed entry (-1: none), or -2 where it is not kept.
  // (Most spheres reach no wall. Between rebuilds a sphere's old row lies within its reach, so
  // only the spheres with a reach row, wall_rows_, are visited; after one, every sphere: one
  // whose row is now empty may have left a touching contact behind.)
  const bool all = reordered;
  const long rows = all ? ni : static_cast<long>(wall_rows_.size());
  auto sphere = [&](long k) -> long { return all ? k : wall_rows_[k]; };
  wall_offset.resize(n + 1);
  if (!all) std::fill(wall_offset.begin(), wall_offset.end(), 0);
  wall_offset[0] = 0;
  fit(reach_keep_, wall_reach_index.size());
#pragma omp parallel for schedule(static) num_threads(c.threads) if (c.parallel)
  for (long k = 0; k < rows; ++k) {
    const long i = sphere(k);
    const Index oi = old_row(i);
    Index count = 0;
    for (Index e = wall_reach_offset[i]; e < wall_reach_offset[i + 1]; ++e) {
      const Index q = stashed(oi, wall_reach_index[e], wall_reach_element[e]);
      const bool kept = keeps(i, e, q);
      reach_keep_[e] = kept ? q : -2;
      count += kept ? 1 : 0;
    }
    wall_offset[i + 1] = count;
  }
  running_sums(wall_offset.data(), ni, scan_threads(c));
  const std::size_t m = static_cast<std::size_t>(wall_offset[n]);
  fit(wall_index, m);
  fit(wall_element, m);
  fit(wall_owner, m);
  cs.size(near_partner.size(), m, scan_threads(c));
  for (Array<double>* a : cs.walls.carried()) zero(*a, c);
  if (c.walls.has_meshes()) wall_tangent.resize(m);
  else wall_tangent.clear();
  wall_clear.assign(wall_tangent.size(), Walls::Clearance{});
  // (A record, where a sphere stood when its entry was found clear, and the tangent plane it
  // keeps: carried while the particles keep their places. A fresh record measures the entry.)
  const std::size_t stashed_entries = cs.stash_wall_index.size();
  const bool records = !reordered && !wall_clear.empty() && clear_stash_.size() == stashed_entries &&
                       tangent_stash_.size() == stashed_entries;
  const auto width = EntryStore::widths(cs.wall_shape);
  const auto state = cs.walls.carried();
  // 2. Each row writes only its own entries, its own old row and its own dissipation.
#pragma omp parallel for schedule(static) num_threads(c.threads) if (c.parallel)
  for (long s = 0; s < rows; ++s) {
    const long i = sphere(s);
    const Index oi = old_row(i);
    Index k = wall_offset[i];
    for (Index e = wall_reach_offset[i]; e < wall_reach_offset[i + 1]; ++e) {
      const Index q = reach_keep_[e];
      if (q == -2) continue;
      wall_index[k] = wall_reach_index[e];
      wall_element[k] = wall_reach_element[e];
      wall_owner[k] = static_cast<Index>(i);
      if (q >= 0 && records) wall_clear[k] = clear_stash_[q], wall_tangent[k] = tangent_stash_[q];
      if (q >= 0 && touching(c.law, old_overlap[q])) {
        for (std::size_t f = 0; f < ContactStore::kFields; ++f) {
          const Array<double>& old = cs.stash_walls[f];
          Array<double>& now = *state[f];
          if (now.empty() || old.empty()) continue;  // the old or new law has no such array
          const std::size_t wd = width[f];
          std::copy(&old[wd * q], &old[wd * q] + wd, &now[wd * k]);
        }
        cs.stash_walls[1][q] = 0;  // carried
      }
      ++k;
    }
    if (oi < 0) continue;
    for (Index q = cs.stash_wall_offset[oi]; q < cs.stash_wall_offset[oi + 1]; ++q)
      if (touching(c.law, old_overlap[q]))  // touching, and now beyond the skin: it opened
        ps.dissipated[i] += spring_energy(c, ps.material[i], c.walls.material(cs.stash_wall_index[q]),
                                          cs.stash_walls[0], q);
  }
  mark_touching(cs.walls, c);
}

void NeighborList::gather_sheets(const Context& c) {
  wall_sheet.clear();
  sheet_offset.assign(1, 0);
  sheet_entry.clear();
  sheet_slot.clear();
  sheet_room.clear();
  if (!c.sheets || !c.walls.has_meshes() || c.walls.moving() || c.law.sticky) return;
  const std::size_t n = c.particles.size();
  const long ni = static_cast<long>(n);
  const double* x = c.particles.arrays().x.data();
  const double* r = c.particles.arrays().radius.data();
  const std::uint8_t* touch = c.contacts.walls.touch.data();
  const double reach = near_skin();
  // 1. Each sphere's positions of one wall: a sheet (sheet_mark_: its holder at the first, -2
  //    at the others) or as they are (-1); each sphere's positions, sheets and sheet entries.
  fit(sheet_mark_, wall_near.size());
  Array<Index>& positions = sheet_rows_[0];
  Array<Index>& sheets = sheet_rows_[1];
  Array<Index>& entries = sheet_rows_[2];
  for (Array<Index>& a : sheet_rows_) fit(a, n + 1), a[0] = 0;
#pragma omp parallel num_threads(c.threads) if (c.parallel)
  {
    std::vector<Index> tris;
#pragma omp for schedule(static)
    for (long i = 0; i < ni; ++i) {
      Index kept = 0, made = 0, held = 0;
      const Index end = wall_near_offset[i + 1];
      for (Index p = wall_near_offset[i]; p < end;) {
        const Index w = wall_index[wall_near[p]];
        Index q = p + 1;
        while (q < end && wall_index[wall_near[q]] == w) ++q;
        Index holder = -1;
        bool sheet = false;
        if (c.walls.kind(int(w)) == Walls::kMesh) {
          int touched = 0;
          tris.clear();
          for (Index a = p; a < q; ++a) {
            tris.push_back(wall_element[wall_near[a]]);
            if (touch[wall_near[a]]) ++touched, holder = wall_near[a];
          }
          const Mesh& mesh = c.walls.mesh(int(w));
          sheet = touched <= 1 && mesh.flat_sheet(vec3(x, i), r[i] + reach, tris.data(), int(tris.size()));
          if (sheet && holder < 0) {  // the triangle the sphere lies over, if any
            holder = wall_near[p];
            for (Index a = p; a < q; ++a)
              if (mesh.over_face(vec3(x, i), wall_element[wall_near[a]])) {
                holder = wall_near[a];
                break;
              }
          }
        }
        for (Index a = p; a < q; ++a) sheet_mark_[a] = sheet ? (a == p ? holder : -2) : -1;
        kept += sheet ? 1 : q - p;
        made += sheet ? 1 : 0;
        held += sheet ? q - p : 0;
        p = q;
      }
      positions[i + 1] = kept, sheets[i + 1] = made, entries[i + 1] = held;
    }
  }
  for (Array<Index>& a : sheet_rows_) running_sums(a.data(), ni, scan_threads(c));
  if (sheets[n] == 0) return;  // (no sheet: the step takes the plain path)
  // 2. The positions without the folded ones, and the sheets, each sphere's where the counts
  //    put them.
  fit(wall_near_next_, static_cast<std::size_t>(positions[n]));
  fit(wall_sheet, static_cast<std::size_t>(positions[n]));
  fit(sheet_offset, static_cast<std::size_t>(sheets[n]) + 1);
  fit(sheet_entry, static_cast<std::size_t>(entries[n]));
#pragma omp parallel for schedule(static) num_threads(c.threads) if (c.parallel)
  for (long i = 0; i < ni; ++i) {
    Index o = positions[i], k = sheets[i], e = entries[i];
    const Index end = wall_near_offset[i + 1];
    for (Index p = wall_near_offset[i]; p < end; ++p) {
      if (sheet_mark_[p] == -2) continue;
      if (sheet_mark_[p] == -1) {
        wall_near_next_[o] = wall_near[p], wall_sheet[o++] = -1;
        continue;
      }
      wall_near_next_[o] = sheet_mark_[p], wall_sheet[o++] = k;
      Index q = p;
      do sheet_entry[e++] = wall_near[q++];
      while (q < end && sheet_mark_[q] == -2);
      sheet_offset[++k] = e;
    }
  }
  wall_near.swap(wall_near_next_);
  std::copy(positions.begin(), positions.begin() + ni + 1, wall_near_offset.begin());
  sheet_slot.assign(static_cast<std::size_t>(sheets[n]), -1);
  sheet_room.assign(4 * sheet_slot.size(), -1.0);
}

void NeighborList::index_entries(const Context& c) {
  const std::size_t n = c.particles.size();
  loaded.assign(n + c.domain.ghosts(), 0);  // (a ghost's mark goes to its source: Domain::fold)
  filter(static_cast<long>(n), [&](long i) {
    return wall_near_offset[i + 1] > wall_near_offset[i] || near_offset[i + 1] > near_offset[i] ||
           near_rev_offset[i + 1] > near_rev_offset[i];
  }, busy, c);
  build_sum_entries(c);
  measure(c);
  fit(active, wall_near.size());  // the walls in contact (engine/contact_pass.hpp)
}

void NeighborList::build_sum_entries(const Context& c) {
  const std::size_t nb = busy.size();
  const std::size_t largest = std::max(near_partner.size(), wall_index.size());
  if (largest >= (std::size_t(1) << 29)) {  // no room for the tags: the particle pass loops
    sum_offset.clear();
    sum_entry.clear();
    std::fill(sheet_slot.begin(), sheet_slot.end(), -1);
    return;
  }
  fit(sum_offset, nb + 1);
  sum_offset[0] = 0;
  const long nbl = static_cast<long>(nb);
#pragma omp parallel for schedule(static) num_threads(c.threads) if (c.parallel)
  for (long b = 0; b < nbl; ++b) {
    const Index k = busy[b];
    sum_offset[b + 1] = (wall_near_offset[k + 1] - wall_near_offset[k]) +
                        (near_offset[k + 1] - near_offset[k]) +
                        (near_rev_offset[k + 1] - near_rev_offset[k]);
  }
  running_sums(sum_offset.data(), nbl, scan_threads(c));
  fit(sum_entry, static_cast<std::size_t>(sum_offset[nb]));
  // Each busy particle's run: its walls, then its owned pairs, then its reverse pairs (rows by
  // source: a ghost partner's entries are its source's), each particle's written by one thread.
  // (Per particle rather than one flat loop per kind, which needed 12 bytes a particle of bases:
  // this runs at refreshes only.)
  std::uint32_t* out = sum_entry.data();
  const bool sheets = !wall_sheet.empty();
#pragma omp parallel for schedule(static) num_threads(c.threads) if (c.parallel)
  for (long b = 0; b < nbl; ++b) {
    const Index k = busy[b];
    Index at = sum_offset[b];
    for (Index p = wall_near_offset[k]; p < wall_near_offset[k + 1]; ++p, ++at) {
      if (sheets && wall_sheet[p] >= 0) sheet_slot[wall_sheet[p]] = at;  // (the holder moves: the step rewrites it)
      out[at] = (std::uint32_t(wall_near[p]) << 3) | 2u;
    }
    for (Index q = near_offset[k]; q < near_offset[k + 1]; ++q, ++at) out[at] = std::uint32_t(q) << 3;
    for (Index p = near_rev_offset[k]; p < near_rev_offset[k + 1]; ++p, ++at)
      out[at] = (std::uint32_t(near_rev[p]) << 3) | 1u;
    out[sum_offset[b]] |= 4u;  // a busy particle has at least one entry
  }
}

void NeighborList::measure_reach(const Context& c) {
  Index below = 0, above = 0;
  const long m = static_cast<long>(near_partner.size());
#pragma omp parallel for schedule(static) num_threads(c.threads) if (c.parallel) reduction(max : below, above)
  for (long q = 0; q < m; ++q) {
    below = std::max(below, near_owner[q] - near_partner[q]);
    above = std::max(above, near_partner[q] - near_owner[q]);
  }
  reach_below = below;
  reach_above = above;
}

void NeighborList::measure(const Context& c) {
  Index most = 0;
  const long nb = static_cast<long>(busy.size());
#pragma omp parallel for schedule(static) num_threads(c.threads) if (c.parallel) reduction(max : most)
  for (long b = 0; b < nb; ++b) {
    const Index k = busy[b];
    most = std::max(most, (wall_near_offset[k + 1] - wall_near_offset[k]) +
                              (near_offset[k + 1] - near_offset[k]) +
                              (near_rev_offset[k + 1] - near_rev_offset[k]));
  }
  max_entries = most;
}

void NeighborList::cache_terms(const Context& c) {
  cache_terms(c, alike_spheres(c.particles.arrays(), scan_threads(c)).body);
}

void NeighborList::cache_terms(const Context& c, bool one) {
  const std::size_t width = c.law.entry_width;
  const ParticleStore& ps = c.particles.arrays();
  const double *mass = ps.mass.data(), *radius = ps.radius.data(), *inv_mass = ps.inv_mass.data();
  const int* material = ps.material.data();
  // (`one`: alike spheres, alike_spheres; every pair of them has the terms of sphere 0 with
  // itself, bit for bit.)
  entry_mask = one ? 0 : ~Index(0);
  fit(near_entry, width * (one ? 1 : near_partner.size()));
  const long m = one ? 1 : static_cast<long>(near_partner.size());
#pragma omp parallel for schedule(static) num_threads(c.threads) if (c.parallel)
  for (long q = 0; q < m; ++q) {
    const Index i = one ? 0 : near_owner[q], j = one ? 0 : near_partner[q];
    // A fixed sphere (inverse mass 0, boundary.hpp) is a wall to the other: its mass.
    const double m_pair = mass[i] * mass[j] / (mass[i] + mass[j]);
    const double m_eff = inv_mass[j] == 0 ? mass[i] : (inv_mass[i] == 0 ? mass[j] : m_pair);
    const double r_eff = radius[i] * radius[j] / (radius[i] + radius[j]);
    c.law.entry_terms(c.pairs(material[i], material[j]), m_eff, r_eff, near_entry.data() + width * q);
  }
}

}  // namespace tsubu
