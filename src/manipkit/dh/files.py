"""DH table files: read and write the YAML format (docs/site/internals/dh-files.md).

:func:`load_dh` and :func:`dh_from_yaml` read a table (the format is in
:func:`load_dh`'s docstring), :func:`save_dh` and :func:`yaml_from_dh` write
one so that it reads back bit for bit. Every problem in a file is a
:class:`~manipkit.errors.DHTableError` naming the file, the row and the field.

Tables are files users download, so reading one is bounded: the file through
:func:`manipkit.inputs.read_text` (a regular file of at most
``MAX_TABLE_BYTES``), YAML with PyYAML's safe loader, no aliases (``*name``:
a few nested aliases expand to gigabytes), at most ``MAX_YAML_NODES`` values
nested at most ``MAX_YAML_DEPTH`` deep (checked while the YAML is read, before
any value is built), at most ``MAX_DH_ROWS`` rows, integers of any length
refused as too large rather than converted, and names that are one line of
printable text. Files are written through :mod:`manipkit.outputs`.

PyYAML is imported inside the functions that need it.
"""

from __future__ import annotations

import difflib
import math
import os
import re
from pathlib import Path

import numpy as np

from manipkit.dh.table import CONVENTIONS, JOINT_TYPES, MAX_DH_ROWS, DHRow, DHTable, check_dh_name
from manipkit.errors import DHTableError, InputFileError
from manipkit.inputs import MAX_TABLE_BYTES, read_text
from manipkit.outputs import write_text
from manipkit.spatial.transforms import transform_from_xyz_rpy
from manipkit.text import short_text

__all__ = [
    "ANGLE_UNITS", "MAX_YAML_DEPTH", "MAX_YAML_NODES", "bundled_tables", "dh_from_yaml", "load_dh", "pi_expression_value",
    "save_dh",
    "yaml_from_dh",
]

ANGLE_UNITS = ("rad", "deg")
#: Values (scalars, lists, mappings) a DH table file may hold: about 20 a row, for ``MAX_DH_ROWS`` rows.
MAX_YAML_NODES = 25 * MAX_DH_ROWS + 1000
#: Nesting of a DH table file: table, joints, row, qlim is 4 deep.
MAX_YAML_DEPTH = 16
_LONGEST_INTEGER = 300  # characters of an integer literal; longer ones are above any DH number (1e300)

_TOP_FIELDS = ("name", "convention", "angles", "base", "tool", "joints")
_ROW_FIELDS = ("a", "alpha", "d", "theta")
_ROW_OPTIONAL = ("type", "qlim", "name")
_PLACEMENT_FIELDS = ("xyz", "rpy")


def bundled_tables() -> dict[str, Path]:
    """Bundled DH table names -> their files (``robots/dh/NAME.yaml``; ``manipkit/data/robots/dh`` in a wheel).

    The same folder :func:`manipkit.description.sources.bundled_dh_tables`
    lists; found here from this package's location, since dh sits below
    description in the layers (docs/architecture.md).
    """
    package = Path(__file__).resolve().parents[1]  # src/manipkit (or site-packages/manipkit)
    for folder in (package.parents[1] / "robots" / "dh", package / "data" / "robots" / "dh"):
        if folder.is_dir():
            return {p.stem: p for p in sorted(folder.glob("*.yaml"))}
    return {}


