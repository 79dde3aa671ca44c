"""Where to put the part (manipkit.analysis.reachmap.pathplace, ``manipkit path --place``) on a hand case.

The case (the UR5 of example-robot-data, base_link -> tool0): at Q_EXTENDED the shoulder lift and the elbow are
0, so the upper arm and the forearm lie straight along one horizontal direction u of the base, and the points on
joint axes 2 and 4 are a2 + a3 = 0.81725 m apart (the reach of the planar 2R of joints 2 and 3). A straight line
of the tool along u, orientation fixed, at s = -0.045 + 0.01 k (k = 0..9) from that pose, puts the wrist
a2 + a3 + s from axis 2: it is reachable for s <= 0 only. Moved by dx along u the line is reachable at every
waypoint iff 0.045 + dx <= 0, i.e. dx <= -0.045 (the shift keeps the wrist in the arm's plane: u is
perpendicular to axis 2). On the grid dx = -0.1, -0.08, ..., 0.04 the feasible offsets are -0.1, -0.08, -0.06.
"""

from __future__ import annotations

import json
import shlex

import numpy as np
import pytest
from cli_helper import run_cli

import manipkit
from manipkit.analysis.reachmap.pathplace import offset_grid, place_path, shifted_poses
from manipkit.app.cli import main
from manipkit.app.cli.path_place import full_option
from manipkit.errors import ReachMapError
from manipkit.paths.plan import plan_path
from manipkit.spatial.rotations import rpy_from_matrix
from manipkit.spatial.transforms import pose_residuals

Q_EXTENDED = np.array([0.0, 0.0, 0.0, -np.pi / 2, np.pi / 2, 0.0])
S = -0.045 + 0.01 * np.arange(10)
REACH = 0.425 + 0.39225  # a2 + a3 (m)


@pytest.fixture(scope="module")
def case():
    robot = manipkit.load("ur5")
    chain = robot.chain("base_link", "tool0")
    T2 = robot.transform("base_link", "upper_arm_link", Q_EXTENDED)
    T4 = robot.transform("base_link", "wrist_1_link", Q_EXTENDED)
    axis = T2[:3, :3] @ chain.joints[1].axis
    v = T4[:3, 3] - T2[:3, 3]
    v -= (v @ axis) * axis
    assert np.linalg.norm(v) == pytest.approx(REACH, abs=1e-9)
    u = v / np.linalg.norm(v)
    k = int(np.argmax(np.abs(u)))
    assert abs(u[k]) == pytest.approx(1.0, abs=1e-12) and abs(u @ axis) < 1e-12  # u is a base axis, x or y
    T = chain.fk(Q_EXTENDED)
    poses = np.repeat(T[None], len(S), axis=0)
    poses[:, :3, 3] += S[:, None] * u
    return robot, chain, poses, k, float(np.sign(u[k]))


def grid_along(k, sign):
    """Offsets d = -0.1 + 0.02 j (j = 0..7) along u, written as a range on base axis k."""
    spec = sorted((sign * -0.1, sign * 0.04))
    ranges = [None, None]
    ranges[k] = (spec[0], spec[1], 0.02)
    return ranges


def test_feasible_region_is_the_derived_bound_and_the_best_plan_checks_out(case):
    robot, chain, poses, k, sign = case
    offsets = offset_grid(*grid_along(k, sign))
    assert len(offsets) == 8
    result = place_path(robot, poses, base="base_link", tip="tool0", offsets=offsets)
    along = sign * offsets[:, k]  # the shift along u
    assert np.array_equal(result.feasible, along + S.max() <= 0)  # dx <= -0.045: -0.1, -0.08, -0.06
    assert result.feasible.sum() == 3
    best = result.best
    assert best is not None and result.feasible[best]
    costs = result.cost[result.feasible]
    assert result.cost[best] == costs.min()
    # independent: plan the shifted poses directly and check every waypoint by FK
    shifted = shifted_poses(poses, offsets[best])
    plan = plan_path(chain, shifted)
    assert plan.feasible and plan.cost == pytest.approx(result.cost[best], abs=1e-12)
    position, rotation = pose_residuals(shifted, chain.fk(plan.q))
    assert position.max() <= 1e-9 and rotation.max() <= 1e-9
    # and every infeasible candidate fails where the reach says: the first waypoint with a2 + a3 + s + d > a2 + a3
    for i in np.flatnonzero(~result.feasible):
        assert result.first_failure[i] == int(np.argmax(S + along[i] > 0))


def _planned(case, workers):
    """place_path of the case on every other offset of the grid (4 candidates, one per block on 2 workers or here)
    with ``workers``: (the answer, the progress calls it made)."""
    robot, _, poses, k, sign = case
    offsets = offset_grid(*grid_along(k, sign))[::2]
    calls: list = []
    result = place_path(robot, poses, base="base_link", tip="tool0", offsets=offsets, workers=workers,
                        progress=lambda stage, done, total: calls.append((stage, done, total)))
    return result, calls


