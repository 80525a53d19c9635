// A domain decomposition's halo (docs/parallel.md): spheres that come into a rank under their
// global ids, leave it, and take their owners' state after each step.
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

void Simulation::insert_spheres(std::size_t n, const Id* ids, const double* positions, const double* radii,
                                const int* materials, const double* velocities,
                                const double* angular_velocities, const double* dissipated, bool keep,
                                const std::int64_t* images, const double* slid, bool check) {
  if (running()) throw std::logic_error("tsubu: Simulation::insert_spheres during a run");
  std::vector<char> seen;
  for (std::size_t k = 0; k < n; ++k) {
    const Id id = ids[k];
    require(id >= 0 && !particles_.has(id), [&] {
      return "insert_spheres: id " + std::to_string(id) + (id < 0 ? " is negative" : " is in use");
    });
    if (static_cast<std::size_t>(id) >= seen.size()) seen.resize(static_cast<std::size_t>(id) + 1, 0);
    require(!seen[static_cast<std::size_t>(id)],
            [&] { return "insert_spheres: id " + std::to_string(id) + " listed twice"; });
    seen[static_cast<std::size_t>(id)] = 1;
    require(finite3(positions + 3 * k) && finite3(velocities + 3 * k) && finite3(angular_velocities + 3 * k) &&
                std::isfinite(dissipated[k]),
            [&] { return "insert_spheres: sphere " + std::to_string(id) + " has a value that is not finite"; });
    require(radii[k] > 0 && std::isfinite(radii[k]), [&] {
      return "insert_spheres: radius of sphere " + std::to_string(id) + " must be > 0, got " + fmt(radii[k]);
    });
    material(materials[k]);
  }
  if (n == 0) return;
  // The contacts kept are carried by ids through the insertion (it changes internal indices).
  const bool carry = keep && law_ != nullptr && lists_.built(particles_.size());
  ContactState pairs, walls;
  if (carry) {
    pairs = contact_state(false);
    walls = contact_state(true);
  }
  domain_.clear_ghosts();
  const std::size_t first = particles_.size();
  particles_.insert(n, ids, positions, radii, materials, velocities, angular_velocities, materials_);
  ParticleStore& ps = particles_.arrays();
  for (std::size_t k = 0; k < n; ++k) ps.dissipated[first + k] = dissipated[k];
  if (images && ps.imaged)
    for (std::size_t k = 0; k < 3 * n; ++k) ps.image[3 * first + k] = static_cast<decltype(ps.image)::value_type>(images[k]);
  if (slid && ps.imaged)
    for (std::size_t k = 0; k < n; ++k) ps.slid[first + k] = slid[k];
  if (ran_ && check)  // (new spheres: the next run checks their overlaps, as add_spheres's)
    for (std::size_t k = 0; k < n; ++k) mark_unchecked(particles_.index(ids[k]), true);
  reset_lists();
  energy_ref_valid_ = false;
  run_.last_move = 0;
  if (carry) set_contact_state(pairs, walls);
}

void Simulation::drop_spheres(std::size_t count, const Id* ids, bool carry) {
  require_held("drop_spheres", count, ids);
  if (count == 0) return;
  remove_now(count, ids, nullptr, false, carry);
}

std::size_t Simulation::pack_state(std::size_t n, const Id* ids, double* out, std::int64_t* images,
                                   double* slid) const {
  const ParticleStore& ps = particles_.arrays();
  std::size_t m = 0;
  for (std::size_t k = 0; k < n; ++k) {
    if (!particles_.has(ids[k])) continue;
    const std::size_t i = static_cast<std::size_t>(particles_.index(ids[k]));
    double* o = out + 9 * m;
    for (int c = 0; c < 3; ++c) {
      o[c] = ps.x[3 * i + c];
      o[3 + c] = ps.v[3 * i + c];
      o[6 + c] = ps.w[3 * i + c];
      if (images) images[3 * m + c] = ps.imaged ? ps.image[3 * i + c] : 0;
    }
    if (slid) slid[m] = ps.imaged ? ps.slid[i] : 0.0;
    ++m;
  }
  return m;
}

