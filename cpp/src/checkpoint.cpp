// The state a checkpoint holds beyond the public setters (simulation.hpp, "checkpoints").
#include <algorithm>
#include <cmath>
#include <cstring>
#include <istream>
#include <iterator>
#include <ostream>
#include <stdexcept>
#include <type_traits>
#include <string>

#include "tsubu/option_table.hpp"
#include "tsubu/simulation.hpp"

namespace tsubu {

namespace {

void require(bool ok, const std::string& what) {
  if (!ok) throw InvalidArgument("checkpoint state: " + what);
}

}  // namespace

Simulation::RunState Simulation::run_state() const {
  RunState s;
  s.step = run_.step;
  s.time = run_.time;
  s.ran = ran_;
  s.speed_fixed = speed_fixed_;
  s.energy_ref = energy_ref_;
  s.energy_ref_valid = energy_ref_valid_;
  s.energy_ref_step = energy_ref_step_;
  s.energy_ref_gravity = energy_ref_gravity_;
  if (ran_) {
    s.unchecked = unchecked_;
    s.unchecked_from = unchecked_from_;
    s.unchecked_walls = plane_count() - walls_checked_;
  }
  return s;
}

void Simulation::set_run_state(const RunState& s) {
  require(s.step >= 0 && std::isfinite(s.time), "step and time must be >= 0 and finite");
  run_.step = s.step;
  run_.time = s.time;
  run_.last_move = 0;
  ran_ = s.ran;
  speed_fixed_ = s.speed_fixed;
  energy_ref_ = s.energy_ref;
  energy_ref_valid_ = s.energy_ref_valid;
  energy_ref_step_ = s.energy_ref_step;
  energy_ref_gravity_ = s.energy_ref_gravity;
  require(s.unchecked_from.size() == 3 * s.unchecked.size() && s.unchecked_walls >= 0 &&
              s.unchecked_walls <= plane_count(),
          "the changes not yet checked for overlaps: 3 coordinates per sphere, at most every wall");
  unchecked_.clear();
  unchecked_from_.clear();
  unchecked_listed_.clear();
  if (!s.unchecked.empty()) unchecked_listed_.assign(particles_.id_bound(), 0);
  for (std::size_t k = 0; k < s.unchecked.size(); ++k) {  // (a sphere since removed is skipped)
    const Id id = s.unchecked[k];
    if (!particles_.has(id) || unchecked_listed_[static_cast<std::size_t>(id)]) continue;
    unchecked_listed_[static_cast<std::size_t>(id)] = 1;
    unchecked_.push_back(id);
    unchecked_from_.insert(unchecked_from_.end(), s.unchecked_from.begin() + 3 * k,
                           s.unchecked_from.begin() + 3 * (k + 1));
  }
  walls_checked_ = plane_count() - s.unchecked_walls;
  publish();
}

void Simulation::get_dissipated(double* out) const {
  particles_.gather_scalar(particles_.arrays().dissipated, out);
}

void Simulation::set_dissipated(const double* in) {
  particles_.for_each_id([&](Id id, Index) {
    require(std::isfinite(in[particles_.rank(id)]),
            "dissipated energy of sphere " + std::to_string(id) + " is not finite");
  });
  for (std::size_t k = 0; k < particles_.size(); ++k)
    particles_.arrays().dissipated[k] = in[particles_.rank(particles_.arrays().id[k])];
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
    if (walls) c.element.push_back(lists_.wall_element[e]);
    for (std::size_t k = 0; k < EntryStore::kFields; ++k) {
      const double* from = arrays[k]->data() + c.widths[k] * e;
      c.values[k].insert(c.values[k].end(), from, from + c.widths[k]);
    }
  };
  particles_.for_each_id([&](Id id, Index i) {  // in id order: the file is the same for any run
    if (walls) {
      for (Index e = lists_.wall_offset[i]; e < lists_.wall_offset[i + 1]; ++e)
        if (touching(law, contacts_.walls.overlap[e])) keep(id, lists_.wall_index[e], e);
    } else {
      for (Index e = lists_.near_offset[i]; e < lists_.near_offset[i + 1]; ++e)
        if (touching(law, contacts_.pairs.overlap[e])) keep(id, particles_.arrays().id[lists_.near_partner[e]], e);
    }
  });
  return c;
}

