"""Collision geometry and checks (manipkit.kinematics.collisions, .world).

Hand cases: spheres on prismatic joints and a tilted box over the floor,
their distances worked out in the comments and compared with coal called
directly; the Panda (example-robot-data, meshes and hulls) against a
geometry model built and checked in the test with Pinocchio and coal alone.
"""

import math
import threading
import warnings
from pathlib import Path

import coal
import numpy as np
import pinocchio as pin
import pytest

import manipkit
from manipkit.errors import CollisionError
from manipkit.kinematics.collisions import (
    FLOOR,
    MAX_THREADS,
    MIN_ROWS_PER_THREAD,
    CollisionChecker,
    collision_free,
    collision_geometry,
    collisions,
    read_srdf,
)
from manipkit.kinematics.robot import Robot
from manipkit.kinematics.world import world_obstacles
from manipkit.spatial.rotations import matrix_from_rpy

BAD = Path(__file__).parent / "bad_inputs" / "collisions"

# Two spheres sliding along x: a (r = 0.1) at (xa, 0, 0.5), b (r = 0.15) at (xb, 0.2, 0.5).
TWO_SPHERES = """<?xml version="1.0"?>
<robot name="two_spheres">
  <link name="base_link"/>
  <link name="a"><collision><geometry><sphere radius="0.1"/></geometry></collision></link>
  <link name="b"><collision><geometry><sphere radius="0.15"/></geometry></collision></link>
  <joint name="slide_a" type="prismatic">
    <parent link="base_link"/><child link="a"/><origin xyz="0 0 0.5"/><axis xyz="1 0 0"/>
    <limit lower="-1" upper="1" effort="1" velocity="1"/>
  </joint>
  <joint name="slide_b" type="prismatic">
    <parent link="base_link"/><child link="b"/><origin xyz="0 0.2 0.5"/><axis xyz="1 0 0"/>
    <limit lower="-1" upper="1" effort="1" velocity="1"/>
  </joint>
</robot>
"""

# A box 0.2 x 0.1 x 0.3 turned by rpy (0.3, 0.4, 0.5), lifted by a prismatic joint along z.
TILTED_BOX = """<?xml version="1.0"?>
<robot name="tilted_box">
  <link name="base_link"/>
  <link name="block">
    <collision><origin xyz="0 0 0" rpy="0.3 0.4 0.5"/><geometry><box size="0.2 0.1 0.3"/></geometry></collision>
  </link>
  <joint name="lift" type="prismatic">
    <parent link="base_link"/><child link="block"/><axis xyz="0 0 1"/>
    <limit lower="-1" upper="1" effort="1" velocity="1"/>
  </joint>
</robot>
"""


@pytest.fixture(scope="module")
def two_spheres():
    return Robot.from_urdf(TWO_SPHERES)


@pytest.fixture(scope="module")
def tilted_box():
    return Robot.from_urdf(TILTED_BOX)


@pytest.fixture(scope="module")
def panda():
    return manipkit.load("panda")


def coal_distance(shape1, T1, shape2, T2) -> float:
    """coal's distance between two shapes at poses T1, T2 (4x4), called directly."""
    result = coal.DistanceResult()
    coal.distance(shape1, coal.Transform3s(T1[:3, :3], T1[:3, 3]), shape2, coal.Transform3s(T2[:3, :3], T2[:3, 3]),
                  coal.DistanceRequest(), result)
    return result.min_distance


def pose(xyz, R=None) -> np.ndarray:
    T = np.eye(4)
    T[:3, 3] = xyz
    if R is not None:
        T[:3, :3] = R
    return T


# ----------------------------------------------------------------------
# Hand cases
# ----------------------------------------------------------------------


def test_distance_of_two_spheres_is_the_gap_between_their_surfaces(two_spheres):
    # xa = -0.1, xb = 0.2: centres (-0.1, 0, 0.5) and (0.2, 0.2, 0.5), d = sqrt(0.3^2 + 0.2^2) = sqrt(0.13);
    # gap = d - 0.1 - 0.15 = 0.110555...; witness on a: centre_a + 0.1 (0.3, 0.2, 0) / d
    report = collisions(two_spheres, [-0.1, 0.2])
    d = math.sqrt(0.13)
    closest = report.min_distance
    assert not report.in_collision and report.pairs == () and report.checked == 1
    assert (closest.link1, closest.link2) == ("a", "b")
    assert closest.distance == pytest.approx(d - 0.25, abs=1e-9)
    direct = coal_distance(coal.Sphere(0.1), pose([-0.1, 0, 0.5]), coal.Sphere(0.15), pose([0.2, 0.2, 0.5]))
    assert closest.distance == pytest.approx(direct, abs=1e-9)
    assert closest.point1 == pytest.approx([-0.1 + 0.1 * 0.3 / d, 0.1 * 0.2 / d, 0.5], abs=1e-9)
    assert closest.point2 == pytest.approx([0.2 - 0.15 * 0.3 / d, 0.2 - 0.15 * 0.2 / d, 0.5], abs=1e-9)