// The per-step halo message to one rank: 1 + 9 m or 1 + 10 m values. A rank that holds a copy
// of a sphere steps it as its owner does, with the same bits, unless the sphere has a pair
// contact there (the rank may lack the partner): so only spheres with near-pair entries (the
// step's only pair contacts) travel, and a falling cloud's copies step on their own. out[0] = m,
// the spheres that travel; then, if all n do, their x, v, w in the list's order, else each one's
// place in the list and its x, v, w. (A periodic box's ghosts hold entries for their sources:
// there every listed sphere travels.)
std::size_t Simulation::pack_halo(std::size_t n, const Id* ids, double* out) const {
  const ParticleStore& ps = particles_.arrays();
  const std::size_t rows = particles_.size();
  const Array<Index>& own = lists_.near_offset;
  const Array<Index>& rev = lists_.near_rev_offset;
  const bool known = domain_.ghosts() == 0 && own.size() == rows + 1 && rev.size() == rows + 1;
  // (A sphere an outlet removed this step is gone on every rank that held it.)
  const auto travels = [&](Id id) {
    if (!particles_.has(id)) return false;
    const std::size_t i = static_cast<std::size_t>(particles_.index(id));
    return !known || own[i + 1] > own[i] || rev[i + 1] > rev[i];
  };
  std::size_t m = 0;
  for (std::size_t k = 0; k < n; ++k) m += travels(ids[k]);
  out[0] = static_cast<double>(m);
  const bool all = m == n;
  double* o = out + 1;
  for (std::size_t k = 0; k < n; ++k) {
    if (!all && !travels(ids[k])) continue;
    const std::size_t i = static_cast<std::size_t>(particles_.index(ids[k]));
    if (!all) *o++ = static_cast<double>(k);
    for (int c = 0; c < 3; ++c) {
      o[c] = ps.x[3 * i + c];
      o[3 + c] = ps.v[3 * i + c];
      o[6 + c] = ps.w[3 * i + c];
    }
    o += 9;
  }
  return static_cast<std::size_t>(o - out);
}

double Simulation::unpack_halo(std::size_t n, const Id* ids, const double* in) {
  ParticleStore& ps = particles_.arrays();
  const std::size_t m = static_cast<std::size_t>(in[0]);
  require(m <= n, [&] { return "unpack_halo: " + std::to_string(m) + " spheres for a list of " + std::to_string(n); });
  const bool all = m == n;
  double v2 = 0;
  const double* o = in + 1;
  for (std::size_t r = 0; r < m; ++r, o += 9) {
    const std::size_t k = all ? r : static_cast<std::size_t>(*o++);
    require(k < n, [&] { return "unpack_halo: place " + std::to_string(k) + " outside a list of " + std::to_string(n); });
    if (!particles_.has(ids[k])) continue;
    const std::size_t i = static_cast<std::size_t>(particles_.index(ids[k]));
    for (int c = 0; c < 3; ++c) {
      ps.x[3 * i + c] = o[c];
      ps.v[3 * i + c] = o[3 + c];
      ps.w[3 * i + c] = o[6 + c];
    }
    v2 = std::max(v2, o[3] * o[3] + o[4] * o[4] + o[5] * o[5]);
  }
  return v2;
}

void Simulation::set_own(std::size_t n, const Id* ids) {
  own_.assign(particles_.id_bound(), 0);
  for (std::size_t k = 0; k < n; ++k)
    if (particles_.has(ids[k])) own_[static_cast<std::size_t>(ids[k])] = 1;
}

std::array<double, 3> Simulation::own_speeds() const {
  const ParticleStore& ps = particles_.arrays();
  double top = 0, rel = 0, most = 0;
  const std::size_t n = particles_.size();
  const bool sheared = domain_.sheared();
  const Domain::MeanFlow u = domain_.mean_flow();
  for (std::size_t k = 0; k < n; ++k) {
    const std::size_t id = static_cast<std::size_t>(ps.id[k]);
    if (id >= own_.size() || !own_[id]) continue;
    const double* v = ps.v.data() + 3 * k;
    top = std::max(top, v[0] * v[0] + v[1] * v[1] + v[2] * v[2]);  // (as the particle pass)
    if (!sheared) continue;
    // (ParticlePass::drift's |v - u|^2, then Domain::sheared_move's, each as they compute it)
    const double h = ps.x[3 * k + static_cast<std::size_t>(u.gradient)] - u.centre;
    double r[3] = {v[0], v[1], v[2]};
    r[u.flow] = v[u.flow] - u.rate * h;
    rel = std::max(rel, r[0] * r[0] + r[1] * r[1] + r[2] * r[2]);
    most = std::max(most, u.relative2(ps.x.data(), ps.v.data(), k));
  }
  for (std::size_t k = 0; k < fixed_.ids.size() && k < fixed_.pass_v2.size(); ++k) {
    const std::size_t id = static_cast<std::size_t>(fixed_.ids[k]);
    if (id < own_.size() && own_[id]) top = std::max(top, fixed_.pass_v2[k]);
  }
  return {top, rel, most};
}

}  // namespace tsubu
