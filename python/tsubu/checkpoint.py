"""Checkpoint files: the complete state of a Simulation, written atomically, verified on reading.

A file is a fixed header followed by a payload::

    magic    8 bytes   b"\\x89TSUBU\\r\\n"  (not text: a foreign or mangled file fails at once)
    version  4 bytes   format version, little-endian unsigned
    length   8 bytes   payload length in bytes, little-endian unsigned
    sha256  32 bytes   SHA-256 of the payload
    payload            format 2: 8 bytes (little-endian) n, n bytes of JSON (what only the
                       Python layer knows: material names, inserters, metadata), then the
                       core's own checkpoint (``Simulation::save`` in C++, docs/checkpoints.md)
                       format 1: a numpy .npz archive (read by ``tsubu._checkpoint_v1``)

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
import json
import os
import struct
import tempfile
from pathlib import Path

from . import _core

__all__ = ["CheckpointError", "FORMAT_VERSION", "MAGIC", "write_atomically", "sync_folder"]

#: The 8 bytes every checkpoint file starts with (bytes; not text, so that a text file, or one
#: mangled by a newline conversion, is refused at once).
MAGIC = b"\x89TSUBU\r\n"
#: The format version this tsubu writes (an int); files with a newer one are refused.
FORMAT_VERSION = 2
_HEADER = struct.Struct("<8sIQ32s")
_LENGTH = struct.Struct("<Q")


class CheckpointError(ValueError):
    """A checkpoint file that cannot be read: truncated, corrupted, not a tsubu checkpoint, or
    written by a newer tsubu. Nothing is built from such a file."""


def write_atomically(path: Path, data: bytes) -> None:
    """Write ``data`` (bytes) to ``path`` (a str or path) so that the file is, at every moment, either the old one or
    the complete new one: a temporary file in the same folder, flushed and fsync'ed, renamed
    over ``path``, and the folder fsync'ed so that the rename itself survives a crash.
    OSError when the file cannot be written (``path`` is then left as it was); when the
    folder does not exist (FileNotFoundError), is not a folder (NotADirectoryError) or cannot be
    written into, the error's message and ``filename`` name ``path``, not the temporary file."""
    path = Path(path)
    folder = path.parent if str(path.parent) else Path(".")
    try:
        fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".tmp", dir=folder)
    except OSError as e:
        raise _folder_error(e, path, folder) from None
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


def _folder_error(error: OSError, path: Path, folder: Path) -> OSError:
    """The OSError of a file that could not be created in ``folder``, said of ``path`` (the file
    asked for) rather than of the temporary file beside it."""
    if error.errno is None:
        return error
    if isinstance(error, FileNotFoundError):
        why = f"cannot write the file: the directory {str(folder)!r} does not exist (create it first)"
    elif isinstance(error, NotADirectoryError):
        why = f"cannot write the file: {str(folder)!r}, or a folder above it, is not a directory"
    else:
        why = f"cannot write the file in the directory {str(folder)!r}: {error.strerror or error}"
    # str() of the error: "[Errno 2] cannot write the file: the directory ... : '<path>'"
    return type(error)(error.errno, why, str(path))


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


def _frame(payload: bytes) -> bytes:
    return _HEADER.pack(MAGIC, FORMAT_VERSION, len(payload), hashlib.sha256(payload).digest()) + payload


def _read(path: Path) -> tuple[int, bytes]:
    """The format version and the payload of a checkpoint file (CheckpointError if it is not a
    whole, intact checkpoint this tsubu can read)."""
    path = Path(path)
    with open(path, "rb") as f:
        data = f.read()
    return _unframe(data, path)


def _unframe(data: bytes, path) -> tuple[int, bytes]:
    """The format version and the payload of a checkpoint's bytes (``path`` names them in
    messages)."""
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
    return version, payload


def _version() -> str:
    from . import __version__
    return __version__


