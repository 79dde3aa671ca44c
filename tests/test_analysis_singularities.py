"""manipkit.analysis.singularities: the known singular families.

Independent sources: Pinocchio's ``computeFrameJacobian`` (LOCAL_WORLD_ALIGNED;
the bundled robots' base_link is the root, so its axes are the base's) for
the smallest singular value, and the symbolic determinants of the bundled DH
tables (``manipkit.dh.symbolic_jacobian``), whose factors must be the families'
conditions. The hand derivations are in the module's docstring. What is
lost at a singular configuration (the null motions, the lost directions, the
joints on one axis) is tested in tests/test_analysis_jacobian_report.py.
"""

import math
import zlib

import numpy as np
import pinocchio as pin
import pytest
import sympy
from hypothesis import given, settings
from hypothesis import strategies as st

from manipkit.analysis.singularities import (
    KNOWN_ROBOTS,
    SingularFamily,
    families_at,
    singular_families,
    singular_family_at,
)
from manipkit.description.sources import bundled_dh_tables
from manipkit.dh import dh_symbols, load_dh
from manipkit.dh.symbolic_jacobian import dh_jacobian_symbolic, jacobian_determinant

SINGULAR = 1e-9  # the smallest singular value on a family is below this, off it above


def pinocchio_jacobian(robot, q):
    """(6, n) Jacobian of ee_link in the root's axes, columns in ``robot.joint_names`` order."""
    data = robot.model.createData()
    J = pin.computeFrameJacobian(robot.model, data, robot.pinocchio_configuration(q), robot.frame_id("ee_link"),
                                 pin.LOCAL_WORLD_ALIGNED)
    return J[:, [robot.model.joints[robot.model.getJointId(name)].idx_v for name in robot.joint_names]]


def smallest_singular_value(robot, q, rows):
    return np.linalg.svd(pinocchio_jacobian(robot, q)[list(rows)], compute_uv=False)[-1]


FAMILY_CASES = [
    (name, family.name) for name in KNOWN_ROBOTS
    for family in singular_families(__import__("manipkit").load(name))
]


def family_named(robot, name) -> SingularFamily:
    return next(f for f in singular_families(robot) if f.name == name)


# --------------------------------------------------------------------------
# every family is singular, and only there


@pytest.mark.parametrize(("robot_name", "family_name"), FAMILY_CASES)
def test_random_members_are_singular(load_robot, robot_name, family_name):
    robot = load_robot(robot_name)
    family = family_named(robot, family_name)
    rng = np.random.default_rng(zlib.crc32(family_name.encode()))  # the same seed in every run
    for q in family.sample(rng, 25):
        assert family.member(q, 1e-12)
        assert smallest_singular_value(robot, q, family.rows) < SINGULAR, (q, family.condition)


@pytest.mark.parametrize(("robot_name", "family_name"), FAMILY_CASES)
def test_members_moved_off_the_family_are_not_singular(load_robot, robot_name, family_name):
    # a member moved by about 1e-3 in every joint leaves the family (distance > 1e-4) and the smallest
    # singular value grows to about the distance times a length (its square for the Stanford arm's d3 = 0,
    # since det J = d3^2 s2 s5): far above 1e-9
    robot = load_robot(robot_name)
    family = family_named(robot, family_name)
    rng = np.random.default_rng(7)
    others = [f for f in singular_families(robot) if f is not family]
    for q in family.sample(rng, 25):
        moved = q + rng.normal(0.0, 1e-3, q.shape)
        if family.distance(moved) < 1e-4 or any(f.member(moved, 1e-4) for f in others):
            continue
        assert smallest_singular_value(robot, moved, family.rows) > SINGULAR


@pytest.mark.parametrize("robot_name", KNOWN_ROBOTS)
def test_random_configurations_are_in_no_family_and_not_singular(load_robot, robot_name):
    robot = load_robot(robot_name)
    for q in robot.sample_q(100, seed=3):
        assert singular_family_at(robot, q, 1e-6) is None
        for family in singular_families(robot):
            assert smallest_singular_value(robot, q, family.rows) > SINGULAR


def test_distance_is_vectorised_and_counts_turns(planar_2r):
    family = singular_families(planar_2r)[0]
    Q = np.array([[0.0, 0.0], [0.0, math.pi], [0.0, 2 * math.pi + 0.1], [1.0, -math.pi + 0.2]])
    assert family.distance(Q) == pytest.approx([0.0, 0.0, 0.1, 0.2], abs=1e-12)
    assert family.member(Q, 1e-9).tolist() == [True, True, False, False]


def test_singular_family_at_names_the_family(load_robot):
    stanford = load_robot("stanford_arm")
    q = stanford.q(joint2=0.4, joint3=0.5, joint5=0.0)
    assert singular_family_at(stanford, q).name == "wrist"
    assert singular_family_at(stanford, stanford.q(joint2=0.4, joint3=0.5, joint5=0.3)) is None


def test_stanford_boom_fully_in_is_outside_the_stroke(load_robot):
    families = {f.name: f for f in singular_families(load_robot("stanford_arm"))}
    assert not families["wrist centre at the shoulder"].reachable
    assert "its lower limit is 0.1 m" in families["wrist centre at the shoulder"].description
    assert families["wrist"].reachable and families["boom along joint 1's axis"].reachable


def test_elbow_arm_shoulder_family_follows_xacro_lengths(load_robot):
    # a2 = 0.6, a3 = 0.3: the shoulder condition is 0.6 c2 + 0.3 c23 = 0, checked by Pinocchio on that model
    robot = load_robot("elbow_arm", a2="0.6", a3="0.3")
    family = family_named(robot, "wrist centre on joint 1's axis")
    assert "0.6 cos(joint2) + 0.3 cos(joint2 + joint3)" in family.condition
    for q in family.sample(np.random.default_rng(1), 10):
        assert smallest_singular_value(robot, q, family.rows) < SINGULAR


