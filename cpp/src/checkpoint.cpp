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
  return {run_.step, run_.time, ran_, speed_fixed_, energy_ref_, energy_ref_valid_, energy_ref_step_,
          energy_ref_gravity_};
}

void Simulation::set_run_state(const RunState& s) {
  require(s.step >= 0 && std::isfinite(s.time), "step and time must be >= 0 and finite");
  run_.step = s.step;
  run_.time = s.time;
  ran_ = s.ran;
  speed_fixed_ = s.speed_fixed;
  energy_ref_ = s.energy_ref;
  energy_ref_valid_ = s.energy_ref_valid;
  energy_ref_step_ = s.energy_ref_step;
  energy_ref_gravity_ = s.energy_ref_gravity;
}

void Simulation::get_dissipated(double* out) const {
  for (std::size_t k = 0; k < particles_.size(); ++k) out[particles_.arrays().id[k]] = particles_.arrays().dissipated[k];
}

void Simulation::set_dissipated(const double* in) {
  for (std::size_t id = 0; id < particles_.size(); ++id)
    require(std::isfinite(in[id]), "dissipated energy of sphere " + std::to_string(id) + " is not finite");
  for (std::size_t k = 0; k < particles_.size(); ++k) particles_.arrays().dissipated[k] = in[particles_.arrays().id[k]];
}

void Simulation::set_plane_state(int wall, const Plane& p) {
  require(wall >= 0 && wall < plane_count(), "no wall " + std::to_string(wall));
  require(p.point.allFinite() && p.normal.allFinite() && p.velocity.allFinite() &&
              p.angular_velocity.allFinite() && std::abs(p.normal.norm() - 1) < 1e-12,
          "wall " + std::to_string(wall) + ": a finite point, unit normal and motion");
  material(p.material);
  walls_.set(wall, p);
  lists_.valid = false;
  energy_ref_valid_ = false;
}

Simulation::ContactState Simulation::contact_state(bool walls) const {
  ContactState c;
  const EntryStore& store = walls ? contacts_.walls : contacts_.pairs;
  const auto arrays = store.carried();
  const auto widths = EntryStore::widths(walls ? contacts_.wall_shape : contacts_.pair_shape);
  for (std::size_t k = 0; k < EntryStore::kFields; ++k) c.widths[k] = arrays[k]->empty() ? 0 : widths[k];
  if (lists_.near_offset.size() != particles_.size() + 1) return c;  // no lists: never ran
  const CompiledLaw& law = this->law();  // (which stored entries touch)
  auto keep = [&](Id owner, Id partner, Index e) {
    c.owner.push_back(owner);
    c.partner.push_back(partner);
    for (std::size_t k = 0; k < EntryStore::kFields; ++k) {
      const double* from = arrays[k]->data() + c.widths[k] * e;
      c.values[k].insert(c.values[k].end(), from, from + c.widths[k]);
    }
  };
  for (Id id = 0; id < static_cast<Id>(particles_.size()); ++id) {  // in id order: the file is the same for any run
    const Index i = particles_.index(id);
    if (walls) {
      for (Index e = lists_.wall_offset[i]; e < lists_.wall_offset[i + 1]; ++e)
        if (touching(law, contacts_.walls.overlap[e])) keep(id, lists_.wall_index[e], e);
    } else {
      for (Index e = lists_.near_offset[i]; e < lists_.near_offset[i + 1]; ++e)
        if (touching(law, contacts_.pairs.overlap[e])) keep(id, particles_.arrays().id[lists_.near_partner[e]], e);
    }
  }
  return c;
}

void Simulation::set_contact_state(const ContactState& pairs, const ContactState& walls) {
  mix_pairs();
  select_law();
  for (int w = 0; w < 2; ++w) {
    const ContactState& c = w ? walls : pairs;
    const auto widths = EntryStore::widths(w ? contacts_.wall_shape : contacts_.pair_shape);
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
      require(c.owner[e] >= 0 && c.owner[e] < static_cast<Id>(particles_.size()),
              "contact names sphere " + std::to_string(c.owner[e]) + ", beyond the spheres");
      require(w ? (c.partner[e] >= 0 && c.partner[e] < plane_count())
                : (c.partner[e] > c.owner[e] && c.partner[e] < static_cast<Id>(particles_.size())),
              "contact " + std::to_string(c.owner[e]) + "-" + std::to_string(c.partner[e]) +
                  " names no " + (w ? "wall" : "sphere of a higher id"));
      require(touching(*law_, c.values[1][e]), "a stored contact is not touching");
    }
  }
  lists_.rebuild_empty(list_context(), skin());  // fresh lists, no state
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
    const Index i = particles_.index(walls.owner[e]);
    Index q = lists_.wall_offset[i];
    while (q < lists_.wall_offset[i + 1] && lists_.wall_index[q] != walls.partner[e]) ++q;
    require(q < lists_.wall_offset[i + 1], "sphere " + std::to_string(walls.owner[e]) +
                                         " is not near wall " + std::to_string(walls.partner[e]));
    put(contacts_.walls, walls, e, q);
  }
  lists_.finish_restore(list_context());  // the near-wall subset now includes the touching walls
  for (std::size_t e = 0; e < pairs.owner.size(); ++e) {
    const Index i = particles_.index(pairs.owner[e]);
    const Index* first = lists_.near_partner.data() + lists_.near_offset[i];
    const Index* last = lists_.near_partner.data() + lists_.near_offset[i + 1];
    const Id b = pairs.partner[e];
    const Index* q = std::lower_bound(first, last, b, [&](Index j, Id id) { return particles_.arrays().id[j] < id; });
    require(q != last && particles_.arrays().id[*q] == b,
            "spheres " + std::to_string(pairs.owner[e]) + " and " + std::to_string(b) + " are not near");
    put(contacts_.pairs, pairs, e, static_cast<Index>(q - lists_.near_partner.data()));
  }
}

}  // namespace tsubu
