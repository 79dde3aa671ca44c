"""Joint configurations from a CSV file: one joint vector a row, columns named by joint.

The file format (``tf-between --q-file``)::

    # comment lines (first cell starting with '#') and blank lines are skipped
    shoulder_joint,elbow_joint
    0.1,0.2
    0.3,-0.4

The first row that is not a comment is the header: joint names of the robot,
each at most once, in any order. Each following row holds one value per
header column; joints the header leaves out are 0 (or the nearest value
inside their limits, as :meth:`manipkit.kinematics.robot.Robot.q` gives).
Values are radians and metres, or degrees for angular joints when
``degrees=True`` (prismatic joints stay in metres). Messages name the file
and the line number in the file (comments and blank lines counted), so a
user can find the row. Conventions: docs/architecture.md.
"""

from __future__ import annotations

import csv
import difflib
import math
import warnings
from collections.abc import Iterator
from typing import TYPE_CHECKING

import numpy as np

from manipkit.errors import JointLimitError, JointValueError, ManipkitError

if TYPE_CHECKING:
    from manipkit.kinematics.robot import Robot

__all__ = ["joint_limits_error", "read_q_file"]

_LIMIT_POLICIES = ("ignore", "error", "clamp")


def read_q_file(robot: Robot, path, *, degrees: bool = False, limits: str = "ignore") -> np.ndarray:
    """Joint vectors from a CSV file whose header names joints (format in the module docstring).

    Parameters
    ----------
    robot : Robot
        The robot whose joints the columns name.
    path : str or os.PathLike
        The CSV file.
    degrees : bool, keyword-only
        Angular values are in degrees (prismatic joints stay in metres).
    limits : {"ignore", "error", "clamp"}, keyword-only
        ``"ignore"``: values as given. ``"error"``: a value outside its
        joint's limits raises :class:`JointLimitError` naming the line.
        ``"clamp"``: such values move to the nearest limit, with one
        ``UserWarning`` summing up what was clamped.

    Returns
    -------
    Q : ndarray, shape (N, n)
        One joint vector a data row, in ``robot.joint_names`` order (radians, metres).

    Raises
    ------
    JointValueError
        The file cannot be read, is not CSV text, has no data row, names an
        unknown or repeated joint, has a row of the wrong length or a cell
        that is not a finite number. The message starts with ``path`` (and
        ``line N`` for a row).
    JointLimitError
        With ``limits="error"``: the first row with a value outside the
        limits. The message starts with ``path: line N:`` and gives the
        limits in degrees when ``degrees`` is true; the attributes
        (``joint``, ``value``, ``lower``, ``upper``, ``unit``) stay in
        radians and metres.

    Examples
    --------
    >>> import manipkit, pathlib, tempfile
    >>> robot = manipkit.load("planar_2r")
    >>> with tempfile.TemporaryDirectory() as folder:
    ...     path = pathlib.Path(folder, "q.csv")
    ...     _ = path.write_text("# joint2 in degrees\\njoint2\\n90\\n-45\\n")
    ...     Q = read_q_file(robot, path, degrees=True)
    >>> Q.round(4)
    array([[ 0.    ,  1.5708],
           [ 0.    , -0.7854]])
    """
    if limits not in _LIMIT_POLICIES:
        raise JointValueError(f"limits={limits!r}: choose one of {', '.join(_LIMIT_POLICIES)}")
    numbered = _data_rows(path)
    if len(numbered) < 2:
        raise JointValueError(f"{path}: needs a header of joint names and at least one row")
    header = _checked_header(robot, path, numbered[0][1])
    Q = np.empty((len(numbered) - 1, len(robot.joint_names)))
    clamped: list[str] = []
    for index, (number, row) in enumerate(numbered[1:]):
        if len(row) != len(header):
            raise JointValueError(f"{path}: line {number} has {len(row)} values, the header has {len(header)}")
        try:
            q = robot.q(dict(zip(header, (cell.strip() for cell in row))), degrees=degrees)
        except ManipkitError as exc:
            raise JointValueError(f"{path}: line {number}: {exc}") from None
        violations = [] if limits == "ignore" else robot.limit_violations(q)
        if violations and limits == "clamp":
            clamped += [f"line {number} {error.joint}" for error in violations]
            q = robot.clamp(q)
        elif violations:
            raise joint_limits_error(violations, degrees=degrees, prefix=f"{path}: line {number}: ")
        Q[index] = q
    if clamped:
        warnings.warn(f"{path}: clamped {len(clamped)} value(s) into the joint limits "
                      f"({', '.join(clamped[:3])}{', ...' if len(clamped) > 3 else ''})", UserWarning, stacklevel=2)
    return Q


