// The domain the particles live in: open space, or a box periodic along some axes, with
// Lees–Edwards sliding images along one of them (docs/periodic.md).
//
// Periodic images are ghosts: rows after the N owned spheres in the particle arrays, each a copy
// of an owned sphere (its source) with the source's id, shifted by a box vector, and across a
// Lees–Edwards boundary offset along the flow by the images' slide and moving faster by
// rate x L_gradient. The neighbour list pairs owned spheres with ghosts as with any sphere, so
// that x_i - x_j of every entry is already the minimum image and v_i - v_j the relative velocity
// across the moving boundary: nothing in the force loop knows about the box, and an MPI rank's
// halo is the same rows. Ghosts are made at every rebuild (after the owned spheres are wrapped
// into the box, counting their images) and moved with their sources after every step.
#pragma once
#include <algorithm>
#include <array>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <limits>

#include "contact/geometry.hpp"
#include "memory.hpp"
#include "state.hpp"
#include "types.hpp"

namespace tsubu {

class Domain {
 public:
  // x_i - x_j, from j to i (a ghost partner holds its image's position: no minimum image here).
  template <class A, class B>
  TSUBU_INLINE static Vec3 displacement(const Eigen::MatrixBase<A>& xi, const Eigen::MatrixBase<B>& xj) {
    return xi - xj;
  }

  // ---- the box ---------------------------------------------------------------------------
  // Periodic along the axes with periodic[d]; lower/upper along all three (the others give the
  // stress volume only).
  void set_box(const Vec3& lower, const Vec3& upper, const std::array<bool, 3>& periodic);
  // Lees–Edwards: images across the `gradient` faces slide along `flow` at rate x L_gradient.
  void set_shear(double rate, int flow, int gradient);
  bool periodic() const { return any_; }
  bool periodic(int d) const { return periodic_[d]; }
  const Vec3& lower() const { return lo_; }
  const Vec3& upper() const { return hi_; }
  Vec3 length() const { return hi_ - lo_; }
  double shear_rate() const { return rate_; }
  int flow() const { return flow_; }
  int gradient() const { return gradient_; }
  bool sheared() const { return sheared_; }
  // How far the images above the gradient faces have slid along the flow, in [0, L_flow) after
  // a rebuild (continuous between rebuilds).
  double shear_offset() const { return offset_; }
  void set_shear_offset(double offset) { offset_ = offset; }
  // The speed of the images across the sheared faces relative to the spheres: what the lists'
  // moved bound adds per step.
  double shear_speed() const { return std::abs(rate_) * length()[gradient_]; }

  // How far the n positions stand outside the periodic faces, at most (0 inside).
  double excursion(const double* x, std::size_t n) const {
    double most = 0;
    for (std::size_t k = 0; k < n; ++k)
      for (int d = 0; d < 3; ++d)
        if (periodic_[d]) most = std::max({most, lo_[d] - x[3 * k + d], x[3 * k + d] - hi_[d]});
    return most;
  }
  // In a Lees–Edwards box without walls, what a step books in the lists' displacement bound:
  // pairs separate by the spheres' velocities less the mean flow u = rate (x_g - centre) (an
  // image's velocity is its source's plus the mean flow's change over a box length, so it has
  // its source's fluctuation), plus the mean flow's own shear across a listed pair, rate x its
  // separation (at most the ghosts' reach): dt (max |v - u| + |rate| reach / 2) per sphere.
  double sheared_move(const ParticleStore& p, std::size_t n, double dt) const {
    const MeanFlow u = mean_flow();
    double most = 0;
    for (std::size_t k = 0; k < n; ++k) most = std::max(most, u.relative2(p.x.data(), p.v.data(), k));
    return sheared_bound(most, dt);
  }
  // The bound above from max |v - u|^2, found by the particle pass where no fixed sphere moves
  // after it (ParticlePass::drift): no sweep of its own over the spheres.
  double sheared_bound(double most, double dt) const {
    return dt * (std::sqrt(most) + 0.5 * std::abs(rate_) * reach_);
  }
  // The mean flow of a Lees–Edwards box, u = rate (x_g - centre) along the flow.
  struct MeanFlow {
    double rate = 0, centre = 0;
    int flow = 0, gradient = 2;
    // |v_k - u(x_k)|^2
    double relative2(const double* x, const double* v, std::size_t k) const {
      Vec3 r = vec3(v, k);
      r[flow] -= rate * (x[3 * k + gradient] - centre);
      return r.squaredNorm();
    }
  };
  MeanFlow mean_flow() const {
    return {rate_, 0.5 * (lo_[gradient_] + hi_[gradient_]), flow_, gradient_};
  }

