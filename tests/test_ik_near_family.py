"""Arms that miss a closed-form family only by rounding keep the closed form; beyond the tolerance, the general solver.

Two arms written as their users write them, with their rounding:

- a UR5-like arm in URDF whose elbow axis is written as ``z`` in a frame turned
  by ``rpy="1.5708 0 0"`` (pi/2 rounded to 4 decimals) and turned back by a fixed
  joint writing ``-1.5708``: axes 2 and 3 are off parallel by ``pi/2 - 1.5708``
  (3.67e-6 rad, from ``R_x(1.5708) (0, 0, -1)``);
- a spherical-wrist (OPW, KUKA-like) arm from a DH table writing 1.5708 for every
  pi/2 twist whose wrist axes 4 and 5 are 0.06 mm apart (``a_4 = 6e-5``).

Both are within the default family tolerance (``FAMILY_TOL``, 1 mm and 1 mrad):
``manipkit family`` names the family and states the snap (the measured misses,
with units), and ``manipkit.ik(..., all=True)`` answers in closed form, every
row landing by Pinocchio's forward kinematics (``robot.transform``) to 1e-10 on
the TRUE chain, the generating configuration among the rows. The same arms
pushed 5 mm off their family (the UR5's axes 5 and 6, the wrist's axes 4 and 5,
5 mm apart) go to the general 6R solver (``method == "algebraic"``), never to a
wrong family, and their rows land too.
"""

import json
import math

import numpy as np
import pytest
from cli_helper import run_cli

import manipkit
from manipkit.dh import DHRow, DHTable, urdf_from_dh
from manipkit.ik.families import FAMILY_TOL, chain_family
from manipkit.kinematics.robot import Robot

ROUNDED = 1.5708  # pi/2 as a URDF writes it
POSES = 200


def _joint(name, parent, child, xyz, rpy, axis=None):
    kind = "fixed" if axis is None else "revolute"
    text = (f'  <joint name="{name}" type="{kind}">\n    <parent link="{parent}"/>\n    <child link="{child}"/>\n'
            f'    <origin xyz="{xyz}" rpy="{rpy}"/>\n')
    if axis is not None:
        text += f'    <axis xyz="{axis}"/>\n    <limit lower="-6.2" upper="6.2" effort="150" velocity="3.15"/>\n'
    return text + "  </joint>\n"


def ur5_like_urdf(wrist_offset: float = 0.0) -> str:
    """A UR5-like arm (ur_description's old layout) with the elbow axis written through a 1.5708 turn.

    ``wrist_offset`` moves axis 6 along the tool's x (m): axes 5 and 6 then miss meeting by that much.
    """
    joints = [
        ("shoulder_pan_joint", "base_link", "shoulder_link", "0 0 0.089159", "0 0 0", "0 0 1"),
        ("shoulder_lift_joint", "shoulder_link", "upper_arm_link", "0 0.13585 0", "0 1.570796326794897 0", "0 1 0"),
        # the elbow written in a frame turned by rpy 1.5708 about x: its axis z there is -y of the upper arm, rounded
        ("elbow_joint", "upper_arm_link", "forearm_twisted", "0 -0.1197 0.425", f"{ROUNDED} 0 0", "0 0 -1"),
        ("elbow_untwist", "forearm_twisted", "forearm_link", "0 0 0", f"-{ROUNDED} 0 0", None),
        ("wrist_1_joint", "forearm_link", "wrist_1_link", "0 0 0.39225", "0 1.570796326794897 0", "0 1 0"),
        ("wrist_2_joint", "wrist_1_link", "wrist_2_link", "0 0.093 0", "0 0 0", "0 0 1"),
        ("wrist_3_joint", "wrist_2_link", "wrist_3_link", f"{wrist_offset!r} 0 0.09465", "0 0 0", "0 1 0"),
        ("ee_fixed_joint", "wrist_3_link", "ee_link", "0 0.0823 0", "0 0 1.570796326794897", None),
    ]
    links = ["base_link"] + [j[2] for j in joints]
    return ('<?xml version="1.0"?>\n<robot name="ur5_rounded">\n' + "".join(f'  <link name="{n}"/>\n' for n in links)
            + "".join(_joint(*j) for j in joints) + "</robot>\n")


def wrist_table(miss: float) -> DHTable:
    """A KUKA-like spherical-wrist arm (standard DH, every pi/2 written 1.5708), axes 4 and 5 ``miss`` (m) apart."""
    rows = [(0.025, -ROUNDED, 0.4), (0.455, 0.0, 0.0), (0.035, -ROUNDED, 0.0), (miss, ROUNDED, 0.42),
            (0.0, -ROUNDED, 0.0), (0.0, 0.0, 0.08)]
    return DHTable([DHRow(a, alpha, d, 0.0, qlim=(-3.0, 3.0)) for a, alpha, d in rows], "standard", "wrist_rounded")


def write(tmp_path, name, text):
    path = tmp_path / f"{name}.urdf"
    path.write_text(text)
    return path


def wrapped(a):
    return np.pi - np.mod(np.pi - np.asarray(a), 2 * np.pi)


