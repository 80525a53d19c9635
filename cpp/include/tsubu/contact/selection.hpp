// Which compiled law a scene selects, and the other questions whose answer depends on which law
// a material or a pair belongs to. The one place outside the evaluators that knows the laws by
// name: the Simulation asks these functions, never a law's type (docs/architecture.md, "Add a
// law": a new law adds its case here and its evaluator to its slot's list in registry.hpp).
#pragma once
#include <cmath>
#include <limits>
#include <string>

#include "../material.hpp"
#include "../option_table.hpp"
#include "../options.hpp"
#include "../registry.hpp"

namespace tsubu::laws {

// The family of normal laws a material asks for: Hertzian (a Young's modulus) or linear (kn).
inline bool hertzian(const Material& m) { return m.youngs_modulus > 0; }
inline bool hertzian(const PairParams& p) { return HertzParams::used(p); }

// The scene-wide choices a pair's mixed parameters take from the run options: a Hertzian pair's
// force is clipped at zero (repulsive) or not, and its dashpot set for that.
inline void apply_options(PairParams& p, const Options& o) {
  if (!HertzParams::used(p)) return;
  p.normal_floor = o.repulsive ? 0.0 : -std::numeric_limits<double>::infinity();
  p.finalise();
}

// The Rayleigh time pi r sqrt(rho/G) / (0.1631 nu + 0.8766) of a sphere of radius r of the
// material (the usual bound of Hertzian DEM codes); infinity for a linear material.
inline double rayleigh_time(const Material& m, double r) {
  if (!hertzian(m)) return std::numeric_limits<double>::infinity();
  const double shear = m.youngs_modulus / (2.0 * (1.0 + m.poisson_ratio));
  return M_PI * r * std::sqrt(m.density / shear) / (0.1631 * m.poisson_ratio + 0.8766);
}

// What a pair's parameters ask of the slots (a scene's: what any of its pairs asks, add()).
struct PairNeeds {
  bool friction = false, rolling = false, rough = false;
  bool adhesive = false;  // a Hertzian pair with a work of adhesion (contact/adhesive.hpp)
  void add(const PairNeeds& o) {
    friction |= o.friction;
    rolling |= o.rolling;
    rough |= o.rough;
    adhesive |= o.adhesive;
  }
};
inline PairNeeds needs(const PairParams& p, bool hertz) {
  return {hertz ? MindlinRotate::used(p) : FrictionParams::used(p), RollingParams::used(p),
          RoughnessParams::used(p), hertz && AdhesionParams::used(p)};
}

// A Hertzian scene with a work of adhesion takes its adhesive core (registry.hpp), the normal
// law the run option adhesion names (a law choice, option_table.hpp), with the Hertzian dashpot
// and Mindlin's frozen-slip spring (mu = 0 gives no tangential force). Throws InvalidArgument
// for what adhesion is not offered with.
inline constexpr std::size_t kAdhesionChoice = law_choice_slot("adhesion");
static_assert(choice_count(option_declaration("adhesion").choices) == AdhesiveNormalLaws::size,
              "one adhesive normal law per choice of the adhesion option");
inline LawKey select_adhesive(const PairNeeds& n, const Options& o) {
  if (n.rough) throw InvalidArgument("roughness is not offered with adhesion (work_of_adhesion > 0)");
  if (o.repulsive)
    throw InvalidArgument("hertz_force='repulsive' clips the adhesive pull: not offered with "
                          "adhesion (work_of_adhesion > 0)");
  if (o.slip != SlipRule::Frozen || o.history != HistoryRule::Rotate)
    throw InvalidArgument("adhesive scenes (work_of_adhesion > 0) use slip_rule='frozen' and "
                          "tangential_history='rotate'");
  LawKey key;
  key.normal = AdhesiveNormalLaws::index(static_cast<std::size_t>(o.law_choices[kAdhesionChoice]));
  key.damping = DampingLaws::index_of<HertzDamping>();
  key.tangential = TangentialLaws::index_of<MindlinRotate>();
  key.rolling = n.rolling ? RollingLaws::index_of<RollingFriction>() : RollingLaws::index_of<NoRolling>();
  key.roughness = RoughnessLaws::index_of<NoRoughness>();
  return key;
}

// Each slot takes the evaluator the scene needs: the simplest that gives its physics. Throws
// InvalidArgument for a combination no law offers.
inline LawKey select(bool hertz, const PairNeeds& n, const Options& o) {
  if (hertz && n.adhesive) return select_adhesive(n, o);
  if (hertz && n.friction && o.history == HistoryRule::Literal)
    throw InvalidArgument(
        "tangential_history='literal' is offered for the linear law only; Hertzian scenes use 'rotate'");
  LawKey key;
  key.normal = hertz ? NormalLaws::index_of<HertzNormal>() : NormalLaws::index_of<HookeNormal>();
  key.damping = hertz ? DampingLaws::index_of<HertzDamping>() : DampingLaws::index_of<RestitutionDamping>();
  const bool truncate = o.slip == SlipRule::Truncate;
  key.tangential = !n.friction ? TangentialLaws::index_of<NoTangential>()
                   : hertz ? (truncate ? TangentialLaws::index_of<MindlinRotateTruncate>()
                                       : TangentialLaws::index_of<MindlinRotate>())
                   : o.history == HistoryRule::Literal ? TangentialLaws::index_of<TangentialLiteral>()
                   : truncate ? TangentialLaws::index_of<TangentialRotateTruncate>()
                              : TangentialLaws::index_of<TangentialRotate>();
  key.rolling = n.rolling ? RollingLaws::index_of<RollingFriction>() : RollingLaws::index_of<NoRolling>();
  key.roughness = n.rough ? RoughnessLaws::index_of<StochasticRoughness>() : RoughnessLaws::index_of<NoRoughness>();
  return key;
}

}  // namespace tsubu::laws
