"""manipkit.app.jacobian_text: one wording of the Jacobian report, so ``manipkit jacobian`` and the viewer agree.

The report's numbers are tested against hand derivations and Pinocchio in
tests/test_analysis_jacobian_report.py; here: the sentences say what stays
still and nothing more, and the command and the viewer's overlay give the
same singularity (the same data and the same lines) for the same pose.
"""

import dataclasses
import json

import numpy as np
import pytest

from manipkit.analysis.jacobian_report import NullMotion, jacobian_report
from manipkit.app.cli import main
from manipkit.app.jacobian_text import singularity_data, singularity_lines
from manipkit.app.viewer import Overlay, ViewerState

SINGULARITY_KEYS = ("rank", "generic_rank", "rank_translation", "generic_rank_translation", "rank_rotation",
                    "generic_rank_rotation", "singular_tol", "movable_rows", "singular", "singular_families",
                    "same_axis", "lost_directions", "lost_motions")


def report_of(robot, q):
    return jacobian_report(robot.chain("base_link", "ee_link"), q)


def test_planar_2r_straight_in_words(planar_2r):
    # (-1, 2)/sqrt5 keeps the origin still and turns the frame at 1/sqrt5 rad/s (hand derivation in
    # tests/test_analysis_jacobian_report.py); "leave the frame still" would be false, vz is never lost
    lines = singularity_lines(report_of(planar_2r, [0.3, 0.0]))
    assert lines == [
        "rank: 2 of 2 (all rows), 1 of 2 (translation rows), 1 of 1 (rotation rows), singular values below 1e-09 "
        "not counted",
        "rows the arm moves: vx, vy, wz (vz, wx, wy are 0 at every configuration, so never lost)",
        "singular: yes (family: elbow straight: joint2 = 0 or 180 deg)",
        "  the origin cannot move along (0.955, 0.296, 0)",
        "  joint1 and joint2 moving as (-0.447, 0.894) keep the origin still and turn the frame at 0.447 rad/s "
        "about (0, 0, 1)",
    ]


def test_a_regular_configuration_says_no_and_nothing_more(iiwa14):
    lines = singularity_lines(report_of(iiwa14, iiwa14.sample_q(1, seed=1)[0]))
    assert lines == ["rank: 6 of 6 (all rows), 3 of 3 (translation rows), 3 of 3 (rotation rows), singular values "
                     "below 1e-09 not counted", "singular: no"]


def test_only_a_motion_that_moves_nothing_leaves_the_frame_still(planar_2r):
    # a one-joint motion whose twist is zero in all rows (a joint that does not move the frame) and one that
    # only keeps the origin still, worded from the same data
    report = report_of(planar_2r, [0.3, 0.0])
    still = NullMotion(np.array([0.0, 1.0]), np.zeros(3), np.zeros(3), "frame")
    turning = NullMotion(np.array([1.0, 0.0]), np.zeros(3), np.array([0.0, 0.0, -2.0]), "origin")
    lines = singularity_lines(dataclasses.replace(report, motions=(still, turning)))
    assert lines[-2:] == ["  joint2 alone leaves the frame still",
                          "  joint1 alone keeps the origin still and turns the frame at 2 rad/s about (0, 0, -1)"]


def test_near_a_family_but_not_singular_says_both(load_robot):
    # joint5 = 1e-7 rad: within the default 1e-6 of the wrist family, but the smallest singular value (about
    # 1e-7 m/s) is above the rank tolerance 1e-9
    stanford = load_robot("stanford_arm")
    report = report_of(stanford, stanford.q(joint2=0.7, joint3=0.5, joint5=1e-7))
    assert not report.singular and [f.name for f in report.families] == ["wrist"]
    assert singularity_lines(report)[-1] == "singular: no (within 1e-06 of the family: wrist: joint5 = 0 or 180 deg)"


def test_the_data_is_json_and_names_the_joints(load_robot):
    stanford = load_robot("stanford_arm")
    data = singularity_data(report_of(stanford, stanford.q()))
    assert json.loads(json.dumps(data, allow_nan=False)) == data
    assert [f["name"] for f in data["singular_families"]] == ["wrist", "boom along joint 1's axis"]
    assert data["same_axis"] == [["joint4", "joint6"]]
    assert [d["rows"] for d in data["lost_directions"]] == ["translation", "rotation"]
    assert [m["still"] for m in data["lost_motions"]] == ["frame", "frame", "origin", "origin"]
    assert data["lost_motions"][2]["joint_rates"] == {"joint1": 0, "joint2": 0, "joint3": 0, "joint4": 1.0,
                                                      "joint5": 0, "joint6": 0}


# --------------------------------------------------------------------------
# the command and the viewer say the same


def cli(capsys, *args) -> tuple[dict, list[str]]:
    """``manipkit jacobian`` in process: (its JSON, its text lines from ``rank:`` on)."""
    assert main(["jacobian", *args, "--format", "json"]) == 0
    answer = json.loads(capsys.readouterr().out)
    assert main(["jacobian", *args]) == 0
    lines = capsys.readouterr().out.splitlines()
    return answer, lines[next(i for i, line in enumerate(lines) if line.startswith("rank:")):]


def viewer(robot, q) -> tuple[dict, list[str]]:
    state = ViewerState(robot, q=q, overlay=Overlay(True))
    ellipsoid = state.ellipsoid()
    text = state.snapshot()["ellipsoid_text"].splitlines()
    assert set(ellipsoid["singularity_lines"]) <= set(text)  # the overlay's readout prints them
    return ellipsoid, ellipsoid["singularity_lines"]


def test_cli_and_viewer_agree_on_the_straight_2r(capsys, planar_2r):
    answer, lines = cli(capsys, "--robot", "planar_2r", "--q", "0.3", "0")
    shown, shown_lines = viewer(planar_2r, [0.3, 0.0])
    assert answer["singular"] is True and shown["singular"] is True
    assert {key: answer[key] for key in SINGULARITY_KEYS} == {key: shown[key] for key in SINGULARITY_KEYS}
    assert lines == shown_lines


@pytest.mark.parametrize(("robot_name", "seed"), [("planar_2r", 1), ("planar_3r", 2), ("scara", 3), ("iiwa14", 4),
                                                  ("stanford_arm", 5), ("stanford_arm", None), ("iiwa14", None)])
def test_cli_and_viewer_agree_on_other_poses(capsys, load_robot, robot_name, seed):
    # random poses (regular) and the default poses of the Stanford arm and the iiwa14 (two families each)
    robot = load_robot(robot_name)
    q = robot.q() if seed is None else robot.sample_q(1, seed=seed)[0]
    answer, lines = cli(capsys, "--robot", robot_name, "--q", *(repr(float(v)) for v in q))
    shown, shown_lines = viewer(robot, q)
    assert answer["singular"] is (seed is None)
    assert {key: answer[key] for key in SINGULARITY_KEYS} == {key: shown[key] for key in SINGULARITY_KEYS}
    assert lines == shown_lines