@pytest.fixture(scope="module")
def on_two_workers(case):
    """:func:`_planned` on a LocalCluster of 2 workers: one cluster for the progress test and the 1-or-2 test."""
    return _planned(case, 2)


def test_progress_counts_every_planned_candidate(case, on_two_workers):
    # one call before the first and one after each planned candidate, here and on a cluster alike
    for result, calls in (_planned(case, None), on_two_workers):
        assert calls == [("candidates planned", done, len(result.offsets)) for done in range(len(result.offsets) + 1)]


def test_one_and_two_workers_give_the_same_answer(case, on_two_workers):
    here, _ = _planned(case, 1)
    two, _ = on_two_workers
    assert here.as_dict() == two.as_dict()
    assert here.feasible.any() and not here.feasible.all()


def test_cli_reports_the_region_and_the_printed_command_plans_the_best(case, capsys):
    _, chain, poses, k, sign = case
    start, end = poses[0], poses[-1]
    line = [*start[:3, 3], *rpy_from_matrix(start[:3, :3]), *end[:3, 3], *rpy_from_matrix(end[:3, :3])]
    axis = "xy"[k]
    low, high, step = grid_along(k, sign)[k]
    argv = ["path", "--robot", "ur5", "--tip", "tool0", "--line", *(f"{v:.15f}" for v in line), "--step", "0.01",
            "--place", f"--place-{axis}", *(f"{v:.15f}" for v in (low, high, step)), "--format", "json"]
    assert main(argv) == 0
    answer = json.loads(capsys.readouterr().out)
    assert answer["candidates"] == 8 and answer["feasible"] == 3
    bound = answer["region"][axis]
    assert sign * min(bound, key=lambda v: -sign * v) == pytest.approx(-0.06, abs=1e-12)
    words = shlex.split(answer["command"])
    assert words[0] == "manipkit" and "--place" not in words and "--offset" in words
    assert main(words[1:]) == 0
    plan = json.loads(capsys.readouterr().out)
    assert plan["feasible"] and plan["cost"] == pytest.approx(answer["best"]["cost"], abs=1e-9)
    assert np.asarray(plan["q"]).shape == (len(poses), 6)


@pytest.mark.parametrize("ranges, words", [
    (((0.0, 1.0, 0.0), None, None, None), "step 0"),
    (((0.0, 1e3, 1e-3), (0.0, 1e3, 1e-3), None, None), "more than 100000"),
    (((1.0, 0.0, 0.1), None, None, None), "the range is empty"),
])
def test_bad_grids_are_one_line_errors(ranges, words):
    with pytest.raises(ReachMapError, match=words):
        offset_grid(*ranges)


class HalfSpaceMap:
    """A stand-in reach map of tool0 in base_link that says yes to a pose iff its position along u is at most
    ``bound`` (m): the screen's rule is tested on its own, apart from any map's resolution."""

    base, frame = "base_link", "tool0"

    def __init__(self, u, bound):
        self.u, self.bound = np.asarray(u, dtype=float), bound

    def query(self, T, *, threshold):
        return np.asarray(T)[..., :3, 3] @ self.u <= self.bound


def test_the_reach_map_screen_drops_candidates_below_the_share(case):
    robot, chain, poses, k, sign = case
    offsets = offset_grid(*grid_along(k, sign))
    u = np.zeros(3)
    u[k] = sign
    along = sign * offsets[:, k]
    top = float((poses[:, :3, 3] @ u).max())
    yes_map = HalfSpaceMap(u, top - 0.07)  # every waypoint yes only for shifts d <= -0.07: -0.1 and -0.08
    result = place_path(robot, poses, base="base_link", tip="tool0", offsets=offsets, reach_map=yes_map, share=1.0)
    counts = [(shifted_poses(poses, o)[:, :3, 3] @ u <= top - 0.07).sum() for o in offsets]
    assert result.screened.tolist() == counts
    assert np.array_equal(result.planned, along <= -0.07 + 1e-12)
    assert np.array_equal(result.feasible, result.planned)  # both kept ones lie inside the derived bound
    assert result.as_dict()["screened_out"] == 6
    with pytest.raises(ReachMapError, match="the reach map is of tool0 in base_link"):
        place_path(robot, poses, base="base_link", tip="ee_link", offsets=offsets, reach_map=yes_map)


def _line_words(poses) -> list[str]:
    """``--line`` of the case's first and last pose (X Y Z R P Y each, rad), written to 1e-15."""
    start, end = poses[0], poses[-1]
    values = [*start[:3, 3], *rpy_from_matrix(start[:3, :3]), *end[:3, 3], *rpy_from_matrix(end[:3, :3])]
    return ["--line", *(f"{v:.15f}" for v in values)]


