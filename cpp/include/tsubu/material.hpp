// Materials and the per-pair contact parameters mixed from them once, at set-up. Each contact law
// owns its parameter set and mixing rule (contact/*.hpp); a material and a pair carry the sets of
// every law (the list in contact/parameters.hpp), and a scene picks its laws when a run starts
// (registry.hpp). Nothing here names a law or a law's field: the fields are reached through the
// sets' visitors, under the names of their declarations (option_table.hpp).
#pragma once
#include <type_traits>
#include <vector>

#include "archive.hpp"
#include "contact/parameters.hpp"
#include "option_table.hpp"
#include "type_list.hpp"
#include "types.hpp"

namespace tsubu {

// What a material has besides its contact laws' parameters.
struct BulkProperties {
  double density = 2500.0;  // kg/m^3 (walls: unused)

  template <class V>
  static constexpr void fields(V&& visit) { visit("density", &BulkProperties::density); }
};

namespace detail {
template <class Sets>
struct MaterialBase;
template <class... Sets>
struct MaterialBase<TypeList<Sets...>> : BulkProperties, Sets::Material... {};
template <class Sets>
struct PairBase;
template <class... Sets>
struct PairBase<TypeList<Sets...>> : Sets::Pair... {};
}  // namespace detail

// One material: every sphere and every wall has one. Its fields start at their declared
// defaults (soda-lime glass beads at a soft stiffness, the shared reference scene's). A material
// with a Young's modulus > 0 is Hertzian (HertzNormal, Mindlin's tangential spring); its kn, kt
// are then unused.
struct Material : detail::MaterialBase<ParameterSets> {
  Material();
};

// Parameters of one contact between two materials (or a material and a wall's material).
struct PairParams : detail::PairBase<ParameterSets> {
  // Derived terms (the sets' finalise()) from the parameters; after any change.
  void finalise();
};

// ---- the fields, by their declarations ----------------------------------------------------------

namespace detail {
template <class Part, class V, class = void>
struct HasFields : std::false_type {};
template <class Part, class V>
struct HasFields<Part, V, std::void_t<decltype(Part::fields(std::declval<V&>()))>> : std::true_type {};

template <class Part, class V>
constexpr void visit_part(V& visit) {
  if constexpr (HasFields<Part, V>::value) Part::fields(visit);
}

template <class P, class = void>
struct HasFinalise : std::false_type {};
template <class P>
struct HasFinalise<P, std::void_t<decltype(P::finalise(std::declval<PairParams&>()))>> : std::true_type {};

template <class C>
constexpr unsigned kScopeOf = std::is_same_v<C, Material> ? kMaterial : kPair;

template <class M>
struct MemberType;
template <class T, class Owner>
struct MemberType<T Owner::*> {
  using type = T;
};
}  // namespace detail

// The type of the field a member pointer names.
template <class Member>
using member_type = typename detail::MemberType<Member>::type;

// visit(name, member pointer) for every field a user sets of C (Material or PairParams), set by
// set. (A member pointer names the field in the set's struct, a base of C.)
template <class C, class V>
constexpr void for_each_field(V&& visit) {
  static_assert(std::is_same_v<C, Material> || std::is_same_v<C, PairParams>);
  if constexpr (std::is_same_v<C, Material>) detail::visit_part<BulkProperties>(visit);
  ParameterSets::for_each([&](auto* set) {
    using Set = std::remove_pointer_t<decltype(set)>;
    if constexpr (std::is_same_v<C, Material>)
      detail::visit_part<typename Set::Material>(visit);
    else
      detail::visit_part<typename Set::Pair>(visit);
  });
}

// visit(declaration, member pointer) for every field of C, in the order of the declarations:
// first C's own (a material's density, youngs_modulus, poisson_ratio; a pair's E*, G*), then
// those a material and a pair share. The bindings list, the checks run and the checkpoints
// write them in this order.
template <class C, class V>
void for_each_declared_field(V&& visit) {
  constexpr unsigned shared = kMaterial | kPair, own = detail::kScopeOf<C>;
  for (const bool pass_shared : {false, true})
    for (const OptionDeclaration& d : kOptionTable) {
      if (!(d.scopes & own) || ((d.scopes & shared) == shared) != pass_shared) continue;
      for_each_field<C>([&](const char* name, auto member) {
        if (same_name(d.name, name)) visit(d, member);
      });
    }
}

namespace detail {
// Whether C's fields and the declarations of C's scope name the same options, each field of the
// kind its declaration says (a double for a Real, an enum for a Choice).
template <class C>
constexpr bool fields_are_declared() {
  std::size_t fields = 0, matched = 0, declared = 0;
  for_each_field<C>([&](const char* name, auto member) {
    using T = member_type<decltype(member)>;
    ++fields;
    for (const auto& d : kOptionTable)
      if ((d.scopes & kScopeOf<C>) && same_name(d.name, name) &&
          (std::is_enum_v<T> ? d.kind == OptionKind::Choice
                             : std::is_same_v<T, double> && d.kind == OptionKind::Real))
        ++matched;
  });
  for (const auto& d : kOptionTable) declared += (d.scopes & kScopeOf<C>) != 0;
  return fields == matched && matched == declared;
}
}  // namespace detail

static_assert(detail::fields_are_declared<Material>(),
              "a Material field without its declaration (option_table.hpp), or the other way round");
static_assert(detail::fields_are_declared<PairParams>(),
              "a PairParams field without its declaration (option_table.hpp), or the other way round");

inline Material::Material() {
  for_each_declared_field<Material>([&](const OptionDeclaration& d, auto member) {
    using T = member_type<decltype(member)>;
    if constexpr (std::is_enum_v<T>)
      this->*member = T(0);  // the first choice
    else
      this->*member = d.default_value * d.scale;
  });
}

inline void PairParams::finalise() {
  ParameterSets::for_each([&](auto* set) {
    using Pair = typename std::remove_pointer_t<decltype(set)>::Pair;
    if constexpr (detail::HasFinalise<Pair>::value) Pair::finalise(*this);
  });
}

// The mixing rule (docs/physics.md), each set's own (contact/*.hpp).
inline PairParams mix(const Material& a, const Material& b) {
  PairParams p;
  ParameterSets::for_each([&](auto* set) {
    using Pair = typename std::remove_pointer_t<decltype(set)>::Pair;
    Pair::mix(a, b, p);
  });
  p.finalise();
  return p;
}

// Checkpoints (checkpoint.cpp): a material's and a pair override's parameters, by name (the
// derived terms of a pair are not saved: finalise() makes them again).
void save(archive::Writer& w, const Material& m);
void restore(archive::Reader& r, Material& m);
void save(archive::Writer& w, const PairParams& p);
void restore(archive::Reader& r, PairParams& p);

// Symmetric table of PairParams indexed by material pair; rebuilt when materials change.
class PairTable {
 public:
  void resize(std::size_t n) {
    n_ = n;
    table_.assign(n * n, PairParams{});
  }
  std::size_t size() const { return n_; }
  const PairParams& operator()(std::size_t a, std::size_t b) const { return table_[a * n_ + b]; }
  void set(std::size_t a, std::size_t b, const PairParams& p) {
    table_[a * n_ + b] = p;
    table_[b * n_ + a] = p;
  }

 private:
  std::size_t n_ = 0;
  std::vector<PairParams> table_;
};

}  // namespace tsubu
