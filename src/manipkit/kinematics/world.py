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
import re

import coal
import numpy as np

from manipkit.bounds import MAX_ANGLE, MAX_LENGTH, MIN_LENGTH
from manipkit.errors import CollisionError
from manipkit.spatial.rotations import matrix_from_rpy
from manipkit.text import UNPRINTABLE, printable, repr_text

__all__ = ["MAX_NAME_CHARS", "MAX_OBSTACLES", "MAX_WORLD_BYTES", "SHAPES", "read_world", "world_obstacles"]

#: Largest world file read (bytes), most obstacles in one, longest obstacle name.
MAX_WORLD_BYTES = 1024 * 1024
MAX_OBSTACLES = 1000
MAX_NAME_CHARS = 100
#: How much of a value or a name an error message quotes.
_QUOTED = 40
#: Most YAML nodes in a world document (an alias tree of 2 kB names 2**60 nodes: refused, not walked).
_MAX_NODES = 100_000
#: Deepest nesting of a world document (an obstacle is 3 levels deep).
_MAX_DEPTH = 100
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
    from manipkit.inputs.files import read_text
    from manipkit.inputs.yamls import load_yaml

    where = printable(str(path))
    text = read_text(path, what="world file", max_bytes=MAX_WORLD_BYTES)
    document = load_yaml(text, where, error=CollisionError, max_depth=_MAX_DEPTH, max_nodes=_MAX_NODES)
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
        unknown = [k for k in entry if not isinstance(k, str) or k not in _KEYS]
        if unknown:
            raise CollisionError(f"{label}: unknown key {repr_text(unknown[0], _QUOTED) if isinstance(unknown[0], str) else 'of type ' + type(unknown[0]).__name__}; "
                                 f"keys: {', '.join(sorted(_KEYS))}")
        name = entry.get("name", f"obstacle_{number}")
        if not isinstance(name, str) or not name.strip():
            raise CollisionError(f"{label}: 'name' must be a non-empty string")
        if len(name) > MAX_NAME_CHARS or UNPRINTABLE.search(name):
            raise CollisionError(f"{label}: name {repr_text(name, _QUOTED)} ({len(name)} characters): a name is one "
                                 f"line of at most {MAX_NAME_CHARS} printable characters")
        label = f"{where}: obstacle '{printable(name)}'"
        if name in names:
            raise CollisionError(f"{label}: the name is used twice; give each obstacle its own name")
        names.add(name)
        shapes = [key for key in SHAPES if key in entry]
        if len(shapes) != 1:
            raise CollisionError(f"{label}: give exactly one shape: box {SHAPES['box']}, sphere {SHAPES['sphere']} "
                                 f"or cylinder {SHAPES['cylinder']}")
        kind = shapes[0]
        size = _numbers(entry[kind], {"box": 3, "sphere": 1, "cylinder": 2}[kind], f"{label}: {kind}", bound=MAX_LENGTH,
                        positive=True)
        shape = {"box": lambda s: coal.Box(*s), "sphere": lambda s: coal.Sphere(s[0]),
                 "cylinder": lambda s: coal.Cylinder(s[0], s[1])}[kind](size)
        xyz = _numbers(entry.get("xyz", [0, 0, 0]), 3, f"{label}: xyz", bound=MAX_LENGTH)
        roll, pitch, yaw = _numbers(entry.get("rpy", [0, 0, 0]), 3, f"{label}: rpy", bound=MAX_ANGLE)
        T = np.eye(4)
        T[:3, :3] = matrix_from_rpy(roll, pitch, yaw)
        T[:3, 3] = xyz
        obstacles.append((name, shape, T))
    return obstacles


_NUMBER = re.compile(r"[-+]?(\d+\.?\d*|\.\d+)([eE][-+]?\d+)?")  # 1e-3, which YAML 1.1 reads as text


def _numbers(value, count: int, label: str, *, bound: float, positive: bool = False) -> list[float]:
    """``count`` finite numbers, ``|v| <= bound`` (a size: ``MIN_LENGTH <= v``); messages quote a bounded prefix."""
    values = [value] if count == 1 and not isinstance(value, list) else value
    if not isinstance(values, list) or len(values) != count:
        got = f"{len(values)} values" if isinstance(values, list) else _quoted(value)
        raise CollisionError(f"{label}: expected {count} number{'s' if count > 1 else ''}, got {got}")
    numbers = []
    for v in values:
        if isinstance(v, str) and len(v) <= 40 and _NUMBER.fullmatch(v.strip()):
            v = float(v)
        if isinstance(v, bool) or not isinstance(v, (int, float)):
            raise CollisionError(f"{label}: {_quoted(v)} is not a number")
        try:
            number = float(v)
        except OverflowError:  # an integer of 400 digits
            number = math.inf
        if math.isnan(number) or (math.isinf(number) and isinstance(v, float)):
            raise CollisionError(f"{label}: '{_quoted(v)}' is not a finite number")
        if not abs(number) <= bound:
            raise CollisionError(f"{label}: {_quoted(v)} is beyond +-{bound:g} (a finite number of "
                                 f"{'metres' if bound == MAX_LENGTH else 'radians'} within the bounds of manipkit)")
        if positive and number < MIN_LENGTH:
            raise CollisionError(f"{label}: {number:g} must be positive, at least {MIN_LENGTH:g} m")
        numbers.append(number)
    return numbers


def _quoted(value) -> str:
    """A bounded quote of a YAML value: numbers and short texts as written, containers by their type and size
    (never formatted whole: an alias tree would be exponentially long)."""
    if isinstance(value, (list, dict)):
        return f"a {'list' if isinstance(value, list) else 'mapping'} of {len(value)} entries"
    if isinstance(value, int) and not isinstance(value, bool) and value.bit_length() > 128:
        return f"an integer of about {int(value.bit_length() * 0.30103) + 1} digits"
    return repr_text(value, _QUOTED)

