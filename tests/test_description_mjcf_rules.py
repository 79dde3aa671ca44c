"""An MJCF robot's default allowed collisions: MuJoCo's contact filter, checked against MuJoCo's own answer.

The independent answer is MuJoCo's ``mj_collision``: every geom margin (and
body margin, which its broad phase reads, and pair margin) is set to 1 km, so
that every geom pair MuJoCo's filter lets through is "in contact" at any
configuration; the body pairs of the contacts ``mj_forward`` then finds are the
pairs MuJoCo tests. The models are compiled by MuJoCo from the files directly
(``MjSpec``; the Menagerie copies carry no meshes, so each mesh geom becomes a
small sphere with its contype/conaffinity, which keeps the filter's input).
manipkit's disabled pairs must be exactly the colliding bodies' pairs MuJoCo
leaves out, pair by pair, and a small model written here has its answer
derived by hand as well.
"""

from __future__ import annotations

import glob
import itertools
import json
from pathlib import Path

import mujoco
import pytest
from cli_helper import run_cli

import manipkit
from manipkit.description.mjcf import mjcf_disabled_pairs, rules_source_text
from manipkit.errors import CollisionError
from manipkit.kinematics.collisions import CollisionChecker

MENAGERIE = next((base / "shared" / "realworld" / "menagerie" for base in Path(__file__).resolve().parents[2:4]
                  if (base / "shared" / "realworld" / "menagerie").is_dir()), Path("/nonexistent"))
ARMS = sorted(glob.glob(str(MENAGERIE / "*" / "*.xml")))
needs_menagerie = pytest.mark.skipif(not ARMS, reason="the shared Menagerie copies are not here")
#: Arms whose collision geoms are primitives (panda's and xarm7's are meshes, absent here).
PRIMITIVE_ARMS = [p for p in ARMS if Path(p).stem in ("iiwa14", "sawyer", "ur5e")]


def mujoco_model(path) -> mujoco.MjModel:
    """MuJoCo's model of ``path``, each mesh geom a 1 cm sphere (no mesh files here), mesh assets deleted."""
    spec = mujoco.MjSpec.from_file(str(path))
    for geom in spec.geoms:
        if geom.type == mujoco.mjtGeom.mjGEOM_MESH:
            geom.type = mujoco.mjtGeom.mjGEOM_SPHERE
            geom.size = [0.01, 0.0, 0.0]
            geom.meshname = ""
    for mesh in list(spec.meshes):
        spec.delete(mesh)
    return spec.compile()


def body_name(model, b: int) -> str:
    return model.body(b).name or f"body{b}"


def mujoco_tested_pairs(model) -> set[tuple[str, str]]:
    """The body pairs (sorted names) MuJoCo's collision filter tests: its contacts with 1 km margins."""
    model.geom_margin[:] = 1000.0
    model.geom_gap[:] = 0.0
    model.body_margin[:] = 1000.0
    if model.npair:
        model.pair_margin[:] = 1000.0
        model.pair_gap[:] = 0.0
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    names = [body_name(model, int(model.geom_bodyid[c.geom1])) for c in data.contact[:data.ncon]], \
        [body_name(model, int(model.geom_bodyid[c.geom2])) for c in data.contact[:data.ncon]]
    return {tuple(sorted(p)) for p in zip(*names)}


def colliding_body_pairs(model) -> set[tuple[str, str]]:
    """Every pair of bodies that have a geom with contype or conaffinity set, or named by a <pair>."""
    paired = set(model.pair_geom1) | set(model.pair_geom2)
    bodies = sorted({int(model.geom_bodyid[g]) for g in range(model.ngeom)
                     if model.geom_contype[g] or model.geom_conaffinity[g] or g in paired})
    return {tuple(sorted((body_name(model, a), body_name(model, b)))) for a, b in itertools.combinations(bodies, 2)}


@needs_menagerie
@pytest.mark.parametrize("path", ARMS, ids=lambda p: Path(p).stem)
def test_menagerie_disabled_pairs_are_the_pairs_mujoco_never_tests(path):
    robot = manipkit.load(path)
    assert robot.srdf is not None and robot.srdf.kind == "mjcf" and robot.srdf.path == Path(path)
    model = mujoco_model(path)
    everything, tested = colliding_body_pairs(model), mujoco_tested_pairs(mujoco_model(path))
    disabled = robot.srdf.pairs()
    assert set(disabled) <= everything
    assert everything - set(disabled) == tested, (everything - set(disabled)) ^ tested
    assert len(disabled) > 0 and len(tested) > 0


