"""MuJoCo MJCF descriptions: every body and site where MuJoCo's own ``mj_kinematics`` puts it.

The independent answer is MuJoCo's: each test compiles the same file with
``mujoco.MjSpec`` (mesh geoms and their mesh assets deleted, since the
Menagerie copies carry no meshes and geoms do not move bodies), sets
``qpos`` in MuJoCo's joint order from the joint values by name, runs
``mj_kinematics`` and compares ``xpos``/``xmat`` and ``site_xpos``/``site_xmat``
with manipkit's pose of the link of that name in the world.
"""

from __future__ import annotations

import glob
import math
from pathlib import Path

import mujoco
import numpy as np
import pytest

import manipkit
from manipkit.description.mjcf import is_mjcf, mjcf_disabled_pairs, mjcf_files
from manipkit.errors import DescriptionError, ReadNotAllowedError

MENAGERIE = next((base / "shared" / "realworld" / "menagerie" for base in Path(__file__).resolve().parents[2:4]
                  if (base / "shared" / "realworld" / "menagerie").is_dir()), Path("/nonexistent"))
ARMS = sorted(glob.glob(str(MENAGERIE / "*" / "*.xml")))
needs_menagerie = pytest.mark.skipif(not ARMS, reason="the shared Menagerie copies are not here")


def mujoco_model(path) -> mujoco.MjModel:
    """MuJoCo's own model of ``path``, mesh geoms and mesh assets deleted (no mesh files here)."""
    spec = mujoco.MjSpec.from_file(str(path))
    for geom in list(spec.geoms):
        if geom.type == mujoco.mjtGeom.mjGEOM_MESH:
            spec.delete(geom)
    for mesh in list(spec.meshes):
        spec.delete(mesh)
    return spec.compile()


def random_qpos(model, rng) -> np.ndarray:
    qpos = model.qpos0.copy()
    for j in range(model.njnt):
        assert int(model.jnt_type[j]) in (mujoco.mjtJoint.mjJNT_HINGE, mujoco.mjtJoint.mjJNT_SLIDE)
        low, high = model.jnt_range[j] if model.jnt_limited[j] else (-math.pi, math.pi)
        qpos[model.jnt_qposadr[j]] = rng.uniform(low, high)
    return qpos


def assert_matches_mujoco(path, robot, model, qpos) -> float:
    """Largest difference (m, or matrix entry) between manipkit's frames and MuJoCo's at ``qpos``."""
    data = mujoco.MjData(model)
    data.qpos[:] = qpos
    mujoco.mj_kinematics(model, data)
    q = robot.q({model.joint(j).name: qpos[model.jnt_qposadr[j]] for j in range(model.njnt)})
    worst = 0.0
    frames = [(model.body(b).name, data.xpos[b], data.xmat[b]) for b in range(1, model.nbody)]
    frames += [(model.site(s).name, data.site_xpos[s], data.site_xmat[s]) for s in range(model.nsite)
               if model.site(s).name]
    for name, xpos, xmat in frames:
        T = robot.transform("world", name, q, check_limits=False)
        worst = max(worst, np.abs(T[:3, 3] - xpos).max(), np.abs(T[:3, :3] - xmat.reshape(3, 3)).max())
    return worst


@needs_menagerie
@pytest.mark.parametrize("path", ARMS, ids=[Path(p).name for p in ARMS])
def test_menagerie_arm_frames_agree_with_mj_kinematics(path):
    robot = manipkit.load(path)
    model = mujoco_model(path)
    assert set(robot.joint_names) == {model.joint(j).name for j in range(model.njnt)}
    assert {model.body(b).name for b in range(1, model.nbody)} <= set(robot.frame_names)
    rng = np.random.default_rng(38)
    worst = max(assert_matches_mujoco(path, robot, model, random_qpos(model, rng)) for _ in range(100))
    assert worst < 1e-12, worst


@needs_menagerie
def test_menagerie_arm_loads_with_missing_meshes_warned():
    robot = manipkit.load(MENAGERIE / "universal_robots_ur5e" / "ur5e.xml")
    # as for URDF: the first three missing files named, then a count (20 meshes, all missing)
    assert len(robot.mesh_warnings) == 4 and all("kinematics do not need meshes" in w for w in robot.mesh_warnings[:3])
    assert robot.mesh_warnings[3] == "ur5e.xml: 17 more mesh file(s) not found"
    assert robot.joint_names == ("shoulder_pan_joint", "shoulder_lift_joint", "elbow_joint", "wrist_1_joint",
                                 "wrist_2_joint", "wrist_3_joint")
    elbow = robot.joints[2]  # class size3_limited: range -3.1415 3.1415
    assert (elbow.lower, elbow.upper) == (-3.1415, 3.1415)


