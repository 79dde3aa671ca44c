"""manipkit.analysis.reachmap.placement: inverse reachability, checked on cases solved by hand and by construction.

Independent sources: the planar 2R (1, 1) reaches exactly the disc r <= 2
about its base (``closed_form.planar_workspace.workspace_2r``), so the
placements from which it reaches two given points are worked out by hand;
for the mobile manipulator the targets are made by FK from a known
placement, which must then reach (nearly) all of them.
"""

import math

import numpy as np
import pytest

from manipkit.analysis.reachmap import ReachMapError, build
from manipkit.analysis.reachmap.constants import DEFAULT_THRESHOLD
from manipkit.analysis.reachmap.placement import (
    base_placement,
    confirm_placement,
    placement_transforms,
    plot_base_placement,
)
from manipkit.closed_form.planar_workspace import workspace_2r


@pytest.fixture(scope="module")
def map_2r(planar_2r):
    return build(planar_2r, voxel=0.1, orientations=1, samples=40000)


def test_two_points_for_a_2r_on_a_planar_base_by_hand(map_2r):
    # Targets A = (0, 0) and B = (3, 0) on the floor. The 2R (1, 1) reaches r <= 2 about its base, so both are
    # reached from p when |p| <= 2 and |p - B| <= 2: the lens between x = 1 and x = 2 on the x axis. Headings
    # do not matter (one orientation bin, the disc is round). Points kept 0.15 m (1.5 voxels) from the circles.
    assert workspace_2r(1.0, 1.0).reachable == (0.0, 2.0)
    targets = np.tile(np.eye(4), (2, 1, 1))
    targets[1, 0, 3] = 3.0
    xs = np.array([-1.0, 0.5, 1.5, 2.5, 4.0, 6.0])
    found = base_placement(map_2r, targets, xs=xs, ys=[0.0, 1.2], yaws=4)
    # by hand at y = 0: |p| and |p - B| for each x -> (-1: 1, 5) (0.5: 0.5, 2.5) (1.5: 1.5, 1.5) (2.5: 2.5, 0.5)
    # (4: 4, 1) (6: 6, 3); at y = 1.2 only x = 1.5 has both within 2 (1.92 and 1.92, too close to 2: skipped)
    assert found.scores[:, 0, :].tolist() == [[1] * 4, [1] * 4, [2] * 4, [1] * 4, [1] * 4, [0] * 4]
    assert found.scores[[0, 5], 1, :].tolist() == [[1] * 4, [0] * 4]  # (-1, 1.2): |p| = 1.56; (6, 1.2): both > 2
    x, y, _, score = found.best
    assert (x, y, score) == (1.5, 0.0, 2)


def test_a_target_above_the_plane_is_never_reached(map_2r):
    targets = np.tile(np.eye(4), (1, 1, 1))
    targets[0, 2, 3] = 0.5
    assert base_placement(map_2r, targets, xs=[0.5], ys=[0.0], yaws=2).scores.max() == 0


def test_mount_moves_the_map_base_on_the_robot(map_2r):
    # The arm base 1 m ahead of the floor frame (mount x = 1): from the floor frame at the origin facing +x it
    # reaches (2.5, 0) (1.5 from the arm base); facing -x the arm base is at (-1, 0), 3.5 away: not reached.
    targets = np.eye(4)[None].copy()
    targets[0, 0, 3] = 2.5
    mount = np.eye(4)
    mount[0, 3] = 1.0
    found = base_placement(map_2r, targets, xs=[0.0], ys=[0.0], yaws=[0.0, math.pi], mount=mount)
    assert found.scores[0, 0].tolist() == [1, 0]


def test_mobile_manipulator_reaches_targets_made_from_a_known_placement(load_robot, tmp_path):
    robot = load_robot("mobile_manipulator")
    reach_map = build(robot, base="base_footprint", voxel=0.08, orientations=8, samples=150000)
    T_F_P = placement_transforms(2.0, 1.0, math.pi / 2)
    targets = T_F_P @ robot.fk(robot.sample_q(10, seed=4), base="base_footprint", tip="ee_link")
    found = base_placement(reach_map, targets, xs=np.arange(0.0, 4.01, 0.25), ys=np.arange(-1.0, 3.01, 0.25), yaws=4)
    i, j = list(found.xs).index(2.0), list(found.ys).index(1.0)
    k = int(np.argmin(abs(found.yaws - math.pi / 2)))
    assert found.scores[i, j, k] >= 9  # the map holds nearly every FK pose (boundary bins may be unsampled)
    assert found.best[3] >= found.scores[i, j, k]
    assert found.scores[0, 0].max() == 0  # (0, -1) is 2.2 m from every target; the arm reaches under 1 m
    plot_base_placement(found, tmp_path / "placement.png")
    assert (tmp_path / "placement.png").stat().st_size > 10_000


