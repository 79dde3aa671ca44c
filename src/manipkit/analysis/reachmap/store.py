"""Reachability maps on disk: written safely, read back validated as a whole (docs/site/internals/reach-maps.md).

A map is a Zarr (v3) folder: a root ``zarr.json`` whose attributes hold the
settings (``format`` is :data:`manipkit.analysis.reachmap.constants.FORMAT`) and one
array folder per array of :data:`MAP_ARRAYS`, each a ``zarr.json`` and its
chunks under ``c/`` (regular chunk grid, ``/`` chunk keys, codecs ``bytes``
then ``zstd``). Every chunk is written, even one that holds only the fill
value, so a missing chunk always means a damaged or truncated map.

**Writing** (:func:`save_map`): the map is written into a new hidden
sibling folder (``.NAME.writing-*``) and renamed to ``NAME`` at the end, so
a full disk, a failure or a Ctrl-C leaves no folder at ``NAME`` (the partial
one is removed). An existing ``NAME`` is replaced only when it is a manipkit
map holding nothing but a map's own files (:func:`writable_map_path`): it is
renamed aside, the new map renamed in, and the old one removed; a folder with
anything else in it, a file or a symbolic link is refused, never emptied.

**Reading** (:func:`read_map`) checks everything before any array is
decoded: every entry of the folder is a folder or a regular file of a map
(no symbolic link, FIFO or stray file), every ``zarr.json`` is JSON of at
most :data:`MAX_JSON_DEPTH` levels and ``MAX_TABLE_BYTES``; the attributes
have their types, finite values and ranges (voxel, origin, orthonormal
right-handed axes, orientation kind and bins, names); each array's metadata
is the one manipkit writes, with the shape the attributes call for; every
chunk is present, and its zstd frame declares the exact size of its chunk
before it is decompressed (a crafted chunk cannot inflate beyond it). Then
the contents: reach codes, IK keys, certificate keys (exactly the reached
voxel-bins, increasing), finite configurations. A map that fails
any check is refused with :class:`~manipkit.errors.InputFileError` naming
what is wrong.
"""

from __future__ import annotations

import json
import math
import numbers
import os
import re
import secrets
import shutil
import stat
import tempfile
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from manipkit.analysis.reachmap.constants import (
    FORMAT,
    HOW_IK,
    HOW_NONE,
    HOW_SAMPLE,
    MAX_BINS,
    MAX_GRID_BYTES,
    MAX_MAP_FILES,
    MAX_VOXEL,
    METHODS,
    MIN_VOXEL,
    map_bytes,
)
from manipkit.analysis.reachmap.orientations import planar_orientations, spatial_orientations
from manipkit.analysis.reachmap.payload import PAYLOAD_ARRAYS, PayloadInvalid, layer_from_stored
from manipkit.errors import InputFileError, OutputError
from manipkit.inputs import MAX_TABLE_BYTES, read_text
from manipkit.outputs import cannot_write
from manipkit.text import printable

if TYPE_CHECKING:
    from manipkit.analysis.reachmap.map import ReachMap

__all__ = ["MAP_ARRAYS", "MAX_JSON_DEPTH", "read_map", "resume_folder", "save_map", "writable_map_path",
           "zstd_content_size"]

#: The arrays of a map and their data types; the manipulability ones only in a map built with the overlay, the
#: payload ones only in a map with a payload layer (:mod:`manipkit.analysis.reachmap.payload`).
MAP_ARRAYS = {"reach": "uint8", "voxel_q": "float64", "ik_keys": "int64", "ik_q": "float64",
              "cert_keys": "int64", "cert_q": "float64", "manipulability": "float64", "manipulability_mean": "float64",
              **PAYLOAD_ARRAYS}
MAX_JSON_DEPTH = 32  # nesting of a map's metadata (manipkit writes 4)
MAX_NAME_CHARS = 1000  # a robot, frame or joint name
MAX_JOINTS = 1000
MAX_COORDINATE = 1e9  # m: the grid origin
UNIT_TOL = 1e-6  # how far a stored unit vector or orthonormal axes may be off
ZSTD_MAGIC = b"\x28\xb5\x2f\xfd"
_STRINGS = re.compile(r'"(?:[^"\\]|\\.)*"')  # JSON strings, whose brackets do not nest
_BRACKETS = re.compile(r"[\[\]{}]")


