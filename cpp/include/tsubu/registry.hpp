// The one place where a scene's run-time choices pick a compiled specialisation of the loop.
//
// Each slot of the contact law has a list of evaluators (below). registry.cpp instantiates the
// loop for every combination, from these lists, and a LawKey (one index per slot) finds it.
// Adding a law: write its evaluator in contact/, append it to its slot's list, and teach
// the law selection (contact/selection.hpp) when a scene wants it. Wall motion is not a slot: a run checks it per
// wall contact (the branch costs nothing measurable, docs/architecture.md), which halves the
// number of instantiations.
#pragma once
#include <cstddef>
#include <string>
#include <tuple>
#include <type_traits>

#include "contact/adhesive.hpp"
#include "contact/damping.hpp"
#include "contact/normal.hpp"
#include "contact/rolling.hpp"
#include "contact/roughness.hpp"
#include "contact/tangential.hpp"
#include "material.hpp"
#include "type_list.hpp"

namespace tsubu {

namespace detail {
struct World;
}

// The evaluators each slot can hold (contact/*.hpp).
using NormalLaws = TypeList<HookeNormal, HertzNormal, JkrNormal, DmtNormal>;
using DampingLaws = TypeList<RestitutionDamping, HertzDamping>;
using TangentialLaws = TypeList<NoTangential, TangentialRotate, TangentialLiteral,
                                TangentialRotateTruncate, MindlinRotate, MindlinRotateTruncate>;
using RollingLaws = TypeList<NoRolling, RollingFriction>;
// The adhesive normal laws, in the order of the run option adhesion's choices (jkr, dmt,
// option_table.hpp): a scene whose Hertzian materials have a work of adhesion takes one
// (contact/selection.hpp).
struct AdhesiveNormalLaws {
  using List = TypeList<JkrNormal, DmtNormal>;
  static constexpr std::size_t size = List::size;
  // Index k of this list as an index into NormalLaws (NormalLaws::size for none).
  static std::size_t index(std::size_t k) {
    std::size_t at = NormalLaws::size, i = 0;
    List::for_each([&](auto* law) {
      if (i++ == k) at = NormalLaws::index_of<std::remove_pointer_t<decltype(law)>>();
    });
    return at;
  }
};
using RoughnessLaws = TypeList<NoRoughness, StochasticRoughness>;

// The normal, damping and tangential laws that belong together (a Hertzian spring with the
// Hertzian dashpot and Mindlin's tangential spring; a linear one with the restitution dashpot and
// a linear tangential spring): each is compiled with every rolling and roughness law.
template <class N, class D, class T>
struct Core {
  using normal = N;
  using damping = D;
  using tangential = T;
};
using CoreLaws = TypeList<Core<HookeNormal, RestitutionDamping, NoTangential>,
                          Core<HookeNormal, RestitutionDamping, TangentialRotate>,
                          Core<HookeNormal, RestitutionDamping, TangentialLiteral>,
                          Core<HookeNormal, RestitutionDamping, TangentialRotateTruncate>,
                          Core<HertzNormal, HertzDamping, NoTangential>,
                          Core<HertzNormal, HertzDamping, MindlinRotate>,
                          Core<HertzNormal, HertzDamping, MindlinRotateTruncate>,
                          // adhesive Hertzian laws: always with Mindlin's spring (mu = 0 gives
                          // no tangential force), frozen slip
                          Core<JkrNormal, HertzDamping, MindlinRotate>,
                          Core<DmtNormal, HertzDamping, MindlinRotate>>;

// A scene's choice: one index per slot, into the lists above.
struct LawKey {
  std::size_t normal = 0, damping = 0, tangential = 0, rolling = 0, roughness = 0;
};

using StepFunction = void (*)(detail::World&, long steps);

// One instantiated law, and what the rest of the engine asks of it without knowing its type.
struct CompiledLaw {
  StepFunction step;
  std::string (*name)();
  double (*critical_time_step)(const PairParams&, const ContactScale&);
  double (*contact_duration)(const PairParams&, const ContactScale&);
  void (*entry_terms)(const PairParams&, double m_eff, double r_eff, double* terms);
  double (*normal_energy)(const PairParams&, double overlap, double r_eff);
  double (*elastic_force)(const PairParams&, double overlap, double r_eff);  // no dashpot
  double (*tangential_energy)(const PairParams&, const double* history);
  double (*tangential_stiffness)(const PairParams&, const double* history);  // 0: no spring
  // The largest separation a touching contact of reduced radius r_eff survives: 0 unless the
  // normal law is sticky (contact/normal.hpp), whose contacts hold at negative overlap.
  double (*separation)(const PairParams&, double r_eff);
  int entry_width, history_width, rough_width;
  bool torque, rolling, sticky;
};

// Whether a stored entry with this overlap touches: overlap > 0, or, under a sticky law, any
// overlap a touching contact stores (an entry that does not touch stores 0).
// (Both tests on every entry, no branch: whether an entry touches is a coin toss for the
// branch predictor in the lists' loops.)
inline bool touching(const CompiledLaw& law, double overlap) {
  return (overlap > 0) | (law.sticky & (overlap != 0));
}

const CompiledLaw& find_law(const LawKey& key);
// How many specialisations the library holds.
std::size_t compiled_law_count();

}  // namespace tsubu
