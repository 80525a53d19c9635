// Unit tests of the roughness generators: the counter-based generator against the published
// known-answer vectors, and the tilt geometry of (11)-(12).
#include <cmath>

#include "check.hpp"
#include "tsubu/contact/roughness.hpp"
#include "tsubu/material.hpp"

using namespace tsubu;

namespace {

void test_philox_known_answers() {
  // Philox4x32-10 known-answer vectors of Random123 (Salmon et al., SC'11), kat_vectors.
  auto a = philox4x32({0, 0, 0, 0}, {0, 0});
  CHECK(a[0] == 0x6627e8d5u && a[1] == 0xe169c58du && a[2] == 0xbc57ac4cu && a[3] == 0x9b00dbd8u);
  a = philox4x32({0xffffffffu, 0xffffffffu, 0xffffffffu, 0xffffffffu}, {0xffffffffu, 0xffffffffu});
  CHECK(a[0] == 0x408f276du && a[1] == 0x41c83b0eu && a[2] == 0xa20bc7c6u && a[3] == 0x6d5451fdu);
  a = philox4x32({0x243f6a88u, 0x85a308d3u, 0x13198a2eu, 0x03707344u}, {0xa4093822u, 0x299f31d0u});
  CHECK(a[0] == 0xd16cfe09u && a[1] == 0x94fdccebu && a[2] == 0x5001e420u && a[3] == 0x24126ea1u);
}

void test_streams_are_keyed() {
  const ContactStream s{7, 3, 9, 1000};
  const ContactStream other_seed{8, 3, 9, 1000}, other_step{7, 3, 9, 1001};
  CHECK(s.uniforms(0) == s.uniforms(0));  // a pure function of the contact
  CHECK(s.uniforms(0) != s.uniforms(1));
  CHECK(s.uniforms(0) != other_seed.uniforms(0));
  CHECK(s.uniforms(0) != other_step.uniforms(0));
  for (double u : s.uniforms(3)) CHECK(u > 0 && u < 1);
}

void test_scatter_statistics() {
  // Box-Muller: mean 0 and standard deviation sigma to 3 standard errors over 20000 draws.
  const double sigma = 0.2;
  const int n = 20000;
  double sum = 0, sum2 = 0;
  for (int k = 0; k < n; ++k) {
    const auto u = ContactStream{1, std::uint64_t(k), 0, 0}.uniforms(0);
    const double x = scatter_normal(sigma, u[0], u[1]);
    sum += x;
    sum2 += x * x;
  }
  const double mean = sum / n, sd = std::sqrt(sum2 / n - mean * mean);
  CHECK_CLOSE(mean, 0.0, 3 * sigma / std::sqrt(n));
  CHECK_CLOSE(sd, sigma, 3 * sigma / std::sqrt(2.0 * n));
}

void test_tilt_geometry() {
  // n' = cos dG n + sin dG (sin psi n1 + cos psi n2) (11-12) is a unit vector at angle dG to n.
  const Vec3 n = Vec3(1, 2, 2) / 3.0;
  const double dg = 0.3, psi = 1.1;
  const Vec3 t = tilt_vector(n, dg, psi);
  CHECK_CLOSE(t.dot(n), 0.0, 1e-15);
  CHECK_CLOSE(t.norm(), std::sin(dg), 1e-15);
  double st[3] = {t.x(), t.y(), t.z()};
  const Vec3 np = tilted_normal(n, st);
  CHECK_CLOSE(np.norm(), 1.0, 1e-15);
  CHECK_CLOSE(std::acos(np.dot(n)), dg, 1e-12);
}

void test_shadow_rule() {
  // At a wall, "reject" never returns a tilt the sphere would not approach (v . n' < 0).
  PairParams p;
  p.roughness = 0.5;  // about 29 degrees: many draws would face away at grazing incidence
  p.shadow = ShadowRule::Reject;
  const Vec3 n(0, 0, 1), v(1.0, 0, -0.05);  // incidence about 3 degrees
  int refused_possible = 0;
  for (std::uint64_t k = 0; k < 2000; ++k) {
    const Vec3 t = draw_tilt(p, n, v, true, ContactStream{5, k, ContactStream::kWallTag, 0});
    const Vec3 np = std::sqrt(1 - t.squaredNorm()) * n + t;
    CHECK(v.dot(np) < 0);
    p.shadow = ShadowRule::None;
    const Vec3 t2 = draw_tilt(p, n, v, true, ContactStream{5, k, ContactStream::kWallTag, 0});
    p.shadow = ShadowRule::Reject;
    if (v.dot(std::sqrt(1 - t2.squaredNorm()) * n + t2) >= 0) ++refused_possible;
  }
  CHECK(refused_possible > 200);  // the test exercised the rule
}

}  // namespace

int main() {
  test_philox_known_answers();
  test_streams_are_keyed();
  test_scatter_statistics();
  test_tilt_geometry();
  test_shadow_rule();
  return tsubu_test::finish("test_roughness");
}