def load_dh(path: str | os.PathLike) -> DHTable:
    """Read a DH table file (YAML, docs/architecture.md "DH table files"), or a bundled table by name.

    ``path`` may be a bundled table's name (``"iiwa14"``, ``"iiwa14_seed004"``;
    :func:`bundled_tables`), as ``manipkit dh show NAME`` takes it: a name
    is looked up first, then a file.

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
        is valid: a missing file, a FIFO, device or folder, a file above
        ``MAX_TABLE_BYTES``, malformed YAML (with line and column), an alias,
        more than ``MAX_YAML_NODES`` values or nesting deeper than
        ``MAX_YAML_DEPTH``, more than ``MAX_DH_ROWS`` rows, a missing or
        unknown field (with the closest valid name), a value that is not a
        number, not finite or too large, a bad ``convention``, ``angles`` or
        ``type``, an empty ``joints`` list, a repeated key, a name with a
        control character.

    Examples
    --------
    >>> from manipkit.description.sources import bundled_dir
    >>> table = load_dh(bundled_dir() / "dh" / "planar_2r.yaml")
    >>> table.convention, table.n
    ('standard', 2)
    """
    bundled = bundled_tables()
    if isinstance(path, str) and path in bundled:
        path = bundled[path]
    path = Path(path)
    try:
        text = read_text(path, what="DH table file", max_bytes=MAX_TABLE_BYTES)
    except InputFileError as exc:
        if not path.exists() and not path.is_symlink():
            close = difflib.get_close_matches(str(path), list(bundled), n=3, cutoff=0.5)
            hint = f"did you mean {', '.join(close)}? " if close else ""
            raise DHTableError(f"{path}: no such DH table file; {hint}bundled tables: "
                               f"{', '.join(bundled) or 'none'}, or a path to a .yaml file") from None
        raise DHTableError(str(exc)) from None
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
    name = check_dh_name("" if name is None else _text_of(name), f"{source}: field 'name'")

    joints = data["joints"]
    if not isinstance(joints, list):
        raise DHTableError(f"{source}: field 'joints' must be a list of rows {{a, alpha, d, theta}}; got {_kind(joints)}")
    if not joints:
        raise DHTableError(f"{source}: field 'joints' is empty; give one row {{a, alpha, d, theta}} per movable joint")
    if len(joints) > MAX_DH_ROWS:
        raise DHTableError(f"{source}: field 'joints' has {len(joints)} rows, above the limit of {MAX_DH_ROWS} rows of a DH table")
    rows = [_row_from_yaml(item, i, source, angles, to_rad) for i, item in enumerate(joints, start=1)]

    base, base_rpy = _placement_from_yaml(data.get("base", {}), "base", source, angles, to_rad)
    tool, tool_rpy = _placement_from_yaml(data.get("tool", {}), "tool", source, angles, to_rad)
    return DHTable(rows, convention, name, base, tool, base_rpy, tool_rpy)


class _HugeInteger(str):
    """The text of an integer literal too long to be a DH number; :func:`_number` refuses it, naming the field."""


def _table_loader(source: str):
    """A PyYAML SafeLoader class for one file: bounded while composing, strict while constructing.

    Composing (before any value is built): an alias is refused, and so are
    more than ``MAX_YAML_NODES`` values or nesting deeper than
    ``MAX_YAML_DEPTH``. Constructing: a key given twice is refused (PyYAML
    keeps the last one silently), and an integer literal longer than
    ``_LONGEST_INTEGER`` characters stays text (:class:`_HugeInteger`)
    instead of a conversion that overflows or hits Python's digit limit.
    """
    import yaml

    class TableLoader(yaml.SafeLoader):
        nodes = depth = 0

        def compose_node(self, parent, index):
            event = self.peek_event()
            line = event.start_mark.line + 1
            if isinstance(event, yaml.AliasEvent):
                raise DHTableError(f"{source}: line {line}: alias *{event.anchor[:40]} refused; "
                                   "a DH table file holds no aliases (write the value out)")
            self.nodes += 1
            if self.nodes > MAX_YAML_NODES:
                raise DHTableError(f"{source}: line {line}: more than {MAX_YAML_NODES} values, above the limit "
                                   f"for a DH table ({MAX_DH_ROWS} rows at most)")
            if self.depth >= MAX_YAML_DEPTH:
                raise DHTableError(f"{source}: line {line}: nested more than {MAX_YAML_DEPTH} levels deep; "
                                   "a DH table is a mapping with a list of rows")
            self.depth += 1
            try:
                return super().compose_node(parent, index)
            finally:
                self.depth -= 1

    def construct_mapping(loader, node, deep=False):
        seen = {}
        for key_node, _ in node.value:
            key = loader.construct_object(key_node, deep=deep)
            if isinstance(key, str) and key in seen:
                mark = key_node.start_mark
                raise DHTableError(
                    f"{source}: key '{_short(key)[1:-1]}' given twice (line {seen[key]} and line {mark.line + 1}); keep one"
                )
            if isinstance(key, str):
                seen[key] = key_node.start_mark.line + 1
        return yaml.SafeLoader.construct_mapping(loader, node, deep=deep)

    def construct_integer(loader, node):
        if len(node.value) > _LONGEST_INTEGER:
            return _HugeInteger(node.value)
        return yaml.SafeLoader.construct_yaml_int(loader, node)

    def construct_timestamp(loader, node):
        try:
            return yaml.SafeLoader.construct_yaml_timestamp(loader, node)
        except ValueError:  # 2020-13-45 looks like a date but is none: the text, refused where a number is due
            return loader.construct_scalar(node)

    TableLoader.add_constructor(yaml.resolver.BaseResolver.DEFAULT_MAPPING_TAG, construct_mapping)
    TableLoader.add_constructor("tag:yaml.org,2002:int", construct_integer)
    TableLoader.add_constructor("tag:yaml.org,2002:timestamp", construct_timestamp)
    return TableLoader


