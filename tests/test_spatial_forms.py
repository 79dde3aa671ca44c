"""manipkit.spatial.forms: every form of a rotation reproduces it; singular sets named, clean angles there.

Independent source: the elementary rotations rot_x, rot_y, rot_z multiplied out (and Rodrigues' formula).
"""

import math

import numpy as np
import pytest
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
