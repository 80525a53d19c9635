// The engine's views of the World (world.hpp): the arrays a pass reads and writes, unpacked once
// per pass, so that the passes themselves never reach into the scene's types.
#pragma once
#include <algorithm>

#include "common.hpp"
#include "world.hpp"

namespace tsubu::detail {

// The contact force and torque on one particle, summed from the per-entry results in an order
// fixed by ids: its walls, the entries it owns (partners by id), the entries it is the partner
// of (owners by id). The step loop and the accessors share it, so get_forces() returns the
// forces the last step used, bit for bit.
struct ContactSums {
  const Index *woff, *wnear, *noff, *roff, *rev;
  const double *r, *wf, *wn, *wr, *wo, *pf, *pn, *pr, *po;
  Index rmask;  // particle k's radius is r[k & rmask] (NeighborList::cut_mask)

  ContactSums(const NeighborList& l, const ContactStore& c, const Particles& p)
      : woff(l.wall_near_offset.data()), wnear(l.wall_near.data()), noff(l.near_offset.data()),
        roff(l.near_rev_offset.data()), rev(l.near_rev.data()), r(p.arrays().radius.data()),
        wf(c.walls.force.data()), wn(c.walls.nxft.data()), wr(c.walls.roll.data()),
        wo(c.walls.overlap.data()), pf(c.pairs.force.data()), pn(c.pairs.nxft.data()),
        pr(c.pairs.roll.data()), po(c.pairs.overlap.data()), rmask(l.cut_mask) {}

  // Where the particles in contact are few and scattered (a large scene), at(k) waits on memory
  // three times: for k's offsets, for its owned entries and reverse indices, for its reverse
  // entries. The caller requests each level a stage ahead: prefetch (offsets, velocities, radius)
  // at distance 3 s, prefetch_owned at 2 s, prefetch_reverse at s. (With `request`: gcc deleted
  // the __builtin_prefetch calls that stood here, as common.hpp says it does.)
  void prefetch(Index k, const double* v, const double* w) const {
    request(woff + k);
    request(noff + k);
    request(roff + k);
    request(r + (k & rmask));
    request(v + 3 * k);
    request(w + 3 * k);
  }
  // (A past-the-end address is harmless: a prefetch does not fault.)
  void prefetch_owned(Index k) const {
    const Index q = noff[k];
    request(pf + 3 * q);
    request(pn + 3 * q);
    request(po + q);
    request(rev + roff[k]);
  }
  void prefetch_reverse(Index k) const {
    for (Index p = roff[k]; p < roff[k + 1]; ++p) {
      const Index q = rev[p];
      request(pf + 3 * q);
      request(pn + 3 * q);
      request(po + q);
    }
  }

