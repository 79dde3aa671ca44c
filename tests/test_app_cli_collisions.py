"""``manipkit collisions`` and ``manipkit acm``: the real commands against the library and Pinocchio + coal.

Bad inputs (missing mesh, SRDF naming unknown links, malformed world files)
are in tests/bad_inputs/cases_collisions.yaml.
"""

import json
from pathlib import Path

import numpy as np
import pinocchio as pin
import pytest
from cli_helper import run_cli

import manipkit
from manipkit.kinematics.collisions import CollisionChecker, collisions, read_srdf

BAD = Path(__file__).parent / "bad_inputs" / "collisions"


@pytest.fixture(scope="module")
def panda():
    return manipkit.load("panda")


def direct_panda_contacts(robot, q) -> set:
    """Pairs in contact by Pinocchio + coal alone (meshes, every pair), limited to non-adjacent links."""
    share = robot.source.path.parents[4]
    geom = pin.buildGeomFromUrdf(robot.model, str(robot.source.path), pin.GeometryType.COLLISION,
                                 package_dirs=[str(share)])
    geom.addAllCollisionPairs()
    data, gdata = robot.model.createData(), geom.createData()
    pin.computeCollisions(robot.model, data, geom, gdata, robot.pinocchio_configuration(q), False)
    link = [robot.model.frames[obj.parentFrame].name for obj in geom.geometryObjects]
    srdf = read_srdf(robot.source.path.parents[1] / "srdf" / "panda.srdf", robot)
    pairs = {tuple(sorted((link[p.first], link[p.second])))
             for p, r in zip(geom.collisionPairs, gdata.collisionResults) if r.isCollision()}
    return {pair for pair in pairs if pair not in srdf and pair[0] != pair[1]}


@pytest.mark.parametrize("q, colliding", [
    # folded: joint 4 at its lower limit and joint 6 low bring the hand onto link 3 / link 4
    ([0, 0.2, 0, -3.0, 0, 0.1, 0, 0.02], True),
    ([0, -0.3, 0, -2.0, 0, 1.8, 0.8, 0.02], False),
])
def test_panda_json_agrees_with_pinocchio_and_coal(panda, q, colliding):
    srdf = panda.source.path.parents[1] / "srdf" / "panda.srdf"
    result = run_cli("manipkit", "collisions", "--robot", "panda", "--geometry", "meshes", "--srdf", srdf,
                     "--format", "json", "--q", *q, status=0)
    answer = json.loads(result.stdout)
    assert set(answer) >= {"in_collision", "pairs", "min_distance"}
    expected = direct_panda_contacts(panda, np.array(q, dtype=float))
    assert answer["in_collision"] is colliding is bool(expected)
    assert {tuple(sorted((p["link1"], p["link2"]))) for p in answer["pairs"]} == expected
    assert answer["q"]["panda_joint4"] == q[3]


def test_text_names_the_pairs_and_the_closest_one(panda):
    result = run_cli("manipkit", "collisions", "--robot", "panda", "--srdf", "none", "--geometry", "hulls",
                     "--q", "panda_joint4=-3", status=0)
    lines = result.stdout.splitlines()
    report = CollisionChecker(panda, srdf="none", skip_home_contacts=True).report({"panda_joint4": -3.0})
    assert report.checked == collisions(panda, srdf="none").checked - 3  # the 3 pairs touching at home left out
    assert lines[0] == (f"robot panda: IN COLLISION ({len(report.pairs)} pairs in contact; {report.checked} link "
                        "pairs checked, hulls geometry)")
    first = report.pairs[0]
    assert lines[1] == f"  {first.link1} - {first.link2}: penetration {-first.distance:.4f} m"
    assert f"closest pair: {first.link1} - {first.link2}, distance {first.distance:.4f} m" in lines
    assert result.stderr == ""


