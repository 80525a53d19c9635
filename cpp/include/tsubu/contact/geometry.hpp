// What the loop measures of one touching contact, once, before any law is evaluated.
#pragma once
#include "../types.hpp"

namespace tsubu {

// A 3-vector as three plain doubles: the "lane" form in which the laws are written. One contact
// evaluated alone and a block of contacts evaluated together (the compiler vectorises across
// the block) then run the same arithmetic, in the same order, and give the same bits.
struct L3 {
  double x, y, z;
};
TSUBU_INLINE L3 operator+(L3 a, L3 b) { return {a.x + b.x, a.y + b.y, a.z + b.z}; }
TSUBU_INLINE L3 operator-(L3 a, L3 b) { return {a.x - b.x, a.y - b.y, a.z - b.z}; }
TSUBU_INLINE L3 operator-(L3 a) { return {-a.x, -a.y, -a.z}; }
TSUBU_INLINE L3 operator*(double s, L3 a) { return {s * a.x, s * a.y, s * a.z}; }
TSUBU_INLINE L3 operator/(L3 a, double s) { return {a.x / s, a.y / s, a.z / s}; }
// Products and sums fused where the CPU can (mul_add), in the same way in both forms.
TSUBU_INLINE double dot(L3 a, L3 b) { return mul_add(a.z, b.z, mul_add(a.y, b.y, a.x * b.x)); }
TSUBU_INLINE L3 cross(L3 a, L3 b) {
  return {mul_add(a.y, b.z, -(a.z * b.y)), mul_add(a.z, b.x, -(a.x * b.z)),
          mul_add(a.x, b.y, -(a.y * b.x))};
}
// s a + b
TSUBU_INLINE L3 mul_add(double s, L3 a, L3 b) {
  return {mul_add(s, a.x, b.x), mul_add(s, a.y, b.y), mul_add(s, a.z, b.z)};
}
// Branch-free choice per component (a blend when vectorised).
TSUBU_INLINE L3 select(bool c, L3 a, L3 b) { return {c ? a.x : b.x, c ? a.y : b.y, c ? a.z : b.z}; }
TSUBU_INLINE L3 lanes(const Vec3& v) { return {v.x(), v.y(), v.z()}; }
TSUBU_INLINE Vec3 vec(L3 a) { return Vec3(a.x, a.y, a.z); }

// The overlap of two spheres of radii ri, rj at squared distance dist2, given 1/|x_ij| (1.7).
TSUBU_INLINE double pair_overlap(double ri, double rj, double dist2, double inv_dist) {
  return (ri + rj) - dist2 * inv_dist;
}
// The lever of a contact force about a sphere's centre: its radius less half the overlap, the
// distance to the contact point on the line of centres (1.19).
TSUBU_INLINE double contact_lever(double r, double overlap) { return r - 0.5 * overlap; }

struct ContactGeometry {
  Vec3 n;          // unit normal from j (or the wall) to i (1.9)
  double delta;    // overlap r_i + r_j - |x_ij| > 0 (1.7, 1.10); wall: r_i - distance (3.1)
  double ci, cj;   // contraction radii r - delta/2 (roughness note 13); wall: cj = 0
  double vn;       // (v_i - v_j) . n, negative while approaching (1.8)
  Vec3 vt;         // tangential relative velocity of the contact points (1.12, lever c not r)
  double m_eff;    // reduced mass m_i m_j / (m_i + m_j); wall: m_i
  double entry[2] = {0, 0};  // the law's entry terms (ContactLaw::entry_terms; the loop keeps them per entry)
  Vec3 prev_n_cross_ft = Vec3::Zero();  // last step's n x F_t (zero for a new contact): the energy booking's
  // Only filled for rolling friction:
  Vec3 w_rel;      // omega_i - omega_j (wall: omega_i - omega_wall)
  double ri, rj;   // radii (1.20); wall: rj = 0
  double spin_mobility;  // r_i / I_i + r_j / I_j: how fast a rolling torque changes w_rel
};

// What a law returns for one contact. Forces and torques of the pair follow from it:
//   F_i = force, F_j = -force;  T_i = -c_i n x F_t + r_i roll;  T_j = -c_j n x F_t - r_j roll.
struct ContactResult {
  Vec3 force = Vec3::Zero();     // total contact force on i
  Vec3 n_cross_ft = Vec3::Zero();// n x F_t
  Vec3 roll = Vec3::Zero();      // rolling-resistance vector R, M_ij = r_i R (1.20)
  double fn = 0;                 // signed normal force on i along n (positive: repulsive)
  double power = 0;              // rate of dissipation in this contact over the step, W
};

}  // namespace tsubu