@needs_menagerie
@pytest.mark.parametrize("path", PRIMITIVE_ARMS, ids=lambda p: Path(p).stem)
def test_menagerie_checked_pairs_and_contacts_agree_with_mj_collision(path):
    robot = manipkit.load(path)
    tested = mujoco_tested_pairs(mujoco_model(path))
    checker = CollisionChecker(robot)  # the default: the MJCF's rules
    geometry = checker.geometry
    # manipkit checks what MuJoCo tests, less the adjacent links, which it never checks (MuJoCo's
    # filterparent already leaves those out on these arms, or an <exclude> does)
    expected = {p for p in tested if p[0] in geometry.link_names and p[1] in geometry.link_names}
    assert set(checker.pairs) == expected - set(geometry.adjacent)
    assert not expected & set(geometry.adjacent)
    # at random configurations, every pair MuJoCo finds penetrating is a pair manipkit finds in contact
    # (the shapes are the same primitives; a capsule is a cylinder with two spheres, exactly)
    model = mujoco_model(path)
    data = mujoco.MjData(model)
    seen = 0
    for q in robot.sample_q(300, seed=3):
        values = dict(zip(robot.joint_names, q))
        for j in range(model.njnt):
            data.qpos[model.jnt_qposadr[j]] = values[model.joint(j).name]
        mujoco.mj_forward(model, data)
        deep = {tuple(sorted((body_name(model, int(model.geom_bodyid[c.geom1])),
                              body_name(model, int(model.geom_bodyid[c.geom2])))))
                for c in data.contact[:data.ncon] if c.dist < -1e-4}
        assert deep <= tested
        found = checker.pairs_in_contact(q)
        assert deep <= found, (deep - found, q)
        seen += len(deep)
    assert seen > 0  # the configurations did bring pairs into contact


#: A model whose answer is derived by hand (test_hand_derived_rules): base is fixed to the world,
#: l1-l2-mid-l3 hinge down a chain (mid has no geom), l4 is welded to l3 and its only geom has
#: contype = conaffinity = 0 but is named by a <pair> with l2's; a and c are loose bodies with other bits.
RULES = """<mujoco><option>{flags}</option><worldbody>
  <body name="base"><geom name="gb" size=".05"/>
    <body name="l1" pos="0 0 .2"><joint name="j1"/><geom name="g1" size=".05"/>
      <body name="l2" pos="0 0 .2"><joint name="j2"/><geom name="g2" size=".05"/>
        <body name="mid" pos="0 0 .2"><joint name="j3"/><inertial pos="0 0 0" mass=".1" diaginertia=".001 .001 .001"/>
          <body name="l3" pos="0 0 .2"><joint name="j4"/><geom name="g3" size=".05"/>
            <body name="l4" pos="0 0 .1"><geom name="g4" size=".04" contype="0" conaffinity="0"/></body>
          </body></body></body></body></body>
  <body name="a" pos="1 0 0"><joint name="ja"/><geom name="ga" size=".05" contype="1" conaffinity="2"/></body>
  <body name="c" pos="2 0 0"><joint name="jc"/><geom name="gc" size=".05" contype="2" conaffinity="0"/></body>
</worldbody><contact><exclude body1="l1" body2="l3"/><pair geom1="g4" geom2="g2"/></contact></mujoco>"""

#: By hand, with MuJoCo's documented rule: contype/conaffinity 1/1 for base, l1, l2, l3; a 1/2; c 2/0; l4 0/0.
NEVER_MEET = ["base-l4", "base-c", "l1-l4", "l1-c", "l2-c", "l3-c", "a-l4", "c-l4"]  # no bit of one in the other


def _pairs(text):
    return {tuple(sorted(p.split("-"))) for p in text}


