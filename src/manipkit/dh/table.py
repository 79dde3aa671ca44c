"""Denavit-Hartenberg tables: data, forward kinematics, files, printing, symbols, URDF.

Conventions (DESIGN.md):

- Standard DH (Spong, Corke ``DHRobot``), one row per joint i:
  ``A_i = Rz(theta_i) Tz(d_i) Tx(a_i) Rx(alpha_i)``; joint i moves about (or
  along) ``z_{i-1}``.
- Modified DH (Craig), row i holds ``a_{i-1}, alpha_{i-1}, d_i, theta_i``:
  ``A_i = Rx(alpha_{i-1}) Tx(a_{i-1}) Rz(theta_i) Tz(d_i)``; joint i moves
  about (or along) ``z_i``.
- For a revolute row, ``theta`` is the constant offset added to the joint
  value; for a prismatic row, ``d`` is.
- ``T_base_tool(q) = base @ A_1(q_1) @ ... @ A_n(q_n) @ tool``.
- Metres and radians inside; a file may give angles in degrees.
- ``rpy`` (base and tool placements) is ``(roll, pitch, yaw)`` with
  ``R = Rz(yaw) Ry(pitch) Rx(roll)``, as in URDF.

What is here:

- :class:`DHRow`, :class:`DHTable`, :func:`dh_link_transform`, :func:`dh_fk`:
  the numeric core.
- :func:`load_dh`, :func:`save_dh`, :func:`dh_from_yaml`, :func:`yaml_from_dh`:
  the table file format (DESIGN.md, "DH table files").
- :func:`format_dh_table`: the boxed printout (``str(table)``).
- :func:`dh_fk_symbolic`, :func:`shorthand`, :func:`format_symbolic`: forward
  kinematics in SymPy.
- :func:`urdf_from_dh`: a URDF whose chain equals the table's exactly.

numpy only at import time (SymPy and PyYAML are imported inside the functions
that need them).
"""

from __future__ import annotations

import difflib
import math
import os
import re
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from manipkit.errors import DHTableError
from manipkit.spatial.rotations import matrix_from_rpy, rpy_from_matrix
from manipkit.spatial.transforms import transform_from_xyz_rpy

__all__ = [
    "CONVENTIONS",
    "JOINT_TYPES",
    "DHRow",
    "DHTable",
    "dh_fk",
    "dh_fk_symbolic",
    "dh_from_yaml",
    "dh_link_transform",
    "dh_symbols",
    "format_dh_table",
    "format_symbolic",
    "load_dh",
    "save_dh",
    "shorthand",
    "transform_from_xyz_rpy",
    "urdf_from_dh",
    "yaml_from_dh",
]

CONVENTIONS = ("standard", "modified")
JOINT_TYPES = ("revolute", "prismatic")
ANGLE_UNITS = ("rad", "deg")


@dataclass(frozen=True)
class DHRow:
    """One joint's DH parameters (metres, radians).

    Attributes
    ----------
    a, alpha, d, theta : float
        Link length, link twist, link offset, joint angle (standard DH), or
        ``a_{i-1}, alpha_{i-1}, d_i, theta_i`` (modified DH). ``theta`` (revolute)
        or ``d`` (prismatic) is the offset added to the joint value.
    type : str
        ``"revolute"`` (default) or ``"prismatic"``.
    qlim : tuple of float, optional
        Joint limits ``(lower, upper)`` (rad or m), if known.
    name : str, optional
        The joint's name (e.g. the URDF joint it stands for); ``""`` if none.

    Examples
    --------
    >>> DHRow(0, np.pi / 2, 0.36, 0).is_revolute
    True
    """

    a: float
    alpha: float
    d: float
    theta: float
    type: str = "revolute"
    qlim: tuple[float, float] | None = None
    name: str = ""

    def __post_init__(self):
        for attribute in ("a", "alpha", "d", "theta"):
            object.__setattr__(self, attribute, float(getattr(self, attribute)))
        if self.type not in JOINT_TYPES:
            raise ValueError(f"DH row type '{self.type}': choose revolute or prismatic")
        if self.qlim is not None:
            lower, upper = (float(v) for v in self.qlim)
            object.__setattr__(self, "qlim", (lower, upper))
        object.__setattr__(self, "name", str(self.name))

    @property
    def is_revolute(self) -> bool:
        return self.type == "revolute"


@dataclass(frozen=True, eq=False)
class DHTable:
    """A DH table with optional base and tool transforms.

    Attributes
    ----------
    rows : tuple of DHRow
        One row per movable joint, base to tip.
    convention : str
        ``"standard"`` or ``"modified"``.
    name : str
        A label for printing.
    base, tool : ndarray, shape (4, 4)
        Constant transforms before the first row and after the last.
    base_rpy, tool_rpy : tuple of float, optional
        The roll-pitch-yaw angles (rad, ``R = Rz(yaw) Ry(pitch) Rx(roll)``)
        ``base`` and ``tool`` were built from, when known (:func:`load_dh`
        keeps the file's). :func:`save_dh` writes them back instead of
        recomputing them from the matrix, as long as they still give the
        matrix's rotation exactly, so a file round-trips to the bit. They take
        no part in ``==``.

    Notes
    -----
    Two tables are equal (``==``) when their rows, convention, name, base and
    tool are equal (exact comparison).

    Examples
    --------
    >>> table = DHTable([DHRow(1, 0, 0, 0), DHRow(1, 0, 0, 0)], "standard", "planar 2R")
    >>> table.n
    2
    """

    rows: tuple[DHRow, ...]
    convention: str = "standard"
    name: str = ""
    base: np.ndarray = field(default_factory=lambda: np.eye(4))
    tool: np.ndarray = field(default_factory=lambda: np.eye(4))
    base_rpy: tuple[float, float, float] | None = None
    tool_rpy: tuple[float, float, float] | None = None

    def __post_init__(self):
        if self.convention not in CONVENTIONS:
            raise ValueError(f"convention '{self.convention}': choose standard or modified")
        object.__setattr__(self, "rows", tuple(self.rows))
        for i, row in enumerate(self.rows, start=1):
            if not isinstance(row, DHRow):
                raise TypeError(f"DH table row {i} is a {type(row).__name__}, not a DHRow")
        for attribute in ("base", "tool"):
            matrix = np.array(getattr(self, attribute), dtype=float)
            if matrix.shape != (4, 4):
                raise ValueError(f"DH table {attribute} must be a 4x4 transform, got shape {matrix.shape}")
            object.__setattr__(self, attribute, matrix)
            rpy = getattr(self, f"{attribute}_rpy")
            if rpy is not None:
                object.__setattr__(self, f"{attribute}_rpy", tuple(float(v) for v in rpy))

    def __eq__(self, other):
        if not isinstance(other, DHTable):
            return NotImplemented
        return (
            self.rows == other.rows
            and self.convention == other.convention
            and self.name == other.name
            and np.array_equal(self.base, other.base)
            and np.array_equal(self.tool, other.tool)
        )

    __hash__ = None

    def __str__(self) -> str:
        return format_dh_table(self)

    @property
    def n(self) -> int:
        """Number of joints."""
        return len(self.rows)