def test_overlapping_spheres_collide_with_their_penetration_depth(two_spheres):
    # xa = 0, xb = 0.05: d = sqrt(0.05^2 + 0.2^2) = sqrt(0.0425) < 0.25: depth 0.25 - d = 0.043845...
    report = collisions(two_spheres, [0.0, 0.05])
    assert report.in_collision
    assert [(p.link1, p.link2) for p in report.pairs] == [("a", "b")]
    assert report.pairs[0].distance == pytest.approx(math.sqrt(0.0425) - 0.25, abs=1e-9)
    direct = coal_distance(coal.Sphere(0.1), pose([0, 0, 0.5]), coal.Sphere(0.15), pose([0.05, 0.2, 0.5]))
    assert report.min_distance.distance == pytest.approx(direct, abs=1e-9)


def test_box_corner_to_the_floor(tilted_box):
    # The lowest corner of a box turned by R sits sum_j |R[2, j]| h_j below its centre (h: half sizes),
    # so at lift 0.3 above a floor at z = 0.05 the gap is 0.3 - 0.05 - sum_j |R[2, j]| h_j.
    R = matrix_from_rpy(0.3, 0.4, 0.5)
    half = np.array([0.1, 0.05, 0.15])
    drop = float(np.abs(R[2]) @ half)
    report = collisions(tilted_box, [0.3], floor=0.05)
    closest = report.min_distance
    assert (closest.link1, closest.link2) == ("block", FLOOR)
    assert closest.distance == pytest.approx(0.3 - 0.05 - drop, abs=1e-9)
    direct = coal_distance(coal.Box(0.2, 0.1, 0.3), pose([0, 0, 0.3], R), coal.Halfspace(np.array([0, 0, 1.0]), 0.05),
                           np.eye(4))
    assert closest.distance == pytest.approx(direct, abs=1e-9)
    corner = closest.point1
    assert corner[2] == pytest.approx(0.3 - drop, abs=1e-9)
    # lowered until the corner is below the floor: in collision with the floor, depth by hand
    low = collisions(tilted_box, [drop], floor=0.05)
    assert low.in_collision and low.pairs[0].link2 == FLOOR
    assert low.pairs[0].distance == pytest.approx(-0.05, abs=1e-9)


def test_no_floor_means_no_floor_pair(tilted_box):
    # One link and no floor: nothing to check, and the report says so (no pair, no distance)
    report = collisions(tilted_box, [-0.9])
    assert report.checked == 0 and not report.in_collision and report.min_distance is None


def test_world_sphere_distance_by_hand(two_spheres):
    # An obstacle ball r = 0.05 at (0.5, 0, 0.5): gap to sphere a at (0, 0, 0.5) is 0.5 - 0.1 - 0.05 = 0.35,
    # to b at (0.9, 0.2, 0.5) it is sqrt(0.4^2 + 0.2^2) - 0.15 - 0.05 = 0.247213...
    world = world_obstacles({"obstacles": [{"name": "ball", "sphere": 0.05, "xyz": [0.5, 0, 0.5]}]})
    checker = CollisionChecker(two_spheres, world=world)
    report = checker.report([0.0, 0.9])
    assert set(checker.pairs) == {("a", "b"), ("a", "ball"), ("b", "ball")}
    closest = report.min_distance
    assert (closest.link1, closest.link2) == ("b", "ball")
    assert closest.distance == pytest.approx(math.sqrt(0.2) - 0.2, abs=1e-9)


