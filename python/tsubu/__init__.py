"""tsubu (粒, "grain"): Discrete Element Method for rigid spheres.

A C++17 core (Eigen, OpenMP) with Kelvin-Voigt contacts, Coulomb friction with tangential
history, rolling friction, plane walls and a linked-cell neighbour list, driven from Python::

    import tsubu
    glass = tsubu.Material(density=2500.0, kn=1e3, restitution=0.5, friction=0.5)
    sim = tsubu.Simulation(gravity=(0, 0, -9.81))
    sim.add_spheres([[0, 0, 0.01]], radius=0.5e-3, material=glass)
    sim.add_plane(point=(0, 0, 0), normal=(0, 0, 1), material=glass)
    sim.run(time=0.1)
"""

from . import _core
from .material import Material
from .simulation import InstabilityError, Simulation
from . import fill
from .insert import Inserter

__version__ = "0.1.0"
openmp = bool(_core.openmp)

__all__ = ["Material", "Simulation", "InstabilityError", "fill", "Inserter", "openmp", "__version__"]