def dh_link_transform(a, alpha, d, theta, *, convention: str) -> np.ndarray:
    """The transform of one DH row, vectorised over its arguments.

    Parameters
    ----------
    a, alpha, d, theta : array_like, broadcastable
        Metres and radians (the values including the joint variable).
    convention : {"standard", "modified"}, keyword-only
        Standard: ``Rz(theta) Tz(d) Tx(a) Rx(alpha)``;
        modified: ``Rx(alpha) Tx(a) Rz(theta) Tz(d)``.

    Returns
    -------
    A : ndarray, shape (..., 4, 4)

    Examples
    --------
    >>> A = dh_link_transform(1.0, 0.0, 0.0, np.pi / 2, convention="standard")
    >>> np.round(A[:3, 3], 12)  # link along x turned by 90 deg about z
    array([0., 1., 0.])
    """
    a, alpha, d, theta = np.broadcast_arrays(*(np.asarray(v, dtype=float) for v in (a, alpha, d, theta)))
    ct, st = np.cos(theta), np.sin(theta)
    ca, sa = np.cos(alpha), np.sin(alpha)
    zero, one = np.zeros_like(a), np.ones_like(a)
    if convention == "standard":
        rows = [
            [ct, -st * ca, st * sa, a * ct],
            [st, ct * ca, -ct * sa, a * st],
            [zero, sa, ca, d],
        ]
    elif convention == "modified":
        rows = [
            [ct, -st, zero, a],
            [st * ca, ct * ca, -sa, -d * sa],
            [st * sa, ct * sa, ca, d * ca],
        ]
    else:
        raise ValueError(f"convention '{convention}': choose standard or modified")
    rows.append([zero, zero, zero, one])
    return np.stack([np.stack(row, axis=-1) for row in rows], axis=-2)


def dh_fk(table: DHTable, q, *, upto: int | None = None) -> np.ndarray:
    """T_base_tool of a DH table, vectorised over configurations.

    Parameters
    ----------
    table : DHTable
    q : array_like, shape (..., n)
        Joint values (rad for revolute rows, m for prismatic rows).
    upto : int, optional
        Stop after this many rows and leave out the tool: the pose of DH
        frame ``upto`` in the base (``upto=0`` gives ``table.base``).

    Returns
    -------
    T : ndarray, shape (..., 4, 4)

    Examples
    --------
    >>> table = DHTable((DHRow(1.0, 0.0, 0.0, 0.0), DHRow(1.0, 0.0, 0.0, 0.0)))
    >>> np.round(dh_fk(table, [0.0, np.pi / 2])[:3, 3], 12)  # planar 2R, elbow at 90 deg
    array([1., 1., 0.])
    """
    q = np.asarray(q, dtype=float)
    if q.shape[-1:] != (table.n,):
        raise ValueError(f"DH table '{table.name}' has {table.n} rows; q has shape {q.shape}")
    count = table.n if upto is None else upto
    T = np.broadcast_to(table.base, q.shape[:-1] + (4, 4)).copy()
    for i, row in enumerate(table.rows[:count]):
        qi = q[..., i]
        theta = row.theta + qi if row.is_revolute else np.full_like(qi, row.theta)
        d = np.full_like(qi, row.d) if row.is_revolute else row.d + qi
        T = T @ dh_link_transform(row.a, row.alpha, d, theta, convention=table.convention)
    return T @ table.tool if upto is None else T


# --------------------------------------------------------------------------
# files


_TOP_FIELDS = ("name", "convention", "angles", "base", "tool", "joints")
_ROW_FIELDS = ("a", "alpha", "d", "theta")
_ROW_OPTIONAL = ("type", "qlim", "name")
_PLACEMENT_FIELDS = ("xyz", "rpy")


def load_dh(path: str | os.PathLike) -> DHTable:
    """Read a DH table file (YAML, DESIGN.md "DH table files").

    The format::

        name: iiwa14                  # optional; default: the file name without .yaml
        convention: modified          # required: standard or modified
        angles: deg                   # optional: deg or rad (default rad)
        base: {xyz: [0, 0, 0], rpy: [0, 0, 0]}      # optional, before row 1
        tool: {xyz: [0, 0, 0.126], rpy: [0, 0, 0]}  # optional, after the last row
        joints:                       # one row per movable joint, base to tip
          - {a: 0, alpha: 0,  d: 0.36, theta: 0}
          - {a: 0, alpha: 90, d: 0,    theta: 180, qlim: [-120, 120], name: iiwa_joint_2}
          - {a: 0, alpha: 0,  d: 0.1,  theta: 0, type: prismatic, qlim: [0, 0.5]}

    - ``a`` and ``d`` are metres; ``alpha`` and ``theta`` are in the file's
      ``angles`` unit, and so are the ``rpy`` of ``base`` and ``tool`` and the
      ``qlim`` of revolute rows (``qlim`` of prismatic rows is metres).
    - Standard rows are ``(a_i, alpha_i, d_i, theta_i)``, modified rows
      ``(a_{i-1}, alpha_{i-1}, d_i, theta_i)``; ``theta`` (revolute) or ``d``
      (prismatic) is the offset added to the joint value.
    - ``rpy`` is ``(roll, pitch, yaw)``, ``R = Rz(yaw) Ry(pitch) Rx(roll)`` (URDF).
    - ``type`` is ``revolute`` (default) or ``prismatic``; ``name`` is an
      optional joint label.
    - Numbers may be written as ``1e-3`` (which PyYAML reads as text).

    Parameters
    ----------
    path : str or path-like

    Returns
    -------
    DHTable
        In metres and radians.

    Raises
    ------
    DHTableError
        One line naming the file, the row (1-based) and the field, and what
        is valid: a missing file, malformed YAML (with line and column), a
        missing or unknown field (with the closest valid name), a value that
        is not a number or not finite, a bad ``convention``, ``angles`` or
        ``type``, an empty ``joints`` list, a repeated key.

    Examples
    --------
    >>> from manipkit.description.sources import bundled_dir
    >>> table = load_dh(bundled_dir() / "dh" / "planar_2r.yaml")
    >>> table.convention, table.n
    ('standard', 2)
    """
    path = Path(path)
    try:
        text = path.read_text(encoding="utf-8")
    except FileNotFoundError:
        raise DHTableError(f"{path}: no such DH table file") from None
    except (OSError, UnicodeDecodeError) as exc:
        raise DHTableError(f"{path}: cannot read the DH table file ({exc})") from None
    name = path.name[: -len(".yaml")] if path.name.endswith(".yaml") else path.stem
    return dh_from_yaml(text, source=str(path), default_name=name)