def test_world_file_reads_every_shape_with_its_pose(tmp_path):
    path = tmp_path / "world.yaml"
    path.write_text("obstacles:\n"
                    "  - {name: table, box: [1.0, 0.6, 0.04], xyz: [0.5, 0, -0.02], rpy: [0, 0, 1.5707963267948966]}\n"
                    "  - {sphere: 0.1}\n"
                    "  - {name: post, cylinder: [0.05, 1.0], xyz: [-0.4, 0, 0.5]}\n")
    obstacles = manipkit.kinematics.read_world(path)
    assert [name for name, _, _ in obstacles] == ["table", "obstacle_2", "post"]
    table, ball, post = (shape for _, shape, _ in obstacles)
    assert isinstance(table, coal.Box) and table.halfSide == pytest.approx([0.5, 0.3, 0.02])
    assert isinstance(ball, coal.Sphere) and ball.radius == 0.1
    assert isinstance(post, coal.Cylinder) and (post.radius, 2 * post.halfLength) == pytest.approx((0.05, 1.0))
    assert obstacles[0][2][:3, :3] @ [1, 0, 0] == pytest.approx([0, 1, 0], abs=1e-12)


@pytest.mark.parametrize("document, fragment", [
    ({"obstacles": [{"box": [1, 2]}]}, "box: expected 3 numbers"),
    ({"obstacles": [{"sphere": 0.1, "rpy": [0, 0]}]}, "rpy: expected 3 numbers"),
    ({"obstacles": [{"sphere": 0.1, "box": [1, 1, 1]}]}, "give exactly one shape"),
    ({"obstacles": [{"name": "a", "sphere": 0.1}, {"name": "a", "sphere": 0.2}]}, "the name is used twice"),
    ({"obstacles": "table"}, "'obstacles' must be a list"),
    ([1, 2], "a world file is a mapping"),
])
def test_malformed_world_documents_name_the_field(document, fragment):
    with pytest.raises(CollisionError, match=fragment.replace("(", r"\(")):
        world_obstacles(document)


# ----------------------------------------------------------------------
# Pairs, SRDF, geometry
# ----------------------------------------------------------------------


def test_adjacent_links_are_not_checked_and_links_without_geometry_are_passed_through(panda):
    # panda_link7 -> panda_link8 (no geometry) -> panda_hand: link7 and the hand count as adjacent
    geometry = collision_geometry(panda)
    chain = [f"panda_link{i}" for i in range(8)]
    expected = {tuple(sorted(p)) for p in zip(chain, chain[1:])}
    expected |= {("panda_hand", "panda_link7"), ("panda_hand", "panda_leftfinger"), ("panda_hand", "panda_rightfinger")}
    assert geometry.adjacent == expected
    checked = set(CollisionChecker(panda).pairs)
    assert not checked & expected


def test_geometry_is_built_once_per_robot_and_kind(panda):
    assert collision_geometry(panda) is collision_geometry(panda, "hulls")
    assert collision_geometry(panda, "meshes") is not collision_geometry(panda)
    # meshes become convex hulls, the fingers' boxes stay boxes
    hulls = [type(obj.geometry) for obj in collision_geometry(panda).model.geometryObjects]
    meshes = [type(obj.geometry) for obj in collision_geometry(panda, "meshes").model.geometryObjects]
    assert [h for h, m in zip(hulls, meshes) if m is coal.BVHModelOBBRSS] == [coal.Convex] * 9
    assert [h for h, m in zip(hulls, meshes) if m is not coal.BVHModelOBBRSS] == [coal.Box] * 8


def test_srdf_pairs_are_not_checked(tmp_path, two_spheres):
    srdf = tmp_path / "spheres.srdf"
    srdf.write_text('<robot name="two_spheres"><disable_collisions link1="b" link2="a" reason="Never"/></robot>')
    assert read_srdf(srdf, two_spheres) == {("a", "b"): "Never"}
    report = collisions(two_spheres, [0.0, 0.05], srdf=srdf)  # the overlapping spheres of the test above
    assert not report.in_collision and report.checked == 0


def test_srdf_naming_an_unknown_link_is_refused():
    robot = manipkit.load(BAD / "arm.urdf")
    with pytest.raises(CollisionError, match="names link 'forearm', which robot 'box_arm' does not have"):
        collisions(robot, srdf=BAD / "unknown_link.srdf")


def test_a_robot_without_collision_elements_has_no_collision_checks(planar_2r):
    robot = manipkit.load(BAD / "no_collision.urdf")
    with pytest.raises(CollisionError, match="has no <collision> elements, so collisions cannot be checked"):
        collisions(robot)
    with pytest.raises(CollisionError, match="has no <collision> elements"):
        collision_free(robot, robot.sample_q(3))


