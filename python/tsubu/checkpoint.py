"""Checkpoint files: the complete state of a Simulation, written atomically, verified on reading.

A file is a fixed header followed by a payload::

    magic    8 bytes   b"\\x89TSUBU\\r\\n"  (not text: a foreign or mangled file fails at once)
    version  4 bytes   format version, little-endian unsigned
    length   8 bytes   payload length in bytes, little-endian unsigned
    sha256  32 bytes   SHA-256 of the payload
    payload            a numpy .npz archive (no pickles): the arrays, and ``meta.json``

A file is refused whole, before anything is built from it, when the magic, the length or the
checksum do not match, or when its version is newer than this tsubu reads.

:meth:`tsubu.Simulation.save` and :meth:`tsubu.Simulation.load` write and read these files;
this module's public names are :class:`CheckpointError` (what ``load`` raises for a bad file),
:data:`FORMAT_VERSION`, :data:`MAGIC` and :func:`write_atomically`. ``docs/checkpoints.md`` in
the repository describes what is saved and how a resumed run is checked to be bit-identical.
"""

from __future__ import annotations

import dataclasses
import hashlib
import io
import json
import os
import struct
import tempfile
from pathlib import Path

import numpy as np

from . import _core

__all__ = ["CheckpointError", "FORMAT_VERSION", "MAGIC", "write_atomically", "sync_folder"]

#: The 8 bytes every checkpoint file starts with (bytes; not text, so that a text file, or one
#: mangled by a newline conversion, is refused at once).
MAGIC = b"\x89TSUBU\r\n"
#: The format version this tsubu writes (an int); files with a newer one are refused.
FORMAT_VERSION = 1
_HEADER = struct.Struct("<8sIQ32s")

# The engine options a checkpoint keeps, as the constructor's arguments.
_OPTIONS = ("gravity", "dt", "threads", "seed", "skin", "tangential_history", "slip_rule",
            "hertz_force", "adhesion", "impact_speed", "max_overlap", "initial_overlap", "allow_unstable_dt",
            "rebuild_every_step", "parallel_min")


class CheckpointError(ValueError):
    """A checkpoint file that cannot be read: truncated, corrupted, not a tsubu checkpoint, or
    written by a newer tsubu. Nothing is built from such a file."""


def write_atomically(path: Path, data: bytes) -> None:
    """Write ``data`` (bytes) to ``path`` (a str or path) so that the file is, at every moment, either the old one or
    the complete new one: a temporary file in the same folder, flushed and fsync'ed, renamed
    over ``path``, and the folder fsync'ed so that the rename itself survives a crash.
    OSError when the file cannot be written (``path`` is then left as it was)."""
    path = Path(path)
    folder = path.parent if str(path.parent) else Path(".")
    fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".tmp", dir=folder)
    try:
        with os.fdopen(fd, "wb") as f:
            f.write(data)
            f.flush()
            os.fsync(f.fileno())
        os.replace(tmp, path)
    except BaseException:
        try:
            os.unlink(tmp)
        except OSError:
            pass
        raise
    sync_folder(folder)


def sync_folder(folder) -> None:
    """fsync a folder, so that a rename into it survives a crash (where the platform has
    directory handles; elsewhere nothing)."""
    try:
        dir_fd = os.open(folder, os.O_RDONLY)
    except OSError:
        return
    try:
        os.fsync(dir_fd)
    except OSError:
        pass
    finally:
        os.close(dir_fd)


def _encode(arrays: dict, meta: dict) -> bytes:
    """The file's bytes for these arrays and this JSON-able metadata."""
    buffer = io.BytesIO()
    text = json.dumps(meta, sort_keys=True, allow_nan=True).encode()
    np.savez(buffer, **arrays, **{"meta.json": np.frombuffer(text, dtype=np.uint8)})
    payload = buffer.getvalue()
    return _HEADER.pack(MAGIC, FORMAT_VERSION, len(payload), hashlib.sha256(payload).digest()) + payload


