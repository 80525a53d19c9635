"""Glass beads thrown at 30 degrees onto a smooth and onto a rough wall: the rough wall scatters
the rebound angle. Run: python examples/rough_wall.py"""
import numpy as np

import tsubu


def throw(roughness: float, n: int = 2000, incidence_deg: float = 30.0, seed: int = 1):
    wall = tsubu.Material(density=2500.0, kn=1e3, restitution=0.8, friction=0.3, roughness=roughness)
    bead = tsubu.Material(density=2500.0, kn=1e3, restitution=0.8, friction=0.3)
    sim = tsubu.Simulation(gravity=(0, 0, 0), seed=seed)
    r = 0.5e-3
    gamma = np.radians(incidence_deg)
    v = 0.1 * np.array([np.cos(gamma), 0.0, -np.sin(gamma)])
    x = np.zeros((n, 3))
    x[:, 0] = np.arange(n) * 10 * r  # far apart: independent impacts
    x[:, 2] = r + 1e-6
    sim.add_spheres(x, r, bead, velocities=np.tile(v, (n, 1)))
    sim.add_plane(point=(0, 0, 0), normal=(0, 0, 1), material=wall)
    sim.run(time=2e-3)
    u = sim.velocities
    return np.degrees(np.arctan2(u[:, 2], np.hypot(u[:, 0], u[:, 1])))


if __name__ == "__main__":
    for sigma in (0.0, 5.0, 10.0, 20.0):
        angle = throw(sigma)
        print(f"wall roughness sigma = {sigma:4.1f} deg: rebound angle {angle.mean():5.2f} "
              f"+- {angle.std():5.2f} deg (incidence 30 deg)")
