"""Reads checkpoint files of format version 1 (tsubu before issue 25 item 4): the payload is a
numpy .npz archive (no pickles) of arrays in id order and a ``meta.json`` describing the rest,
restored through the core's setters one by one. Kept so that old files still load;
``tsubu.checkpoint`` writes format 2. Tested on ``tests/data/checkpoint_v1.tsubu``."""

from __future__ import annotations

import io
import json

import numpy as np

from . import _core
from .checkpoint import CheckpointError, _restore_inserters


def load(payload: bytes, path, threads=None):
    """A new Simulation from a format-1 payload (the bytes after the header)."""
    try:
        with np.load(io.BytesIO(payload), allow_pickle=False) as z:
            arrays = {k: z[k] for k in z.files}
        meta = json.loads(arrays.pop("meta.json").tobytes().decode())
    except Exception as e:  # intact bytes that are not our layout: a bug or a forged file
        raise CheckpointError(f"{path}: unreadable checkpoint contents ({e})") from None
    return _restore(arrays, meta, threads)


def _restore(arrays: dict, meta: dict, threads=None):
    """A new Simulation in the state ``arrays`` and ``meta`` describe."""
    from .material import Material
    from .simulation import Simulation

    try:
        options = dict(meta["options"])
        if threads is not None:
            options["threads"] = threads
        sim = Simulation(**options)
        core = sim._core
        scene = set(meta["scene_materials"])
        for index, fields in enumerate(meta["materials"]):
            got = sim._material(Material(**fields), f"materials[{index}]", scene=index in scene)
            if got != index:
                raise CheckpointError(f"material {index} registered as {got}")
        for o in meta["pair_overrides"]:
            params = _core.PairParams()
            for f, v in o["params"].items():
                setattr(params, f, v)
            core.set_pair_parameters(o["a"], o["b"], params)
        n = len(arrays["radii"])
        if n:
            core.add_spheres(arrays["positions"], arrays["radii"],
                             arrays["material_ids"].astype(np.intc), arrays["velocities"],
                             arrays["angular_velocities"])
            core.set_dissipated(arrays["dissipated"])
        for w in meta["walls"]:
            index = core.add_plane(w["point"], w["normal"], w["material"], w["velocity"],
                                   w["angular_velocity"])
            core.set_plane_state(index, w["point"], w["normal"], w["velocity"],
                                 w["angular_velocity"], w["material"])
        state = {}
        for kind in ("pair", "wall"):
            state[kind] = {
                "owner": arrays[f"{kind}_owner"], "partner": arrays[f"{kind}_partner"],
                "values": [arrays[f"{kind}_values{k}"] for k in range(len(meta["contact_widths"][kind]))],
                "widths": meta["contact_widths"][kind]}
        core.set_contact_state(state["pair"], state["wall"])
        core.set_run_state(meta["run_state"])
        _restore_inserters(sim, meta["inserters"])
        sim.metadata = meta["metadata"]
    except CheckpointError:
        raise
    except (KeyError, TypeError, ValueError, IndexError) as e:
        raise CheckpointError(f"inconsistent checkpoint contents: {type(e).__name__}: {e}") from None
    return sim