class _Invalid(Exception):
    """What is wrong with a map (turned into one InputFileError naming the map)."""


# --------------------------------------------------------------------------
# Writing


def writable_map_path(path) -> Path:
    """``path`` if a map can be written there: its folder exists, and it is new or a map (to be replaced).

    Raises
    ------
    OutputError
        ``cannot write PATH: no such folder ...``, ``...: it exists and is not
        a reachability map``, ``...: it is a symbolic link`` or ``...: it holds
        NAME, which is not part of a reachability map``.
    """
    path = Path(path)
    parent = path.parent if str(path.parent) else Path(".")
    shown = printable(str(path))
    if not parent.is_dir():
        raise OutputError(f"cannot write {shown}: no such folder {printable(str(parent))}")
    if path.is_symlink():
        raise OutputError(f"cannot write {shown}: it is a symbolic link; give the name of a new folder")
    if path.exists():
        if not path.is_dir() or not _is_map(path):
            raise OutputError(f"cannot write {shown}: it exists and is not a reachability map; give a new name")
        try:
            _check_entries(path)
        except OSError as exc:
            raise cannot_write(shown, exc) from None
        except _Invalid as exc:
            raise OutputError(f"cannot write {shown}: {exc}; a map is replaced only when it holds nothing else "
                              "(move those files or give a new name)") from None
    return path


def resume_folder(path) -> Path:
    """The hidden sibling ``.NAME.partial`` of the map folder ``path``: where a build of it keeps finished blocks.

    (:mod:`manipkit.analysis.reachmap.blockstore`; the command line removes it once the map is saved.)

    >>> resume_folder("maps/iiwa.zarr").as_posix()
    'maps/.iiwa.zarr.partial'
    """
    path = Path(path)
    return path.with_name(f".{path.name}.partial")


def save_map(reach_map: ReachMap, path) -> Path:
    """Write ``reach_map`` to the folder ``path`` (see the module docstring); returns ``path``.

    Raises
    ------
    OutputError
        A path :func:`writable_map_path` refuses, or ``cannot write PATH: reason`` (a full disk, no permission).
    """
    path = writable_map_path(path)
    parent = path.parent if str(path.parent) else Path(".")
    try:
        partial = Path(tempfile.mkdtemp(prefix=f".{path.name}.writing-", dir=parent))
    except OSError as exc:
        raise cannot_write(printable(str(path)), exc) from None
    try:
        _write_arrays(reach_map, partial)
        _put_in_place(partial, path)
    except OSError as exc:
        raise cannot_write(printable(str(path)), exc) from None
    finally:
        _settle_zarr()  # a failed write leaves zarr's other writes running: let them end before the folder goes
        shutil.rmtree(partial, ignore_errors=True)
    return path


def _write_arrays(reach_map: ReachMap, folder: Path) -> None:
    import zarr
    from zarr.codecs import ZstdCodec

    root = zarr.open_group(str(folder), mode="w")
    options = {"compressors": ZstdCodec(level=0, checksum=False), "config": {"write_empty_chunks": True}}
    chunk = tuple(min(s, 16) for s in reach_map.shape) + (reach_map.reach.shape[3],)
    ik_rows = max(1, min(len(reach_map.ik_keys), 65536))
    root.create_array("reach", data=reach_map.reach, chunks=chunk, **options)
    root.create_array("voxel_q", data=reach_map.voxel_q, chunks=chunk[:3] + (reach_map.voxel_q.shape[3],), **options)
    root.create_array("ik_keys", data=reach_map.ik_keys.astype(np.int64), chunks=(ik_rows,), **options)
    root.create_array("ik_q", data=reach_map.ik_q, chunks=(ik_rows, reach_map.ik_q.shape[1]), **options)
    cert_rows = max(1, min(len(reach_map.cert_keys), 65536))
    root.create_array("cert_keys", data=reach_map.cert_keys.astype(np.int64), chunks=(cert_rows,), **options)
    root.create_array("cert_q", data=reach_map.cert_q, chunks=(cert_rows, reach_map.cert_q.shape[1]), **options)
    if reach_map.manipulability is not None:
        root.create_array("manipulability", data=reach_map.manipulability, chunks=chunk[:3], **options)
        root.create_array("manipulability_mean", data=reach_map.manipulability_mean, chunks=chunk[:3], **options)
    if reach_map.payload is not None:
        layer = reach_map.payload
        for name, values in (("payload_best", layer.best), ("payload_worst", layer.worst),
                             ("payload_saturating", layer.saturating.astype(np.int64))):
            root.create_array(name, data=values, chunks=chunk[:3], **options)
        root.create_array("payload_bins", data=layer.bins, chunks=(cert_rows,), **options)
        root.create_array("payload_bins_worst", data=layer.bins_worst, chunks=(cert_rows,), **options)
    root.attrs.update(reach_map.attrs())


