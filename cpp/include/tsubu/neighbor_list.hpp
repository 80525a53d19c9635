// The two-level neighbour list (docs/architecture.md), built with linked cells and a skin.
//
// The Verlet list holds every pair within r_i + r_j + skin, each once, owned by the lower id, an
// owner's partners sorted by id. The near list, refreshed from it when particles may have moved
// by half its reach (skin/10 to skin/2, near_fraction), holds the pairs within r_i + r_j + reach,
// each entry with its contact state (ContactStore); the step loop touches only it. Its entries
// keep the owner order and the partner-id order of the Verlet list, and a reverse index sorted
// by owner id lets every particle sum its contacts in an order fixed by ids: bit-identical
// results for any thread count, any rebuild schedule and any reach. The near-wall list holds
// the (sphere, wall, element) entries within r + skin of a wall, by sphere. A rebuild re-sorts
// the particles by cell.
#pragma once
#include <algorithm>
#include <array>
#include <cstdint>
#include <string>
#include <utility>
#include <vector>

#include "contact_store.hpp"
#include "domain.hpp"
#include "material.hpp"
#include "memory.hpp"
#include "particles.hpp"
#include "registry.hpp"
#include "types.hpp"
#include "walls/walls.hpp"

namespace tsubu {

class NeighborList {
 public:
  // What a rebuild or refresh reads and writes besides the lists.
  struct Context {
    Particles& particles;
    Walls& walls;  // (a rebuild marks their positions for its criterion)
    Domain& domain;  // (a rebuild wraps a periodic box's spheres and makes its ghosts)
    ContactStore& contacts;
    const CompiledLaw& law;  // the entries' terms; the energy of a spring that opens
    bool law_chosen;         // false: no run has chosen the law yet (the contact shapes are unset)
    const PairTable& pairs;
    int threads;    // threads for the parallel loops
    bool parallel;  // whether to use them (a scene of options.parallel_min spheres or more)
    bool sheets = true;  // whether flat sheets of mesh triangles may stand as one entry (wall_sheet)
  };

  // ---- the lists (read by the engine's views) ---------------------------------------------
  Array<Index> pair_offset, pair_partner;  // Verlet list: rows by owner (internal index)
  Array<Index> near_offset, near_owner, near_partner, near_rev_offset, near_rev;
  Array<double> near_cut2;  // (r_i + r_j)^2 of entry q at q & cut_mask
  // The law's terms of each near pair (ContactLaw::entry_terms, CompiledLaw::entry_width per
  // entry: for the linear law the dashpot itself; for Hertz sqrt(R*) and the dashpot's mass
  // term), fixed while the pair is in the list: square roots saved per contact and step. Entry
  // q's are at width * (q & entry_mask).
  Array<double> near_entry;
  // 0 where one value serves every entry, else all ones: cut_mask where every sphere held has
  // one radius, entry_mask where they also have one mass, material and mobility (fixed or not).
  // Then the arrays hold that one value, and the step streams 8 + 8 width bytes less per entry
  // (lockstep: the monodisperse hopper 3 % faster, the 1e5 drop and the sheared bed 2 %).
  Index cut_mask = ~Index(0), entry_mask = ~Index(0);
  // The walls' two levels, as the pairs': the reach list, the (wall, element) keys within
  // r + skin of each sphere, rows by sphere (built at a rebuild, keys only); and the near-wall
  // list, its entries within r + the reach (all of them if a wall moves, and every touching one),
  // rows by sphere in the reach list's order, refreshed with the near list. The near-wall
  // entries hold the wall contact state (ContactStore::walls, wall_tangent, wall_clear), so
  // that a step finds a sphere's few entries side by side, not scattered among the tens of
  // triangles a fine mesh puts within its reach. wall_near: the positions the step reads,
  // entry indices by sphere (every entry, but where flat sheets fold several into one).
  Array<Index> wall_reach_offset, wall_reach_index, wall_reach_element;
  Array<Index> wall_offset, wall_index, wall_element, wall_owner, wall_near_offset, wall_near;
  // Particles with near-pair or near-wall entries: the only ones whose contacts can be summed;
  // and, per step, 1 for those with an entry in contact (set by the contact pass, cleared by
  // the particle pass).
  Array<Index> busy;
  Array<std::uint8_t> loaded;
  // Every busy particle's entries in the order its sums take them (ContactSums::at), flat, so
  // the particle pass of a dense scene sums them in one loop without a branch per particle:
  // (entry << 3) | (first of its particle << 2) | kind (0 owned pair, 1 reverse pair, 2 wall);
  // sum_offset[b] is busy particle b's first. Empty if an entry index does not fit.
  Array<std::uint32_t> sum_entry;
  Array<Index> sum_offset;
  // For the fused pass (engine/fused_pass.hpp): how far down and up the particle array a near
  // pair's partner lies from its owner (index distances, at most), and the most entries one
  // particle sums.
  Index reach_below = 0, reach_above = 0, max_entries = 0;
  Array<Index> active;  // scratch of the contact pass: the near-wall entries in contact
  // Scenes with a mesh: each near-wall entry's tangent plane this step (Walls::measure), written
  // by the contact pass; empty otherwise.
  std::vector<Plane> wall_tangent;
  // Scenes with a mesh: how far each near-wall entry was found clear of its sphere, and where
  // (Walls::measure skips it while the sphere stays near there); reset by every rebuild and run
  // start (reset_clearance), carried through refreshes and removals by (wall, element).
  std::vector<Walls::Clearance> wall_clear;
  void reset_clearance() {
    wall_clear.assign(wall_tangent.size(), Walls::Clearance{});
    for (std::size_t k = 3; k < sheet_room.size(); k += 4) sheet_room[k] = -1;
  }
  // Scenes with a mesh and no wall moving, under a law that is not sticky: the near triangles of
  // one mesh that form a flat sheet around a sphere (Mesh::flat_sheet) stand in wall_near as one
  // position, the entry of the triangle that holds the contact (or that the sphere lies over).
  // The step measures that triangle alone while the sphere lies over its face, and the whole
  // sheet, as separate entries would be, when it nears an edge; the contact then moves to the
  // triangle that holds it (engine/mesh_contacts.hpp): the same bits as separate entries, one
  // entry's work. wall_sheet[p]: position p's sheet, or -1 (empty: no sheets); sheet k's entries
  // are sheet_entry[sheet_offset[k], sheet_offset[k + 1]), its slot in sum_entry sheet_slot[k]
  // (-1: none). sheet_room[4 k, 4 k + 4): where the sphere stood when its holder's face was last
  // measured, and the square of how far it may move from there with nothing to measure (the
  // face's tangent plane stands as it is: Mesh::face_room); -1 to measure.
  Array<Index> wall_sheet, sheet_offset, sheet_entry, sheet_slot;
  Array<double> sheet_room;