def dh_from_yaml(text: str, *, source: str = "<string>", default_name: str = "") -> DHTable:
    """A DH table from the text of a table file (see :func:`load_dh` for the format).

    Parameters
    ----------
    text : str
        YAML.
    source : str, keyword-only
        How messages name the text (a file name).
    default_name : str, keyword-only
        The table's name when the text has no ``name``.

    Returns
    -------
    DHTable

    Raises
    ------
    DHTableError
        See :func:`load_dh`.

    Examples
    --------
    >>> table = dh_from_yaml("convention: standard\\nangles: deg\\njoints:\\n  - {a: 1, alpha: 90, d: 0, theta: 0}")
    >>> round(table.rows[0].alpha, 12)
    1.570796326795
    """
    data = _parse_yaml(text, source)
    if not isinstance(data, dict):
        raise DHTableError(
            f"{source}: a DH table is a mapping with the keys {', '.join(_TOP_FIELDS)}; "
            f"got {_kind(data)}"
        )
    _check_keys(data, _TOP_FIELDS, ("convention", "joints"), source, "the table")

    convention = _choice(data["convention"], CONVENTIONS, source, "field 'convention'")
    angles = _choice(data.get("angles", "rad"), ANGLE_UNITS, source, "field 'angles'")
    to_rad = math.radians if angles == "deg" else float
    name = data.get("name", default_name)
    name = "" if name is None else str(name)

    joints = data["joints"]
    if not isinstance(joints, list):
        raise DHTableError(f"{source}: field 'joints' must be a list of rows {{a, alpha, d, theta}}; got {_kind(joints)}")
    if not joints:
        raise DHTableError(f"{source}: field 'joints' is empty; give one row {{a, alpha, d, theta}} per movable joint")
    rows = [_row_from_yaml(item, i, source, angles, to_rad) for i, item in enumerate(joints, start=1)]

    base, base_rpy = _placement_from_yaml(data.get("base", {}), "base", source, angles, to_rad)
    tool, tool_rpy = _placement_from_yaml(data.get("tool", {}), "tool", source, angles, to_rad)
    return DHTable(rows, convention, name, base, tool, base_rpy, tool_rpy)


def _parse_yaml(text: str, source: str):
    import yaml

    class StrictSafeLoader(yaml.SafeLoader):
        """SafeLoader that refuses a key given twice (PyYAML keeps the last one silently)."""

    def construct_mapping(loader, node, deep=False):
        seen = {}
        for key_node, _ in node.value:
            key = loader.construct_object(key_node, deep=deep)
            if isinstance(key, str) and key in seen:
                mark = key_node.start_mark
                raise DHTableError(
                    f"{source}: key '{key}' given twice (line {seen[key]} and line {mark.line + 1}); keep one"
                )
            if isinstance(key, str):
                seen[key] = key_node.start_mark.line + 1
        return yaml.SafeLoader.construct_mapping(loader, node, deep=deep)

    StrictSafeLoader.add_constructor(yaml.resolver.BaseResolver.DEFAULT_MAPPING_TAG, construct_mapping)
    try:
        return yaml.load(text, Loader=StrictSafeLoader)  # a SafeLoader: same safety as yaml.safe_load
    except yaml.YAMLError as exc:
        mark = getattr(exc, "problem_mark", None) or getattr(exc, "context_mark", None)
        where = f" at line {mark.line + 1}, column {mark.column + 1}" if mark is not None else ""
        problem = getattr(exc, "problem", None) or str(exc).splitlines()[0]
        raise DHTableError(f"{source}: malformed YAML{where}: {problem}") from None


def _kind(value) -> str:
    if value is None:
        return "nothing"
    return {dict: "a mapping", list: "a list", str: f"the text {value!r:.40}"}.get(type(value), f"{value!r:.40}")


def _check_keys(mapping: dict, valid, required, source: str, what: str) -> None:
    for key in mapping:
        if key not in valid:
            close = difflib.get_close_matches(str(key), valid, n=1, cutoff=0.5)
            hint = f" (did you mean '{close[0]}'?)" if close else ""
            raise DHTableError(f"{source}: {what}: unknown field '{key}'{hint}; valid fields: {', '.join(valid)}")
    for key in required:
        if key not in mapping:
            raise DHTableError(f"{source}: {what}: missing field '{key}'; required fields: {', '.join(required)}")


def _choice(value, valid, source: str, what: str) -> str:
    if value not in valid:
        raise DHTableError(f"{source}: {what} is {value!r}; choose {' or '.join(valid)}")
    return value


def _number(value, source: str, what: str, unit: str) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float, str)):
        raise DHTableError(f"{source}: {what} is {_kind(value)}, not a number; give a number in {unit}")
    try:
        number = float(value.strip()) if isinstance(value, str) else float(value)
    except ValueError:
        raise DHTableError(f"{source}: {what} is {value!r:.40}, not a number; give a number in {unit}") from None
    if not math.isfinite(number):
        raise DHTableError(f"{source}: {what} is {value}, not finite; give a finite number in {unit}")
    return number


def _numbers(value, count: int, source: str, what: str, unit: str) -> list[float]:
    if not isinstance(value, list) or len(value) != count:
        raise DHTableError(f"{source}: {what} must be a list of {count} numbers in {unit}; got {_kind(value)}")
    return [_number(v, source, f"{what} entry {i}", unit) for i, v in enumerate(value, start=1)]


def _angle_unit(angles: str) -> str:
    return "degrees (angles: deg)" if angles == "deg" else "radians (angles: rad)"


