"""What the closed-form modules share: the planar argument checks and the numbers in their messages.

The checks raise :class:`PlanarArmError` naming the value; they serve
:mod:`manipkit.closed_form.planar`, :mod:`manipkit.closed_form.planar_workspace`
and the analysis built on them. :func:`quantity_text` is how every
closed-form message prints a length or angle.
"""

from __future__ import annotations

import math

import numpy as np

from manipkit.bounds import tolerances
from manipkit.errors import ClosedFormIKError, PlanarArmError
from manipkit.text import short_text

__all__ = ["NOISE", "arm_angles", "as_float", "finite_array", "link_length", "quantity_text", "tolerance", "tolerance_pair"]

NOISE = 1e-12  # lengths and angles below this print as 0 in messages (rounding noise)


def quantity_text(value: float) -> str:
    """A length (m) or angle (rad) in a message: :func:`manipkit.text.short_text`, with ``|value| <= NOISE`` as 0.

    Examples
    --------
    >>> quantity_text(0.35), quantity_text(-1.2e-16)
    ('0.35', '0')
    """
    return short_text(value, zero=NOISE)


def arm_angles(value, count: int) -> np.ndarray:
    """A 7R SRS arm's angle (rad) for each of ``count`` targets, (count,) float and C-contiguous: one finite
    number for all, or ``count`` of them; :class:`ClosedFormIKError` naming what is wrong otherwise.

    Examples
    --------
    >>> arm_angles(0.5, 3), arm_angles([0.1, -0.2], 2)
    (array([0.5, 0.5, 0.5]), array([ 0.1, -0.2]))
    """
    if value is None:
        raise ClosedFormIKError("a 7R SRS arm has a family of solutions for each target: give arm_angle (rad; "
                                "ik --arm-angle PSI; one, or one per target), or lock a joint")
    try:
        given = np.asarray(value)
    except (TypeError, ValueError):  # ragged nesting
        given = np.asarray(None)
    if given.dtype.kind not in "iuf":  # not text, bool, complex or objects: a number is asked for
        raise ClosedFormIKError(f"arm_angle must be a number (rad) or one per target, got {value!r:.60}")
    angles = given.astype(float)
    if angles.ndim > 1 or (angles.ndim == 1 and len(angles) != count):
        raise ClosedFormIKError(f"arm_angle must be one number (rad) or {count} of them (one per target), got "
                                f"shape {angles.shape}")
    if not np.all(np.isfinite(angles)):
        raise ClosedFormIKError(f"arm_angle must be finite (rad), got {value!r:.60}")
    return np.ascontiguousarray(np.broadcast_to(angles, (count,)))


def as_float(value, what: str) -> np.ndarray:
    """``value`` as a float array, or :class:`PlanarArmError` when it is not numeric."""
    try:
        return np.asarray(value, dtype=float)
    except (TypeError, ValueError):
        raise PlanarArmError(f"{what} must be numeric, got {value!r:.80}") from None


def link_length(value, what: str) -> float:
    """A link length (m): a finite scalar > 0."""
    array = as_float(value, what)
    if array.ndim != 0:
        raise PlanarArmError(f"{what} must be a single number, got shape {array.shape}")
    length = float(array)
    if not math.isfinite(length) or length <= 0.0:
        raise PlanarArmError(f"{what} = {length} is not a valid link length; it must be a finite number > 0")
    return length


def finite_array(value, what: str, *, shape_tail: tuple[int, ...] = (), scalar: bool = False) -> np.ndarray:
    """Finite targets: a scalar (``scalar=True``), or an array ending in ``shape_tail``."""
    array = as_float(value, what)
    if scalar and array.ndim != 0:
        raise PlanarArmError(f"{what} must be a single number, got shape {array.shape}; use the *_batch solver")
    if shape_tail and array.shape[-len(shape_tail):] != shape_tail:
        raise PlanarArmError(f"{what} must have shape (..., {', '.join(map(str, shape_tail))}), got {array.shape}")
    if not np.all(np.isfinite(array)):
        bad = np.argwhere(~np.isfinite(array))[0]
        where = f"{what}[{', '.join(str(int(i)) for i in bad)}]" if array.ndim else what
        raise PlanarArmError(f"{where} = {array[tuple(bad)]} is not finite; targets must be finite numbers")
    return array


def tolerance(tol) -> float:
    """A boundary tolerance (m): one number >= 0, by manipkit's one tolerance parser
    (:func:`manipkit.ik.result.tolerances`), else :class:`PlanarArmError`."""
    return tolerances(tol, error=PlanarArmError, pair=False, zero=True)[0]


def tolerance_pair(tol, *, error: type[Exception] | None = None, what: str = "tol") -> tuple[float, float]:
    """``(position m, rotation rad)`` by :func:`manipkit.ik.result.tolerances` (the one parser), remembered for
    numbers and pairs of numbers already read: a closed-form call on a robot parses the same tolerance each time.

    ``error``: the exception :func:`~manipkit.ik.result.tolerances` raises (its default when None).
    """
    if type(tol) is float and 0.0 < tol < math.inf:  # one positive number, as most calls give it: no parsing
        return tol, tol
    plain = type(tol) in (float, int) or (type(tol) is tuple and all(type(t) in (float, int) for t in tol))
    key = (tol, error, what)
    found = _PARSED.get(key) if plain else None  # (bools, arrays, lists are parsed each time)
    if found is None:
        found = tolerances(tol, what=what) if error is None else tolerances(tol, error=error, what=what)
        if plain and len(_PARSED) < 256:
            _PARSED[key] = found
    return found


#: (tol, error, what) -> the parsed pair, for the numbers and tuples read so far (at most 256).
_PARSED: dict = {}
