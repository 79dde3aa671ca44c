"""``manipkit collisions`` and ``acm`` with the SRDF the robot ships and the meshes by default (issue 38).

Every expected contact and distance is computed here with Pinocchio's
geometry loader and coal called directly (``coal.collide``,
``coal.distance`` on the objects Pinocchio places), every expected SRDF pair
read from the SRDF with a regular expression; adjacency is worked out here
from the URDF's joints (links without geometry passed through, as MoveIt's
Setup Assistant does).
"""

import json
import re
import xml.etree.ElementTree as ET
from pathlib import Path

import coal
import numpy as np
import pinocchio as pin
import pytest
from cli_helper import run_cli

import manipkit
from manipkit.description.sources import example_robot_data_dir

ERD = example_robot_data_dir()
WS_NEW = Path("/work/shared/realworld/ws_new/src")
OMY = WS_NEW / "open_manipulator/open_manipulator_description/urdf/omy_3m/omy_3m.urdf.xacro"
OMY_SRDF = WS_NEW / "open_manipulator/open_manipulator_moveit_config/config/omy_3m/omy_3m.srdf"
PAIR = re.compile(r"<disable_collisions\s+link1=\"([^\"]+)\"\s+link2=\"([^\"]+)\"(?:\s+reason=\"([^\"]*)\")?")


def _srdf_pairs(path) -> dict:
    return {tuple(sorted((a, b))): reason for a, b, reason in PAIR.findall(Path(path).read_text())}


def _robot(name):
    return manipkit.load(OMY, prefix="") if name == "omy_3m" else manipkit.load(name)


def _omy_args(name):
    return ["--robot", OMY, "--arg", "prefix:="] if name == "omy_3m" else ["--robot", name]


class Direct:
    """A robot's collision objects as Pinocchio loads them (meshes as coal BVH models), checked with coal here."""

    def __init__(self, robot):
        self.robot = robot
        self.geom = pin.buildGeomFromUrdfString(robot.model, robot.urdf, pin.GeometryType.COLLISION,
                                                package_dirs=[str(ERD.parent)])
        self.link = [robot.model.frames[o.parentFrame].name for o in self.geom.geometryObjects]
        root = ET.fromstring(robot.urdf)
        parent = {j.find("child").get("link"): j.find("parent").get("link") for j in root.findall("joint")}
        with_geometry = set(self.link)
        self.adjacent = set()
        for link in with_geometry:
            up = parent.get(link)
            while up is not None and up not in with_geometry:
                up = parent.get(up)
            if up is not None:
                self.adjacent.add(tuple(sorted((link, up))))
        joint_of = {}
        for o, link in zip(self.geom.geometryObjects, self.link):
            joint_of.setdefault(link, set()).add(o.parentJoint)
        self.rigid = {tuple(sorted((a, b))) for a in joint_of for b in joint_of if a != b
                      and len(joint_of[a] | joint_of[b]) == 1}

    def pairs(self, disabled=()):
        names = sorted(set(self.link))
        return [(a, b) for i, a in enumerate(names) for b in names[i + 1:]
                if (a, b) not in self.adjacent and (a, b) not in self.rigid and (a, b) not in disabled]

    def _placed(self, q):
        data, gdata = self.robot.model.createData(), self.geom.createData()
        pin.updateGeometryPlacements(self.robot.model, data, self.geom, gdata, self.robot.pinocchio_configuration(q))
        return [(o.geometry, coal.Transform3s(M.rotation, M.translation))
                for o, M in zip(self.geom.geometryObjects, gdata.oMg)]

    def contacts(self, q, pairs, *, hulls=False) -> set:
        placed = self._placed(q)
        found = set()
        for i, (gi, Ti) in enumerate(placed):
            for j, (gj, Tj) in enumerate(placed):
                key = tuple(sorted((self.link[i], self.link[j])))
                if i < j and key in pairs:
                    if hulls:
                        gi, gj = _hull(gi), _hull(gj)
                    result = coal.CollisionResult()
                    if coal.collide(gi, Ti, gj, Tj, coal.CollisionRequest(), result):
                        found.add(key)
        return found

    def distance(self, q, a, b) -> float:
        placed = self._placed(q)
        best = np.inf
        for i, (gi, Ti) in enumerate(placed):
            for j, (gj, Tj) in enumerate(placed):
                if (self.link[i], self.link[j]) == (a, b):
                    result = coal.DistanceResult()
                    best = min(best, coal.distance(gi, Ti, gj, Tj, coal.DistanceRequest(), result))
        return best


