// The time loop, written once as a template over the contact law; registry.cpp instantiates it
// for every combination of the slots' evaluators and a run picks one when it starts.
//
// One step (symplectic Euler, 2.2) is two passes: the contact pass (contact_pass.hpp) evaluates
// every near entry in contact and stores its result with it; the particle pass
// (particle_pass.hpp) sums each particle's entries in an order fixed by ids and advances
// v^{n+1} = v^n + dt F/m, w^{n+1} = w^n + dt T/I, x^{n+1} = x^n + dt v^{n+1}. No per-particle force
// arrays are streamed, and results are bit-identical for any thread count and any rebuild
// schedule. In large scenes, whose arrays do not stay in cache from one pass to the next, a
// step's particle pass and the next step's contact pass are one sweep (fused_pass.hpp) whenever
// no neighbour list can fall due in between. A run stops early, on request, only where a
// run's last step would end: after a two-pass step.
#pragma once
#include <algorithm>
#include <cmath>
#include <stdexcept>

#include "fused_pass.hpp"

namespace tsubu::detail {

template <class Law>
struct Stepper {
  using CP = ContactPass<Law>;
  using PP = ParticlePass<Law>;

  static void run(World& s, long steps) {
    RunCounters& run = s.run;
    NeighborList& lists = s.lists;
    const double dt = run.dt;
    const bool moving = s.walls.moving();
    // Fixed spheres with a prescribed motion work on the scene as a moving wall does.
    // So does a Lees–Edwards box.
    const bool driven = moving || (s.fixed && s.fixed->moving()) || s.domain.shear_rate() != 0 ||
                        s.domain.servo().on;
    const bool periodic = s.domain.periodic();
    const bool streaming = s.streaming();
    PhaseTimer clock(run.phase_seconds);
    // With fixed walls no energy enters the scene: the balance is checked every kEnergyCheck
    // steps (RunHooks::audit), which catches the bounded bursts that a dense pack run above its
    // own (lower) bound goes through without any overlap limit.
    s.hooks.start_audit(driven);
    // Large scenes with fixed walls fuse a step's particle pass with the next step's contact
    // pass whenever no neighbour list can be due in between; the first and the last step of a
    // run, and those that end on an energy check, run as two passes.
    const bool fuse = fuses(s) && steps > 2;
    const ParticleStore& p = s.particles.arrays();
    const double min_mass = fuse ? *std::min_element(p.mass.data(), p.mass.data() + s.particles.size())
                                 : 0.0;
    double vmax2 = -1;  // max |v|^2 after the last step; < 0: not known yet
    bool ready = false;  // this step's contacts were evaluated by the last step's fused pass
    Found found;
    for (long k = 0; k < steps; ++k) {
      if (!ready) {
        // A stop (Simulation::request_stop) ends the run here, between two steps. A fused step
        // has begun the next one: a stop found when deciding to fuse it makes it the last.
        if (s.hooks.stop_due(clock.last())) break;
        s.hooks.update_lists();
        clock.lap(Phase::Neighbors);
        found = CP::run(ContactView(s, dt), run.balance.cuts(Index(s.particles.size()), s.threads),
                        run.balance, run.regions[int(Region::Contacts)]);
        if (periodic) s.domain.fold(lists.loaded.data(), s.particles.size());
        clock.lap(Phase::Contacts);
      } else if (lists.needs_rebuild(s.walls, s.options.rebuild_every_step) || lists.needs_refresh()) {
        throw std::logic_error("tsubu: a fused step moved particles further than its bound");
      }
      if (found.excess > 0) s.hooks.report_overlap(dt);
      if (found.bad) s.hooks.report_nonfinite();
      // The last step's dt max|v| (known from its particle pass): a sphere that moved further
      // than max_move may have passed through another, or over a contact, unseen. Checked after
      // the overlaps, which name a contact the step ran into.
      if (run.last_move > s.max_move) s.hooks.report_fast(s.max_move);
      // The walls take their step here, after the contacts that used them and before the
      // particle pass, which does not read them: a fused pass then evaluates the next step's
      // wall contacts where the walls then stand.
      if (moving) {
        if (s.walls.servoed()) s.hooks.steer_walls();
        s.walls.advance(dt);
      }
      ready = fuse && k > 0 && k + 1 < steps && (run.step + 1) % kEnergyCheck != 0 &&
              fusable(s, dt, vmax2, found, min_mass) && !s.hooks.stop_due(clock.last());
      run.fused_steps += ready ? 1 : 0;
      const ParticleView pv(s, dt);
      if (s.fixed) s.fixed->before(s.particles);
      double rel2 = 0;  // max |v - u|^2, where pv.relative
      const bool nonfinite =
          ready ? FusedPass<Law>::run(pv, ContactView(s, dt, 1), lists.reach_below, lists.reach_above,
                                      run.balance.cuts(pv.n, s.threads), run.balance, vmax2, found,
                                      run.regions[int(Region::Fused)])
                : PP::run(pv, run.balance.cuts(pv.n, s.threads), run.balance, vmax2, rel2,
                          run.regions[int(Region::Particles)]);
      run.balance.step();
      if (s.fixed) vmax2 = std::max(vmax2, s.fixed->after(s.particles, dt));
      // A rank's halo takes its owners' state here; the hook answers the step's max |v|^2 of
      // the whole scene (over every rank), which the lists book.
      double most = -1;  // a rank's max |v - u|^2 after the fixed spheres' motion (streaming)
      if (s.exchange) s.hooks.exchange_ghosts(vmax2, rel2, most);
      run.last_move = std::sqrt(vmax2) * dt;  // the distance any particle moved: dt max|v|
      // (A Lees–Edwards image also moves at the slide's speed: a pair across the sheared faces
      // closes by at most 2 moved + slide, so each sphere books half the slide; without walls,
      // the spheres' motion relative to the mean flow bounds it closer: Domain::sheared_bound,
      // with max |v - u| from the particle pass, or Domain::sheared_move where fixed spheres
      // are placed after it.)
      if (!periodic) lists.book_moved(run.last_move);
      else if (pv.relative) lists.book_moved(s.domain.sheared_bound(rel2, dt));
      else if (streaming)
        lists.book_moved(most >= 0 ? s.domain.sheared_bound(most, dt)
                                   : s.domain.sheared_move(s.particles.arrays(), s.particles.size(), dt));
      else lists.book_moved(run.last_move + 0.5 * dt * s.domain.shear_speed());
      if (nonfinite) s.hooks.report_nonfinite_velocity();
      if (periodic) {
        if (s.domain.servo().on) s.hooks.steer_box();
        s.domain.advance(dt);
        s.domain.update_ghosts(s.particles.arrays(), s.particles.size(), s.threads);
      }
      ++run.step;
      run.time += dt;
      if (s.outlets) s.hooks.remove_outgoing();
      if (!driven && run.step % kEnergyCheck == 0) s.hooks.audit();
      clock.lap(Phase::Integrate);
    }
  }

