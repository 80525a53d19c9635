// Contact state: what each near-pair and near-wall entry carries from step to step (the
// tangential history, the overlap, the last results, the roughness draw), aligned with the
// neighbour list's entries, and the same state keyed by ids while the lists are rebuilt (the
// stash), so that a contact keeps its history whatever the particles' order and the lists'
// schedule. The stash and checkpoints speak in (owner id, partner id) for pairs, always owned by
// the lower id, and (sphere id, wall, element) for walls.
#pragma once
#include <array>
#include <cstddef>

#include "memory.hpp"
#include "registry.hpp"
#include "state.hpp"
#include "types.hpp"

namespace tsubu {

class ContactStore {
 public:
  static constexpr std::size_t kFields = EntryStore::kFields;
  // How each carried field (EntryStore::carried, in its order) changes if a pair's owner and
  // partner swap (i <-> j): -1 the values change sign (vectors measured from i: the tangential
  // displacement, the force on the owner, the rolling vector), +1 they do not (the overlap; n x F,
  // both factors flip), 0 the field is tied to its owner and cannot be swapped (the roughness
  // draw, keyed by the owner's id: a decomposition that hands a pair to its other sphere keeps
  // the lower id as the owner, as the lists do).
  static constexpr std::array<int, kFields> kSwapSign{-1, +1, -1, +1, -1, 0};

  EntryStore pairs, walls;          // per entry of the near list and of the near-wall list
  EntryShape pair_shape, wall_shape;  // the arrays the scene's law needs

  // The shapes the law needs (arrays it does not use stay empty).
  void shape_for(const CompiledLaw& law);
  // Sizes every array for the lists' entry counts (capacity grows by 1/8, not doubled; new
  // pages first touched on `threads` threads, fit_touched).
  void size(std::size_t pair_entries, std::size_t wall_entries, int threads = 1);

  // The stash: touching pair entries, compactly, rows by owner in `stash_offset` (the owner's
  // old index), partners as ids (or Verlet pairs: stash_by_verlet), a zero row after the last
  // (stash_pair_state); the near-wall list's entries whole, rows by sphere in
  // `stash_wall_offset`, with their (wall, element) keys (NeighborList::stash_near_walls, or a
  // checkpoint's wall contacts).
  Array<Index> stash_offset;
  Array<Id> stash_partner;
  std::array<Array<double>, kFields> stash_pairs, stash_walls;
  Array<Index> stash_wall_offset, stash_wall_index, stash_wall_element;

  // Moves the touching pair entries of rows `offset` (partners `partner`, internal indices)
  // into the stash, each keyed by its partner's id (`id` maps an internal index to its id) or,
  // where `verlet` is given (each entry's Verlet pair, NeighborList::near_verlet), by that
  // pair: a refresh, whose Verlet list and particle order stand. `law` says which entries touch
  // (touching(), registry.hpp); on `threads` threads where > 1.
  void stash_pair_state(const Array<Index>& offset, const Array<Index>& partner, const Array<Id>& id,
                        const CompiledLaw& law, int threads = 1, const Array<Index>* verlet = nullptr);
  bool stash_by_verlet = false;  // the stash's keys are Verlet pairs, not partner ids

  std::size_t bytes() const;
  std::size_t stash_bytes() const;

 private:
  // scratch of stash_pair_state: each stashed entry's index in the list; the touching entries
  // before each entry
  Array<Index> stash_source_, stash_before_;
};

// Resizes a per-entry array, growing its capacity by 1/8 rather than doubling: the lists change
// size a little at every refresh, and memory per particle is a figure we report.
template <class T>
void fit(Array<T>& a, std::size_t size, T value = T()) {
  if (size > a.capacity()) a.reserve(size + size / 8);
  a.resize(size, value);
}

// fit() for an array the threads then fill in parts: when it must grow, its new pages are first
// touched on `threads` threads before the old values are copied over (else every page fault of
// the new mapping, the kernel zeroing the page, falls on the one thread that copies).
template <class T>
void fit_touched(Array<T>& a, std::size_t size, int threads) {
  if (size > a.capacity() && threads > 1 && size * sizeof(T) >= detail::kLargePage) {
    Array<T> fresh;
    fresh.reserve(size + size / 8);
    detail::touch_pages(fresh.data(), fresh.capacity() * sizeof(T), threads);
    fresh.assign(a.begin(), a.end());
    a.swap(fresh);
  }
  fit(a, size);
}

}  // namespace tsubu
