"""The gravity torques g(q) of a DH table with point masses, in SymPy: what a statics course works by hand.

Each link ``i`` (row ``i``, from 1) carries a point mass ``m_i`` at a point
``c_i`` fixed in DH frame ``i`` (the frame after the row: in standard DH its
origin is the far end of link ``i``, so ``c_i = (-a_i / 2, 0, 0)`` is the
middle of a planar link). With gravity ``g_vec`` in the base frame the
potential energy is ``V(q) = -sum_i m_i g_vec . p_i(q)``, ``p_i = F_i c_i``,
and the torque each joint's motor holds the arm still with is

    g(q) = dV/dq,

the convention of :mod:`manipkit.statics` and of Pinocchio's
``computeGeneralizedGravity`` (``tau = g(q) - sum J^T w``): positive where
the motor pushes the joint's own positive way. N m for a revolute joint, N for
a prismatic one. The default gravity is ``(0, 0, -g)`` with ``g`` a symbol, so
``g(q)`` reads as in the textbook; give a vector of numbers (m/s^2) instead
for a number per joint.

Frames come from :func:`manipkit.dh.symbolic_jacobian.dh_frames_symbolic`
(standard or modified DH, the table's base included; the tool carries no
mass). SymPy is imported inside the function.
"""

from __future__ import annotations

import re
from collections.abc import Mapping, Sequence

from manipkit import bounds
from manipkit.dh.symbolic import MAX_SYMBOLIC_ROWS, dh_symbols
from manipkit.dh.symbolic_jacobian import dh_frames_symbolic
from manipkit.dh.table import DHTable
from manipkit.errors import DHDerivationError
from manipkit.text import short_text

__all__ = ["MAX_SYMBOL_NAME", "dh_gravity_symbolic"]

#: Longest symbol name taken for a mass or a centre coordinate (it is printed in every entry of g(q)).
MAX_SYMBOL_NAME = 40


def _symbolic(value, what: str, limit: float | None = None, unit: str = ""):
    """A SymPy value from a number (``|value| <= limit``), a SymPy expression, or a symbol name (real)."""
    import sympy

    if isinstance(value, str):
        name = value.removeprefix("-")
        if len(name) > MAX_SYMBOL_NAME:
            raise DHDerivationError(f"{what} {value[:40]!r}... ({len(value):,} characters): give a symbol name of at "
                                    f"most {MAX_SYMBOL_NAME} characters")
        if not name.isidentifier():
            raise DHDerivationError(f"{what} {value[:40]!r}: give a number or a symbol name (letters, digits, _; "
                                    "a leading - for its negative)")
        symbol = sympy.Symbol(name, real=True)
        return -symbol if value.startswith("-") else symbol
    try:
        made = sympy.sympify(value, strict=True)
    except (sympy.SympifyError, TypeError, ValueError):
        raise DHDerivationError(f"{what} {str(value)[:40]!r}: give a number or a symbol name") from None
    if made.is_number and not made.is_finite:
        raise DHDerivationError(f"{what} {str(value)[:40]!r}: give a finite number")
    if limit is not None and made.is_number and abs(made) > limit:
        raise DHDerivationError(f"{what} {short_text(float(made))}: give a value within {limit:g} {unit}")
    return made


def _check_no_shared_symbols(masses, centres, g_vec, q, lengths) -> None:
    """Refuse a mass or centre named like a joint variable, a gravity symbol or a kept link length: SymPy would
    take them for one symbol (a mass ``q1`` differentiated as the joint angle, a mass ``g`` squared)."""
    taken = {str(s): "a joint variable" for s in q}
    taken.update({str(s): "a link length symbol" for s in (lengths or {}).values()})
    taken.update({str(s): "a symbol of gravity" for s in g_vec.free_symbols})
    for what, values in (("mass", masses), ("centre", centres)):
        for i, value in enumerate(values):
            for symbol in sorted(_free_symbols(value), key=str):
                role = taken.get(str(symbol)) or (
                    "the printed shorthand of a cosine or sine" if re.fullmatch(r"[cs]\d+", str(symbol)) else None)
                if role is not None:
                    raise DHDerivationError(f"{what} {i + 1}: the name {str(symbol)!r} is {role} of "
                                            "this derivation; give the mass or centre another name")


def _free_symbols(value) -> set:
    return set(getattr(value, "free_symbols", ()))


