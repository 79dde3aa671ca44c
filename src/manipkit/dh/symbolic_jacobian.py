"""The geometric Jacobian of a DH table in SymPy, its determinant, and its printout.

:func:`dh_jacobian_symbolic` gives the (6, n) geometric Jacobian of the tool
frame's origin, expressed in the table's base frame: rows are the linear
velocity (vx, vy, vz) then the angular velocity (wx, wy, wz), columns are the
joints in row order (docs/architecture.md, "Conventions": Jacobians list
linear then angular velocity). Column i of a revolute joint turning about the
unit axis z through the point o is ``(z x (p - o), z)``; of a prismatic joint
sliding along z, ``(z, 0)``; ``p`` is the tool frame's origin. In standard DH
joint i turns about ``z_{i-1}`` (the frame before its row), in modified DH
about ``z_i`` (the frame after its row).

Link lengths may be symbols (``lengths={"a1": "l1", "a2": "l2"}``), so the
planar 2R's determinant reads ``l1*l2*sin(q2)``. The matrices of each row
come from :func:`manipkit.dh.symbolic.dh_fk_symbolic` (its exact numbers:
multiples of pi/12, short decimals as rationals); a length made a symbol is
added to the row's translation, which is linear in ``a`` and ``d``:
standard DH ``t = d e_z + a R e_x``, modified DH ``t = a e_x + d R e_z``.

:func:`jacobian_determinant` is ``det J`` for the selected rows when they
make J square, else ``sqrt(det(J J^T))`` (the Yoshikawa measure of the
selected rows), simplified and factored, so the singular conditions are its
factors. :func:`format_jacobian` prints J with ``s_1``, ``c_12`` as text or
LaTeX.

SymPy is imported inside the functions.
"""

from __future__ import annotations

import re
from collections.abc import Mapping, Sequence
from itertools import combinations

import numpy as np

from manipkit.dh.symbolic import (
    MAX_SYMBOLIC_OPS,
    MAX_SYMBOLIC_ROWS,
    check_symbolic_size,
    dh_fk_symbolic,
    dh_symbols,
    format_symbolic,
    shorthand,
)
from manipkit.dh.table import DHRow, DHTable
from manipkit.errors import DHDerivationError

__all__ = ["JACOBIAN_ROWS", "dh_frames_symbolic", "dh_jacobian_symbolic", "format_jacobian", "jacobian_determinant", "length_symbols"]

JACOBIAN_ROWS = ("vx", "vy", "vz", "wx", "wy", "wz")
"""Row labels of a geometric Jacobian: linear velocity, then angular velocity."""

_LENGTH_KEY = re.compile(r"^([ad])([1-9][0-9]*)$")


def length_symbols(table: DHTable, lengths: Mapping[str, object] | None) -> dict[tuple[int, str], object]:
    """``{(row index from 0, "a" or "d"): sympy.Symbol}`` from a ``lengths`` mapping.

    Parameters
    ----------
    table : DHTable
    lengths : mapping or None
        Keys ``"a1"``, ``"d3"``: the field ``a`` or ``d`` of row 1, 3 (as the
        table stores it: in modified DH row i's ``a`` is ``a_{i-1}``). Values:
        symbol names (identifiers) or SymPy symbols. A prismatic row's ``d``
        is its constant offset (the joint variable is added to it).

    Raises
    ------
    DHDerivationError
        A key that is not ``a<row>`` or ``d<row>`` of the table, or a name that is not an identifier.

    Examples
    --------
    >>> table = DHTable([DHRow(1, 0, 0, 0), DHRow(1, 0, 0, 0)])
    >>> length_symbols(table, {"a1": "l1", "a2": "l2"})
    {(0, 'a'): l1, (1, 'a'): l2}
    """
    import sympy

    made = {}
    for key, value in (lengths or {}).items():
        match = _LENGTH_KEY.match(str(key))
        if not match or int(match.group(2)) > table.n:
            raise DHDerivationError(f"length key {str(key)[:40]!r}: give a1 .. a{table.n} or d1 .. d{table.n} "
                                    "(the field and the row number, from 1)")
        symbol = value if isinstance(value, sympy.Symbol) else sympy.Symbol(str(value), real=True)
        if not symbol.name.isidentifier():
            raise DHDerivationError(f"length symbol {symbol.name[:40]!r} is not a name; use letters, digits and _ (l1, d_3)")
        made[(int(match.group(2)) - 1, match.group(1))] = symbol
    return made