@needs_menagerie
def test_include_resolves_as_mujoco_resolves_it():
    scene = manipkit.load(MENAGERIE / "universal_robots_ur5e" / "scene.xml")
    arm = manipkit.load(MENAGERIE / "universal_robots_ur5e" / "ur5e.xml")
    q = arm.sample_q(1, seed=3)[0]
    np.testing.assert_allclose(scene.transform("world", "wrist_3_link", q),
                               arm.transform("world", "wrist_3_link", q), atol=1e-15)
    files = mjcf_files(MENAGERIE / "universal_robots_ur5e" / "scene.xml")
    assert [f.name for f in files] == ["scene.xml", "ur5e.xml"]


@needs_menagerie
def test_tool_sites_are_ee_link():
    assert manipkit.load(MENAGERIE / "kuka_iiwa_14" / "iiwa14.xml").ee_frame == "attachment_site"
    assert manipkit.load(MENAGERIE / "ufactory_xarm7" / "xarm7.xml").ee_frame == "link_tcp"
    ur5e = manipkit.load(MENAGERIE / "universal_robots_ur5e" / "ur5e.xml")
    assert (ur5e.ee_frame, ur5e.ee_reason.split(",")[1]) == ("wrist_3_link", " the tip of the longest chain (no tool frame named)")


# --------------------------------------------------------------------------
# What the compiler resolves, on small files written here
# --------------------------------------------------------------------------

FEATURES = """<mujoco model="features">
  <compiler angle="degree" eulerseq="zyx"/>
  <default>
    <default class="arm"><joint axis="0 1 0" range="-90 90"/><geom type="capsule" size="0.02 0.05"/></default>
  </default>
  <worldbody>
    <body name="base" pos="0.1 0.2 0.3" euler="10 20 30" childclass="arm">
      <joint name="j1" axis="0 0 1" ref="30"/>
      <geom/>
      <frame pos="0 0 0.2" axisangle="1 1 0 40">
        <body name="link2" xyaxes="0 1 0 -1 0 1">
          <joint name="j2" pos="0.05 0 0" ref="-15"/>
          <joint name="s2" type="slide" axis="1 0 0" range="-0.1 0.2" pos="0 0.03 0" ref="0.05"/>
          <geom type="box" size="0.01 0.02 0.03" contype="2" conaffinity="2"/>
          <body name="link3" pos="0 0 0.3" zaxis="0 1 1">
            <joint name="j3" type="hinge" axis="1 0 0" pos="0 0 -0.1" limited="false"/>
            <geom type="ellipsoid" size="0.01 0.02 0.04"/>
            <site name="pinch_site" pos="0 0 0.1" quat="0.5 0.5 0.5 0.5"/>
          </body>
        </body>
      </frame>
    </body>
    <body name="side" pos="1 0 0"><geom size="0.1" contype="4" conaffinity="4"/></body>
  </worldbody>
  <contact><exclude body1="base" body2="link3"/></contact>
</mujoco>
"""


@pytest.fixture
def features(tmp_path):
    path = tmp_path / "features.xml"
    path.write_text(FEATURES)
    return path


def test_degrees_eulerseq_frames_ref_and_offset_joints_agree_with_mj_kinematics(features):
    robot = manipkit.load(features)
    model = mujoco.MjModel.from_xml_path(str(features))
    rng = np.random.default_rng(0)
    assert max(assert_matches_mujoco(features, robot, model, random_qpos(model, rng)) for _ in range(100)) < 1e-12
    assert robot.ee_frame == "pinch_site"
    kinds = {j.name: j.type for j in robot.joints}
    assert kinds == {"j1": "revolute", "j2": "revolute", "s2": "prismatic", "j3": "continuous"}
    j1 = robot.joints[robot.joint_names.index("j1")]
    assert (j1.lower, j1.upper) == pytest.approx((-math.pi / 2, math.pi / 2), abs=1e-15)  # range in degrees


def test_joint_ref_is_the_value_at_the_written_pose(features):
    # at qpos = ref MuJoCo puts a body where the file writes it: MuJoCo's qpos0 is the same pose
    robot = manipkit.load(features)
    model = mujoco.MjModel.from_xml_path(str(features))
    data = mujoco.MjData(model)
    mujoco.mj_kinematics(model, data)
    q = robot.q(j1=math.radians(30), j2=math.radians(-15), s2=0.05)
    np.testing.assert_allclose(robot.transform("world", "link3", q)[:3, 3], data.xpos[model.body("link3").id],
                               atol=1e-15)


