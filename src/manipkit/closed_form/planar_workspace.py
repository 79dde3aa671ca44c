"""Reachable and dexterous workspaces of planar 2R and 3R arms, in closed form (radii about the base).

Conventions (docs/architecture.md), as in :mod:`manipkit.closed_form.planar`:
the arm moves in the x-y plane of its base frame, every joint turns about +z,
lengths in metres. Joint 1 turns the whole arm, so both workspaces are sets of
distances ``r`` from the base. :mod:`manipkit.analysis.workspace` samples
and draws them.
"""

from __future__ import annotations

from dataclasses import dataclass

from manipkit.closed_form.checks import link_length, quantity_text, tolerance

__all__ = ["Workspace", "workspace_2r", "workspace_3r"]


def _interval_text(low: float, high: float) -> str:
    if high == 0.0:
        return "the base point only (r = 0)"
    if low == 0.0:
        return f"disc r <= {quantity_text(high)}"
    if low == high:
        return f"circle r = {quantity_text(low)}"
    return f"annulus {quantity_text(low)} <= r <= {quantity_text(high)}"


@dataclass(frozen=True)
class Workspace:
    """Reachable and dexterous workspaces of a planar arm, as radii about the base.

    Both are rotationally symmetric (joint 1 turns the whole arm), so they
    are sets of distances ``r`` from the base.

    Attributes
    ----------
    lengths : tuple of float
        Link lengths (m), base to tool.
    reachable : tuple of float
        ``(r_min, r_max)``: the tool reaches exactly the points with
        ``r_min <= r <= r_max`` (a disc when ``r_min = 0``).
    dexterous : tuple of (float, float)
        The points the tool reaches with *every* orientation, as disjoint
        closed intervals ``(r_min, r_max)`` of r in increasing order: ``()``
        when empty, one interval usually, two when a disc around the base and
        an annulus are both dexterous but the ring between them is not.
        ``(0, 0)`` is the base point alone.
    why_dexterous : str
        The reasoning behind ``dexterous`` for these lengths, in one line.
    """

    lengths: tuple[float, ...]
    reachable: tuple[float, float]
    dexterous: tuple[tuple[float, float], ...]
    why_dexterous: str

    @property
    def description(self) -> str:
        """One line for humans: both workspaces in words, with the radii."""
        lengths = ", ".join(quantity_text(v) for v in self.lengths)
        reach = _interval_text(*self.reachable)
        if self.dexterous:
            dext = " and ".join(_interval_text(*piece) for piece in self.dexterous)
        else:
            dext = "empty"
        return f"planar {len(self.lengths)}R (l = {lengths}): reachable {reach}; dexterous {dext}: {self.why_dexterous}"

    def __str__(self) -> str:
        return self.description


def workspace_2r(l1, l2, *, tol: float = 1e-12) -> Workspace:
    """Reachable and dexterous workspaces of a planar 2R arm.

    Parameters
    ----------
    l1, l2 : float
        Link lengths (m), > 0.
    tol : float, keyword-only
        ``|l1 - l2| <= tol`` counts as equal links.

    Returns
    -------
    Workspace
        ``reachable = (|l1 - l2|, l1 + l2)``: link 2 sweeps a circle of radius
        l2 around the elbow, which is at distance l1, so the tool's distance
        ``sqrt(l1^2 + l2^2 + 2 l1 l2 cos q2)`` takes every value between
        ``|l1 - l2|`` (q2 = pi) and ``l1 + l2`` (q2 = 0).

        ``dexterous`` is empty: the tool orientation ``q1 + q2`` is fixed by
        the position up to the two elbow solutions. The one exception is
        ``l1 = l2``, where the base point is reached folded (q2 = pi) with
        any q1, hence every orientation: ``dexterous = ((0, 0),)``.

    Examples
    --------
    >>> workspace_2r(1.0, 0.5).reachable
    (0.5, 1.5)
    >>> workspace_2r(1.0, 1.0).dexterous  # folded at the base, any q1
    ((0.0, 0.0),)
    """
    l1, l2 = link_length(l1, "l1"), link_length(l2, "l2")
    tol = tolerance(tol)
    reachable = (abs(l1 - l2), l1 + l2)
    if abs(l1 - l2) <= tol:
        return Workspace(
            (l1, l2), (0.0, l1 + l2), ((0.0, 0.0),),
            "with l1 = l2 the arm folds onto the base, where any q1 turns the tool through every angle",
        )
    return Workspace(
        (l1, l2), reachable, (), "a 2R tool's orientation q1 + q2 is fixed by its position, up to the elbow choice"
    )


