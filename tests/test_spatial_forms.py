"""manipkit.spatial.forms: every form of a rotation reproduces it; singular sets named, clean angles there.

Independent source: the elementary rotations rot_x, rot_y, rot_z multiplied out (and Rodrigues' formula).
"""

import math

import numpy as np
import pytest
import scipy.linalg
from hypothesis import given
from hypothesis import strategies as st

from manipkit.errors import InvalidRotationError
from manipkit.spatial.forms import FORMS, rotation_forms, rotation_from_form
from manipkit.spatial.rotations import rot_x, rot_y, rot_z

angles = st.floats(-math.pi, math.pi, allow_nan=False)


def rebuilt(forms, form):
    values = {
        "matrix": forms.matrix.ravel(), "rpy": forms.rpy, "zyx": forms.zyx, "zyz": forms.zyz,
        "axis-angle": [*forms.axis, forms.angle], "quaternion": forms.quaternion,
    }[form]
    return rotation_from_form(form, values)


@given(angles, st.floats(-math.pi / 2, math.pi / 2), angles)
def test_every_form_reproduces_the_rotation(yaw, pitch, roll):
    R = rot_z(yaw) @ rot_y(pitch) @ rot_x(roll)
    forms = rotation_forms(R)
    for form in FORMS:
        assert np.abs(rebuilt(forms, form) - R).max() < 1e-9, form


@pytest.mark.parametrize("sign", [1, -1])
@given(yaw=angles, roll=angles, noise=st.floats(-1e-12, 1e-12))
def test_near_gimbal_lock_roll_is_0_and_the_rotation_is_kept(sign, yaw, roll, noise):
    R = rot_z(yaw) @ rot_y(sign * math.pi / 2 + noise) @ rot_x(roll)
    forms = rotation_forms(R)
    assert forms.rpy[0] == 0.0 and forms.zyx[2] == 0.0
    assert np.abs(rebuilt(forms, "rpy") - R).max() < 1e-9
    assert forms.notes["rpy"].startswith(f"gimbal lock (pitch = {'+' if sign > 0 else '-'}90 deg)")


def test_zyz_at_theta_0_and_180_sets_psi_0():
    assert rotation_forms(rot_z(0.4) @ rot_z(0.5)).zyz == pytest.approx([0.9, 0, 0], abs=1e-15)
    forms = rotation_forms(rot_z(0.7) @ rot_y(math.pi) @ rot_z(0.2))  # only phi - psi = 0.5 is defined
    assert forms.zyz == pytest.approx([0.5, math.pi, 0], abs=1e-12)
    assert forms.notes["zyz"] == "theta = 180 deg: only phi - psi is defined; psi set to 0"


def test_axis_angle_and_quaternion_at_180_deg_pick_the_positive_axis():
    forms = rotation_forms(rot_y(-math.pi))  # rot_y(-pi) = rot_y(pi): the axis +y
    assert forms.axis == pytest.approx([0, 1, 0], abs=1e-15) and forms.angle == pytest.approx(math.pi)
    assert list(forms.quaternion) == pytest.approx([0, 1, 0, 0], abs=1e-15) and forms.quaternion[3] == 0.0


def test_the_identity_has_axis_z_and_angle_0():
    forms = rotation_forms(np.eye(3))
    assert forms.angle == 0.0 and list(forms.axis) == [0.0, 0.0, 1.0]
    assert set(forms.notes) == {"zyz", "axis-angle"}


@pytest.mark.parametrize(("form", "values", "message"), [
    ("euler", [0, 0, 0], "rotation form 'euler': choose one of matrix, rpy"),
    ("rpy", [0, 0], "rpy takes 3 numbers, got 2"),
    ("matrix", [1, 0, 0, 0, 1, 0, 0, 0, -1], "det"),
    ("axis-angle", [0, 0, 0, 1], "the axis is (0, 0, 0)"),
    ("rpy", [0, math.inf, 0], "finite"),
])
def test_bad_forms_are_refused_with_a_message(form, values, message):
    with pytest.raises(InvalidRotationError, match=message.replace("(", r"\(").replace(")", r"\)")):
        rotation_from_form(form, values)


