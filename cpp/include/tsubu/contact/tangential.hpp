// Tangential contact laws: spring-dashpot on the accumulated tangential displacement (1.11,
// 1.13-1.16) with the Coulomb cap (1.17-1.18). Each law owns the history it needs.
#pragma once
#include <algorithm>
#include <cmath>

#include "geometry.hpp"
#include "normal.hpp"

namespace tsubu {

// The parameters of the tangential spring-dashpot with the Coulomb cap, and their mixing rule:
// stiffnesses as two half-springs in series (harmonic mean), the coefficients geometric means.
// The parameter set (contact/parameters.hpp) of every tangential law: a material's and a pair's.
struct FrictionParams {
  double kt = 0;                  // tangential stiffness, N/m
  double friction = 0;            // Coulomb mu (1.17)
  double tangential_damping = 0;  // eta_t / eta_n (1.11)

  template <class V>
  static constexpr void fields(V&& visit) {
    visit("kt", &FrictionParams::kt);
    visit("friction", &FrictionParams::friction);
    visit("tangential_damping", &FrictionParams::tangential_damping);
  }

  template <class M>
  static void mix(const M& a, const M& b, FrictionParams& p) {
    p.kt = (a.kt == 0 || b.kt == 0) ? 0.0 : 2.0 * a.kt * b.kt / (a.kt + b.kt);
    p.friction = std::sqrt(a.friction * b.friction);
    p.tangential_damping = std::sqrt(a.tangential_damping * b.tangential_damping);
  }
  // A scene whose pairs all have mu = 0 or kt = 0 runs without tangential code.
  static bool used(const FrictionParams& p) { return p.friction > 0 && p.kt > 0; }
};

// Frictionless contacts: no tangential force, no history, no angular-velocity reads.
struct NoTangential {
  static constexpr bool enabled = false;
  static constexpr bool kDeferred = false;
  static constexpr const char* name = "frictionless";
  static constexpr int history_width = 0;
  static constexpr int kLaneParams = 0;
  struct History {};
  static void pack(const FrictionParams&, double*) {}
  static double elastic_energy(const double*, const double*) { return 0; }
  static double history_stiffness(const double*, const double*) { return 0; }
};

// What every law with a tangential spring shares: four lane parameters (kt, mu, eta_t/eta_n,
// 1/kt) and a 3-vector of history, the displacement xi, holding 1/2 kt |xi|^2.
struct TangentialSpring {
  static constexpr bool enabled = true;
  // Whether lane_as<true> exists: a lane that skips a rare costly step and says where it did
  // (TangentialRotateRule).
  static constexpr bool kDeferred = false;
  static constexpr int history_width = 3;
  static constexpr int kLaneParams = 4;
  struct History { double xi[3]; };
  static void pack(const FrictionParams& p, double* q) {
    q[0] = p.kt;
    q[1] = p.friction;
    q[2] = p.tangential_damping;
    q[3] = 1.0 / p.kt;  // (the slip rule's; a division per lane otherwise, the lane's slowest step)
  }
  static bool used(const FrictionParams& p) { return FrictionParams::used(p); }
  // The energy of the spring with displacement xi; q as packed.
  static double elastic_energy(const double* q, const double* xi) {
    return 0.5 * q[0] * (xi[0] * xi[0] + xi[1] * xi[1] + xi[2] * xi[2]);
  }
  // k_t at the contact's normal state: a linear spring's is fixed.
  TSUBU_INLINE static double stiffness(const double* q, const NormalState&) { return q[0]; }
  // 1 / k_t, the same bits as dividing in the lane.
  TSUBU_INLINE static double compliance(const double* q, const NormalState&) { return q[3]; }
  // k_t of a stored history (the energy audit's power): fixed.
  static double history_stiffness(const double* q, const double* /*xi*/) { return q[0]; }
  // eta_t = (eta_t / eta_n) eta_n (1.11) and the Coulomb cap mu |f_n| (1.17), from the lane's
  // packed parameters.
  TSUBU_INLINE static double damping(const double* q, double eta_n) { return q[2] * eta_n; }
  TSUBU_INLINE static double cap(const double* q, double fn) { return q[1] * std::abs(fn); }
  // What the history does when the normal state changes: nothing for a fixed k_t.
  TSUBU_INLINE static void follow(const double*, const NormalState&, double, L3&, double&, double&) {}
};

namespace detail {
// Coulomb cap (1.17)-(1.18) shared by the history laws, branch-free (both outcomes are computed
// and one is kept, so that a block of contacts vectorises). `trial` holds the displacement with
// this step's increment; `frozen` the displacement without it. When the trial force exceeds
// mu |f_n| the contact slips: the force is mu |f_n| along -t, t = v_t/|v_t| (|f_n|, not
// the |f_t| of the notes' (1.17), docs/physics.md), and the displacement stays frozen (1.18). Returns F_t; sets xi.
//
// The power booked as dissipated is what the contact took over the step's displacement v_t dt
// less what its spring stored: -(F_prev + F_t)/2 . v_t - dU/dt. The force is averaged over the
// steps before and after the displacement (`prev_work`: F_prev . v_t, last step's F_t turned
// into this tangent plane), which is the work symplectic Euler really does (the kick's midpoint
// rule); F_t . v_t
// alone would book mu |f_n| |v_t| whenever a slipping contact jitters, though a force that
// follows -v_t flips with v_t and does no net work (docs/physics.md, "Energy balance").
// `compliance`: 1/kt (read only by the truncating rule).
template <bool kTruncate = false>
TSUBU_INLINE L3 coulomb(L3 vt, double kt, double compliance, double eta_t, double cap, double dt,
                        L3 trial, L3 frozen, double prev_work, L3& xi, double& power) {
  const L3 ft = mul_add(-kt, trial, -(eta_t * vt));  // (1.11)
  const double ft2 = dot(ft, ft);
  const bool slip = ft2 > cap * cap;
  // Sticking, U goes from 1/2 kt |trial - v_t dt|^2 to 1/2 kt |trial|^2; with F_t = -kt trial -
  // eta_t v_t the rest is the dashpot's eta_t v_t^2 / 2 and what F_prev differs from the spring.
  const double vt2 = dot(vt, vt);
  const double stick_power = 0.5 * (eta_t * vt2 - kt * (dot(trial, vt) - dt * vt2) - prev_work);
  if constexpr (kTruncate) {
    // The rule of LAMMPS's gran/hooke/history and of the shared reference scene: the trial force is scaled down to
    // the cap in its own direction, and the displacement truncated to match.
    // (Divisions are the lane's slowest operations: 1/kt comes packed, 1/dt is the loop's.)
    const L3 fs = (cap / std::sqrt(ft2)) * ft;
    const L3 cut = -compliance * (fs + eta_t * vt);
    // dissipated = work against the slip + the spring energy cut off
    const double slip_power =
        -0.5 * (dot(fs, vt) + prev_work) + (0.5 * kt * (dot(frozen, frozen) - dot(cut, cut))) * (1.0 / dt);
    xi = select(slip, cut, trial);
    power += slip ? slip_power : stick_power;
    return select(slip, fs, ft);
  } else {
    // Slip direction -t; if v_t vanishes the spring alone broke the cap: keep its direction.
    const double vt_abs = std::sqrt(dot(vt, vt));
    const L3 fs = select(vt_abs > 0, (-cap / vt_abs) * vt, (cap / std::sqrt(ft2)) * ft);
    xi = select(slip, frozen, trial);
    // (fs . v_t = -cap |v_t|, also where v_t = 0; frozen: U unchanged)
    power += slip ? 0.5 * (cap * vt_abs - prev_work) : stick_power;
    return select(slip, fs, ft);
  }
}

// The Eigen form of a tangential law's lane (single contacts, tests): F_t, with h.xi updated.
template <class Law>
TSUBU_INLINE Vec3 tangential(const ContactGeometry& g, const FrictionParams& p, double eta_t,
                             double fn_abs, double dt, typename Law::History& h, double& power) {
  L3 xi{h.xi[0], h.xi[1], h.xi[2]};
  const double prev_work = dot(lanes(g.prev_n_cross_ft), cross(lanes(g.n), lanes(g.vt)));
  const L3 ft = Law::lane(lanes(g.n), lanes(g.vt), p.kt, 1.0 / p.kt, eta_t, p.friction * fn_abs, dt, prev_work,
                          xi, power);
  h.xi[0] = xi.x;
  h.xi[1] = xi.y;
  h.xi[2] = xi.z;
  return vec(ft);
}
}  // namespace detail

// Default rule (docs/physics.md): the stored displacement is a vector, rotated into the current
// tangent plane each step with its length kept, then incremented by v_t dt. kTruncate selects
// the slip rule: false, the notes' (1.17)-(1.18) (default); true, LAMMPS's (for comparisons).
template <bool kTruncate>
struct TangentialRotateRule : TangentialSpring {
  static constexpr const char* name = kTruncate ? "friction(rotate, truncate)" : "friction(rotate)";

