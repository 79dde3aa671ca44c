"""``manipkit path`` --retime, --arc, --plot and --map (run in process): what they print, write and refuse.

The trajectory is checked by finite differences against the URDF's limits (read from its XML) and by Pinocchio's
FK against the requested tool speed; the arc's waypoints against the circle derived by hand in the test.
"""

from __future__ import annotations

import json
import math
import xml.etree.ElementTree as ET

import numpy as np
import pytest
from cli_helper import run_cli
from test_paths_retime import pinocchio_tip_positions

import manipkit

LINE = ["--line", "0.4", "0.1", "0.4", "3.14159", "0", "0", "0.5", "0.1", "0.4", "3.14159", "0", "0", "--step", "0.01"]
UR5 = ["manipkit", "path", "--robot", "ur5", "--tip", "tool0"]
SLACK = 1e-3


@pytest.fixture(scope="module")
def ur5():
    robot = manipkit.load("ur5")
    root = ET.parse(robot.source.path).getroot()
    limits = {j.get("name"): float(j.find("limit").get("velocity")) for j in root.iter("joint") if j.find("limit") is not None}
    chain = robot.chain("base_link", "tool0")
    return robot, chain, np.array([limits[name] for name in chain.joint_names])


# --------------------------------------------------------------------------
# --retime


def test_retime_json_trajectory_keeps_the_limits_the_waypoints_and_the_tool_speed(ur5):
    robot, chain, vmax = ur5
    result = run_cli(*UR5, *LINE, "--speed", "0.05", "--retime", "--acceleration-scale", "0.5", "--format", "json")
    assert result.returncode == 0, result.stderr
    answer = json.loads(result.stdout)
    motion = answer["trajectory"]
    t, q, qd, qdd = (np.array(motion[k]) for k in ("t", "q", "qd", "qdd"))
    assert q.shape == qd.shape == qdd.shape == (len(t), 6)
    h = np.diff(t)
    velocity = np.diff(q, axis=0) / h[:, None]
    acceleration = 2.0 * np.diff(velocity, axis=0) / (h[1:] + h[:-1])[:, None]
    assert (np.abs(velocity) <= vmax * (1 + SLACK)).all()
    assert (np.abs(acceleration) <= 0.5 * vmax / 0.5 * (1 + SLACK)).all()  # --acceleration-scale 0.5 of v / 0.5 s
    # every waypoint of the plan, in order, at its stated time
    index = np.searchsorted(t, motion["waypoint_times"])
    assert (np.diff(index) > 0).all()
    np.testing.assert_array_equal(q[index], np.array(answer["q"]))
    tool = np.linalg.norm(np.diff(pinocchio_tip_positions(robot, q), axis=0), axis=1) / h
    assert 0.99 * 0.05 <= tool.max() <= 0.05 * (1 + SLACK)
    assert motion["duration"] == pytest.approx(t[-1]) and motion["duration"] >= 0.1 / 0.05
    assert {s["limit"] for s in motion["slowdowns"]} >= {"tool speed"}


def test_retime_text_and_csv(tmp_path, ur5):
    _, chain, _ = ur5
    out = tmp_path / "motion.csv"
    result = run_cli(*UR5, *LINE, "--speed", "0.1", "--retime", "-o", str(out))
    assert result.returncode == 0, result.stderr
    text = result.stdout
    assert "RETIMED (TOPP-RA): " in text and " s through 11 waypoints in order, rest to rest" in text
    assert ("  limits: 1 x each joint's URDF velocity limit v; acceleration 1 x v / 0.5 s (the URDF gives none); "
            "tool at most 0.1 m/s") in text
    assert "where it slows down (12 (segment, limit) pair(s) bind, over 10 of 10 segment(s)):" in text
    # the tool speed binds all along but where the arm speeds up and brakes (the acceleration limits, first and last)
    assert "    the tool speed limit binds on waypoints 0-10 for " in text
    assert "    shoulder_lift_joint's acceleration limit binds on waypoints 0-1 for " in text
    assert f"trajectory (t, q, qd, qdd) written to {out}" in text
    rows = out.read_text().splitlines()
    head = rows[0].split(",")
    names = list(chain.joint_names)
    assert head == (["t[s]"] + [f"q.{n}[rad]" for n in names] + [f"qd.{n}[rad/s]" for n in names]
                    + [f"qdd.{n}[rad/s^2]" for n in names])
    table = np.array([[float(v) for v in row.split(",")] for row in rows[1:]])
    motion = json.loads(run_cli(*UR5, *LINE, "--speed", "0.1", "--retime", "--format", "json").stdout)["trajectory"]
    np.testing.assert_array_equal(table[:, 0], motion["t"])
    np.testing.assert_array_equal(table[:, 1:7], motion["q"])
    np.testing.assert_array_equal(table[:, 13:], motion["qdd"])
    duration = float(text.split("RETIMED (TOPP-RA): ")[1].split(" s ")[0])
    assert duration == pytest.approx(motion["duration"], rel=1e-5)