def _put_in_place(partial: Path, path: Path) -> None:
    """Rename ``partial`` to ``path``; a map at ``path`` (checked again) is renamed aside first, then removed."""
    if not os.path.lexists(path):
        os.rename(partial, path)
        return
    writable_map_path(path)
    old = path.with_name(f".{path.name}.old-{secrets.token_hex(4)}")
    os.rename(path, old)
    try:
        os.rename(partial, path)
    except BaseException:
        os.rename(old, path)
        raise
    shutil.rmtree(old, ignore_errors=True)


def _settle_zarr() -> None:
    """Wait (a few seconds at most) for writes still running on zarr's event loop, so none is left pending."""
    import asyncio

    from zarr.core.sync import sync

    async def drain():
        tasks = [task for task in asyncio.all_tasks() if task is not asyncio.current_task()]
        if tasks:
            await asyncio.wait(tasks, timeout=5.0)

    try:
        sync(drain())
    except Exception:  # noqa: BLE001 - best effort: nothing is left to report
        pass


# --------------------------------------------------------------------------
# The folder and its metadata


def _is_map(path: Path) -> bool:
    """Whether ``path/zarr.json`` says it is a manipkit map (its attributes' ``format``)."""
    try:
        meta = _read_json(path / "zarr.json")
        return isinstance(meta, dict) and isinstance(meta.get("attributes"), dict) and \
            meta["attributes"].get("format") == FORMAT
    except (_Invalid, InputFileError):
        return False


def _read_json(path: Path):
    """A map's ``zarr.json``: a regular file of at most ``MAX_TABLE_BYTES``, JSON nested at most ``MAX_JSON_DEPTH``."""
    if path.is_symlink():
        raise _Invalid(f"{path.parent.name}/zarr.json is a symbolic link")
    text = read_text(path, what="reachability map metadata", max_bytes=MAX_TABLE_BYTES)
    depth = deepest = 0
    for bracket in _BRACKETS.findall(_STRINGS.sub("", text)):  # a depth bound before the parser recurses
        depth += 1 if bracket in "[{" else -1
        deepest = max(deepest, depth)
    if deepest > MAX_JSON_DEPTH:
        raise _Invalid(f"its metadata {path.name} is nested {deepest} levels deep, more than {MAX_JSON_DEPTH}")
    try:
        return json.loads(text)
    except ValueError as exc:
        raise _Invalid(f"its metadata is not JSON ({printable(str(exc))[:80]})") from None


def _check_entries(path: Path) -> None:
    """Every entry under ``path`` is one of a map's: zarr.json, the array folders, their zarr.json and chunks."""
    count = 0

    def entry(full: Path, folder: bool) -> None:
        nonlocal count
        count += 1
        if count > MAX_MAP_FILES:
            raise _Invalid(f"more than {MAX_MAP_FILES} entries, not a map manipkit wrote")
        mode = os.lstat(full).st_mode
        kind = stat.S_ISDIR(mode) if folder else stat.S_ISREG(mode)
        if stat.S_ISLNK(mode) or not kind:
            what = "a symbolic link" if stat.S_ISLNK(mode) else "not a regular file" if not folder else "not a folder"
            raise _Invalid(f"{printable(str(full.relative_to(path)))} is {what}")

    def stray(full: Path) -> _Invalid:
        return _Invalid(f"it holds {printable(str(full.relative_to(path)))}, which is not part of a reachability map")

    for top in sorted(os.listdir(path)):
        full = path / top
        if top == "zarr.json":
            entry(full, folder=False)
            continue
        if top not in MAP_ARRAYS:
            raise stray(full)
        entry(full, folder=True)
        for name in sorted(os.listdir(full)):
            if name not in ("zarr.json", "c"):
                raise stray(full / name)
            entry(full / name, folder=name == "c")
        chunks = full / "c"
        if not chunks.exists():
            continue
        for folder, folders, files in os.walk(chunks):
            for name in folders + files:
                if not name.isdigit():
                    raise stray(Path(folder) / name)
                entry(Path(folder) / name, folder=name in folders)