@pytest.mark.parametrize("flags, expected", [
    # base-l1: base is welded to the world, so filterparent does not apply (MuJoCo compares weld bodies,
    # never the world's); l2-l3: mid, l3's parent, sits between them; l2-l4: the <pair>
    ("", {**dict.fromkeys(_pairs(NEVER_MEET), "contype/conaffinity never meet"),
          ("l1", "l2"): "parent and child bodies", ("l1", "l3"): "<exclude> in the description",
          ("l3", "l4"): "rigidly attached (no joint between them)"}),
    ('<flag filterparent="disable"/>', {**dict.fromkeys(_pairs(NEVER_MEET), "contype/conaffinity never meet"),
                                        ("l1", "l3"): "<exclude> in the description",
                                        ("l3", "l4"): "rigidly attached (no joint between them)"}),
    ('<flag contact="disable"/>', None),  # nothing is tested: all 21 pairs of the 7 bodies
], ids=["default", "filterparent-off", "contact-off"])
def test_hand_derived_rules_and_mujocos_answer(tmp_path, flags, expected):
    path = tmp_path / "rules.xml"
    path.write_text(RULES.format(flags=flags))
    model = mujoco.MjModel.from_xml_path(str(path))
    disabled = mjcf_disabled_pairs(model)
    everything = colliding_body_pairs(model)
    assert len(everything) == 21
    if expected is None:
        assert set(disabled) == everything
    else:
        assert disabled == expected
    assert everything - set(disabled) == mujoco_tested_pairs(mujoco.MjModel.from_xml_path(str(path)))
    # the loaded robot takes them as its default, and l4's paired geom is collision geometry
    robot = manipkit.load(path)
    assert robot.srdf.pairs() == disabled
    assert "l4" in CollisionChecker(robot, srdf="none").geometry.link_names


def test_cli_names_the_mjcf_rules_and_srdf_overrides(tmp_path):
    path = tmp_path / "rules.xml"
    path.write_text(RULES.format(flags=""))
    result = run_cli("manipkit", "collisions", "--robot", str(path))
    assert result.returncode == 0, result.stderr
    out = result.stdout
    assert ("allowed pairs: the MJCF's contype/conaffinity and <exclude> rules (rules.xml): the 11 pairs MuJoCo "
            "never tests are not checked") in out
    result = run_cli("manipkit", "collisions", "--robot", str(path), "--format", "json")
    assert result.returncode == 0, result.stderr
    answer = json.loads(result.stdout)
    assert answer["srdf"] == str(path) and answer["srdf_kind"] == "mjcf" and answer["disabled_pairs"] == 11
    robot = manipkit.load(path)
    ours = CollisionChecker(robot).pairs
    assert answer["checked_pairs"] == len(ours)
    # --srdf none: every pair but adjacent and rigid ones; home contacts left out as MoveIt's Setup Assistant does
    result = run_cli("manipkit", "collisions", "--robot", str(path), "--srdf", "none")
    assert result.returncode == 0, result.stderr
    out = result.stdout
    assert "no SRDF: not checked" in out and "MJCF" not in out
    # --srdf FILE: that SRDF's pairs instead
    srdf = tmp_path / "r.srdf"
    srdf.write_text('<robot name="rules"><disable_collisions link1="a" link2="c" reason="User"/></robot>')
    result = run_cli("manipkit", "collisions", "--robot", str(path), "--srdf", str(srdf))
    assert result.returncode == 0, result.stderr
    out = result.stdout
    assert f"SRDF {srdf}: its 1 <disable_collisions> pair is not checked" in out
    result = run_cli("manipkit", "collisions", "--robot", str(path), "--srdf", str(srdf), "--format", "json")
    assert json.loads(result.stdout)["srdf_kind"] == "srdf"
    assert set(CollisionChecker(robot, srdf=str(srdf)).pairs) == set(CollisionChecker(robot, srdf="none").pairs) - {("a", "c")}
    # --srdf naming the MJCF itself is its rules (as the default)
    assert set(CollisionChecker(robot, srdf=str(path)).pairs) == set(ours)
    assert rules_source_text(str(path)) == "the MJCF's contype/conaffinity and <exclude> rules (rules.xml)"


def test_acm_compares_with_the_mjcf_rules(tmp_path):
    path = tmp_path / "rules.xml"
    path.write_text(RULES.format(flags=""))
    result = run_cli("manipkit", "acm", "--robot", str(path), "-o", str(tmp_path / "out.srdf"), "--samples", "200")
    assert result.returncode == 0, result.stderr
    out = result.stdout
    assert "compared with the MJCF's contype/conaffinity and <exclude> rules (rules.xml): " in out


def test_an_mjcf_of_another_robot_as_srdf_is_refused_in_one_line(tmp_path):
    path = tmp_path / "rules.xml"
    path.write_text(RULES.format(flags=""))
    other = tmp_path / "other.xml"
    other.write_text('<mujoco><worldbody><body name="x"><joint/><geom size=".1"/><body name="y"><joint/>'
                     '<geom size=".1"/></body></body></worldbody></mujoco>')
    with pytest.raises(CollisionError, match=r"other.xml: the pair its contact rules disable, number 1 names link 'x'"):
        CollisionChecker(manipkit.load(path), srdf=str(other))