def line_distance(p1, h1, p2, h2) -> float:
    """The distance (m) between two lines, by hand: |(p2 - p1) . (h1 x h2)| / |h1 x h2|."""
    n = np.cross(h1, h2)
    return float(abs((p2 - p1) @ n) / np.linalg.norm(n))


def sweep(robot, chain):
    """Over POSES random in-limit configurations: (methods, families, worst Pinocchio miss, found, most rows).

    "most rows": the most distinct rows of one pose with their 2 pi aliases (joints within +-6.2 rad) taken as one.
    """
    methods, families, worst, found, rows = set(), set(), 0.0, 0, 0
    for q in chain.sample(POSES, seed=36):
        T = chain.fk(q)
        result = manipkit.ik(robot, T, base=chain.base, tip=chain.tip, all=True)
        methods.add(result.method)
        families.add(result.arm_family)
        rows = max(rows, len(np.unique(np.round(wrapped(result.solutions), 6), axis=0)))
        for s in result.solutions:
            worst = max(worst, float(np.abs(robot.transform(chain.base, chain.tip, s, check_limits=False) - T).max()))
        if len(result.solutions) and np.abs(wrapped(result.solutions - q)).max(axis=1).min() < 1e-7:
            found += 1
    return methods, families, worst, found, rows


@pytest.fixture(scope="module")
def ur5_rounded():
    return Robot.from_urdf(ur5_like_urdf())


@pytest.fixture(scope="module")
def wrist_rounded():
    return Robot.from_urdf(urdf_from_dh(wrist_table(6e-5)))


def test_the_rounded_ur5_is_off_parallel_by_the_rounding(ur5_rounded):
    chain = ur5_rounded.chain("base_link", "ee_link")
    axes = chain.axes(np.zeros(6))
    h = np.asarray(axes.direction)
    expected = math.pi / 2 - ROUNDED  # R_x(1.5708) (0, 0, -1) = (0, sin, -cos): cos(1.5708) = pi/2 - 1.5708 to 1e-18
    angle = math.atan2(float(np.linalg.norm(np.cross(h[1], h[2]))), abs(float(h[1] @ h[2])))
    assert abs(angle - abs(expected)) < 1e-12
    family = chain_family(chain)
    assert family.kind == "three parallel, two intersecting" and not family.ideal
    assert abs(family.deviation - abs(expected)) < 1e-12


def test_family_names_the_ur_family_and_states_the_snap(tmp_path):
    path = write(tmp_path, "ur5_rounded", ur5_like_urdf())
    text = run_cli("manipkit", "family", "--robot", str(path), status=0).stdout
    assert "family: three parallel, two intersecting" in text
    assert "axes 2, 3, 4 parallel, angle 3.67321e-06 rad" in text
    snap = [line for line in text.splitlines() if line.startswith("snap:")]
    assert len(snap) == 1 and "3.67321e-06 rad" in snap[0] and "axes 2, 3, 4" in snap[0], text
    out = json.loads(run_cli("manipkit", "family", "--robot", str(path), "--format", "json", status=0).stdout)
    assert out["family"] == "three parallel, two intersecting" and out["solved"]
    assert [s["axes"] for s in out["snap"]] == [[2, 3, 4]] and abs(out["snap"][0]["angle"] - 3.67321e-06) < 1e-11


def test_family_names_the_wrist_family_and_states_the_snap(tmp_path, wrist_rounded):
    chain = wrist_rounded.chain("base_link", "ee_link")
    axes = chain.axes(np.zeros(6))
    p, h = np.asarray(axes.point), np.asarray(axes.direction)
    assert abs(line_distance(p[3], h[3], p[4], h[4]) - 6e-5) < 1e-12  # the table's a_4: the wrist misses by 0.06 mm
    family = chain_family(chain)
    assert family.kind == "spherical wrist, two parallel" and not family.ideal
    wrist = family.evidence[0]
    # the common point is at least half the 0.06 mm from one of two lines that far apart, at most all of it
    assert wrist.axes == (4, 5, 6) and 3e-5 - 1e-12 <= wrist.miss <= 6e-5
    path = write(tmp_path, "wrist_rounded", urdf_from_dh(wrist_table(6e-5)))
    text = run_cli("manipkit", "family", "--robot", str(path), status=0).stdout
    assert "family: spherical wrist, two parallel" in text
    snap = [line for line in text.splitlines() if line.startswith("snap:")]
    assert len(snap) == 1 and "axes 4, 5, 6" in snap[0] and f"{wrist.miss:.6g} m" in snap[0], text


def test_an_exact_arm_states_no_snap():
    text = run_cli("manipkit", "family", "--robot", "ur5", "--tip", "tool0", status=0).stdout
    assert "snap: none" in text


@pytest.mark.parametrize("name", ["ur5_rounded", "wrist_rounded"])
def test_near_family_arms_answer_in_closed_form_on_the_true_chain(name, request):
    robot = request.getfixturevalue(name)
    chain = robot.chain("base_link", "ee_link")
    methods, families, worst, found, rows = sweep(robot, chain)
    assert methods == {"closed_form"}
    assert families == {chain_family(chain).kind}
    assert worst < 1e-10, f"a row misses the true chain by {worst:.3g}"
    assert found == POSES, f"{POSES - found} of {POSES} generating configurations missing"
    assert 1 <= rows <= 16  # the closed form's eight branches, and what the elimination adds (6R: 16 at most)


