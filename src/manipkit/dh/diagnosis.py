"""What :func:`manipkit.dh.check.check_dh` found, as data: the diagnosis of a DH table against a URDF chain.

No words here: :mod:`manipkit.app.dh_text` turns a diagnosis into the
sentences ``manipkit dh check`` prints. Every object is immutable (frozen
dataclasses, read-only arrays).

:class:`DHDiagnosis` says which stage of the check explained the
difference (``kind``, one of ``DIAGNOSIS_KINDS``):

- ``"agrees"``: the table passed; nothing else is set;
- ``"row count"``: the table's rows do not match the chain's movable joints
  (``rows``; ``extra_row`` when there is exactly one row too many);
- ``"no joints"``: the chain has no movable joint, so the table and the URDF
  differ by the constant ``tool`` transform alone;
- ``"base and tool"``, ``"single entry"``, ``"length with base and tool"``,
  ``"reversed joint"``: that stage's correction reconciles the table with
  the URDF fully; ``fixes`` lists every full correction found, the simplest
  first (``fixes[0]`` gave ``DHCheck.candidate``);
- ``"axes compared"``: none of those reconciles them; the joint axes at
  q = 0 (``axes``) show which joints turn the other way and where the axes
  stop agreeing (``first_difference``), ``fixes`` holds a full correction
  found by comparing the axes (joint directions, base and tool, joint zero
  offsets) or ``partial`` the best one that at least halves the error, and
  ``differences`` every entry in which the table differs from ``derived``,
  the table :func:`~manipkit.dh.from_urdf.dh_from_urdf_chain` derives in
  the same convention (then ``DHCheck.candidate``).

A :class:`DHCorrection` is one correction tried (``kind`` from
``CORRECTION_KINDS``) with the largest error it leaves over the samples.

Conventions (docs/architecture.md): metres and radians (``EntryChange.unit``
says which), transforms are 4 x 4 homogeneous, rows and joints are numbered
from 1 as a table is printed; joint names are ``DHCheck.joints[joint - 1]``.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from manipkit.dh.entries import ANGLE_ENTRIES

if TYPE_CHECKING:
    from manipkit.dh.table import DHRow, DHTable

__all__ = [
    "AXIS_RELATIONS", "CORRECTION_KINDS", "DIAGNOSIS_KINDS", "AxisComparison", "DHCorrection", "DHDiagnosis", "EndChange",
    "EntryChange",
]

#: The stages of the diagnosis, simplest first (``DHDiagnosis.kind``).
DIAGNOSIS_KINDS = (
    "agrees", "row count", "no joints", "base and tool", "single entry", "length with base and tool",
    "reversed joint", "axes compared",
)
#: The kinds of one correction (``DHCorrection.kind``).
CORRECTION_KINDS = ("base and tool", "single entry", "length with base and tool", "reversed joint", "joint offsets")
#: How a joint's axis in the table compares with the URDF's at q = 0 (``AxisComparison.relation``).
AXIS_RELATIONS = ("same", "reversed", "joint type", "different")


def _frozen(array) -> np.ndarray:
    out = np.array(array, dtype=float)
    out.flags.writeable = False
    return out


@dataclass(frozen=True)
class EntryChange:
    """One DH entry: the table's value and the value the URDF implies for it.

    Attributes
    ----------
    row : int
        Row number, from 1.
    entry : str
        ``"a"``, ``"alpha"``, ``"d"`` or ``"theta"``.
    table_value, urdf_value : float
        In ``unit``. ``urdf_value`` is the value that makes the table agree
        together with the rest of the correction it belongs to (for a
        reversed joint: the value the reversal gives the entry).
    """

    row: int
    entry: str
    table_value: float
    urdf_value: float

    @property
    def unit(self) -> str:
        """``"rad"`` for alpha and theta, ``"m"`` for a and d."""
        return "rad" if self.entry in ANGLE_ENTRIES else "m"


@dataclass(frozen=True, eq=False)
class EndChange:
    """The table's base (before row 1) or tool (after the last row) and the one the URDF implies (4 x 4, read-only)."""

    end: str
    table_value: np.ndarray
    urdf_value: np.ndarray

    def __post_init__(self):
        object.__setattr__(self, "table_value", _frozen(self.table_value))
        object.__setattr__(self, "urdf_value", _frozen(self.urdf_value))