void Simulation::set_contact_state(const ContactState& pairs, const ContactState& walls, bool wrap) {
  mix_pairs();
  select_law();
  for (int w = 0; w < 2; ++w) {
    const ContactState& c = w ? walls : pairs;
    const auto widths = EntryStore::widths(w ? contacts_.wall_shape : contacts_.pair_shape);
    const std::size_t m = c.owner.size();
    require(c.partner.size() == m, "owner and partner counts differ");
    require(c.element.empty() || c.element.size() == m, "owner and element counts differ");
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
      require(particles_.has(c.owner[e]), "contact names sphere " + std::to_string(c.owner[e]) + ", which the scene has not");
      require(w ? (c.partner[e] >= 0 && c.partner[e] < plane_count())
                : (c.partner[e] > c.owner[e] && particles_.has(c.partner[e])),
              "contact " + std::to_string(c.owner[e]) + "-" + std::to_string(c.partner[e]) +
                  " names no " + (w ? "wall" : "sphere of a higher id"));
      require(touching(*law_, c.values[1][e]), "a stored contact is not touching");
    }
  }
  lists_.rebuild_empty(list_context(), skin(), wrap);  // fresh lists, no state
  auto put = [](EntryStore& st, const ContactState& c, std::size_t from, Index to) {
    const auto arrays = st.carried();
    for (std::size_t k = 0; k < EntryStore::kFields; ++k) {
      const std::size_t wd = c.widths[k];
      std::copy(c.values[k].begin() + wd * from, c.values[k].begin() + wd * (from + 1),
                arrays[k]->begin() + wd * to);
    }
    st.touch[to] = 1;
  };
  // The wall contacts go to the stash, rows by internal index, from which the near-wall list
  // takes them as a refresh takes the last list's (they stay in it while they touch).
  {
    const std::size_t n = particles_.size(), m = walls.owner.size();
    Array<Index>& rows = contacts_.stash_wall_offset;
    rows.assign(n + 1, 0);
    std::vector<Index> row_of(m);
    for (std::size_t e = 0; e < m; ++e) {
      const Index i = particles_.index(walls.owner[e]);
      const Index element = walls.element.empty() ? 0 : walls.element[e];
      require(lists_.reaches(i, Index(walls.partner[e]), element),
              "sphere " + std::to_string(walls.owner[e]) + " is not near wall " +
                  std::to_string(walls.partner[e]) + " (element " + std::to_string(element) + ")");
      row_of[e] = i;
      ++rows[std::size_t(i) + 1];
    }
    for (std::size_t i = 0; i < n; ++i) rows[i + 1] += rows[i];
    contacts_.stash_wall_index.resize(m);
    contacts_.stash_wall_element.resize(m);
    for (std::size_t k = 0; k < EntryStore::kFields; ++k)  // (a law's unused arrays stay empty)
      contacts_.stash_walls[k].assign(std::size_t(walls.widths[k]) * m, 0.0);
    std::vector<Index> fill(rows.begin(), rows.end() - 1);
    for (std::size_t e = 0; e < m; ++e) {
      const Index q = fill[std::size_t(row_of[e])]++;
      contacts_.stash_wall_index[q] = Index(walls.partner[e]);
      contacts_.stash_wall_element[q] = walls.element.empty() ? 0 : walls.element[e];
      for (std::size_t k = 0; k < EntryStore::kFields; ++k) {
        const std::size_t wd = walls.widths[k];
        std::copy(walls.values[k].begin() + wd * e, walls.values[k].begin() + wd * (e + 1),
                  contacts_.stash_walls[k].begin() + wd * std::size_t(q));
      }
    }
  }
  lists_.finish_restore(list_context());  // the near-wall list now holds the touching walls
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

// ---- grains as boundaries (boundary.hpp) ------------------------------------------------------

