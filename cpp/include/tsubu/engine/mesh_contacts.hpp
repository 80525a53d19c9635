// Scenes with a mesh wall: before a thread evaluates its part of the near-wall entries, each
// sphere's entries are measured together (Walls::measure: the tangent plane of each triangle's
// nearest point, and the hidden ones), and a contact that slides from one triangle onto a
// neighbour keeps its state: where an entry of a mesh starts touching while an adjacent
// triangle's entry of the same sphere stops, the stopping entry's history, forces and touch move
// to the starting one, and nothing is booked as lost. On a flat surface of many triangles a
// sphere then has one contact whose spring crosses the triangles' edges whole
// (docs/geometry.md, "Contact with triangles").
#pragma once
#include <algorithm>
#include <cstdint>
#include <vector>

#include "contact.hpp"

namespace tsubu::detail {

template <class Law>
struct MeshContacts {
  using F = Features<Law>;
  using C = Contacts<Law>;

  // A contact hands its state over only to a triangle whose normal turned by less than this
  // (cos 60 degrees): a sphere rolling over a ridge, not one that jumps to another face.
  static constexpr double kHandOver = 0.5;
  static constexpr double kSamePlane = 1 - 1e-6;

  // The near-wall positions [lo, hi) of the list (whole spheres).
  static void measure(const ContactView& c, Index lo, Index hi) {
    // (A sphere near a wall seldom has the next sphere in the array as neighbour: each
    // position's entry data is requested a few positions ahead, or each read would wait.)
    for (Index p = lo; p < std::min(hi, lo + kAhead); ++p) prefetch(c, c.wnear[p]);
    for (Index p = lo; p < hi;) {
      const Index i = c.wown[c.wnear[p]];
      Index q = p + 1;
      while (q < hi && c.wown[c.wnear[q]] == i) ++q;
      for (Index a = p + kAhead; a < std::min(hi, q + kAhead); ++a) prefetch(c, c.wnear[a]);
      const Vec3 x = vec3(c.x, i);
      if (c.sheets.of) measure_sheets(c, x, c.r[i], p, q);
      else measure_entries(c, x, c.r[i], c.wnear + p, int(q - p));
      p = q;
    }
  }

  static constexpr Index kAhead = 24;
  static void prefetch(const ContactView& c, Index e) {
    const char* t = reinterpret_cast<const char*>(c.tangent + e);
    request(t);
    request(t + sizeof(Wall) - 1);
    if (c.clear) request(c.clear + e);
    request(c.wtouch + e);
    if constexpr (F::kHistory) request(c.wxi + Law::history_width * e);
    if constexpr (C::kWallMoment) request(c.wnxft + 3 * e);
    request(c.wforce + 3 * e);
    request(c.woverlap + e);
  }

  // One sphere's entries[0, n), all of its entries of each wall among them.
  static void measure_entries(const ContactView& c, const Vec3& x, double r, const Index* entries, int n) {
    c.meshes->measure(x, r, c.wall, c.welement, entries, n, c.tangent, c.wtouch, c.clear);
    hand_over(c, x, r, entries, n);
  }