def dh_gravity_symbolic(table: DHTable, masses: Sequence, *, centres: Sequence | None = None,
                        gravity: Sequence | None = None, lengths: Mapping[str, object] | None = None,
                        symbols=None, simplify: bool = True):
    """g(q) = dV/dq of a DH table with a point mass on each link, as a SymPy column (n, 1).

    Parameters
    ----------
    table : DHTable
    masses : sequence of n numbers, symbol names or SymPy expressions
        ``m_i`` (kg) of link ``i``; a name such as ``"m1"`` becomes a real symbol (``"-g"``: its negative).
    centres : sequence of n 3-vectors, keyword-only, optional
        ``c_i`` (m) in DH frame ``i``'s axes, entries numbers, names or expressions;
        default the frame's origin (the far end of the link in standard DH).
    gravity : 3-vector, keyword-only, optional
        ``g_vec`` (m/s^2) in the base frame's axes; default ``(0, 0, -g)`` with the symbol ``g``.
    lengths : mapping, keyword-only, optional
        Link lengths kept as symbols (``{"a1": "l1", "a2": "l2"}``), as in
        :func:`manipkit.dh.symbolic_jacobian.dh_jacobian_symbolic`.
    symbols : keyword-only, optional
        Joint symbols (:func:`manipkit.dh.symbolic.dh_symbols`); default ``q1 ... qn``.
    simplify : bool, keyword-only
        Fold angle sums (SymPy's ``TR10i``) and collect common factors in each entry (default True; the same
        function either way, about 1 s for three symbolic rows and longer with many decimal numbers).

    Returns
    -------
    sympy.Matrix, shape (n, 1)
        The torque (N m) or force (N) each joint holds, in row order.

    Raises
    ------
    DHDerivationError
        Not one mass (and centre) per row, a centre that is not a 3-vector, a value that is not a number or a
        name, more than ``MAX_SYMBOLIC_ROWS`` rows.

    Examples
    --------
    A planar 2R arm in a vertical plane (x along the floor, y up: gravity ``(0, -g, 0)``), point masses at the
    link ends:

    >>> from manipkit.dh.table import DHRow
    >>> arm = DHTable([DHRow(1, 0, 0, 0), DHRow(1, 0, 0, 0)])
    >>> dh_gravity_symbolic(arm, ["m1", "m2"], gravity=(0, "-g", 0), lengths={"a1": "l1", "a2": "l2"})
    Matrix([
    [g*(l1*m1*cos(q1) + l1*m2*cos(q1) + l2*m2*cos(q1 + q2))],
    [                                  g*l2*m2*cos(q1 + q2)]])
    """
    # Over 80 lines: the docstring (conventions, units, an example) is most of it; the checks name each input.
    import sympy

    if table.n > MAX_SYMBOLIC_ROWS:
        raise DHDerivationError(f"DH table '{table.name}': {table.n} rows, above the limit of {MAX_SYMBOLIC_ROWS} "
                                "rows for symbolic gravity torques; use manipkit.statics.static_torques instead")
    if isinstance(masses, str) or len(masses) != table.n:
        raise DHDerivationError(f"masses: give {table.n} values, one per row of '{table.name}' (numbers or names)")
    m = [_symbolic(value, f"mass {i + 1}", bounds.MAX_MASS, "kg") for i, value in enumerate(masses)]
    for i, mass in enumerate(m):
        if mass.is_number and mass < 0:
            raise DHDerivationError(f"mass {i + 1} = {short_text(float(mass))} kg: give a mass >= 0 kg")
    if centres is None:
        c = [sympy.zeros(3, 1) for _ in range(table.n)]
    else:
        if isinstance(centres, str) or len(centres) != table.n:
            raise DHDerivationError(f"centres: give {table.n} points (x, y, z), one per row of '{table.name}'")
        c = []
        for i, point in enumerate(centres):
            if isinstance(point, str) or len(point) != 3:
                raise DHDerivationError(f"centre {i + 1}: give three coordinates (x, y, z) in DH frame {i + 1}")
            c.append(sympy.Matrix([_symbolic(v, f"centre {i + 1} coordinate", bounds.MAX_LENGTH, "m") for v in point]))
    if gravity is None:
        g_vec = sympy.Matrix([0, 0, -sympy.Symbol("g", real=True)])
    else:
        if isinstance(gravity, str) or len(gravity) != 3:
            raise DHDerivationError("gravity: give three components (m/s^2) in the base frame's axes")
        g_vec = sympy.Matrix([_symbolic(v, "gravity component") for v in gravity])
    q = dh_symbols(table.n, symbols)
    _check_no_shared_symbols(m, c, g_vec, q, lengths)
    frames = dh_frames_symbolic(table, lengths=lengths, symbols=symbols, simplify=simplify)
    V = sympy.S.Zero
    for i in range(table.n):
        F = frames[i + 1]
        p = F[:3, 3] + F[:3, :3] * c[i]
        V -= m[i] * (g_vec.T * p)[0, 0]
    torques = sympy.Matrix([sympy.diff(V, qi) for qi in q])
    if simplify:
        from sympy.simplify.fu import TR10i

        torques = torques.applyfunc(lambda e: sympy.factor_terms(TR10i(sympy.expand(e))))
    return torques
