"""IK that respects the arm's body: ``ik(..., collision_free=)``, ``mark_collisions`` and ``manipkit ik --collision-free``.

Every collision-free answer is checked here by a geometry model built in the
test with Pinocchio and coal alone; a target reachable only through the arm's
own base is refused with the pair named.
"""

import json
import math

import coal
import numpy as np
import pinocchio as pin
import pytest
from cli_helper import run_cli

import manipkit
from manipkit.ik.collision_marks import mark_collisions
from manipkit.ik.numerical import ik
from manipkit.ik.textbook import analytic_ik
from manipkit.kinematics.collisions import CollisionChecker
from manipkit.kinematics.robot import Robot

# A block (0.4 x 0.4 x 0.1, top at z = 0.1), a post on it up to z = 0.3 (beside the turning axis), and a rod turning
# about y at (0, 0, 0.3), 0.4 m long with the tool at its end. base_link and rod are not adjacent (the post is
# between them). Tool at q: (0.4 sin q, 0, 0.3 + 0.4 cos q); straight down (q = pi) the rod goes into the block.
ROD = """<?xml version="1.0"?>
<robot name="rod_on_block">
  <link name="base_link">
    <collision><origin xyz="0 0 0.05"/><geometry><box size="0.4 0.4 0.1"/></geometry></collision>
  </link>
  <link name="post">
    <collision><origin xyz="0 -0.05 0.1"/><geometry><box size="0.02 0.02 0.2"/></geometry></collision>
  </link>
  <link name="rod">
    <collision><origin xyz="0 0 0.2"/><geometry><box size="0.04 0.04 0.4"/></geometry></collision>
  </link>
  <link name="tool"/>
  <joint name="mount" type="fixed"><parent link="base_link"/><child link="post"/><origin xyz="0 0 0.1"/></joint>
  <joint name="turn" type="revolute">
    <parent link="post"/><child link="rod"/><origin xyz="0 0 0.2"/><axis xyz="0 1 0"/>
    <limit lower="-3.2" upper="3.2" effort="1" velocity="1"/>
  </joint>
  <joint name="tip" type="fixed"><parent link="rod"/><child link="tool"/><origin xyz="0 0 0.4"/></joint>
</robot>
"""


@pytest.fixture(scope="module")
def rod():
    return Robot.from_urdf(ROD)


@pytest.fixture(scope="module")
def panda():
    return manipkit.load("panda")


def target_at(xyz) -> np.ndarray:
    T = np.eye(4)
    T[:3, 3] = xyz
    return T


def test_a_target_reached_only_through_the_base_is_refused_with_the_pair_named(rod):
    down = target_at([0, 0, -0.1])
    plain = ik(rod, down, "base_link", "tool", mode="position")
    assert plain.success and abs(abs(plain.q[0]) - math.pi) < 1e-6  # without collisions: straight down
    refused = ik(rod, down, "base_link", "tool", mode="position", collision_free=True)
    assert not refused.success
    assert refused.reason.startswith("every answer found is in collision (")
    assert "the first: base_link - rod (penetration " in refused.reason
    assert abs(abs(refused.closest[0]) - math.pi) < 1e-6


def test_a_free_target_is_solved_with_its_clearance(rod):
    # Horizontal (q = pi/2): tool at (0.4, 0, 0.3); the rod's underside at z = 0.28 clears the block's top (0.1)
    # by 0.18 m, the closest pair.
    result = ik(rod, target_at([0.4, 0, 0.3]), "base_link", "tool", mode="position", collision_free=True)
    assert result.success and result.q[0] == pytest.approx(math.pi / 2, abs=1e-8)
    assert result.collides == (False,)
    assert result.clearance[0] == pytest.approx(0.18, abs=1e-9)


