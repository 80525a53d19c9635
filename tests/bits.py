"""Bit-for-bit comparison of two simulations, shared by the tests that continue, split or fuse
runs and expect the bits of an uninterrupted one."""
import numpy as np

import tsubu


def assert_same_bits(a: tsubu.Simulation, b: tsubu.Simulation):
    """Same step count and time, the same per-sphere arrays, contacts and energy, to the bit."""
    assert (a.step_count, a.time) == (b.step_count, b.time)
    for name in ("positions", "velocities", "angular_velocities", "forces", "torques"):
        assert np.array_equal(getattr(a, name), getattr(b, name)), name
    ca, cb = a.contacts(), b.contacts()
    assert ca.keys() == cb.keys()
    for key in ca:
        assert np.array_equal(ca[key], cb[key]), key
    assert a.energy() == b.energy()