def encode(sim, metadata: dict) -> bytes:
    """The checkpoint file's bytes for ``sim`` (format 2): the core's own bytes, and beside them
    what only the Python layer knows, as JSON."""
    # (An inserter's config may register its material: the materials and the core's bytes after.)
    inserters = [{"config": ins._config(sim), "state": ins._state()} for ins in sim._inserters]
    meta = {
        "format": "tsubu checkpoint", "tsubu_version": _version(),
        "materials": [dataclasses.asdict(m) for m in sim._materials],
        "scene_materials": [sim._material_index[id(m)] for m in sim._scene_materials],
        "inserters": inserters,
        "metadata": metadata,
    }
    text = json.dumps(meta, sort_keys=True, allow_nan=True).encode()
    return _frame(_LENGTH.pack(len(text)) + text + sim._core.save_bytes())


def load(path, threads=None):
    """A new Simulation from the checkpoint file at ``path`` (any format this tsubu reads)."""
    version, payload = _read(path)
    if version == 1:
        from . import _checkpoint_v1
        return _checkpoint_v1.load(payload, path, threads)
    return _restore(payload, path, threads)


def decode(data: bytes, materials=None):
    """A new Simulation from a checkpoint's bytes (what :func:`encode` gives: copies and pickles
    of a Simulation). ``materials``: Material objects to use in place of those the bytes
    describe (the same number, in the same order), so that a copy shares them, or a pickle
    keeps their identity."""
    version, payload = _unframe(data, "<copy of a Simulation>")
    if version != FORMAT_VERSION:
        raise CheckpointError(f"a copy of a Simulation in checkpoint format {version}, not {FORMAT_VERSION}")
    return _restore(payload, "<copy of a Simulation>", materials=materials)


def _restore_inserters(sim, saved_inserters: list) -> None:
    """Re-attach the inserters a checkpoint saved (their configuration and progress) to ``sim``."""
    if not saved_inserters:
        return
    from .insert import Inserter
    for saved in saved_inserters:
        inserter = Inserter._from_config(saved["config"], sim)
        inserter._attach(sim)
        inserter._restore(saved["state"])
        sim._inserters.append(inserter)


def _restore(payload: bytes, path, threads=None, materials=None):
    """A new Simulation from a format-2 payload (with ``materials`` in place of those it
    describes, if given)."""
    from .material import Material
    from .simulation import Simulation

    try:
        if len(payload) < _LENGTH.size:
            raise CheckpointError("no JSON section")
        (n,) = _LENGTH.unpack_from(payload)
        if n > len(payload) - _LENGTH.size:
            raise CheckpointError(f"the JSON section's length {n} runs past the end")
        meta = json.loads(payload[_LENGTH.size:_LENGTH.size + n].decode())
        core = _core.Simulation.load_bytes(payload[_LENGTH.size + n:])
        sim = Simulation()
        sim._core = core
        if len(meta["materials"]) != core.material_count:
            raise CheckpointError(f"{len(meta['materials'])} materials in the JSON section, "
                                  f"{core.material_count} in the core's")
        if materials is not None and len(materials) != len(meta["materials"]):
            raise CheckpointError(f"{len(materials)} materials given for the "
                                  f"{len(meta['materials'])} of the checkpoint")
        for index, fields in enumerate(meta["materials"]):
            m = Material(**fields) if materials is None else materials[index]
            sim._material_index[id(m)] = index
            sim._materials.append(m)
        sim._scene_materials = [sim._materials[k] for k in meta["scene_materials"]]
        _restore_inserters(sim, meta["inserters"])
        sim.metadata = meta["metadata"]
        if threads is not None:
            sim.threads = threads
    except CheckpointError as e:
        raise CheckpointError(f"{path}: inconsistent checkpoint contents: {e}") from None
    except (KeyError, TypeError, ValueError, IndexError, UnicodeDecodeError) as e:
        raise CheckpointError(f"{path}: inconsistent checkpoint contents: {type(e).__name__}: {e}") from None
    return sim