# --------------------------------------------------------------------------
# Reading


def read_map(path) -> dict:
    """The fields of the map stored in the folder ``path`` by :func:`save_map`, validated as a whole (module docstring).

    A dict of :class:`~manipkit.analysis.reachmap.map.ReachMap`'s fields by name
    (:func:`manipkit.analysis.reachmap.map.load` makes the map of them).

    Raises
    ------
    InputFileError
        No such folder, not a manipkit reachability map, or a map that fails a check (named).
    """
    path = Path(path)
    shown = printable(str(path))
    if not path.is_dir():
        raise InputFileError(f"{shown}: no such reachability map (a folder written by 'manipkit reachmap -o')")
    invalid = f"{shown}: not a valid reachability map"
    try:
        meta = _read_json(path / "zarr.json")
    except _Invalid as exc:
        raise InputFileError(f"{invalid}: {exc}") from None
    except InputFileError:
        meta = None
    if not isinstance(meta, dict) or not isinstance(meta.get("attributes"), dict) or \
            meta["attributes"].get("format") != FORMAT:
        older = isinstance(meta, dict) and isinstance(meta.get("attributes"), dict) and \
            str(meta["attributes"].get("format")).startswith("manipkit-reachmap-")
        raise InputFileError(f"{shown}: a reachability map of an older format (no certificates); rebuild it with "
                             f"'manipkit reachmap'" if older else
                             f"{shown}: not a manipkit reachability map (no '{FORMAT}' zarr.json in it)")
    try:
        _check_entries(path)
        a = _checked_attributes(meta)
        arrays = _read_arrays(path, a)
        _check_contents(arrays)
        payload = None if "payload" not in a else layer_from_stored(
            a["payload"], arrays, arrays["cert_keys"], a["orientations"].size, a["joint_names"])
    except (_Invalid, PayloadInvalid) as exc:
        raise InputFileError(f"{invalid}: {exc}; rebuild it with 'manipkit reachmap'") from None
    except OSError as exc:
        raise InputFileError(f"{shown}: cannot be read ({exc.strerror or exc})") from None
    return {"reach": arrays["reach"], "origin": a["origin"], "axes": a["axes"], "voxel": a["voxel"],
            "orientations": a["orientations"], "method": a["method"], "robot": a["robot"], "frame": a["frame"],
            "base": a["base"], "joint_names": a["joint_names"], "voxel_q": arrays["voxel_q"],
            "ik_keys": arrays["ik_keys"], "ik_q": arrays["ik_q"], "settings": a["settings"],
            "manipulability": arrays.get("manipulability"), "manipulability_mean": arrays.get("manipulability_mean"),
            "cert_keys": arrays["cert_keys"], "cert_q": arrays["cert_q"], "payload": payload}


def _real(value, what: str, low: float = -math.inf, high: float = math.inf) -> float:
    if isinstance(value, bool) or not isinstance(value, numbers.Real) or not math.isfinite(value) \
            or not low <= value <= high:
        raise _Invalid(f"{what} is {printable(repr(value))[:40]}; it must be a finite number from {low:g} to {high:g}")
    return float(value)


def _whole(value, what: str, low: int, high: int) -> int:
    if isinstance(value, bool) or not isinstance(value, int) or not low <= value <= high:
        raise _Invalid(f"{what} is {printable(repr(value))[:40]}; it must be a whole number from {low} to {high}")
    return value


def _vector(value, what: str, *, unit: bool = False) -> np.ndarray:
    if not isinstance(value, list) or len(value) != 3:
        raise _Invalid(f"{what} is {printable(repr(value))[:40]}; it must be 3 numbers")
    v = np.array([_real(x, what, -MAX_COORDINATE, MAX_COORDINATE) for x in value])
    if unit and abs(np.linalg.norm(v) - 1.0) > UNIT_TOL:
        raise _Invalid(f"{what} has length {np.linalg.norm(v):.6g}; it must be a unit vector")
    return v


def _name(value, what: str) -> str:
    if not isinstance(value, str) or not 0 < len(value) <= MAX_NAME_CHARS:
        raise _Invalid(f"{what} is {printable(repr(value))[:40]}; it must be a name of 1 to {MAX_NAME_CHARS} characters")
    return value