def test_without_retime_json_has_no_trajectory():
    answer = json.loads(run_cli(*UR5, *LINE, "--speed", "0.1", "--format", "json").stdout)
    assert "trajectory" not in answer


# --------------------------------------------------------------------------
# --arc

ARC = ["--arc", "0.4", "0.1", "0.4", "3.14159", "0", "0", "0.5", "0.2", "0.4", "3.14159", "0", "0",
       "0.6", "0.1", "0.4", "3.14159", "0", "0", "--step", "0.01"]


def test_arc_waypoints_lie_on_the_circle_derived_by_hand(ur5):
    # (0.4, 0.1), (0.5, 0.2), (0.6, 0.1) at z = 0.4: equidistant 0.1 m from (0.5, 0.1), so that is the centre and
    # 0.1 m the radius; start at angle pi, via at pi/2, end at 0 (about +z, clockwise from above). Each quarter is
    # 0.1 pi / 2 = 0.157 m long: 16 arcs of at most 0.01 m, 33 waypoints, the via the 17th (index 16).
    _, chain, _ = ur5
    result = run_cli(*UR5, *ARC, "--speed", "0.1", "--format", "json")
    assert result.returncode == 0, result.stderr
    answer = json.loads(result.stdout)
    q = np.array(answer["q"])
    assert q.shape == (33, 6)
    T = chain.fk(q)
    p = T[:, :3, 3]
    np.testing.assert_allclose(np.linalg.norm(p[:, :2] - [0.5, 0.1], axis=1), 0.1, atol=1e-9)
    np.testing.assert_allclose(p[:, 2], 0.4, atol=1e-9)
    angle = np.arctan2(p[:, 1] - 0.1, p[:, 0] - 0.5)
    np.testing.assert_allclose(angle, np.pi - np.arange(33) * (np.pi / 32), atol=1e-9)
    np.testing.assert_allclose(p[16], [0.5, 0.2, 0.4], atol=1e-9)
    # one orientation all along (the three poses share it): rpy (3.14159, 0, 0), tool z down (R_x(a) e_z = (0, -sin a, cos a))
    np.testing.assert_allclose(T[:, :3, 2], np.broadcast_to([0, -math.sin(3.14159), math.cos(3.14159)], (33, 3)),
                               atol=1e-9)
    # times: 0.1 pi / 32 m between waypoints at 0.1 m/s, along the chord's length
    chord = 2 * 0.1 * math.sin(np.pi / 64)
    np.testing.assert_allclose(np.diff(answer["t"]), chord / 0.1, rtol=1e-9)


# --------------------------------------------------------------------------
# --plot and --map: PNG files, and the map's data (stored in the PNG) against the report

PNG = b"\x89PNG\r\n\x1a\n"
OUT_OF_REACH = ["--line", "0.5", "0.1", "0.4", "3.14159", "0", "0", "1.0", "0.1", "0.4", "3.14159", "0", "0",
                "--step", "0.05", "--speed", "0.1", "--free-axis", "x", "--free-step", "30deg"]


def map_data(path):
    from PIL import Image

    from manipkit.app.path_plots import MAP_KEY

    with Image.open(path) as image:
        assert image.format == "PNG" and image.size[0] > 300
        return json.loads(image.text[MAP_KEY])


def test_the_map_of_a_line_out_of_reach_matches_the_report(tmp_path):
    # 0.5 m to 1.0 m out along x at 5 cm: the UR5 (about 0.95 m from shoulder to tool0 stretched) loses the line
    chart, plot = tmp_path / "map.png", tmp_path / "joints.png"
    result = run_cli(*UR5, *OUT_OF_REACH, "--map", str(chart), "--plot", str(plot), "--format", "json")
    assert result.returncode == 1
    answer = json.loads(result.stdout)
    assert chart.read_bytes()[:8] == PNG and not plot.exists()  # no joint path: no joint plot
    data = map_data(chart)
    kinds, cells = data["kinds"], np.array(data["cells"])
    assert data["angles_deg"] == pytest.approx(-180 + 30 * np.arange(12))
    assert cells.shape == (11, 12)
    for i, records in enumerate(answer["failures"]):
        unreachable = sum(r["count"] for r in records if r["kind"] == "unreachable")
        assert (cells[i] == kinds.index("unreachable")).sum() == unreachable
    alive = (cells >= kinds.index("reached")).any(axis=1)
    first = answer["first_failure"]
    assert first is not None and alive[:first].all() and not alive[first:].any()