def test_a_missing_collision_mesh_is_named():
    robot = manipkit.load(BAD / "missing_mesh.urdf")
    with pytest.raises(CollisionError, match="link 'upper': mesh meshes/upper_collision.stl not found"):
        collision_geometry(robot)


def test_unknown_geometry_kind_is_refused(two_spheres):
    with pytest.raises(CollisionError, match="geometry 'spheres' is not known; give one of hulls, meshes"):
        collisions(two_spheres, geometry="spheres")


@pytest.mark.parametrize("name", ["course_arm", "iiwa14", "mobile_manipulator", "planar_2r", "planar_3r",
                                  "scara", "stanford_arm", "elbow_arm"])
def test_bundled_robots_have_collision_shapes_on_every_link_with_a_body(load_robot, name):
    # every link drawn (except the tool-frame marker balls) has a collision shape
    robot = load_robot(name)
    import xml.etree.ElementTree as ET

    root = ET.fromstring(robot.urdf)
    drawn = {link.get("name") for link in root.iter("link") if link.find("visual") is not None} - {"ee_link"}
    assert set(collision_geometry(robot).link_names) == drawn


def test_course_arm_folded_onto_its_stand_collides_and_stretched_does_not(course_arm):
    assert not collisions(course_arm).in_collision
    # shoulder and elbow wrist bent fully: the forearm comes down through the turret
    folded = collisions(course_arm, course_arm.q(shoulder_joint=0, bottom_wrist_joint=3.0))
    assert folded.in_collision
    assert any("arm_base" in (p.link1, p.link2) or "base_link" in (p.link1, p.link2) for p in folded.pairs)


def test_mobile_manipulator_base_and_lidar_are_boxes(load_robot):
    robot = load_robot("mobile_manipulator")
    geometry = collision_geometry(robot)
    shapes = {link: obj.geometry for link, obj in zip(geometry.links, geometry.model.geometryObjects)}
    assert isinstance(shapes["base_link"], coal.Box) and shapes["base_link"].halfSide == pytest.approx([0.2, 0.15, 0.05])
    assert isinstance(shapes["lidar_link"], coal.Box) and shapes["lidar_link"].halfSide == pytest.approx([0.035, 0.035, 0.02])


# ----------------------------------------------------------------------
# The Panda against Pinocchio + coal called directly
# ----------------------------------------------------------------------


def direct_contacts(robot, geometry: str, Q) -> list[set]:
    """Link pairs in contact per configuration, by a geometry model built here from the URDF file (all pairs)."""
    share = robot.source.path.parents[4]  # .../share/example-robot-data/robots/panda_description/urdf/panda.urdf
    model = robot.model
    geom = pin.buildGeomFromUrdf(model, str(robot.source.path), pin.GeometryType.COLLISION, package_dirs=[str(share)])
    if geometry == "hulls":
        for obj in geom.geometryObjects:
            if not isinstance(obj.geometry, coal.BVHModelOBBRSS):
                continue
            obj.geometry.buildConvexHull(True, "Qt")
            obj.geometry = obj.geometry.convex
    geom.addAllCollisionPairs()
    data, gdata = model.createData(), geom.createData()
    with warnings.catch_warnings():  # every query afresh, as documented (Pinocchio caches coal's guess otherwise)
        warnings.simplefilter("ignore", DeprecationWarning)
        for request in gdata.collisionRequests:
            request.enable_cached_gjk_guess = False
    link = [model.frames[obj.parentFrame].name for obj in geom.geometryObjects]
    answers = []
    for q in Q:
        pin.computeCollisions(model, data, geom, gdata, robot.pinocchio_configuration(q), False)
        answers.append({tuple(sorted((link[p.first], link[p.second])))
                        for p, r in zip(geom.collisionPairs, gdata.collisionResults) if r.isCollision()})
    return answers


@pytest.mark.parametrize("geometry", ["meshes", "hulls"])
def test_panda_collisions_agree_with_pinocchio_and_coal_called_directly(panda, geometry):
    checker = CollisionChecker(panda, geometry=geometry, srdf="none")  # every pair but adjacent ones
    Q = panda.sample_q(60, seed=3)
    direct = direct_contacts(panda, geometry, Q)
    checked = set(checker.pairs)
    colliding = free = 0
    batch = collision_free(panda, Q, geometry=geometry, srdf="none")
    for q, contacts, is_free in zip(Q, direct, batch):
        expected = contacts & checked
        report = checker.report(q)
        assert {(p.link1, p.link2) if p.link1 < p.link2 else (p.link2, p.link1) for p in report.pairs} == expected
        assert report.in_collision == bool(expected) == (not is_free)
        colliding += bool(expected)
        free += not expected
    assert colliding >= 3 and free >= 3  # both kinds are among the samples


