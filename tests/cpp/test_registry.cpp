// The registry: every combination of the slots' evaluator lists is compiled once, a LawKey finds
// its own specialisation, and what a compiled law reports matches the types it was built from.
#include <set>
#include <string>

#include "check.hpp"
#include "tsubu/registry.hpp"
#include "tsubu/simulation.hpp"

using namespace tsubu;

namespace {

void test_every_combination_is_compiled() {
  const std::size_t expected = CoreLaws::size * RollingLaws::size * RoughnessLaws::size;
  CHECK(compiled_law_count() == expected);
  // 4 linear, 3 Hertzian and 2 adhesive (JKR, DMT) cores, x 2 rolling x 2 roughness
  CHECK(expected == 36);
  const std::size_t jkr = NormalLaws::index_of<JkrNormal>(), dmt = NormalLaws::index_of<DmtNormal>();
  CHECK(jkr == 2 && dmt == 3);
  std::set<std::string> names;
  std::set<StepFunction> steps;
  LawKey k;
  for (k.normal = 0; k.normal < NormalLaws::size; ++k.normal)
    for (k.damping = 0; k.damping < DampingLaws::size; ++k.damping)
      for (k.tangential = 0; k.tangential < TangentialLaws::size; ++k.tangential)
        for (k.rolling = 0; k.rolling < RollingLaws::size; ++k.rolling)
          for (k.roughness = 0; k.roughness < RoughnessLaws::size; ++k.roughness) {
            // A core is a linear spring with the restitution dashpot and a linear tangential
            // law, or Hertz with the Hertzian dashpot and Mindlin (or no friction).
            const bool mindlin = k.tangential >= 4;
            // An adhesive normal law (JKR, DMT) goes with the Hertzian dashpot and Mindlin's
            // frozen-slip spring only.
            const bool adhesive = k.normal == jkr || k.normal == dmt;
            const bool core = adhesive ? (k.damping == 1 && k.tangential == 4)
                              : k.normal == k.damping &&
                              (k.tangential == 0 || mindlin == (k.normal == 1)) &&
                              !(k.normal == 1 && (k.tangential == 2 || k.tangential == 1 || k.tangential == 3));
            bool found = true;
            try {
              find_law(k);
            } catch (const InvalidArgument&) {
              found = false;
            }
            CHECK(found == core);
            if (!found) continue;
            const CompiledLaw& law = find_law(k);
            names.insert(law.name());
            steps.insert(law.step);
            // What it reports follows from its slots.
            CHECK(law.history_width == (k.tangential == 0 ? 0 : mindlin ? 4 : 3));
            CHECK(law.entry_width == (k.normal == 1 ? 2 : k.normal == jkr ? 6 : k.normal == dmt ? 3 : 1));
            CHECK(law.sticky == (k.normal == jkr));
            CHECK(law.rolling == (k.rolling == 1));
            CHECK(law.rough_width == (k.roughness == 1 ? 6 : 0));
            CHECK((law.name().find("roughness") != std::string::npos) == (k.roughness == 1));
            CHECK((law.name().find("rolling") != std::string::npos) == (k.rolling == 1));
          }
  CHECK(names.size() == expected);  // one specialisation per key, none shared
  CHECK(steps.size() == expected);
}

void test_index_of_names_the_slots() {
  CHECK(TangentialLaws::index_of<NoTangential>() == 0);
  CHECK(TangentialLaws::index_of<TangentialLiteral>() == 2);
  CHECK(RoughnessLaws::index_of<StochasticRoughness>() == 1);
  LawKey k;
  k.tangential = TangentialLaws::index_of<TangentialRotate>();
  CHECK(find_law(k).name() == "hooke+friction(rotate)");
}

void test_bad_key_is_refused() {
  LawKey k;
  k.tangential = TangentialLaws::size;
  bool thrown = false;
  try {
    find_law(k);
  } catch (const InvalidArgument&) {
    thrown = true;
  }
  CHECK(thrown);
}

// The services a compiled law offers agree with the law's own formulas: the contact duration of a
// linear spring-dashpot, t_c = pi / sqrt(k/m - eta^2 / 4m^2) (B.3, B.5), and 1/2 k delta^2.
void test_services_match_the_law() {
  Material glass;
  const PairParams p = mix(glass, glass);
  const double m = 1.3e-6;
  const CompiledLaw& law = find_law(LawKey{});
  const double eta = p.damping_factor * std::sqrt(m * p.kn);
  const double tc = M_PI / std::sqrt(p.kn / m - eta * eta / (4 * m * m));
  CHECK_CLOSE(law.contact_duration(p, {m, 0.25e-3, 1.0}), tc, 1e-12 * tc);
  double terms[2];
  CHECK(law.entry_width == 1);
  law.entry_terms(p, m, 0.25e-3, terms);
  CHECK_CLOSE(terms[0], eta, 1e-15 * eta);
  CHECK_CLOSE(law.normal_energy(p, 2e-6, 0.25e-3), 0.5 * p.kn * 4e-12, 1e-25);
  CHECK_CLOSE(law.elastic_force(p, 2e-6, 0.25e-3), p.kn * 2e-6, 1e-18);
}

// The Hertzian law's services: Hertz's contact duration t_c = 2.868 (m*^2 / (R* E*^2 v))^(1/5)
// (Johnson 1985, eq. 11.24), the energy (8/15) E* sqrt(R*) delta^(5/2) and force
// (4/3) E* sqrt(R*) delta^(3/2), and the entry terms sqrt(R*), 2 sqrt(5/6) |beta| sqrt(m*).
void test_hertz_services() {
  Material steel;
  steel.youngs_modulus = 2.0e11;
  steel.poisson_ratio = 0.3;
  steel.restitution = 0.5;
  PairParams p = mix(steel, steel);
  const double estar = 2.0e11 / (2 * (1 - 0.09));
  CHECK_CLOSE(p.effective_modulus, estar, 1e-6 * estar);
  const double g = 2.0e11 / 2.6, gstar = g / (2 * (2 - 0.3));
  CHECK_CLOSE(p.effective_shear_modulus, gstar, 1e-6 * gstar);
  LawKey key;
  key.normal = NormalLaws::index_of<HertzNormal>();
  key.damping = DampingLaws::index_of<HertzDamping>();
  key.tangential = TangentialLaws::index_of<MindlinRotate>();
  const CompiledLaw& law = find_law(key);
  CHECK(law.entry_width == 2 && law.history_width == 4);
  const double m = 1e-3, r = 5e-3, v = 2.0, d = 1e-6;
  const double tc = 2.868265 * std::pow(m * m / (r * estar * estar * v), 0.2);
  CHECK_CLOSE(law.contact_duration(p, {m, r, v}), tc, 1e-12 * tc);
  CHECK_CLOSE(law.normal_energy(p, d, r), 8.0 / 15 * estar * std::sqrt(r) * std::pow(d, 2.5), 1e-20);
  CHECK_CLOSE(law.elastic_force(p, d, r), 4.0 / 3 * estar * std::sqrt(r) * std::pow(d, 1.5), 1e-12);
  double terms[2];
  law.entry_terms(p, m, r, terms);
  const double le = std::log(0.5), beta = le / std::sqrt(le * le + M_PI * M_PI);
  CHECK_CLOSE(terms[0], std::sqrt(r), 1e-15);
  CHECK_CLOSE(terms[1], 2 * std::sqrt(5.0 / 6.0) * std::abs(beta) * std::sqrt(m), 1e-15);
  // Mindlin's spring holds 1/2 8 G* a |xi|^2 with the a its history keeps.
  const double h[4] = {1e-7, 0, 0, 2e-5};
  CHECK_CLOSE(law.tangential_energy(p, h), 0.5 * 8 * gstar * 2e-5 * 1e-14, 1e-22);
}

}  // namespace

int main() {
  test_every_combination_is_compiled();
  test_index_of_names_the_slots();
  test_bad_key_is_refused();
  test_hertz_services();
  test_services_match_the_law();
  return tsubu_test::finish("test_registry");
}
