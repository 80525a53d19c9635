// The time-step bounds, the contact duration and the law a scene selects (simulation.hpp).
#include "tsubu/simulation.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <string>
#include <vector>

#include "check.hpp"
#include "tsubu/contact/selection.hpp"

namespace tsubu {

using detail::finite3;
using detail::fmt;
using detail::require;

// ---- time step ---------------------------------------------------------------------------

// Calls f(params, scale) for every kind of contact the scene can have: each pair of particle
// materials present (reduced mass and radius of their lightest and smallest particles) and each
// particle material against each wall material (the lightest particle's mass, the smallest
// radius), at the scene's characteristic impact speed.
template <class F>
void Simulation::for_each_contact_type(F&& f) const {
  const std::size_t nm = materials_.size();
  std::vector<double> lightest, smallest;
  particles_.extremes(nm, lightest, smallest);
  std::vector<char> wall_material(nm, 0);
  for (int w = 0; w < walls_.count(); ++w) wall_material[walls_.material(w)] = 1;
  const double speed = characteristic_speed();
  for (std::size_t a = 0; a < nm; ++a) {
    if (!std::isfinite(lightest[a])) continue;
    for (std::size_t b = a; b < nm; ++b) {
      if (!std::isfinite(lightest[b]) || particles_.size() < 2) continue;
      const double ma = lightest[a], mb = lightest[b], ra = smallest[a], rb = smallest[b];
      f(pair_parameters(int(a), int(b)), ContactScale{ma * mb / (ma + mb), ra * rb / (ra + rb), speed});
    }
    for (std::size_t b = 0; b < nm; ++b)
      if (wall_material[b]) f(pair_parameters(int(a), int(b)), ContactScale{lightest[a], smallest[a], speed});
  }
}

double Simulation::critical_time_step() const {
  const CompiledLaw& law = find_law(law_key());
  double bound = std::numeric_limits<double>::infinity();
  for_each_contact_type(
      [&](const PairParams& p, const ContactScale& s) { bound = std::min(bound, law.critical_time_step(p, s)); });
  return bound;
}

double Simulation::contact_duration() const {
  const CompiledLaw& law = find_law(law_key());
  double tc = std::numeric_limits<double>::infinity();
  for_each_contact_type(
      [&](const PairParams& p, const ContactScale& s) { tc = std::min(tc, law.contact_duration(p, s)); });
  return tc;
}

double Simulation::default_time_step() const {
  return std::min(contact_duration() / 50.0, 0.2 * rayleigh_time());
}

double Simulation::rayleigh_time() const {
  std::vector<double> lightest, smallest;
  particles_.extremes(materials_.size(), lightest, smallest);
  double t = std::numeric_limits<double>::infinity();
  for (std::size_t a = 0; a < materials_.size(); ++a)
    if (std::isfinite(smallest[a])) t = std::min(t, laws::rayleigh_time(materials_[a], smallest[a]));
  return t;
}

double Simulation::characteristic_speed() const {
  if (opt_.impact_speed > 0) return opt_.impact_speed;
  if (speed_fixed_ > 0) return speed_fixed_;
  double v2 = 0;
  for (std::size_t k = 0; k < particles_.size(); ++k) v2 = std::max(v2, vec3(particles_.arrays().v.data(), k).squaredNorm());
  return std::max(1.0, 2.0 * std::sqrt(v2));
}

bool Simulation::hertzian() const {
  // The materials in use: spheres' and walls'.
  std::vector<char> used(materials_.size(), 0);
  for (std::size_t k = 0; k < particles_.size(); ++k) used[particles_.arrays().material[k]] = 1;
  for (int w = 0; w < walls_.count(); ++w) used[walls_.material(w)] = 1;
  int hertz = -1, linear = -1;
  for (std::size_t a = 0; a < materials_.size(); ++a) {
    if (!used[a]) continue;
    (laws::hertzian(materials_[a]) ? hertz : linear) = static_cast<int>(a);
  }
  require(hertz < 0 || linear < 0, [&] {
    return "the scene mixes a Hertzian material (material " + std::to_string(hertz) +
           ", given youngs_modulus) with a linear one (material " + std::to_string(linear) +
           ", given kn): give every sphere and wall material youngs_modulus, or none";
  });
  return hertz >= 0;
}

double Simulation::time_step() const { return opt_.dt > 0 ? opt_.dt : default_time_step(); }

double Simulation::skin() const {
  if (opt_.skin > 0) return opt_.skin;
  if (particles_.size() == 0) return 0;
  return 0.2 * 2.0 * particles_.radius_sum() / static_cast<double>(particles_.size());
}

LawKey Simulation::law_key() const {
  const bool hertz = hertzian();
  laws::PairNeeds scene;
  const std::size_t nm = materials_.size();
  for (std::size_t a = 0; a < nm; ++a)
    for (std::size_t b = a; b < nm; ++b) scene.add(laws::needs(pair_parameters(int(a), int(b)), hertz));
  return laws::select(hertz, scene, opt_);
}
}  // namespace tsubu
