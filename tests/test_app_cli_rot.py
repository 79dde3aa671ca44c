"""``manipkit rot``: one rotation in every form, text and JSON, singular cases named (commands run in process).

Expected values come from the elementary rotations (Rz, Ry, Rx products), independent of the conversions.
"""

import json
import math

import numpy as np
import pytest
from cli_helper import run_cli

from manipkit.spatial.rotations import rot_x, rot_y, rot_z


def rot_json(*args):
    return json.loads(run_cli("manipkit", "rot", *args, "--format", "json", status=0).stdout)


def test_rpy_in_every_form_reproduces_the_matrix():
    data = rot_json("rpy", 0.1, 0.2, 0.3)
    R = rot_z(0.3) @ rot_y(0.2) @ rot_x(0.1)  # URDF rpy: R = Rz(yaw) Ry(pitch) Rx(roll)
    assert np.abs(np.array(data["matrix"]) - R).max() < 1e-15
    assert data["zyx"] == pytest.approx([0.3, 0.2, 0.1], abs=1e-14)
    phi, theta, psi = data["zyz"]
    assert np.abs(rot_z(phi) @ rot_y(theta) @ rot_z(psi) - R).max() < 1e-14
    axis, angle = np.array(data["axis-angle"]["axis"]), data["axis-angle"]["angle"]
    # Rodrigues, written out: R = I + sin(a) K + (1 - cos(a)) K^2
    K = np.array([[0, -axis[2], axis[1]], [axis[2], 0, -axis[0]], [-axis[1], axis[0], 0]])
    assert np.abs(np.eye(3) + math.sin(angle) * K + (1 - math.cos(angle)) * K @ K - R).max() < 1e-14
    x, y, z, w = data["quaternion"]
    assert w >= 0 and abs(math.hypot(x, y, z, w) - 1) < 1e-15
    assert abs(2 * math.atan2(math.hypot(x, y, z), w) - angle) < 1e-14
    assert data["notes"] == {}


def test_each_input_form_gives_the_same_rotation():
    R = rot_z(0.3) @ rot_y(0.2) @ rot_x(0.1)
    reference = rot_json("rpy", 0.1, 0.2, 0.3)
    for form in ("zyx", "zyz", "quaternion"):
        values = reference[form]
        assert np.abs(np.array(rot_json(form, *values)["matrix"]) - R).max() < 1e-14, form
    axis_angle = reference["axis-angle"]
    assert np.abs(np.array(rot_json("axis-angle", *axis_angle["axis"], axis_angle["angle"])["matrix"]) - R).max() < 1e-14
    assert np.abs(np.array(rot_json("matrix", *R.ravel())["rpy"]) - [0.1, 0.2, 0.3]).max() < 1e-14


def test_text_output_names_each_form_and_its_convention():
    out = run_cli("manipkit", "rot", "zyx", 30, 20, 10, "--deg", status=0).stdout
    assert "rotation matrix:" in out
    assert "rpy (roll, pitch, yaw), R = Rz(yaw) Ry(pitch) Rx(roll): [10.000000 20.000000 30.000000] deg" in out
    assert "ZYX (yaw, pitch, roll), R = Rz(yaw) Ry(pitch) Rx(roll): [30.000000 20.000000 10.000000] deg" in out
    assert "quaternion (x, y, z, w):" in out and "axis-angle: axis [" in out


def test_gimbal_lock_is_named_and_roll_is_0():
    # ZYX (yaw 30, pitch 90, roll -20) deg: at pitch +90 only yaw - roll = 50 deg is defined.
    out = run_cli("manipkit", "rot", "zyx", 30, 90, -20, "--deg", status=0).stdout
    assert "ZYX (yaw, pitch, roll), R = Rz(yaw) Ry(pitch) Rx(roll): [50.000000 90.000000 0.000000] deg" in out
    assert "note: gimbal lock (pitch = +90 deg): only yaw - roll is defined; roll set to 0" in out
    data = rot_json("zyx", 30, 90, -20, "--deg")
    assert np.abs(np.array(data["matrix"]) - rot_z(math.radians(50)) @ rot_y(math.pi / 2)).max() < 1e-15


def test_gimbal_lock_from_a_matrix_with_rounding_noise_is_clean():
    # Ry(-90 deg) with 1e-12 of noise in the entries that vanish at the lock: roll stays exactly 0.
    R = rot_y(-math.pi / 2)
    R[2, 1] = R[2, 2] = 1e-12
    data = rot_json("matrix", *R.ravel())
    assert data["rpy"][0] == 0.0 and data["rpy"][1] == pytest.approx(-math.pi / 2, abs=1e-11)
    assert "gimbal lock (pitch = -90 deg): only yaw + roll is defined" in data["notes"]["rpy"]


def test_zyz_singular_and_axis_angle_at_0_and_180_deg_are_named():
    data = rot_json("matrix", 1, 0, 0, 0, 1, 0, 0, 0, 1)
    assert data["notes"]["zyz"] == "theta = 0 deg: only phi + psi is defined; psi set to 0"
    assert data["notes"]["axis-angle"] == "angle 0: every axis is valid; (0, 0, 1) given"
    assert data["axis-angle"] == {"axis": [0.0, 0.0, 1.0], "angle": 0.0}
    half = rot_json("axis-angle", 0, -1, 0, "pi")  # 180 deg about -y is 180 deg about +y
    assert half["axis-angle"]["axis"] == pytest.approx([0, 1, 0], abs=1e-15)
    assert "angle 180 deg: axis and -axis are the same rotation" in half["notes"]["axis-angle"]
    assert "w = 0 (180 deg): q and -q are the same rotation" in half["notes"]["quaternion"]
    assert rot_json("rpy", 0, "pi", 0)["notes"]["zyz"] == "theta = 180 deg: only phi - psi is defined; psi set to 0"


