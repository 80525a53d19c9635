// The state a checkpoint holds beyond the public setters (simulation.hpp, "checkpoints").
#include <algorithm>
#include <cmath>
#include <string>

#include "tsubu/simulation.hpp"

namespace tsubu {

namespace {

void require(bool ok, const std::string& what) {
  if (!ok) throw InvalidArgument("checkpoint state: " + what);
}

}  // namespace

Simulation::RunState Simulation::run_state() const {
  return {step_, time_, ran_, speed_fixed_, energy_ref_, energy_ref_valid_, energy_ref_step_,
          energy_ref_gravity_};
}

void Simulation::set_run_state(const RunState& s) {
  require(s.step >= 0 && std::isfinite(s.time), "step and time must be >= 0 and finite");
  step_ = s.step;
  time_ = s.time;
  ran_ = s.ran;
  speed_fixed_ = s.speed_fixed;
  energy_ref_ = s.energy_ref;
  energy_ref_valid_ = s.energy_ref_valid;
  energy_ref_step_ = s.energy_ref_step;
  energy_ref_gravity_ = s.energy_ref_gravity;
}

void Simulation::get_dissipated(double* out) const {
  for (std::size_t k = 0; k < n_; ++k) out[particles_.id[k]] = particles_.dissipated[k];
}

void Simulation::set_dissipated(const double* in) {
  for (std::size_t id = 0; id < n_; ++id)
    require(std::isfinite(in[id]), "dissipated energy of sphere " + std::to_string(id) + " is not finite");
  for (std::size_t k = 0; k < n_; ++k) particles_.dissipated[k] = in[particles_.id[k]];
}

void Simulation::set_plane_state(int wall, const Plane& p) {
  require(wall >= 0 && wall < plane_count(), "no wall " + std::to_string(wall));
  require(p.point.allFinite() && p.normal.allFinite() && p.velocity.allFinite() &&
              p.angular_velocity.allFinite() && std::abs(p.normal.norm() - 1) < 1e-12,
          "wall " + std::to_string(wall) + ": a finite point, unit normal and motion");
  material(p.material);
  planes_[wall] = p;
  list_valid_ = false;
  energy_ref_valid_ = false;
}

Simulation::ContactState Simulation::contact_state(bool walls) const {
  ContactState c;
  const EntryStore& store = walls ? wall_state_ : pair_state_;
  const auto arrays = store.carried();
  const auto widths = EntryStore::widths(walls ? wall_shape_ : pair_shape_);
  for (std::size_t k = 0; k < EntryStore::kFields; ++k) c.widths[k] = arrays[k]->empty() ? 0 : widths[k];
  if (near_offset_.size() != n_ + 1) return c;  // no lists: never ran
  auto keep = [&](Id owner, Id partner, Index e) {
    c.owner.push_back(owner);
    c.partner.push_back(partner);
    for (std::size_t k = 0; k < EntryStore::kFields; ++k) {
      const double* from = arrays[k]->data() + c.widths[k] * e;
      c.values[k].insert(c.values[k].end(), from, from + c.widths[k]);
    }
  };
  for (Id id = 0; id < static_cast<Id>(n_); ++id) {  // in id order: the file is the same for any run
    const Index i = index_of_[id];
    if (walls) {
      for (Index e = wall_offset_[i]; e < wall_offset_[i + 1]; ++e)
        if (wall_state_.overlap[e] > 0) keep(id, wall_index_[e], e);
    } else {
      for (Index e = near_offset_[i]; e < near_offset_[i + 1]; ++e)
        if (pair_state_.overlap[e] > 0) keep(id, particles_.id[near_partner_[e]], e);
    }
  }
  return c;
}

void Simulation::set_contact_state(const ContactState& pairs, const ContactState& walls) {
  mix_pairs();
  select_law();
  for (int w = 0; w < 2; ++w) {
    const ContactState& c = w ? walls : pairs;
    const auto widths = EntryStore::widths(w ? wall_shape_ : pair_shape_);
    const std::size_t m = c.owner.size();
    require(c.partner.size() == m, "owner and partner counts differ");
    for (std::size_t k = 0; k < EntryStore::kFields; ++k) {
      const int need = widths[k];
      require(m == 0 || c.widths[k] == need,
              std::string(w ? "wall" : "pair") + " contact array " + std::to_string(k) + " has " +
                  std::to_string(c.widths[k]) + " values per contact; this scene's law " +
                  law_->name() + " has " + std::to_string(need));
      require(c.values[k].size() == m * static_cast<std::size_t>(c.widths[k]),
              "contact array " + std::to_string(k) + " has the wrong length");
    }
    for (std::size_t e = 0; e < m; ++e) {
      require(c.owner[e] >= 0 && c.owner[e] < static_cast<Id>(n_),
              "contact names sphere " + std::to_string(c.owner[e]) + ", beyond the spheres");
      require(w ? (c.partner[e] >= 0 && c.partner[e] < plane_count())
                : (c.partner[e] > c.owner[e] && c.partner[e] < static_cast<Id>(n_)),
              "contact " + std::to_string(c.owner[e]) + "-" + std::to_string(c.partner[e]) +
                  " names no " + (w ? "wall" : "sphere of a higher id"));
      require(c.values[1][e] > 0, "a stored contact is not touching");
    }
  }
  rebuild(false);  // fresh lists, no state
  auto put = [](EntryStore& st, const ContactState& c, std::size_t from, Index to) {
    const auto arrays = st.carried();
    for (std::size_t k = 0; k < EntryStore::kFields; ++k) {
      const std::size_t wd = c.widths[k];
      std::copy(c.values[k].begin() + wd * from, c.values[k].begin() + wd * (from + 1),
                arrays[k]->begin() + wd * to);
    }
    st.touch[to] = 1;
  };
  for (std::size_t e = 0; e < walls.owner.size(); ++e) {
    const Index i = index_of_[walls.owner[e]];
    Index q = wall_offset_[i];
    while (q < wall_offset_[i + 1] && wall_index_[q] != walls.partner[e]) ++q;
    require(q < wall_offset_[i + 1], "sphere " + std::to_string(walls.owner[e]) +
                                         " is not near wall " + std::to_string(walls.partner[e]));
    put(wall_state_, walls, e, q);
  }
  refresh_near(false, false);  // the near-wall subset now includes the touching walls
  for (std::size_t e = 0; e < pairs.owner.size(); ++e) {
    const Index i = index_of_[pairs.owner[e]];
    const Index* first = near_partner_.data() + near_offset_[i];
    const Index* last = near_partner_.data() + near_offset_[i + 1];
    const Id b = pairs.partner[e];
    const Index* q = std::lower_bound(first, last, b, [&](Index j, Id id) { return particles_.id[j] < id; });
    require(q != last && particles_.id[*q] == b,
            "spheres " + std::to_string(pairs.owner[e]) + " and " + std::to_string(b) + " are not near");
    put(pair_state_, pairs, e, static_cast<Index>(q - near_partner_.data()));
  }
}

}  // namespace tsubu
