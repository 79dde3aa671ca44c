"""The closed-form result contract, as properties over random targets, for every mode of every solver.

For every solver and mode (planar 2R position and pose, planar 3R pose and
position, SCARA pose and position, Stanford and elbow pose, and the five
bundled robots through ``analytic_ik`` in both modes), over random targets
that include the workspace boundaries and the singular sets:

- every reported solution reproduces the target in the asked mode to 1e-9,
  by forward kinematics computed here: the planar formulas written out in
  :func:`planar_fk`, or Pinocchio through the bundled URDFs (an independent
  model from the DH tables the solvers use);
- with no solution, every component the arm cannot meet is reported with its
  size, and where the size has a textbook value (distance outside the
  annulus, height off the plane, tilt of the tool, the tool angle a 2R arm
  misses) it is that value.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import manipkit
from manipkit.errors import ClosedFormIKError, IKOptionError
from manipkit.ik import decoupled, planar, planar_modes
from manipkit.ik.result import (
    PLANAR_POSE,
    PLANAR_POSITION,
    SPATIAL_POSE,
    SPATIAL_POSITION,
    IKResult,
)
from manipkit.ik.textbook import ANALYTIC_SOLVERS, analytic_ik

TOL = 1e-9
SETTINGS = settings(deadline=None, max_examples=80)

lengths = st.floats(0.1, 5.0)
angles = st.floats(-math.pi, math.pi)
KINDS = ("inside", "outer", "inner", "base", "outside")


@pytest.fixture(scope="module")
def arms():
    return {name: manipkit.load(name) for name in ANALYTIC_SOLVERS}


def planar_fk(q, link_lengths):
    """(x, y, phi) of a planar arm, written out: link i points along q1 + ... + qi (angles from +x, about +z)."""
    heading = np.cumsum(q)
    return float(np.dot(link_lengths, np.cos(heading))), float(np.dot(link_lengths, np.sin(heading))), float(heading[-1])


def angle_between(a, b):
    return abs(math.remainder(a - b, 2.0 * math.pi))


def annulus_gap(r, outer, inner):
    """How far (m) radius r lies outside [inner, outer]; 0 inside."""
    return max(r - outer, inner - r, 0.0)


def planar_point(kind, l1, l2, theta, fraction):
    """A 2R target of the given kind: inside the annulus, on either circle, at the base, or outside."""
    outer, inner = l1 + l2, abs(l1 - l2)
    r = {
        "inside": inner + (outer - inner) * (0.02 + 0.96 * fraction),
        "outer": outer,
        "inner": inner,
        "base": 0.0,
        "outside": outer + 0.01 + 3.0 * fraction if fraction > 0.3 or inner < 0.02 else inner * fraction,
    }[kind]
    return r * math.cos(theta), r * math.sin(theta)


def assert_unmet_when_empty(result: IKResult):
    assert result.success == (len(result.labels) > 0) == (result.solutions.shape[0] > 0)
    if result.success:
        assert result.unmet == ()
    else:
        assert result.count == 0 and result.unmet, result.reason
        assert all(size > 0.0 and math.isfinite(size) for _, size in result.unmet), result.unmet
        assert result.reason.startswith("no solution")


# --------------------------------------------------------------------------
# planar 2R: position, and pose


@SETTINGS
@given(lengths, lengths, st.sampled_from(KINDS), angles, st.floats(0.0, 1.0), st.booleans())
def test_2r_position(l1, l2, kind, theta, fraction, equal):
    l2 = l1 if equal else l2
    x, y = planar_point(kind, l1, l2, theta, fraction)
    result = planar.ik_2r(x, y, l1, l2)
    assert result.mode == PLANAR_POSITION
    for row, position in zip(result.solutions, result.residual_position):
        x_fk, y_fk, _ = planar_fk(row, [l1, l2])
        assert math.hypot(x_fk - x, y_fk - y) <= TOL and position <= TOL
    assert np.all(result.residual_rotation == 0.0)
    assert_unmet_when_empty(result)
    gap = annulus_gap(math.hypot(x, y), l1 + l2, abs(l1 - l2))
    if gap > 1e-12:
        assert not result.success and result.unmet[0][0] == "position" and abs(result.unmet[0][1] - gap) <= 1e-12
    else:
        assert result.success


@SETTINGS
@given(lengths, lengths, st.sampled_from(KINDS), angles, st.floats(0.0, 1.0), angles, st.booleans())
def test_2r_pose(l1, l2, kind, theta, fraction, phi, equal):
    l2 = l1 if equal else l2
    x, y = planar_point(kind, l1, l2, theta, fraction)
    position = planar.ik_2r(x, y, l1, l2)
    # Half the cases ask for an angle an elbow has (reachable), half for a random one.
    if position.success and not position.infinite and fraction < 0.5:
        phi = planar_fk(position.solutions[0], [l1, l2])[2]
    result = planar_modes.ik_2r_pose(x, y, phi, l1, l2)
    assert result.mode == PLANAR_POSE
    for row, rotation in zip(result.solutions, result.residual_rotation):
        x_fk, y_fk, phi_fk = planar_fk(row, [l1, l2])
        assert math.hypot(x_fk - x, y_fk - y) <= TOL and angle_between(phi_fk, phi) <= TOL and rotation <= TOL
    assert_unmet_when_empty(result)
    if not result.success and position.success:
        headings = [planar_fk(row, [l1, l2])[2] for row in position.solutions]
        assert result.unmet[0][0] == "orientation"
        assert abs(result.unmet[0][1] - min(angle_between(h, phi) for h in headings)) <= 1e-12
    if position.infinite:  # at the base with l1 = l2: any angle is met (q1 = phi - pi)
        assert result.count == 1


# --------------------------------------------------------------------------
# planar 3R: pose, and position (a family in phi)


@SETTINGS
@given(lengths, lengths, lengths, st.sampled_from(KINDS), angles, st.floats(0.0, 1.0), angles, st.booleans())
def test_3r_pose(l1, l2, l3, kind, theta, fraction, phi, equal):
    l2 = l1 if equal else l2
    wx, wy = planar_point(kind, l1, l2, theta, fraction)  # the wrist point's kind decides the case
    x, y = wx + l3 * math.cos(phi), wy + l3 * math.sin(phi)
    result = planar.ik_3r(x, y, phi, l1, l2, l3)
    assert result.mode == PLANAR_POSE
    for row in result.solutions:
        x_fk, y_fk, phi_fk = planar_fk(row, [l1, l2, l3])
        assert math.hypot(x_fk - x, y_fk - y) <= TOL and angle_between(phi_fk, phi) <= TOL
    assert_unmet_when_empty(result)
    gap = annulus_gap(math.hypot(x - l3 * math.cos(phi), y - l3 * math.sin(phi)), l1 + l2, abs(l1 - l2))
    if gap > 1e-9:
        assert result.unmet[0][0] == "position" and abs(result.unmet[0][1] - gap) <= 1e-9
    elif gap == 0.0 and kind == "inside":
        assert result.count == 2


@SETTINGS
@given(lengths, lengths, lengths, st.floats(0.0, 1.2), angles, st.integers(1, 6), st.lists(angles, max_size=4))
def test_3r_position_family(l1, l2, l3, reach, theta, samples, phis):
    far, near = l1 + l2 + l3, max(0.0, abs(l1 - l2) - l3, l3 - l1 - l2)
    r = reach * far
    x, y = r * math.cos(theta), r * math.sin(theta)
    result = planar_modes.ik_3r_position(x, y, l1, l2, l3, samples=samples)
    assert result.mode == PLANAR_POSITION
    for row in result.solutions:
        x_fk, y_fk, _ = planar_fk(row, [l1, l2, l3])
        assert math.hypot(x_fk - x, y_fk - y) <= TOL
    assert np.all(result.residual_rotation == 0.0)
    assert_unmet_when_empty(result)
    gap = annulus_gap(r, far, near)
    if gap > 1e-9:
        assert result.unmet == (("position", pytest.approx(gap, abs=1e-9)),)
    elif gap == 0.0 and near + 1e-6 < r < far - 1e-6:
        assert result.count == math.inf and result.free_parameter == "phi" and len(result.labels) >= 1
        members = result.members(phis)
        for row, label in zip(members.solutions, members.labels):
            x_fk, y_fk, phi_fk = planar_fk(row, [l1, l2, l3])
            assert math.hypot(x_fk - x, y_fk - y) <= TOL
            assert label.startswith("phi = ")


# --------------------------------------------------------------------------
# the decoupled arms, checked through the bundled URDFs (their default parameters)


def scara_q(kind, values):
    t1, t2, d3, t4 = values
    t2 = {"righty": t2, "straight": 0.0, "folded": math.pi}.get(kind, t2)
    d3 = {"top": 0.0, "bottom": 0.3}.get(kind, 0.3 * abs(d3) / math.pi)
    return [t1, t2, d3, t4]


@SETTINGS
@given(st.sampled_from(("righty", "straight", "folded", "top", "bottom")), st.lists(angles, min_size=4, max_size=4),
       st.sampled_from(("reach", "tilt", "high", "far")), st.floats(0.01, 0.5))
def test_scara_pose(arms, kind, values, perturbation, size):
    robot = arms["scara"]
    q = scara_q(kind, values)
    T = robot.transform("base_link", "ee_link", q)
    expected = None
    if perturbation == "tilt":
        c, s = math.cos(size), math.sin(size)
        T[:3, :3] = T[:3, :3] @ np.array([[1.0, 0.0, 0.0], [0.0, c, -s], [0.0, s, c]])  # about the tool's x axis
        expected = ("tool z axis tilt", size)
    elif perturbation == "high":
        T[2, 3] = 0.35 + size  # d3 = d1 - d4 - z = 0.35 - z < 0: above the top of the stroke
        expected = ("z", size)
    elif perturbation == "far":
        T[:2, 3] *= (0.6 + size) / max(np.linalg.norm(T[:2, 3]), 1e-9)
        expected = ("position (r)", size)
    result = decoupled.ik_scara(T)
    assert result.mode == SPATIAL_POSE
    for row in result.solutions:
        reached = robot.transform("base_link", "ee_link", row)
        assert np.linalg.norm(reached[:3, 3] - T[:3, 3]) <= TOL
        assert np.linalg.norm(reached[:3, :3] - T[:3, :3]) <= TOL
    assert_unmet_when_empty(result)
    if expected is None:
        assert result.success
    else:
        assert dict(result.unmet)[expected[0]] == pytest.approx(expected[1], abs=1e-9)


@SETTINGS
@given(st.sampled_from(("righty", "straight", "folded", "top", "bottom")), st.lists(angles, min_size=4, max_size=4),
       st.floats(-math.pi, math.pi), st.lists(angles, max_size=3))
def test_scara_position_family(arms, kind, values, tilt, rolls):
    robot = arms["scara"]
    T = robot.transform("base_link", "ee_link", scara_q(kind, values))
    T[:3, :3] = manipkit.spatial.rotations.rot_x(tilt)  # any orientation: ignored in position mode
    result = decoupled.ik_scara(T, mode="position")
    assert result.mode == SPATIAL_POSITION and result.success and "theta4" in result.free_parameter
    for row in (*result.solutions, *result.members(rolls).solutions):
        reached = robot.transform("base_link", "ee_link", row)
        assert np.linalg.norm(reached[:3, 3] - T[:3, 3]) <= TOL
    branches = len(result.labels) // 4  # 4 sampled rolls by default; 1 branch on a boundary circle, else 2
    assert branches in (1, 2) and len(result.members(rolls).labels) == len(rolls) * branches


def six_joint_q(name, kind, values):
    q = list(values)
    if name == "stanford_arm":
        q[2] = 0.1 + 0.9 * abs(values[2]) / math.pi  # d3 inside its stroke
    if kind == "wrist singular":
        q[4] = 0.0
    elif kind == "wrist flipped singular":
        q[4] = math.pi
    elif kind == "boundary" and name == "elbow_arm":
        q[2] = 0.0  # arm straight: the wrist centre on the outer sphere
    elif kind == "boundary":
        q[1] = 0.0  # Stanford boom vertical
    return q


@SETTINGS
@given(st.sampled_from(("stanford_arm", "elbow_arm")), st.sampled_from(("generic", "wrist singular", "wrist flipped singular", "boundary")),
       st.lists(angles, min_size=6, max_size=6))
def test_six_joint_arms_pose(arms, name, kind, values):
    robot = arms[name]
    T = robot.transform("base_link", "ee_link", six_joint_q(name, kind, values))
    solve = decoupled.ik_stanford if name == "stanford_arm" else decoupled.ik_elbow
    result = solve(T)
    assert result.mode == SPATIAL_POSE and result.success
    for row in result.solutions:
        reached = robot.transform("base_link", "ee_link", row)
        assert np.linalg.norm(reached[:3, 3] - T[:3, 3]) <= TOL
        assert np.linalg.norm(reached[:3, :3] - T[:3, :3]) <= TOL


@SETTINGS
@given(st.sampled_from(("stanford_arm", "elbow_arm")), st.floats(0.05, 3.0), angles, angles)
def test_six_joint_arms_out_of_reach_name_the_wrist_centre(arms, name, beyond, azimuth, elevation):
    # A wrist centre beyond the outer sphere (elbow arm) or beyond the boom's stroke (Stanford).
    T = np.eye(4)
    if name == "elbow_arm":
        shoulder, radius = np.array([0.0, 0.0, 0.4]), 0.45 + 0.4 + beyond  # d1; a2 + a3
    else:
        shoulder, radius = np.zeros(3), math.hypot(1.0, 0.154) + beyond  # d1 = 0; stroke 1.0 and offset d2
    direction = [math.cos(elevation) * math.cos(azimuth), math.cos(elevation) * math.sin(azimuth), math.sin(elevation)]
    T[:3, 3] = shoulder + radius * np.array(direction)
    T[:3, 3] += T[:3, 2] * (0.1 if name == "elbow_arm" else 0.263)  # the tool d6 beyond the wrist centre along z
    result = (decoupled.ik_elbow if name == "elbow_arm" else decoupled.ik_stanford)(T)
    assert_unmet_when_empty(result)
    if name == "elbow_arm":
        assert result.unmet == (("wrist centre", pytest.approx(beyond, abs=1e-9)),)
    else:
        assert set(dict(result.unmet)) <= {"wrist centre", "d3"}


# --------------------------------------------------------------------------
# the bundled robots through analytic_ik, both modes: rows checked through the URDF here too


@SETTINGS
@given(st.sampled_from(sorted(ANALYTIC_SOLVERS)), st.sampled_from(("pose", "position")),
       st.lists(angles, min_size=6, max_size=6), st.sampled_from(("none", "z", "tilt")), st.floats(0.01, 0.5))
def test_analytic_ik_every_robot_every_mode(arms, name, mode, values, perturbation, size):
    robot = arms[name]
    n = len(robot.joint_names)
    q = list(values[:n])
    if name == "scara":
        q = scara_q("righty", q)
    elif name == "stanford_arm":
        q = six_joint_q(name, "generic", q)
    T = robot.transform("base_link", "ee_link", q)
    if ANALYTIC_SOLVERS[name].planar and perturbation == "z":
        T[2, 3] += size
    elif ANALYTIC_SOLVERS[name].planar and perturbation == "tilt":
        T[:3, :3] = T[:3, :3] @ manipkit.spatial.rotations.rot_x(size)
    else:
        perturbation = "none"
    if mode == "position" and ANALYTIC_SOLVERS[name].solves == (SPATIAL_POSE,):
        with pytest.raises(IKOptionError, match="not a position alone"):
            analytic_ik(robot, T, mode=mode)
        return
    result = analytic_ik(robot, T, mode=mode)
    planar_arm = ANALYTIC_SOLVERS[name].planar
    assert result.mode == {(True, "pose"): PLANAR_POSE, (True, "position"): PLANAR_POSITION,
                           (False, "pose"): SPATIAL_POSE, (False, "position"): SPATIAL_POSITION}[planar_arm, mode]
    for row, position, rotation in zip(result.solutions, result.residual_position, result.residual_rotation):
        reached = robot.transform("base_link", "ee_link", row)
        assert np.linalg.norm(reached[:3, 3] - T[:3, 3]) <= TOL and position <= TOL
        if mode == "pose":
            assert np.linalg.norm(reached[:3, :3] - T[:3, :3]) <= 2 * TOL and rotation <= TOL
        else:
            assert rotation == 0.0
    assert_unmet_when_empty(result)
    unmet = dict(result.unmet)
    if perturbation == "z":
        assert unmet["z"] == pytest.approx(size, abs=1e-12)
    elif perturbation == "tilt" and mode == "pose":
        assert unmet["tilt"] == pytest.approx(size, abs=1e-12)
    elif name != "planar_2r" or mode == "position":
        assert result.success  # the target came from FK (a tilt does not matter for a position)
    if result.family_function is not None:
        more = result.members([0.25, -2.0])
        for row in more.solutions:
            assert np.linalg.norm(robot.transform("base_link", "ee_link", row)[:3, 3] - T[:3, 3]) <= TOL


def test_members_of_a_result_that_is_no_family_is_an_error():
    with pytest.raises(ClosedFormIKError, match="not a family"):
        planar.ik_2r(1.0, 1.0, 1.0, 1.0).members([0.0])


def test_a_2r_pose_with_an_elbow_at_the_angle_keeps_that_elbow_only():
    # q = (0, pi/2) with l1 = l2 = 1 puts the tool at (1, 1), heading pi/2; the other elbow, q = (pi/2, -pi/2), heads 0.
    result = planar_modes.ik_2r_pose(1.0, 1.0, math.pi / 2, 1.0, 1.0)
    assert result.labels == ("elbow-down",) and np.allclose(result.solutions, [[0.0, math.pi / 2]], atol=1e-12)


# --------------------------------------------------------------------------
# the HTML table Jupyter shows


def html_rows(markup):
    """(caption, header cells, body rows of cells, paragraphs) of the markup, parsed as XML (so it must be well formed)."""
    import xml.etree.ElementTree as ET

    root = ET.fromstring(f"<div>{markup}</div>")
    table = root.find("table")
    rows = [[cell.text or "" for cell in row] for row in table.findall("tr")]
    return table.find("caption").text, rows[0], rows[1:], [p.text for p in root.findall("p")]


def test_html_repr_lists_every_solution_with_its_residuals(arms):
    robot = arms["stanford_arm"]
    T = robot.transform("base_link", "ee_link", [0.4, 0.8, 0.6, 0.3, 1.0, -0.2])
    result = analytic_ik(robot, T)
    caption, header, rows, notes = html_rows(result._repr_html_())
    assert "decoupled.ik_stanford" in caption and "4 solution(s)" in caption and "success: True" in caption
    assert header == ["#", "label", *robot.joint_names, "position (m)", "rotation (rad)", "success"]
    assert [row[1] for row in rows] == list(result.labels)
    for row, q, position in zip(rows, result.solutions, result.residual_position):
        np.testing.assert_allclose([float(v) for v in row[2:8]], q, rtol=1e-5, atol=1e-6)  # 6 significant digits
        assert float(row[8]) == pytest.approx(position, rel=1e-2, abs=1e-300) and row[10] == "True"
    assert notes == [result.note] and result.reason == ""


def test_html_repr_of_no_solution_shows_the_reason_escaped():
    result = planar_modes.ik_2r_pose(1.0, 0.5, 0.3, 1.0, 1.0)
    caption, _, rows, notes = html_rows(result._repr_html_())
    assert rows == [] and "success: False" in caption and notes == [result.reason] and "orientation" in notes[0]
    odd = IKResult(np.zeros((1, 2)), ("<b>&",), 1, "a < b", np.zeros(1), np.zeros(1))
    markup = odd._repr_html_()
    assert "&lt;b&gt;&amp;" in markup and "<b>" not in markup and html_rows(markup)[3] == ["a < b"]
