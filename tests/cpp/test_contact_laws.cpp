// Unit tests of the contact evaluators, each against its equation in the seed notes.
#include <cmath>
#include <limits>
#include <type_traits>

#include "check.hpp"
#include "tsubu/contact/law.hpp"

using namespace tsubu;

namespace {

PairParams params(double e = 0.5, double mu = 0.5) {
  Material m;
  m.kn = 1000.0;
  m.kt = 2.0 / 7.0 * 1000.0;
  m.restitution = e;
  m.friction = mu;
  return mix(m, m);
}

ContactGeometry touching(double delta, double vn, const Vec3& vt) {
  ContactGeometry g;
  g.n = Vec3(0, 0, 1);
  g.delta = delta;
  g.ci = g.cj = 0.5e-3 - delta / 2;
  g.vn = vn;
  g.vt = vt;
  g.m_eff = 1e-6;
  g.entry[0] = g.entry[1] = 0;
  return g;
}

void test_mixing() {
  Material a, b;
  a.kn = 1000;
  b.kn = 3000;
  a.restitution = 0.5;
  b.restitution = 0.8;
  a.friction = 0.2;
  b.friction = 0.8;
  const PairParams p = mix(a, b);
  CHECK_CLOSE(p.kn, 2 * 1000.0 * 3000.0 / 4000.0, 1e-9);  // harmonic mean
  CHECK_CLOSE(p.restitution, std::sqrt(0.4), 1e-15);       // geometric mean
  CHECK_CLOSE(p.friction, 0.4, 1e-15);
  const PairParams same = mix(a, a);
  CHECK_CLOSE(same.kn, a.kn, 1e-12);  // equal materials keep their value
}

void test_normal() {
  const PairParams p = params(0.5);
  const double m = 1e-6;
  const double le = std::log(0.5);
  const double eta = -2 * le * std::sqrt(m * p.kn / (M_PI * M_PI + le * le));  // (B.9)
  CHECK_CLOSE(RestitutionDamping::coefficient(p, m, HookeNormal::stiffest(p, {m, 0, 0}).stiffness), eta, 1e-15);
  double q[1], power;
  HookeNormal::pack(p, q);
  const NormalState s = HookeNormal::state(q, nullptr, 1e-6);
  CHECK_CLOSE(HookeNormal::force(q, s, 1e-6, eta, -0.1, power), p.kn * 1e-6 + eta * 0.1, 1e-15);  // (1.6)
  CHECK_CLOSE(power, eta * 0.01, 1e-18);
  const PairParams elastic = params(1.0);
  CHECK_CLOSE(RestitutionDamping::coefficient(elastic, m, elastic.kn), 0.0, 0.0);  // e = 1: no dashpot
}

void test_tangential_stick_and_slip() {
  const PairParams p = params(0.5, 0.5);
  const double dt = 1e-6;
  double power = 0;
  TangentialRotate::History h{{0, 0, 0}};
  // Stick: F_t = -k_t v_t dt after one step (1.11, 1.13).
  const ContactGeometry g = touching(1e-6, 0, Vec3(1e-3, 0, 0));
  Vec3 f = TangentialRotate::evaluate(g, p, 0.0, 1.0, dt, h, power);
  CHECK_CLOSE(f.x(), -p.kt * 1e-3 * dt, 1e-18);
  CHECK_CLOSE(h.xi[0], 1e-9, 1e-24);
  // Slip: |F_t| = mu |f_n| along -t (1.17 with |f_n|), history frozen (1.18).
  const double fn_small = 1e-9;
  const ContactGeometry fast = touching(1e-6, 0, Vec3(0, 2.0, 0));
  f = TangentialRotate::evaluate(fast, p, 0.0, fn_small, dt, h, power);
  CHECK_CLOSE(f.norm(), 0.5 * fn_small, 1e-20);
  CHECK_CLOSE(f.y(), -0.5 * fn_small, 1e-20);
  CHECK_CLOSE(h.xi[0], 1e-9, 1e-24);
  CHECK_CLOSE(h.xi[1], 0.0, 0.0);
  CHECK(power > 0);
}

void test_rotate_keeps_length() {
  // docs/physics.md: the stored displacement is turned into the new tangent plane, length kept.
  const PairParams p = params(0.5, 1e9);
  TangentialRotate::History h{{3e-9, 0, 4e-9}};  // 5e-9 long, partly along the new normal z
  double power = 0;
  const ContactGeometry g = touching(1e-6, 0, Vec3::Zero());
  TangentialRotate::evaluate(g, p, 0.0, 1.0, 1e-6, h, power);
  CHECK_CLOSE(std::hypot(h.xi[0], h.xi[1], h.xi[2]), 5e-9, 1e-22);
  CHECK_CLOSE(h.xi[2], 0.0, 1e-24);
}

void test_literal_only_grows() {
  // (1.14): the literal rule re-aims the whole length along the current v_t, so when v_t reverses
  // the stored displacement flips instead of unloading; the default rule unloads.
  const PairParams p = params(0.5, 1e9);
  TangentialLiteral::History lit{{0, 0, 0}};
  TangentialRotate::History rot{{0, 0, 0}};
  double power = 0;
  const double dt = 1e-6;
  const ContactGeometry fwd = touching(1e-6, 0, Vec3(1e-3, 0, 0));
  const ContactGeometry back = touching(1e-6, 0, Vec3(-1e-3, 0, 0));
  for (int k = 0; k < 10; ++k) {
    TangentialLiteral::evaluate(fwd, p, 0.0, 1.0, dt, lit, power);
    TangentialRotate::evaluate(fwd, p, 0.0, 1.0, dt, rot, power);
  }
  TangentialLiteral::evaluate(back, p, 0.0, 1.0, dt, lit, power);
  TangentialRotate::evaluate(back, p, 0.0, 1.0, dt, rot, power);
  CHECK_CLOSE(lit.xi[0], -11e-9, 1e-22);  // 10 + 1 steps of |v_t| dt, now along -x
  CHECK_CLOSE(rot.xi[0], 9e-9, 1e-22);    // 10 - 1 steps: the spring unloads
}

void test_rolling_cap() {
  // (1.20) with a cap: a torque that would reverse the relative spin in one step is limited to
  // stopping it.
  PairParams p = params();
  p.rolling_friction = 0.1;
  ContactGeometry g = touching(1e-6, 0, Vec3::Zero());
  g.w_rel = Vec3(0, 2.0, 0);
  g.ri = 0.5e-3;
  g.rj = 0;
  const double inertia = 0.4 * 1e-6 * g.ri * g.ri;
  g.spin_mobility = g.ri / inertia;
  const double dt = 1e-6;
  Vec3 r = RollingFriction::evaluate(g, p, 1e-3, dt);  // uncapped: mu_r |f_n| = 1e-4
  CHECK_CLOSE(r.y(), -1e-4, 1e-18);
  r = RollingFriction::evaluate(g, p, 1e3, dt);  // capped
  const double dw = dt * g.ri * r.y() / inertia;  // change of w_rel in one step
  CHECK_CLOSE(dw, -2.0, 1e-12);
}

void test_law_combination() {
  const PairParams p = params(0.5, 0.5);
  using Frictionless = ContactLaw<HookeNormal, RestitutionDamping, NoTangential, NoRolling, NoRoughness>;
  static_assert(!Frictionless::has_history && !Frictionless::has_torque);
  static_assert(
      ContactLaw<HookeNormal, RestitutionDamping, TangentialRotate, NoRolling, NoRoughness>::has_history);
  ContactGeometry g = touching(1e-6, -0.01, Vec3(1e-3, 0, 0));
  Frictionless::entry_terms(p, g.m_eff, 0.25e-3, g.entry);
  Frictionless::History none;
  ContactResult res;
  Frictionless::evaluate(g, p, 1e-6, none, res);
  CHECK_CLOSE(res.force.x(), 0.0, 0.0);  // no tangential force at all
  CHECK(res.force.z() > 0);
  CHECK(res.power > 0);
}

// ---- adhesive laws (contact/adhesive.hpp) ------------------------------------------------

PairParams adhesive(double w, double floor = -std::numeric_limits<double>::infinity()) {
  Material m;
  m.youngs_modulus = 1e7;
  m.poisson_ratio = 0.3;
  m.restitution = 0.5;
  m.friction = 0.5;
  m.work_of_adhesion = w;
  PairParams p = mix(m, m);
  p.normal_floor = floor;
  p.finalise();
  return p;
}

// The JKR law's overlap at contact radius a: delta = a^2/R - sqrt(2 pi w a / E*).
double jkr_overlap(const PairParams& p, double R, double a) {
  return a * a / R - std::sqrt(2 * M_PI * p.work_of_adhesion * a / p.effective_modulus);
}

// A law's force (no dashpot: vn = 0) at overlap delta, reduced radius R, through its lane form.
template <class N>
double lane_force(const PairParams& p, double R, double delta, double vn = 0, double* size = nullptr) {
  double q[N::kLaneParams], e[N::kEntryTerms], power;
  N::pack(p, q);
  N::entry_terms(p, R, e);
  const NormalState s = N::state(q, e, delta);
  if (size) *size = s.size;
  const double eta = 3e-3;
  if constexpr (std::is_invocable_v<decltype(&N::force), const double*, const double*,
                                    const NormalState&, double, double, double, double&>)
    return N::force(q, e, s, delta, eta, vn, power);
  else
    return N::force(q, s, delta, eta, vn, power);
}

void test_adhesive_laws_at_zero_adhesion_are_hertz() {
  // w = 0: JKR and DMT give Hertz's force bit for bit (with a dashpot, and clipped or not), and
  // its energy.
  const double R = 0.5e-3;
  for (double floor : {-std::numeric_limits<double>::infinity(), 0.0})
    for (double delta : {1e-9, 3.7e-7, 2e-6, 5e-5, 0.0, -1e-7})
      for (double vn : {0.0, -0.2, 0.3}) {
        const PairParams p = adhesive(0.0, floor);
        const double hertz = lane_force<HertzNormal>(p, R, delta, vn);
        CHECK(lane_force<JkrNormal>(p, R, delta, vn) == hertz);
        CHECK(lane_force<DmtNormal>(p, R, delta, vn) == hertz);
        CHECK(JkrNormal::elastic_energy(p, delta, R) == HertzNormal::elastic_energy(p, delta, R));
        CHECK(DmtNormal::elastic_energy(p, delta, R) == HertzNormal::elastic_energy(p, delta, R));
        CHECK(JkrNormal::elastic_force(p, delta, R) == HertzNormal::elastic_force(p, delta, R));
      }
  CHECK(JkrNormal::separation(adhesive(0.0), R) == 0.0);
}

void test_jkr_closed_form() {
  const double R = 0.5e-3, w = 0.1;
  const PairParams p = adhesive(w);
  const double E = p.effective_modulus;
  const double Fc = 1.5 * M_PI * w * R;  // force-controlled pull-off
  const double ac = std::cbrt(M_PI * w * R * R / (8 * E));
  const double dc = -0.75 * std::cbrt(M_PI * M_PI * w * w * R / (E * E));
  CHECK_CLOSE(JkrNormal::separation(p, R), -dc, 1e-15 * -dc);
  CHECK_CLOSE(jkr_overlap(p, R, ac), dc, 1e-12 * -dc);  // delta_c = delta(a_c)
  // The contact radius solves delta(a) = delta on the stable branch, from delta_c up.
  for (double x : {1.0, 1.0001, 1.01, 1.3, 2.0, 4.0, 30.0, 1e3}) {
    const double a = ac * x, delta = jkr_overlap(p, R, a);
    double got;
    lane_force<JkrNormal>(p, R, delta, 0, &got);
    CHECK_CLOSE(got, a, (x < 1.01 ? 1e-6 : 1e-12) * a);
    // F = 4 E* a^3 / (3R) - sqrt(8 pi w E* a^3)
    const double F = 4 * E * a * a * a / (3 * R) - std::sqrt(8 * M_PI * w * E * a * a * a);
    CHECK_CLOSE(lane_force<JkrNormal>(p, R, delta), F, 1e-9 * std::max(std::abs(F), Fc));
    CHECK_CLOSE(JkrNormal::elastic_force(p, delta, R), F, 1e-9 * std::max(std::abs(F), Fc));
  }
  // At delta_c the force is -5/9 F_c; its minimum, -F_c, at a = (9 pi w R^2 / (8 E*))^(1/3).
  CHECK_CLOSE(lane_force<JkrNormal>(p, R, dc), -5.0 / 9.0 * Fc, 1e-6 * Fc);
  const double af = std::cbrt(9 * M_PI * w * R * R / (8 * E));
  CHECK_CLOSE(lane_force<JkrNormal>(p, R, jkr_overlap(p, R, af)), -Fc, 1e-12 * Fc);
  // The energy is the work of the force from delta = 0: zero there, dU/d delta = F.
  CHECK(JkrNormal::elastic_energy(p, 0.0, R) == 0.0);
  for (double delta : {0.9 * dc, 0.3 * dc, 2e-7, 3e-6}) {
    const double h = 1e-4 * -dc;
    const double dU = (JkrNormal::elastic_energy(p, delta + h, R) - JkrNormal::elastic_energy(p, delta - h, R)) / (2 * h);
    CHECK_CLOSE(dU, JkrNormal::elastic_force(p, delta, R), 1e-6 * Fc);
  }
  // The energy lost when the contact breaks at delta_c: 7.09 (w^5 R^4 / E*^2)^(1/3) (to the
  // three digits of the closed form's constant).
  const double lost = JkrNormal::elastic_energy(p, dc, R);
  CHECK_CLOSE(lost, 7.09 * std::cbrt(std::pow(w, 5) * std::pow(R, 4) / (E * E)), 1e-3 * lost);
  // ... and its lane form agrees.
  double q[JkrNormal::kLaneParams], e[JkrNormal::kEntryTerms];
  JkrNormal::pack(p, q);
  JkrNormal::entry_terms(p, R, e);
  CHECK_CLOSE(JkrNormal::lane_energy(q, e, dc), lost, 1e-12 * lost);
  CHECK(JkrNormal::lane_energy(q, e, 0.0) == 0.0);
  CHECK(JkrNormal::entry_separation(e) == JkrNormal::separation(p, R));
}

void test_dmt_closed_form() {
  const double R = 0.5e-3, w = 0.1;
  const PairParams p = adhesive(w);
  const double Fc = 2 * M_PI * w * R;
  for (double delta : {1e-9, 1e-7, 2e-6}) {
    const double hertz = HertzNormal::elastic_force(p, delta, R);
    CHECK_CLOSE(lane_force<DmtNormal>(p, R, delta), hertz - Fc, 1e-12 * Fc);
    CHECK_CLOSE(DmtNormal::elastic_force(p, delta, R), hertz - Fc, 1e-12 * Fc);
    CHECK_CLOSE(DmtNormal::elastic_energy(p, delta, R),
                HertzNormal::elastic_energy(p, delta, R) - Fc * delta, 1e-12 * Fc * delta);
  }
  static_assert(!DmtNormal::kSticky && JkrNormal::kSticky);
}

}  // namespace

int main() {
  test_mixing();
  test_normal();
  test_tangential_stick_and_slip();
  test_rotate_keeps_length();
  test_literal_only_grows();
  test_rolling_cap();
  test_law_combination();
  test_adhesive_laws_at_zero_adhesion_are_hertz();
  test_jkr_closed_form();
  test_dmt_closed_form();
  return tsubu_test::finish("test_contact_laws");
}