  static constexpr bool kDeferred = true;

  // One contact: normal n, tangential velocity vt, cap mu |f_n|, last step's F_t . v_t
  // `prev_work`; returns F_t, updates xi.
  TSUBU_INLINE static L3 lane(L3 n, L3 vt, double kt, double compliance, double eta_t, double cap,
                              double dt, double prev_work, L3& xi, double& power) {
    bool far = false;
    return lane_as<false>(n, vt, kt, compliance, eta_t, cap, dt, prev_work, xi, power, far);
  }
  // kSeriesOnly: the rescale by the series alone, and `far` set where the turn is too large for
  // it: that lane's results are not lane()'s, and the caller evaluates it again with lane().
  // The square root and division of the exact rescale then leave the block's usual path.
  template <bool kSeriesOnly>
  TSUBU_INLINE static L3 lane_as(L3 n, L3 vt, double kt, double compliance, double eta_t, double cap,
                                 double dt, double prev_work, L3& xi, double& power, bool& far) {
    const L3 old = xi;
    const double along = dot(old, n);
    const L3 flat = old - along * n;
    // Rescale to the old length: sqrt(len2 / rot2) = (1 - eps)^(-1/2), eps = along^2 / len2.
    // Each step turns the plane by a tiny angle, so the series (error < eps^3 / 3, below
    // rounding for eps < 1e-5) is the usual case; the square root covers large turns.
    const double len2 = dot(old, old), rot2 = dot(flat, flat);
    const double eps = along * along / len2;
    const double series = 1.0 + eps * (0.5 + 0.375 * eps);
    double scale = series;
    if constexpr (kSeriesOnly) {
      far = (along != 0) & !(eps < 1e-5);  // (no && : a branch would stop the vectoriser)
    } else {
      const double exact = std::sqrt(len2 / rot2);
      scale = eps < 1e-5 ? series : (rot2 > 0 ? exact : 1.0);
    }
    const L3 rot = select(along != 0, scale * flat, flat);
    const L3 trial = mul_add(dt, vt, rot);  // (1.13) one step
    return detail::coulomb<kTruncate>(vt, kt, compliance, eta_t, cap, dt, trial, rot, prev_work, xi, power);
  }
  TSUBU_INLINE static Vec3 evaluate(const ContactGeometry& g, const FrictionParams& p, double eta_t,
                                    double fn_abs, double dt, History& h, double& power) {
    return detail::tangential<TangentialRotateRule>(g, p, eta_t, fn_abs, dt, h, power);
  }
};
using TangentialRotate = TangentialRotateRule<false>;
using TangentialRotateTruncate = TangentialRotateRule<true>;

// The notes' literal rule (1.14)-(1.16): the whole accumulated length is re-aimed along the
// current t = v_t/|v_t| and grows by |v_t| dt; unchanged when v_t = 0. Kept for comparison only:
// its spring never unloads (docs/physics.md shows the difference).
struct TangentialLiteral : TangentialSpring {
  static constexpr const char* name = "friction(literal)";