def _row_matrix(table: DHTable, i: int, q, symbols: dict, simplify):
    """The SymPy link matrix of row ``i`` (from 0) with joint symbol ``q``, its chosen lengths as symbols."""
    row = table.rows[i]
    a_sym, d_sym = symbols.get((i, "a")), symbols.get((i, "d"))
    plain = DHRow(0.0 if a_sym is not None else row.a, row.alpha, 0.0 if d_sym is not None else row.d, row.theta,
                  row.type)
    A = dh_fk_symbolic(DHTable([plain], table.convention), symbols=[q], simplify=simplify)
    if a_sym is not None:
        A[:3, 3] += a_sym * (A[:3, 0] if table.convention == "standard" else _unit(0))
    if d_sym is not None:
        A[:3, 3] += d_sym * (_unit(2) if table.convention == "standard" else A[:3, 2])
    return A


def _unit(axis: int):
    import sympy

    e = sympy.zeros(3, 1)
    e[axis] = 1
    return e


def _placement(table: DHTable, which: str, simplify):
    """The table's base or tool as an exact SymPy matrix (identity when it is the identity)."""
    import sympy

    matrix = table.base if which == "base" else table.tool
    if np.array_equal(matrix, np.eye(4)):
        return sympy.eye(4)
    q0 = sympy.Symbol("q_placement", real=True)
    kwargs = {which: matrix, f"{which}_rpy": table.base_rpy if which == "base" else table.tool_rpy}
    carrier = DHTable([DHRow(0.0, 0.0, 0.0, 0.0)], table.convention, **kwargs)
    if which == "base":
        return dh_fk_symbolic(carrier, upto=0, simplify=simplify)
    return dh_fk_symbolic(carrier, symbols=[q0], simplify=simplify).subs(q0, 0)


def dh_frames_symbolic(table: DHTable, *, lengths: Mapping[str, object] | None = None, symbols=None,
                       simplify: bool = True) -> list:
    """The DH frames of a table in SymPy: ``[F_0, ..., F_n]``, ``F_0 = base`` and ``F_i = base A_1 ... A_i``.

    Each a (4, 4) ``sympy.Matrix`` in the joint symbols (:func:`manipkit.dh.symbolic.dh_symbols`; default
    ``q1 ... qn``), lengths chosen as symbols by ``lengths`` (:func:`length_symbols`), angle sums folded after
    each product when ``simplify`` (SymPy's ``TR10i``). The tool is not included. Bounded as
    :func:`manipkit.dh.symbolic.dh_fk_symbolic` is (``MAX_SYMBOLIC_OPS`` after each row).
    """
    import sympy
    from sympy.simplify.fu import TR10i

    q = dh_symbols(table.n, symbols)
    chosen = length_symbols(table, lengths)
    frames = [_placement(table, "base", simplify)]
    for i in range(table.n):
        product = frames[-1] * _row_matrix(table, i, q[i], chosen, simplify)
        check_symbolic_size(product, MAX_SYMBOLIC_OPS, table, f"row {i + 1}")  # as dh_fk_symbolic: stop before it explodes
        frames.append(product.applyfunc(lambda e: TR10i(sympy.expand(e))) if simplify else product)
    return frames