def test_a_feasible_map_marks_the_chosen_tool_angle_and_the_joint_plot_is_a_png(tmp_path):
    chart, plot = tmp_path / "map.png", tmp_path / "joints.png"
    args = [*LINE, "--speed", "0.1", "--free-axis", "z", "--free-step", "45deg"]
    result = run_cli(*UR5, *args, "--retime", "--map", str(chart), "--plot", str(plot))
    assert result.returncode == 0, result.stderr
    assert f"joint plot written to {plot}" in result.stdout and f"feasibility map written to {chart}" in result.stdout
    assert plot.read_bytes()[:8] == PNG and chart.read_bytes()[:8] == PNG
    data = map_data(chart)
    cells = np.array(data["cells"])
    chosen = cells == data["kinds"].index("chosen")
    assert (chosen.sum(axis=1) == 1).all()
    chain = manipkit.load("ur5").chain("base_link", "tool0")
    from manipkit.paths import line_poses, plan_path
    from manipkit.spatial.transforms import transform_from_xyz_rpy

    poses = line_poses(transform_from_xyz_rpy([0.4, 0.1, 0.4], [3.14159, 0, 0]),
                       transform_from_xyz_rpy([0.5, 0.1, 0.4], [3.14159, 0, 0]), step=0.01)
    plan = plan_path(chain, poses, speed=0.1, free_axis="z", free_step=math.radians(45))
    angles = np.array(data["angles_deg"])[np.argmax(chosen, axis=1)]
    np.testing.assert_allclose(angles, np.degrees(plan.tool_angles), atol=1e-9)
    np.testing.assert_array_equal(cells, plan.feasibility)


# --------------------------------------------------------------------------
# bad input: one line, exit 2


@pytest.mark.parametrize("extra, message", [
    (["--retime"], "--retime needs --speed M/S"),
    (["--speed", "0.1", "--acceleration-scale", "2"], "--acceleration-scale applies with --retime"),
    (["--speed", "0.1", "--retime", "--acceleration-scale", "0"], "--acceleration-scale 0: give a positive factor"),
    (["--speed", "0.1", "--retime", "--reconfigure"], "--retime with --reconfigure"),
    (["--map", "m.png"], "--map draws waypoint x tool angle: give --free-axis x|y|z"),
    (["--plot", "joints.svg"], "--plot joints.svg: give a .png file name"),
    (["--plot", "same.png", "--map", "same.png", "--free-axis", "z"], "--plot same.png and --map same.png name the same file"),
])
def test_bad_new_options_are_one_line(extra, message):
    result = run_cli(*UR5, *LINE, *extra)
    assert result.returncode == 2
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1 and message in lines[0], result.stderr


@pytest.mark.parametrize("arc, message", [
    ("0.4 0.1 0.4 3.14159 0 0 0.5 0.1 0.4 3.14159 0 0 0.6 0.1 0.4 3.14159 0 0", "the three positions are collinear"),
    ("0.4 0.1 0.4 3.14159 0 0 0.5 0.2 0.4 3.14159 0 0 0.6 0.1 nan 3.14159 0 0", "--arc: give 18 finite numbers"),
])
def test_bad_arcs_are_one_line(arc, message):
    result = run_cli(*UR5, "--arc", *arc.split(), "--step", "0.01")
    assert result.returncode == 2
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1 and message in lines[0], result.stderr


def test_an_arc_needs_a_step():
    result = run_cli(*UR5, *ARC[:-2])
    assert result.returncode == 2 and "--arc needs --step M" in result.stderr


@pytest.mark.parametrize("extra, message", [
    (["--step", "0"], "step 0: give a length in metres"),
    (["--step", "0.01", "--plot", "/nonexistent/x.png"], "cannot write /nonexistent/x.png: no such folder"),
    (["--step", "0.01", "--speed", "0", "--retime"], "--speed 0: give a speed in m/s from 1e-09 to 1e+06"),
    (["--step", "0.01", "--speed", "0.1", "--retime", "--acceleration-scale", "nan"], "--acceleration-scale nan"),
])
def test_more_bad_input_on_an_arc_is_one_line(extra, message):
    result = run_cli(*UR5, *ARC[:-2], *extra)
    assert result.returncode == 2
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1 and message in lines[0], result.stderr


def test_retiming_a_single_waypoint_is_one_line():
    point = ["0.4", "0.1", "0.4", "3.14159", "0", "0"]
    result = run_cli(*UR5, "--line", *point, *point, "--step", "0.01", "--speed", "0.1", "--retime")
    assert result.returncode == 2
    assert result.stderr.strip() == "manipkit: error: the path has one waypoint: there is no motion to retime"