@dataclass(frozen=True, eq=False)
class AxisComparison:
    """One joint's axis in the table against the URDF's, at q = 0 in the base frame (read-only arrays).

    Attributes
    ----------
    joint : int
        Joint (row) number, from 1.
    relation : str
        ``"same"`` (equal screws), ``"reversed"`` (opposite screws: the joint
        turns, or slides, the other way), ``"joint type"`` (one turns, the
        other slides) or ``"different"``.
    urdf_direction, table_direction : ndarray, shape (3,)
        Unit direction of the axis (of the motion, for a sliding joint).
    urdf_point, table_point : ndarray, shape (3,), or None
        The point of the axis nearest the base's origin (m); None for a
        joint that slides.
    angle : float
        Angle between the two axis lines, 0 to pi/2 (rad).
    distance : float or None
        Distance between the two axis lines (m); None unless both turn.
    """

    joint: int
    relation: str
    urdf_direction: np.ndarray
    table_direction: np.ndarray
    urdf_point: np.ndarray | None
    table_point: np.ndarray | None
    angle: float
    distance: float | None

    def __post_init__(self):
        for name in ("urdf_direction", "table_direction", "urdf_point", "table_point"):
            if getattr(self, name) is not None:
                object.__setattr__(self, name, _frozen(getattr(self, name)))

    @property
    def urdf_slides(self) -> bool:
        """The URDF joint slides (prismatic) rather than turns."""
        return self.urdf_point is None


@dataclass(frozen=True, eq=False)
class DHCorrection:
    """A correction of the table and the largest error it leaves over the samples.

    Attributes
    ----------
    kind : str
        One of ``CORRECTION_KINDS``:

        - ``"base and tool"``: a constant ``base`` transform before row 1
          and/or ``tool`` transform after the last row (None: not part of
          it; neither: the table as it stands);
        - ``"single entry"``: ``entry`` takes the value the URDF implies;
        - ``"length with base and tool"``: one length (a or d) ``entry``,
          with the ``base`` and ``tool`` transforms fitted with it (either
          may be the identity, within ``RECONCILE_TOL``: not needed);
        - ``"reversed joint"``: joint ``reversed[0]`` turned the other way
          by rewriting the table (``changes``), with ``base`` and/or
          ``tool`` as for ``"base and tool"``;
        - ``"joint offsets"``: ``offsets`` added to the joint values (theta
          of a turning joint, d of a sliding one) and the ``tool`` left at
          the tip.
    residual : float
        Largest position (m) or rotation (rad) error left over the samples.
    candidate : DHTable or None
        The corrected table, when the correction is one (None when it is
        only described: joints reversed as the table stands, offsets).
    entry : EntryChange or None
        The entry of ``"single entry"`` and ``"length with base and tool"``.
    reversed : tuple of int
        Joints (from 1) that turn the other way: the one ``"reversed
        joint"`` rewrites; for the other kinds, joints whose values are
        negated as the table stands (``q_table = -q_urdf``).
    changes : tuple of EntryChange and EndChange
        How ``"reversed joint"`` rewrites the table (``urdf_value`` the new value).
    base, tool : ndarray, shape (4, 4), or None
        Constant transforms before row 1 and after the last row.
    offsets : tuple of (int, float)
        ``(joint, offset)`` for each joint with a zero offset (rad, or m
        for a sliding joint), ``"joint offsets"`` only.
    """

    kind: str
    residual: float
    candidate: DHTable | None = None
    entry: EntryChange | None = None
    reversed: tuple[int, ...] = ()
    changes: tuple[EntryChange | EndChange, ...] = ()
    base: np.ndarray | None = None
    tool: np.ndarray | None = None
    offsets: tuple[tuple[int, float], ...] = ()

    def __post_init__(self):
        if self.kind not in CORRECTION_KINDS:
            raise ValueError(f"correction kind {self.kind!r}: choose one of {', '.join(CORRECTION_KINDS)}")
        for name in ("base", "tool"):
            if getattr(self, name) is not None:
                object.__setattr__(self, name, _frozen(getattr(self, name)))
        object.__setattr__(self, "reversed", tuple(int(j) for j in self.reversed))
        object.__setattr__(self, "changes", tuple(self.changes))
        object.__setattr__(self, "offsets", tuple((int(j), float(o)) for j, o in self.offsets))