void Simulation::save_boundaries(archive::Writer& w) const {
  std::vector<std::int64_t> ids(fixed_.ids.begin(), fixed_.ids.end());
  w.integers("fixed_id", ids);
  w.reals("fixed_velocity", fixed_.v);
  w.reals("fixed_angular_velocity", fixed_.w);
  std::vector<std::int64_t> kind, inside;
  std::vector<double> a, b;
  for (const Outlet& o : outlets_) {
    kind.push_back(o.kind);
    inside.push_back(o.remove_inside ? 1 : 0);
    a.insert(a.end(), o.a.data(), o.a.data() + 3);
    b.insert(b.end(), o.b.data(), o.b.data() + 3);
  }
  w.integers("outlet_kind", kind);
  w.integers("outlet_remove_inside", inside);
  w.reals("outlet_a", a);
  w.reals("outlet_b", b);
  w.integers("removed_id", std::vector<std::int64_t>(removed_.id.begin(), removed_.id.end()));
  w.integers("removed_outlet", std::vector<std::int64_t>(removed_.outlet.begin(), removed_.outlet.end()));
  w.integers("removed_step", std::vector<std::int64_t>(removed_.step.begin(), removed_.step.end()));
  w.reals("removed_time", removed_.time);
  w.reals("removed_position", removed_.position);
  w.reals("removed_velocity", removed_.velocity);
}

void Simulation::restore_boundaries(archive::Reader& r) {
  const std::vector<std::int64_t> ids = r.integers("fixed_id");
  const std::size_t nf = ids.size();
  const std::vector<double> v = r.reals("fixed_velocity", 3 * nf), w = r.reals("fixed_angular_velocity", 3 * nf);
  fixed_ = FixedSpheres();
  ParticleStore& ps = particles_.arrays();
  for (std::size_t k = 0; k < nf; ++k) {
    if (!particles_.has(ids[k]) || (k > 0 && ids[k] <= ids[k - 1]))
      r.fail("fixed sphere " + std::to_string(ids[k]) + ": not a sphere of the scene, or not in increasing order");
    for (int c = 0; c < 3; ++c)
      if (!std::isfinite(v[3 * k + c]) || !std::isfinite(w[3 * k + c]))
        r.fail("fixed sphere " + std::to_string(ids[k]) + ": a motion that is not finite");
    fixed_.ids.push_back(ids[k]);
    const std::size_t i = static_cast<std::size_t>(particles_.index(ids[k]));
    ps.inv_mass[i] = 0;
    ps.inv_inertia[i] = 0;
  }
  fixed_.v = v;
  fixed_.w = w;
  if (nf > 0 && lists_.built(particles_.size())) lists_.cache_terms(list_context());
  const std::vector<std::int64_t> kind = r.integers("outlet_kind");
  const std::size_t no = kind.size();
  const std::vector<std::int64_t> inside = r.integers("outlet_remove_inside", no);
  const std::vector<double> a = r.reals("outlet_a", 3 * no), b = r.reals("outlet_b", 3 * no);
  outlets_.clear();
  for (std::size_t k = 0; k < no; ++k) {
    Outlet o;
    if (kind[k] != Outlet::PlaneOutlet && kind[k] != Outlet::BoxOutlet)
      r.fail("outlet " + std::to_string(k) + " of unknown kind " + std::to_string(kind[k]));
    o.kind = static_cast<int>(kind[k]);
    o.remove_inside = inside[k] != 0;
    o.a = Vec3(a[3 * k], a[3 * k + 1], a[3 * k + 2]);
    o.b = Vec3(b[3 * k], b[3 * k + 1], b[3 * k + 2]);
    if (!o.a.allFinite() || !o.b.allFinite()) r.fail("outlet " + std::to_string(k) + " is not finite");
    outlets_.push_back(o);
  }
  const std::vector<std::int64_t> id = r.integers("removed_id");
  const std::size_t nr = id.size();
  const std::vector<std::int64_t> by = r.integers("removed_outlet", nr), step = r.integers("removed_step", nr);
  removed_ = RemovalLog();
  removed_.id.assign(id.begin(), id.end());
  removed_.outlet.assign(by.begin(), by.end());
  removed_.step.assign(step.begin(), step.end());
  removed_.time = r.reals("removed_time", nr);
  removed_.position = r.reals("removed_position", 3 * nr);
  removed_.velocity = r.reals("removed_velocity", 3 * nr);
}

// ---- the parts' sections ------------------------------------------------------------------------

