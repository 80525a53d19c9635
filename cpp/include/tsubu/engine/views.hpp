// The engine's views of a Simulation: the arrays a pass reads and writes, unpacked once per pass,
// so that the passes themselves never reach into the Simulation.
#pragma once
#include <algorithm>

#include "../simulation.hpp"
#include "common.hpp"

namespace tsubu::detail {

// Everything the contact pass reads and writes.
struct ContactView {
  const double *x, *v, *w, *r, *m, *inv_i;
  const int* mat;
  const Id* ids;
  const Index *own, *par, *wown, *wall, *wnear, *owned;
  const double *cut2, *entry;  // (r_i + r_j)^2, the law's entry terms (ContactLaw::entry_terms)
  double limit;  // max_overlap
  double speed;  // the scene's characteristic impact speed (Simulation::characteristic_speed)
  double *xi, *force, *nxft, *roll, *overlap, *rough;
  double *wxi, *wforce, *wnxft, *wroll, *woverlap, *wrough;
  std::uint8_t *touch, *wtouch;
  double* diss;
  std::uint8_t* loaded;
  Index* wact;  // scratch: the near-wall entries in contact
  const Plane* planes;
  bool moving;  // a wall moves: wall contacts take its velocity
  const PairTable* table;
  const PairParams* same;  // the parameters of every pair when all spheres share a material
  Box box;
  std::uint64_t step, seed;
  double dt;
  Index pairs, walls;  // near-pair and near-wall entries
  int threads;
  bool far;  // a large scene: partners' positions are prefetched

  // `ahead`: 1 where the pass evaluates the next step's contacts (the fused pass).
  ContactView(Simulation& s, double dt_, long ahead = 0)
      : x(s.particles_.x.data()), v(s.particles_.v.data()), w(s.particles_.w.data()),
        r(s.particles_.radius.data()), m(s.particles_.mass.data()),
        inv_i(s.particles_.inv_inertia.data()), mat(s.particles_.material.data()),
        ids(s.particles_.id.data()), own(s.near_owner_.data()), par(s.near_partner_.data()),
        wown(s.wall_owner_.data()), wall(s.wall_index_.data()), wnear(s.wall_near_.data()),
        owned(s.near_offset_.data()), cut2(s.near_cut2_.data()), entry(s.near_entry_.data()),
        limit(s.opt_.max_overlap), speed(s.speed_), xi(s.pair_state_.xi.data()), force(s.pair_state_.force.data()),
        nxft(s.pair_state_.nxft.data()), roll(s.pair_state_.roll.data()),
        overlap(s.pair_state_.overlap.data()), rough(s.pair_state_.rough.data()),
        wxi(s.wall_state_.xi.data()), wforce(s.wall_state_.force.data()),
        wnxft(s.wall_state_.nxft.data()), wroll(s.wall_state_.roll.data()),
        woverlap(s.wall_state_.overlap.data()), wrough(s.wall_state_.rough.data()),
        touch(s.pair_state_.touch.data()), wtouch(s.wall_state_.touch.data()),
        diss(s.particles_.dissipated.data()), loaded(s.loaded_.data()), wact(s.active_.data()),
        planes(s.planes_.data()), moving(s.walls_move()), table(&s.pairs_),
        same(s.sphere_material_ >= 0 ? &s.pairs_(s.sphere_material_, s.sphere_material_)
                                     : nullptr),
        box(s.box_), step(std::uint64_t(s.step_ + ahead)), seed(s.opt_.seed), dt(dt_),
        pairs(Index(s.near_partner_.size())), walls(Index(s.wall_near_.size())),
        threads(static_cast<int>(s.n_) >= s.opt_.parallel_min ? s.threads() : 1),
        far(s.n_ >= kFar) {}

  // Scenes of this many spheres or more do not stay in cache from one pass to the next.
  static constexpr std::size_t kFar = std::size_t(1) << 16;
};

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
  bool flat;
  int threads;
  double dt, gx, gy, gz;

  ParticleView(Simulation& s, double dt_)
      : x(s.particles_.x.data()), v(s.particles_.v.data()), w(s.particles_.w.data()),
        inv_m(s.particles_.inv_mass.data()), inv_i(s.particles_.inv_inertia.data()),
        radius(s.particles_.radius.data()), busy(s.busy_.data()), n(Index(s.n_)),
        nb(Index(s.busy_.size())), loaded(s.loaded_.data()), sums(s),
        sum_entry(s.sum_entry_.data()), sum_offset(s.sum_offset_.data()),
        flat(s.sum_offset_.size() == std::size_t(nb) + 1),
        threads(Index(s.n_) >= s.opt_.parallel_min ? s.threads() : 1), dt(dt_),
        gx(dt_ * s.opt_.gravity.x()), gy(dt_ * s.opt_.gravity.y()), gz(dt_ * s.opt_.gravity.z()) {}

  // The first busy particle at or after particle k.
  Index first_busy(Index k) const { return Index(std::lower_bound(busy, busy + nb, k) - busy); }
};

}  // namespace tsubu::detail