def _row_from_yaml(item, index: int, source: str, angles: str, to_rad) -> DHRow:
    where = f"row {index}"
    if not isinstance(item, dict):
        raise DHTableError(f"{source}: {where} must be a mapping {{a, alpha, d, theta}}; got {_kind(item)}")
    _check_keys(item, _ROW_FIELDS + _ROW_OPTIONAL, _ROW_FIELDS, source, where)
    angle_unit = _angle_unit(angles)
    a = _number(item["a"], source, f"{where}: field 'a'", "metres")
    d = _number(item["d"], source, f"{where}: field 'd'", "metres")
    alpha = to_rad(_number(item["alpha"], source, f"{where}: field 'alpha'", angle_unit))
    theta = to_rad(_number(item["theta"], source, f"{where}: field 'theta'", angle_unit))
    kind = _choice(item.get("type", "revolute"), JOINT_TYPES, source, f"{where}: field 'type'")
    qlim = None
    if item.get("qlim") is not None:
        unit = angle_unit if kind == "revolute" else "metres"
        lower, upper = _numbers(item["qlim"], 2, source, f"{where}: field 'qlim'", unit)
        if not lower < upper:
            raise DHTableError(f"{source}: {where}: field 'qlim' is [{lower:g}, {upper:g}]; the lower limit must be below the upper")
        if kind == "revolute":
            lower, upper = to_rad(lower), to_rad(upper)
        qlim = (lower, upper)
    name = item.get("name", "")
    return DHRow(a, alpha, d, theta, kind, qlim, "" if name is None else str(name))


def _placement_from_yaml(value, what: str, source: str, angles: str, to_rad):
    if not isinstance(value, dict):
        raise DHTableError(f"{source}: field '{what}' must be a mapping {{xyz: [x, y, z], rpy: [roll, pitch, yaw]}}; got {_kind(value)}")
    _check_keys(value, _PLACEMENT_FIELDS, (), source, f"field '{what}'")
    if not value:
        return np.eye(4), None
    xyz = _numbers(value.get("xyz", [0, 0, 0]), 3, source, f"{what}: field 'xyz'", "metres")
    rpy = [to_rad(v) for v in _numbers(value.get("rpy", [0, 0, 0]), 3, source, f"{what}: field 'rpy'", _angle_unit(angles))]
    return transform_from_xyz_rpy(xyz, rpy), tuple(rpy)


def save_dh(table: DHTable, path: str | os.PathLike, *, angles: str = "deg", header: str | None = None) -> None:
    """Write a DH table file (see :func:`load_dh` for the format).

    Parameters
    ----------
    table : DHTable
    path : str or path-like
    angles : {"deg", "rad"}, keyword-only
        Unit of ``alpha``, ``theta``, the ``rpy`` of base and tool and the
        ``qlim`` of revolute rows in the file.
    header : str, optional
        Text written as ``#`` comment lines at the top.

    Notes
    -----
    ``load_dh(path) == table`` after saving, bit for bit: numbers are written
    with the shortest text that reads back to the same float. With
    ``angles="deg"`` the written degrees are chosen (among the few floats
    next to ``degrees(x)``) so that ``radians`` gives back ``x`` exactly;
    this exists for every angle that is the radian value of some float
    number of degrees, which covers every table read from a file in
    degrees. (A few radian values are not such a value; they come back
    within one unit in the last place.) Base and tool are written as
    ``xyz`` and ``rpy``; a table read from a file keeps the file's ``rpy``.

    Raises
    ------
    DHTableError
        A value that is not finite, or a base or tool that is not a rigid
        transform.

    Examples
    --------
    >>> import tempfile
    >>> table = DHTable([DHRow(1, 0, 0, 0), DHRow(1, 0, 0, 0)], "standard", "planar_2r")
    >>> with tempfile.TemporaryDirectory() as folder:
    ...     save_dh(table, Path(folder) / "planar_2r.yaml")
    ...     load_dh(Path(folder) / "planar_2r.yaml") == table
    True
    """
    Path(path).write_text(yaml_from_dh(table, angles=angles, header=header), encoding="utf-8")


def yaml_from_dh(table: DHTable, *, angles: str = "deg", header: str | None = None) -> str:
    """The text of a DH table file (what :func:`save_dh` writes).

    Parameters
    ----------
    table : DHTable
    angles : {"deg", "rad"}, keyword-only
    header : str, optional
        Comment lines for the top.

    Returns
    -------
    str

    Examples
    --------
    >>> print(yaml_from_dh(DHTable([DHRow(1, np.pi / 2, 0, 0)], "standard", "one")))
    name: one
    convention: standard
    angles: deg
    joints:
      - {a: 1, alpha: 90, d: 0, theta: 0}
    <BLANKLINE>
    """
    if angles not in ANGLE_UNITS:
        raise ValueError(f"angles '{angles}': choose deg or rad")
    angle = _degrees_for_file if angles == "deg" else (lambda x: x)
    lines = [f"# {line}".rstrip() for line in (header.splitlines() if header else [])]
    lines += [
        f"name: {_yaml_string(table.name)}",
        f"convention: {table.convention}",
        f"angles: {angles}",
    ]
    for what in ("base", "tool"):
        T = getattr(table, what)
        if np.array_equal(T, np.eye(4)):
            continue
        xyz, rpy = _xyz_rpy(T, getattr(table, f"{what}_rpy"), what)
        lines.append(f"{what}: {{xyz: {_yaml_list(xyz, what + ' xyz')}, rpy: {_yaml_list([angle(v) for v in rpy], what + ' rpy')}}}")
    lines.append("joints:")
    for i, row in enumerate(table.rows, start=1):
        where = f"row {i}"
        fields = [
            f"a: {_yaml_number(row.a, where + ' a')}",
            f"alpha: {_yaml_number(angle(row.alpha), where + ' alpha')}",
            f"d: {_yaml_number(row.d, where + ' d')}",
            f"theta: {_yaml_number(angle(row.theta), where + ' theta')}",
        ]
        if not row.is_revolute:
            fields.append("type: prismatic")
        if row.qlim is not None:
            limits = [angle(v) for v in row.qlim] if row.is_revolute else list(row.qlim)
            fields.append(f"qlim: {_yaml_list(limits, where + ' qlim')}")
        if row.name:
            fields.append(f"name: {_yaml_string(row.name)}")
        lines.append(f"  - {{{', '.join(fields)}}}")
    return "\n".join(lines) + "\n"


def _degrees_for_file(x: float) -> float:
    """The float number of degrees, shortest in text, whose ``math.radians`` is exactly ``x``."""
    guess = math.degrees(x)
    candidates = [guess]
    low = high = guess
    for _ in range(4):
        low, high = math.nextafter(low, -math.inf), math.nextafter(high, math.inf)
        candidates += [low, high]
    exact = [c for c in candidates if math.radians(c) == x]
    if not exact:
        return guess
    return min(exact, key=lambda c: (len(_yaml_number(c, "")), abs(c - guess)))