def test_too_many_placements_and_bad_targets_are_errors(map_2r):
    with pytest.raises(ReachMapError, match="coarser step"):
        base_placement(map_2r, np.tile(np.eye(4), (100, 1, 1)), xs=np.arange(1000.0), ys=np.arange(1000.0), yaws=1)
    with pytest.raises(ReachMapError, match=r"shape \(K, 4, 4\)"):
        base_placement(map_2r, np.eye(4))




def test_the_map_estimate_counts_targets_by_the_query_rule_and_says_so(map_2r, planar_2r):
    # 400 targets in the ring 1.8 <= r <= 2.2 about the floor origin, the arm base there (one placement): the 2R
    # (1, 1) reaches exactly r <= 2 (closed form), so a target counted beyond 2 is a false positive. The count with
    # the default threshold is the sum of query(T) (voxel-bin reached and support >= 0.65); threshold 0 is the sum of
    # the plain voxel-bin answers; the first never counts more, and counts fewer targets beyond the reach.
    rng = np.random.default_rng(3)
    r, a = 1.8 + 0.4 * rng.random(400), rng.uniform(-math.pi, math.pi, 400)
    targets = np.tile(np.eye(4), (400, 1, 1))
    targets[:, 0, 3], targets[:, 1, 3] = r * np.cos(a), r * np.sin(a)
    found = base_placement(map_2r, targets, xs=[0.0], ys=[0.0], yaws=[0.0])
    plain = base_placement(map_2r, targets, xs=[0.0], ys=[0.0], yaws=[0.0], threshold=0.0)
    yes, bin_yes = map_2r.query(targets, refine=False), map_2r.query(targets, interpolate=False)
    assert found.threshold == DEFAULT_THRESHOLD and plain.threshold == 0.0
    assert int(found.scores[0, 0, 0]) == int(yes.sum()) and int(plain.scores[0, 0, 0]) == int(bin_yes.sum())
    beyond = r > 2.0
    assert (yes & beyond).sum() < (bin_yes & beyond).sum() and not (yes & ~bin_yes).any()
    assert yes[r < 1.9].all()  # 0.1 m (a voxel) inside the reach: the support there is 1
    chosen = confirm_placement(map_2r, found, planar_2r, candidates=1, restarts=2)
    assert chosen.map_score == int(yes.sum())
    text = chosen.summary()
    assert "the map estimates" in text and "its support is at least 0.65" in text and "voxel-bin was reached" in text
    with pytest.raises(ReachMapError, match="threshold -0.1: give the least support"):
        base_placement(map_2r, targets, xs=[0.0], ys=[0.0], yaws=[0.0], threshold=-0.1)


