"""World files: a few obstacles (boxes, spheres, cylinders) fixed in the robot's root link frame.

A world file is YAML (metres and radians; ``rpy`` as in URDF,
R = Rz(yaw) Ry(pitch) Rx(roll))::

    obstacles:
      - name: table
        box: [1.0, 0.6, 0.04]      # size along x, y, z
        xyz: [0.5, 0.0, -0.02]     # centre in the root link's frame
        rpy: [0, 0, 0]
      - name: ball
        sphere: 0.1                # radius
        xyz: [0.4, 0.2, 0.3]
      - name: post
        cylinder: [0.05, 1.0]      # radius, length (along the obstacle's z)
        xyz: [-0.4, 0, 0.5]

:func:`read_world` turns it into ``(name, coal shape, T_root_obstacle)``
triples for :class:`manipkit.kinematics.collisions.CollisionChecker`.
"""

from __future__ import annotations

import math
import os

import coal
import numpy as np

from manipkit.errors import CollisionError
from manipkit.spatial.rotations import matrix_from_rpy
from manipkit.text import printable

__all__ = ["MAX_OBSTACLES", "MAX_WORLD_BYTES", "SHAPES", "read_world", "world_obstacles"]

#: Largest world file read (bytes) and most obstacles in one.
MAX_WORLD_BYTES = 1024 * 1024
MAX_OBSTACLES = 1000
#: Shape keys and what their value is.
SHAPES = {"box": "[x, y, z] sizes", "sphere": "a radius", "cylinder": "[radius, length]"}
_KEYS = {"name", "xyz", "rpy", *SHAPES}


def read_world(path: str | os.PathLike) -> list[tuple[str, object, np.ndarray]]:
    """The obstacles of a world file: ``(name, coal shape, T_root_obstacle)`` each (see the module docstring).

    Raises
    ------
    CollisionError
        Not YAML, or an obstacle that is malformed: the message names the
        file, the obstacle and the field, and says what is valid.
    InputFileError
        The file cannot be read (missing, a folder, too large).
    """
    import yaml

    from manipkit.inputs.files import read_text

    where = printable(str(path))
    text = read_text(path, what="world file", max_bytes=MAX_WORLD_BYTES)
    try:
        document = yaml.safe_load(text)
    except yaml.YAMLError as exc:
        raise CollisionError(f"{where}: not valid YAML: {' '.join(str(exc).split())}") from None
    return world_obstacles(document, where=where)


def world_obstacles(document, *, where: str = "world") -> list[tuple[str, object, np.ndarray]]:
    """:func:`read_world` on a document already read (a dict with an ``obstacles`` list)."""
    if not isinstance(document, dict) or set(document) != {"obstacles"}:
        raise CollisionError(f"{where}: a world file is a mapping with one key, 'obstacles' (a list of boxes, "
                             "spheres and cylinders)")
    entries = document["obstacles"]
    if not isinstance(entries, list):
        raise CollisionError(f"{where}: 'obstacles' must be a list")
    if len(entries) > MAX_OBSTACLES:
        raise CollisionError(f"{where}: {len(entries)} obstacles; at most {MAX_OBSTACLES}")
    obstacles, names = [], set()
    for number, entry in enumerate(entries, 1):
        label = f"{where}: obstacle {number}"
        if not isinstance(entry, dict):
            raise CollisionError(f"{label}: expected a mapping with a shape ({', '.join(SHAPES)}) and xyz/rpy")
        unknown = sorted(str(k) for k in entry if k not in _KEYS)
        if unknown:
            raise CollisionError(f"{label}: unknown key '{printable(unknown[0])}'; keys: {', '.join(sorted(_KEYS))}")
        name = entry.get("name", f"obstacle_{number}")
        if not isinstance(name, str) or not name.strip():
            raise CollisionError(f"{label}: 'name' must be a non-empty string")
        label = f"{where}: obstacle '{printable(name)}'"
        if name in names:
            raise CollisionError(f"{label}: the name is used twice; give each obstacle its own name")
        names.add(name)
        shapes = [key for key in SHAPES if key in entry]
        if len(shapes) != 1:
            raise CollisionError(f"{label}: give exactly one shape: box {SHAPES['box']}, sphere {SHAPES['sphere']} "
                                 f"or cylinder {SHAPES['cylinder']}")
        kind = shapes[0]
        size = _numbers(entry[kind], {"box": 3, "sphere": 1, "cylinder": 2}[kind], f"{label}: {kind}", positive=True)
        shape = {"box": lambda s: coal.Box(*s), "sphere": lambda s: coal.Sphere(s[0]),
                 "cylinder": lambda s: coal.Cylinder(s[0], s[1])}[kind](size)
        xyz = _numbers(entry.get("xyz", [0, 0, 0]), 3, f"{label}: xyz")
        roll, pitch, yaw = _numbers(entry.get("rpy", [0, 0, 0]), 3, f"{label}: rpy")
        T = np.eye(4)
        T[:3, :3] = matrix_from_rpy(roll, pitch, yaw)
        T[:3, 3] = xyz
        obstacles.append((name, shape, T))
    return obstacles


def _numbers(value, count: int, label: str, *, positive: bool = False) -> list[float]:
    values = [value] if count == 1 and not isinstance(value, list) else value
    if not isinstance(values, list) or len(values) != count:
        raise CollisionError(f"{label}: expected {count} number{'s' if count > 1 else ''}, got {printable(repr(value))}")
    numbers = []
    for v in values:
        if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v):
            raise CollisionError(f"{label}: '{printable(repr(v))}' is not a finite number")
        if positive and v <= 0:
            raise CollisionError(f"{label}: {v} must be positive (m)")
        numbers.append(float(v))
    return numbers

