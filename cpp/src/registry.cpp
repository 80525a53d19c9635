// Maps a LawKey to its compiled specialisation. The loop is instantiated for every combination of
// the slots' evaluator lists (registry.hpp) in the registry_part*.cpp files.
#include "tsubu/registry.hpp"

#include <array>

#include "registry_parts.hpp"

namespace tsubu {

namespace {
static_assert(detail::kRegistryParts == 2, "one registry_part<p>.cpp per part");

const std::array<CompiledLaw, detail::kLawCount>& laws() {
  static const std::array<CompiledLaw, detail::kLawCount> table = [] {
    std::array<CompiledLaw, detail::kLawCount> t{};
    detail::compile_part<0>(t.data());
    detail::compile_part<1>(t.data());
    return t;
  }();
  return table;
}
}  // namespace

const CompiledLaw& find_law(const LawKey& key) {
  if (key.rolling >= detail::kRollingN || key.roughness >= detail::kRoughnessN ||
      detail::law_index(key) >= detail::kLawCount)
    throw InvalidArgument("no compiled contact law for this combination of features");
  return laws()[detail::law_index(key)];
}

std::size_t compiled_law_count() { return detail::kLawCount; }

}  // namespace tsubu