namespace {

// A material's or a pair's fields, by name, in the order of their declarations
// (for_each_declared_field): reals, and the choices as the indices of their names.
template <class C>
void save_fields(archive::Writer& w, const C& c) {
  for_each_declared_field<C>([&](const OptionDeclaration& d, auto member) {
    if constexpr (std::is_enum_v<member_type<decltype(member)>>)
      w.integer(d.name, static_cast<int>(c.*member));
    else
      w.real(d.name, c.*member);
  });
}

template <class C>
void restore_fields(archive::Reader& r, C& c) {
  for_each_declared_field<C>([&](const OptionDeclaration& d, auto member) {
    using T = member_type<decltype(member)>;
    if constexpr (std::is_enum_v<T>) {
      const std::int64_t k = r.integer(d.name);
      if (k < 0 || k >= static_cast<std::int64_t>(choice_count(d.choices)))
        r.fail(std::string(d.name) + ": no choice " + std::to_string(k));
      c.*member = static_cast<T>(k);
    } else {
      c.*member = r.real(d.name);
    }
  });
}

}  // namespace

void save(archive::Writer& w, const Material& m) { save_fields(w, m); }
void restore(archive::Reader& r, Material& m) { restore_fields(r, m); }
void save(archive::Writer& w, const PairParams& p) { save_fields(w, p); }
void restore(archive::Reader& r, PairParams& p) { restore_fields(r, p); }

void Simulation::RunState::save(archive::Writer& w) const {
  w.integer("step", step);
  w.real("time", time);
  w.integer("ran", ran);
  w.real("speed_fixed", speed_fixed);
  const Energy& e = energy_ref;
  w.reals("energy_ref", {e.translational, e.rotational, e.gravitational, e.elastic, e.dissipated,
                         e.step_correction});
  w.integer("energy_ref_valid", energy_ref_valid);
  w.integer("energy_ref_step", energy_ref_step);
  w.vec3("energy_ref_gravity", energy_ref_gravity);
  if (!unchecked.empty() || unchecked_walls > 0) {  // (optional: most checkpoints have none)
    w.integers("unchecked", std::vector<std::int64_t>(unchecked.begin(), unchecked.end()));
    w.reals("unchecked_from", unchecked_from);
    w.integer("unchecked_walls", unchecked_walls);
  }
}

void Simulation::RunState::restore(archive::Reader& r) {
  step = static_cast<long>(r.integer("step"));
  time = r.real("time");
  ran = r.integer("ran") != 0;
  speed_fixed = r.real("speed_fixed");
  const std::vector<double> e = r.reals("energy_ref", 6);
  energy_ref = {e[0], e[1], e[2], e[3], e[4], e[5]};
  energy_ref_valid = r.integer("energy_ref_valid") != 0;
  energy_ref_step = static_cast<long>(r.integer("energy_ref_step"));
  energy_ref_gravity = r.vec3("energy_ref_gravity");
  if (r.next_is("unchecked")) {
    const std::vector<std::int64_t> ids = r.integers("unchecked");
    unchecked.assign(ids.begin(), ids.end());
    unchecked_from = r.reals("unchecked_from", 3 * ids.size());
    const std::int64_t walls = r.integer("unchecked_walls");
    if (walls < 0 || walls > (1 << 30)) r.fail("unchecked_walls: " + std::to_string(walls));
    unchecked_walls = static_cast<int>(walls);
  }
}

void Simulation::ContactState::save(archive::Writer& w) const {
  w.integers("owner", std::vector<std::int64_t>(owner.begin(), owner.end()));
  w.integers("partner", std::vector<std::int64_t>(partner.begin(), partner.end()));
  w.integers("widths", std::vector<std::int64_t>(widths.begin(), widths.end()));
  for (std::size_t k = 0; k < EntryStore::kFields; ++k) w.reals("values" + std::to_string(k), values[k]);
}

void Simulation::ContactState::restore(archive::Reader& r) {
  const std::vector<std::int64_t> o = r.integers("owner");
  const std::vector<std::int64_t> p = r.integers("partner", o.size());
  const std::vector<std::int64_t> wd = r.integers("widths", EntryStore::kFields);
  owner.assign(o.begin(), o.end());
  partner.assign(p.begin(), p.end());
  for (std::size_t k = 0; k < EntryStore::kFields; ++k) {
    if (wd[k] < 0 || wd[k] > 64) r.fail("contact array " + std::to_string(k) + ": a width of " + std::to_string(wd[k]));
    widths[k] = static_cast<int>(wd[k]);
    values[k] = r.reals("values" + std::to_string(k), o.size() * static_cast<std::size_t>(wd[k]));
  }
}

