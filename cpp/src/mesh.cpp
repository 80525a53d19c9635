#include "tsubu/walls/mesh.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numeric>
#include <stdexcept>
#include <string>

namespace tsubu {

Mesh::Mesh(std::vector<Vec3> vertices, std::vector<Face> faces, const Vec3& center)
    : body_(std::move(vertices)), faces_(std::move(faces)), center0_(center), center_(center) {
  prepare();
}

void Mesh::prepare() {
  const std::size_t nv = body_.size(), nf = faces_.size();
  // Canonical vertices: equal coordinates, one vertex.
  std::vector<Index> order(nv);
  std::iota(order.begin(), order.end(), Index(0));
  auto less = [&](Index a, Index b) {
    const Vec3 &p = body_[std::size_t(a)], &q = body_[std::size_t(b)];
    if (p.x() != q.x()) return p.x() < q.x();
    if (p.y() != q.y()) return p.y() < q.y();
    if (p.z() != q.z()) return p.z() < q.z();
    return a < b;
  };
  std::sort(order.begin(), order.end(), less);
  canon_.assign(nv, 0);
  for (std::size_t k = 0; k < nv; ++k) {
    const bool same = k > 0 && body_[std::size_t(order[k])] == body_[std::size_t(order[k - 1])];
    canon_[std::size_t(order[k])] = same ? canon_[std::size_t(order[k - 1])] : order[k];
  }
  tri_.resize(nf);
  std::vector<double> extent(nf);
  Vec3 lo = Vec3::Constant(std::numeric_limits<double>::infinity()), hi = -lo;
  for (std::size_t t = 0; t < nf; ++t) {
    const Vec3 &a = body_[std::size_t(faces_[t][0])], &b = body_[std::size_t(faces_[t][1])],
               &c = body_[std::size_t(faces_[t][2])];
    Tri& T = tri_[t];
    T.a = a, T.b = b, T.c = c;
    T.n = (b - a).cross(c - a).normalized();
    T.centroid = (a + b + c) / 3;
    T.round = std::sqrt(std::max({(a - T.centroid).squaredNorm(), (b - T.centroid).squaredNorm(),
                                  (c - T.centroid).squaredNorm()}));
    for (std::size_t j = 0; j < 3; ++j) T.canon[j] = canon_[std::size_t(faces_[t][j])];
    const Vec3 tlo = a.cwiseMin(b).cwiseMin(c), thi = a.cwiseMax(b).cwiseMax(c);
    extent[t] = (thi - tlo).maxCoeff();
    lo = lo.cwiseMin(tlo);
    hi = hi.cwiseMax(thi);
  }
  if (nf == 0) return;
  // Cells about the size of a typical triangle (the median's longest side), at most 2^20 along an
  // axis.
  std::vector<double> sorted = extent;
  std::nth_element(sorted.begin(), sorted.begin() + long(nf / 2), sorted.end());
  const double span = (hi - lo).maxCoeff();
  h_ = std::max({sorted[nf / 2], span * 1e-6, 1e-300});
  lo_ = lo - Vec3::Constant(0.5 * h_);
  for (int d = 0; d < 3; ++d) dims_[std::size_t(d)] = static_cast<long>((hi[d] - lo_[d]) / h_) + 2;
  std::vector<std::pair<std::uint64_t, Index>> cell_tri;
  const double half_diagonal = 0.5 * std::sqrt(3.0) * h_;
  for (std::size_t t = 0; t < nf; ++t) {
    const Vec3 &a = body_[std::size_t(faces_[t][0])], &b = body_[std::size_t(faces_[t][1])],
               &c = body_[std::size_t(faces_[t][2])];
    const Vec3 tlo = a.cwiseMin(b).cwiseMin(c), thi = a.cwiseMax(b).cwiseMax(c);
    long c0[3], c1[3];
    for (int d = 0; d < 3; ++d) {
      c0[d] = std::clamp(static_cast<long>((tlo[d] - lo_[d]) / h_), 0L, dims_[std::size_t(d)] - 1);
      c1[d] = std::clamp(static_cast<long>((thi[d] - lo_[d]) / h_), 0L, dims_[std::size_t(d)] - 1);
    }
    for (long z = c0[2]; z <= c1[2]; ++z)
      for (long y = c0[1]; y <= c1[1]; ++y)
        for (long x = c0[0]; x <= c1[0]; ++x) {
          const Vec3 mid = lo_ + h_ * Vec3(double(x) + 0.5, double(y) + 0.5, double(z) + 0.5);
          if (std::abs(tri_[t].n.dot(mid - a)) > half_diagonal) continue;  // the plane misses it
          const std::uint64_t key = (std::uint64_t(z) * std::uint64_t(dims_[1]) + std::uint64_t(y)) *
                                        std::uint64_t(dims_[0]) + std::uint64_t(x);
          cell_tri.emplace_back(key, static_cast<Index>(t));
        }
  }
  std::sort(cell_tri.begin(), cell_tri.end());
  keys_.clear();
  start_.clear();
  tris_.resize(cell_tri.size());
  for (std::size_t k = 0; k < cell_tri.size(); ++k) {
    if (k == 0 || cell_tri[k].first != cell_tri[k - 1].first) {
      keys_.push_back(cell_tri[k].first);
      start_.push_back(static_cast<Index>(k));
    }
    tris_[k] = cell_tri[k].second;
  }
  start_.push_back(static_cast<Index>(cell_tri.size()));
  // Where the box's cells are not many more than the occupied ones, every cell's start, so that
  // a query reads its cells directly, without a binary search per row of cells.
  const double cells = double(dims_[0]) * double(dims_[1]) * double(dims_[2]);
  dense_.clear();
  if (cells <= 64.0 * double(keys_.size()) + 4096.0) {
    dense_.assign(std::size_t(cells) + 1, 0);
    for (std::size_t k = 0; k < keys_.size(); ++k) dense_[keys_[k] + 1] = start_[k + 1] - start_[k];
    for (std::size_t c = 0; c + 1 < dense_.size(); ++c) dense_[c + 1] += dense_[c];
  }
}

std::vector<Index>& Mesh::scratch() {
  thread_local std::vector<Index> found;
  return found;
}

void Mesh::candidates(const Vec3& X, double ext, std::vector<Index>& out) const {
  out.clear();
  if (keys_.empty()) return;
  long c0[3], c1[3];
  for (int d = 0; d < 3; ++d) {
    const double a = (X[d] - ext - lo_[d]) / h_, b = (X[d] + ext - lo_[d]) / h_;
    if (!(b >= 0) || !(a < double(dims_[std::size_t(d)]))) return;  // outside the bins (or NaN)
    c0[d] = static_cast<long>(std::max(0.0, a));  // (clamped before the cast: no overflow)
    c1[d] = static_cast<long>(std::min(double(dims_[std::size_t(d)] - 1), b));
  }
  for (long z = c0[2]; z <= c1[2]; ++z)
    for (long y = c0[1]; y <= c1[1]; ++y) {
      const std::uint64_t row = (std::uint64_t(z) * std::uint64_t(dims_[1]) + std::uint64_t(y)) *
                                std::uint64_t(dims_[0]);
      if (!dense_.empty()) {
        out.insert(out.end(), tris_.begin() + dense_[row + std::uint64_t(c0[0])],
                   tris_.begin() + dense_[row + std::uint64_t(c1[0]) + 1]);
        continue;
      }
      auto it = std::lower_bound(keys_.begin(), keys_.end(), row + std::uint64_t(c0[0]));
      for (; it != keys_.end() && *it <= row + std::uint64_t(c1[0]); ++it) {
        const std::size_t k = std::size_t(it - keys_.begin());
        out.insert(out.end(), tris_.begin() + start_[k], tris_.begin() + start_[k + 1]);
      }
    }
  std::sort(out.begin(), out.end());
  out.erase(std::unique(out.begin(), out.end()), out.end());
}

MeshPoint Mesh::nearest_body(const Vec3& p, Index t) const {
  const Tri& T = tri_[std::size_t(t)];
  const Vec3 &a = T.a, &b = T.b, &c = T.c;
  MeshPoint m;
  auto at_point = [&](const Vec3& q, MeshFeature feature) {
    const Vec3 d = p - q;
    m.distance = d.norm();
    m.point = q;
    if (m.distance > 0) {
      m.normal = d / m.distance;
    } else {  // the centre on the edge or vertex: the face's normal
      m.normal = T.n;
    }
    m.feature = feature;
    return m;
  };
  auto vertex = [&](int k) { return MeshFeature{MeshFeature::kVertex, T.canon[std::size_t(k)], -1}; };
  auto edge = [&](int k, int l) {
    const Index u = T.canon[std::size_t(k)], v = T.canon[std::size_t(l)];
    return MeshFeature{MeshFeature::kEdge, std::min(u, v), std::max(u, v)};
  };
  // The Voronoi regions of the triangle (Ericson 5.1.5); a point on a region's border goes to
  // the edge or vertex, so a face contact is strictly inside its triangle.
  const Vec3 ab = b - a, ac = c - a, ap = p - a;
  const double d1 = ab.dot(ap), d2 = ac.dot(ap);
  if (d1 <= 0 && d2 <= 0) return at_point(a, vertex(0));
  const Vec3 bp = p - b;
  const double d3 = ab.dot(bp), d4 = ac.dot(bp);
  if (d3 >= 0 && d4 <= d3) return at_point(b, vertex(1));
  const double vc = d1 * d4 - d3 * d2;
  if (vc <= 0 && d1 >= 0 && d3 <= 0) return at_point(a + (d1 / (d1 - d3)) * ab, edge(0, 1));
  const Vec3 cp = p - c;
  const double d5 = ab.dot(cp), d6 = ac.dot(cp);
  if (d6 >= 0 && d5 <= d6) return at_point(c, vertex(2));
  const double vb = d5 * d2 - d1 * d6;
  if (vb <= 0 && d2 >= 0 && d6 <= 0) return at_point(a + (d2 / (d2 - d6)) * ac, edge(0, 2));
  const double va = d3 * d6 - d5 * d4;
  if (va <= 0 && (d4 - d3) >= 0 && (d5 - d6) >= 0)
    return at_point(b + ((d4 - d3) / ((d4 - d3) + (d5 - d6))) * (c - b), edge(1, 2));
  // The face: the triangle's own plane through its first vertex, turned to the centre's side.
  const Vec3& nf = T.n;
  const double s = nf.dot(ap);
  m.normal = s >= 0 ? nf : Vec3(-nf);
  m.distance = std::abs(s);
  m.point = a;
  m.feature = MeshFeature{MeshFeature::kFace, t, -1};
  return m;
}

bool Mesh::clear_of(const Vec3& x, double r, Index t, Vec3& normal, double& lower) const {
  const Tri& T = tri_[std::size_t(t)];
  const Vec3 d = to_body(x) - T.centroid;
  const double s = T.n.dot(d), r2 = r * r;
  // distance^2 >= s^2 + (in-plane distance to the centroid - round)^2, where positive
  const double in_plane = std::sqrt(std::max(0.0, d.squaredNorm() - s * s)) - T.round;
  const double lower2 = in_plane > 0 ? s * s + in_plane * in_plane : s * s;
  const bool clear = lower2 >= r2;
  if (clear) normal = (s >= 0 ? 1.0 : -1.0) * face_normal(t), lower = std::sqrt(lower2);
  return clear;
}

Mesh::Weights Mesh::weights(const Vec3& X, Index t) const {
  const Tri& T = tri_[std::size_t(t)];
  const Vec3 ab = T.b - T.a, ac = T.c - T.a, ap = X - T.a;
  Weights k;
  k.ab2 = ab.dot(ab), k.ac2 = ac.dot(ac);
  const double d01 = ab.dot(ac), d20 = ap.dot(ab), d21 = ap.dot(ac);
  k.whole = k.ab2 * k.ac2 - d01 * d01;
  k.v = k.ac2 * d20 - d01 * d21, k.w = k.ab2 * d21 - d01 * d20, k.u = k.whole - k.v - k.w;
  return k;
}

bool Mesh::over_face(const Vec3& x, Index t) const {
  const Weights k = weights(to_body(x), t);
  const double margin = kInside * k.whole;
  return k.v > margin && k.w > margin && k.u > margin;
}

double Mesh::face_room(const Vec3& x, Index t) const {
  if (moved_) return 0;
  const Weights k = weights(x, t);
  if (!(std::min({k.u, k.v, k.w}) > 1e-6 * k.whole)) return 0;
  // (a barycentric coordinate is the distance to its edge over the height: twice the area,
  // sqrt(whole), over the edge's length)
  const Tri& T = tri_[std::size_t(t)];
  const double to_edge =
      std::min({k.u / std::sqrt((T.c - T.b).squaredNorm()), k.v / std::sqrt(k.ac2), k.w / std::sqrt(k.ab2)}) *
      std::sqrt(k.whole) / k.whole;
  return 0.5 * to_edge;
}

namespace {
double segment_distance2(const Vec3& p, const Vec3& a, const Vec3& b) {
  const Vec3 ab = b - a;
  const double len2 = ab.squaredNorm();
  const double s = len2 > 0 ? std::clamp(ab.dot(p - a) / len2, 0.0, 1.0) : 0.0;
  return (p - (a + s * ab)).squaredNorm();
}
}  // namespace

bool Mesh::flat_sheet(const Vec3& x, double reach, const Index* tris, int n) const {
  if (n < 1) return false;
  const Vec3 X = to_body(x);
  const Tri& first = tri_[std::size_t(tris[0])];
  double size = 0, smallest = std::numeric_limits<double>::infinity();
  for (int k = 0; k < n; ++k) {
    size = std::max(size, tri_[std::size_t(tris[k])].round);
    smallest = std::min(smallest, tri_[std::size_t(tris[k])].round);
  }
  // (A neighbour tilted by 1e-12 leans over an edge by reach x 1e-12 at most: far inside the
  // kInside margin of a triangle not a thousand times smaller than the reach.)
  if (!(reach < 1e3 * smallest)) return false;
  for (int k = 0; k < n; ++k) {
    const Tri& T = tri_[std::size_t(tris[k])];
    const double side = T.n.dot(first.n) >= 0 ? 1.0 : -1.0;
    if ((T.n - side * first.n).cwiseAbs().maxCoeff() > 1e-12) return false;
    for (const Vec3* corner : {&T.a, &T.b, &T.c})
      if (std::abs(first.n.dot(*corner - first.a)) > 1e-10 * size) return false;
  }
  // Every edge within reach inside the sheet (no rim, ridge, crack or fin): then the sheet
  // covers the plane around x out to reach.
  for (int k = 0; k < n; ++k) {
    const Tri& T = tri_[std::size_t(tris[k])];
    const Vec3* corner[3] = {&T.a, &T.b, &T.c};
    for (int j = 0; j < 3; ++j) {
      const int l = (j + 1) % 3;
      if (!(segment_distance2(X, *corner[j], *corner[l]) < reach * reach)) continue;
      const MeshFeature edge{MeshFeature::kEdge, T.canon[std::size_t(j)], T.canon[std::size_t(l)]};
      int holders = 0;
      for (int m = 0; m < n; ++m) holders += has(tris[m], edge) ? 1 : 0;
      if (holders != 2) return false;
    }
  }
  // No two of them overlapping (an offset second copy of a floor in the same mesh: separate
  // entries would give a contact per copy): in the plane, an edge's outward normal separates
  // any two triangles that only meet at an edge or corner.
  auto separated = [&](const Tri& s, const Tri& t) {
    const Vec3* sc[3] = {&s.a, &s.b, &s.c};
    const Vec3* tc[3] = {&t.a, &t.b, &t.c};
    for (const Tri* own : {&s, &t}) {
      const Vec3* oc[3] = {&own->a, &own->b, &own->c};
      for (int j = 0; j < 3; ++j) {
        const Vec3 axis = first.n.cross(*oc[(j + 1) % 3] - *oc[j]);
        double s_lo = axis.dot(*sc[0]), s_hi = s_lo, t_lo = axis.dot(*tc[0]), t_hi = t_lo;
        for (int k = 1; k < 3; ++k) {
          s_lo = std::min(s_lo, axis.dot(*sc[k])), s_hi = std::max(s_hi, axis.dot(*sc[k]));
          t_lo = std::min(t_lo, axis.dot(*tc[k])), t_hi = std::max(t_hi, axis.dot(*tc[k]));
        }
        const double slack = 1e-9 * axis.norm() * size;
        if (s_hi <= t_lo + slack || t_hi <= s_lo + slack) return true;
      }
    }
    return false;
  };
  for (int k = 0; k < n; ++k)
    for (int m = k + 1; m < n; ++m)
      if (!separated(tri_[std::size_t(tris[k])], tri_[std::size_t(tris[m])])) return false;
  return true;
}

MeshPoint Mesh::nearest(const Vec3& x, Index t) const {
  if (!moved_) return nearest_body(x, t);
  MeshPoint m = nearest_body(to_body(x), t);
  m.point = to_world(m.point);
  m.normal = rotation_ * m.normal;
  return m;
}

bool Mesh::adjacent(Index s, Index t) const {
  for (Index u : tri_[std::size_t(s)].canon)
    for (Index v : tri_[std::size_t(t)].canon)
      if (u == v) return true;
  return false;
}

bool Mesh::has(Index t, const MeshFeature& feature) const {
  auto holds = [&](Index v) {
    for (Index u : tri_[std::size_t(t)].canon)
      if (u == v) return true;
    return false;
  };
  switch (feature.kind) {
    case MeshFeature::kFace: return feature.a == t;
    case MeshFeature::kEdge: return holds(feature.a) && holds(feature.b);
    default: return holds(feature.a);
  }
}

std::vector<Vec3> Mesh::world_vertices() const {
  std::vector<Vec3> out(body_.size());
  for (std::size_t v = 0; v < body_.size(); ++v) out[v] = to_world(body_[v]);
  return out;
}

void Mesh::advance(double dt, const Vec3& velocity, const Vec3& angular_velocity) {
  if (velocity.squaredNorm() == 0 && angular_velocity.squaredNorm() == 0) return;
  moved_ = true;
  center_ += dt * velocity;
  const double angle = angular_velocity.norm() * dt;
  if (angle > 0) {
    Eigen::Quaterniond q(orientation_[0], orientation_[1], orientation_[2], orientation_[3]);
    q = Eigen::Quaterniond(Eigen::AngleAxisd(angle, angular_velocity.normalized())) * q;
    q.normalize();
    orientation_ = {q.w(), q.x(), q.y(), q.z()};
    rotation_ = q.toRotationMatrix();
  }
}

void Mesh::set_center(const Vec3& c) {
  // The body stays where it is: center0 moves with the centre, in the body frame.
  if (moved_) center0_ += rotation_.transpose() * (c - center_);
  else center0_ = c;
  center_ = c;
}

double Mesh::shift_since(const Vec3& c0, const Orientation& q0, double reach) const {
  const Eigen::Quaterniond q(q0[0], q0[1], q0[2], q0[3]);
  return (center_ - c0).norm() + (rotation_ - q.toRotationMatrix()).norm() * reach;
}

std::size_t Mesh::bytes() const {
  return body_.capacity() * sizeof(Vec3) + faces_.capacity() * sizeof(Face) +
         tri_.capacity() * sizeof(Tri) +
         canon_.capacity() * sizeof(Index) +
         keys_.capacity() * sizeof(std::uint64_t) +
         (start_.capacity() + tris_.capacity() + dense_.capacity()) * sizeof(Index);
}

void Mesh::save(archive::Writer& w) const {
  std::vector<double> v;
  v.reserve(3 * body_.size());
  for (const Vec3& p : body_) v.insert(v.end(), p.data(), p.data() + 3);
  std::vector<std::int64_t> f;
  f.reserve(3 * faces_.size());
  for (const Face& t : faces_) f.insert(f.end(), t.begin(), t.end());
  w.reals("vertices", v);
  w.integers("faces", f);
  w.vec3("center0", center0_);
  w.vec3("center", center_);
  w.reals("orientation", orientation_.data(), 4);
  w.integer("moved", moved_ ? 1 : 0);
}

Mesh Mesh::restore(archive::Reader& r) {
  const std::vector<double> v = r.reals("vertices");
  const std::vector<std::int64_t> f = r.integers("faces");
  if (v.size() % 3 != 0 || f.size() % 3 != 0 || f.empty()) r.fail("a mesh needs vertices and faces in threes");
  std::vector<Vec3> vertices(v.size() / 3);
  for (std::size_t k = 0; k < vertices.size(); ++k) {
    vertices[k] = Vec3(v[3 * k], v[3 * k + 1], v[3 * k + 2]);
    if (!vertices[k].allFinite()) r.fail("mesh vertex " + std::to_string(k) + " is not finite");
  }
  std::vector<Face> faces(f.size() / 3);
  for (std::size_t k = 0; k < faces.size(); ++k)
    for (std::size_t j = 0; j < 3; ++j) {
      const std::int64_t idx = f[3 * k + j];
      if (idx < 0 || idx >= std::int64_t(vertices.size())) r.fail("mesh face " + std::to_string(k) + " names no vertex");
      faces[k][j] = static_cast<Index>(idx);
    }
  Mesh m(std::move(vertices), std::move(faces), r.vec3("center0"));
  m.center_ = r.vec3("center");
  const std::vector<double> q = r.reals("orientation", 4);
  const Eigen::Quaterniond quat(q[0], q[1], q[2], q[3]);
  m.orientation_ = {q[0], q[1], q[2], q[3]};
  m.rotation_ = quat.toRotationMatrix();
  m.moved_ = r.integer("moved") != 0;
  if (!m.center_.allFinite() || !m.center0_.allFinite() || !(std::abs(quat.norm() - 1) <= 1e-9))
    r.fail("a mesh's pose is not finite or not a rotation");
  return m;
}

}  // namespace tsubu