  // Whether runs of this scene fuse steps where they can.
  static bool fuses(const World& s) {
    // (A fixed sphere is put in place after the particle pass, and an outlet removes spheres
    // after it: neither can be fused with the next contact pass.)
    // (Nor can a periodic box, whose ghosts follow their sources between the two.)
    // (Walls may move, with their prescribed motion: a servo wall's speed has no bound that
    // fusable could use, and a moving mesh's measure is left to the two passes.)
    const bool walls = !s.walls.moving() || (!s.walls.servoed() && !s.walls.has_meshes());
    // (Nor a rank's halo, which takes its owners' state between the two.)
    return Features<Law>::kBlocked && walls && !s.fixed && !s.outlets && !s.domain.periodic() && !s.exchange &&
           s.particles.size() >= ContactView::kFar;
  }

  // Whether this step may be fused with the next step's contact pass: no neighbour list can be
  // due after it. Any particle's new speed is at most its old one plus dt (|g| + the most
  // entries it sums x the largest contact force / the smallest mass); the step then moves no
  // particle further than dt times that (the factor 1 + 1e-9 covers rounding).
  static bool fusable(const World& s, double dt, double vmax2, const Found& now, double min_mass) {
    const double speed = std::sqrt(vmax2) + dt * (s.options.gravity.norm() +
                                                   double(s.lists.max_entries) * now.fmax / min_mass);
    const double step = dt * speed * (1 + 1e-9);
    // (The walls have already taken this step: Stepper::run.)
    return std::isfinite(step) && s.lists.can_move(step, s.options.rebuild_every_step) &&
           !s.walls.moved_beyond(s.lists.moved + step, s.lists.skin);
  }
};

}  // namespace tsubu::detail