// ---- the whole scene -------------------------------------------------------------------------

namespace {

void put_le(std::ostream& out, std::uint64_t v, int bytes) {
  char b[8];
  for (int k = 0; k < bytes; ++k) b[k] = static_cast<char>((v >> (8 * k)) & 0xff);
  out.write(b, bytes);
}

std::uint64_t get_le(const std::string& s, std::size_t at, int bytes) {
  std::uint64_t v = 0;
  for (int k = 0; k < bytes; ++k) v |= std::uint64_t(static_cast<unsigned char>(s[at + k])) << (8 * k);
  return v;
}

constexpr std::size_t kMagicSize = 8, kHeaderSize = kMagicSize + 4 + 8;

}  // namespace

void Simulation::save(std::ostream& out) const {
  archive::Writer body;
  auto section = [&](const char* name, auto&& write) {
    archive::Writer w;
    write(w);
    body.section(name, w);
  };
  section("options", [&](archive::Writer& w) { opt_.save(w); });
  section("materials", [&](archive::Writer& w) {
    w.integer("count", material_count());
    for (const Material& m : materials_) {
      archive::Writer one;
      tsubu::save(one, m);
      w.section("material", one);
    }
  });
  section("pair_overrides", [&](archive::Writer& w) {
    w.integer("count", static_cast<std::int64_t>(overrides_.size()));
    for (std::size_t k = 0; k < overrides_.size(); ++k) {
      w.integers("materials", {overrides_key_[k][0], overrides_key_[k][1]});
      archive::Writer one;
      tsubu::save(one, overrides_[k]);
      w.section("parameters", one);
    }
  });
  section("particles", [&](archive::Writer& w) { particles_.save(w); });
  section("walls", [&](archive::Writer& w) { walls_.save(w); });
  if (domain_.periodic()) section("periodic", [&](archive::Writer& w) { save_periodic(w); });  // (optional)
  section("pair_contacts", [&](archive::Writer& w) { contact_state(false).save(w); });
  section("wall_contacts", [&](archive::Writer& w) {
    const ContactState c = contact_state(true);
    c.save(w);
    // The element of each wall contact (a plane has one: 0; a mesh, a triangle).
    w.integers("element", std::vector<std::int64_t>(c.element.begin(), c.element.end()));
  });
  section("run", [&](archive::Writer& w) { run_state().save(w); });
  // (Optional: written only for a scene with fixed spheres, outlets or removed spheres, so that
  // other scenes' checkpoints are the bytes they were.)
  if (!fixed_.empty() || !outlets_.empty() || removed_.size() > 0)
    section("boundaries", [&](archive::Writer& w) { save_boundaries(w); });
  out.write(kCheckpointMagic, kMagicSize);
  put_le(out, kCheckpointVersion, 4);
  put_le(out, body.data().size(), 8);
  out.write(body.data().data(), static_cast<std::streamsize>(body.data().size()));
  if (!out) throw std::runtime_error("checkpoint: the stream could not be written");
}