@dataclass(frozen=True, eq=False)
class DHDiagnosis:
    """Why a DH table does not agree with the URDF chain, as data (see the module's docstring for ``kind``).

    Attributes
    ----------
    kind : str
        One of ``DIAGNOSIS_KINDS``: the stage that explained the difference.
    fixes : tuple of DHCorrection
        Every correction that reconciles the table with the URDF fully,
        simplest first.
    axes : tuple of AxisComparison
        Each joint's axis against the URDF's at q = 0, as the table stands
        (every kind but ``"agrees"``, ``"row count"`` and ``"no joints"``).
    partial : DHCorrection or None
        ``"axes compared"`` with no full fix: the best correction tried, when
        it at least halves the largest error.
    derived : DHTable or None
        ``"axes compared"``: the table derived from the URDF in the same
        convention, when its rows match the table's in kind.
    differences : tuple of EntryChange and EndChange
        Every entry (and base or tool) in which the table differs from
        ``derived`` (angles modulo 2 pi).
    rows : int
        ``"row count"``: the table's rows (the chain's joints are ``DHCheck.joints``).
    extra_row : DHRow or None
        ``"row count"`` with one row too many: the last row, which has no joint.
    tool : ndarray, shape (4, 4), or None
        ``"no joints"``: the constant transform ``T_table^-1 T_urdf`` after the table.

    Examples
    --------
    >>> import manipkit
    >>> from manipkit.dh import DHRow, DHTable, check_dh
    >>> rows = [DHRow(4, 0, 0, 0), DHRow(2.5, 0, 0, 0), DHRow(1, 0, 0, 0)]  # planar_3r's a_2 is 2 m
    >>> diagnosis = check_dh(DHTable(rows, "standard"), manipkit.load("planar_3r"), samples=50).diagnosis
    >>> diagnosis.kind, diagnosis.fixes[0].entry
    ('single entry', EntryChange(row=2, entry='a', table_value=2.5, urdf_value=2.0))
    >>> diagnosis.first_difference, diagnosis.reversed_joints  # at q = 0, joint 3's axis is 0.5 m off
    (3, ())
    """

    kind: str
    fixes: tuple[DHCorrection, ...] = ()
    axes: tuple[AxisComparison, ...] = ()
    partial: DHCorrection | None = None
    derived: DHTable | None = None
    differences: tuple[EntryChange | EndChange, ...] = ()
    rows: int = 0
    extra_row: DHRow | None = None
    tool: np.ndarray | None = None

    def __post_init__(self):
        if self.kind not in DIAGNOSIS_KINDS:
            raise ValueError(f"diagnosis kind {self.kind!r}: choose one of {', '.join(DIAGNOSIS_KINDS)}")
        for name in ("fixes", "axes", "differences"):
            object.__setattr__(self, name, tuple(getattr(self, name)))
        if self.tool is not None:
            object.__setattr__(self, "tool", _frozen(self.tool))

    @property
    def reversed_joints(self) -> tuple[int, ...]:
        """Joints (from 1) whose table axis is the URDF's reversed at q = 0, as the table stands."""
        return tuple(a.joint for a in self.axes if a.relation == "reversed")

    @property
    def differing_joints(self) -> tuple[int, ...]:
        """Joints (from 1) whose table axis is not the URDF's, up to its sense, at q = 0."""
        return tuple(a.joint for a in self.axes if a.relation not in ("same", "reversed"))

    @property
    def first_difference(self) -> int | None:
        """The first joint (from 1) where the axes stop agreeing at q = 0; None when all lie on the URDF's."""
        return next(iter(self.differing_joints), None)
