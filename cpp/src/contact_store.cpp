#include "tsubu/contact_store.hpp"

#include <algorithm>

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
                                    const Array<Id>& id, const CompiledLaw& law, int threads) {
  // Only touching entries have state: copy theirs, compactly, with rows by owner. On one thread
  // in one pass; on more, rows are counted, then copied, each row by one thread.
  const long rows = offset.empty() ? 0 : static_cast<long>(offset.size()) - 1;
  const double* overlap = pairs.overlap.data();
  const auto state = pairs.carried();
  const auto width = EntryStore::widths(pair_shape);
  std::array<const double*, kFields> now;
  for (std::size_t k = 0; k < kFields; ++k) now[k] = state[k]->data();
  auto size_for = [&](std::size_t count) {
    stash_partner.resize(count);
    for (std::size_t k = 0; k < kFields; ++k) stash_pairs[k].resize(state[k]->empty() ? 0 : count * width[k]);
  };
  // Row i's touching entries into the stash from entry c on; returns the entry after them.
  auto copy_row = [&](long i, std::size_t c) {
    for (Index q = offset[i]; q < offset[i + 1]; ++q) {
      if (!touching(law, overlap[q])) continue;
      stash_partner[c] = id[partner[q]];
      for (std::size_t k = 0; k < kFields; ++k) {
        if (stash_pairs[k].empty()) continue;
        const std::size_t wd = width[k];
        const double* from = now[k] + wd * q;
        std::copy(from, from + wd, stash_pairs[k].data() + wd * c);
      }
      ++c;
    }
    return c;
  };
  stash_offset.resize(rows + 1);
  stash_offset[0] = 0;
  if (threads <= 1) {
    std::size_t count = 0;
    for (const double o : pairs.overlap) count += touching(law, o);
    size_for(count);
    std::size_t c = 0;
    for (long i = 0; i < rows; ++i) stash_offset[i + 1] = static_cast<Index>(c = copy_row(i, c));
    return;
  }
#pragma omp parallel for schedule(static) num_threads(threads)
  for (long i = 0; i < rows; ++i) {
    Index count = 0;
    for (Index q = offset[i]; q < offset[i + 1]; ++q) count += touching(law, overlap[q]) ? 1 : 0;
    stash_offset[i + 1] = count;
  }
  list_loops::running_sums(stash_offset.data(), rows, threads);
  size_for(static_cast<std::size_t>(stash_offset[rows]));
#pragma omp parallel for schedule(static) num_threads(threads)
  for (long i = 0; i < rows; ++i) copy_row(i, static_cast<std::size_t>(stash_offset[i]));
}

namespace {
template <class... A>
std::size_t capacity_bytes(const A&... v) {
  return ((v.capacity() * sizeof(typename A::value_type)) + ... + 0);
}
}  // namespace

std::size_t ContactStore::bytes() const { return pairs.bytes() + walls.bytes(); }

std::size_t ContactStore::stash_bytes() const {
  std::size_t b = capacity_bytes(stash_offset, stash_partner, stash_wall_offset, stash_wall_index,
                                 stash_wall_element);
  for (std::size_t k = 0; k < kFields; ++k) b += capacity_bytes(stash_pairs[k], stash_walls[k]);
  return b;
}

}  // namespace tsubu
