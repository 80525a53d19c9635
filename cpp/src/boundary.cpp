// Grains as boundaries (boundary.hpp, docs/boundaries.md): removal, fixed and prescribed
// spheres, outlets, and the ids in id order.
#include <Eigen/Geometry>
#include <algorithm>
#include <stdexcept>
#include <string>
#include <vector>

#include "check.hpp"
#include "tsubu/simulation.hpp"

namespace tsubu {

using detail::finite3;
using detail::fmt;
using detail::require;

namespace {

std::string too_fast(double speed) {
  return "a velocity of " + fmt(speed) + " m/s is faster than light (" + fmt(Simulation::kMaxWallSpeed) +
         " m/s): check its units";
}

}  // namespace

void Simulation::remove_now(std::size_t count, const Id* ids, const int* outlet, bool log, bool keep) {
  std::vector<char> gone(particles_.id_bound(), 0);
  for (std::size_t k = 0; k < count; ++k) gone[static_cast<std::size_t>(ids[k])] = 1;
  if (log) {  // the log, by increasing id within a step
    std::vector<std::size_t> order(count);
    for (std::size_t k = 0; k < count; ++k) order[k] = k;
    std::sort(order.begin(), order.end(), [&](std::size_t a, std::size_t b) { return ids[a] < ids[b]; });
    const ParticleStore& ps = particles_.arrays();
    for (std::size_t k : order) {
      const std::size_t i = static_cast<std::size_t>(particles_.index(ids[k]));
      removed_.id.push_back(ids[k]);
      removed_.outlet.push_back(outlet[k]);
      removed_.step.push_back(run_.step);
      removed_.time.push_back(run_.time);
      for (int c = 0; c < 3; ++c) {
        removed_.position.push_back(ps.x[3 * i + c]);
        removed_.velocity.push_back(ps.v[3 * i + c]);
      }
    }
  }
  if (!fixed_.empty()) {  // the fixed spheres removed leave the list
    FixedSpheres kept;
    for (std::size_t k = 0; k < fixed_.ids.size(); ++k) {
      if (gone[static_cast<std::size_t>(fixed_.ids[k])]) continue;
      kept.ids.push_back(fixed_.ids[k]);
      kept.v.insert(kept.v.end(), fixed_.v.begin() + 3 * k, fixed_.v.begin() + 3 * k + 3);
      kept.w.insert(kept.w.end(), fixed_.w.begin() + 3 * k, fixed_.w.begin() + 3 * k + 3);
    }
    fixed_ = std::move(kept);
  }
  energy_ref_valid_ = false;
  if (running() && lists_.valid && lists_.built(particles_.size()) && !domain_.periodic()) {
    // An outlet, during a run: the lists lose the spheres' rows and entries in place (a
    // rebuild, or a round trip through ids as a checkpoint takes, costs some twenty steps).
    lists_.remove(list_context(), ids, count);
    return;
  }
  // The contacts that stay are carried by ids, as a checkpoint carries them (the lists refer to
  // internal indices, which the removal changes; and between runs the law may change).
  const bool carry = keep && law_ != nullptr && lists_.built(particles_.size());
  ContactState pairs, walls;
  if (carry) {
    auto drop = [&](ContactState& c, bool wall) {
      ContactState kept;
      kept.widths = c.widths;
      for (std::size_t e = 0; e < c.owner.size(); ++e) {
        if (gone[static_cast<std::size_t>(c.owner[e])] || (!wall && gone[static_cast<std::size_t>(c.partner[e])]))
          continue;
        kept.owner.push_back(c.owner[e]);
        kept.partner.push_back(c.partner[e]);
        if (!c.element.empty()) kept.element.push_back(c.element[e]);  // a mesh wall's triangle
        for (std::size_t k = 0; k < EntryStore::kFields; ++k)
          kept.values[k].insert(kept.values[k].end(), c.values[k].begin() + c.widths[k] * e,
                                c.values[k].begin() + c.widths[k] * (e + 1));
      }
      c = std::move(kept);
    };
    pairs = contact_state(false);
    walls = contact_state(true);
    drop(pairs, false);
    drop(walls, true);
  }
  domain_.clear_ghosts();  // (the rows go with the removal; a rebuild makes them again)
  particles_.remove(ids, count);
  reset_lists();
  run_.last_move = 0;
  if (carry) set_contact_state(pairs, walls);
}

void Simulation::remove_outgoing() {
  const ParticleStore& ps = particles_.arrays();
  std::vector<Id> out;
  std::vector<int> by;
  // Rows in memory order (the removal does not depend on the order found).
  const std::size_t n = particles_.size();
  long found = 0;
  for (const Outlet& outlet : outlets_) found += outlet.count(ps.x.data(), n);
  if (found == 0) return;
  for (std::size_t o = 0; o < outlets_.size(); ++o) {
    const Outlet& outlet = outlets_[o];
    for (std::size_t i = 0; i < n; ++i)
      if (outlet.removes(ps.x.data() + 3 * i) &&
          std::find(out.begin(), out.end(), ps.id[i]) == out.end()) {  // (the first outlet names it)
        out.push_back(ps.id[i]);
        by.push_back(static_cast<int>(o));
      }
  }
  if (out.empty()) return;
  remove_now(out.size(), out.data(), by.data());  // (rebuilds the lists, with their terms)
  contacts_.size(lists_.near_partner.size(), lists_.wall_index.size());
}

void Simulation::reset_lists() {
  const long rebuilds = lists_.rebuilds, refreshes = lists_.refreshes;
  lists_ = NeighborList();  // nothing to carry over from lists of the old indices
  lists_.rebuilds = rebuilds;
  lists_.refreshes = refreshes;
}

void Simulation::require_held(const char* what, std::size_t count, const Id* ids) const {
  if (running()) throw std::logic_error(std::string("tsubu: Simulation::") + what + " during a run");
  std::vector<char> seen(particles_.id_bound(), 0);
  for (std::size_t k = 0; k < count; ++k) {
    require(particles_.has(ids[k]), [&] { return std::string(what) + ": no sphere " + std::to_string(ids[k]); });
    require(!seen[static_cast<std::size_t>(ids[k])],
            [&] { return std::string(what) + ": sphere " + std::to_string(ids[k]) + " listed twice"; });
    seen[static_cast<std::size_t>(ids[k])] = 1;
  }
}

void Simulation::fix_spheres(std::size_t count, const Id* ids, const double* velocities,
                             const double* angular_velocities) {
  require_held("fix_spheres", count, ids);
  for (std::size_t k = 0; k < count; ++k) {
    require(finite3(velocities + 3 * k) && finite3(angular_velocities + 3 * k), [&] {
      return "fix_spheres: the motion of sphere " + std::to_string(ids[k]) + " is not finite";
    });
    const double speed = Eigen::Map<const Vec3>(velocities + 3 * k).norm();
    require(speed <= kMaxWallSpeed, [&] {
      return "fix_spheres: sphere " + std::to_string(ids[k]) + ": " + too_fast(speed);
    });
  }
  ParticleStore& ps = particles_.arrays();
  for (std::size_t k = 0; k < count; ++k) {
    const Id id = ids[k];
    long at = fixed_.find(id);
    if (at < 0) {
      const auto it = std::lower_bound(fixed_.ids.begin(), fixed_.ids.end(), id);
      at = it - fixed_.ids.begin();
      fixed_.ids.insert(it, id);
      fixed_.v.insert(fixed_.v.begin() + 3 * at, 3, 0.0);
      fixed_.w.insert(fixed_.w.begin() + 3 * at, 3, 0.0);
    }
    const std::size_t i = static_cast<std::size_t>(particles_.index(id));
    for (int c = 0; c < 3; ++c) {
      fixed_.v[3 * at + c] = ps.v[3 * i + c] = velocities[3 * k + c];
      fixed_.w[3 * at + c] = ps.w[3 * i + c] = angular_velocities[3 * k + c];
    }
    ps.inv_mass[i] = 0;
    ps.inv_inertia[i] = 0;
  }
  if (count > 0) {
    energy_ref_valid_ = false;
    run_.last_move = 0;
    if (lists_.built(particles_.size()) && law_ != nullptr) lists_.cache_terms(list_context());
  }
}

void Simulation::free_spheres(std::size_t count, const Id* ids) {
  if (running()) throw std::logic_error("tsubu: Simulation::free_spheres during a run");
  for (std::size_t k = 0; k < count; ++k)
    require(particles_.has(ids[k]), [&] { return "free_spheres: no sphere " + std::to_string(ids[k]); });
  ParticleStore& ps = particles_.arrays();
  bool any = false;
  for (std::size_t k = 0; k < count; ++k) {
    const long at = fixed_.find(ids[k]);
    if (at < 0) continue;
    any = true;
    fixed_.ids.erase(fixed_.ids.begin() + at);
    fixed_.v.erase(fixed_.v.begin() + 3 * at, fixed_.v.begin() + 3 * at + 3);
    fixed_.w.erase(fixed_.w.begin() + 3 * at, fixed_.w.begin() + 3 * at + 3);
    const std::size_t i = static_cast<std::size_t>(particles_.index(ids[k]));
    const double m = ps.mass[i], r = ps.radius[i];
    ps.inv_mass[i] = 1.0 / m;  // as Particles::add has them
    ps.inv_inertia[i] = 1.0 / (0.4 * m * r * r);
  }
  if (any) {
    energy_ref_valid_ = false;
    if (lists_.built(particles_.size()) && law_ != nullptr) lists_.cache_terms(list_context());
  }
}

void Simulation::get_fixed(std::uint8_t* out) const {
  std::fill(out, out + particles_.size(), std::uint8_t(0));
  for (Id id : fixed_.ids) out[particles_.rank(id)] = 1;
}

void Simulation::get_ids(Id* out) const {
  particles_.for_each_id([&](Id id, Index) { out[particles_.rank(id)] = id; });
}

int Simulation::add_outlet(const Outlet& outlet) {
  if (running()) throw std::logic_error("tsubu: Simulation::add_outlet during a run");
  Outlet o = outlet;
  require(o.a.allFinite() && o.b.allFinite(), "outlet: a point, normal or corner is not finite");
  if (o.kind == Outlet::PlaneOutlet) {
    require(o.b.norm() > 0, "outlet: the normal must be a non-zero vector");
    o.b = o.b.normalized();
  } else {
    require(o.kind == Outlet::BoxOutlet, "outlet: unknown kind " + std::to_string(o.kind));
    require((o.a.array() <= o.b.array()).all(), "outlet: a box needs lo <= hi along every axis");
  }
  outlets_.push_back(o);
  return static_cast<int>(outlets_.size()) - 1;
}

}  // namespace tsubu