def test_pi_expressions_and_to_select_forms():
    data = rot_json("rpy", "pi/2", 0, "-pi/4", "--to", "rpy", "--to", "quaternion")
    assert set(data) == {"input", "angles", "rpy", "quaternion", "notes"}
    assert data["rpy"] == pytest.approx([math.pi / 2, 0, -math.pi / 4], abs=1e-15)


def test_a_matrix_file_is_read(tmp_path):
    path = tmp_path / "R.txt"
    path.write_text("[[0, -1, 0], [1, 0, 0], [0, 0, 1]]\n")
    assert rot_json("matrix", path)["rpy"] == pytest.approx([0, 0, math.pi / 2], abs=1e-15)


@pytest.mark.parametrize(("args", "fragment"), [
    (("rpy", 1, 2), "rpy takes 3 numbers, got 2"),
    (("rpy", 1, 2, "x"), "rpy value 3 is 'x'; give a number or a pi expression"),
    (("rpy", "pi/2", 0, 0, "--deg"), "in radians; drop --deg"),
    (("matrix", 1, 0, 0, 0, 1, 0, 0, 0, -1), "det"),
    (("quaternion", 0, 0, 0, 0), "zero or not finite"),
    (("axis-angle", 0, 0, 0, 1), "the axis is (0, 0, 0)"),
])
def test_bad_input_is_one_line_with_exit_2(args, fragment):
    result = run_cli("manipkit", "rot", *args, status=2)
    assert result.stderr.count("\n") == 1 and fragment in result.stderr, result.stderr
    assert "Traceback" not in result.stderr


def test_rounding_noise_prints_as_zero_at_any_precision():
    # Rz(pi/2): cos(pi/2) is 6.1e-17 in floating point, not a number anyone wrote; the noise rule prints it as 0
    out = run_cli("manipkit", "rot", "rpy", "0", "0", "pi/2", "--to", "matrix", "--precision", "17", status=0).stdout
    assert "0.00000000000000006" not in out
    assert "[ 0.00000000000000000 -1.00000000000000000  0.00000000000000000]" in out


# ----------------------------------------------------------------------
# Hand-rounded matrices: --tol and --nearest (issue 25, item 7)
# ----------------------------------------------------------------------

SEED_RY = ("-0.835", "0", "-0.549", "0", "1", "0", "0.549", "0", "-0.835")  # seeds/000, T_3's rotation, 3 decimals


def test_a_hand_rounded_matrix_is_refused_with_the_two_ways_to_take_it():
    result = run_cli("manipkit", "rot", "matrix", *SEED_RY, status=2)
    assert "not a rotation matrix within tol 1e-06" in result.stderr
    assert "--tol 0.002 accepts it, and --nearest uses the nearest rotation (SVD, 0.00097 away)" in result.stderr


@pytest.mark.parametrize("option", [("--tol", "0.002"), ("--nearest",)])
def test_tol_or_nearest_takes_it_and_prints_how_far_it_moved(option):
    result = run_cli("manipkit", "rot", "matrix", *SEED_RY, *option, "--deg", status=0)
    first, *rest = result.stdout.splitlines()
    how = "--nearest" if option == ("--nearest",) else "within --tol 0.002"
    assert first == (f"the given matrix is not exactly a rotation ({how}): the forms are of its nearest rotation "
                     "(SVD), 0.000972 away (Frobenius norm; largest entry change 0.000574)")
    # the nearest rotation of k Ry(phi) is Ry(phi), phi = atan2(-0.549, -0.835) = -146.676 deg (by hand: see
    # test_spatial_forms); axis-angle gives it as 146.676 deg about -y
    assert "axis-angle: axis [0.000000 -1.000000 0.000000], angle 146.675679 deg" in rest


def test_nearest_in_json_gives_the_distance_and_the_rotation():
    data = rot_json("matrix", *SEED_RY, "--nearest")
    k = math.hypot(0.835, 0.549)
    assert data["nearest"]["distance"] == pytest.approx(abs(1 - k) * math.sqrt(2), rel=1e-12)
    assert np.abs(np.array(data["matrix"]) - rot_y(math.atan2(-0.549, -0.835))).max() < 1e-15
    assert "nearest" not in rot_json("matrix", *map(str, rot_z(0.4).ravel()))  # a rotation is taken as it is


@pytest.mark.parametrize(("args", "fragment"), [
    (("matrix", "1", "0", "0", "0", "1", "0", "0", "0", "-1", "--nearest"), "det = -1: the nearest rotation needs"),
    (("rpy", "0", "0", "1", "--nearest"), "--nearest applies to a matrix; rpy always gives a rotation"),
    (("quaternion", "0", "0", "0", "1", "--tol", "0.1"), "--tol applies to a matrix"),
    (("matrix", *SEED_RY, "--tol", "0"), "--tol 0: give a positive finite tolerance"),
    (("matrix", *SEED_RY, "--tol", "x"), "--tol x: give a positive number"),
])
def test_tol_and_nearest_misuse_is_one_line(args, fragment):
    result = run_cli("manipkit", "rot", *args, status=2)
    assert fragment in result.stderr and len(result.stderr.splitlines()) == 1
