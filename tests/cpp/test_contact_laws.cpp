// Unit tests of the contact evaluators, each against its equation in the seed notes.
#include <cmath>

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

}  // namespace

int main() {
  test_mixing();
  test_normal();
  test_tangential_stick_and_slip();
  test_rotate_keeps_length();
  test_literal_only_grows();
  test_rolling_cap();
  test_law_combination();
  return tsubu_test::finish("test_contact_laws");
}
