"""manipkit.app.pose: the pose text tf-between and the viewer print, with the printed-noise and gimbal-lock rules."""

from __future__ import annotations

import math

import numpy as np

from manipkit.app.pose import pose_fields, pose_report, pose_text
from manipkit.spatial.forms import rotation_forms
from manipkit.spatial.rotations import matrix_from_rpy


def report_of(T) -> dict:
    fields = pose_fields(T)
    return {"source": "a", "target": "b", "translation": fields["translation"].tolist(),
            "quaternion_xyzw": fields["quaternion_xyzw"].tolist(), "rpy": fields["rpy"].tolist(),
            "matrix": np.asarray(T).tolist()}


def test_rounding_noise_prints_as_zero(planar_2r):
    # planar 2R (1, 1) at q1 = 90 deg, q2 = 0: the tip is at (2 cos 90, 2 sin 90) = (0, 2); numpy's cos(pi/2) leaves
    # x = 2 * 6.1e-17 = 1.2e-16 m, which printed 0.00000000000000012 at 17 decimals before
    q = planar_2r.q(joint1=90, degrees=True)
    report = pose_report(planar_2r, "base_link", "ee_link", q)
    assert 0 < abs(report["translation"][0]) < 1e-15  # the JSON keeps the number as computed
    text = pose_text(report, precision=17)
    assert "- Translation (m): [0.00000000000000000, 2.00000000000000000, 0.00000000000000000]" in text
    assert "0.00000000000000006" not in text and "0.00000000000000012" not in text


def test_a_small_but_real_translation_still_prints():
    T = np.eye(4)
    T[:3, 3] = [1e-6, 0.0, 0.0]  # a micrometre is not noise
    assert "[0.000001000, 0.000000000, 0.000000000]" in pose_text(report_of(T), precision=9)


def test_near_gimbal_lock_the_rpy_is_the_one_manipkit_rot_prints_and_says_so():
    # pitch 1e-11 short of 90 deg: only yaw - roll = 0.5 - 0.3 = 0.2 is defined; the rule sets roll = 0, yaw = 0.2
    R = matrix_from_rpy([0.3, math.pi / 2 - 1e-11, 0.5])
    T = np.eye(4)
    T[:3, :3] = R
    fields = pose_fields(T)
    np.testing.assert_allclose(fields["rpy"], rotation_forms(R).rpy, atol=0, rtol=0)
    np.testing.assert_allclose(fields["rpy"], [0.0, math.pi / 2, 0.2], atol=1e-10)
    assert "(gimbal lock (pitch = +90 deg): only yaw - roll is defined; roll set to 0)" in pose_text(report_of(T))


def test_away_from_gimbal_lock_no_note_and_the_angles_as_given():
    R = matrix_from_rpy([0.3, 0.4, 0.5])
    T = np.eye(4)
    T[:3, :3] = R
    np.testing.assert_allclose(pose_fields(T)["rpy"], [0.3, 0.4, 0.5], atol=1e-15)
    assert "gimbal" not in pose_text(report_of(T))
