"""``manipkit rot FORM VALUE...``: one rotation in every form (matrix, rpy, ZYX, ZYZ, axis-angle, quaternion).

The conversions and the singular cases (gimbal lock, ZYZ at theta = 0 or
180 deg, axis-angle at 0 or 180 deg, the quaternion's sign) come from
:mod:`manipkit.spatial.forms`; conventions are in docs/architecture.md. A
hand-rounded matrix is taken within ``--tol`` or by ``--nearest`` as its nearest
rotation (:func:`manipkit.spatial.forms.rotation_from_matrix`), and the answer
says how far that moved.
"""

from __future__ import annotations

import argparse
import math
from pathlib import Path

from manipkit.app.cli.common import (
    EXIT_OK,
    UsageError,
    check_angles,
    check_precision,
    check_tolerance,
    is_number,
    print_json,
)

__all__ = ["register", "run_rot"]

_FORMS = ("matrix", "rpy", "zyx", "zyz", "axis-angle", "quaternion")
_ANGLE_VALUES = {"rpy": (0, 1, 2), "zyx": (0, 1, 2), "zyz": (0, 1, 2), "axis-angle": (3,)}
_LABELS = {
    "rpy": "rpy (roll, pitch, yaw), R = Rz(yaw) Ry(pitch) Rx(roll)",
    "zyx": "ZYX (yaw, pitch, roll), R = Rz(yaw) Ry(pitch) Rx(roll)",
    "zyz": "ZYZ (phi, theta, psi), R = Rz(phi) Ry(theta) Rz(psi)",
    "axis-angle": "axis-angle",
    "quaternion": "quaternion (x, y, z, w)",
}


def register(commands) -> None:
    """Add ``manipkit rot`` to the subparsers ``commands``."""
    rot = commands.add_parser(
        "rot", help="convert a rotation between matrix, rpy, ZYX, ZYZ, axis-angle and quaternion",
        description="Convert one rotation between forms. VALUES: matrix 9 numbers row by row (or a file with a "
                    "3x3 matrix), rpy roll pitch yaw, zyx yaw pitch roll, zyz phi theta psi, axis-angle ax ay az "
                    "angle, quaternion x y z w. Angles in radians (pi/2 works) or, with --deg, degrees.",
    )
    rot.add_argument("form", metavar="FORM", choices=_FORMS, help="the form of VALUES: " + ", ".join(_FORMS))
    # REMAINDER: "-pi/4" is a value, not an option; the options below may also follow the values (see _split)
    rot.add_argument("values", metavar="VALUE", nargs=argparse.REMAINDER,
                     help="the numbers (negative numbers and -pi/4 work as they are)")
    rot.add_argument("--deg", action="store_true", help="angles given and printed in degrees")
    rot.add_argument("--to", action="append", choices=_FORMS, metavar="FORM",
                     help="print only this form (repeatable; default: all)")
    rot.add_argument("--precision", type=int, default=6, metavar="N", help="decimals printed (default 6)")
    rot.add_argument("--tol", type=float, default=1e-6, metavar="TOL",
                     help="matrix: how far from a rotation it may be (column norms, dot products, det; default 1e-6); "
                          "one within it is taken as its nearest rotation, and the answer says how far that moved")
    rot.add_argument("--nearest", action="store_true",
                     help="matrix: take the nearest rotation (SVD) of any matrix with det > 0, and say how far it moved")
    rot.add_argument("--format", choices=("text", "json"), default="text")
    rot.set_defaults(run=run_rot)


def run_rot(args) -> int:
    """Read the rotation, print every form asked (text or JSON) with the singular cases named."""
    import numpy as np

    from manipkit.spatial.forms import rotation_forms, rotation_from_form, rotation_from_matrix

    _split(args)
    check_precision(args.precision)
    check_tolerance(args.tol)
    if args.form != "matrix" and (args.nearest or args.tol != 1e-6):
        raise UsageError(f"--{'nearest' if args.nearest else 'tol'} applies to a matrix; {args.form} always gives a rotation")
    values = _values(args)
    taken = None
    if args.form == "matrix":
        matrix = np.asarray(values, dtype=float)
        taken = rotation_from_matrix(matrix.reshape(3, 3) if matrix.size == 9 else matrix, tol=args.tol,
                                     nearest=args.nearest)
        R = taken.matrix
    else:
        R = rotation_from_form(args.form, values)
    forms = rotation_forms(R)
    wanted = args.to or list(_FORMS)
    scale = math.degrees if args.deg else float
    unit = "deg" if args.deg else "rad"
    data = {
        "matrix": forms.matrix.tolist(),
        "rpy": [scale(v) for v in forms.rpy],
        "zyx": [scale(v) for v in forms.zyx],
        "zyz": [scale(v) for v in forms.zyz],
        "axis-angle": {"axis": forms.axis.tolist(), "angle": scale(forms.angle)},
        "quaternion": forms.quaternion.tolist(),
    }
    moved = taken is not None and taken.projected
    if args.format == "json":
        nearest = {"nearest": {"distance": taken.distance, "largest_change": taken.largest_change}} if moved else {}
        print_json({"input": {"form": args.form, "values": [float(v) for v in np.atleast_1d(values).ravel()]},
                    "angles": unit, **nearest, **{form: data[form] for form in wanted},
                    "notes": {form: note for form, note in forms.notes.items() if form in wanted}})
        return EXIT_OK
    lines = [_nearest_line(taken, args)] if moved else []
    for form in wanted:
        lines += _form_lines(form, data[form], unit, args.precision)
        if form in forms.notes:
            lines.append(f"  note: {forms.notes[form]}")
    print("\n".join(lines))
    return EXIT_OK


