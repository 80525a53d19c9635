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
    for (Index p = lo; p < hi;) {
      const Index i = c.wown[c.wnear[p]];
      Index q = p + 1;
      while (q < hi && c.wown[c.wnear[q]] == i) ++q;
      const Vec3 x = vec3(c.x, i);
      c.meshes->measure(x, c.r[i], c.wall, c.welement, c.wnear + p, int(q - p), c.tangent, c.wtouch, c.clear);
      hand_over(c, x, c.r[i], p, q);
      p = q;
    }
  }

  static void hand_over(const ContactView& c, const Vec3& x, double r, Index lo, Index hi) {
    // An entry stops when it no longer presses (a sticky law: when hidden, which puts it clear
    // of the sphere by more than r).
    const double stopped = Law::kSticky ? -r : 0.0;
    for (Index a = lo; a < hi; ++a) {
      const Index e = c.wnear[a];
      const Index w = c.wall[e];
      if (c.wtouch[e] || c.meshes->kind(w) != Walls::kMesh || !(c.tangent[e].overlap(x, r) > 0)) continue;
      const Mesh& mesh = c.meshes->mesh(w);
      Index from = -1;
      double best = kHandOver;
      for (Index b = lo; b < hi; ++b) {
        const Index o = c.wnear[b];
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