  TSUBU_INLINE static L3 lane(L3, L3 vt, double kt, double compliance, double eta_t, double cap,
                              double dt, double prev_work, L3& xi, double& power) {
    const L3 old = xi;
    const double vt_abs = std::sqrt(dot(vt, vt));
    const L3 trial =
        select(vt_abs > 0, ((std::sqrt(dot(old, old)) + vt_abs * dt) / vt_abs) * vt, old);  // (1.14), (1.16)
    return detail::coulomb(vt, kt, compliance, eta_t, cap, dt, trial, old, prev_work, xi, power);
  }
  TSUBU_INLINE static Vec3 evaluate(const ContactGeometry& g, const FrictionParams& p, double eta_t,
                                    double fn_abs, double dt, History& h, double& power) {
    return detail::tangential<TangentialLiteral>(g, p, eta_t, fn_abs, dt, h, power);
  }
};

// Mindlin's tangential spring for Hertzian contacts: k_t = 8 G* a, a = sqrt(R* delta) (Mindlin
// 1949; Di Renzo & Di Maio 2004), with the history and slip rule of TangentialRotateRule. k_t
// changes with the overlap, so the stored displacement must follow it (docs/physics.md):
//  - loading (a > a_old): xi is scaled by a_old / a, so F_t = k_t xi does not jump: a tangential
//    force changes only through tangential motion, as in an incremental law (a displacement
//    kept as it is would gain 1/2 (k_t - k_t,old) xi^2 of energy from nowhere);
//  - unloading (a < a_old): xi is kept, so F_t falls with k_t (Thornton, Cummins & Cleary 2013's
//    rule for a shrinking contact area; Mindlin & Deresiewicz 1953).
// Either way the spring's energy 1/2 k_t |xi|^2 only falls; what it loses is booked as
// dissipated. The history keeps a, the fourth value, so that the energy a history holds is known
// from the history alone.
template <bool kTruncate>
struct MindlinRule : TangentialRotateRule<kTruncate> {
  static constexpr const char* name = kTruncate ? "mindlin(rotate, truncate)" : "mindlin(rotate)";
  static constexpr int history_width = 4;
  struct History { double xi[4]; };
  // Lanes read 8 G*, mu, eta_t / eta_n (and no 1/k_t: it changes with the contact).
  template <class P>
  static void pack(const P& p, double* q) {
    q[0] = 8.0 * p.effective_shear_modulus;
    q[1] = p.friction;
    q[2] = p.tangential_damping;
    q[3] = 0;  // (k_t follows the contact: compliance() divides in the lane)
  }
  template <class P>
  static bool used(const P& p) { return p.friction > 0 && p.effective_shear_modulus > 0; }
  // 1/2 k_t |xi|^2 with the k_t of the stored a.
  static double elastic_energy(const double* q, const double* xi) {
    return 0.5 * q[0] * xi[3] * (xi[0] * xi[0] + xi[1] * xi[1] + xi[2] * xi[2]);
  }
  TSUBU_INLINE static double stiffness(const double* q, const NormalState& s) { return q[0] * s.size; }
  TSUBU_INLINE static double compliance(const double* q, const NormalState& s) { return 1.0 / stiffness(q, s); }
  // 8 G* a with the a the history keeps.
  static double history_stiffness(const double* q, const double* xi) { return q[0] * xi[3]; }
  TSUBU_INLINE static void follow(const double* q, const NormalState& s, double dt, L3& xi,
                                  double& a_old, double& power) {
    const double a = s.size;
    const bool loading = a_old < a;
    const double scale = loading ? a_old / a : 1.0;
    const double u2 = dot(xi, xi);
    // 1/2 8G* (a_old - a scale^2) |xi|^2 >= 0
    power += (0.5 * q[0] * u2 * (a_old - a * scale * scale)) * (1.0 / dt);
    xi = scale * xi;
    a_old = a;
  }
};
using MindlinRotate = MindlinRule<false>;
using MindlinRotateTruncate = MindlinRule<true>;

}  // namespace tsubu