  // ---- bookkeeping ------------------------------------------------------------------------
  // Bounds on the distance any particle moved since the last rebuild and since the last
  // refresh (sums of dt max|v| over the steps).
  double moved = 0, moved_near = 0;
  long near_steps = 0;  // the bookings (steps) since the last refresh
  double skin = 0;  // the skin of the last rebuild
  bool valid = false;  // false: the next run rebuilds first
  long rebuilds = 0, refreshes = 0;

  // Whether the lists exist for n particles (a run built them).
  bool built(std::size_t n) const { return near_offset.size() == n + 1; }
  // The near list's reach beyond contact: a fraction of the skin, at least a tenth (a sticky
  // contact's reach), chosen at each refresh (choose_near_fraction).
  double near_fraction = kNearMin;
  static constexpr double kNearMin = 0.1, kNearMax = 0.5;
  double near_skin() const { return near_fraction * skin; }
  // Whether a rebuild is due: two particles may have closed by the skin, or a wall moved too
  // far; or the lists are invalid, or `every_step` (a testing aid).
  bool needs_rebuild(const Walls& walls, bool every_step) const {
    if (!valid || every_step) return true;
    if (!wall_sheet.empty() && walls.moving()) return true;  // (sheets hold for fixed walls only)
    if (2.0 * moved > skin) return true;
    return walls.moved_beyond(moved, skin);
  }
  bool needs_refresh() const { return 2.0 * moved_near > near_skin(); }
  // Whether the particles may move `step` further without any list falling due.
  bool can_move(double step, bool every_step) const {
    return valid && !every_step && 2.0 * (moved + step) <= skin && 2.0 * (moved_near + step) <= near_skin();
  }
  void book_moved(double distance) {
    moved += distance;
    moved_near += distance;
    ++near_steps;
  }