  // ---- per run ---------------------------------------------------------------------------
  // Slides the images by dt (Lees–Edwards).
  void advance(double dt) { offset_ += rate_ * length()[gradient_] * dt; }
  // Puts the owned spheres back into the box, counting images (and, across the sheared faces,
  // their slide and velocity); called by a rebuild, with no ghosts present.
  void wrap(ParticleStore& p, std::size_t n);
  // One sphere's position, velocity, images and slide brought into the box (what wrap does to
  // each; the accessors apply it to copies between rebuilds).
  void wrap_one(double* x, double* v, int* image, double* slid) const;
  // Appends the ghosts of the n owned spheres that lie within `margin` of the periodic faces
  // (all images needed by pairs up to that reach), sorted by cell through `key` (a callback
  // mapping a position to a sort key), and records their sources and shifts; `reach` bounds a
  // listed pair's separation (sheared_move, stretch).
  template <class Key>
  void make_ghosts(ParticleStore& p, std::size_t n, double margin, double reach, Key&& key);
  // Moves the ghosts with their sources: x = x_src + shift, v = v_src (+ the slide's speed), w.
  // `threads`: the ghosts are shared among that many OpenMP threads (each writes only its own
  // rows).
  void update_ghosts(ParticleStore& p, std::size_t n, int threads = 1) const;
  std::size_t ghosts() const { return source_.size(); }
  const Array<Index>& ghost_sources() const { return source_; }
  // The owned row of row j (itself for an owned sphere).
  Index source(Index j, std::size_t n) const {
    return static_cast<std::size_t>(j) < n ? j : source_[static_cast<std::size_t>(j) - n];
  }
  // Marks the sources of the ghosts marked (loaded: a byte per row; the contact pass marks
  // both rows of a touching entry), clearing the ghosts' marks.
  void fold(std::uint8_t* loaded, std::size_t n) const {
    for (std::size_t q = 0; q < source_.size(); ++q)
      if (loaded[n + q]) {
        loaded[source_[q]] = 1;
        loaded[n + q] = 0;
      }
  }
  void clear_ghosts() {
    source_.clear();
    image_.clear();
    slide_.clear();
  }

  // ---- a pressure-controlled box ---------------------------------------------------------
  // The length along `axis` follows a target normal stress (compression positive): the box
  // stretches at the strain rate gain x (P_axis - pressure), at most max_rate in magnitude.
  struct Servo {
    bool on = false;
    int axis = 2;
    double pressure = 0, gain = 0, max_rate = 0;
  };
  void set_servo(const Servo& s) { servo_ = s; }
  const Servo& servo() const { return servo_; }
  // Stretches the box along the servo axis by the factor 1 + rate dt about its lower face, the
  // n owned spheres with it (affinely); returns how far any sphere or image moved (a bound).
  double stretch(ParticleStore& p, std::size_t n, double rate, double dt);

  // The position of owned row k as if it had never been wrapped.
  template <class X>
  Vec3 unwrapped(const Eigen::MatrixBase<X>& x, const ParticleStore& p, std::size_t k) const {
    if (!any_) return x;
    Vec3 u = x;
    for (int d = 0; d < 3; ++d) u[d] += p.image[3 * k + d] * (hi_[d] - lo_[d]);
    u[flow_] += p.slid[k];
    return u;
  }
  // The region the cell grid must cover: the bounding box of the n positions x (and ghosts).
  void grid_extent(const double* x, std::size_t n, Vec3& lo, Vec3& hi) const {
    lo = Vec3::Constant(std::numeric_limits<double>::infinity());
    hi = -lo;
    for (std::size_t k = 0; k < n; ++k) {
      lo = lo.cwiseMin(Vec3(vec3(x, k)));
      hi = hi.cwiseMax(Vec3(vec3(x, k)));
    }
  }