def test_batched_answers_equal_one_at_a_time_on_any_thread_count(panda):
    Q = panda.sample_q(3 * MIN_ROWS_PER_THREAD, seed=5)  # enough rows for 3 threads
    checker = CollisionChecker(panda, floor=0.0)
    one_by_one = np.array([checker.report(q).in_collision for q in Q])
    for workers in (1, 2, 3):
        assert (checker.in_collision(Q, workers=workers) == one_by_one).all()
    assert 0 < one_by_one.sum() < len(Q)


def test_contact_counts_equal_a_direct_count_on_any_thread_count(panda):
    # The per-pair counts of 3000 samples (3 threads' worth), against Pinocchio + coal called here on every sample
    Q = panda.sample_q(3 * MIN_ROWS_PER_THREAD, seed=11)
    checker = CollisionChecker(panda, srdf="none")
    direct = direct_contacts(panda, "hulls", Q)
    expected = {pair: sum(pair in contacts for contacts in direct) for pair in checker.pairs}
    for workers in (1, 2, 3):
        counts = checker.contact_counts(Q, workers=workers)
        assert counts == expected and list(counts) == list(checker.pairs)
    assert sum(expected.values()) > 10 and sum(v == 0 for v in expected.values()) > 10  # both kinds of pair
    assert checker.contact_counts(Q[:0]) == dict.fromkeys(checker.pairs, 0)