def joint_limits_error(violations: list[JointLimitError], *, degrees: bool = False, prefix: str = "") -> JointLimitError:
    """One error for the joints of a vector outside their limits, in the unit the user gave them.

    Parameters
    ----------
    violations : list of JointLimitError
        From :meth:`manipkit.kinematics.robot.Robot.limit_violations` (not empty).
    degrees : bool, keyword-only
        The values were given in degrees: an angular joint's value and limits
        are said in degrees.
    prefix : str, keyword-only
        Put before the message (for example ``"q.csv: line 4: "``).

    Returns
    -------
    JointLimitError
        The first violation, its message in the user's unit and naming up to
        three more joints outside their limits; its attributes (``joint``,
        ``value``, ``lower``, ``upper``, ``unit``) stay in radians and metres.

    Examples
    --------
    >>> print(joint_limits_error([JointLimitError("j", math.pi, -math.pi / 2, math.pi / 2)], degrees=True))
    joint 'j' = 180 is above its upper limit 90 (limits [-90, 90] deg)
    """
    first = violations[0]
    shown = first
    if degrees and first.unit == "rad":
        shown = JointLimitError(first.joint, *(math.degrees(v) for v in (first.value, first.lower, first.upper)), unit="deg")
    message = f"{prefix}{shown}"
    if len(violations) > 1:
        message += "; also outside: " + ", ".join(e.joint for e in violations[1:4]) + (", ..." if len(violations) > 4 else "")
    error = JointLimitError(first.joint, first.value, first.lower, first.upper, first.unit)
    error.args = (message,)
    return error


def _data_rows(path) -> list[tuple[int, list[str]]]:
    """(line number, cells) of each row that is neither blank nor a comment."""
    try:
        with open(path, newline="", encoding="utf-8") as handle:
            return [
                (line, row) for line, row in _numbered_rows(csv.reader(handle))
                if row and any(cell.strip() for cell in row) and not row[0].lstrip().startswith("#")
            ]
    except IsADirectoryError:
        raise JointValueError(f"{path}: is a folder, expected a CSV file") from None
    except OSError as exc:
        raise JointValueError(f"{path}: cannot read ({exc.strerror or exc})") from None
    except UnicodeDecodeError:
        raise JointValueError(f"{path}: not a text file; expected CSV with a header of joint names") from None
    except csv.Error as exc:
        raise JointValueError(f"{path}: not valid CSV ({exc})") from None


def _numbered_rows(reader) -> Iterator[tuple[int, list[str]]]:
    """(line number in the file, row) for each CSV row."""
    for row in reader:
        yield reader.line_num, row


def _checked_header(robot: Robot, path, cells: list[str]) -> list[str]:
    """The header's joint names, each a joint of ``robot`` given once."""
    header = [cell.strip() for cell in cells]
    unknown = [name for name in header if name not in robot.joint_names]
    if unknown:
        close = difflib.get_close_matches(unknown[0], robot.joint_names, n=1, cutoff=0.5)
        hint = f"did you mean {close[0]}? " if close else ""
        raise JointValueError(f"{path}: unknown joint column(s) {', '.join(unknown)}; {hint}"
                              f"joints: {', '.join(robot.joint_names)}")
    repeated = sorted({name for name in header if header.count(name) > 1})
    if repeated:
        raise JointValueError(f"{path}: column(s) {', '.join(repeated)} appear twice in the header")
    return header
