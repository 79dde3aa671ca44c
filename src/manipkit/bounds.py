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
- :data:`MIN_SPEED`, :data:`MAX_SPEED` (m/s or rad/s), :data:`MIN_DURATION`, :data:`MAX_DURATION` (s): a
  tool speed and a sample interval, over the same 1e-9 to 1e6 range as lengths.
- :data:`MAX_GRAVITY` (m/s^2): a gravity vector's magnitude; 1e3 is a hundred
  times the Earth's, beyond any planet or centrifuge an arm is held in.
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
the caller names (each layer has its own), with the bound in the message; :func:`speed` and :func:`duration` do
the same for speeds and times, :func:`gravity` for a gravity vector.
"""

from __future__ import annotations

import math
import numbers
import operator
from typing import TYPE_CHECKING

from manipkit.errors import IKOptionError, ManipkitError, OptionError
from manipkit.text import repr_text, short_text

if TYPE_CHECKING:  # numpy is imported where it is used: a command's start (tf-between) need not load it here
    import numpy as np

__all__ = ["MAX_ANGLE", "MAX_COUNT", "MAX_DURATION", "MAX_GRAVITY", "MAX_LENGTH", "MAX_MASS", "MAX_MESH_BYTES",
           "MAX_MESH_VERTICES", "MAX_SPEED", "MAX_TEXTURE_BYTES", "MIN_DURATION", "MIN_LENGTH", "MIN_SPEED", "count",
           "duration", "gravity", "length", "speed", "tolerances"]

MAX_ANGLE = 1e6
MAX_LENGTH = 1e6
#: Largest mass a user may give (kg): a point mass, a payload; the same 1e6 as lengths, so that their
#: products (torques, moments) stay far inside the float range.
MAX_MASS = 1e6
MIN_LENGTH = 1e-9
MIN_SPEED, MAX_SPEED = 1e-9, 1e6
MIN_DURATION, MAX_DURATION = 1e-9, 1e6
MAX_GRAVITY = 1e3
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
    if positive:
        return _bounded(value, what, "a length in metres", "metres", MIN_LENGTH, MAX_LENGTH, error)
    return _bounded(value, what, "a length in metres", "metres", None, MAX_LENGTH, error)


def speed(value, what: str, *, unit: str = "m/s", error: type[ManipkitError] = OptionError) -> float:
    """``value`` as a positive speed in ``unit`` (m/s or rad/s) in ``[MIN_SPEED, MAX_SPEED]``, else ``error``.

    Examples
    --------
    >>> speed(1e-300, "--speed")
    Traceback (most recent call last):
    ...
    manipkit.errors.OptionError: --speed 1e-300: give a speed in m/s from 1e-09 to 1e+06
    """
    return _bounded(value, what, f"a speed in {unit}", unit, MIN_SPEED, MAX_SPEED, error)


def duration(value, what: str, *, error: type[ManipkitError] = OptionError) -> float:
    """``value`` as a positive time in seconds in ``[MIN_DURATION, MAX_DURATION]``, else ``error`` naming ``what``."""
    return _bounded(value, what, "a time in seconds", "seconds", MIN_DURATION, MAX_DURATION, error)


def _bounded(value, what, quantity, unit, low, high, error) -> float:
    """``value`` as a float in ``[low, high]`` (``low`` None: ``|value| <= high``), else one line naming
    ``what``, ``quantity`` ("a speed in m/s") and the bounds."""
    try:
        number = float(value)
    except (TypeError, ValueError, OverflowError):
        raise error(f"{what} {repr_text(value, 40)}: give a number of {unit}") from None
    if not (math.isfinite(number) and (-high if low is None else low) <= number <= high):
        valid = f"within +-{short_text(high)}" if low is None else f"from {short_text(low)} to {short_text(high)}"
        raise error(f"{what} {short_text(number)}: give {quantity} {valid}")
    return number


def gravity(values, what: str, *, direction: bool = False, error: type[ManipkitError] = OptionError) -> np.ndarray:
    """``values`` as a (3,) gravity vector (m/s^2): finite, magnitude at most :data:`MAX_GRAVITY`; with
    ``direction`` (a payload's weight needs one) not all zero. Else ``error`` naming ``what``.

    Examples
    --------
    >>> gravity((0, 0, -9.81), "--gravity").tolist()
    [0.0, 0.0, -9.81]
    >>> gravity((0, 0, 1e300), "--gravity")
    Traceback (most recent call last):
    ...
    manipkit.errors.OptionError: --gravity [0, 0, 1e+300]: give 3 finite numbers (m/s^2), magnitude at most 1000
    """
    import numpy as np

    try:
        g = np.asarray(values, dtype=float).reshape(-1)
    except (TypeError, ValueError, OverflowError):
        g = np.zeros(0)
    with np.errstate(over="ignore", invalid="ignore"):
        magnitude = float(np.linalg.norm(g)) if g.size == 3 else math.nan
    if not (g.size == 3 and np.all(np.isfinite(g)) and magnitude <= MAX_GRAVITY):
        shown = "[" + ", ".join(short_text(float(v)) for v in g[:3]) + "]" if g.size == 3 else repr_text(values, 40)
        raise error(f"{what} {shown}: give 3 finite numbers (m/s^2), magnitude at most {short_text(MAX_GRAVITY)}")
    if direction and magnitude == 0.0:
        raise error(f"{what} [0, 0, 0]: give a gravity that is not zero (a payload's weight needs a direction)")
    return g


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
    import numpy as np

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
