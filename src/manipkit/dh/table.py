"""Denavit-Hartenberg tables: the rows, the table and its forward kinematics (numpy only).

Conventions (docs/architecture.md):

- Standard DH (Spong, Corke ``DHRobot``), one row per joint i:
  ``A_i = Rz(theta_i) Tz(d_i) Tx(a_i) Rx(alpha_i)``; joint i moves about (or
  along) ``z_{i-1}``.
- Modified DH (Craig), row i holds ``a_{i-1}, alpha_{i-1}, d_i, theta_i``:
  ``A_i = Rx(alpha_{i-1}) Tx(a_{i-1}) Rz(theta_i) Tz(d_i)``; joint i moves
  about (or along) ``z_i``.
- For a revolute row, ``theta`` is the constant offset added to the joint
  value; for a prismatic row, ``d`` is.
- ``T_base_tool(q) = base @ A_1(q_1) @ ... @ A_n(q_n) @ tool``.
- Metres and radians.
- ``rpy`` (base and tool placements) is ``(roll, pitch, yaw)`` with
  ``R = Rz(yaw) Ry(pitch) Rx(roll)``, as in URDF.

The rest of :mod:`manipkit.dh` builds on this module: table files
(:mod:`~manipkit.dh.files`), the boxed printout (:mod:`~manipkit.dh.text`),
SymPy forward kinematics (:mod:`~manipkit.dh.symbolic`), URDF export
(:mod:`~manipkit.dh.to_urdf`) and import (:mod:`~manipkit.dh.from_urdf`), and
the check against a robot (:mod:`~manipkit.dh.check`).
"""

from __future__ import annotations

import re
from dataclasses import dataclass, field

import numpy as np

from manipkit.bounds import MAX_ANGLE
from manipkit.dh.text import format_dh_table, html_dh_table, latex_dh_table
from manipkit.errors import DHTableError, InvalidRotationError, JointValueError
from manipkit.spatial.rotations import matrix_from_rpy, rpy_from_matrix
from manipkit.text import repr_text, short_text

__all__ = [
    "CONVENTIONS",
    "JOINT_TYPES",
    "MAX_DH_ROWS",
    "DHRow",
    "DHTable",
    "check_dh_name",
    "dh_fk",
    "dh_link_transform",
]

CONVENTIONS = ("standard", "modified")
JOINT_TYPES = ("revolute", "prismatic")
#: Rows a DH table file may have (real arms have up to a dozen; snakes a few hundred).
MAX_DH_ROWS = 1000


def check_dh_name(name: str, what: str) -> str:
    """``name`` if it is one line of printable text (a table's or a row's name), else DHTableError.

    Names are written into URDF (XML), YAML, LaTeX and boxed text, so a
    control character (Unicode category Cc: a line break, a tab, an escape
    sequence, NUL) or a lone surrogate (not writable as UTF-8) is refused;
    ``what`` says where the name came from. (The non-characters U+FFFE and
    U+FFFF, which only XML refuses, are refused by ``urdf_from_dh``.)

    >>> check_dh_name("iiwa_joint_2", "row 2: field 'name'")
    'iiwa_joint_2'
    """
    bad = _NOT_IN_A_NAME.search(name)
    if bad:
        raise DHTableError(
            f"{what}: character {bad.start() + 1} is U+{ord(bad.group()):04X}, not printable text; "
            "a name is one line of printable text (no line break, tab or other control character)"
        )
    return name


