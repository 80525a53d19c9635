// The contact laws' parameter sets: what a Material and a PairParams are made of
// (material.hpp composes them from this list and names no law).
//
// A parameter set is a pair of structs, declared with its law in contact/:
//   - Material: the fields a material carries (a default-constructible struct, distinct from
//     every other set's: a Material inherits them all);
//   - Pair: the fields of one contact between two materials (PairParams inherits them all),
//     with the mixing rule
//         template <class M> static void mix(const M& a, const M& b, Pair& p)
//     (M: the Material) and, if the set has terms derived from the mixed ones,
//         template <class P> static void finalise(P& p)
//     (P: the PairParams, after every set's mix and after any override).
// Each part lists the fields a user sets, under the names of their declarations
// (option_table.hpp), with
//         template <class V> static constexpr void fields(V&& visit)
//             { visit("name", &Part::member); ... }
// (a double for a Real option, an enum whose values are the choices' indices for a Choice).
// The defaults of a Material, the checks (options.cpp), the bindings and the checkpoints reach
// every field through these visitors; material.hpp checks at compile time that the fields and
// the declarations name the same options.
//
// A law with parameters adds its set here; the set's order is the order of the PairParams'
// bases (and of mix()).
#pragma once

#include "../type_list.hpp"
#include "adhesive.hpp"
#include "damping.hpp"
#include "normal.hpp"
#include "rolling.hpp"
#include "roughness.hpp"
#include "tangential.hpp"

namespace tsubu {

template <class MaterialPart, class PairPart = MaterialPart>
struct ParameterSet {
  using Material = MaterialPart;
  using Pair = PairPart;
};

// The Material part of a set a material sets nothing of (Owner: to keep the type distinct).
template <class Owner>
struct NoMaterialFields {};

using ParameterSets =
    TypeList<ParameterSet<HookeNormal::Params>,                 // kn
             ParameterSet<HertzMaterial, HertzParams>,           // E, nu; E*, G*
             ParameterSet<AdhesionParams>,                       // w
             ParameterSet<RestitutionDamping::Properties,         // e
                          RestitutionDamping::Params>,
             ParameterSet<NoMaterialFields<HertzDamping>, HertzDamping::Params>,
             ParameterSet<FrictionParams>,                       // kt, mu, eta_t/eta_n
             ParameterSet<RollingParams>,                        // mu_r
             ParameterSet<RoughnessParams>>;                     // sigma, distribution, shadow

}  // namespace tsubu
