"""Real ROS description packages as their users keep them: the file path alone gives the right poses.

The shared catkin-style workspace ``shared/realworld/ws_ros1`` (beside the
repository; CI clones only the repository, so these tests skip there) holds
four public packages with their xacro, YAML and package.xml files (meshes left
out). Each is loaded with its file path and nothing else, and every link's
pose is compared with an FK composed independently of manipkit: the xacro
package expands the file with ``$(find PKG)`` answered from a package map
built here (each ``package.xml``'s ``<name>``), and yourdfpy (which follows
mimic joints) composes the chain. Joint values are drawn inside yourdfpy's
limits and given to manipkit by name.

Links moved by a mimic joint (the Franka and PR2 fingers) are compared on
their own, as are the independent joints manipkit lists (yourdfpy's actuated
joints).
"""

from __future__ import annotations

import io
import json
import re
import warnings
from contextlib import redirect_stderr, redirect_stdout
from pathlib import Path

import numpy as np
import pytest
import yourdfpy
from cli_helper import run_cli

import manipkit

# shared/ sits beside the repository (CI, /work/main) or beside the folder of worktrees
REALWORLD = next((base / "shared" / "realworld" / "ws_ros1" for base in Path(__file__).resolve().parents[2:4]
                  if (base / "shared" / "realworld").is_dir()), Path("/nonexistent"))
SRC = REALWORLD / "src"
pytestmark = pytest.mark.skipif(not SRC.is_dir(), reason=f"the shared real-world workspace is not here ({SRC})")

#: name -> (top-level file below src/, xacro arguments, (source, target) for a command-line check)
ROBOTS = {
    "ur5e": ("universal_robot/ur_description/urdf/ur5e.xacro", {}, ("base_link", "tool0")),
    "panda": ("franka_ros/franka_description/robots/panda/panda.urdf.xacro", {"hand": "true"},
              ("panda_link0", "panda_hand")),
    "pr2": ("pr2_common/pr2_description/robots/pr2.urdf.xacro", {}, ("base_link", "r_gripper_palm_link")),
    "abb_irb2400": ("abb/abb_irb2400_support/urdf/irb2400.xacro", {}, ("base_link", "tool0")),
}
WITH_MIMIC = {"panda", "pr2"}  # Franka's second finger; PR2's gripper fingers and fingertips
CONFIGURATIONS = 5  # random in-limit configurations per robot, besides zero
TOLERANCE = 1e-9


# --------------------------------------------------------------------------
# The independent side: our own package map, the xacro package, yourdfpy
# --------------------------------------------------------------------------


def package_map(src: Path) -> dict[str, Path]:
    """Every ``package.xml`` below ``src`` by its ``<name>`` (the workspace has no nested or ignored packages)."""
    packages = {}
    for manifest in sorted(src.rglob("package.xml")):
        name = re.search(r"<name>\s*([^<\s]+)\s*</name>", manifest.read_text()).group(1)
        packages[name] = manifest.parent
    return packages


def xacro_itself(path: Path, args: dict[str, str], packages: dict[str, Path]) -> str:
    """URDF text as the xacro package makes it, ``$(find PKG)`` answered from ``packages``."""
    import xacro
    import xacro.substitution_args as substitution_args

    with pytest.MonkeyPatch.context() as patch:
        patch.setattr(substitution_args, "_eval_find", lambda name: str(packages[name]))
        xacro.all_includes.clear()
        with redirect_stdout(io.StringIO()), redirect_stderr(io.StringIO()):
            return xacro.process_file(str(path), mappings=dict(args)).toxml()


class Reference:
    """One robot as yourdfpy composes it: actuated joints, limits, and which links move with a mimic joint."""

    def __init__(self, urdf_text: str):
        self.urdf = yourdfpy.URDF.load(io.StringIO(urdf_text), build_scene_graph=True, load_meshes=False,
                                       build_collision_scene_graph=False)
        self.actuated = list(self.urdf.actuated_joint_names)  # mimic joints are not among them
        joints = {joint.child: joint for joint in self.urdf.robot.joints}
        self.root = self.urdf.base_link
        self.links = [link.name for link in self.urdf.robot.links]
        self.behind_mimic = set()
        for link in self.links:
            walk = link
            while walk in joints:
                if joints[walk].mimic is not None:
                    self.behind_mimic.add(link)
                    break
                walk = joints[walk].parent

    def limits(self, name: str) -> tuple[float, float]:
        joint = self.urdf.joint_map[name]
        if joint.type == "continuous" or joint.limit is None or joint.limit.lower is None:
            return -np.pi, np.pi
        return max(joint.limit.lower, -np.pi), min(joint.limit.upper, np.pi)

    def configurations(self, seed: int) -> list[dict[str, float]]:
        """Zero, then random values inside the limits, by actuated joint name."""
        rng = np.random.default_rng(seed)
        zero = {name: 0.0 for name in self.actuated}
        return [zero] + [{name: float(rng.uniform(*self.limits(name))) for name in self.actuated}
                         for _ in range(CONFIGURATIONS)]

    def pose(self, configuration: dict[str, float], source: str, target: str) -> np.ndarray:
        """T_source_target."""
        self.urdf.update_cfg(configuration)
        return self.urdf.get_transform(target, source)


@pytest.fixture(scope="module")
def packages() -> dict[str, Path]:
    return package_map(SRC)


@pytest.fixture(scope="module")
def loaded(packages):
    """name -> (manipkit Robot from the file path alone, yourdfpy Reference), each built once."""
    cache = {}

    def get(name: str):
        if name not in cache:
            relative, args, _ = ROBOTS[name]
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")  # ur_description is also in example-robot-data: one warning
                robot = manipkit.load(SRC / relative, **args)
            cache[name] = (robot, Reference(xacro_itself(SRC / relative, args, packages)))
        return cache[name]

    return get