  // Rebuilds every list with the given skin, re-sorting the particles by cell; with
  // `keep_history`, carries the contact state over by ids (a touching contact whose spheres
  // jumped apart by more than the skin in one step has opened: its spring energy is booked as
  // lost, as the step would have).
  // `wrap` false keeps a periodic box's spheres where they are (a checkpoint's restore: the
  // run it resumes wraps them at its own next rebuild, so that the bits match).
  void rebuild(const Context& c, double skin, bool keep_history, bool wrap = true);
  // Refreshes the near lists from the Verlet and reach lists, carrying the contact state over.
  void refresh(const Context& c);
  // Removes the spheres `gone` (count ids) from the particles and from every list, with their
  // entries, in place: the others keep their order, their entries and their state, and no list
  // falls due (an outlet removes a few spheres a step; a rebuild costs some twenty steps).
  void remove(const Context& c, const Id* gone, std::size_t count);
  // near_entry from the current pair table (after a refresh, or when parameters change).
  void cache_terms(const Context& c);
  // Puts contact state saved by ids (checkpoints) into fresh lists: builds them without
  // carrying anything, and returns; the caller puts the wall contacts in ContactStore's stash
  // (rows by internal index, as stash_near_walls leaves them), then calls finish_restore(),
  // which carries them into the near-wall list, and then fills the pair entries.
  void rebuild_empty(const Context& c, double skin, bool wrap = true);
  // Whether sphere i (internal index) has wall `wall`'s element `element` within its reach.
  bool reaches(Index i, Index wall, Index element) const;
  // How deep the ghosts' layer is: a pair's reach (the cell side h = 2 r_max + skin) beyond
  // spheres that may stand up to skin/2 outside the box (wrapped at the last rebuild).
  static double ghost_margin(double h, double skin) { return h + 0.5 * skin; }
  void finish_restore(const Context& c);

  // The Verlet list's pairs as ids, lower first, sorted.
  std::vector<std::array<Id, 2>> pairs_by_id(const Particles& particles) const;
  // Bytes held, by group: verlet list, near list, walls, scratch (ContactStore's arrays not
  // included).
  std::size_t verlet_bytes() const;
  std::size_t near_bytes() const;
  std::size_t wall_bytes() const;
  std::size_t scratch_bytes() const;

 private:
  // cache_terms, with whether every sphere held has one radius, mass, inverse mass and material.
  void cache_terms(const Context& c, bool one_body);
  // The cell grid of a rebuild (cell_grid.cpp): dense (every cell of the particles' bounding
  // box, cell c = (z dims_y + y) dims_x + x) when that is at most 2 N + 1000 cells, else sparse:
  // only the occupied cells, by their sorted (z, y, x) keys in cell_key_, so that spheres
  // kilometres apart cost memory in proportion to N, not to the volume they span.
  struct CellGrid {
    Vec3 lo = Vec3::Zero(), hi = Vec3::Zero();  // the particles' bounding box
    double h = 1;                                // cell side
    std::array<long, 3> dims{1, 1, 1};
    // A dense grid's cell c has index c . stride: the axis with the most cells varies slowest
    // and the one with the fewest fastest, so that the cells around a particle lie within the
    // smallest cross-section of the box in index order. The particles follow the cells, so the
    // index reach of a pair (the fused pass's window, NeighborList::reach_below/above) and the
    // boundaries between the threads' parts are that cross-section.
    std::array<long, 3> stride{1, 1, 1};
    bool sparse = false;
    long index(const long* c) const { return c[0] * stride[0] + c[1] * stride[1] + c[2] * stride[2]; }
  };
  using CellKey = std::array<std::int64_t, 3>;

  CellGrid plan_grid(const Context& c, double skin) const;
  static CellKey cell_of(const CellGrid& g, const double* x);
  // Bins the particles (cell_of_, cell_start_, perm_) without moving them.
  void bin_by_cell(const Context& c, const CellGrid& g);
  // Throws ResourceError, before the rebuild changes anything, when the Verlet list the grid
  // would give cannot fit in memory (or in its 32-bit indices).
  void check_fits(const Context& c, const CellGrid& g, double skin) const;
  static double bytes_per_pair(const Context& c);
  template <class Visit>
  void for_each_cell_around(const CellGrid& g, const CellKey& key, Visit&& visit) const;

