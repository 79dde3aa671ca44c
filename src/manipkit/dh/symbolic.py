"""Forward kinematics of a DH table in SymPy: exact matrices in the joint variables.

:func:`dh_fk_symbolic` gives ``T_base_tool`` as a ``sympy.Matrix`` with the
conventions of :func:`manipkit.dh.table.dh_fk` (docs/architecture.md);
:func:`shorthand` writes it as textbooks do (``c_1``, ``s_12``) and
:func:`format_symbolic` prints it as text or LaTeX.

SymPy is imported inside the functions, so importing this module is cheap.

The work is bounded: a symbolic product grows about threefold a row when the
twists are not multiples of 90 deg (8 rows at 30 deg: 84,000 operations,
minutes to simplify), so :func:`dh_fk_symbolic` refuses more than
``MAX_SYMBOLIC_ROWS`` rows and stops with a one-line error, suggesting the
numeric form, as soon as the matrix passes ``MAX_SYMBOLIC_OPS`` operations
(counted after each row, before it is simplified). The bundled arms stay
below 700; a random 5-row table with a turned base and tool reaches 7,000.
"""

from __future__ import annotations

import math
import re

import numpy as np

from manipkit.dh.table import DHTable
from manipkit.errors import DHDerivationError

__all__ = [
    "check_symbolic_size", "dh_fk_symbolic", "dh_length_symbols", "dh_symbols", "EXACT_ANGLE_TOL",
    "format_symbolic", "MAX_SYMBOLIC_OPS", "MAX_SYMBOLIC_ROWS", "shorthand",
]

EXACT_ANGLE_TOL = 1e-12
"""Relative tolerance within which an angle counts as a multiple of pi/12 in :func:`dh_fk_symbolic`."""
MAX_SYMBOLIC_ROWS = 20
"""Most rows :func:`dh_fk_symbolic` takes (real arms have up to about ten)."""
MAX_SYMBOLIC_OPS = 10000
"""Most operations (``sympy.count_ops``, all 16 entries) the symbolic matrix may reach; the 7-row iiwa needs 688."""

_NUMERIC_HINT = "print the numeric table instead (manipkit dh show TABLE, without --symbolic; dh_fk in Python)"


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


def _symbolic_placement(table: DHTable, which: str, tol: float):
    """The table's ``base`` or ``tool`` from its xyz and rpy, each number made exact where it is nice."""
    import sympy

    xyz, rpy = table.placement_xyz_rpy(which)
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

    Raises
    ------
    DHDerivationError
        When ``symbols`` does not hold ``n`` symbols, or a name is not an
        identifier (letters, digits, ``_``): names are written into LaTeX.

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
        raise DHDerivationError(f"{n} joint symbols needed, got {len(made)}: {str(made)[:200]}")
    for symbol in made:
        if not symbol.name.isidentifier():
            raise DHDerivationError(f"joint symbol {symbol.name[:40]!r} is not a name; use letters, digits and _ "
                                    "(q1, theta_2)")
    return made


def dh_fk_symbolic(
    table: DHTable,
    *,
    upto: int | None = None,
    simplify: bool | str = True,
    symbols=None,
    exact_tol: float = EXACT_ANGLE_TOL,
    max_rows: int = MAX_SYMBOLIC_ROWS,
    max_ops: int = MAX_SYMBOLIC_OPS,
):
    """T_base_tool of a DH table as a SymPy matrix in the joint variables.

    Parameters
    ----------
    table : DHTable
    upto : int, keyword-only, optional
        Stop after this many rows and leave out the tool (as :func:`~manipkit.dh.table.dh_fk`).
    simplify : {True, False, "trigsimp"}, keyword-only
        ``True`` (default): after every row, fold ``sin a cos b + cos a sin b``
        into ``sin(a + b)`` and the like (SymPy's Fu rule ``TR10i``). In a
        serial chain each joint variable appears in one row only, so products
        are multilinear in the ``sin``/``cos`` of the joints and angle sums are
        the only simplification there is; this is fast (0.1 s for 7 joints).
        ``"trigsimp"``: in addition ``sympy.trigsimp`` on every entry of
        the result (slow: about 20 s for the 7-joint iiwa).
        ``False``: the plain product.
    symbols : str, sequence or True, keyword-only, optional
        Joint symbols, see :func:`dh_symbols`; default ``q1 ... qn`` (real).
        A revolute row's symbol is added to ``theta``, a prismatic row's to ``d``.
        ``True``: the default joint symbols, and the table's non-zero lengths
        as symbols too (``L1``, ``d1``, ...; see :func:`dh_length_symbols`)
        instead of exact numbers such as ``21/50``.
    exact_tol : float, keyword-only
        Relative tolerance within which an angle counts as a multiple of
        ``pi/12`` (default ``EXACT_ANGLE_TOL`` = 1e-12), see Notes.
    max_rows, max_ops : int, keyword-only
        Bounds on the work (default ``MAX_SYMBOLIC_ROWS`` = 20 rows and
        ``MAX_SYMBOLIC_OPS`` = 10000 operations in the matrix, counted by
        ``sympy.count_ops`` after each row's product, before simplifying).

    Returns
    -------
    sympy.Matrix, shape (4, 4)
        ``base @ A_1 @ ... @ A_n @ tool`` with the conventions of :func:`~manipkit.dh.table.dh_fk`.

    Raises
    ------
    DHDerivationError
        More than ``max_rows`` rows, or the matrix passes ``max_ops``
        operations (the message names the row and suggests the numeric
        form); a bad ``simplify`` or ``symbols``.

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
    >>> from manipkit.dh.table import DHRow
    >>> table = DHTable([DHRow(1, 0, 0, 0), DHRow(1, 0, 0, 0)], "standard")
    >>> T = dh_fk_symbolic(table)
    >>> T[0, 3]
    cos(q1) + cos(q1 + q2)
    """
    # Over 80 lines: the docstring (conventions, bounds, examples) is most of it.
    import sympy
    from sympy.simplify.fu import TR10i

    if simplify not in (True, False, "trigsimp"):
        raise DHDerivationError(f"simplify={simplify!r}: choose True, False or 'trigsimp'")
    count = table.n if upto is None else upto
    if count > max_rows:
        raise DHDerivationError(f"DH table '{table.name}': {count} rows, above the limit of {max_rows} rows for "
                                f"symbolic forward kinematics; {_NUMERIC_HINT}")
    length_symbols = dh_length_symbols(table) if symbols is True else {}
    named = {str(symbol): symbol for symbol in length_symbols}
    q = dh_symbols(table.n, None if symbols is True else symbols)

    def length(row_index: int, entry: str, value: float):
        name = _length_name(table, row_index, entry)
        return named[name] if name in named else _exact_length(value)

    T = sympy.eye(4) if np.array_equal(table.base, np.eye(4)) else _symbolic_placement(table, "base", exact_tol)
    for i, (row, qi) in enumerate(zip(table.rows[:count], q), start=1):
        theta = _exact_angle(row.theta, exact_tol) + (qi if row.is_revolute else 0)
        d = length(i, "d", row.d) + (0 if row.is_revolute else qi)
        a = length(i, "a", row.a)
        T = T * _symbolic_link(a, _exact_angle(row.alpha, exact_tol), d, theta, table.convention)
        check_symbolic_size(T, max_ops, table, f"row {i} of {table.n}")
        if simplify:
            T = T.applyfunc(TR10i)
    if upto is None and not np.array_equal(table.tool, np.eye(4)):
        T = T * _symbolic_placement(table, "tool", exact_tol)
        check_symbolic_size(T, max_ops, table, "the tool")
        if simplify:
            T = T.applyfunc(TR10i)
    if simplify == "trigsimp":
        T = T.applyfunc(sympy.trigsimp)
    return T