 private:
  std::array<bool, 3> periodic_{false, false, false};
  bool any_ = false, sheared_ = false;
  Vec3 lo_ = Vec3::Zero(), hi_ = Vec3::Zero();
  double rate_ = 0, offset_ = 0;
  int flow_ = 0, gradient_ = 2;
  // Per ghost: its source's row, its image (box lengths along each axis), and its image along
  // the gradient (-1, 0, 1: how many slides it takes).
  Array<Index> source_;
  Array<std::int8_t> image_;
  Array<std::int8_t> slide_;
  Servo servo_;
  double reach_ = 0;  // a listed pair's separation, at most (make_ghosts)
};

template <class Key>
void Domain::make_ghosts(ParticleStore& p, std::size_t n, double margin, double reach, Key&& key) {
  clear_ghosts();
  if (!any_) return;
  reach_ = reach;
  const Vec3 L = length();
  // Each owned sphere's images within `margin` of the box: offsets -1, 0, 1 along each periodic
  // axis; across the sheared faces the flow coordinate first slides (by up to a length either
  // way), then takes any image of the flow axis (-2..2) that lands within reach.
  struct Ghost {
    std::uint64_t key;
    Index source;
    std::array<std::int8_t, 3> image;
    std::int8_t slide;
  };
  std::vector<Ghost> made;
  auto inside = [&](const Vec3& y) {
    for (int d = 0; d < 3; ++d)
      if (periodic_[d] && (y[d] < lo_[d] - margin || y[d] >= hi_[d] + margin)) return false;
    return true;
  };
  const int span[3] = {periodic_[0] ? 1 : 0, periodic_[1] ? 1 : 0, periodic_[2] ? 1 : 0};
  auto images = [](const int* c) {
    return std::array<std::int8_t, 3>{static_cast<std::int8_t>(c[0]), static_cast<std::int8_t>(c[1]),
                                      static_cast<std::int8_t>(c[2])};
  };
  for (std::size_t k = 0; k < n; ++k) {
    const Vec3 x = vec3(p.x.data(), k);
    // Which image of each axis lands within the margin, by `inside`'s own test (the flow axis
    // of a sheared image is tested after its slide): most spheres lie further from every face
    // and have no image at all.
    bool fits[3][3];
    bool any = false;
    for (int d = 0; d < 3; ++d)
      for (int cd = -1; cd <= 1; ++cd) {
        const double y = x[d] + cd * L[d];
        fits[d][cd + 1] = !periodic_[d] || cd == 0 || !(y < lo_[d] - margin || y >= hi_[d] + margin);
        any |= periodic_[d] && cd != 0 && fits[d][cd + 1];
      }
    if (!any) continue;
    for (int c2 = -span[2]; c2 <= span[2]; ++c2)
      for (int c1 = -span[1]; c1 <= span[1]; ++c1)
        for (int c0 = -span[0]; c0 <= span[0]; ++c0) {
          int c[3] = {c0, c1, c2};
          const int s = sheared_ ? c[gradient_] : 0;
          bool fit = true;
          for (int d = 0; d < 3; ++d) fit &= (s != 0 && d == flow_) || fits[d][c[d] + 1];
          if (!fit) continue;
          Vec3 shift(c[0] * L[0], c[1] * L[1], c[2] * L[2]);
          if (s != 0) {  // a sheared image: its flow image is chosen after the slide
            if (c[flow_] != 0) continue;
            const double slid = s * offset_;
            for (int a = -2; a <= 2; ++a) {
              c[flow_] = a;
              Vec3 ys = x + Vec3(c[0] * L[0], c[1] * L[1], c[2] * L[2]);
              ys[flow_] += slid;
              if (inside(ys)) made.push_back({key(ys), static_cast<Index>(k), images(c), static_cast<std::int8_t>(s)});
            }
            continue;
          }
          if (c0 == 0 && c1 == 0 && c2 == 0) continue;
          const Vec3 y = x + shift;
          if (inside(y)) made.push_back({key(y), static_cast<Index>(k), images(c), 0});
        }
  }
  std::stable_sort(made.begin(), made.end(), [](const Ghost& a, const Ghost& b) { return a.key < b.key; });
  const std::size_t g = made.size();
  source_.resize(g);
  image_.resize(3 * g);
  slide_.resize(g);
  for (std::size_t q = 0; q < g; ++q) {
    source_[q] = made[q].source;
    for (int d = 0; d < 3; ++d) image_[3 * q + d] = made[q].image[d];
    slide_[q] = made[q].slide;
  }
  // The ghost rows: copies of their sources, then moved into place.
  p.for_each_field([&](auto& a, int width) {
    a.resize(width * (n + g));
    for (std::size_t q = 0; q < g; ++q)
      for (int c = 0; c < width; ++c) a[width * (n + q) + c] = a[width * source_[q] + c];
  });
  update_ghosts(p, n);
}

}  // namespace tsubu
