// Materials and the per-pair contact parameters mixed from them once, at set-up. Each contact law
// owns its parameter set and mixing rule (contact/*.hpp); a material and a pair carry the sets of
// every law, and a scene picks its laws when a run starts (registry.hpp).
#pragma once
#include <cmath>
#include <vector>

#include "contact/adhesive.hpp"
#include "contact/damping.hpp"
#include "contact/normal.hpp"
#include "contact/rolling.hpp"
#include "contact/roughness.hpp"
#include "archive.hpp"
#include "contact/tangential.hpp"
#include "types.hpp"

namespace tsubu {

// One material: every sphere and every wall has one. Defaults: soda-lime glass beads at a soft
// stiffness (the shared reference scene's).
// A material with a Young's modulus > 0 is Hertzian (HertzNormal, Mindlin's tangential spring);
// its kn, kt are then unused. A Hertzian material with a work of adhesion > 0 makes the scene
// adhesive (JKR or DMT, Options::adhesion).
struct Material : HookeNormal::Params,
                  AdhesionParams,
                  RestitutionDamping::Properties,
                  FrictionParams,
                  RollingParams,
                  RoughnessParams {
  double density = 2500.0;  // kg/m^3 (walls: unused)
  double youngs_modulus = 0;  // E, Pa; 0: a linear (kn, kt) material
  double poisson_ratio = 0.3;  // nu, in (-1, 0.5]
  Material() {
    kn = 1.0e3;
    kt = 2.0 / 7.0 * 1.0e3;
    restitution = 0.5;
    friction = 0.5;
  }
};

// Parameters of one contact between two materials (or a material and a wall's material).
struct PairParams : HookeNormal::Params,
                    HertzNormal::Params,
                    AdhesionParams,
                    RestitutionDamping::Params,
                    HertzDamping::Params,
                    FrictionParams,
                    RollingParams,
                    RoughnessParams {
  // Derived terms (the damping laws') from the parameters; after any change.
  void finalise() {
    RestitutionDamping::finalise(*this);
    if (HertzParams::used(*this)) HertzDamping::finalise(*this);
  }
};

// The mixing rule (docs/physics.md), each law's own: stiffnesses as half-springs in series,
// restitution, the friction coefficients and the work of adhesion by geometric mean, roughness in
// quadrature.
inline PairParams mix(const Material& a, const Material& b) {
  PairParams p;
  HookeNormal::mix(a, b, p);
  HertzParams::mix(a, b, p);
  AdhesionParams::mix(a, b, p);
  RestitutionDamping::mix(a, b, p);
  HertzDamping::mix(a, b, p);
  FrictionParams::mix(a, b, p);
  RollingParams::mix(a, b, p);
  RoughnessParams::mix(a, b, p);
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