def _decode(path: Path) -> tuple[dict, dict]:
    """The arrays and the metadata of a checkpoint file (CheckpointError if it is not a whole,
    intact checkpoint this tsubu can read)."""
    path = Path(path)
    with open(path, "rb") as f:
        data = f.read()
    if len(data) < _HEADER.size or not data.startswith(MAGIC):
        if len(data) < len(MAGIC) and MAGIC.startswith(data):
            raise CheckpointError(f"{path}: truncated checkpoint ({len(data)} bytes)")
        raise CheckpointError(f"{path}: not a tsubu checkpoint (it does not start with tsubu's "
                              "checkpoint signature)")
    _, version, length, digest = _HEADER.unpack_from(data)
    if version > FORMAT_VERSION:
        raise CheckpointError(f"{path}: checkpoint format version {version} was written by a newer "
                              f"tsubu; this tsubu reads versions up to {FORMAT_VERSION}: upgrade tsubu")
    if version < 1:
        raise CheckpointError(f"{path}: checkpoint format version {version} does not exist")
    payload = data[_HEADER.size:]
    if len(payload) != length:
        raise CheckpointError(f"{path}: truncated or extended checkpoint: the header says "
                              f"{length} bytes of data, the file has {len(payload)}")
    if hashlib.sha256(payload).digest() != digest:
        raise CheckpointError(f"{path}: corrupted checkpoint: its SHA-256 checksum does not match "
                              "its contents")
    try:
        with np.load(io.BytesIO(payload), allow_pickle=False) as z:
            arrays = {k: z[k] for k in z.files}
        meta = json.loads(arrays.pop("meta.json").tobytes().decode())
    except Exception as e:  # intact bytes that are not our layout: a bug or a forged file
        raise CheckpointError(f"{path}: unreadable checkpoint contents ({e})") from None
    return arrays, meta


def _options(sim) -> dict:
    c = sim._core
    zero_is_none = lambda v: None if v == 0 else v  # noqa: E731
    return {"gravity": list(c.gravity), "dt": zero_is_none(c.dt), "threads": zero_is_none(c.threads),
            "seed": int(c.seed), "skin": zero_is_none(c.skin_option),
            "tangential_history": c.history_rule, "slip_rule": c.slip_rule,
            "hertz_force": "repulsive" if c.repulsive else "signed", "adhesion": c.adhesion,
            "impact_speed": zero_is_none(c.impact_speed), "max_overlap": c.max_overlap,
            "initial_overlap": c.initial_overlap, "allow_unstable_dt": c.allow_unstable_dt,
            "rebuild_every_step": c.rebuild_every_step, "parallel_min": c.parallel_min}


def _state_of(sim, metadata: dict | None) -> tuple[dict, dict]:
    """The arrays and metadata that describe ``sim`` completely."""
    core = sim._core
    arrays = {
        "positions": core.positions(), "velocities": core.velocities(),
        "angular_velocities": core.angular_velocities(), "radii": core.radii(),
        "material_ids": np.asarray(core.materials(), dtype=np.int64),
        "dissipated": core.dissipated(),
    }
    widths = {}
    for kind in ("pair", "wall"):
        state = core.contact_state(kind == "wall")
        arrays[f"{kind}_owner"] = state["owner"]
        arrays[f"{kind}_partner"] = state["partner"]
        for k, values in enumerate(state["values"]):
            arrays[f"{kind}_values{k}"] = values
        widths[kind] = list(state["widths"])
    walls = []
    for w in range(core.plane_count):
        p = core.plane(w)
        walls.append({k: (list(v) if k != "material" else int(v)) for k, v in p.items()})
    overrides = []
    for (a, b), params in sim._pair_overrides.items():
        overrides.append({"a": a, "b": b, "params": {f: getattr(params, f) for f in params.fields}})
    scene = [sim._material_index[id(m)] for m in sim._scene_materials]
    meta = {
        "format": "tsubu checkpoint", "tsubu_version": _version(),
        "options": _options(sim),
        "materials": [dataclasses.asdict(m) for m in sim._materials],
        "scene_materials": scene,
        "pair_overrides": overrides,
        "walls": walls,
        "run_state": core.run_state(),
        "contact_widths": widths,
        "inserters": [{"config": ins._config(sim), "state": ins._state()} for ins in sim._inserters],
        "metadata": {} if metadata is None else metadata,
    }
    return arrays, meta


def _version() -> str:
    from . import __version__
    return __version__


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
            sim._pair_overrides[(o["a"], o["b"])] = params
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
        if meta["inserters"]:
            from .insert import Inserter
            for saved in meta["inserters"]:
                inserter = Inserter._from_config(saved["config"], sim)
                inserter._attach(sim)
                inserter._restore(saved["state"])
                sim._inserters.append(inserter)
        sim.metadata = meta["metadata"]
    except CheckpointError:
        raise
    except (KeyError, TypeError, ValueError, IndexError) as e:
        raise CheckpointError(f"inconsistent checkpoint contents: {type(e).__name__}: {e}") from None
    return sim
