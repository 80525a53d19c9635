// Tests of a mesh wall's geometry (cpp/src/mesh.cpp, cpp/src/walls.cpp): the nearest point of a
// triangle in each of its seven Voronoi regions, the bins against a brute-force search, a moved
// mesh against the same mesh given where it went, and which contacts Walls::measure hides.
#include <algorithm>
#include <cmath>
#include <random>
#include <vector>

#include "check.hpp"
#include "tsubu/walls/walls.hpp"

using namespace tsubu;

namespace {

bool close(const Vec3& a, const Vec3& b, double tol = 1e-12) { return (a - b).norm() <= tol; }

// One triangle (0,0,0), (1,0,0), (0,1,0), normal +z.
Mesh one_triangle() {
  return Mesh({Vec3(0, 0, 0), Vec3(1, 0, 0), Vec3(0, 1, 0)}, {Mesh::Face{0, 1, 2}}, Vec3(0, 0, 0));
}

void nearest_points_by_region() {
  const Mesh m = one_triangle();
  // Face: straight above (and below: both sides push, the normal turns to the centre's side).
  MeshPoint p = m.nearest(Vec3(0.2, 0.3, 0.5), 0);
  CHECK(p.feature.kind == MeshFeature::kFace && std::abs(p.distance - 0.5) < 1e-15);
  CHECK(close(p.normal, Vec3(0, 0, 1)));
  p = m.nearest(Vec3(0.2, 0.3, -0.25), 0);
  CHECK(p.feature.kind == MeshFeature::kFace && close(p.normal, Vec3(0, 0, -1)) && std::abs(p.distance - 0.25) < 1e-15);
  // Edges: beyond each side, the foot of the perpendicular on the edge.
  p = m.nearest(Vec3(0.5, -1, 0), 0);
  CHECK(p.feature.kind == MeshFeature::kEdge && p.feature.a == 0 && p.feature.b == 1);
  CHECK(close(p.point, Vec3(0.5, 0, 0)) && close(p.normal, Vec3(0, -1, 0)) && std::abs(p.distance - 1) < 1e-15);
  p = m.nearest(Vec3(-2, 0.5, 0), 0);
  CHECK(p.feature.kind == MeshFeature::kEdge && p.feature.a == 0 && p.feature.b == 2 && close(p.point, Vec3(0, 0.5, 0)));
  p = m.nearest(Vec3(1, 1, 0), 0);  // beyond the hypotenuse
  CHECK(p.feature.kind == MeshFeature::kEdge && p.feature.a == 1 && p.feature.b == 2 && close(p.point, Vec3(0.5, 0.5, 0)));
  CHECK(std::abs(p.distance - std::sqrt(0.5)) < 1e-15);
  // Vertices.
  p = m.nearest(Vec3(-1, -1, 1), 0);
  CHECK(p.feature.kind == MeshFeature::kVertex && p.feature.a == 0 && close(p.point, Vec3(0, 0, 0)));
  p = m.nearest(Vec3(2, -0.5, 0), 0);
  CHECK(p.feature.kind == MeshFeature::kVertex && p.feature.a == 1);
  p = m.nearest(Vec3(-0.5, 2, 0), 0);
  CHECK(p.feature.kind == MeshFeature::kVertex && p.feature.a == 2);
}

// A bumpy square of many triangles: the bins find exactly the triangles a brute-force search
// finds, in increasing order.
void bins_match_brute_force() {
  const int n = 20;
  std::vector<Vec3> v;
  std::vector<Mesh::Face> f;
  std::mt19937_64 rng(3);
  std::uniform_real_distribution<double> bump(-0.02, 0.02);
  for (int i = 0; i <= n; ++i)
    for (int j = 0; j <= n; ++j) v.emplace_back(double(i) / n, double(j) / n, bump(rng));
  for (int i = 0; i < n; ++i)
    for (int j = 0; j < n; ++j) {
      const Index a = i * (n + 1) + j, b = a + 1, c = a + n + 1, d = c + 1;
      f.push_back({a, c, b});
      f.push_back({b, c, d});
    }
  const Mesh m(v, f, Vec3(0.5, 0.5, 0));
  std::uniform_real_distribution<double> where(-0.2, 1.2);
  int mismatches = 0;
  for (int k = 0; k < 300; ++k) {
    const Vec3 x(where(rng), where(rng), 0.1 * where(rng));
    const double r = 0.03, reach = 0.01;
    std::vector<Index> found, brute;
    m.for_each_near(x, r, reach, [&](Index t) { found.push_back(t); });
    for (Index t = 0; t < m.triangles(); ++t)
      if (m.distance(x, t) < r + reach) brute.push_back(t);
    if (found != brute) ++mismatches;
  }
  CHECK(mismatches == 0);
}

// A mesh moved by rigid motion answers as the same mesh built where it went.
void moved_mesh_matches_its_copy() {
  Mesh m = one_triangle();
  const Vec3 v(0.3, -0.1, 0.2), w(0.5, 1.0, -2.0);
  for (int k = 0; k < 100; ++k) m.advance(0.01, v, w);
  const std::vector<Vec3> there = m.world_vertices();
  const Mesh copy(there, {Mesh::Face{0, 1, 2}}, m.center());
  const Vec3 x(0.7, 0.4, 0.9);
  const MeshPoint a = m.nearest(x, 0), b = copy.nearest(x, 0);
  CHECK(a.feature == b.feature);
  CHECK(std::abs(a.distance - b.distance) < 1e-12 && close(a.normal, b.normal, 1e-12));
  // Its centre moved with the velocity; a vertex at distance d from it turned with w.
  CHECK(close(m.center(), Vec3(0.3, -0.1, 0.2), 1e-12));
}

// Two coplanar triangles sharing an edge, and a roof: which contacts Walls::measure keeps.
void hidden_contacts() {
  Walls walls;
  Plane motion;
  // A flat square of two triangles (shared edge 1-2) at z = 0.
  walls.add_mesh(Mesh({Vec3(0, 0, 0), Vec3(1, 0, 0), Vec3(0, 1, 0), Vec3(1, 1, 0)},
                      {Mesh::Face{0, 1, 2}, Mesh::Face{1, 3, 2}}, Vec3(0.5, 0.5, 0)),
                 motion);
  // A roof: two faces meeting at the ridge x = 0 (z = 0), sloping down to z = -0.5 at x = +-1.
  walls.add_mesh(Mesh({Vec3(0, 0, 5), Vec3(0, 1, 5), Vec3(-1, 0, 4.5), Vec3(-1, 1, 4.5), Vec3(1, 0, 4.5),
                       Vec3(1, 1, 4.5)},
                      {Mesh::Face{0, 2, 1}, Mesh::Face{1, 2, 3}, Mesh::Face{0, 1, 4}, Mesh::Face{1, 5, 4}},
                      Vec3(0, 0.5, 4.75)),
                 motion);
  const std::vector<Index> wall = {0, 0, 1, 1, 1, 1}, element = {0, 1, 0, 1, 2, 3};
  auto touching = [&](const Vec3& x, double r, Index first, int count) {
    std::vector<Index> entries;
    for (int k = 0; k < count; ++k) entries.push_back(first + k);
    std::vector<Plane> tangent(wall.size());
    walls.measure(x, r, wall.data(), element.data(), entries.data(), count, tangent.data());
    std::vector<Index> out;
    for (Index e : entries)
      if (tangent[std::size_t(e)].overlap(x, r) > 0) out.push_back(e);
    return std::pair(out, tangent);
  };
  // Over triangle 0 near the shared edge: one contact, the face, with the plane's overlap.
  auto [flat, tf] = touching(Vec3(0.45, 0.5, 0.09), 0.1, 0, 2);
  CHECK(flat.size() == 1 && flat[0] == 0 && std::abs(tf[0].overlap(Vec3(0.45, 0.5, 0.09), 0.1) - 0.01) < 1e-15);
  // Exactly over the shared edge: still one contact.
  auto [edge, te] = touching(Vec3(0.5, 0.5, 0.09), 0.1, 0, 2);
  CHECK(edge.size() == 1);
  // On the ridge: one contact (of four triangles touching), along the vertical.
  const Vec3 top(0, 0.5, 5.09);
  auto [ridge, tr] = touching(top, 0.1, 2, 4);
  CHECK(ridge.size() == 1 && close(tr[std::size_t(ridge[0])].normal, Vec3(0, 0, 1), 1e-15));
}

}  // namespace

int main() {
  nearest_points_by_region();
  bins_match_brute_force();
  moved_mesh_matches_its_copy();
  hidden_contacts();
  return tsubu_test::finish("test_mesh");
}
