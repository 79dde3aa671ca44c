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
user can find the row. A UTF-8 byte-order mark (Excel's "CSV UTF-8") is
skipped. Conventions: docs/architecture.md.

:func:`iter_q_file` streams the rows in batches (memory bounded by the batch,
whatever the file's length); :func:`read_q_file` returns them all as one
array. Both refuse a FIFO, device or symlink loop before reading
(:func:`manipkit.inputs.check_input_file`) and a line longer than
:data:`MAX_LINE_CHARS`.
"""

from __future__ import annotations

import contextlib
import csv
import difflib
import math
import os
import stat
import warnings
from collections.abc import Iterator
from typing import TYPE_CHECKING

import numpy as np

from manipkit.errors import JointLimitError, JointValueError, ManipkitError
from manipkit.inputs import check_input_file

if TYPE_CHECKING:
    from manipkit.kinematics.robot import Robot

__all__ = ["BATCH_ROWS", "MAX_LINE_CHARS", "iter_q_file", "joint_limits_error", "read_q_file"]

_LIMIT_POLICIES = ("ignore", "error", "clamp")
#: Rows :func:`iter_q_file` reads, checks and yields together (about 0.5 MB of joint values for 7 joints).
BATCH_ROWS = 8192
#: A longer line is refused (a row of 200 joint values takes about 5,000 characters); it is never held whole.
MAX_LINE_CHARS = 1 << 16


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
    InputFileError
        A FIFO, device or socket, or a symlink loop: refused before it is
        opened (a FIFO would block).

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
    return np.concatenate(list(iter_q_file(robot, path, degrees=degrees, limits=limits)))


def iter_q_file(robot: Robot, path, *, degrees: bool = False, limits: str = "ignore", batch_rows: int = BATCH_ROWS,
                what: str = "joint-value file") -> Iterator[np.ndarray]:
    """The joint vectors of a CSV file (format in the module docstring), streamed in batches.

    Reads, checks and yields at most ``batch_rows`` rows at a time, so memory
    stays bounded however long the file is (a million rows stream in the
    memory of one batch). Parameters, values and messages are those of
    :func:`read_q_file`, which collects these batches.

    Parameters
    ----------
    batch_rows : int, keyword-only
        Rows per batch (the last one may hold fewer).
    what : str, keyword-only
        How a file that is not a regular file is named in its message
        (``"--q-file"`` on the command line).

    Yields
    ------
    Q : ndarray, shape (k, n)
        ``1 <= k <= batch_rows`` joint vectors in ``robot.joint_names`` order
        (radians, metres), the file's rows in order.

    Raises
    ------
    JointValueError, JointLimitError
        As :func:`read_q_file`, when the bad row is reached: the batches
        before it have been yielded. Errors in the header, and in the rows of
        the first batch, come before anything is yielded.
    InputFileError
        A FIFO, device or socket, a symlink loop, or a file that cannot be
        read, refused before reading (a FIFO would block).

    Notes
    -----
    With ``limits="clamp"`` the one ``UserWarning`` summing up what was
    clamped comes after the last batch.
    """
    if limits not in _LIMIT_POLICIES:
        raise JointValueError(f"limits={limits!r}: choose one of {', '.join(_LIMIT_POLICIES)}")
    clamped: list = [0]  # count, then the first three "line N joint" labels
    with _open_q_file(path, what) as handle:
        rows = _data_rows(_BoundedLines(handle, path), path)
        first = next(rows, None)
        header = _checked_header(robot, path, first[1]) if first is not None else None
        batches = _batches(_same_width(rows, header, path), max(1, int(batch_rows)))
        batch = next(batches, None)
        if batch is None:
            raise JointValueError(f"{path}: needs a header of joint names and at least one row")
        while batch is not None:
            yield _batch_q(robot, path, header, batch, degrees=degrees, limits=limits, clamped=clamped)
            batch = next(batches, None)
    if clamped[0]:
        labels = clamped[1:]
        warnings.warn(f"{path}: clamped {clamped[0]} value(s) into the joint limits "
                      f"({', '.join(labels)}{', ...' if clamped[0] > 3 else ''})", UserWarning, stacklevel=2)


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


@contextlib.contextmanager
def _open_q_file(path, what: str):
    """The file as text (BOM skipped), after refusing a FIFO, device or loop; the old messages otherwise."""
    try:
        info = os.stat(path)
    except (FileNotFoundError, NotADirectoryError):
        info = None  # open() below names it, as before
    except OSError:  # a symlink loop, a name too long
        check_input_file(path, what=what)  # raises, naming the reason
        info = None
    if info is not None and stat.S_ISDIR(info.st_mode):
        raise JointValueError(f"{path}: is a folder, expected a CSV file")
    if info is not None and not stat.S_ISREG(info.st_mode):
        check_input_file(path, what=what)  # raises: open() would block on a FIFO
    try:
        handle = open(path, newline="", encoding="utf-8-sig")
    except OSError as exc:
        raise JointValueError(f"{path}: cannot read ({exc.strerror or exc})") from None
    with handle:
        yield handle


class _BoundedLines:
    """The lines of a file for :mod:`csv`, each read at most :data:`MAX_LINE_CHARS` at a time.

    A longer line is an error, and so is a record longer than that over
    several lines (a quoted field left open): ``since_record`` counts the
    characters read since the last record, which :func:`_data_rows` resets.
    """

    def __init__(self, handle, path):
        self.handle, self.path, self.number, self.since_record = handle, path, 0, 0

    def __iter__(self):
        return self

    def __next__(self) -> str:
        line = self.handle.readline(MAX_LINE_CHARS + 1)
        if not line:
            raise StopIteration
        self.number += 1
        self.since_record += len(line)
        if self.since_record > MAX_LINE_CHARS:
            what = "is" if len(line) > MAX_LINE_CHARS else "ends a row (a quote left open?) that is"
            raise JointValueError(f"{self.path}: line {self.number} {what} longer than {MAX_LINE_CHARS} characters; "
                                  "expected CSV rows of joint values")
        return line


def _data_rows(lines: _BoundedLines, path) -> Iterator[tuple[int, list[str]]]:
    """(line number, cells) of each row that is neither blank nor a comment."""
    reader = csv.reader(lines)
    try:
        for row in reader:
            lines.since_record = 0
            if row and any(cell.strip() for cell in row) and not row[0].lstrip().startswith("#"):
                yield reader.line_num, row
    except OSError as exc:
        raise JointValueError(f"{path}: cannot read ({exc.strerror or exc})") from None
    except UnicodeDecodeError:
        raise JointValueError(f"{path}: not a text file; expected CSV with a header of joint names") from None
    except csv.Error as exc:
        raise JointValueError(f"{path}: not valid CSV ({exc})") from None


def _same_width(rows: Iterator, header: list[str] | None, path) -> Iterator[tuple[int, list[str]]]:
    """The rows, each checked to have one value per header name as it is read (not a batch later)."""
    for number, row in rows:
        if len(row) != len(header):
            raise JointValueError(f"{path}: line {number} has {len(row)} values, the header has {len(header)}")
        yield number, row


def _batches(rows: Iterator, size: int) -> Iterator[list]:
    batch = []
    for row in rows:
        batch.append(row)
        if len(batch) == size:
            yield batch
            batch = []
    if batch:
        yield batch


def _batch_q(robot: Robot, path, header: list[str], batch: list[tuple[int, list[str]]], *, degrees: bool,
             limits: str, clamped: list) -> np.ndarray:
    """Joint vectors of a batch of rows: whole-batch numpy when every cell is a finite number, else row by row.

    The row-by-row path (:func:`_row_q`, :meth:`Robot.q` on each row) finds
    the first bad row and words its error; both paths give the same values.
    """
    width = len(header)
    try:
        if any(len(cells) != width for _, cells in batch):
            raise ValueError("a row of another length")
        values = np.array([[float(cell) for cell in cells] for _, cells in batch], dtype=float).reshape(len(batch), width)
        if not np.isfinite(values).all():
            raise ValueError("not finite")
    except (TypeError, ValueError):
        return np.array([_row_q(robot, path, header, number, cells, degrees, limits, clamped) for number, cells in batch])
    index = {name: i for i, name in enumerate(robot.joint_names)}
    columns = np.array([index[name] for name in header], dtype=np.intp)
    Q = np.tile(robot.q(), (len(batch), 1))
    if degrees:  # the conversion of Robot.q: angular joints only, np.radians equals math.radians
        angular = np.array([robot.joints[c].is_angular for c in columns], dtype=bool)
        values[:, angular] = np.radians(values[:, angular])
    Q[:, columns] = values
    if limits == "ignore":
        return Q
    from manipkit.kinematics.robot import LIMIT_TOLERANCE

    lower = np.array([j.lower for j in robot.joints], dtype=float) - LIMIT_TOLERANCE
    upper = np.array([j.upper for j in robot.joints], dtype=float) + LIMIT_TOLERANCE
    outside = ~((lower <= Q) & (Q <= upper))  # as Robot.limit_violations decides
    rows = np.flatnonzero(outside.any(axis=1))
    if rows.size and limits == "error":
        violations = robot.limit_violations(Q[rows[0]])
        raise joint_limits_error(violations, degrees=degrees, prefix=f"{path}: line {batch[rows[0]][0]}: ")
    if rows.size:
        for row, column in np.argwhere(outside)[: max(0, 3 - len(clamped) + 1)]:
            clamped.append(f"line {batch[row][0]} {robot.joint_names[column]}")
        del clamped[4:]
        clamped[0] += int(outside.sum())
        Q[rows] = robot.clamp(Q[rows])
    return Q


def _row_q(robot: Robot, path, header: list[str], number: int, row: list[str], degrees: bool, limits: str,
           clamped: list) -> np.ndarray:
    """One row's joint vector, each problem an error naming its line (the words of :func:`read_q_file`)."""
    if len(row) != len(header):
        raise JointValueError(f"{path}: line {number} has {len(row)} values, the header has {len(header)}")
    try:
        q = robot.q(dict(zip(header, (cell.strip() for cell in row))), degrees=degrees)
    except ManipkitError as exc:
        raise JointValueError(f"{path}: line {number}: {exc}") from None
    violations = [] if limits == "ignore" else robot.limit_violations(q)
    if violations and limits == "clamp":
        clamped += [f"line {number} {error.joint}" for error in violations]
        del clamped[4:]
        clamped[0] += len(violations)
        q = robot.clamp(q)
    elif violations:
        raise joint_limits_error(violations, degrees=degrees, prefix=f"{path}: line {number}: ")
    return q


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