def test_ik_re_scores_the_maps_best_placements_by_hand(map_2r, planar_2r):
    # The 2R (1, 1) reaches exactly the disc r <= 2 about its base, so from a placement p a target t is reachable
    # iff |t - p| <= 2: the count by hand. Four targets 2.04 m from the origin (0.04 m outside the disc, inside
    # reached 0.1 m voxels) and one 2.036 m out: the map (threshold 0, the plain voxel-bin answer) says yes to all
    # five from the origin, where IK can reach none. Every distance is at least 0.036 m from 2. On this planar arm
    # the tool's z axis is the plane's normal, so "position+axis" asks for the position alone.
    points = np.array([(2.04, 0.0), (-2.04, 0.0), (0.0, 2.04), (0.0, -2.04), (1.44, 1.44)])
    targets = np.tile(np.eye(4), (len(points), 1, 1))
    targets[:, :2, 3] = points
    xs, ys = np.array([-0.3, 0.0, 0.3, 0.6]), np.array([0.0, 0.3])
    found = base_placement(map_2r, targets, xs=xs, ys=ys, yaws=[0.0], threshold=0.0)
    distance = np.hypot(points[:, 0] - xs[:, None, None], points[:, 1] - ys[None, :, None])  # (x, y, target)
    assert np.abs(distance - 2.0).min() > 0.035
    by_hand = (distance <= 2.0).sum(axis=-1)
    assert found.scores[1, 0, 0] == 5 and by_hand[1, 0] == 0  # the map's best placement reaches nothing
    chosen = confirm_placement(map_2r, found, planar_2r, candidates=8, mode="position+axis")
    assert chosen.mode == "position+axis" and chosen.candidates == 8
    for x, y, _, map_count, ik_count in chosen.tried:  # IK's count from every candidate is the count by hand
        i, j = int(np.flatnonzero(np.isclose(xs, x))[0]), int(np.flatnonzero(np.isclose(ys, y))[0])
        assert ik_count == by_hand[i, j] and map_count == found.scores[i, j, 0]
    assert int(chosen.confirmed.sum()) == by_hand.max() == 3
    # the most by hand: (0.3, 0.3) and (0.6, 0.3), both scored 3 by the map; the tie goes to the map's order
    assert (chosen.x, chosen.y) == (0.3, 0.3) and chosen.map_score == 3
    T_B = np.linalg.inv(placement_transforms(chosen.x, chosen.y, chosen.yaw)) @ targets
    for q, target, yes in zip(chosen.q, T_B, chosen.confirmed):  # every confirmed answer lands by FK
        if yes:
            assert np.linalg.norm(planar_2r.transform("base_link", "ee_link", q)[:3, 3] - target[:3, 3]) < 1e-6
    assert chosen.confirmed.tolist() == (distance[2, 1] <= 2.0).tolist()
    assert "IK confirms 3 of 5 targets (position and the direction of the tool's z axis" in chosen.summary()
    assert "the map estimates 3 of 5 from there" in chosen.summary()
    only_the_map = confirm_placement(map_2r, found, planar_2r, candidates=1, mode="position+axis")
    assert (only_the_map.x, only_the_map.y, int(only_the_map.confirmed.sum())) == (0.0, 0.0, 0)


def test_confirm_mode_is_the_full_pose_unless_the_arm_has_fewer_than_6_joints(map_2r, planar_2r):
    from manipkit.analysis.reachmap.placement import confirm_mode

    assert confirm_mode(map_2r, planar_2r) == "pose"  # planar: its pose is its in-plane position and turn
    assert confirm_mode(map_2r, planar_2r, "position+axis") == "position+axis"
    with pytest.raises(ReachMapError, match="mode 'axis': give one of auto, pose, position\\+axis"):
        confirm_mode(map_2r, planar_2r, "axis")
    with pytest.raises(ReachMapError, match="candidates 0: give a whole number from 1 to 1000"):
        confirm_placement(map_2r, base_placement(map_2r, np.eye(4)[None], xs=[0.0], ys=[0.0], yaws=[0.0]),
                          planar_2r, candidates=0)


def test_a_6r_arm_is_confirmed_on_the_full_pose_by_its_closed_form(load_robot):
    # ur5: 6 joints, so IK matches the full pose, through the dispatcher's closed form (8 branches per target); the
    # answer kept per target is the first branch within tol, and it must land on the target by FK
    from manipkit.ik.numerical_many import ik_many

    ur5 = load_robot("ur5")
    reach_map = build(ur5, base="base_link", voxel=0.1, orientations=50, samples=200_000)
    targets = placement_transforms(0.4, 0.2, 0.3) @ ur5.fk(ur5.sample_q(6, seed=2), base="base_link", tip="ee_link")
    found = base_placement(reach_map, targets, yaws=8)
    chosen = confirm_placement(reach_map, found, ur5, candidates=5)
    assert chosen.mode == "pose" and chosen.pose_confirmed is None and chosen.candidates == 5
    T_B = np.linalg.inv(placement_transforms(chosen.x, chosen.y, chosen.yaw)) @ targets
    for q, target in zip(chosen.q[chosen.confirmed], T_B[chosen.confirmed]):
        reached = ur5.transform("base_link", "ee_link", q)
        assert np.linalg.norm(reached[:3, 3] - target[:3, 3]) < 1e-6
        assert np.abs(reached[:3, :3] - target[:3, :3]).max() < 1e-6
    independent = ik_many(ur5, T_B, "base_link", "ee_link", mode="pose", tol=1e-6, restarts=100, seed=11)
    assert int(chosen.confirmed.sum()) == int(independent.success.sum()) == int(chosen.tried[:, 4].max())
    assert int(chosen.confirmed.sum()) >= 5  # a 6R arm reaches full poses from placements off the true one
    assert "IK confirms" in chosen.summary() and "(full pose, by FK;" in chosen.summary()