def test_geoms_become_collision_shapes_and_disabled_pairs(features):
    robot = manipkit.load(features)
    import xml.etree.ElementTree as ET

    root = ET.fromstring(robot.urdf)
    shapes = {link.get("name"): [c.find("geometry")[0].tag for c in link.findall("collision")]
              for link in root.iter("link")}
    assert shapes["base"] == ["cylinder", "sphere", "sphere"] and shapes["link2"] == ["box"] and shapes["link3"] == ["sphere"]
    link3 = next(link for link in root.iter("link") if link.get("name") == "link3")
    assert link3.find("collision/geometry/sphere").get("radius") == "0.04"  # the ellipsoid's largest semi-axis
    model = mujoco.MjModel.from_xml_path(str(features))
    # base 1/1 (contype/conaffinity), link2 2/2 its child, link3 1/1 link2's child and excluded with base,
    # side 4/4 on the world: side meets nobody's bits; base and link3 would meet, but <exclude> names them
    assert mjcf_disabled_pairs(model) == {
        ("base", "link2"): "parent and child bodies",
        ("base", "link3"): "<exclude> in the description",
        ("link2", "link3"): "parent and child bodies",
        ("base", "side"): "contype/conaffinity never meet",
        ("link2", "side"): "contype/conaffinity never meet",
        ("link3", "side"): "contype/conaffinity never meet",
    }


def test_free_joint_is_floating_pose_in_the_world(tmp_path):
    path = tmp_path / "free.xml"
    path.write_text('<mujoco><worldbody><body name="box" pos="1 2 3"><freejoint name="f"/><geom size=".1"/>'
                    '<body name="lid" pos="0 0 .2"><joint name="h" range="-1 1"/><geom size=".05"/></body>'
                    '</body></worldbody></mujoco>')
    robot = manipkit.load(path)
    model = mujoco.MjModel.from_xml_path(str(path))
    data = mujoco.MjData(model)
    quat = np.array([0.3, -0.2, 0.6, 0.5]) / np.linalg.norm([0.3, -0.2, 0.6, 0.5])
    data.qpos[:] = [0.4, -0.5, 0.6, *quat, 0.7]
    mujoco.mj_kinematics(model, data)
    from manipkit.spatial import rpy_from_matrix

    rpy = rpy_from_matrix(data.xmat[model.body("box").id].reshape(3, 3))
    q = robot.q(f=[0.4, -0.5, 0.6, *rpy], h=0.7)
    for body in ("box", "lid"):
        T = robot.transform("world", body, q, check_limits=False)
        b = model.body(body).id
        np.testing.assert_allclose(T[:3, 3], data.xpos[b], atol=1e-12)
        np.testing.assert_allclose(T[:3, :3], data.xmat[b].reshape(3, 3), atol=1e-12)


def test_ball_joint_is_refused_in_one_line(tmp_path):
    path = tmp_path / "ball.xml"
    path.write_text('<mujoco><worldbody><body name="b"><joint name="shoulder" type="ball"/><geom size=".1"/></body>'
                    '</worldbody></mujoco>')
    with pytest.raises(DescriptionError, match=r"ball.xml: joint 'shoulder' of body 'b' is a ball joint"):
        manipkit.load(path)


def test_compiler_error_names_the_file(tmp_path):
    path = tmp_path / "bad.xml"
    path.write_text('<mujoco><worldbody><body name="a"><joint range="1 -1" limited="true"/><geom size=".1"/>'
                    '</body></worldbody></mujoco>')
    with pytest.raises(DescriptionError, match=r"^bad.xml: MuJoCo compiler: range\[0\] should be smaller than "
                                               r"range\[1\] in joint Element name '', id 0, line 1$"):
        manipkit.load(path)


def test_include_outside_the_folder_is_refused_before_mujoco_reads_it(tmp_path):
    outside = tmp_path / "outside.xml"
    outside.write_text("<mujoco><worldbody/></mujoco>")
    (tmp_path / "robot").mkdir()
    path = tmp_path / "robot" / "arm.xml"
    path.write_text('<mujoco><include file="../outside.xml"/><worldbody/></mujoco>')
    with pytest.raises(ReadNotAllowedError, match=r"arm.xml:1: <include file=\"../outside.xml\">"):
        manipkit.load(path)
    assert manipkit.load(path, allow_read=tmp_path).frame_names == ("world",)