# Unicode's control characters (category Cc) and lone surrogates (category Cs)
_NOT_IN_A_NAME = re.compile("[\x00-\x1f\x7f-\x9f\ud800-\udfff]")


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
            object.__setattr__(self, attribute, _as_float(getattr(self, attribute), f"DH row field '{attribute}'"))
        if self.type not in JOINT_TYPES:
            raise DHTableError(f"DH row type '{self.type}': choose revolute or prismatic")
        if self.qlim is not None:
            try:
                lower, upper = (float(v) for v in self.qlim)
            except (TypeError, ValueError):
                raise DHTableError(f"DH row qlim is {self.qlim!r:.60}; give two numbers (lower, upper)") from None
            object.__setattr__(self, "qlim", (lower, upper))
        object.__setattr__(self, "name", check_dh_name(str(self.name), "DH row field 'name'"))

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
            raise DHTableError(f"convention '{self.convention}': choose standard or modified")
        object.__setattr__(self, "rows", tuple(self.rows))
        object.__setattr__(self, "name", check_dh_name(str(self.name), "DH table name"))
        for i, row in enumerate(self.rows, start=1):
            if not isinstance(row, DHRow):
                raise DHTableError(f"DH table row {i} is a {type(row).__name__}, not a DHRow")
        for attribute in ("base", "tool"):
            try:
                matrix = np.array(getattr(self, attribute), dtype=float)
            except (TypeError, ValueError):
                raise DHTableError(f"DH table {attribute} must be a 4x4 transform of numbers, got {getattr(self, attribute)!r:.60}") from None
            if matrix.shape != (4, 4):
                raise DHTableError(f"DH table {attribute} must be a 4x4 transform, got shape {matrix.shape}")
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

    def __repr__(self) -> str:
        kinds = "".join("R" if row.is_revolute else "P" for row in self.rows)
        placed = [what for what in ("base", "tool") if not np.array_equal(getattr(self, what), np.eye(4))]
        return (f"DHTable({self.name!r}, {self.convention} DH, {self.n} joints {kinds}"
                + "".join(f", with {what}" for what in placed) + "; print() it for the table)")

    def _repr_html_(self) -> str:
        """Jupyter's view: the table as HTML (:func:`manipkit.dh.text.html_dh_table`)."""
        return html_dh_table(self)

    def _repr_latex_(self) -> str:
        """LaTeX math of the table (:func:`manipkit.dh.text.latex_dh_table`), for Jupyter and nbconvert."""
        return latex_dh_table(self)

    @property
    def n(self) -> int:
        """Number of joints."""
        return len(self.rows)

    def placement_xyz_rpy(self, which: str, *, check: bool = True,
                          gimbal_tol: float = 1e-12) -> tuple[np.ndarray, np.ndarray]:
        """Translation (m) and roll-pitch-yaw (rad) of ``base`` or ``tool``.

        ``R = Rz(yaw) Ry(pitch) Rx(roll)``. The table's ``base_rpy`` /
        ``tool_rpy`` are returned when they still give the matrix's rotation
        exactly (so a file's angles come back as written); otherwise the angles
        are computed from the matrix.

        Parameters
        ----------
        which : {"base", "tool"}
        check : bool, keyword-only
            Default: a bottom row other than ``[0, 0, 0, 1]`` or a block that is
            not a rotation raises :class:`~manipkit.errors.DHTableError`.
            ``False`` (for printing): the block's angles are read as they are.
        gimbal_tol : float, keyword-only
            Computed angles: where ``cos(pitch) <= gimbal_tol`` the rotation
            counts as gimbal-locked and roll is 0 (``rpy_from_matrix``). The
            printout uses 1e-9, so a pitch of 90 deg up to rounding noise
            reads ``[0, 90, yaw]`` instead of noise-chosen roll and yaw.

        Examples
        --------
        >>> from manipkit.spatial.transforms import transform_from_xyz_rpy
        >>> tool = transform_from_xyz_rpy([0, 0, 0.1], [0, 0, 0.5])
        >>> DHTable([DHRow(1, 0, 0, 0)], tool=tool, tool_rpy=(0, 0, 0.5)).placement_xyz_rpy("tool")
        (array([0. , 0. , 0.1]), array([0. , 0. , 0.5]))
        """
        T, rpy_hint = getattr(self, which), getattr(self, f"{which}_rpy")
        if check and not np.array_equal(T[3], [0.0, 0.0, 0.0, 1.0]):
            raise DHTableError(f"DH table {which}: bottom row is {T[3].tolist()}, not [0, 0, 0, 1]")
        if rpy_hint is not None and np.array_equal(matrix_from_rpy(np.array(rpy_hint)), T[:3, :3]):
            return T[:3, 3], np.array(rpy_hint)
        try:
            rpy = rpy_from_matrix(T[:3, :3], check=check, gimbal_tol=gimbal_tol)
        except InvalidRotationError as exc:
            raise DHTableError(f"DH table {which}: {exc}") from None
        return T[:3, 3], rpy


