"""The sane bounds of every number and count manipkit takes, in one place.

A number a user gives (an option, an API argument, a value in a file) is
taken only inside these bounds, so no answer is built from a value whose
float64 spacing is larger than what it measures, and no allocation is sized
by a count nobody could wait for:

- :data:`MAX_ANGLE` (rad): beyond it the spacing of float64 numbers (1.2e-10
  rad at 1e6) grows towards a full turn (at about 1e16), so the angle names
  no definite rotation.
- :data:`MAX_LENGTH` (m): lengths, offsets, prismatic limits, characteristic
  lengths; two finite offsets near 1.7e308 would sum to infinity, and no arm
  is a thousand kilometres long.
- :data:`MAX_MASS` (kg): a payload or a point mass given by a user.
- :data:`MIN_LENGTH` (m): the smallest positive length-like step (a voxel, a
  grid step, a characteristic length): a nanometre; below it a grid over an
  arm's reach has more cells than memory.
- :data:`MAX_COUNT`: samples, restarts, configurations in one call.
- :data:`MAX_MESH_BYTES`, :data:`MAX_TEXTURE_BYTES`: a mesh file, and a file
  a mesh names (a DAE texture, an OBJ material library); real robot meshes
  are a few MB, and the viewer holds each base64 encoded in memory several times.
- :data:`MAX_MESH_VERTICES`: vertices of one collision mesh given to coal
  (qhull's hull of a 10-million-vertex mesh outlasts any wait).

:func:`tolerances` is the one parser of IK residual tolerances (a number or a
(position m, rotation rad) pair). :func:`length` and :func:`count` check one value and raise the error class
the caller names (each layer has its own), with the bound in the message.
"""

from __future__ import annotations

import math
import numbers
import operator

import numpy as np

from manipkit.errors import IKOptionError, ManipkitError, OptionError
from manipkit.text import repr_text, short_text

__all__ = ["MAX_ANGLE", "MAX_COUNT", "MAX_LENGTH", "MAX_MASS", "MAX_MESH_BYTES", "MAX_MESH_VERTICES", "MAX_TEXTURE_BYTES",
           "MIN_LENGTH", "count", "length", "tolerances"]

MAX_ANGLE = 1e6
MAX_LENGTH = 1e6
#: Largest mass a user may give (kg): a point mass, a payload; the same 1e6 as lengths, so that their
#: products (torques, moments) stay far inside the float range.
MAX_MASS = 1e6
MIN_LENGTH = 1e-9
MAX_COUNT = 10_000_000
MAX_MESH_BYTES = 256 << 20
MAX_TEXTURE_BYTES = 32 << 20
MAX_MESH_VERTICES = 2_000_000


def length(value, what: str, *, positive: bool = True, error: type[ManipkitError] = OptionError) -> float:
    """``value`` as a float length in metres within the bounds, else ``error`` naming ``what``.

    ``positive``: a step or a scale, in ``[MIN_LENGTH, MAX_LENGTH]``;
    otherwise a signed offset, ``|value| <= MAX_LENGTH``.

    Examples
    --------
    >>> length(0.05, "--voxel")
    0.05
    >>> length(1e300, "--voxel")
    Traceback (most recent call last):
    ...
    manipkit.errors.OptionError: --voxel 1e+300: give a length in metres from 1e-09 to 1e+06
    """
    try:
        number = float(value)
    except (TypeError, ValueError, OverflowError):
        raise error(f"{what} {repr_text(value, 40)}: give a number of metres") from None
    low = MIN_LENGTH if positive else -MAX_LENGTH
    if not (math.isfinite(number) and low <= number <= MAX_LENGTH):
        valid = f"from {short_text(MIN_LENGTH)} to {short_text(MAX_LENGTH)}" if positive else f"within +-{short_text(MAX_LENGTH)}"
        raise error(f"{what} {short_text(number)}: give a length in metres {valid}")
    return number


def count(value, what: str, *, minimum: int = 1, maximum: int = MAX_COUNT,
          error: type[ManipkitError] = OptionError) -> int:
    """``value`` as an int in ``[minimum, maximum]``, else ``error`` naming ``what`` and the range.

    Checked before anything is allocated. A float that is a whole number
    (``1e6``) is taken; ``True``/``False`` and strings are not counts.

    Examples
    --------
    >>> count(1e3, "n")
    1000
    >>> count(-1, "n")
    Traceback (most recent call last):
    ...
    manipkit.errors.OptionError: n -1: give a whole number from 1 to 10000000
    """
    number = None
    if isinstance(value, numbers.Real) and not isinstance(value, bool):  # not "3", not True
        try:
            number = operator.index(value)
        except TypeError:
            try:
                number = int(value) if float(value).is_integer() else None
            except (ValueError, OverflowError):
                number = None
    if number is None or not minimum <= number <= maximum:
        raise error(f"{what} {repr_text(value, 40)}: give a whole number from {minimum} to {maximum}")
    return number


def tolerances(tol, *, error: type[Exception] = IKOptionError, what: str = "tol", pair: bool = True,
               zero: bool = False) -> tuple[float, float]:
    """``(position m, rotation rad)`` from one number (both) or a pair, or ``error`` naming ``what``.

    The one parser of tolerances in manipkit's IK. Each must be finite and
    positive (``zero=True``: >= 0); ``pair=False`` takes one number only.

    Examples
    --------
    >>> tolerances(1e-9), tolerances((1e-6, 1e-3))
    ((1e-09, 1e-09), (1e-06, 0.001))
    >>> tolerances(0.0)
    Traceback (most recent call last):
    ...
    manipkit.errors.IKOptionError: tol must be a positive number or (position m, rotation rad), got 0.0
    """
    if type(tol) is float and tol > 0.0 and math.isfinite(tol):  # the common case, fast
        return tol, tol
    try:
        values = np.atleast_1d(np.asarray(tol, dtype=float))
    except (TypeError, ValueError):
        values = np.zeros(0)
    shapes = ((1,), (2,)) if pair else ((1,),)
    bad = values.shape not in shapes or np.ndim(tol) > 1 or not np.all(np.isfinite(values))
    if bad or np.any(values < 0.0) or (not zero and np.any(values == 0.0)):
        least = "a number >= 0" if zero else "a positive number"
        if pair:
            raise error(f"{what} must be {least} or (position m, rotation rad), got {tol!r:.60}")
        raise error(f"{what} = {tol!r:.60} must be {least}")
    return float(values[0]), float(values[-1])
