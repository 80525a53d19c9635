// The loop's instantiations, compiled in kRegistryParts translation units (registry_part*.cpp)
// so that a multi-core build compiles them side by side: part p holds the specialisations whose
// index k has k % kRegistryParts == p. Private to the library.
#pragma once
#include <cstddef>
#include <utility>

#include "tsubu/registry.hpp"

namespace tsubu::detail {

constexpr std::size_t kRoughnessN = RoughnessLaws::size, kRollingN = RollingLaws::size,
                      kTangentialN = TangentialLaws::size, kDampingN = DampingLaws::size,
                      kNormalN = NormalLaws::size;
constexpr std::size_t kLawCount = kNormalN * kDampingN * kTangentialN * kRollingN * kRoughnessN;
constexpr std::size_t kRegistryParts = 2;

// Specialisation k: its slots' indices in mixed radix, the roughness slot the fastest.
constexpr std::size_t law_index(const LawKey& k) {
  return (((k.normal * kDampingN + k.damping) * kTangentialN + k.tangential) * kRollingN + k.rolling) *
             kRoughnessN +
         k.roughness;
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