_COLLISION_KEYS = frozenset({"checked", "floor", "geometry", "srdf", "disabled_pairs"})  # CollisionSettings.as_dict


def _setting(value) -> bool:
    """A plain setting (number, name, flag or none), or the collision settings' table of them."""
    if isinstance(value, dict):
        return len(value) <= 16 and all(_setting(v) or _names(v) for v in value.values())
    return isinstance(value, str | int | float | bool | None)


def _names(value) -> bool:
    return isinstance(value, list) and len(value) <= 16 and all(isinstance(v, str) for v in value)


#: The build's record that the summary prints (query.checks_lines): whole numbers, shares and the checks' tables.
_WHOLE_SETTINGS = ("samples", "seed", "samples_used", "blocks", "fill_passes")
_SHARE_SETTINGS = ("converge", "checked_threshold")
_CHECKS = {"completeness": (("n", "hits"), ("rate", "low", "high")),
           "false_positive": (("drawn", "n", "failed"), ("rate", "high"))}
_OPTIONAL_CHECK_KEYS = ("hits", "drawn")  # maps of earlier builds lack them


def _checked_fields(table: dict, wholes, shares, where: str) -> None:
    """The entries of ``table`` named in ``wholes`` (whole numbers) and ``shares`` (in [0, 1]), where present."""
    for name in wholes:
        if name in table:
            _whole(table[name], f"{where}.{name}", 0, 2**63 - 1)
    for name in shares:
        if name in table:
            _real(table[name], f"{where}.{name}", 0.0, 1.0)


def _checked_build_record(settings: dict) -> None:
    """The settings the summary reads, checked where present: whole numbers, shares in [0, 1], the checks' tables
    (whole counts, shares, the IK mode a name); ``samples_used`` comes with ``blocks``."""
    _checked_fields(settings, _WHOLE_SETTINGS, _SHARE_SETTINGS, "settings")
    if "samples_used" in settings and "blocks" not in settings:
        raise _Invalid("settings.samples_used needs settings.blocks")
    for key, (wholes, shares) in _CHECKS.items():
        table = settings.get(key)
        if table is None:
            continue
        if not isinstance(table, dict):
            raise _Invalid(f"settings.{key} must be a table")
        needed = [name for name in (*wholes, *shares) if name not in _OPTIONAL_CHECK_KEYS]
        needed += ["mode"] if key == "false_positive" else []
        missing = [name for name in needed if name not in table]
        if missing:
            raise _Invalid(f"settings.{key} lacks {', '.join(missing)}")
        _checked_fields(table, wholes, shares, f"settings.{key}")
        if "mode" in table:
            _name(table["mode"], f"settings.{key}.mode")