def test_threads_may_share_a_checker(panda):
    checker = CollisionChecker(panda)
    Q = panda.sample_q(40, seed=9)
    expected = [checker.report(q).in_collision for q in Q]
    answers = {}

    def run(k):
        answers[k] = [checker.report(q).in_collision for q in Q]

    threads = [threading.Thread(target=run, args=(k,)) for k in range(3)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    assert all(a == expected for a in answers.values())


def test_panda_with_frankas_srdf_is_free_at_its_default_pose_and_reports_witness_points_in_the_base(panda):
    srdf = panda.source.path.parents[1] / "srdf" / "panda.srdf"
    report = collisions(panda, srdf=srdf)
    assert not report.in_collision and report.min_distance.distance > 0
    closest = report.min_distance
    # the witness points are distance apart (both in panda_link0, the base)
    assert np.linalg.norm(np.subtract(closest.point1, closest.point2)) == pytest.approx(closest.distance, abs=1e-9)


def test_bad_batch_shapes_are_refused(panda):
    with pytest.raises(CollisionError, match=r"needs configurations of 8 joint values \(N, 8\); got shape \(2, 3\)"):
        collision_free(panda, np.zeros((2, 3)))
    with pytest.raises(CollisionError, match="workers 0: give a whole number of threads"):
        collision_free(panda, np.zeros((2, 8)), workers=0)
    with pytest.raises(CollisionError, match=f"workers {MAX_THREADS + 1}: .* at most {MAX_THREADS}"):
        collision_free(panda, np.zeros((2, 8)), workers=MAX_THREADS + 1)


FLOATING = """<?xml version="1.0"?>
<robot name="floating">
  <link name="world"/>
  <link name="body"><collision><geometry><box size="0.1 0.1 0.1"/></geometry></collision></link>
  <link name="arm"><collision><origin xyz="0 0 0.2"/><geometry><box size="0.05 0.05 0.3"/></geometry></collision></link>
  <joint name="free" type="floating"><parent link="world"/><child link="body"/></joint>
  <joint name="hinge" type="continuous"><parent link="body"/><child link="arm"/><axis xyz="0 1 0"/></joint>
</robot>
"""


@pytest.mark.parametrize("name", ["course_arm", "panda", "floating"])
def test_batched_configurations_equal_one_at_a_time(load_robot, name):
    # course_arm: continuous joints (cos, sin); panda: a mimic finger; floating: a free joint's quaternion
    robot = Robot.from_urdf(FLOATING) if name == "floating" else load_robot(name)
    Q = robot.sample_q(7, seed=2)
    C = robot.joint_layout.configurations(Q)
    assert C.shape == (robot.model.nq, 7) and C.flags.f_contiguous
    for i, q in enumerate(Q):
        assert C[:, i] == pytest.approx(robot.pinocchio_configuration(q), abs=1e-15)
    hits = CollisionChecker(robot, floor=-0.5).in_collision(Q)
    assert list(hits) == [CollisionChecker(robot, floor=-0.5).report(q).in_collision for q in Q]


def test_wheels_and_base_stand_on_the_floor_and_the_arm_does_not_go_through_it(load_robot):
    # mobile_manipulator: root base_footprint on the ground; the wheels (r = 0.05, axle at z = 0.05) touch z = 0 at
    # every wheel angle and the caster is rigid with the root: none of them is checked against the floor.
    robot = load_robot("mobile_manipulator")
    checker = CollisionChecker(robot, floor=0.0)
    floor_pairs = {a if b == FLOOR else b for a, b in checker.pairs if FLOOR in (a, b)}
    assert floor_pairs == {"arm_base", "bicep", "bottom_wrist", "elbow", "top_wrist"}
    assert not checker.report().in_collision
    # the arm (0.75 m from the shoulder, 0.35 m above the ground) reaches below the ground in some samples:
    # there the floor pair's witness point on the link is below z = 0
    reports = [checker.report(q) for q in robot.sample_q(200, seed=4)]
    below = [p for r in reports for p in r.pairs if FLOOR in (p.link1, p.link2)]
    assert below
    for pair in below:
        on_link = pair.point1 if pair.link2 == FLOOR else pair.point2
        assert on_link[2] < 1e-9 and pair.distance < 0


def test_a_floor_above_a_link_at_the_default_pose_is_still_checked(tilted_box):
    # the block sits 0.2 m deep in a floor at z = 0.2 + its drop at lift 0: deeper than RESTING, so it is checked
    R = matrix_from_rpy(0.3, 0.4, 0.5)
    drop = float(np.abs(R[2]) @ np.array([0.1, 0.05, 0.15]))
    report = collisions(tilted_box, [0.0], floor=0.2 - drop)
    assert report.in_collision and report.pairs[0].distance == pytest.approx(-0.2, abs=1e-9)


def test_collision_settings_parse_and_filter(panda):
    from manipkit.kinematics.collisions import CollisionSettings

    assert CollisionSettings.parse(panda, "none") is None
    floor_only = CollisionSettings.parse(panda, "floor", floor=0.0)
    assert floor_only.checker(panda) is floor_only.checker(panda)  # one per robot and settings
    assert all(FLOOR in pair for pair in floor_only.checker(panda).pairs)
    both = CollisionSettings.parse(panda, "self,floor", floor=0.0, srdf=panda.source.path.parents[1] / "srdf" / "panda.srdf")
    Q = panda.sample_q(100, seed=1)
    expected = ~CollisionChecker(panda, floor=0.0, srdf=panda.source.path.parents[1] / "srdf" / "panda.srdf").in_collision(Q)
    assert (both.free(panda, Q) == expected).all()
    assert both.as_dict()["checked"] == ["self", "floor"] and both.as_dict()["disabled_pairs"] == 35
    with pytest.raises(CollisionError, match="collisions 'walls': give self, floor, self,floor or none"):
        CollisionSettings.parse(panda, "walls")


def test_answers_do_not_depend_on_the_previous_configuration(iiwa14):
    # Pinocchio caches coal's GJK guess between queries; with it, 8 of these 5,000 iiwa14 configurations (cylinders
    # a few millimetres deep) were answered differently than by a fresh query. Every answer must equal a fresh one.
    checker = CollisionChecker(iiwa14, floor=0.0)
    Q = iiwa14.sample_q(5000, seed=3)
    fresh = np.array([pin.computeCollisions(iiwa14.model, iiwa14.model.createData(), checker.model,
                                            checker.model.createData(), iiwa14.pinocchio_configuration(q), True)
                      for q in Q])
    assert (checker.in_collision(Q) == fresh).all()
    assert (np.array([checker.report(q).in_collision for q in Q]) == fresh).all()


def test_a_checker_is_immutable(two_spheres):
    checker = CollisionChecker(two_spheres)
    with pytest.raises(AttributeError, match="a CollisionChecker is immutable"):
        checker.floor = 0.0
    with pytest.raises(TypeError):
        checker.disabled[("a", "b")] = "Never"