  // kWallLever: walls store n x F_t; kPairLever: pairs store n x F; kRolling: rolling vectors.
  template <bool kWallLever, bool kPairLever, bool kRolling>
  void at(Index k, Vec3& F, Vec3& T) const {
    const double rk = r[k & rmask];
    for (Index p = woff[k]; p < woff[k + 1]; ++p) {
      const Index e = wnear[p];
      F += vec3(wf, e);
      if constexpr (kWallLever) T -= contact_lever(rk, wo[e]) * vec3(wn, e);  // (1.19)
      if constexpr (kRolling) T += rk * vec3(wr, e);                     // (1.20)
    }
    for (Index q = noff[k]; q < noff[k + 1]; ++q) {
      F += vec3(pf, q);
      if constexpr (kPairLever) T -= contact_lever(rk, po[q]) * vec3(pn, q);
      if constexpr (kRolling) T += rk * vec3(pr, q);
    }
    for (Index p = roff[k]; p < roff[k + 1]; ++p) {
      const Index q = rev[p];
      F -= vec3(pf, q);
      if constexpr (kPairLever) T -= contact_lever(rk, po[q]) * vec3(pn, q);
      if constexpr (kRolling) T -= rk * vec3(pr, q);
    }
  }
};

// Everything the contact pass reads and writes.
struct ContactView {
  const double *x, *v, *w, *r, *m, *inv_i;
  const int* mat;
  const Id* ids;
  const Index *own, *par, *wown, *wall, *welement, *wnear_offset, *owned;
  Index* wnear;  // (a flat sheet's position follows its contact: MeshContacts)
  const double *cut2, *entry;  // (r_i + r_j)^2, the law's entry terms (ContactLaw::entry_terms)
  Index cut_mask, entry_mask;  // entry q's are at q & mask (NeighborList::cut_mask)
  double limit;  // max_overlap
  double speed;  // the scene's characteristic impact speed (Simulation::characteristic_speed)
  double *xi, *force, *nxft, *roll, *overlap, *rough;
  double *wxi, *wforce, *wnxft, *wroll, *woverlap, *wrough;
  std::uint8_t *touch, *wtouch;
  double* diss;
  std::uint8_t* loaded;
  Index* wact;  // scratch: the near-wall entries in contact
  const Wall* planes;
  // Scenes with a mesh: the walls, and each near-wall entry's tangent plane this step (the
  // contact pass measures them first); null otherwise, and an entry's wall is planes[wall[e]].
  const Walls* meshes;
  Wall* tangent;
  Walls::Clearance* clear;  // with meshes and no wall moving: Walls::measure's records; else null
  // The flat sheets (NeighborList::wall_sheet): `of` null where there are none.
  struct Sheets {
    const Index *of, *offset, *entry, *slot;
    std::uint32_t* sum_entry;
    double* room;
  } sheets;
  bool moving;  // a wall moves: wall contacts take its velocity
  const PairTable* table;
  const PairParams* same;  // the parameters of every pair when all spheres share a material
  std::uint64_t step, seed;
  double dt;
  Index pairs;  // near-pair entries
  // Where the near pairs are kAskPairs or more, the pass requests each block's data before its
  // gather (Blocked::request_pairs), and the particle pass the sums' (ParticleView::ask): the
  // entries' state and results then come from the last-level cache, not a nearer one, and the
  // hardware's prefetch does not keep up (the hopper of hopper_liggghts.py, 55,000 near pairs;
  // the tiled bed, 430,000). Below, the requests cost 1-4 % (the 10,000-sphere beds, 27,000).
  bool ask;
  static constexpr std::size_t kAskPairs = std::size_t(1) << 15;
  Index n;             // particles (near-list owners)
  int threads;

  // `ahead`: 1 where the pass evaluates the next step's contacts (the fused pass).
  ContactView(World& s, double dt_, long ahead = 0)
      : ContactView(s.particles.arrays(), s.lists, s.contacts, s, dt_, ahead) {}

  // Scenes of this many spheres or more do not stay in cache from one pass to the next.
  static constexpr std::size_t kFar = std::size_t(1) << 16;