def dh_jacobian_symbolic(
    table: DHTable,
    *,
    lengths: Mapping[str, object] | None = None,
    symbols=None,
    point: int | None = None,
    simplify: bool = True,
    max_rows: int = MAX_SYMBOLIC_ROWS,
):
    """The (6, n) geometric Jacobian of a DH table's tool frame, in the base frame, as a SymPy matrix.

    Parameters
    ----------
    table : DHTable
        Its ``base`` and ``tool`` are included: the Jacobian is that of the
        tool frame's origin, expressed in the axes of the frame ``base`` is
        given in (for the bundled tables, the URDF's ``base_link``).
    lengths : mapping, keyword-only, optional
        Link lengths to keep as symbols, see :func:`length_symbols`
        (``{"a1": "l1", "a2": "l2"}``).
    symbols : keyword-only, optional
        Joint symbols, see :func:`manipkit.dh.symbolic.dh_symbols`; default ``q1 ... qn`` (real).
    point : int, keyword-only, optional
        Give the linear velocity of the origin of DH frame ``point`` (0 .. n,
        moving with the tool) instead of the tool's origin. The rows change
        by ``v_point = v_tool + w x (o_point - p_tool)``, a unimodular change,
        so determinants and singular sets stay the same; at the wrist
        centre of a spherical wrist (frame 3 of the Stanford and elbow arms) the
        wrist's columns have no linear part and the determinant splits into
        arm times wrist, which SymPy finds far faster.
    simplify : bool, keyword-only
        Fold angle sums (SymPy's ``TR10i``) after each product, then
        ``trigsimp`` every entry (default True: about 2 s for the six-joint
        Stanford and elbow arms, 40 s for the seven-joint iiwa14; False: the
        plain products, 0.05 s, equal as functions).
    max_rows : int, keyword-only
        Refuse longer tables (default ``MAX_SYMBOLIC_ROWS``).

    Returns
    -------
    sympy.Matrix, shape (6, n)
        Rows vx, vy, vz, wx, wy, wz (:data:`JACOBIAN_ROWS`); m/s and rad/s per
        unit joint rate (rad/s or m/s).

    Raises
    ------
    DHDerivationError
        More than ``max_rows`` rows; a bad ``lengths`` key or symbol; bad joint symbols.

    Examples
    --------
    >>> table = DHTable([DHRow(1, 0, 0, 0), DHRow(1, 0, 0, 0)])
    >>> J = dh_jacobian_symbolic(table, lengths={"a1": "l1", "a2": "l2"})
    >>> J[:2, :]
    Matrix([
    [-l1*sin(q1) - l2*sin(q1 + q2), -l2*sin(q1 + q2)],
    [ l1*cos(q1) + l2*cos(q1 + q2),  l2*cos(q1 + q2)]])
    """
    # Over 80 lines: the docstring (conventions, bounds, examples) is most of it.
    import sympy
    from sympy.simplify.fu import TR10i

    if table.n > max_rows:
        raise DHDerivationError(f"DH table '{table.name}': {table.n} rows, above the limit of {max_rows} rows for a "
                                "symbolic Jacobian; use the numeric Jacobian of the robot instead")
    frames = dh_frames_symbolic(table, lengths=lengths, symbols=symbols, simplify=simplify)

    def fold(M):
        return M.applyfunc(lambda e: TR10i(sympy.expand(e))) if simplify else M

    if point is None:
        p = fold(frames[-1] * _placement(table, "tool", simplify))[:3, 3]
    elif isinstance(point, int | np.integer) and 0 <= point <= table.n:
        p = frames[point][:3, 3]
    else:
        raise DHDerivationError(f"point={point!r}: give a DH frame number 0 .. {table.n}, or None for the tool")
    columns = []
    for i, row in enumerate(table.rows):
        F = frames[i] if table.convention == "standard" else frames[i + 1]
        z, o = F[:3, 2], F[:3, 3]
        if row.is_revolute:
            columns.append(z.cross(p - o).col_join(z))
        else:
            columns.append(z.col_join(sympy.zeros(3, 1)))
    J = fold(sympy.Matrix.hstack(*columns))
    return J.applyfunc(lambda e: TR10i(sympy.trigsimp(e))) if simplify else J