def _yaml_number(value: float, what: str) -> str:
    value = float(value)
    if not math.isfinite(value):
        raise DHTableError(f"{what} is {value}; a DH table file holds finite numbers only")
    if value.is_integer() and abs(value) < 1e15:
        return "-0.0" if value == 0 and math.copysign(1.0, value) < 0 else str(int(value))
    text = repr(value)
    if "e" in text and "." not in text.split("e")[0]:  # PyYAML reads 1e-05 as text, 1.0e-05 as a number
        mantissa, exponent = text.split("e")
        text = f"{mantissa}.0e{exponent}"
    return text


def _yaml_list(values, what: str) -> str:
    return "[" + ", ".join(_yaml_number(v, what) for v in values) + "]"


_YAML_PLAIN = re.compile(r"[A-Za-z_][A-Za-z0-9_.\-]*\Z")
_YAML_RESERVED = {"y", "n", "yes", "no", "on", "off", "true", "false", "null"}


def _yaml_string(text: str) -> str:
    if _YAML_PLAIN.match(text) and text.lower() not in _YAML_RESERVED:
        return text
    import yaml

    return yaml.safe_dump(text, default_style='"', allow_unicode=True, width=float("inf")).strip()


def _xyz_rpy(T: np.ndarray, rpy_hint, what: str, *, check: bool = True) -> tuple[np.ndarray, np.ndarray]:
    """Translation and rpy (rad) of a rigid transform, keeping ``rpy_hint`` when it gives the rotation exactly.

    ``check`` (default): a bottom row other than [0, 0, 0, 1] or a block that
    is not a rotation raises DHTableError; without it (for printing) the
    block's rpy are read as they are.
    """
    if check and not np.array_equal(T[3], [0.0, 0.0, 0.0, 1.0]):
        raise DHTableError(f"DH table {what}: bottom row is {T[3].tolist()}, not [0, 0, 0, 1]")
    if rpy_hint is not None and np.array_equal(matrix_from_rpy(np.array(rpy_hint)), T[:3, :3]):
        return T[:3, 3], np.array(rpy_hint)
    try:
        rpy = rpy_from_matrix(T[:3, :3], check=check)
    except ValueError as exc:
        raise DHTableError(f"DH table {what}: {exc}") from None
    return T[:3, 3], rpy


# --------------------------------------------------------------------------
# printing


_BOX = {"top": "┌┬┐", "mid": "├┼┤", "bottom": "└┴┘"}


def _fmt(value: float) -> str:
    text = f"{value:.6g}"
    return "0" if text in ("-0", "0") else text


def _fmt_deg(radians: float) -> str:
    return _fmt(math.degrees(radians)) + "°"


def _with_variable(variable: str, offset_text: str, unit: str) -> str:
    if offset_text == "0":
        return variable
    if offset_text.startswith("-"):
        return f"{variable} - {offset_text[1:]}{unit}"
    return f"{variable} + {offset_text}{unit}"


def format_dh_table(table: DHTable) -> str:
    """A DH table as a boxed text table (also ``str(table)``).

    The heading names the table, the convention (``standard DH`` or
    ``modified DH``), the joint count and kinds (R revolute, P prismatic).
    Columns, standard DH: ``j, θⱼ, dⱼ, aⱼ, αⱼ, q limits``; modified DH:
    ``j, aⱼ₋₁, αⱼ₋₁, θⱼ, dⱼ, q limits``. The joint variable ``qj`` appears in
    the ``θ`` column of a revolute row and in the ``d`` column of a
    prismatic row, with the row's offset (``q2 + 180°``). Angles are in
    degrees, lengths in metres, six significant digits. A base or tool that
    is not the identity is printed below the table as ``xyz`` (m) and
    ``rpy`` (deg, ``R = Rz(yaw) Ry(pitch) Rx(roll)``).

    Parameters
    ----------
    table : DHTable

    Returns
    -------
    str

    Examples
    --------
    >>> print(format_dh_table(DHTable([DHRow(1, 0, 0, 0), DHRow(1, 0, 0, np.pi / 2)], "standard", "planar_2r")))
    planar_2r: standard DH, 2 joints (RR)
    ┌───┬──────────┬────┬────┬────┬──────────┐
    │ j │ θⱼ       │ dⱼ │ aⱼ │ αⱼ │ q limits │
    ├───┼──────────┼────┼────┼────┼──────────┤
    │ 1 │ q1       │  0 │  1 │ 0° │        - │
    │ 2 │ q2 + 90° │  0 │  1 │ 0° │        - │
    └───┴──────────┴────┴────┴────┴──────────┘
    """
    named = any(row.name for row in table.rows)
    if table.convention == "standard":
        header = ["j", "θⱼ", "dⱼ", "aⱼ", "αⱼ", "q limits"]
    else:
        header = ["j", "aⱼ₋₁", "αⱼ₋₁", "θⱼ", "dⱼ", "q limits"]
    if named:
        header.insert(1, "joint")
    body = []
    for j, row in enumerate(table.rows, start=1):
        variable = f"q{j}"
        theta = _with_variable(variable, _fmt(math.degrees(row.theta)), "°") if row.is_revolute else _fmt_deg(row.theta)
        d = _fmt(row.d) if row.is_revolute else _with_variable(variable, _fmt(row.d), "")
        if row.qlim is None:
            limits = "-"
        elif row.is_revolute:
            limits = f"[{_fmt_deg(row.qlim[0])}, {_fmt_deg(row.qlim[1])}]"
        else:
            limits = f"[{_fmt(row.qlim[0])}, {_fmt(row.qlim[1])}] m"
        if table.convention == "standard":
            cells = [str(j), theta, d, _fmt(row.a), _fmt_deg(row.alpha), limits]
        else:
            cells = [str(j), _fmt(row.a), _fmt_deg(row.alpha), theta, d, limits]
        if named:
            cells.insert(1, row.name or "-")
        body.append(cells)
    # the joint variable's column and names read left-aligned, numbers right-aligned
    variable_column = header.index("θⱼ")
    left = {0, 1} if named else {0}
    left.add(variable_column)
    widths = [max(len(r[k]) for r in [header] + body) for k in range(len(header))]

    def line(kind: str) -> str:
        first, middle, last = _BOX[kind]
        return first + middle.join("─" * (w + 2) for w in widths) + last

    def cells_line(cells, is_header=False) -> str:
        parts = [
            c.ljust(w) if (is_header or k in left) else c.rjust(w)
            for k, (c, w) in enumerate(zip(cells, widths))
        ]
        return "│ " + " │ ".join(parts) + " │"

    kinds = "".join("R" if row.is_revolute else "P" for row in table.rows)
    title = f"{table.convention} DH, {table.n} joint{'s' if table.n != 1 else ''} ({kinds})"
    out = [f"{table.name}: {title}" if table.name else title, line("top"), cells_line(header, True), line("mid")]
    out += [cells_line(cells) for cells in body]
    out.append(line("bottom"))
    for what in ("base", "tool"):
        T = getattr(table, what)
        if np.array_equal(T, np.eye(4)):
            continue
        xyz, rpy = _xyz_rpy(T, getattr(table, f"{what}_rpy"), what, check=False)
        out.append(
            f"{what}: xyz = [{', '.join(_fmt(v) for v in xyz)}] m, "
            f"rpy = [{', '.join(_fmt_deg(v) for v in rpy)}] (R = Rz(yaw) Ry(pitch) Rx(roll))"
        )
    return "\n".join(out)