def _checked_attributes(meta) -> dict:
    """The root attributes as Python values, every one checked (types, finite, ranges, kinds, consistency)."""
    if meta.get("zarr_format") != 3 or meta.get("node_type") != "group" or meta.get("consolidated_metadata"):
        raise _Invalid("its zarr.json is not the plain Zarr v3 group manipkit writes")
    a = meta["attributes"]
    out = {name: _name(a.get(name), name) for name in ("robot", "frame", "base")}
    names = a.get("joint_names")
    if not isinstance(names, list) or len(names) > MAX_JOINTS:
        raise _Invalid(f"joint_names must be a list of at most {MAX_JOINTS} names")
    out["joint_names"] = tuple(_name(n, "a joint name") for n in names)
    out["voxel"] = _real(a.get("voxel"), "voxel", MIN_VOXEL, MAX_VOXEL)
    out["origin"] = _vector(a.get("origin"), "origin")
    rows = a.get("axes")
    if not isinstance(rows, list) or len(rows) != 3:
        raise _Invalid("axes must be a 3x3 matrix")
    axes = np.array([_vector(row, "axes") for row in rows])
    if not np.allclose(axes.T @ axes, np.eye(3), atol=UNIT_TOL) or np.linalg.det(axes) < 0:
        raise _Invalid("axes are not orthonormal and right-handed (a rotation)")
    out["axes"] = axes
    if a.get("method") not in METHODS:
        raise _Invalid(f"method is {printable(repr(a.get('method')))[:40]}; it must be one of {', '.join(METHODS)}")
    out["method"] = a["method"]
    o = a.get("orientations")
    if not isinstance(o, dict) or o.get("kind") not in ("spatial", "planar"):
        raise _Invalid("orientations.kind must be 'spatial' or 'planar'")
    n_dir = _whole(o.get("n_directions"), "orientations.n_directions", 1, MAX_BINS)
    n_roll = _whole(o.get("n_rolls"), "orientations.n_rolls", 1, MAX_BINS)
    if n_dir * n_roll > MAX_BINS:
        raise _Invalid(f"{n_dir}x{n_roll} orientation bins, more than {MAX_BINS}")
    if o["kind"] == "spatial":
        out["orientations"] = spatial_orientations(n_dir, n_roll)
    else:
        axis, u = _vector(o.get("axis"), "orientations.axis", unit=True), _vector(o.get("u"), "orientations.u", unit=True)
        tool_axis = _vector(o.get("tool_axis"), "orientations.tool_axis", unit=True)
        tool_vector = _vector(o.get("tool_vector"), "orientations.tool_vector", unit=True)
        if n_dir != 1 or abs(axis @ u) > UNIT_TOL or abs(tool_axis @ tool_vector) > UNIT_TOL:
            raise _Invalid("planar orientations need one direction and perpendicular axis/u, tool_axis/tool_vector")
        if not (np.allclose(axes[:, 2], axis, atol=UNIT_TOL) and np.allclose(axes[:, 0], u, atol=UNIT_TOL)):
            raise _Invalid("a planar map's axes must be (u, axis x u, axis) of its orientations")
        out["orientations"] = planar_orientations(n_roll, axis, u, tool_axis, tool_vector)
    settings = a.get("settings")
    if not isinstance(settings, dict) or not all(_setting(v) for v in settings.values()):
        raise _Invalid("settings must be a table of numbers, names and flags")
    collisions = settings.get("collisions")
    if collisions is not None and not (isinstance(collisions, dict) and set(collisions) <= _COLLISION_KEYS
                                       and all(_setting(v) or _names(v) for v in collisions.values())):
        raise _Invalid(f"settings.collisions must be a table of {', '.join(sorted(_COLLISION_KEYS))}")
    _checked_build_record(settings)
    out["settings"] = dict(settings)
    if "payload" in a:
        out["payload"] = a["payload"]  # checked with its arrays (payload.layer_from_stored)
    return out


def _array_meta(path: Path, name: str) -> tuple[tuple[int, ...], tuple[int, ...]]:
    """(shape, chunk shape) of array ``name`` if its zarr.json is the plain one manipkit writes."""
    meta = _read_json(path / name / "zarr.json")
    plain = (isinstance(meta, dict) and meta.get("zarr_format") == 3 and meta.get("node_type") == "array"
             and meta.get("data_type") == MAP_ARRAYS[name] and not meta.get("storage_transformers")
             and meta.get("chunk_key_encoding") == {"name": "default", "configuration": {"separator": "/"}})
    codecs = meta.get("codecs") if isinstance(meta, dict) else None
    if not plain or not isinstance(codecs, list) or len(codecs) != 2 or not all(isinstance(c, dict) for c in codecs) \
            or codecs[0].get("name") != "bytes" or codecs[0].get("configuration", {"endian": "little"}) != \
            {"endian": "little"} or codecs[1].get("name") != "zstd":
        raise _Invalid(f"array {name}: its zarr.json is not the {MAP_ARRAYS[name]} Zarr v3 array with bytes and zstd "
                       "codecs manipkit writes")
    grid = meta.get("chunk_grid")
    shape = meta.get("shape")
    chunk = grid.get("configuration", {}).get("chunk_shape") if isinstance(grid, dict) and \
        grid.get("name") == "regular" and isinstance(grid.get("configuration"), dict) else None
    if not isinstance(shape, list) or not isinstance(chunk, list) or len(shape) != len(chunk):
        raise _Invalid(f"array {name}: shape and chunk shape must be lists of the same length")
    shape = tuple(_whole(s, f"array {name}: a dimension", 0, 2**31) for s in shape)
    chunk = tuple(_whole(c, f"array {name}: a chunk dimension", 1, max(s, 1)) for c, s in zip(chunk, shape))
    return shape, chunk