# ----------------------------------------------------------------------
# Hand-rounded matrices: rotation_from_matrix (issue 25, item 7)
# ----------------------------------------------------------------------

# The seed's rotation about y, written to three decimals (seeds/000, its T_3): c = -0.835, s = -0.549
SEED_RY = np.array([[-0.835, 0.0, -0.549], [0.0, 1.0, 0.0], [0.549, 0.0, -0.835]])


def test_a_rounded_matrix_is_refused_with_the_tolerance_that_takes_it_and_the_distance_to_the_nearest():
    from manipkit.spatial.forms import rotation_from_matrix

    with pytest.raises(InvalidRotationError) as raised:
        rotation_from_matrix(SEED_RY)
    message = str(raised.value)
    assert message.startswith("R is not a rotation matrix within tol 1e-06: ")
    suggested = float(message.split("--tol ")[1].split()[0])
    assert "--nearest uses the nearest rotation (SVD, 0.00097 away)" in message
    # the tolerance named accepts the matrix, and is the smallest 1-2-5 step that does
    assert rotation_from_matrix(SEED_RY, tol=suggested).projected
    with pytest.raises(InvalidRotationError):
        rotation_from_matrix(SEED_RY, tol=suggested / 2.5)


def test_the_nearest_rotation_of_a_scaled_planar_rotation_is_the_normalised_one():
    from manipkit.spatial.forms import rotation_from_matrix

    taken = rotation_from_matrix(SEED_RY, nearest=True)
    # by hand: SEED_RY = k Ry(phi) in the x-z block, k = hypot(0.835, 0.549); its nearest rotation is Ry(phi),
    # phi = atan2(s, c) with Ry = [[c, 0, s], [0, 1, 0], [-s, 0, c]], and the distance is |1 - k| * sqrt(2)
    k = math.hypot(0.835, 0.549)
    assert np.abs(taken.matrix - rot_y(math.atan2(-0.549, -0.835))).max() < 1e-15
    assert taken.distance == pytest.approx(abs(1 - k) * math.sqrt(2), rel=1e-12)
    assert taken.largest_change == pytest.approx(abs(1 - k) * 0.835 / k, rel=1e-12)
    assert taken.projected and np.array_equal(taken.given, SEED_RY)


@given(angles, st.floats(-math.pi / 2, math.pi / 2), angles, st.integers(2, 4))
def test_a_rotation_rounded_to_a_few_decimals_is_taken_back_to_within_the_rounding(yaw, pitch, roll, decimals):
    from manipkit.spatial.forms import rotation_from_matrix

    R = rot_z(yaw) @ rot_y(pitch) @ rot_x(roll)
    M = np.round(R, decimals)
    taken = rotation_from_matrix(M, nearest=True)
    # independent: the orthogonal factor of the polar decomposition (SciPy) is the nearest rotation
    assert np.abs(taken.matrix - scipy.linalg.polar(M)[0]).max() < 1e-12
    assert np.abs(taken.matrix - R).max() < 3 * 10.0**-decimals
    assert taken.distance == pytest.approx(np.linalg.norm(taken.matrix - M), abs=1e-15)


def test_an_exact_rotation_is_taken_as_given():
    from manipkit.spatial.forms import rotation_from_matrix

    R = rot_z(0.3) @ rot_x(1.1)
    taken = rotation_from_matrix(R)
    assert taken.matrix is taken.given and not taken.projected and taken.distance == 0.0


def test_nearest_refuses_a_reflection_and_a_singular_matrix():
    from manipkit.spatial.forms import rotation_from_matrix

    with pytest.raises(InvalidRotationError, match="det = -1: the nearest rotation needs a matrix with a positive"):
        rotation_from_matrix(np.diag([1.0, 1.0, -1.0]), nearest=True)
    with pytest.raises(InvalidRotationError, match="det = 0"):
        rotation_from_matrix(np.zeros((3, 3)), nearest=True)