def test_cli_workers_give_the_same_printed_answer_as_here(case):
    """``--place --workers 2`` from the command line on a real LocalCluster: the same printed lines as without.

    The run with ``--workers 2`` is a subprocess with a timeout because a hang is the point: a review saw this
    command start its cluster and print nothing in minutes. The cause was not the cluster: the grid it ran holds
    offsets whose untimed plan re-solves its ladder thousands of times (minutes in a worker as here); this grid's 8
    plan in seconds. The run without (the reference, no cluster) runs in this process (tests/cli_helper.py)."""
    import os
    import subprocess
    import sys

    _, _, poses, k, sign = case
    low, high, step = grid_along(k, sign)[k]
    words = ["path", "--robot", "ur5", "--tip", "tool0", *_line_words(poses), "--step", "0.01", "--place",
             f"--place-{'xy'[k]}", *(f"{v:.15f}" for v in (low, high, step))]
    env = {**os.environ, "MANIPKIT_COMPILE_NOTE": "0"}
    runs = [run_cli("manipkit", *words, env={"MANIPKIT_COMPILE_NOTE": "0"}),
            subprocess.run([sys.executable, "-m", "manipkit.app.cli", *words, "--workers", "2"], capture_output=True,
                           text=True, timeout=600, env=env, stdin=subprocess.DEVNULL)]
    for run in runs:
        assert run.returncode == 0, run.stderr
    here, two = (run.stdout for run in runs)
    assert here == two
    assert "planned: 8; feasible: 3" in here and "plan it: manipkit path" in here


def test_the_printed_command_spells_out_abbreviated_options(case, capsys):
    """argparse takes ``--place-ya`` for ``--place-yaw`` and ``--ti`` for ``--tip``: the printed command drops the
    first with the search options and names the second whole, and it plans the best offset at the same cost."""
    _, _, poses, k, sign = case
    low, high, step = grid_along(k, sign)[k]
    argv = ["path", "--robot", "ur5", "--ti", "tool0", *_line_words(poses), "--step", "0.01", "--place",
            f"--place-{'xy'[k]}", *(f"{v:.15f}" for v in (low, high, step)), "--place-ya", "0", "0", "0.1",
            "--format", "json"]
    assert main(argv) == 0
    answer = json.loads(capsys.readouterr().out)
    assert answer["feasible"] == 3
    words = shlex.split(answer["command"])
    assert "--place-ya" not in words and "--ti" not in words and words[words.index("--tip") + 1] == "tool0"
    assert main(words[1:]) == 0
    plan = json.loads(capsys.readouterr().out)
    assert plan["feasible"] and plan["cost"] == pytest.approx(answer["best"]["cost"], abs=1e-12)


@pytest.mark.parametrize("word, full", [("--reach-m=maps/ur5", "--reach-map=maps/ur5"), ("--reach-m", "--reach-map"),
                                        ("--place-x", "--place-x"), ("-0.3", "-0.3"), ("--pla", "--pla")])
def test_full_option_spells_out_a_unique_prefix_only(word, full):
    names = {"--place", "--place-x", "--place-yaw", "--reach-map", "--reach-share"}
    assert full_option(word, names) == full


def test_yaw_about_the_base_z_changes_only_the_first_joint(case):
    """Yaw offsets (about base z, the UR5's first joint axis): ``Rz(yaw) @ T`` is reached by the same joints with
    q1 + yaw (FK of the first joint composes with Rz(yaw); q1 has range 4 pi, so an alias stays in limits), so
    at every yaw the plan is feasible exactly when it is at yaw 0, at the same cost (the summed |dq| of q1 + yaw
    is that of q1; equal-cost branches may swap), and an infeasible line fails at the same waypoint. Moved in by 0.08 along u the line is
    feasible (0.045 - 0.08 < 0); as it is, waypoint 5 (s = 0.005 > 0) is the first out of reach."""
    robot, chain, poses, k, sign = case
    u = np.zeros(3)
    u[k] = sign
    inside = poses.copy()
    inside[:, :3, 3] -= 0.08 * u
    offsets = offset_grid(yaw=(-3.0, 3.0, 1.0))
    assert len(offsets) == 7
    feasible = place_path(robot, inside, base="base_link", tip="tool0", offsets=offsets)
    assert feasible.feasible.all()
    assert np.allclose(feasible.cost, feasible.cost[0], rtol=0, atol=1e-9)
    plan0 = plan_path(chain, inside)
    for yaw in offsets[:, 3]:  # the yaw-0 plan with q1 + yaw follows the turned path (FK, independent of the search)
        q = plan0.q.copy()
        q[:, 0] += yaw
        position, rotation = pose_residuals(shifted_poses(inside, (0, 0, 0, yaw)), chain.fk(q))
        assert position.max() <= 1e-9 and rotation.max() <= 1e-9
    out = place_path(robot, poses, base="base_link", tip="tool0", offsets=offsets)
    assert not out.feasible.any()
    assert out.first_failure.tolist() == [5] * 7 == [int(np.argmax(S > 0))] * 7