def test_a_mesh_file_present_is_placed_where_mujoco_puts_its_vertices(tmp_path):
    # an off-centre tetrahedron: MuJoCo re-centres it (mesh_pos, mesh_quat); the URDF mesh is the file itself,
    # so its pose must undo that: file vertices through the URDF visual origin == MuJoCo's vertices in the body
    vertices = np.array([[0.3, 0.1, 0.0], [0.5, 0.1, 0.0], [0.3, 0.4, 0.0], [0.3, 0.1, 0.25]])
    (tmp_path / "tet.obj").write_text("".join(f"v {x} {y} {z}\n" for x, y, z in vertices)
                                      + "f 1 3 2\nf 1 2 4\nf 1 4 3\nf 2 3 4\n")
    path = tmp_path / "mesh.xml"
    path.write_text('<mujoco><asset><mesh name="tet" file="tet.obj" scale="2 1 1"/></asset><worldbody>'
                    '<body name="b" pos="0 0 1"><joint name="j" range="-1 1"/>'
                    '<geom type="mesh" mesh="tet" pos="0.1 0 0" euler="0.3 0.2 0.1"/></body></worldbody></mujoco>')
    robot = manipkit.load(path)
    assert not robot.mesh_warnings
    model = mujoco.MjModel.from_xml_path(str(path))
    g = 0
    data = mujoco.MjData(model)
    mujoco.mj_kinematics(model, data)
    first, count = model.mesh_vertadr[0], model.mesh_vertnum[0]
    mujoco_world = data.geom_xpos[g] + model.mesh_vert[first:first + count] @ data.geom_xmat[g].reshape(3, 3).T
    from xml.etree import ElementTree as ET

    from manipkit.spatial import transform_from_xyz_rpy

    visual = ET.fromstring(robot.urdf).find("link[@name='b']/visual")
    origin = visual.find("origin")
    T_body_file = transform_from_xyz_rpy([float(v) for v in origin.get("xyz").split()],
                                         [float(v) for v in origin.get("rpy").split()])
    T_world_file = robot.transform("world", "b", robot.q()) @ T_body_file
    ours = (vertices * [2, 1, 1]) @ T_world_file[:3, :3].T + T_world_file[:3, 3]
    # MuJoCo may drop or reorder vertices: compare as sets of points
    assert len(mujoco_world) == len(ours)
    distances = np.linalg.norm(ours[:, None, :] - mujoco_world[None, :, :], axis=2).min(axis=1)
    assert distances.max() < 1e-6  # MuJoCo stores mesh vertices as float32 (about 6e-8 relative)


def test_is_mjcf_reads_the_root_element(tmp_path, features):
    urdf = tmp_path / "robot.xml"
    urdf.write_text('<robot name="r"><link name="a"/></robot>')
    assert is_mjcf(features) and not is_mjcf(urdf)
    assert manipkit.load(urdf).frame_names == ("a",)  # a URDF named .xml is read as URDF


def test_an_include_too_large_is_refused_before_anything_reads_it(tmp_path):
    from manipkit.errors import InputFileError
    from manipkit.inputs import MAX_DESCRIPTION_BYTES

    with open(tmp_path / "big.xml", "wb") as stream:
        stream.truncate(MAX_DESCRIPTION_BYTES + 1)  # sparse: no disk space taken
    path = tmp_path / "arm.xml"
    path.write_text('<mujoco>\n<include file="big.xml"/>\n<worldbody/></mujoco>')
    with pytest.raises(InputFileError, match=r"^arm.xml:2: <include file=\"big.xml\">: robot file .*big.xml is 67,108,865 bytes, above the limit"):
        manipkit.load(path)


@needs_menagerie
def test_warnings_name_the_mjcf_file_and_line_of_the_body():
    scene = manipkit.load(MENAGERIE / "universal_robots_ur5e" / "scene.xml")
    # line 64 of the included ur5e.xml: <body name="base" quat="1 0 0 1">
    assert scene.mesh_warnings[0].startswith("ur5e.xml:64: link 'base' mesh ")


