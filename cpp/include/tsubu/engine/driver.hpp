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

  static void run(Simulation& s, long steps) {
    const double dt = s.dt_;
    const bool moving = s.walls_move();
    PhaseTimer clock(s.phase_seconds_);
    // With fixed walls no energy enters the scene: the balance is checked every kEnergyCheck
    // steps (Simulation::check_energy), which catches the bounded bursts that a dense pack run
    // above its own (lower) bound goes through without any overlap limit.
    if (moving) {
      s.energy_ref_valid_ = false;
    } else if (!s.energy_ref_valid_ || s.energy_ref_gravity_ != s.opt_.gravity) {
      s.energy_ref_ = s.energy_now();
      s.energy_ref_valid_ = true;
      s.energy_ref_gravity_ = s.opt_.gravity;
      s.energy_ref_step_ = s.step_;
    }
    // Large scenes with fixed walls fuse a step's particle pass with the next step's contact
    // pass whenever no neighbour list can be due in between; the first and the last step of a
    // run, and those that end on an energy check, run as two passes.
    const bool fuse = fuses(s, moving) && steps > 2;
    const double min_mass = fuse ? *std::min_element(s.particles_.mass.data(),
                                                     s.particles_.mass.data() + s.n_)
                                 : 0.0;
    double vmax2 = -1;  // max |v|^2 after the last step; < 0: not known yet
    bool ready = false;  // this step's contacts were evaluated by the last step's fused pass
    Found found;
    for (long k = 0; k < steps; ++k) {
      if (!ready) {
        // A stop (Simulation::request_stop) ends the run here, between two steps. A fused step
        // has begun the next one: a stop found when deciding to fuse it makes it the last.
        if (s.stop_due(clock.last())) break;
        if (s.needs_rebuild()) {
          s.rebuild(true);
        } else if (s.needs_refresh()) {
          s.stash_near();
          s.refresh_near(true, false);
        }
        clock.lap(Phase::Neighbors);
        found = CP::run(ContactView(s, dt));
        clock.lap(Phase::Contacts);
      } else if (s.needs_rebuild() || s.needs_refresh()) {
        throw std::logic_error("tsubu: a fused step moved particles further than its bound");
      }
      if (found.excess > 0) s.report_overlap(dt);
      if (found.bad) s.report_nonfinite();
      ready = fuse && k > 0 && k + 1 < steps && (s.step_ + 1) % Simulation::kEnergyCheck != 0 &&
              fusable(s, dt, vmax2, found, min_mass) && !s.stop_due(clock.last());
      s.fused_steps_ += ready ? 1 : 0;
      const ParticleView pv(s, dt);
      const bool nonfinite =
          ready ? FusedPass<Law>::run(pv, ContactView(s, dt, 1), s.near_reach_below_,
                                      s.near_reach_above_, vmax2, found)
                : PP::run(pv, vmax2);
      book_moved(s, dt, vmax2);
      if (nonfinite) s.report_nonfinite_velocity();
      if (moving) s.move_planes(dt);
      s.box_.wrap(s.particles_.x.data(), s.n_);
      ++s.step_;
      s.time_ += dt;
      if (!moving && s.step_ % Simulation::kEnergyCheck == 0) s.check_energy(s.energy_ref_);
      clock.lap(Phase::Integrate);
    }
  }

  // Adds the distance any particle moved this step, dt max|v|, to the neighbour lists' bounds.
  static void book_moved(Simulation& s, double dt, double vmax2) {
    const double moved = std::sqrt(vmax2) * dt;
    s.moved_ += moved;
    s.moved_near_ += moved;
  }

  // Whether runs of this scene fuse steps where they can.
  static bool fuses(const Simulation& s, bool moving) {
    return Features<Law>::kBlocked && !moving && s.n_ >= ContactView::kFar;
  }

  // Whether this step may be fused with the next step's contact pass: no neighbour list can be
  // due after it. Any particle's new speed is at most its old one plus dt (|g| + the most
  // entries it sums x the largest contact force / the smallest mass); the step then moves no
  // particle further than dt times that (the factor 1 + 1e-9 covers rounding).
  static bool fusable(const Simulation& s, double dt, double vmax2, const Found& now,
                      double min_mass) {
    const double speed = std::sqrt(vmax2) + dt * (s.opt_.gravity.norm() +
                                                   double(s.max_entries_) * now.fmax / min_mass);
    const double step = dt * speed * (1 + 1e-9);
    return s.list_valid_ && !s.opt_.rebuild_every_step && std::isfinite(step) &&
           2.0 * (s.moved_ + step) <= s.list_skin_ && 2.0 * (s.moved_near_ + step) <= s.near_skin();
  }
};

}  // namespace tsubu::detail