def _length_name(table: DHTable, row: int, entry: str) -> str:
    """``L{i}`` for the a of row ``row`` (1-based; ``a_{i-1}`` in modified DH, so ``L{i-1}``), ``d{i}`` for its d."""
    if entry == "d":
        return f"d{row}"
    return f"L{row if table.convention == 'standard' else row - 1}"


def dh_length_symbols(table: DHTable) -> dict:
    """The table's non-zero lengths as SymPy symbols, with their values (m): ``{L1: 0.42, d1: 0.36, ...}``.

    ``L{i}`` stands for ``a_i`` (standard DH: row i; modified DH: row i
    holds ``a_{i-1}``, so ``L{i-1}``), ``d{i}`` for ``d_i`` (for a prismatic
    row, its offset). Zero lengths get no symbol. These are the symbols
    ``dh_fk_symbolic(table, symbols=True)`` writes; substitute the values back
    with ``T.subs(dh_length_symbols(table))``.

    Examples
    --------
    >>> from manipkit.dh.table import DHRow
    >>> dh_length_symbols(DHTable([DHRow(0.42, 0, 0.36, 0), DHRow(0.4, 0, 0, 0)], "standard"))
    {L1: 0.42, d1: 0.36, L2: 0.4}
    """
    import sympy

    values = {}
    for i, row in enumerate(table.rows, start=1):
        for entry in ("a", "d"):
            value = getattr(row, entry)
            if value != 0:
                values[sympy.Symbol(_length_name(table, i, entry), real=True)] = value
    return values


def check_symbolic_size(T, max_ops: int, table: DHTable, where: str) -> None:
    """DHDerivationError when the matrix ``T`` holds more than ``max_ops`` operations (before simplifying)."""
    import sympy

    ops = sum(sympy.count_ops(entry) for entry in T)
    if ops > max_ops:
        raise DHDerivationError(
            f"DH table '{table.name}': the symbolic T_base_tool grows to {ops} operations at {where}, above the "
            f"limit of {max_ops} (twists that are not multiples of 90 deg make it grow about threefold a row); "
            f"{_NUMERIC_HINT}"
        )


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


def format_symbolic(matrix, *, latex: bool = False, width: int = 100, name: str = "T", title: str | None = None) -> str:
    """A SymPy matrix as text or LaTeX, optionally after a title line.

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
    title : str, keyword-only, optional
        A first line (it may hold a table's name): as it is for text, as a
        LaTeX comment ``% title`` for LaTeX, its line breaks and other
        control characters made spaces so nothing of it leaves the comment.

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

    head = "" if title is None else ("% " if latex else "") + _one_line(title) + "\n"
    if latex:
        return head + sympy.latex(matrix, mat_str="bmatrix", mat_delim="")
    text = sympy.pretty(matrix, use_unicode=True, wrap_line=False)
    if max((len(line) for line in text.splitlines()), default=0) <= width:
        return head + text
    rows, cols = matrix.shape
    return head + "\n".join(f"{name}[{i + 1},{j + 1}] = {sympy.sstr(matrix[i, j])}" for i in range(rows) for j in range(cols))


def _one_line(text: str) -> str:
    """``text`` with every control character (line breaks included) and line separator made a space."""
    return "".join(" " if (ord(c) < 32 or 0x7F <= ord(c) <= 0x9F or c in "\u2028\u2029") else c for c in str(text))