def _read_arrays(path: Path, a: dict) -> dict:
    """Every array of the map, shapes checked against the attributes and the memory bound before any is read."""
    names = [name for name in MAP_ARRAYS if (path / name).exists()]
    overlay = [name for name in ("manipulability", "manipulability_mean") if name in names]
    missing = [name for name in ("reach", "voxel_q", "ik_keys", "ik_q", "cert_keys", "cert_q") if name not in names]
    if missing or len(overlay) == 1:
        raise _Invalid(f"array {(missing or ['manipulability', 'manipulability_mean'])[0]} is missing")
    layer = [name for name in PAYLOAD_ARRAYS if name in names]
    if layer and len(layer) != len(PAYLOAD_ARRAYS) or bool(layer) != ("payload" in a):
        raise _Invalid("a payload layer needs its attribute and every one of its arrays "
                       f"({', '.join(PAYLOAD_ARRAYS)})")
    metas = {name: _array_meta(path, name) for name in names}
    shape, n_joints, n_bins = metas["reach"][0], len(a["joint_names"]), a["orientations"].size
    grid = shape[:3]
    K = metas["ik_keys"][0][0] if len(metas["ik_keys"][0]) == 1 else -1
    C = metas["cert_keys"][0][0] if len(metas["cert_keys"][0]) == 1 else -1
    expected = {"reach": grid + (n_bins,), "voxel_q": grid + (n_joints,), "ik_keys": (K,), "ik_q": (K, n_joints),
                "cert_keys": (C,), "cert_q": (C, n_joints), "manipulability": grid, "manipulability_mean": grid,
                "payload_best": grid, "payload_worst": grid, "payload_saturating": grid, "payload_bins": (C,),
                "payload_bins_worst": (C,)}
    if len(shape) != 4 or shape[3] != n_bins or any(metas[n][0] != expected[n] for n in names) or min(K, C) < 0:
        raise _Invalid(f"array shapes that disagree with the attributes (reach {shape}, {n_bins} orientation bins, "
                       f"{n_joints} joints)")
    if a["orientations"].kind == "planar" and (grid[2] != 1 or grid[0] != grid[1]):
        raise _Invalid(f"a planar map has a square of voxels in one layer; this one has {'x'.join(map(str, grid))}")
    if a["orientations"].kind == "spatial" and (len(set(grid)) != 1 or not np.array_equal(a["axes"], np.eye(3))):
        raise _Invalid("a spatial map has identity axes and a cube of voxels")
    if min(grid) < 1 or map_bytes(math.prod(grid), n_bins, n_joints) + 16 * (K + C) * (n_joints + 1) > MAX_GRID_BYTES:
        raise _Invalid(f"a grid of {'x'.join(map(str, grid))} voxels: empty, or arrays larger than {MAX_GRID_BYTES} bytes")
    return {name: _read_array(path / name, name, *metas[name]) for name in names}


def zstd_content_size(data: bytes) -> int | None:
    """The decompressed size declared by ``data`` if it is exactly one zstd frame that declares it, else None.

    The frame header (RFC 8878, 3.1.1.1) gives the size; the blocks are
    walked to the frame's end (and its checksum), which must be the end of
    ``data``: a second frame (whose size a decoder would add) or trailing
    bytes give None.

    >>> zstd_content_size(bytes.fromhex("28b52ffd2004" "210000" "00000000"))  # one raw block of 4 bytes
    4
    >>> zstd_content_size(bytes.fromhex("28b52ffd2004" "210000" "00000000") * 2) is None  # two frames
    True
    """
    if len(data) < 6 or data[:4] != ZSTD_MAGIC:
        return None
    descriptor = data[4]
    single, checksum = (descriptor >> 5) & 1, (descriptor >> 2) & 1
    size_bytes = (1 if single else 0, 2, 4, 8)[descriptor >> 6]
    start = 5 + (0 if single else 1) + (0, 1, 2, 4)[descriptor & 3]
    if descriptor & 0x08 or size_bytes == 0 or len(data) < start + size_bytes:
        return None
    value = int.from_bytes(data[start:start + size_bytes], "little") + (256 if size_bytes == 2 else 0)
    position, last = start + size_bytes, False
    while not last:  # block headers: 3 bytes, little-endian: last flag, type, size
        if len(data) < position + 3:
            return None
        header = int.from_bytes(data[position:position + 3], "little")
        last, kind, size = header & 1, (header >> 1) & 3, header >> 3
        if kind == 3:  # reserved
            return None
        position += 3 + (1 if kind == 1 else size)  # an RLE block stores one byte
    position += 4 if checksum else 0
    return value if position == len(data) else None