def workspace_3r(l1, l2, l3, *, tol: float = 1e-12) -> Workspace:
    """Reachable and dexterous workspaces of a planar 3R arm.

    Parameters
    ----------
    l1, l2, l3 : float
        Link lengths (m), > 0.
    tol : float, keyword-only
        Pieces of the dexterous set closer than this are merged.

    Returns
    -------
    Workspace
        For lengths 4, 2, 1: reachable ``1 <= r <= 7``, dexterous
        ``3 <= r <= 5``.

    Notes
    -----
    Reachable: a chain of links reaches every distance from
    ``max(0, 2 l_max - (l1 + l2 + l3))`` (the longest link folded back on the
    others, or 0 when they can close a triangle) to ``l1 + l2 + l3``.

    Dexterous (every tool orientation phi): for orientation phi the wrist
    (joint 3) must sit at ``p - l3 (cos phi, sin phi)``. As phi turns, that
    point runs round the circle of radius l3 about the tool point ``p``, and
    every one of its points must lie in the annulus ``a <= |w| <= b`` that the
    2R arm (l1, l2) reaches, ``a = |l1 - l2|``, ``b = l1 + l2``. The circle's
    points have distances from ``|r - l3|`` to ``r + l3`` from the base
    (``r = |p|``), so the condition is

        ``r + l3 <= b``  and  ``|r - l3| >= a``,

    that is ``l3 + a <= r <= b - l3`` (the wrist circle between the two
    boundary circles: an annulus, non-empty when ``2 l3 <= b - a``) or
    ``r <= min(l3 - a, b - l3)`` (the wrist circle enclosing the inner
    boundary circle: a disc around the base, when ``l3 >= a``). For 4, 2, 1:
    ``a = 2``, ``b = 6``, so ``3 <= r <= 5``, and ``l3 = 1 < a`` rules out the
    disc.

    Examples
    --------
    >>> ws = workspace_3r(4.0, 2.0, 1.0)
    >>> ws.reachable, ws.dexterous
    ((1.0, 7.0), ((3.0, 5.0),))
    >>> workspace_3r(1.0, 1.0, 0.5).dexterous  # a disc
    ((0.0, 1.5),)
    >>> workspace_3r(1.0, 1.0, 3.0).dexterous  # l3 longer than the 2R reach: empty
    ()
    """
    l1, l2, l3 = link_length(l1, "l1"), link_length(l2, "l2"), link_length(l3, "l3")
    tol = tolerance(tol)
    total = l1 + l2 + l3
    reachable = (max(0.0, 2.0 * max(l1, l2, l3) - total), total)
    a, b = abs(l1 - l2), l1 + l2
    pieces = []
    if l3 >= a and b - l3 >= 0.0:
        pieces.append([0.0, min(l3 - a, b - l3)])
    if l3 + a <= b - l3:
        if pieces and pieces[0][1] >= l3 + a - tol:
            pieces[0][1] = max(pieces[0][1], b - l3)
        else:
            pieces.append([l3 + a, b - l3])
    dexterous = tuple((float(lo), float(hi)) for lo, hi in pieces)
    a_b = f"what links 1 and 2 reach ({_interval_text(a, b)})"
    if not dexterous:
        why = f"a wrist circle of radius l3 = {quantity_text(l3)} fits nowhere in {a_b}"
    else:
        why = f"the wrist circle of radius l3 = {quantity_text(l3)} about the tool lies in {a_b}"
    return Workspace((l1, l2, l3), reachable, dexterous, why)