def jacobian_determinant(J, rows: Sequence[int] | None = None, *, simplify: bool = True):
    """``det J[rows]`` when square, else ``sqrt(det(J[rows] J[rows]^T))``, simplified and factored.

    Parameters
    ----------
    J : sympy.Matrix, shape (6, n)
    rows : sequence of int, optional
        Rows to keep (0..5 = vx, vy, vz, wx, wy, wz); default all. A planar
        arm keeps the rows it can move: ``[0, 1]`` (2R), ``[0, 1, 5]`` (3R).
    simplify : bool, keyword-only
        Expand, fold angle sums, ``factor`` and drop factors ``sin(x)**2 + cos(x)**2`` (default True). A square
        block-triangular matrix (a zero top-right block, as a Jacobian taken
        at a spherical wrist's centre has) is split into its diagonal blocks first.

    Returns
    -------
    sympy expression
        Zero exactly where the selected rows lose rank: its factors are the
        singular conditions. For a square block it keeps its sign; otherwise
        ``det(J J^T)`` is written as the sum of the squares of the maximal
        minors (Cauchy-Binet), each factored, so it is zero exactly where all of them are.

    Raises
    ------
    DHDerivationError
        More selected rows than columns (``det(J J^T)`` would be identically 0).

    Examples
    --------
    >>> table = DHTable([DHRow(1, 0, 0, 0), DHRow(1, 0, 0, 0)])
    >>> jacobian_determinant(dh_jacobian_symbolic(table, lengths={"a1": "l1", "a2": "l2"}), [0, 1])
    l1*l2*sin(q2)
    """
    import sympy

    picked = J if rows is None else J.extract(list(rows), list(range(J.cols)))
    if picked.rows > picked.cols:
        raise DHDerivationError(f"{picked.rows} rows for {picked.cols} joints: the rows always lose rank; "
                                f"choose at most {picked.cols} rows")
    if picked.rows == picked.cols:
        return _block_det(picked, simplify)
    # Cauchy-Binet: det(J J^T) is the sum of the squares of the maximal minors (each simplifies well)
    minors = (_block_det(picked.extract(list(range(picked.rows)), list(cols)), simplify)
              for cols in combinations(range(picked.cols), picked.rows))
    return sympy.sqrt(sympy.Add(*(m**2 for m in minors)))


def _block_det(M, simplify: bool):
    """``det M``, split as ``det(M[:k, :k]) det(M[k:, k:])`` where ``M[:k, k:]`` is zero, each part simplified."""

    for k in range(1, M.rows):
        if M[:k, k:].is_zero_matrix:
            return _block_det(M[:k, :k], simplify) * _block_det(M[k:, k:], simplify)
    value = M.det(method="berkowitz")
    return _factored(value) if simplify else value


def _factored(value):
    """``value`` expanded, angle sums folded, factored, and factors equal to 1 (``sin(x)**2 + cos(x)**2``) dropped."""
    import sympy
    from sympy.simplify.fu import TR10i

    factors = []
    for factor in sympy.Mul.make_args(sympy.factor(TR10i(sympy.expand(value)))):
        base, _ = factor.as_base_exp()
        if base.has(sympy.sin, sympy.cos) and sympy.count_ops(base) <= 40 and sympy.trigsimp(base) == 1:
            continue
        factors.append(factor)
    return sympy.Mul(*factors)


def format_jacobian(J, *, latex: bool = False, textbook: bool = True, title: str | None = None, width: int = 100) -> str:
    """A symbolic Jacobian as text or LaTeX; ``textbook=True`` writes ``s_1``, ``c_12``.

    Text with one entry per line when the matrix is wider than ``width``
    (:func:`manipkit.dh.symbolic.format_symbolic`), entries named ``J[row,col]`` (from 1).

    Examples
    --------
    >>> table = DHTable([DHRow(1, 0, 0, 0)])
    >>> print(format_jacobian(dh_jacobian_symbolic(table)[:2, :], latex=True))
    \\begin{bmatrix}- s_{1}\\\\c_{1}\\end{bmatrix}
    """
    return format_symbolic(shorthand(J) if textbook else J, latex=latex, width=width, name="J", title=title)
