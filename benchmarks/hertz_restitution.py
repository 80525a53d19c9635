"""The restitution the Hertzian law really gives, over impact speeds 1e-3 to 10 m/s.

A sphere (R = 10 mm, rho = 2500 kg/m^3, E = 1e8 Pa, nu = 0.3) hits a 1e6 x stiffer wall head
on, no gravity; the rebound speed / impact speed is printed for several requested restitutions,
both normal forces (hertz_force "signed": the beta form, which may pull; "repulsive": clipped
at zero with the corrected dashpot) and three time steps (t_c/50, the default; t_c/100;
t_c/200), t_c Hertz's contact duration at the impact speed. The last column is the exact
(RK4-integrated, no DEM step) restitution of the dashpot the run used. docs/physics.md quotes
the table.

    PYTHONPATH=python python benchmarks/hertz_restitution.py
"""

from __future__ import annotations

import math

import tsubu
from tsubu import _core

R, RHO, E, NU = 0.01, 2500.0, 1.0e8, 0.3
M = RHO * 4.0 / 3.0 * math.pi * R ** 3
E_STAR = 1.0 / ((1 - NU ** 2) / E + (1 - NU ** 2) / (1e6 * E))
SPEEDS = (1e-3, 1e-2, 1e-1, 1.0, 10.0)


def impact(v: float, e: float, force: str, per: int) -> float:
    mat = tsubu.Material(density=RHO, youngs_modulus=E, poisson_ratio=NU, restitution=e, friction=0.0)
    wall = tsubu.Material(density=RHO, youngs_modulus=1e6 * E, poisson_ratio=NU, restitution=e,
                          friction=0.0)
    tc = 2.868265 * (M * M / (R * E_STAR * E_STAR * v)) ** 0.2
    sim = tsubu.Simulation(gravity=(0, 0, 0), dt=tc / per, hertz_force=force, impact_speed=v)
    sim.add_sphere((0, 0, R + 0.1 * v * tc / per), R, mat, velocity=(0, 0, -v))
    sim.add_plane(material=wall)
    sim.run(steps=3 * per)
    return sim.velocities[0][2] / v


def main() -> None:
    print(f"{'e asked':>8} {'force':>10} {'dt':>7} " + " ".join(f"{v:>9g}" for v in SPEEDS)
          + f" {'exact':>9}")
    for e in (0.1, 0.3, 0.5, 0.7, 0.9):
        for force in ("signed", "repulsive"):
            exact = _core.hertz_restitution(_core.hertz_damping_factor(e, force == "repulsive"),
                                            force == "repulsive")
            for per in (50, 100, 200):
                row = [impact(v, e, force, per) for v in SPEEDS]
                print(f"{e:8.2f} {force:>10} {'tc/' + str(per):>7} "
                      + " ".join(f"{x:9.5f}" for x in row) + f" {exact:9.6f}")


if __name__ == "__main__":
    main()
