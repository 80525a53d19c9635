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
  const std::size_t expected = NormalLaws::size * DampingLaws::size * TangentialLaws::size *
                               RollingLaws::size * RoughnessLaws::size;
  CHECK(compiled_law_count() == expected);
  CHECK(expected == 16);
  std::set<std::string> names;
  std::set<StepFunction> steps;
  LawKey k;
  for (k.tangential = 0; k.tangential < TangentialLaws::size; ++k.tangential)
    for (k.rolling = 0; k.rolling < RollingLaws::size; ++k.rolling)
      for (k.roughness = 0; k.roughness < RoughnessLaws::size; ++k.roughness) {
        const CompiledLaw& law = find_law(k);
        names.insert(law.name());
        steps.insert(law.step);
        // What it reports follows from its slots.
        CHECK(law.history_width == (k.tangential == 0 ? 0 : 3));
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
  CHECK_CLOSE(law.contact_duration(p, m), tc, 1e-12 * tc);
  CHECK_CLOSE(law.damping_term(p, m), eta, 1e-15 * eta);
  CHECK_CLOSE(law.normal_energy(p, 2e-6), 0.5 * p.kn * 4e-12, 1e-25);
  CHECK_CLOSE(law.elastic_force(p, 2e-6), p.kn * 2e-6, 1e-18);
}

}  // namespace

int main() {
  test_every_combination_is_compiled();
  test_index_of_names_the_slots();
  test_bad_key_is_refused();
  test_services_match_the_law();
  return tsubu_test::finish("test_registry");
}