def _as_float(value, what: str) -> float:
    try:
        return float(value)
    except (TypeError, ValueError):
        raise DHTableError(f"{what} is {value!r:.40}, not a number") from None


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
    if convention not in ("standard", "modified"):
        raise DHTableError(f"convention '{convention}': choose standard or modified")
    ct, st = np.cos(theta), np.sin(theta)
    ca, sa = np.cos(alpha), np.sin(alpha)
    A = np.zeros(a.shape + (4, 4))  # filled in place: 12 us for one row, 42 us when stacked from lists
    if convention == "standard":
        A[..., 0, 0], A[..., 0, 1], A[..., 0, 2], A[..., 0, 3] = ct, -st * ca, st * sa, a * ct
        A[..., 1, 0], A[..., 1, 1], A[..., 1, 2], A[..., 1, 3] = st, ct * ca, -ct * sa, a * st
        A[..., 2, 1], A[..., 2, 2], A[..., 2, 3] = sa, ca, d
    else:
        A[..., 0, 0], A[..., 0, 1], A[..., 0, 3] = ct, -st, a
        A[..., 1, 0], A[..., 1, 1], A[..., 1, 2], A[..., 1, 3] = st * ca, ct * ca, -sa, -d * sa
        A[..., 2, 0], A[..., 2, 1], A[..., 2, 2], A[..., 2, 3] = st * sa, ct * sa, ca, d * ca
    A[..., 3, 3] = 1.0
    return A


def dh_fk(table: DHTable, q, *, upto: int | None = None, check: bool = True) -> np.ndarray:
    """T_base_tool of a DH table, vectorised over configurations.

    Parameters
    ----------
    table : DHTable
    q : array_like, shape (..., n)
        Joint values (rad for revolute rows, m for prismatic rows).
    upto : int, optional
        Stop after this many rows and leave out the tool: the pose of DH
        frame ``upto`` in the base (``upto=0`` gives ``table.base``).
    check : bool, keyword-only
        Refuse joint values that are not finite or beyond
        :data:`manipkit.bounds.MAX_ANGLE` (default); False lets NaN rows
        through as NaN poses (a batch of solver slots, some empty).

    Returns
    -------
    T : ndarray, shape (..., 4, 4)

    Examples
    --------
    >>> table = DHTable((DHRow(1.0, 0.0, 0.0, 0.0), DHRow(1.0, 0.0, 0.0, 0.0)))
    >>> np.round(dh_fk(table, [0.0, np.pi / 2])[:3, 3], 12)  # planar 2R, elbow at 90 deg
    array([1., 1., 0.])
    """
    try:
        q = np.asarray(q, dtype=float)
    except (TypeError, ValueError, OverflowError):
        raise JointValueError(f"DH table '{table.name}': q must be numbers, got {repr_text(q)}") from None
    if q.shape[-1:] != (table.n,):
        raise JointValueError(f"DH table '{table.name}' has {table.n} rows; q has shape {q.shape}")
    if check and not (np.abs(q) <= MAX_ANGLE).all():  # False for NaN too
        bad = np.argwhere(~(np.abs(q) <= MAX_ANGLE))[0]
        raise JointValueError(
            f"DH table '{table.name}': q[{', '.join(str(int(i)) for i in bad)}] = {q[tuple(bad)]}; joint values must "
            f"be finite, at most {short_text(MAX_ANGLE)} (rad or m) in magnitude"
        )
    count = table.n if upto is None else upto
    T = np.broadcast_to(table.base, q.shape[:-1] + (4, 4)).copy()
    for i, row in enumerate(table.rows[:count]):
        qi = q[..., i]
        theta = row.theta + qi if row.is_revolute else np.full_like(qi, row.theta)
        d = np.full_like(qi, row.d) if row.is_revolute else row.d + qi
        T = T @ dh_link_transform(row.a, row.alpha, d, theta, convention=table.convention)
    return T @ table.tool if upto is None else T