# --------------------------------------------------------------------------
# robots without known families


@pytest.mark.parametrize("robot_name", ["mobile_manipulator", "panda"])
def test_other_robots_have_no_known_families(load_robot, robot_name):
    robot = load_robot(robot_name)
    assert singular_families(robot) == []
    assert singular_family_at(robot, robot.q()) is None


def test_a_known_name_with_another_structure_gets_no_families(planar_3r):
    # a 3-joint arm that calls itself planar_2r is not the 2R
    from manipkit import Robot

    renamed = Robot.from_urdf(planar_3r.urdf.replace('name="planar_3r"', 'name="planar_2r"', 1))
    assert renamed.name == "planar_2r"
    assert singular_families(renamed) == []


# --------------------------------------------------------------------------
# the symbolic determinants factor into the same conditions

TABLES = bundled_dh_tables()
DETERMINANTS = [("planar_2r", [0, 1], None), ("planar_3r", [0, 1, 5], None), ("scara", [0, 1, 2, 5], None),
                ("stanford_arm", None, 3), ("elbow_arm", None, 3)]


@pytest.mark.parametrize(("robot_name", "rows", "point"), DETERMINANTS)
def test_each_factor_of_the_symbolic_determinant_is_a_family(load_robot, robot_name, rows, point):
    # det = product of factors; each non-constant factor vanishes on all samples of one family with the same
    # rows, and every such family makes some factor vanish: the families are exactly the determinant's zeros
    robot = load_robot(robot_name)
    table = load_dh(TABLES[robot_name])
    det = jacobian_determinant(dh_jacobian_symbolic(table, point=point), rows)
    factors = [f.as_base_exp()[0] for f in sympy.Mul.make_args(det) if f.free_symbols]
    q = dh_symbols(table.n)
    families = [f for f in singular_families(robot) if rows is None or list(f.rows) == rows]
    samples = {f.name: f.sample(np.random.default_rng(2), 10) for f in families}
    vanishes = {
        (str(factor), name): all(abs(float(factor.subs(dict(zip(q, s))))) < 1e-12 for s in Q)
        for factor in factors for name, Q in samples.items()
    }
    for factor in factors:
        assert any(vanishes[(str(factor), f.name)] for f in families), f"factor {factor} is no family"
    for f in families:
        assert any(vanishes[(str(factor), f.name)] for factor in factors), f"family {f.name} is no factor"


def test_planar_3r_position_family_is_where_sqrt_det_j_jt_vanishes(planar_3r):
    family = family_named(planar_3r, "all links in line")
    measure = jacobian_determinant(dh_jacobian_symbolic(load_dh(TABLES["planar_3r"])), [0, 1])
    f = sympy.lambdify(dh_symbols(3), measure, "numpy")
    assert max(abs(f(*q)) for q in family.sample(np.random.default_rng(4), 20)) < 1e-12


# --------------------------------------------------------------------------
# every family that holds


def test_families_at_names_every_family_that_holds(load_robot, iiwa14):
    # Stanford arm at its default q = (0, 0, 0.1, 0, 0, 0): joint5 = 0 (wrist) and joint2 = 0 (boom along
    # joint 1's axis) at once; iiwa14 at q = 0: joint4 = 0 (elbow straight) and joint2 = joint6 = 0
    stanford = load_robot("stanford_arm")
    assert [f.name for f in families_at(stanford, stanford.q())] == ["wrist", "boom along joint 1's axis"]
    assert singular_family_at(stanford, stanford.q()).name == "wrist"  # the first of them
    assert [f.name for f in families_at(iiwa14, iiwa14.q())] == ["elbow straight", "shoulder and wrist axes aligned"]
    assert families_at(iiwa14, iiwa14.sample_q(1, seed=1)[0]) == []


def test_families_at_takes_joint_values_by_name(load_robot):
    stanford = load_robot("stanford_arm")
    assert [f.name for f in families_at(stanford, {"joint2": 0.4, "joint3": 0.5})] == ["wrist"]
    assert singular_family_at(stanford, {"joint2": 0.4, "joint3": 0.5, "joint5": 0.3}) is None


# --------------------------------------------------------------------------
# properties


@settings(max_examples=40, deadline=None)
@given(case=st.sampled_from(FAMILY_CASES), seed=st.integers(0, 2**32 - 1), turns=st.integers(-3, 3))
def test_members_are_at_distance_zero_and_full_turns_change_nothing(load_robot, case, seed, turns):
    # a member is at distance 0; adding whole turns to the revolute joints gives the same configuration, so
    # the same distance (prismatic joints stay)
    robot = load_robot(case[0])
    family = family_named(robot, case[1])
    q = family.sample(np.random.default_rng(seed), 1)[0]
    assert family.distance(q) < 1e-9
    turned = q + np.array([2 * math.pi * turns if j.is_angular else 0.0 for j in robot.joints])
    assert family.distance(turned) == pytest.approx(family.distance(q), abs=1e-9)
    assert family.distance(np.stack([q, turned])).shape == (2,)


def test_a_joint_vector_of_the_wrong_length_is_refused(planar_2r):
    from manipkit.errors import JointValueError

    with pytest.raises(JointValueError, match=r"give 2 finite joint values \(joint1, joint2\)"):
        singular_family_at(planar_2r, [0.0, 0.0, 0.0])
    with pytest.raises(JointValueError, match="robot 'planar_2r' has no joint 'joint3'"):
        families_at(planar_2r, {"joint3": 0.0})
