// The loop's instantiations, compiled in kRegistryParts translation units (registry_part*.cpp)
// so that a multi-core build compiles them side by side: part p holds the specialisations whose
// index k has k % kRegistryParts == p. Private to the library.
#pragma once
#include <array>
#include <cstddef>
#include <utility>

#include "tsubu/registry.hpp"

namespace tsubu::detail {

constexpr std::size_t kRoughnessN = RoughnessLaws::size, kRollingN = RollingLaws::size,
                      kTangentialN = TangentialLaws::size, kDampingN = DampingLaws::size,
                      kNormalN = NormalLaws::size, kCoreN = CoreLaws::size;
constexpr std::size_t kLawCount = kCoreN * kRollingN * kRoughnessN;
constexpr std::size_t kRegistryParts = 2;

// The slots' indices of each core (CoreLaws), in order.
template <std::size_t... C>
constexpr std::array<std::array<std::size_t, 3>, kCoreN> core_keys(std::index_sequence<C...>) {
  return {{{NormalLaws::index_of<typename CoreLaws::template at<C>::normal>(),
            DampingLaws::index_of<typename CoreLaws::template at<C>::damping>(),
            TangentialLaws::index_of<typename CoreLaws::template at<C>::tangential>()}...}};
}
constexpr auto kCoreKeys = core_keys(std::make_index_sequence<kCoreN>());

// Specialisation k: the core's index, then rolling, then roughness (the fastest); kLawCount if
// the key names no compiled core.
constexpr std::size_t law_index(const LawKey& k) {
  for (std::size_t c = 0; c < kCoreN; ++c)
    if (kCoreKeys[c][0] == k.normal && kCoreKeys[c][1] == k.damping && kCoreKeys[c][2] == k.tangential)
      return (c * kRollingN + k.rolling) * kRoughnessN + k.roughness;
  return kLawCount;
}

// Fills table[k] for every k of part `Part` (defined in registry_part.inc, instantiated once per
// part file).
template <std::size_t Part>
void compile_part(CompiledLaw* table);
template <>
void compile_part<0>(CompiledLaw* table);
template <>
void compile_part<1>(CompiledLaw* table);

}  // namespace tsubu::detail
