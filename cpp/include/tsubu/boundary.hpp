// Grains as boundaries (docs/boundaries.md): spheres that are fixed or move with a prescribed
// velocity and spin, and outlets that remove the spheres whose centre leaves the scene's region.
//
// A fixed sphere has infinite mass to the scene: its inverse mass and inertia are 0 (the kick of
// the particle pass adds dt * 0 * F), a contact with it takes the free sphere's mass as m_eff
// (NeighborList::cache_terms: as a wall does), and after each step's particle pass
// FixedSpheres::after puts it where its prescribed motion takes it, x += dt v, with v and w the
// prescribed ones (the drift's gravity undone). A scene without fixed spheres does none of this:
// the loop holds a null pointer and tests it once per step.
#pragma once
#include <algorithm>
#include <vector>

#include "particles.hpp"
#include "types.hpp"

namespace tsubu {

struct FixedSpheres {
  std::vector<Id> ids;        // by increasing id
  std::vector<double> v, w;   // the prescribed velocity and angular velocity, 3 per id
  std::vector<double> x0;     // scratch: the positions before the particle pass
  std::vector<double> pass_v2;  // |v|^2 as the particle pass left each, before after() (one each)

  bool empty() const { return ids.empty(); }
  // Whether some fixed sphere moves or spins (then it works on the scene like a moving wall).
  bool moving() const {
    return std::any_of(v.begin(), v.end(), [](double a) { return a != 0; }) ||
           std::any_of(w.begin(), w.end(), [](double a) { return a != 0; });
  }
  // The position in `ids` of `id`, or -1.
  long find(Id id) const {
    const auto it = std::lower_bound(ids.begin(), ids.end(), id);
    return it != ids.end() && *it == id ? long(it - ids.begin()) : -1;
  }

  // Before the particle pass: the fixed spheres' positions.
  void before(const Particles& p) {
    x0.resize(3 * ids.size());
    const double* x = p.arrays().x.data();
    for (std::size_t k = 0; k < ids.size(); ++k) {
      const std::size_t i = static_cast<std::size_t>(p.index(ids[k]));
      for (int c = 0; c < 3; ++c) x0[3 * k + c] = x[3 * i + c];
    }
  }
  // After it: x = x_before + dt v, v and w the prescribed ones. Returns max |v|^2 over them.
  double after(Particles& p, double dt) {
    ParticleStore& s = p.arrays();
    double top = 0;
    pass_v2.resize(ids.size());
    for (std::size_t k = 0; k < ids.size(); ++k) {
      const std::size_t i = static_cast<std::size_t>(p.index(ids[k]));
      // (a rank of a decomposed scene books the speed the pass gave it, as one process does)
      pass_v2[k] = s.v[3 * i] * s.v[3 * i] + s.v[3 * i + 1] * s.v[3 * i + 1] + s.v[3 * i + 2] * s.v[3 * i + 2];
      double v2 = 0;
      for (int c = 0; c < 3; ++c) {
        const double vc = v[3 * k + c];
        s.v[3 * i + c] = vc;
        s.w[3 * i + c] = w[3 * k + c];
        s.x[3 * i + c] = x0[3 * k + c] + dt * vc;
        v2 += vc * vc;
      }
      top = std::max(top, v2);
    }
    return top;
  }
};

// An outlet: a plane (point, normal: a sphere whose centre is behind the plane, (x - p).n < 0,
// is removed: the normal points into the scene, as a wall's does) or a box [lo, hi] (a sphere
// whose centre is outside it is removed, or, with remove_inside, one whose centre is inside it).
struct Outlet {
  enum Kind : int { PlaneOutlet = 0, BoxOutlet = 1 };
  int kind = PlaneOutlet;
  Vec3 a = Vec3::Zero();  // plane: the point; box: lo
  Vec3 b = Vec3::Zero();  // plane: the unit normal; box: hi
  bool remove_inside = false;  // box only

  bool removes(const double* x) const { return kind == PlaneOutlet ? behind(x) : leaving_box(x); }
  // How many of the n centres x (3 each) it removes: the per-step test, without a branch per
  // sphere, so that the compiler vectorises it (nearly every step finds none).
  long count(const double* x, std::size_t n) const {
    long found = 0;
    if (kind == PlaneOutlet)
      for (std::size_t i = 0; i < n; ++i) found += behind(x + 3 * i) ? 1 : 0;
    else
      for (std::size_t i = 0; i < n; ++i) found += leaving_box(x + 3 * i) ? 1 : 0;
    return found;
  }

 private:
  bool behind(const double* x) const {
    return (x[0] - a[0]) * b[0] + (x[1] - a[1]) * b[1] + (x[2] - a[2]) * b[2] < 0;
  }
  bool leaving_box(const double* x) const {  // (& not &&: no branch)
    const bool inside = (x[0] >= a[0]) & (x[0] <= b[0]) & (x[1] >= a[1]) & (x[1] <= b[1]) &
                        (x[2] >= a[2]) & (x[2] <= b[2]);
    return inside == remove_inside;
  }
};

// The spheres removed so far, in the order of removal (by step, then by id): by an outlet (its
// index) or by Simulation::remove_spheres (outlet -1), with the step, the time and the state they
// left with.
struct RemovalLog {
  std::vector<Id> id;
  std::vector<int> outlet;
  std::vector<long> step;
  std::vector<double> time, position, velocity;  // position, velocity: 3 each
  std::size_t size() const { return id.size(); }
};

}  // namespace tsubu