Simulation Simulation::load(std::istream& in) {
  const std::string data((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  auto refuse = [](const std::string& what) { throw InvalidArgument("checkpoint: " + what); };
  if (data.size() < kMagicSize || data.compare(0, kMagicSize, kCheckpointMagic, kMagicSize) != 0) {
    if (data.size() < kMagicSize && std::string(kCheckpointMagic, kMagicSize).compare(0, data.size(), data) == 0)
      refuse("truncated: " + std::to_string(data.size()) + " bytes, shorter than the header");
    refuse("not a tsubu checkpoint (the stream does not start with its signature)");
  }
  if (data.size() < kHeaderSize)
    refuse("truncated: " + std::to_string(data.size()) + " bytes, shorter than the header");
  const std::uint64_t version = get_le(data, kMagicSize, 4), length = get_le(data, kMagicSize + 4, 8);
  if (version > kCheckpointVersion)
    refuse("format version " + std::to_string(version) + " was written by a newer tsubu; this one reads " +
           std::to_string(kCheckpointVersion));
  if (version != kCheckpointVersion)
    refuse("format version " + std::to_string(version) + " is not read by the C++ core (format 1 "
           "files are read by tsubu's Python layer)");
  if (data.size() - kHeaderSize != length)
    refuse(std::string(data.size() - kHeaderSize < length ? "truncated" : "extended") + ": the header says " +
           std::to_string(length) + " bytes of data, the stream has " + std::to_string(data.size() - kHeaderSize));
  const std::string body = data.substr(kHeaderSize);
  archive::Reader top(body);

  archive::Reader options = top.section("options");
  Options opt;
  opt.restore(options);
  options.finish();
  Simulation s(opt);

  archive::Reader materials = top.section("materials");
  const std::int64_t nm = materials.integer("count");
  if (nm < 0 || nm > (1 << 20)) materials.fail("a material count of " + std::to_string(nm));
  for (std::int64_t k = 0; k < nm; ++k) {
    archive::Reader one = materials.section("material");
    Material m;
    restore(one, m);
    one.finish();
    s.add_material(m);
  }
  materials.finish();

  archive::Reader pairs = top.section("pair_overrides");
  const std::int64_t np = pairs.integer("count");
  if (np < 0 || np > nm * nm) pairs.fail("a pair override count of " + std::to_string(np));
  for (std::int64_t k = 0; k < np; ++k) {
    const std::vector<std::int64_t> ab = pairs.integers("materials", 2);
    if (ab[0] < 0 || ab[0] >= nm || ab[1] < 0 || ab[1] >= nm) pairs.fail("an override names no material");
    archive::Reader one = pairs.section("parameters");
    PairParams p;
    restore(one, p);
    one.finish();
    s.set_pair_parameters(static_cast<int>(ab[0]), static_cast<int>(ab[1]), p);
  }
  pairs.finish();

  archive::Reader particles = top.section("particles");
  s.particles_.restore(particles, s.materials_);
  particles.finish();

  archive::Reader walls = top.section("walls");
  s.walls_.restore(walls, s.material_count());
  walls.finish();

  double moved[3] = {0, 0, 0};
  const bool periodic = top.next_is("periodic");
  if (periodic) {
    archive::Reader b = top.section("periodic");
    s.restore_periodic(b);
    moved[0] = b.real("moved");
    moved[1] = b.real("moved_near");
    moved[2] = b.real("skin");
    const std::vector<std::int64_t> servo = b.integers("servo", 2);
    const std::vector<double> values = b.reals("servo_values", 3);
    if (servo[0]) s.set_pressure(values[0], static_cast<int>(servo[1]), values[1], values[2]);
    b.finish();
  }

  ContactState contacts[2];
  const char* names[2] = {"pair_contacts", "wall_contacts"};
  for (int w = 0; w < 2; ++w) {
    archive::Reader r = top.section(names[w]);
    contacts[w].restore(r);
    if (w == 1) {
      const std::vector<std::int64_t> element = r.integers("element", contacts[w].owner.size());
      for (std::size_t k = 0; k < element.size(); ++k) {
        const std::int64_t wall = contacts[w].partner[k];
        const bool mesh = wall >= 0 && wall < s.plane_count() && s.walls_.kind(int(wall)) == Walls::kMesh;
        const std::int64_t most = mesh ? s.walls_.mesh(int(wall)).triangles() : 1;
        if (element[k] < 0 || element[k] >= most)
          r.fail("a contact with wall " + std::to_string(wall) + "'s element " + std::to_string(element[k]) +
                 " (it has " + std::to_string(most) + ")");
        contacts[w].element.push_back(static_cast<Index>(element[k]));
      }
    }
    r.finish();
  }
  s.set_contact_state(contacts[0], contacts[1], !periodic);

  archive::Reader run = top.section("run");
  RunState state;
  state.restore(run);
  run.finish();
  s.set_run_state(state);
  if (periodic) {  // lists as the saved run's (its skin), falling due when its would have
    s.lists_.rebuild(s.list_context(), moved[2], true, false);
    s.lists_.moved = moved[0];
    s.lists_.moved_near = moved[1];
  }
  if (top.next_is("boundaries")) {
    archive::Reader b = top.section("boundaries");
    s.restore_boundaries(b);
    b.finish();
  }
  top.finish();
  return s;
}

}  // namespace tsubu