 private:
  ContactView(ParticleStore& p, NeighborList& l, ContactStore& c, World& s, double dt_, long ahead)
      : x(p.x.data()), v(p.v.data()), w(p.w.data()), r(p.radius.data()), m(p.mass.data()),
        inv_i(p.inv_inertia.data()), mat(p.material.data()), ids(p.id.data()),
        own(l.near_owner.data()), par(l.near_partner.data()), wown(l.wall_owner.data()),
        wall(l.wall_index.data()), welement(l.wall_element.data()),
        wnear_offset(l.wall_near_offset.data()), owned(l.near_offset.data()), wnear(l.wall_near.data()),
        cut2(l.near_cut2.data()), entry(l.near_entry.data()), cut_mask(l.cut_mask),
        entry_mask(l.entry_mask), limit(s.options.max_overlap),
        speed(s.run.speed), xi(c.pairs.xi.data()), force(c.pairs.force.data()),
        nxft(c.pairs.nxft.data()), roll(c.pairs.roll.data()), overlap(c.pairs.overlap.data()),
        rough(c.pairs.rough.data()), wxi(c.walls.xi.data()), wforce(c.walls.force.data()),
        wnxft(c.walls.nxft.data()), wroll(c.walls.roll.data()), woverlap(c.walls.overlap.data()),
        wrough(c.walls.rough.data()), touch(c.pairs.touch.data()), wtouch(c.walls.touch.data()),
        diss(p.dissipated.data()), loaded(l.loaded.data()), wact(l.active.data()),
        planes(s.walls.planes()), meshes(s.walls.has_meshes() ? &s.walls : nullptr),
        tangent(s.walls.has_meshes() ? l.wall_tangent.data() : nullptr),
        clear(s.walls.has_meshes() && !s.walls.moving() ? l.wall_clear.data() : nullptr),
        sheets{l.wall_sheet.empty() ? nullptr : l.wall_sheet.data(), l.sheet_offset.data(),
               l.sheet_entry.data(), l.sheet_slot.data(), l.sum_entry.data(), l.sheet_room.data()},
        moving(s.walls.moving()), table(&s.pairs),
        same(s.sphere_material >= 0 ? &s.pairs(s.sphere_material, s.sphere_material) : nullptr),
        step(std::uint64_t(s.run.step + ahead)), seed(s.options.seed), dt(dt_),
        pairs(Index(l.near_partner.size())), ask(l.near_partner.size() >= kAskPairs),
        n(Index(s.particles.size())), threads(s.threads) {}
};

// The plane a near-wall entry's contact is evaluated on: its wall, or in a scene with meshes the
// tangent plane the pass measured (one branch per wall entry, the same way every time).
TSUBU_INLINE const Wall& wall_plane(const ContactView& c, Index e) {
  return c.tangent ? c.tangent[e] : c.planes[c.wall[e]];
}

// Everything the particle pass reads and writes.
struct ParticleView {
  double *x, *v, *w;
  const double *inv_m, *inv_i, *radius;
  const Index* busy;
  Index n, nb;
  std::uint8_t* loaded;
  ContactSums sums;
  const std::uint32_t* sum_entry;
  const Index* sum_offset;
  // Particle k's radius is at k & radius_mask, its inverse mass and inertia at k & body_mask
  // (NeighborList::cut_mask and entry_mask: 0 for alike spheres, read once).
  Index radius_mask, body_mask;
  bool flat;
  // The flat sums request their entries' results ahead (ParticlePass::flat_sums) where the
  // near pairs are ContactView::kAskPairs or more.
  bool ask;
  // The pass also finds max |v - u|^2 (Stepper::run's lists bound in a Lees–Edwards box with
  // no walls; not where fixed spheres are placed after the pass).
  bool relative;
  Domain::MeanFlow flow;
  int threads;
  double dt, gx, gy, gz;

  ParticleView(World& s, double dt_) : ParticleView(s.particles.arrays(), s.lists, s, dt_) {}

  // The first busy particle at or after particle k.
  Index first_busy(Index k) const { return Index(std::lower_bound(busy, busy + nb, k) - busy); }

 private:
  ParticleView(ParticleStore& p, NeighborList& l, World& s, double dt_)
      : x(p.x.data()), v(p.v.data()), w(p.w.data()), inv_m(p.inv_mass.data()),
        inv_i(p.inv_inertia.data()), radius(p.radius.data()), busy(l.busy.data()),
        n(Index(s.particles.size())), nb(Index(l.busy.size())), loaded(l.loaded.data()),
        sums(l, s.contacts, s.particles), sum_entry(l.sum_entry.data()),
        sum_offset(l.sum_offset.data()), radius_mask(l.cut_mask), body_mask(l.entry_mask),
        flat(l.sum_offset.size() == std::size_t(nb) + 1),
        ask(l.near_partner.size() >= ContactView::kAskPairs),
        relative(s.streaming() && !s.fixed),
        flow(s.domain.mean_flow()), threads(s.threads), dt(dt_), gx(dt_ * s.options.gravity.x()),
        gy(dt_ * s.options.gravity.y()), gz(dt_ * s.options.gravity.z()) {}
};

}  // namespace tsubu::detail