def _read_array(folder: Path, name: str, shape: tuple[int, ...], chunk: tuple[int, ...]) -> np.ndarray:
    """Array ``name``, every chunk present, a regular file whose zstd frame declares exactly its chunk's bytes."""
    from numcodecs.zstd import Zstd

    dtype = np.dtype(MAP_ARRAYS[name]).newbyteorder("<")
    out = np.empty(shape, dtype=dtype)
    chunk_bytes = math.prod(chunk) * dtype.itemsize
    codec = Zstd()
    for index in np.ndindex(*(-(-s // c) for s, c in zip(shape, chunk))):
        key = "/".join(map(str, index))
        where = f"chunk {name}/c/{key}"
        try:
            fd = os.open(folder / "c" / key, os.O_RDONLY | os.O_NOFOLLOW | os.O_NONBLOCK)
        except FileNotFoundError:
            raise _Invalid(f"{where} is missing (a truncated or partial copy?)") from None
        with os.fdopen(fd, "rb") as handle:
            info = os.fstat(handle.fileno())
            if not stat.S_ISREG(info.st_mode):
                raise _Invalid(f"{where} is not a regular file")
            if info.st_size > chunk_bytes + chunk_bytes // 64 + 1024:
                raise _Invalid(f"{where} is {info.st_size} bytes, more than its chunk of {chunk_bytes} bytes compresses to")
            data = handle.read()
        declared = zstd_content_size(data)
        if declared is None:
            raise _Invalid(f"{where} is not one zstd frame that declares its size (as manipkit writes)")
        if declared != chunk_bytes:
            raise _Invalid(f"{where} declares {declared} bytes; its chunk holds {chunk_bytes}")
        try:
            raw = codec.decode(data)
        except (RuntimeError, ValueError, MemoryError) as exc:
            raise _Invalid(f"{where} cannot be decompressed ({printable(str(exc))[:60]})") from None
        if len(raw) != chunk_bytes:
            raise _Invalid(f"{where} holds {len(raw)} bytes, not {chunk_bytes}")
        block = np.frombuffer(raw, dtype=dtype).reshape(chunk)
        target = tuple(slice(i * c, min((i + 1) * c, s)) for i, c, s in zip(index, chunk, shape))
        out[target] = block[tuple(slice(0, t.stop - t.start) for t in target)]
    return out.astype(MAP_ARRAYS[name])


def _check_contents(arrays: dict) -> None:
    """Reach codes, IK keys (sorted, unique, in range, marked HOW_IK) and finite values."""
    reach, keys = arrays["reach"], arrays["ik_keys"]
    if reach.size and int(reach.max()) > max(HOW_NONE, HOW_SAMPLE, HOW_IK):
        raise _Invalid(f"reach holds the code {int(reach.max())}; codes are {HOW_NONE}, {HOW_SAMPLE} and {HOW_IK}")
    if keys.size and (keys[0] < 0 or keys[-1] >= reach.size or np.any(np.diff(keys) <= 0)):
        raise _Invalid("ik_keys are not increasing voxel-bin indices inside the grid")
    if keys.size != int((reach == HOW_IK).sum()) or (keys.size and np.any(reach.reshape(-1)[keys] != HOW_IK)):
        raise _Invalid("ik_keys disagree with the voxel-bins reach marks as reached by IK")
    cert = arrays["cert_keys"]
    if cert.size != int((reach > HOW_NONE).sum()) or (cert.size and (np.any(np.diff(cert) <= 0) or cert[0] < 0
                                                                     or cert[-1] >= reach.size
                                                                     or np.any(reach.reshape(-1)[cert] == HOW_NONE))):
        raise _Invalid("cert_keys are not exactly the reached voxel-bins, increasing (one certificate each)")
    if np.isinf(arrays["voxel_q"]).any() or not np.isfinite(arrays["ik_q"]).all() or \
            not np.isfinite(arrays["cert_q"]).all():
        raise _Invalid("configurations that are not finite")
    for name in ("manipulability", "manipulability_mean"):
        values = arrays.get(name)
        if values is not None and (np.isinf(values).any() or (values < 0).any()):
            raise _Invalid(f"{name} holds values that are not finite and >= 0")