def test_floor_and_world_reach_the_check(tmp_path, course_arm):
    world = tmp_path / "world.yaml"
    # a ball 0.4 m along -y at z = 0.3: the arm turned down to the side (shoulder -90 deg, along -y at z 0.30) hits it
    world.write_text("obstacles:\n  - {name: ball, sphere: 0.05, xyz: [0, -0.4, 0.3]}\n")
    free = json.loads(run_cli("manipkit", "collisions", "--robot", "course_arm", "--world", world, "--floor", "0",
                              "--format", "json", status=0).stdout)
    assert not free["in_collision"]
    names = {free["min_distance"]["link1"], free["min_distance"]["link2"]}
    assert names & {"ball", "floor"}
    hit = json.loads(run_cli("manipkit", "collisions", "--robot", "course_arm", "--world", world, "--format", "json",
                             "--q", "shoulder_joint=-1.5708", status=0).stdout)
    assert hit["in_collision"] and any("ball" in (p["link1"], p["link2"]) for p in hit["pairs"])
    expected = collisions(course_arm, course_arm.q(shoulder_joint=-1.5708), world=world)
    assert [p["distance"] for p in hit["pairs"]] == [p.distance for p in expected.pairs]


def test_acm_writes_the_srdf_and_checks_it(tmp_path):
    out = tmp_path / "course_arm.srdf"
    result = run_cli("manipkit", "acm", "--robot", "course_arm", "-o", out, "--samples", "300", status=0)
    lines = result.stdout.splitlines()
    assert lines[0] == f"robot course_arm: 15 link pairs, 300 samples, meshes geometry; wrote {out}"
    assert lines[1].startswith("disabled: 5 Adjacent, ")
    assert lines[2].startswith("check: no enabled pair is in contact at the default pose")
    course_arm = manipkit.load("course_arm")
    disabled = read_srdf(out, course_arm)
    assert sum(reason == "Adjacent" for reason in disabled.values()) == 5
    assert not collisions(course_arm, srdf=out).in_collision
    # the file is read back everywhere: the collisions command takes it
    run_cli("manipkit", "collisions", "--robot", "course_arm", "--srdf", out, status=0)


def test_acm_writes_the_same_matrix_on_any_number_of_workers(tmp_path):
    outputs = []
    for workers in ("1", "2"):
        out = tmp_path / f"panda_{workers}.srdf"
        result = run_cli("manipkit", "acm", "--robot", "panda", "-o", out, "--samples", "4000", "--workers", workers,
                         status=0)
        outputs.append((result.stdout.replace(str(out), "OUT"), out.read_bytes()))
    assert outputs[0] == outputs[1]
    refused = run_cli("manipkit", "acm", "--robot", "panda", "-o", tmp_path / "x.srdf", "--workers", "0", status=2)
    assert refused.stderr.count("\n") == 1 and "--workers 0: give a whole number of threads from 1 to 64" in refused.stderr


def test_acm_of_a_robot_in_contact_at_its_default_pose_disables_those_pairs(tmp_path):
    # The Stanford arm's wrist parts meet at the wrist centre: those pairs are Default, and the check then holds.
    out = tmp_path / "stanford.srdf"
    run_cli("manipkit", "collisions", "--robot", "stanford_arm", status=0)  # in collision without a matrix
    assert collisions(manipkit.load("stanford_arm")).in_collision
    result = run_cli("manipkit", "acm", "--robot", "stanford_arm", "-o", out, "--samples", "200", status=0)
    assert "check: no enabled pair is in contact at the default pose" in result.stdout
    assert "Default" in out.read_text()



def test_an_srdf_that_leaves_pairs_touching_at_the_default_pose_is_warned_about(tmp_path, panda):
    # Franka's matrix without its 'Default' pair panda_hand - panda_link5: on hulls they touch at the default pose
    shipped = (panda.source.path.parents[1] / "srdf" / "panda.srdf").read_text()
    line = next(x for x in shipped.splitlines() if 'link1="panda_hand" link2="panda_link5"' in x
                or 'link1="panda_link5" link2="panda_hand"' in x)
    srdf = tmp_path / "edited.srdf"
    srdf.write_text(shipped.replace(line, ""))
    result = run_cli("manipkit", "collisions", "--robot", "panda", "--srdf", srdf, "--q", "panda_joint1=1",
                     "--geometry", "hulls", status=0)
    assert result.stderr == (f"warning: SRDF {srdf} leaves 1 pair in contact at the default pose with hulls geometry "
                             "(panda_link5 - panda_hand); was it made for other geometry? "
                             "`manipkit acm --geometry hulls` makes one for it\n")
    quiet = run_cli("manipkit", "collisions", "--robot", "panda", "--srdf", panda.source.path.parents[1] / "srdf" /
                    "panda.srdf", status=0)
    assert quiet.stderr == ""