def _parse_yaml(text: str, source: str):
    import yaml

    try:
        return yaml.load(text, Loader=_table_loader(source))  # a SafeLoader: same safety as yaml.safe_load
    except yaml.YAMLError as exc:
        mark = getattr(exc, "problem_mark", None) or getattr(exc, "context_mark", None)
        where = f" at line {mark.line + 1}, column {mark.column + 1}" if mark is not None else ""
        problem = getattr(exc, "problem", None) or str(exc).splitlines()[0]
        raise DHTableError(f"{source}: malformed YAML{where}: {problem}") from None
    except DHTableError:
        raise
    except (ValueError, OverflowError) as exc:  # a value PyYAML's constructors cannot build (a date out of range)
        raise DHTableError(f"{source}: a value cannot be read ({' '.join(str(exc).split())[:200]})") from None


def _text_of(value) -> str:
    """``str(value)`` for a name or key, described instead when it is a list or mapping (whose text can be huge)."""
    if isinstance(value, (dict, list, set)):
        return f"<a {type(value).__name__} of {len(value)} items>"
    return str(value)


def _short(value, limit: int = 40) -> str:
    """``repr(value)`` cut to ``limit`` characters, so that a message stays short whatever a file holds."""
    if isinstance(value, (dict, list, set)):
        return _text_of(value)
    text = repr(str(value)[: limit + 1] if isinstance(value, str) else value)
    return text if len(text) <= limit else text[: limit - 4] + "...'"


def _kind(value) -> str:
    if value is None:
        return "nothing"
    if isinstance(value, _HugeInteger):
        return f"an integer of {len(value.lstrip('+-'))} digits"
    if isinstance(value, str):
        return f"the text {_short(value)}"
    if isinstance(value, (dict, list)):
        return "a mapping" if isinstance(value, dict) else "a list"
    return _short(value)


def _check_keys(mapping: dict, valid, required, source: str, what: str) -> None:
    for key in mapping:
        if key not in valid:
            key_text = _short(_text_of(key))[1:-1]
            close = difflib.get_close_matches(_text_of(key)[:40], valid, n=1, cutoff=0.5)
            hint = f" (did you mean '{close[0]}'?)" if close else ""
            raise DHTableError(f"{source}: {what}: unknown field '{key_text}'{hint}; valid fields: {', '.join(valid)}")
    for key in required:
        if key not in mapping:
            raise DHTableError(f"{source}: {what}: missing field '{key}'; required fields: {', '.join(required)}")


def _choice(value, valid, source: str, what: str) -> str:
    if not isinstance(value, str) or isinstance(value, _HugeInteger) or value not in valid:
        raise DHTableError(f"{source}: {what} is {_short(value)}; choose {' or '.join(valid)}")
    return value