def test_a_capsule_is_its_cylinder_and_two_spheres_at_mujocos_end_points(tmp_path):
    path = tmp_path / "capsule.xml"
    path.write_text('<mujoco><worldbody><body name="b"><joint name="j" range="-1 1"/>'
                    '<geom type="capsule" fromto="0.1 0.2 0.3 0.4 -0.1 0.5" size="0.03"/></body></worldbody></mujoco>')
    from xml.etree import ElementTree as ET

    from manipkit.spatial import transform_from_xyz_rpy

    link = ET.fromstring(manipkit.load(path).urdf).find("link[@name='b']")
    pieces = {}
    for collision in link.findall("collision"):
        origin, shape = collision.find("origin"), collision.find("geometry")[0]
        T = transform_from_xyz_rpy([float(v) for v in origin.get("xyz").split()],
                                   [float(v) for v in origin.get("rpy").split()])
        pieces.setdefault(shape.tag, []).append((T, shape.attrib))
    (T_cylinder, cylinder), = pieces["cylinder"]
    ends = sorted(tuple(T[:3, 3]) for T, _ in pieces["sphere"])
    # fromto: the capsule's segment runs from (0.1, 0.2, 0.3) to (0.4, -0.1, 0.5), radius 0.03
    np.testing.assert_allclose(ends, [(0.1, 0.2, 0.3), (0.4, -0.1, 0.5)], atol=1e-12)
    assert float(cylinder["radius"]) == 0.03 and all(float(a["radius"]) == 0.03 for _, a in pieces["sphere"])
    assert float(cylinder["length"]) == pytest.approx(math.dist((0.1, 0.2, 0.3), (0.4, -0.1, 0.5)), abs=1e-12)
    np.testing.assert_allclose(T_cylinder[:3, 3], (0.25, 0.05, 0.4), atol=1e-12)
    direction = np.subtract((0.4, -0.1, 0.5), (0.1, 0.2, 0.3)) / float(cylinder["length"])
    assert abs(T_cylinder[:3, 2] @ direction) == pytest.approx(1.0, abs=1e-12)  # its z axis along the segment


@needs_menagerie
def test_collision_geoms_give_mujocos_distances():
    # MuJoCo's mj_geomDistance over the same body pairs (colliding geoms, not parent and child) is the second
    # source; cylinders are convex shapes to both (GJK/EPA in coal and in MuJoCo), so they agree to about 1e-6
    from manipkit.kinematics.collisions import collisions

    path = MENAGERIE / "universal_robots_ur5e" / "ur5e.xml"
    robot, model = manipkit.load(path), mujoco_model(path)
    data = mujoco.MjData(model)
    colliding = [g for g in range(model.ngeom) if model.geom_contype[g] or model.geom_conaffinity[g]]
    for q in robot.sample_q(20, seed=7):
        data.qpos[:] = q
        mujoco.mj_kinematics(model, data)
        best = (math.inf, None)
        for g1 in colliding:
            for g2 in colliding:
                a, b = model.geom_bodyid[g1], model.geom_bodyid[g2]
                if a < b and model.body_parentid[b] != a:
                    distance = mujoco.mj_geomDistance(model, data, g1, g2, 10.0, None)
                    best = min(best, (distance, (model.body(a).name, model.body(b).name)))
        report = collisions(robot, q)
        assert sorted(best[1]) == sorted((report.min_distance.link1, report.min_distance.link2))
        assert abs(report.min_distance.distance - best[0]) < 1e-5, (best, report.min_distance)


def test_mujocos_contact_rules_are_an_allowed_collision_source(features):
    from manipkit.kinematics.collisions import CollisionChecker

    robot = manipkit.load(features)
    disabled = mjcf_disabled_pairs(features)
    everything = CollisionChecker(robot, srdf="none").pairs
    as_mujoco = CollisionChecker(robot, srdf=disabled).pairs
    # base-link3 and the three pairs with side would be checked; MuJoCo's rules leave out all four,
    # and they are the default of a robot loaded from MJCF
    assert set(everything) == {("base", "link3"), ("base", "side"), ("link2", "side"), ("link3", "side")}
    assert as_mujoco == () and CollisionChecker(robot).pairs == ()
    assert robot.srdf.kind == "mjcf" and robot.srdf.pairs() == disabled


def test_a_mesh_outside_the_folder_is_refused_unless_allowed(tmp_path):
    (tmp_path / "meshes").mkdir()
    (tmp_path / "meshes" / "tet.obj").write_text("v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\nf 1 3 2\nf 1 2 4\nf 1 4 3\nf 2 3 4\n")
    (tmp_path / "robot").mkdir()
    path = tmp_path / "robot" / "arm.xml"
    path.write_text('<mujoco><compiler meshdir="../meshes"/><asset><mesh name="tet" file="tet.obj"/></asset>'
                    '<worldbody><body name="b"><joint name="j" range="-1 1"/><geom type="mesh" mesh="tet"/></body>'
                    '</worldbody></mujoco>')
    with pytest.raises(ReadNotAllowedError, match=r"^arm.xml: mesh 'tet': .*tet.obj is outside what arm.xml may read"):
        manipkit.load(path)
    assert not manipkit.load(path, allow_read=tmp_path / "meshes").mesh_warnings