# --------------------------------------------------------------------------
# symbolic forward kinematics (SymPy, imported here only)


EXACT_ANGLE_TOL = 1e-12
"""Relative tolerance within which an angle counts as a multiple of pi/12 in :func:`dh_fk_symbolic`."""


def _exact_length(value: float):
    """A SymPy number for a length: an Integer or the Rational of its shortest decimal text, else a Float."""
    import sympy

    if value.is_integer() and abs(value) < 2**53:
        return sympy.Integer(int(value))
    text = repr(value)
    digits = text.lstrip("-").replace(".", "").lstrip("0")
    if "e" not in text and len(digits) <= 9:
        exact = sympy.Rational(text)  # the decimal as written; float(exact) == value since repr round-trips
        if float(exact) == value:
            return exact
    return sympy.Float(value)


def _exact_angle(value: float, tol: float = EXACT_ANGLE_TOL):
    """A SymPy angle: ``k pi / 12`` when ``value`` is one (within relative ``tol``), else as a length."""
    import sympy

    k = value / (math.pi / 12)
    nearest = round(k)
    if abs(k - nearest) <= tol * max(1.0, abs(k)):
        return sympy.Rational(nearest, 12) * sympy.pi
    return _exact_length(value)


def _symbolic_link(a, alpha, d, theta, convention: str):
    import sympy

    ct, st, ca, sa = sympy.cos(theta), sympy.sin(theta), sympy.cos(alpha), sympy.sin(alpha)
    if convention == "standard":
        rows = [[ct, -st * ca, st * sa, a * ct], [st, ct * ca, -ct * sa, a * st], [0, sa, ca, d]]
    else:
        rows = [[ct, -st, 0, a], [st * ca, ct * ca, -sa, -d * sa], [st * sa, ct * sa, ca, d * ca]]
    return sympy.Matrix(rows + [[0, 0, 0, 1]])


def _symbolic_placement(T: np.ndarray, rpy_hint, tol: float):
    import sympy

    xyz, rpy = _xyz_rpy(T, rpy_hint, "base or tool")
    roll, pitch, yaw = (_exact_angle(float(v), tol) for v in rpy)
    c, s = sympy.cos, sympy.sin
    Rx = sympy.Matrix([[1, 0, 0], [0, c(roll), -s(roll)], [0, s(roll), c(roll)]])
    Ry = sympy.Matrix([[c(pitch), 0, s(pitch)], [0, 1, 0], [-s(pitch), 0, c(pitch)]])
    Rz = sympy.Matrix([[c(yaw), -s(yaw), 0], [s(yaw), c(yaw), 0], [0, 0, 1]])
    R = Rz * Ry * Rx
    M = sympy.eye(4)
    M[:3, :3] = R
    M[:3, 3] = sympy.Matrix([_exact_length(float(v)) for v in xyz])
    return M


def dh_symbols(n: int, symbols=None) -> tuple:
    """The joint symbols :func:`dh_fk_symbolic` uses.

    Parameters
    ----------
    n : int
        Number of joints.
    symbols : str or sequence, optional
        ``None``: ``q1 ... qn`` (real). A string is passed to
        ``sympy.symbols`` (``"t1:4"``, ``"theta_1 theta_2"``); a sequence
        holds names or SymPy symbols, one per joint.

    Returns
    -------
    tuple of sympy.Symbol

    Examples
    --------
    >>> dh_symbols(3)
    (q1, q2, q3)
    """
    import sympy

    if symbols is None:
        made = sympy.symbols(f"q1:{n + 1}", real=True)
    elif isinstance(symbols, str):
        made = sympy.symbols(symbols, real=True)
        made = made if isinstance(made, tuple) else (made,)
    else:
        made = tuple(s if isinstance(s, sympy.Symbol) else sympy.Symbol(str(s), real=True) for s in symbols)
    made = tuple(made)
    if len(made) != n:
        raise ValueError(f"{n} joint symbols needed, got {len(made)}: {made}")
    return made


def dh_fk_symbolic(
    table: DHTable,
    *,
    upto: int | None = None,
    simplify: bool | str = True,
    symbols=None,
    exact_tol: float = EXACT_ANGLE_TOL,
):
    """T_base_tool of a DH table as a SymPy matrix in the joint variables.

    Parameters
    ----------
    table : DHTable
    upto : int, keyword-only, optional
        Stop after this many rows and leave out the tool (as :func:`dh_fk`).
    simplify : {True, False, "trigsimp"}, keyword-only
        ``True`` (default): after every row, fold ``sin a cos b + cos a sin b``
        into ``sin(a + b)`` and the like (SymPy's Fu rule ``TR10i``). In a
        serial chain each joint variable appears in one row only, so products
        are multilinear in the ``sin``/``cos`` of the joints and angle sums are
        the only simplification there is; this is fast (0.1 s for 7 joints).
        ``"trigsimp"``: in addition ``sympy.trigsimp`` on every entry of
        the result (slow: about 20 s for the 7-joint iiwa).
        ``False``: the plain product.
    symbols : str or sequence, keyword-only, optional
        Joint symbols, see :func:`dh_symbols`; default ``q1 ... qn`` (real).
        A revolute row's symbol is added to ``theta``, a prismatic row's to ``d``.
    exact_tol : float, keyword-only
        Relative tolerance within which an angle counts as a multiple of
        ``pi/12`` (default ``EXACT_ANGLE_TOL`` = 1e-12), see Notes.

    Returns
    -------
    sympy.Matrix, shape (4, 4)
        ``base @ A_1 @ ... @ A_n @ tool`` with the conventions of :func:`dh_fk`.

    Notes
    -----
    Numbers become exact where they are "nice": an angle within a relative
    ``exact_tol`` of a multiple of ``pi/12`` (15 deg) becomes
    that exact multiple of ``pi``; a length (and any other angle) becomes an
    Integer, or the Rational of its shortest decimal text when that has at
    most 9 significant digits (``0.36 -> 9/25``; exact, since that text reads
    back to the same float), and a Float otherwise. Base and tool enter as
    their ``xyz`` and ``rpy`` converted the same way.

    Examples
    --------
    >>> table = DHTable([DHRow(1, 0, 0, 0), DHRow(1, 0, 0, 0)], "standard")
    >>> T = dh_fk_symbolic(table)
    >>> T[0, 3]
    cos(q1) + cos(q1 + q2)
    """
    import sympy
    from sympy.simplify.fu import TR10i

    if simplify not in (True, False, "trigsimp"):
        raise ValueError(f"simplify={simplify!r}: choose True, False or 'trigsimp'")
    q = dh_symbols(table.n, symbols)
    count = table.n if upto is None else upto
    T = sympy.eye(4) if np.array_equal(table.base, np.eye(4)) else _symbolic_placement(table.base, table.base_rpy, exact_tol)
    for row, qi in zip(table.rows[:count], q):
        theta = _exact_angle(row.theta, exact_tol) + (qi if row.is_revolute else 0)
        d = _exact_length(row.d) + (0 if row.is_revolute else qi)
        T = T * _symbolic_link(_exact_length(row.a), _exact_angle(row.alpha, exact_tol), d, theta, table.convention)
        if simplify:
            T = T.applyfunc(TR10i)
    if upto is None and not np.array_equal(table.tool, np.eye(4)):
        T = T * _symbolic_placement(table.tool, table.tool_rpy, exact_tol)
        if simplify:
            T = T.applyfunc(TR10i)
    if simplify == "trigsimp":
        T = T.applyfunc(sympy.trigsimp)
    return T