def _number(value, source: str, what: str, unit: str) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float, str)):
        raise DHTableError(f"{source}: {what} is {_kind(value)}, not a number; give a number in {unit}")
    if isinstance(value, _HugeInteger):
        raise DHTableError(f"{source}: {what} is {_kind(value)}, too large; give a number in {unit}")
    try:
        number = float(value.strip()) if isinstance(value, str) else float(value)
    except ValueError:
        raise DHTableError(f"{source}: {what} is {_short(value)}, not a number; give a number in {unit}") from None
    except OverflowError:  # an integer above the largest float (1.8e308)
        raise DHTableError(f"{source}: {what} is an integer of {len(str(abs(value)))} digits, too large; "
                           f"give a number in {unit}") from None
    if not math.isfinite(number):
        shown = value if not isinstance(value, str) else _short(value.strip())[1:-1]
        raise DHTableError(f"{source}: {what} is {shown}, not finite; give a finite number in {unit}")
    return number


_PI_TOKEN = re.compile(r"\s*(?:(\d+(?:\.\d*)?(?:[eE][+-]?\d+)?|\.\d+(?:[eE][+-]?\d+)?)|(pi|π)|([-+*/()]))")
_LONGEST_EXPRESSION = 60  # characters of a pi expression: "-3*pi/4", "(pi/2 + 0.1)"


def pi_expression_value(text: str) -> float | None:
    """The value of an angle written with pi (``pi/2``, ``-pi/4``, ``3*pi/4``, ``2pi/3``, ``(pi + 0.1)/2``), or None.

    A small parser, not ``eval``: numbers, ``pi`` (or ``π``), ``+ - * /``,
    parentheses and a number written before ``pi`` (``2pi``), at most
    ``_LONGEST_EXPRESSION`` characters. None when ``text`` is not such an
    expression (or has no pi: a plain number is read as one elsewhere).

    >>> pi_expression_value("-pi/4"), pi_expression_value("2*pi/3") == 2 * math.pi / 3, pi_expression_value("pie")
    (-0.7853981633974483, True, None)
    """
    text = text.strip()
    if len(text) > _LONGEST_EXPRESSION or not ("pi" in text or "π" in text):
        return None
    tokens, position = [], 0
    while position < len(text):
        match = _PI_TOKEN.match(text, position)
        if match is None or match.end() == position:
            return None
        number, pi, operator = match.groups()
        tokens.append(float(number) if number else math.pi if pi else operator)
        position = match.end()
    tokens.append(None)  # the end
    at = 0

    def peek():
        return tokens[at]

    def take():
        nonlocal at
        at += 1
        return tokens[at - 1]

    def factor(depth=0):
        if depth > 20:
            raise ValueError
        token = take()
        if token in ("+", "-"):
            value = factor(depth + 1)
            return value if token == "+" else -value
        if token == "(":
            value = expression(depth + 1)
            if take() != ")":
                raise ValueError
        elif isinstance(token, float):
            value = token
        else:
            raise ValueError
        if isinstance(peek(), float) and peek() == math.pi:  # 2pi
            take()
            value *= math.pi
        return value

    def term(depth):
        value = factor(depth)
        while peek() in ("*", "/"):
            operator, right = take(), factor(depth)
            value = value * right if operator == "*" else value / right
        return value

    def expression(depth=0):
        value = term(depth)
        while peek() in ("+", "-"):
            operator, right = take(), term(depth)
            value = value + right if operator == "+" else value - right
        return value

    try:
        value = expression()
    except (ValueError, ZeroDivisionError, OverflowError):
        return None
    return value if peek() is None and math.isfinite(value) else None


def _angle(value, source: str, what: str, angles: str, to_rad) -> float:
    """An angle in radians: a number in the file's unit, or (``angles: rad``) a pi expression such as ``pi/2``."""
    if isinstance(value, str) and not isinstance(value, _HugeInteger) and ("pi" in value or "π" in value):
        if angles == "deg":
            raise DHTableError(f"{source}: {what} is {_short(value)}, a pi expression, but the file's angles are "
                               "degrees; write degrees (90), or set angles: rad")
        number = pi_expression_value(value)
        if number is None:
            raise DHTableError(f"{source}: {what} is {_short(value)}, not a number or pi expression; give radians "
                               "as a number or with pi (pi/2, -pi/4, 3*pi/4)")
        return number
    return to_rad(_number(value, source, what, _angle_unit(angles)))