  // One sphere's positions [lo, hi), some of them flat sheets (NeighborList::wall_sheet): the
  // others measured as ever; a sheet by its holder's triangle alone while the sphere lies over
  // that face (nothing else of the sheet can then touch it), else entry by entry, as if they
  // stood in the list, after which the position takes the entry that holds the contact.
  static void measure_sheets(const ContactView& c, const Vec3& x, double r, Index lo, Index hi) {
    Index sheets = 0;
    for (Index a = lo; a < hi; ++a) sheets += c.sheets.of[a] >= 0 ? 1 : 0;
    if (sheets == 0) {
      measure_entries(c, x, r, c.wnear + lo, int(hi - lo));
      return;
    }
    if (sheets < hi - lo) {
      thread_local std::vector<Index> plain;
      plain.clear();
      for (Index a = lo; a < hi; ++a)
        if (c.sheets.of[a] < 0) plain.push_back(c.wnear[a]);
      measure_entries(c, x, r, plain.data(), int(plain.size()));
    }
    for (Index a = lo; a < hi; ++a) {
      const Index k = c.sheets.of[a], e = c.wnear[a];
      if (k < 0) continue;
      // Still over the face it was over, on the same side: its tangent plane and record stand.
      double* room = c.sheets.room + 4 * k;
      if ((x - Eigen::Map<const Vec3>(room)).squaredNorm() < room[3] && c.tangent[e].distance(x) > 0) continue;
      if (c.meshes->measure_face(x, r, c.wall[e], c.welement[e], e, c.tangent, c.wtouch, c.clear)) {
        const double reach = c.meshes->mesh(c.wall[e]).face_room(x, c.welement[e]);
        room[0] = x.x(), room[1] = x.y(), room[2] = x.z(), room[3] = reach > 0 ? reach * reach : -1.0;
        continue;
      }
      room[3] = -1;
      const Index* entries = c.sheets.entry + c.sheets.offset[k];
      const int n = int(c.sheets.offset[k + 1] - c.sheets.offset[k]);
      measure_entries(c, x, r, entries, n);
      // Of a flat sheet at most one entry is touched or pressed (one face, or an edge or corner
      // that no face hides); it holds the contact, else the triangle under the sphere does.
      const Mesh& mesh = c.meshes->mesh(c.wall[e]);
      Index holder = -1;
      for (int b = 0; b < n && holder < 0; ++b)
        if (c.wtouch[entries[b]] || c.tangent[entries[b]].overlap(x, r) > 0) holder = entries[b];
      for (int b = 0; b < n && holder < 0; ++b)
        if (mesh.over_face(x, c.welement[entries[b]])) holder = entries[b];
      if (holder < 0 || holder == e) continue;
      c.wnear[a] = holder;
      if (c.sheets.slot[k] >= 0) {
        std::uint32_t& u = c.sheets.sum_entry[c.sheets.slot[k]];
        u = (std::uint32_t(holder) << 3) | (u & 7u);
      }
    }
  }

  static void hand_over(const ContactView& c, const Vec3& x, double r, const Index* entries, int n) {
    // An entry stops when it no longer presses (a sticky law: when hidden, which puts it clear
    // of the sphere by more than r).
    const double stopped = Law::kSticky ? -r : 0.0;
    for (int a = 0; a < n; ++a) {
      const Index e = entries[a];
      const Index w = c.wall[e];
      if (c.wtouch[e] || c.meshes->kind(w) != Walls::kMesh || !(c.tangent[e].overlap(x, r) > 0)) continue;
      const Mesh& mesh = c.meshes->mesh(w);
      Index from = -1;
      double best = kHandOver;
      for (int b = 0; b < n; ++b) {
        const Index o = entries[b];
        if (o == e || c.wall[o] != w || !c.wtouch[o] || c.tangent[o].overlap(x, r) > stopped) continue;
        const double turn = c.tangent[o].normal.dot(c.tangent[e].normal);
        // (a triangle that shares no vertex, on the same plane: a step across a sliver)
        if (turn > best && (turn > kSamePlane || mesh.adjacent(c.welement[o], c.welement[e]))) best = turn, from = o;
      }
      if (from >= 0) move(c, from, e);
    }
  }

  // Moves entry `from`'s contact state to entry `to` and clears `from`.
  static void move(const ContactView& c, Index from, Index to) {
    auto carry = [&](double* a, int width) {
      std::copy(a + width * from, a + width * (from + 1), a + width * to);
      std::fill(a + width * from, a + width * (from + 1), 0.0);
    };
    if constexpr (F::kHistory) carry(c.wxi, Law::history_width);
    carry(c.wforce, 3);
    if constexpr (C::kWallMoment) carry(c.wnxft, 3);
    if constexpr (F::kRolling) carry(c.wroll, 3);
    if constexpr (F::kRough) carry(c.wrough, F::kRoughWidth);
    carry(c.woverlap, 1);
    c.wtouch[to] = c.wtouch[from];
    c.wtouch[from] = 0;
  }
};

}  // namespace tsubu::detail