def _index_of(symbol) -> str:
    match = re.search(r"(\d+)$", symbol.name)
    return match.group(1) if match else symbol.name


def shorthand(expr):
    """Write ``sin(q_i)`` as ``s_i`` and ``cos(q_i)`` as ``c_i``, as textbooks do.

    Sums of joint symbols get joined indices: ``sin(q1 + q2) -> s_12``,
    ``cos(q1 + q2 + q3) -> c_123`` (indices with more than one digit are
    separated by commas: ``s_9,10``). The index is the trailing number of the
    symbol's name (``q2``, ``theta_2``), or the whole name. Arguments other
    than plain sums of symbols (``q1 - q2``, ``2*q1``) stay as they are.

    Parameters
    ----------
    expr : sympy expression or Matrix

    Returns
    -------
    The same type, with real symbols ``s_...`` and ``c_...``.

    Examples
    --------
    >>> import sympy
    >>> q1, q2 = sympy.symbols("q1 q2", real=True)
    >>> shorthand(sympy.cos(q1) + sympy.sin(q1 + q2))
    c_1 + s_12
    """
    import sympy

    replacements = {}
    for function in expr.atoms(sympy.sin, sympy.cos):
        terms = sympy.Add.make_args(function.args[0])
        if not all(isinstance(t, sympy.Symbol) for t in terms):
            continue
        indices = sorted((_index_of(t) for t in terms), key=lambda s: (not s.isdigit(), int(s) if s.isdigit() else 0, s))
        joined = "".join(indices) if all(len(i) == 1 for i in indices) else ",".join(indices)
        letter = "s" if isinstance(function, sympy.sin) else "c"
        replacements[function] = sympy.Symbol(f"{letter}_{joined}", real=True)
    return expr.xreplace(replacements)


def format_symbolic(matrix, *, latex: bool = False, width: int = 100, name: str = "T") -> str:
    """A SymPy matrix as text or LaTeX.

    Parameters
    ----------
    matrix : sympy.Matrix
    latex : bool, keyword-only
        Return LaTeX: ``\\begin{bmatrix} ... \\end{bmatrix}`` (``sympy.latex``).
    width : int, keyword-only
        Text only: when ``sympy.pretty`` would print a line longer than this,
        print one entry per line instead (``T[1,1] = ...``, 1-based indices).
    name : str, keyword-only
        The matrix name used in the one-entry-per-line form.

    Returns
    -------
    str

    Examples
    --------
    >>> import sympy
    >>> q1 = sympy.Symbol("q1", real=True)
    >>> format_symbolic(sympy.Matrix([[sympy.cos(q1), 0], [0, 1]]), latex=True)
    '\\\\begin{bmatrix}\\\\cos{\\\\left(q_{1} \\\\right)} & 0\\\\\\\\0 & 1\\\\end{bmatrix}'
    """
    import sympy

    if latex:
        return sympy.latex(matrix, mat_str="bmatrix", mat_delim="")
    text = sympy.pretty(matrix, use_unicode=True, wrap_line=False)
    if max((len(line) for line in text.splitlines()), default=0) <= width:
        return text
    rows, cols = matrix.shape
    return "\n".join(f"{name}[{i + 1},{j + 1}] = {sympy.sstr(matrix[i, j])}" for i in range(rows) for j in range(cols))


# --------------------------------------------------------------------------
# URDF export


def _rz_tz(theta: float, d: float) -> np.ndarray:
    return dh_link_transform(0.0, 0.0, d, theta, convention="standard")


def _tx_rx(a: float, alpha: float) -> np.ndarray:
    return dh_link_transform(a, alpha, 0.0, 0.0, convention="standard")


def _rx_tx(a: float, alpha: float) -> np.ndarray:
    return dh_link_transform(a, alpha, 0.0, 0.0, convention="modified")