def _numbers(value, count: int, source: str, what: str, unit: str) -> list[float]:
    if not isinstance(value, list) or len(value) != count:
        raise DHTableError(f"{source}: {what} must be a list of {count} numbers in {unit}; got {_kind(value)}")
    return [_number(v, source, f"{what} entry {i}", unit) for i, v in enumerate(value, start=1)]


def _angles(value, count: int, source: str, what: str, angles: str, to_rad) -> list[float]:
    if not isinstance(value, list) or len(value) != count:
        raise DHTableError(f"{source}: {what} must be a list of {count} numbers in {_angle_unit(angles)}; got {_kind(value)}")
    return [_angle(v, source, f"{what} entry {i}", angles, to_rad) for i, v in enumerate(value, start=1)]


def _angle_unit(angles: str) -> str:
    return "degrees (angles: deg)" if angles == "deg" else "radians (angles: rad)"


def _row_from_yaml(item, index: int, source: str, angles: str, to_rad) -> DHRow:
    where = f"row {index}"
    if not isinstance(item, dict):
        raise DHTableError(f"{source}: {where} must be a mapping {{a, alpha, d, theta}}; got {_kind(item)}")
    _check_keys(item, _ROW_FIELDS + _ROW_OPTIONAL, _ROW_FIELDS, source, where)
    a = _number(item["a"], source, f"{where}: field 'a'", "metres")
    d = _number(item["d"], source, f"{where}: field 'd'", "metres")
    alpha = _angle(item["alpha"], source, f"{where}: field 'alpha'", angles, to_rad)
    theta = _angle(item["theta"], source, f"{where}: field 'theta'", angles, to_rad)
    kind = _choice(item.get("type", "revolute"), JOINT_TYPES, source, f"{where}: field 'type'")
    qlim = None
    if item.get("qlim") is not None:
        if kind == "revolute":
            lower, upper = _angles(item["qlim"], 2, source, f"{where}: field 'qlim'", angles, to_rad)
        else:
            lower, upper = _numbers(item["qlim"], 2, source, f"{where}: field 'qlim'", "metres")
        if not lower < upper:
            shown = (math.degrees if angles == "deg" and kind == "revolute" else float)
            raise DHTableError(f"{source}: {where}: field 'qlim' is [{short_text(shown(lower))}, {short_text(shown(upper))}]; "
                               "the lower limit must be below the upper")
        qlim = (lower, upper)
    name = item.get("name", "")
    name = check_dh_name("" if name is None else _text_of(name), f"{source}: {where}: field 'name'")
    return DHRow(a, alpha, d, theta, kind, qlim, name)


def _placement_from_yaml(value, what: str, source: str, angles: str, to_rad):
    if not isinstance(value, dict):
        raise DHTableError(f"{source}: field '{what}' must be a mapping {{xyz: [x, y, z], rpy: [roll, pitch, yaw]}}; got {_kind(value)}")
    _check_keys(value, _PLACEMENT_FIELDS, (), source, f"field '{what}'")
    if not value:
        return np.eye(4), None
    xyz = _numbers(value.get("xyz", [0, 0, 0]), 3, source, f"{what}: field 'xyz'", "metres")
    rpy = _angles(value.get("rpy", [0, 0, 0]), 3, source, f"{what}: field 'rpy'", angles, to_rad)
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
        A value that is not finite, a base or tool that is not a rigid
        transform.
    OutputError
        The file cannot be written (``cannot write PATH: reason``: a missing
        folder, which is not created, a path that is a folder, no
        permission, a full disk).

    Examples
    --------
    >>> import tempfile
    >>> table = DHTable([DHRow(1, 0, 0, 0), DHRow(1, 0, 0, 0)], "standard", "planar_2r")
    >>> with tempfile.TemporaryDirectory() as folder:
    ...     save_dh(table, Path(folder) / "planar_2r.yaml")
    ...     load_dh(Path(folder) / "planar_2r.yaml") == table
    True
    """
    text = yaml_from_dh(table, angles=angles, header=header)
    write_text(path, text)


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
        raise DHTableError(f"angles '{angles}': choose deg or rad")
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
        xyz, rpy = table.placement_xyz_rpy(what)
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