@pytest.mark.parametrize("name", ["ur5_5mm", "wrist_5mm"])
def test_arms_beyond_the_tolerance_go_to_the_general_solver(name):
    robot = Robot.from_urdf(ur5_like_urdf(5e-3) if name == "ur5_5mm" else urdf_from_dh(wrist_table(5e-3)))
    chain = robot.chain("base_link", "ee_link")
    family = chain_family(chain)
    assert family.kind == "none"  # never a wrong family
    assert FAMILY_TOL[0] < 5e-3
    methods, families, worst, found, rows = sweep(robot, chain)
    assert methods == {"algebraic"} and families == {"general 6R"}
    assert worst < 1e-10, f"a row misses by {worst:.3g}"
    assert found >= 0.999 * POSES, f"{POSES - found} of {POSES} generating configurations missing"
    assert 1 <= rows <= 16  # a 6R arm has 16 solutions at most


def test_a_branch_the_snapped_closed_form_misses_is_found_by_the_elimination():
    # The closed form is solved on the nearest ideal arm and each branch refined on the true chain; near a boundary
    # of the ideal arm's reach a branch of the true arm can be missing (about 1 pose in 200 on this arm, axes 5 and 6
    # 0.06 mm apart). Find such a pose by the closed form alone, then ask the dispatcher for every solution.
    robot = Robot.from_urdf(ur5_like_urdf(6e-5))
    chain = robot.chain("base_link", "ee_link")
    assert chain_family(chain).snap  # within the tolerance, not exact
    missed = None
    for q in chain.sample(3000, seed=7):
        T = chain.fk(q)
        alone = manipkit.ik(robot, T, all=True, method="closed_form", aliases=False)
        if not len(alone.solutions) or np.abs(wrapped(alone.solutions - q)).max(axis=1).min() > 1e-7:
            missed = q, T, alone
            break
    assert missed is not None, "no pose in 3000 where the closed form misses its generating configuration"
    q, T, alone = missed
    every = manipkit.ik(robot, T, all=True, aliases=False)
    assert every.method == "closed_form"
    assert np.abs(wrapped(every.solutions - q)).max(axis=1).min() < 1e-7  # found now
    assert every.solutions[: len(alone.solutions)].tolist() == alone.solutions.tolist()  # the closed form's rows first
    added = every.labels[len(alone.solutions):]
    assert added and "general 6R elimination" in every.note
    assert list(added) == (["found by elimination"] if len(added) == 1 else  # numbered apart when several
                           [f"found by elimination #{k}" for k in range(1, len(added) + 1)])
    for s in every.solutions:  # every row, old and new, lands on the true chain by Pinocchio
        assert np.abs(robot.transform("base_link", "ee_link", s, check_limits=False) - T).max() < 1e-10
    rows = np.round(wrapped(every.solutions), 6)
    assert len(np.unique(rows, axis=0)) == len(rows)  # no solution listed twice


def test_the_batch_on_a_snapped_arm_finds_every_solution_the_single_call_finds():
    # ik_many used to answer a snapped arm with the nearest ideal arm's rows unrefined (every slot off the true
    # chain by up to 1e-4 m on this arm: no target a success) and without the rows only the elimination finds
    robot = Robot.from_urdf(ur5_like_urdf(6e-5))
    chain = robot.chain("base_link", "ee_link")
    Q = chain.sample(200, seed=7)
    T = chain.fk(Q)
    batch = manipkit.ik_many(robot, T)
    assert batch.solutions.shape == (200, 16, 6) and bool(batch.success.all())
    by_elimination = 0
    for i, (q, target) in enumerate(zip(Q, T)):
        single = manipkit.ik(robot, target, all=True, aliases=False)
        filled = ~np.isnan(batch.solutions[i, :, 0])
        rows = batch.solutions[i][filled]
        names = [name for name, full in zip(batch.branch_labels(i), filled) if full]
        assert all(batch.branch_labels(i)[j] == "" for j in np.flatnonzero(~filled))  # empty slots have no name
        assert sorted(names) == sorted(single.labels)  # the batch keeps slot order, the single call its label order
        assert len(rows) == len(single.solutions)
        for s, label in zip(single.solutions, single.labels):  # every row of the single call, with its name
            j = int(np.argmin(np.abs(wrapped(rows - s)).max(axis=1)))
            assert np.abs(wrapped(rows[j] - s)).max() < 1e-9 and names[j] == label
        for s in rows:  # and every row of the batch lands on the true chain, by Pinocchio's FK
            assert np.abs(robot.transform("base_link", "ee_link", s, check_limits=False) - target).max() < 1e-10
        assert np.abs(wrapped(rows - q)).max(axis=1).min() < 1e-7  # the generating configuration among them
        by_elimination += any(label.startswith("found by elimination") for label in single.labels)
    assert by_elimination  # the sample holds targets where the elimination adds rows the closed form misses