def test_cli_place_yaw_in_degrees(case, capsys):
    """``--deg --place-yaw 0 90 45`` on the line moved in by 0.08 along u (feasible at every yaw, previous test):
    the feasible offsets' yaws are 0, pi/4, pi/2 rad, at one cost."""
    _, _, poses, k, sign = case
    inside = poses.copy()
    inside[:, k, 3] -= 0.08 * sign
    line = _line_words(inside)
    line[4:7] = [f"{np.degrees(float(v)):.15f}" for v in line[4:7]]  # --deg: the R P Y of --line in degrees too
    line[10:13] = [f"{np.degrees(float(v)):.15f}" for v in line[10:13]]
    argv = ["path", "--robot", "ur5", "--tip", "tool0", *line, "--step", "0.01", "--place", "--deg",
            "--place-yaw", "0", "90", "45", "--format", "json"]
    assert main(argv) == 0
    answer = json.loads(capsys.readouterr().out)
    assert answer["candidates"] == 3 and answer["feasible"] == 3
    rows = np.array(answer["feasible_offsets"])
    assert np.allclose(rows[:, 3], [0.0, np.pi / 4, np.pi / 2], rtol=0, atol=1e-12)
    assert np.allclose(rows[:, 4], rows[0, 4], rtol=0, atol=1e-9)


def test_cli_screens_with_a_saved_reach_map(case, tmp_path, capsys):
    """A real map (``manipkit reachmap --tip tool0`` at 0.1 m, 20 directions, 200000 FK samples) screens the line
    moved along u by d = -0.2 .. 1.0 every 0.1. A bound by hand: consecutive link origins of the chain are a
    fixed distance apart (each joint turns about an axis through its child's origin), so tool0 is never farther
    from the base origin than L, the sum of those distances; a yes needs a reached voxel centre within one voxel
    on each axis of the position (0.173 m), and a reached voxel's centre is within half a diagonal (0.087 m) of a
    sample: so an offset whose waypoints all lie farther than L + 0.26 m is dropped. The screen only drops (the
    feasible offsets are among the unscreened search's, d <= -0.045), and the count printed is that of the
    loaded map's own query."""
    from manipkit.analysis.reachmap.map import load

    robot, _, poses, k, sign = case
    links = ["base_link", "shoulder_link", "upper_arm_link", "forearm_link", "wrist_1_link", "wrist_2_link",
             "wrist_3_link", "tool0"]
    L = sum(np.linalg.norm(robot.transform(a, b, Q_EXTENDED)[:3, 3]) for a, b in zip(links, links[1:]))
    folder = tmp_path / "ur5_tool0"
    assert main(["reachmap", "--robot", "ur5", "--tip", "tool0", "--voxel", "0.1", "--orientations", "20",
                 "--samples", "200000", "--method", "fk", "-o", str(folder)]) == 0
    capsys.readouterr()
    spec = sorted((sign * -0.2, sign * 1.0))
    argv = ["path", "--robot", "ur5", "--tip", "tool0", *_line_words(poses), "--step", "0.01", "--place",
            f"--place-{'xy'[k]}", f"{spec[0]:.15f}", f"{spec[1]:.15f}", "0.1", "--reach-map", str(folder),
            "--format", "json"]
    status = main(argv)
    answer = json.loads(capsys.readouterr().out)
    offsets = offset_grid(*[(spec[0], spec[1], 0.1) if i == k else None for i in range(2)])
    along = sign * offsets[:, k]
    reach_map = load(str(folder))
    counts = np.array([reach_map.query(shifted_poses(poses, o), threshold=0.65).sum() for o in offsets])
    kept = counts >= len(poses)
    assert answer["candidates"] == 13 and answer["screened_out"] == int((~kept).sum())
    nearest = np.array([np.linalg.norm(shifted_poses(poses, o)[:, :3, 3], axis=1).min() for o in offsets])
    far = nearest > L + 0.26
    assert far.any() and not kept[far].any()
    unscreened = place_path(robot, poses, base="base_link", tip="tool0", offsets=offsets)
    assert np.array_equal(unscreened.feasible, along <= -0.045)
    listed = {round(row[k], 9) for row in answer["feasible_offsets"]}
    assert listed <= {round(v, 9) for v in offsets[unscreened.feasible, k]}
    assert status == (0 if listed else 1)
