// A pack of glass beads settling in a box, driven from C++ without Python.
#include <tsubu/simulation.hpp>

#include <algorithm>
#include <cstdio>
#include <random>
#include <vector>

int main() {
  tsubu::Options options;
  options.gravity = tsubu::Vec3(0, 0, -9.81);
  tsubu::Simulation sim(options);

  tsubu::Material glass;  // SI units
  glass.density = 2500.0;
  glass.kn = 1.0e3;
  glass.kt = 2.0 / 7.0 * glass.kn;
  glass.restitution = 0.5;
  glass.friction = 0.5;
  const int material = sim.add_material(glass);

  // 8 x 8 x 12 beads of 0.4-0.5 mm radius on a lattice, jittered velocities.
  const double spacing = 1.1e-3, box = 8 * spacing;
  std::mt19937_64 rng(7);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  for (int k = 0; k < 12; ++k)
    for (int j = 0; j < 8; ++j)
      for (int i = 0; i < 8; ++i) {
        const tsubu::Vec3 x = (tsubu::Vec3(i, j, k) + tsubu::Vec3::Constant(0.5)) * spacing;
        sim.add_sphere(x, 0.45e-3 + 0.05e-3 * u(rng), material,
                       0.05 * tsubu::Vec3(u(rng), u(rng), u(rng)));
      }
  sim.add_plane({0, 0, 0}, {0, 0, 1}, material);  // floor
  sim.add_plane({0, 0, 0}, {1, 0, 0}, material);
  sim.add_plane({box, 0, 0}, {-1, 0, 0}, material);
  sim.add_plane({0, 0, 0}, {0, 1, 0}, material);
  sim.add_plane({0, box, 0}, {0, -1, 0}, material);

  std::printf("%zu beads, law %s, dt = %.4g s (stability bound %.4g s)\n", sim.size(),
              sim.law_name().c_str(), sim.time_step(), sim.critical_time_step());
  const double e0 = sim.energy().total();
  std::vector<double> x(3 * sim.size());
  try {
    for (int block = 1; block <= 5; ++block) {
      sim.run(static_cast<long>(0.01 / sim.time_step()));
      sim.get_positions(x.data());
      double zmean = 0, zmin = 1e9;
      for (std::size_t p = 0; p < sim.size(); ++p) {
        zmean += x[3 * p + 2] / sim.size();
        zmin = std::min(zmin, x[3 * p + 2]);
      }
      const tsubu::Energy e = sim.energy();
      std::printf("t = %5.3f s  mean height %.3f mm  lowest %.3f mm  kinetic %.3e J  "
                  "contacts %zu  energy balance %+.1e\n",
                  sim.time(), zmean * 1e3, zmin * 1e3, e.kinetic(), sim.contacts().size(),
                  (e.total() + e.dissipated - e0) / std::abs(e0));
    }
  } catch (const tsubu::InstabilityError& err) {
    std::fprintf(stderr, "unstable: %s\n", err.what());
    return 1;
  }
  return 0;
}