  // A periodic box's ghosts (Domain::make_ghosts), after the owned spheres, sorted by cell,
  // and ghost_cell_start_ (each cell's ghosts, counted from the first ghost row).
  void make_ghosts(const Context& c, const CellGrid& grid);
  void build_verlet(const Context& c, const CellGrid& grid, double skin);
  void build_walls(const Context& c, double skin);
  // Builds the near list from the Verlet list; with `transfer`, carries the stashed pair state
  // over (carry_pairs), with `wall_transfer` the stashed wall state by (sphere, wall, element);
  // `reordered`: the particles were re-sorted since the stash.
  void refresh_near(const Context& c, bool transfer, bool reordered, bool wall_transfer);
  // refresh_near's part: every carried array of the new near list from the stash (rows by old
  // index; keys by Verlet pair after a refresh, by partner id after a rebuild), the touch
  // flags, and the energy of stashed contacts left behind.
  void carry_pairs(const Context& c, bool reordered);
  // The near list's next reach (near_fraction), from what the last one cost: see near_list.cpp.
  void choose_near_fraction();
  // The near-wall list from the reach list (refresh_near's part).
  void refresh_walls(const Context& c, bool transfer, bool reordered);
  // Moves the near-wall list's rows, keys, state and records into the stash.
  void stash_near_walls(const Context& c);
  // Folds the near-wall positions of each sphere's flat sheets into one (wall_sheet).
  void gather_sheets(const Context& c);
  // busy, loaded, the sum entries, max_entries and `active` from the lists' entries.
  void index_entries(const Context& c);
  // sum_entry and sum_offset from the near list, the reverse index and the near-wall list.
  void build_sum_entries(const Context& c);
  // max_entries from the near lists.
  void measure(const Context& c);
  // reach_below and reach_above from the near list (refresh_near finds them as it fills it).
  void measure_reach(const Context& c);
  // The energy a contact loses when it opens (its tangential spring; the engine releases).
  static double spring_energy(const Context& c, int material_a, int material_b,
                              const Array<double>& xi, std::size_t e);

  // The entry map of a removal: each old entry's new index, or -1.
  Array<Index> pair_to_, wall_to_, reach_to_, reach_keep_;
  Array<Index> wall_rows_;  // the spheres with a reach row (build_walls, remove)
  // The near-wall entries' clearance records and the tangent planes they keep while a refresh
  // rebuilds the list (the rest of their state is in ContactStore's stash).
  std::vector<Walls::Clearance> clear_stash_;
  std::vector<Plane> tangent_stash_;
  // Scratch reused by rebuilds (no allocation once warm).
  Array<Index> cell_start_, cell_of_, perm_, old_index_of_, ghost_cell_start_;
  Array<CellKey> cell_key_;
  Array<double> scratch_;
  Array<Index> scratch_int_;
  std::vector<Array<Index>> verlet_parts_;  // build_verlet: the partners of each thread's rows (but the first's)
  std::vector<Array<Index>> verlet_rows_;   // build_verlet: each thread's candidates of one row
  Array<std::uint8_t> near_kept_;  // refresh_near: 1 for each Verlet pair within the reach
  // Each near entry's Verlet pair (kept through removals: a refresh's stash is keyed by it, and
  // carry_pairs merges each row's stash and new entries, both in Verlet-pair order).
  Array<Index> near_verlet_;
  // carry_pairs: each new entry's stashed row (the stash's zero row where none); 1 for each
  // stashed entry carried.
  Array<Index> carry_source_;
  Array<std::uint8_t> carry_taken_;
  // gather_sheets: each position's mark, each sphere's positions, sheets and sheet entries
  // (running sums), and the positions kept.
  Array<Index> sheet_mark_, wall_near_next_;
  std::array<Array<Index>, 3> sheet_rows_;
};

// Calls visit(cell) for each existing cell among the 27 around `key` (itself included), in the
// order of increasing (z, y, x).
template <class Visit>
inline void NeighborList::for_each_cell_around(const CellGrid& g, const CellKey& key, Visit&& visit) const {
  const std::array<long, 3> dims{g.dims[2], g.dims[1], g.dims[0]};  // in key order (z, y, x)
  std::array<std::int64_t, 3> lo_key, hi_key;
  for (int d = 0; d < 3; ++d) {
    lo_key[d] = std::max<std::int64_t>(key[d] - 1, 0);
    hi_key[d] = std::min<std::int64_t>(key[d] + 1, dims[d] - 1);
  }
  for (std::int64_t cz = lo_key[0]; cz <= hi_key[0]; ++cz)
    for (std::int64_t cy = lo_key[1]; cy <= hi_key[1]; ++cy)
      for (std::int64_t cx = lo_key[2]; cx <= hi_key[2]; ++cx) {
        if (!g.sparse) {
          const long c[3] = {long(cx), long(cy), long(cz)};
          visit(g.index(c));
          continue;
        }
        const CellKey q{cz, cy, cx};
        const auto it = std::lower_bound(cell_key_.begin(), cell_key_.end(), q);
        if (it != cell_key_.end() && *it == q) visit(static_cast<long>(it - cell_key_.begin()));
      }
}

}  // namespace tsubu