def manipkit_q(robot, configuration: dict[str, float]) -> np.ndarray:
    """yourdfpy's actuated values by name, in ``robot.joint_names`` order (the same joints: checked by a test)."""
    return np.array([configuration[name] for name in robot.joint_names])


def _compare(robot, reference: Reference, links: list[str], seed: int) -> None:
    for index, configuration in enumerate(reference.configurations(seed)):
        q = manipkit_q(robot, configuration)
        for link in links:
            expected = reference.pose(configuration, reference.root, link)
            actual = robot.transform(robot.root_link, link, q, check_limits=False)
            np.testing.assert_allclose(actual, expected, atol=TOLERANCE, rtol=0,
                                       err_msg=f"{link} at configuration {index}: {configuration}")


# --------------------------------------------------------------------------
# Every link, zero and random configurations, against yourdfpy
# --------------------------------------------------------------------------


@pytest.mark.parametrize("name", list(ROBOTS))
def test_every_link_not_moved_by_a_mimic_joint_matches_yourdfpy(name, loaded):
    robot, reference = loaded(name)
    assert robot.root_link == reference.root
    assert set(reference.links) <= set(robot.frame_names)
    assert set(reference.actuated) <= set(robot.joint_names)
    links = [link for link in reference.links if link not in reference.behind_mimic]
    assert len(links) > 5
    _compare(robot, reference, links, seed=13)


@pytest.mark.parametrize("name", [n for n in ROBOTS if n in WITH_MIMIC])
def test_every_link_moved_by_a_mimic_joint_matches_yourdfpy(name, loaded):
    robot, reference = loaded(name)
    links = sorted(reference.behind_mimic)
    assert links  # panda_rightfinger; PR2's right fingers and both fingertips of each gripper
    _compare(robot, reference, links, seed=14)


@pytest.mark.parametrize("name", list(ROBOTS))
def test_the_joint_names_are_yourdfpys_actuated_joints(name, loaded):
    robot, reference = loaded(name)
    assert sorted(robot.joint_names) == sorted(reference.actuated)


def test_the_workspace_holds_the_four_packages_and_their_dependencies(packages):
    assert set(packages) == {"ur_description", "franka_description", "pr2_description", "abb_irb2400_support",
                             "abb_resources"}


# --------------------------------------------------------------------------
# tf-between with the file path only
# --------------------------------------------------------------------------


def tf_between(source: str, target: str, path: Path, *args: str) -> np.ndarray:
    result = run_cli("tf-between", source, target, "--robot", path, "--format", "json", "--precision", "15", *args)
    assert result.returncode == 0, result.stderr
    assert all(line.startswith("warning: ") for line in result.stderr.splitlines()), result.stderr
    return np.array(json.loads(result.stdout)["matrix"])


def _arg_options(args: dict[str, str]) -> list[str]:
    return [option for key, value in args.items() for option in ("--arg", f"{key}:={value}")]


@pytest.mark.parametrize("name", list(ROBOTS))
def test_tf_between_with_the_file_path_only_matches_yourdfpy(name, loaded):
    relative, args, (source, target) = ROBOTS[name]
    robot, reference = loaded(name)
    configuration = reference.configurations(seed=15)[1]
    given = {joint: value for joint, value in configuration.items() if joint in robot.chain_joints(source, target)}
    assert given  # the chain has joints, and their values are not all zero
    T = tf_between(source, target, SRC / relative, *_arg_options(args),
                   "--q", *(f"{joint}={value!r}" for joint, value in given.items()))
    expected = reference.pose({**{j: 0.0 for j in reference.actuated}, **given}, source, target)
    np.testing.assert_allclose(T, expected, atol=TOLERANCE, rtol=0)


def test_franka_right_finger_follows_the_left_one():
    # panda_finger_joint2 (hand -> right finger): origin (0, 0, 0.0584), axis (0, -1, 0), mimics finger_joint1
    # with multiplier 1, offset 0; so with finger_joint1 = 0.03 the right finger sits at (0, -0.03, 0.0584).
    relative, args, _ = ROBOTS["panda"]
    T = tf_between("panda_hand", "panda_rightfinger", SRC / relative, *_arg_options(args),
                   "--q", "panda_finger_joint1=0.03")
    expected = np.eye(4)
    expected[:3, 3] = [0.0, -0.03, 0.0584]
    np.testing.assert_allclose(T, expected, atol=TOLERANCE, rtol=0)


def test_pr2_gripper_fingertip_follows_the_finger_joint(loaded):
    # l_gripper_r_finger_tip_link hangs below l_gripper_r_finger_joint and l_gripper_r_finger_tip_joint,
    # both mimicking l_gripper_l_finger_joint: its pose in the palm changes with that one value.
    relative, _, _ = ROBOTS["pr2"]
    _, reference = loaded("pr2")
    T = tf_between("l_gripper_palm_link", "l_gripper_r_finger_tip_link", SRC / relative,
                   "--q", "l_gripper_l_finger_joint=0.4")
    expected = reference.pose({**{j: 0.0 for j in reference.actuated}, "l_gripper_l_finger_joint": 0.4},
                              "l_gripper_palm_link", "l_gripper_r_finger_tip_link")
    closed = reference.pose({j: 0.0 for j in reference.actuated}, "l_gripper_palm_link", "l_gripper_r_finger_tip_link")
    assert np.linalg.norm(expected[:3, 3] - closed[:3, 3]) > 0.01  # the check can fail: the tip really moves
    np.testing.assert_allclose(T, expected, atol=TOLERANCE, rtol=0)