def _nearest_line(taken, args) -> str:
    """What replacing the given matrix by its nearest rotation moved."""
    from manipkit.text import short_text

    how = "--nearest" if args.nearest else f"within --tol {short_text(args.tol)}"
    return (f"the given matrix is not exactly a rotation ({how}): the forms are of its nearest rotation (SVD), "
            f"{short_text(taken.distance, 3)} away (Frobenius norm; largest entry change "
            f"{short_text(taken.largest_change, 3)})")


_OPTIONS = {"--deg": "deg", "--nearest": "nearest", "--to": _FORMS, "--precision": int, "--tol": float,
            "--format": ("text", "json")}


def _split(args) -> None:
    """Move the options given after the values (kept in ``args.values`` by REMAINDER) into ``args``."""
    values, tokens = [], list(args.values)
    while tokens:
        token = tokens.pop(0)
        name, _, inline = token.partition("=")
        if name not in _OPTIONS:
            if token.startswith("--"):
                raise UsageError(f"unknown option {token[:40]}; options: {', '.join(_OPTIONS)}")
            values.append(token)
            continue
        kind = _OPTIONS[name]
        if isinstance(kind, str):  # a flag
            setattr(args, kind, True)
            continue
        if not inline and not tokens:
            raise UsageError(f"{name} needs a value")
        value = inline or tokens.pop(0)
        if kind is int:
            try:
                args.precision = int(value)
            except ValueError:
                raise UsageError(f"--precision {value[:40]}: give a whole number") from None
        elif kind is float:
            try:
                args.tol = float(value)
            except ValueError:
                raise UsageError(f"--tol {value[:40]}: give a positive number") from None
        elif value not in kind:
            raise UsageError(f"{name} {value[:40]}: choose one of {', '.join(kind)}")
        elif name == "--to":
            args.to = (args.to or []) + [value]
        else:
            args.format = value
    if not values:
        raise UsageError(f"{args.form}: give its values after the form, e.g. manipkit rot rpy 0.1 0.2 0.3")
    args.values = values


def _values(args):
    """The numbers of VALUES (pi expressions in radians), or the 3x3 matrix of a file for ``matrix FILE``."""
    from manipkit.dh.files import pi_expression_value

    if args.form == "matrix" and len(args.values) == 1 and not is_number(args.values[0]):
        from manipkit.inputs.matrices import read_matrix

        return read_matrix(Path(args.values[0]), rotation=True)
    expected = 9 if args.form == "matrix" else 4 if args.form in ("axis-angle", "quaternion") else 3
    if len(args.values) != expected:
        raise UsageError(f"{args.form} takes {expected} numbers, got {len(args.values)}: {' '.join(args.values)[:80]}")
    numbers = []
    for k, text in enumerate(args.values):
        is_angle = k in _ANGLE_VALUES.get(args.form, ())
        if is_number(text):
            value = float(text)
            numbers.append(math.radians(value) if is_angle and args.deg else value)
            continue
        pi_value = pi_expression_value(text) if is_angle else None
        if pi_value is None:
            hint = "a number or a pi expression (pi/2, -pi/4)" if is_angle else "a number"
            raise UsageError(f"{args.form} value {k + 1} is '{text[:40]}'; give {hint}")
        if args.deg:
            raise UsageError(f"{args.form} value {k + 1} is '{text[:40]}', in radians; drop --deg or give degrees")
        numbers.append(pi_value)
    if not all(math.isfinite(v) for v in numbers):
        raise UsageError(f"{args.form}: the values must be finite numbers")
    angles = [numbers[k] for k in _ANGLE_VALUES.get(args.form, ())]
    check_angles(args.form, angles, degrees=False)  # 1e300 rad names no rotation (sin and cos are noise there)
    return numbers




def _form_lines(form: str, value, unit: str, precision: int) -> list[str]:
    """The lines of one form; rounding noise (1e-9 of 1, or of 1 rad in the unit printed) prints as 0."""
    import math

    from manipkit.spatial.forms import SINGULAR_TOL
    from manipkit.text import number_text, vector_text

    angle_zero = math.degrees(SINGULAR_TOL) if unit == "deg" else SINGULAR_TOL

    def number(v, zero=SINGULAR_TOL) -> str:
        return number_text(v, precision, zero=zero)

    def vector(values, zero=SINGULAR_TOL) -> str:
        return vector_text(values, lambda v: number(v, zero))

    if form == "matrix":
        width = max(len(number(v)) for row in value for v in row)
        return ["rotation matrix:"] + ["  [" + " ".join(number(v).rjust(width) for v in row) + "]" for row in value]
    if form == "axis-angle":
        return [f"axis-angle: axis {vector(value['axis'])}, angle {number(value['angle'], angle_zero)} {unit}"]
    if form == "quaternion":
        return [f"{_LABELS[form]}: {vector(value)}"]
    return [f"{_LABELS[form]}: {vector(value, angle_zero)} {unit}"]