def urdf_from_dh(table: DHTable, *, name: str | None = None) -> str:
    """A URDF (text) whose chain from ``base_link`` to ``ee_link`` is the DH table's, exactly.

    Structure: ``base_link -base_joint-> link_0 -joint_1-> link_1 ... -joint_n->
    link_n -tool_joint-> ee_link``. ``base_joint`` (origin: the table's base)
    and ``tool_joint`` are fixed; ``joint_i`` (or the row's name) is revolute
    or prismatic about the z axis of its frame, with the row's ``qlim`` or
    -pi..pi / -1..1 m. Every link has a small mass and cylinders along the
    common normal (``a``) and the offset (``d``) so the arm is visible.

    How the chain equals the table (``q``-dependent part ``M_i`` = ``Rz(q_i)``
    or ``Tz(q_i)``, which commutes with ``Rz(theta) Tz(d)``):

    - Modified DH: ``A_i = Rx(alpha) Tx(a) Rz(theta) Tz(d) M_i``, so
      ``joint_i``'s origin is ``Rx(alpha) Tx(a) Rz(theta) Tz(d)`` and
      ``link_i`` *is* DH frame i. ``tool_joint``'s origin is the tool.
    - Standard DH: ``A_i = Rz(theta) Tz(d) M_i Tx(a) Rx(alpha)`` (joint i
      moves about ``z_{i-1}``), so ``joint_1``'s origin is
      ``Rz(theta_1) Tz(d_1)``, ``joint_{i+1}``'s is
      ``Tx(a_i) Rx(alpha_i) Rz(theta_{i+1}) Tz(d_{i+1})`` and ``tool_joint``'s
      is ``Tx(a_n) Rx(alpha_n) tool``. Then ``link_i`` is DH frame i before its
      last ``Tx(a_i) Rx(alpha_i)``: ``T_link_i = T_frame_i (Tx(a_i) Rx(alpha_i))^-1``,
      origin where ``x_i`` meets ``z_{i-1}``, x axis along ``x_i``, z axis
      along joint i's axis ``z_{i-1}``. (No URDF link can be DH frame i
      itself: a child link's frame is on its joint's axis, and frame i is
      ``a_i`` away from it.)

    ``link_0`` is DH frame 0 (the base) in both conventions.

    Parameters
    ----------
    table : DHTable
    name : str, keyword-only, optional
        Robot name; default the table's name, or ``dh_robot``.

    Returns
    -------
    str
        URDF XML.

    Examples
    --------
    >>> text = urdf_from_dh(DHTable([DHRow(1, 0, 0, 0), DHRow(1, 0, 0, 0)], "standard", "planar_2r"))
    >>> text.count("<joint "), text.count('type="revolute"')
    (4, 2)
    """
    import xml.etree.ElementTree as ET

    robot_name = name or table.name or "dh_robot"
    n = table.n
    standard = table.convention == "standard"

    # joint origins O_1..O_n and the tool origin, each split as (common-normal part, the rest)
    origins = []
    for i, row in enumerate(table.rows):
        offsets = _rz_tz(row.theta, row.d)
        if standard:
            previous = _tx_rx(table.rows[i - 1].a, table.rows[i - 1].alpha) if i > 0 else np.eye(4)
        else:
            previous = _rx_tx(row.a, row.alpha)
        origins.append((previous, offsets))
    if standard and n:
        tool_origin = (_tx_rx(table.rows[-1].a, table.rows[-1].alpha), table.tool)
    else:
        tool_origin = (np.eye(4), table.tool)

    lengths = [abs(r.a) + abs(r.d) for r in table.rows] + [float(np.linalg.norm(table.tool[:3, 3]))]
    radius = 0.02 * sum(lengths) if sum(lengths) > 0 else 0.02

    robot = ET.Element("robot", name=robot_name)
    robot.append(ET.Comment(
        f" generated by manipkit.dh.urdf_from_dh from the {table.convention} DH table "
        f"'{table.name}'; base_link -> ee_link equals the table's base @ A_1 ... A_n @ tool "
    ))

    def fmt(values) -> str:
        return " ".join(repr(float(v) + 0.0) for v in values)

    def origin(parent: ET.Element, T: np.ndarray) -> None:
        rpy = rpy_from_matrix(T[:3, :3], check=False)
        ET.SubElement(parent, "origin", xyz=fmt(T[:3, 3]), rpy=fmt(rpy))

    def link(link_name: str, segments, axis_marker: bool) -> None:
        element = ET.SubElement(robot, "link", name=link_name)
        inertial = ET.SubElement(element, "inertial")
        ET.SubElement(inertial, "origin", xyz="0 0 0", rpy="0 0 0")
        ET.SubElement(inertial, "mass", value="0.1")
        ET.SubElement(inertial, "inertia", ixx="1e-4", ixy="0", ixz="0", iyy="1e-4", iyz="0", izz="1e-4")
        pieces = []
        if axis_marker:  # the joint: a short, thick cylinder along z
            pieces.append((np.eye(4), 1.4 * radius, 3.0 * radius))
        for start, end in segments:
            vector = end - start
            length = float(np.linalg.norm(vector))
            if length < 1e-9:
                continue
            pose = np.eye(4)
            pose[:3, :3] = _rotation_z_onto(vector / length)
            pose[:3, 3] = (start + end) / 2
            pieces.append((pose, radius, length))
        for pose, r, length in pieces:
            visual = ET.SubElement(element, "visual")
            origin(visual, pose)
            geometry = ET.SubElement(visual, "geometry")
            ET.SubElement(geometry, "cylinder", radius=repr(r), length=repr(length))

    def segments_of(split) -> list:
        normal, rest = split
        corner, end = normal[:3, 3], (normal @ rest)[:3, 3]
        return [(np.zeros(3), corner), (corner, end)]

    link("base_link", [(np.zeros(3), table.base[:3, 3])], False)
    for i in range(n + 1):
        following = origins[i] if i < n else tool_origin
        link(f"link_{i}", segments_of(following), i > 0)
    link("ee_link", [], False)

    def joint(joint_name: str, kind: str, parent: str, child: str, T: np.ndarray, row: DHRow | None = None):
        element = ET.SubElement(robot, "joint", name=joint_name, type=kind)
        ET.SubElement(element, "parent", link=parent)
        ET.SubElement(element, "child", link=child)
        origin(element, T)
        if row is not None:
            ET.SubElement(element, "axis", xyz="0 0 1")
            lower, upper = row.qlim if row.qlim is not None else ((-math.pi, math.pi) if row.is_revolute else (-1.0, 1.0))
            ET.SubElement(element, "limit", lower=repr(lower), upper=repr(upper), effort="100", velocity="1")

    joint("base_joint", "fixed", "base_link", "link_0", table.base)
    for i, row in enumerate(table.rows, start=1):
        normal, rest = origins[i - 1]
        joint(row.name or f"joint_{i}", row.type, f"link_{i - 1}", f"link_{i}", normal @ rest, row)
    joint("tool_joint", "fixed", f"link_{n}", "ee_link", tool_origin[0] @ tool_origin[1])

    ET.indent(robot)
    return '<?xml version="1.0"?>\n' + ET.tostring(robot, encoding="unicode") + "\n"


def _rotation_z_onto(u: np.ndarray) -> np.ndarray:
    """A rotation whose z column is the unit vector ``u``."""
    helper = np.array([1.0, 0.0, 0.0]) if abs(u[0]) < 0.9 else np.array([0.0, 1.0, 0.0])
    x = np.cross(helper, u)
    x /= np.linalg.norm(x)
    return np.column_stack([x, np.cross(u, x), u])