def hull_contacts(robot, q, srdf_pairs) -> set:
    """Link pairs in contact at q by Pinocchio + coal alone (convex hulls of the meshes), adjacent and SRDF pairs out."""
    share = robot.source.path.parents[4]
    geom = pin.buildGeomFromUrdf(robot.model, str(robot.source.path), pin.GeometryType.COLLISION,
                                 package_dirs=[str(share)])
    for obj in geom.geometryObjects:
        if isinstance(obj.geometry, coal.BVHModelOBBRSS):
            obj.geometry.buildConvexHull(True, "Qt")
            obj.geometry = obj.geometry.convex
    geom.addAllCollisionPairs()
    data, gdata = robot.model.createData(), geom.createData()
    pin.computeCollisions(robot.model, data, geom, gdata, robot.pinocchio_configuration(q), False)
    link = [robot.model.frames[obj.parentFrame].name for obj in geom.geometryObjects]
    pairs = {tuple(sorted((link[p.first], link[p.second])))
             for p, r in zip(geom.collisionPairs, gdata.collisionResults) if r.isCollision()}
    return {p for p in pairs if p[0] != p[1] and p not in srdf_pairs}


def test_every_collision_free_panda_answer_is_collision_free_by_an_independent_check(panda):
    from manipkit.kinematics.collisions import read_srdf

    srdf = panda.source.path.parents[1] / "srdf" / "panda.srdf"
    checker = CollisionChecker(panda, srdf=srdf)
    disabled = set(read_srdf(srdf, panda))
    Q = panda.sample_q(200, seed=11)
    colliding_targets = [q for q in Q if checker.report(q).in_collision][:4]
    assert len(colliding_targets) == 4
    solved = 0
    for q in colliding_targets:  # each target was reached by a colliding configuration
        T = panda.transform("panda_link0", "panda_hand_tcp", q)
        result = ik(panda, T, "panda_link0", "panda_hand_tcp", collision_free=checker, all=True, restarts=20)
        solved += result.success
        if not result.success:  # refused: the answer it names is in contact by the independent check too
            assert "is in collision" in result.reason
            assert hull_contacts(panda, result.closest, disabled)
            continue
        for answer, clearance in zip(result.solutions, result.clearance):
            assert hull_contacts(panda, answer, disabled) == set()
            assert clearance > 0
            assert np.allclose(panda.transform("panda_link0", "panda_hand_tcp", answer), T, atol=1e-8)
    assert solved >= 2


def test_analytic_solutions_are_marked_and_dropped(load_robot):
    # The Stanford arm's default shapes overlap (base and boom) in every configuration: all four solutions collide.
    robot = load_robot("stanford_arm")
    T = manipkit.transform_from_xyz_rpy([0.3, 0.2, 0.5], [0, 1.5, 0])
    result = analytic_ik(robot, T)
    checker = CollisionChecker(robot)
    marked = mark_collisions(result, checker)
    assert marked.collides == (True,) * 4 and (marked.clearance < 0).all()
    assert list(marked.clearance) == [checker.report(q).min_distance.distance for q in result.solutions]
    dropped = mark_collisions(result, checker, drop=True)
    assert not dropped.success and dropped.count == 0
    assert dropped.reason.startswith("every solution is in collision (4); the first: base_link - link2 (penetration")
    assert (dropped.closest == result.solutions[0]).all()


def test_cli_collision_free_json_and_refusal(rod, tmp_path):
    path = tmp_path / "rod.urdf"
    path.write_text(ROD)
    ok = run_cli("manipkit", "ik", "--robot", path, "--frame", "tool", "--xyz", "0.4", "0", "0.3",
                 "--collision-free", "--format", "json", status=0)
    answer = json.loads(ok.stdout)
    assert answer["collides"] == [False] and answer["clearance"][0] == pytest.approx(0.18, abs=1e-9)
    refused = run_cli("manipkit", "ik", "--robot", path, "--frame", "tool", "--xyz", "0", "0", "-0.1",
                      "--collision-free", status=1)
    assert "best found (in collision): turn=" in refused.stdout
    assert "note: every answer found is in collision (1 distinct); the first: base_link - rod (penetration" in refused.stdout
    marked = run_cli("manipkit", "ik", "--robot", path, "--frame", "tool", "--xyz", "0", "0", "-0.1",
                     "--collisions", status=0)
    assert "(IN COLLISION, penetration " in marked.stdout
