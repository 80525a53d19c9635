"""tsubu (粒, "grain"): Discrete Element Method for rigid spheres.

A C++17 core (Eigen, OpenMP) with linear (Kelvin-Voigt) and Hertz-Mindlin contacts, Coulomb
friction with tangential history, rolling friction, rough surfaces, moving plane walls and a
linked-cell neighbour list, driven from Python with numpy arrays (SI units)::

    import tsubu
    glass = tsubu.Material(density=2500.0, kn=1e3, restitution=0.5, friction=0.5)
    sim = tsubu.Simulation(gravity=(0, 0, -9.81))
    sim.add_spheres([[0, 0, 0.01]], radius=0.5e-3, material=glass)
    sim.add_plane(point=(0, 0, 0), normal=(0, 0, 1), material=glass)
    sim.run(time=0.1)

The public names are listed in ``tsubu.__all__``: :class:`Simulation`, :class:`Material`,
:class:`InstabilityError`, :class:`PerformanceWarning`, the build's :data:`openmp` flag and
:data:`__version__`, :func:`read_mesh`, and the modules of filling, pouring, triangle meshes
(:mod:`tsubu.mesh`), output and scene files.
"""

from . import _core
from .material import Material
from .simulation import Box, InstabilityError, PerformanceWarning, Simulation
from . import fill, mesh, output
from .insert import Inserter
from .mesh import read_mesh

#: The package's version, a string such as ``"0.1.0"``.
__version__ = "0.1.0"
#: Whether the compiled core was built with OpenMP (a bool). Without it tsubu runs
#: single-threaded, and the ``threads`` option changes nothing.
openmp = bool(_core.openmp)

__all__ = ["Material", "Simulation", "Box", "InstabilityError", "PerformanceWarning", "fill", "Inserter",
           "mesh", "read_mesh", "output", "openmp", "__version__"]
