#include "tsubu/contact_store.hpp"

#include <algorithm>
#include <vector>

#include "list_loops.hpp"

namespace tsubu {

void ContactStore::shape_for(const CompiledLaw& law) {
  const int moment = law.history_width > 0 ? 3 : 0;
  pair_shape = {law.history_width, law.rough_width > 0 ? 3 : moment, law.rolling ? 3 : 0, law.rough_width};
  wall_shape = {law.history_width, moment, law.rolling ? 3 : 0, law.rough_width};
}

void ContactStore::size(std::size_t pair_entries, std::size_t wall_entries, int threads) {
  auto size = [threads](EntryStore& st, const EntryShape& shape, std::size_t entries) {
    const auto width = EntryStore::widths(shape);
    const auto arrays = st.carried();
    for (std::size_t k = 0; k < kFields; ++k) fit_touched(*arrays[k], width[k] * entries, threads);
    fit_touched(st.touch, entries, threads);
  };
  size(pairs, pair_shape, pair_entries);
  size(walls, wall_shape, wall_entries);
}

void ContactStore::stash_pair_state(const Array<Index>& offset, const Array<Index>& partner,
                                    const Array<Id>& id, const CompiledLaw& law, int threads,
                                    const Array<Index>* verlet) {
  // Only touching entries have state: theirs, compactly, rows by owner, a zero row after the
  // last (for the new entries that carry nothing: NeighborList::carry_pairs gathers from it).
  // The entries are listed in one flat pass without a branch (a touching entry is a coin toss
  // for the branch predictor, and so is a row's end), then each field gathered.
  const long rows = offset.empty() ? 0 : static_cast<long>(offset.size()) - 1;
  const long m = rows > 0 ? static_cast<long>(offset[rows]) : 0;
  const double* overlap = pairs.overlap.data();
  auto touches = [&](long q) -> Index { return touching(law, overlap[q]); };
  fit(stash_before_, static_cast<std::size_t>(m) + 1);
  fit(stash_source_, static_cast<std::size_t>(m) + 1);  // (+ 1: where a part's last slot goes)
  Index* before = stash_before_.data();
  Index* source = stash_source_.data();
  const int nt = threads > 1 && m >= list_loops::kScanRows ? threads : 1;
  std::vector<Index> start(static_cast<std::size_t>(nt) + 1, 0);
#pragma omp parallel num_threads(nt) if (nt > 1)
  {
    const auto [t, team] = list_loops::part();
    const long lo = m * t / team, hi = m * (t + 1) / team;
    Index count = 0;
    for (long q = lo; q < hi; ++q) count += touches(q);
    start[t + 1] = count;
#pragma omp barrier
#pragma omp single
    for (int u = 0; u < team; ++u) start[u + 1] += start[u];
    Index c = start[t];
    const Index end = start[t + 1];
    for (long q = lo; q < hi; ++q) {
      before[q] = c;
      source[c < end ? c : m] = static_cast<Index>(q);
      c += touches(q);
    }
  }
  const std::size_t count = static_cast<std::size_t>(start[nt]);
  before[m] = static_cast<Index>(count);
  stash_offset.resize(rows + 1);
  stash_offset[0] = 0;
  const long last = offset.empty() ? -1 : rows;
  stash_by_verlet = verlet != nullptr;
  stash_partner.resize(count);
  const long stashed = static_cast<long>(count);
#pragma omp parallel num_threads(threads) if (threads > 1)
  {
#pragma omp for schedule(static) nowait
    for (long i = 0; i <= last; ++i) stash_offset[i] = before[offset[i]];
#pragma omp for schedule(static)
    for (long c = 0; c < stashed; ++c)
      stash_partner[c] = verlet ? Id((*verlet)[source[c]]) : id[partner[source[c]]];
  }
  const auto state = pairs.carried();
  const auto width = EntryStore::widths(pair_shape);
  for (std::size_t k = 0; k < kFields; ++k) {
    Array<double>& to = stash_pairs[k];
    if (state[k]->empty()) {
      to.clear();
      continue;
    }
    const std::size_t wd = static_cast<std::size_t>(width[k]);
    to.resize((count + 1) * wd);
    list_loops::gather_rows(to.data(), state[k]->data(), source, stashed, width[k], threads);
    std::fill(to.begin() + static_cast<std::ptrdiff_t>(count * wd), to.end(), 0.0);
  }
}

namespace {
template <class... A>
std::size_t capacity_bytes(const A&... v) {
  return ((v.capacity() * sizeof(typename A::value_type)) + ... + 0);
}
}  // namespace

std::size_t ContactStore::bytes() const { return pairs.bytes() + walls.bytes(); }

std::size_t ContactStore::stash_bytes() const {
  std::size_t b = capacity_bytes(stash_offset, stash_partner, stash_source_, stash_before_,
                                 stash_wall_offset, stash_wall_index, stash_wall_element);
  for (std::size_t k = 0; k < kFields; ++k) b += capacity_bytes(stash_pairs[k], stash_walls[k]);
  return b;
}

}  // namespace tsubu