def _hull(geometry):
    if isinstance(geometry, coal.BVHModelOBBRSS):
        geometry.buildConvexHull(True, "Qt")
        return geometry.convex
    return geometry


@pytest.mark.parametrize("name, srdf", [
    ("panda", ERD / "robots/panda_description/srdf/panda.srdf"),
    ("kinova", ERD / "robots/kinova_description/srdf/kinova.srdf"),
    pytest.param("omy_3m", OMY_SRDF, marks=pytest.mark.skipif(not OMY.is_file(), reason="no shared ws_new")),
])
def test_collisions_at_home_use_the_shipped_srdf_and_the_meshes(name, srdf):
    robot = _robot(name)
    answer = json.loads(run_cli("manipkit", "collisions", *_omy_args(name), "--format", "json", status=0).stdout)
    assert answer["srdf"] == str(srdf) and answer["geometry"] == "meshes"
    direct = Direct(robot)
    disabled = _srdf_pairs(srdf)
    contacts = direct.contacts(robot.q(), set(direct.pairs(disabled)))
    # With SRDF pairs, the pairs it leaves are checked; the kinova's disables none, so (as MoveIt's Setup Assistant)
    # the pairs touching at home are left out and listed
    left_out = contacts if not disabled else set()
    assert {tuple(p) for p in answer["left_out_in_contact_at_home"]} == left_out
    assert answer["in_collision"] is bool(contacts - left_out) is False
    assert answer["checked_pairs"] == len(direct.pairs(disabled)) - len(left_out)
    text = run_cli("manipkit", "collisions", *_omy_args(name), status=0).stdout
    assert f"SRDF {srdf}: its {len(disabled)} <disable_collisions> pair" in text


def test_panda_without_srdf_leaves_out_the_pairs_touching_at_home_and_names_them():
    robot = manipkit.load("panda")
    direct = Direct(robot)
    touching = direct.contacts(robot.q(), set(direct.pairs()))
    assert len(touching) == 3  # panda_link5 - panda_link7, panda_hand - panda_link5, the fingers (meshes)
    text = run_cli("manipkit", "collisions", "--robot", "panda", "--srdf", "none", status=0).stdout
    line = next(x for x in text.splitlines() if x.startswith("no SRDF: "))
    named = set(tuple(sorted(p.split(" - "))) for p in line.split("(", 1)[1].rstrip(")").split(", "))
    assert named == touching and "the 3 pairs in contact at the home configuration" in line
    assert text.startswith(f"robot panda: collision-free ({len(direct.pairs()) - 3} link pairs checked, meshes")


def test_the_hull_contact_the_meshes_do_not_have_is_said_with_both_numbers():
    # The Jaco2 at its home pose: links 2 and 4 overlap as hulls and are 14 mm apart as meshes (issue 38)
    robot = manipkit.load("kinova")
    direct = Direct(robot)
    pair = ("j2s6s200_link_2", "j2s6s200_link_4")
    assert direct.contacts(robot.q(), {pair}, hulls=True) == {pair} and direct.contacts(robot.q(), {pair}) == set()
    apart = direct.distance(robot.q(), *pair)
    assert 0.013 < apart < 0.015
    text = run_cli("manipkit", "collisions", "--robot", "kinova", status=0).stdout
    assert text.startswith("robot kinova: collision-free")
    assert re.search(rf"  {pair[0]} - {pair[1]}: in contact with hulls \(penetration 0\.\d+ m\); "
                     rf"{1000 * apart:.1f} mm apart with meshes", text)
    # With hulls and no SRDF pairs (kinova.srdf disables none), the pair touches at home and is left out, and said
    hulls = run_cli("manipkit", "collisions", "--robot", "kinova", "--geometry", "hulls", status=0).stdout
    left_out = next(x for x in hulls.splitlines() if x.startswith("no SRDF pairs: "))
    assert f"{pair[0]} - {pair[1]}" in left_out and hulls.startswith("robot kinova: collision-free")


@pytest.mark.parametrize("name, srdf", [
    ("panda", ERD / "robots/panda_description/srdf/panda.srdf"),
    pytest.param("omy_3m", OMY_SRDF, marks=pytest.mark.skipif(not OMY.is_file(), reason="no shared ws_new")),
])
def test_acm_is_compared_with_the_shipped_srdf_pair_by_pair(tmp_path, name, srdf):
    samples = 10_000 if name == "panda" else 2000  # the panda's rarest pair (link2 - link6) needs MoveIt's 10,000
    out = tmp_path / "ours.srdf"
    text = run_cli("manipkit", "acm", *_omy_args(name), "-o", out, "--samples", str(samples), status=0).stdout
    ours, theirs = _srdf_pairs(out), _srdf_pairs(srdf)
    robot = _robot(name)
    direct = Direct(robot)
    names = sorted(set(direct.link))
    everything = [(a, b) for i, a in enumerate(names) for b in names[i + 1:]]
    differ = [p for p in everything if (p in ours) != (p in theirs)]
    same = sum(1 for p in everything if p in ours and p in theirs and ours[p] == theirs[p])
    assert (f"compared with SRDF {srdf}: {len(everything) - len(differ)} of {len(everything)} pairs agree (disabled in "
            f"both or checked in both; {same} disabled for the same reason)") in text
    Q = robot.sample_q(samples, seed=0)  # the samples acm checks (seed 0, its default)
    for a, b in differ:
        line = next(x for x in text.splitlines() if x.startswith(f"  {a} - {b}: "))
        if (a, b) in ours:
            assert line == (f"  {a} - {b}: ours {ours[(a, b)]}, theirs checked: "
                            + {"Never": f"in contact in none of {samples} samples with meshes",
                               "Default": "in contact at the home configuration with meshes"}[ours[(a, b)]])
        else:
            count = sum(bool(direct.contacts(q, {(a, b)})) for q in Q)
            assert 0 < count < 0.95 * samples
            assert line == (f"  {a} - {b}: ours checked, theirs {theirs[(a, b)]}: in contact in {count} of {samples} "
                            "samples with meshes, so not Never")
    if name == "panda":
        assert differ == []  # Franka's matrix, made with these meshes, is ours pair by pair


TM5 = WS_NEW / "tmr_ros1/tm_description/xacro/tm5-900.urdf.xacro"


@pytest.mark.skipif(not TM5.is_file(), reason="the shared workspace ws_new is not on this machine")
def test_an_arm_whose_collision_meshes_are_not_shipped_is_refused_in_one_line():
    # ws_new's tm_description ships the TM5-900's xacro but not its meshes/ folder: the URDF's first collision mesh
    # (link_0's, read here from the expanded URDF by a regular expression) resolves to a path that does not exist
    urdf = manipkit.load(TM5).urdf
    mesh = re.search(r"<collision>.*?<mesh\s+filename=\"package://tm_description/([^\"]+)\"", urdf, re.S).group(1)
    resolved = TM5.parents[1] / mesh
    assert not resolved.exists()
    result = run_cli("manipkit", "collisions", "--robot", TM5, status=2)
    line, = result.stderr.strip().splitlines()
    assert "collision geometry unavailable" in line and "'link_0'" in line and str(resolved) in line
    assert "does not exist" in line and not result.stdout
