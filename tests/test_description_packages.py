"""ROS package lookup like ROS (workspace, ROS_PACKAGE_PATH, AMENT_PREFIX_PATH, then built-ins) and ``--arg k:=v``."""

import io
import json
import os
import shutil
import warnings
from contextlib import redirect_stderr, redirect_stdout
from pathlib import Path

import numpy as np
import pytest
import yourdfpy
from cli_helper import run_cli

import manipkit
from manipkit.description import packages as packages_module
from manipkit.description.packages import PackageResolver, package_index, workspace_root
from manipkit.description.sources import example_robot_data_dir
from manipkit.errors import PackageNotFoundError

# shared/ sits beside the repository (CI, /work/main) or beside the folder of worktrees
REALWORLD = next((base / "shared" / "realworld" / "ws_ros1" for base in Path(__file__).resolve().parents[2:4]
                  if (base / "shared" / "realworld").is_dir()), Path("/nonexistent"))
UR5E = REALWORLD / "src" / "universal_robot" / "ur_description" / "urdf" / "ur5e.xacro"
XACRO = 'xmlns:xacro="http://www.ros.org/wiki/xacro"'


@pytest.fixture(autouse=True)
def no_ros_environment(monkeypatch):
    """Each test sets the ROS variables it needs; none leak in from the shell running the tests."""
    monkeypatch.delenv("ROS_PACKAGE_PATH", raising=False)
    monkeypatch.delenv("AMENT_PREFIX_PATH", raising=False)


def package(folder: Path, name: str, *, z: float = 0.5) -> Path:
    """A package in ``folder`` declaring ``name``, with ``urdf/arm.xacro`` (a macro ``arm``: tool at z)."""
    (folder / "urdf").mkdir(parents=True)
    (folder / "package.xml").write_text(f'<?xml version="1.0"?>\n<package format="3">\n  <name>{name}</name>\n</package>\n')
    (folder / "urdf" / "arm.xacro").write_text(
        f'<robot {XACRO}><xacro:macro name="arm"><link name="tool"/>'
        '<joint name="j" type="revolute"><parent link="base_link"/><child link="tool"/>'
        f'<origin xyz="0 0 {z}"/><axis xyz="0 0 1"/><limit lower="-1" upper="1" effort="1" velocity="1"/>'
        '</joint></xacro:macro></robot>'
    )
    return folder


def top(path: Path, package_name: str) -> Path:
    """A description including ``$(find package_name)/urdf/arm.xacro``."""
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(f'<robot name="mine" {XACRO}><xacro:include filename="$(find {package_name})/urdf/arm.xacro"/>'
                    '<link name="base_link"/><xacro:arm/></robot>')
    return path


def tool_z(path: Path, **kwargs) -> float:
    return manipkit.load(path, **kwargs).transform("base_link", "tool")[2, 3]


# --------------------------------------------------------------------------
# The workspace around the description file
# --------------------------------------------------------------------------


def test_a_ros1_workspace_src_layout_is_found_from_the_file_alone(tmp_path):
    ws = tmp_path / "catkin_ws"
    package(ws / "src" / "arms" / "my_arm_description", "my_arm_description")  # one folder deeper (a repository)
    path = top(ws / "src" / "my_robot" / "urdf" / "robot.urdf.xacro", "my_arm_description")
    (ws / "src" / "my_robot" / "package.xml").write_text("<package><name>my_robot</name></package>")
    assert workspace_root(path) == ((ws / "src").resolve(), packages_module.MAX_SCAN_DEPTH)
    assert tool_z(path) == 0.5


def test_a_package_whose_folder_name_differs_from_its_name(tmp_path):
    package(tmp_path / "ws" / "src" / "some-checkout", "my_arm_description", z=0.25)
    path = top(tmp_path / "ws" / "robot.urdf.xacro", "my_arm_description")
    assert tool_z(path) == 0.25
    assert PackageResolver(near=path).find("my_arm_description") == (tmp_path / "ws" / "src" / "some-checkout").resolve()


def test_a_checkout_without_src_is_indexed_from_its_outermost_package_folder(tmp_path):
    # repo/{arm_pkg, robot_pkg/urdf/robot.xacro}: no src/ anywhere, the packages sit side by side.
    repo = tmp_path / "repo"
    package(repo / "arm_pkg", "arm_pkg")
    path = top(repo / "robot_pkg" / "urdf" / "robot.xacro", "arm_pkg")
    (repo / "robot_pkg" / "package.xml").write_text("<package><name>robot_pkg</name></package>")
    assert workspace_root(path) == (repo.resolve(), packages_module.MAX_SCAN_DEPTH)
    assert tool_z(path) == 0.5


def _colcon_workspace(ws: Path) -> dict[str, Path]:
    """A ROS 2 workspace after ``colcon build``: src/, and build/, install/, log/ (each with colcon's
    COLCON_IGNORE); install/PKG/share/PKG holds a copy of each package (an isolated install)."""
    package(ws / "src" / "arm_description", "arm_description", z=0.5)
    robot = top(ws / "src" / "my_robot" / "urdf" / "robot.urdf.xacro", "arm_description")
    (ws / "src" / "my_robot" / "package.xml").write_text("<package><name>my_robot</name></package>")
    package(ws / "install" / "arm_description" / "share" / "arm_description", "arm_description", z=0.5)
    installed = top(ws / "install" / "my_robot" / "share" / "my_robot" / "urdf" / "robot.urdf.xacro", "arm_description")
    (installed.parents[1] / "package.xml").write_text("<package><name>my_robot</name></package>")
    for folder in ("build", "install", "log"):
        (ws / folder).mkdir(exist_ok=True)
        (ws / folder / "COLCON_IGNORE").write_text("")
    return {"source": robot, "installed": installed}


@pytest.mark.parametrize("which", ["source", "installed"])
def test_a_ros2_colcon_workspace_is_found_from_a_file_in_src_or_in_install(tmp_path, which):
    files = _colcon_workspace(tmp_path / "ros2_ws")
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # the install space's copies are not a second arm_description
        assert tool_z(files[which]) == 0.5
    assert PackageResolver(near=files[which]).find("arm_description") == (tmp_path / "ros2_ws" / "src" / "arm_description").resolve()


def test_a_ros2_merged_install_space_is_found_from_the_file_alone(tmp_path):
    # colcon build --merge-install: install/share/PKG for every package; not sourced (no AMENT_PREFIX_PATH)
    share = tmp_path / "ws" / "install" / "share"
    package(share / "arm_description", "arm_description", z=0.7)
    path = top(share / "my_robot" / "urdf" / "robot.urdf.xacro", "arm_description")
    (share / "my_robot" / "package.xml").write_text("<package><name>my_robot</name></package>")
    (tmp_path / "ws" / "install" / "COLCON_IGNORE").write_text("")
    assert tool_z(path) == 0.7


def test_a_ros2_isolated_install_space_needs_ament_prefix_path_and_says_so(tmp_path, monkeypatch):
    # install/PKG/share/PKG with no src/ beside it: each package is its own prefix, as AMENT_PREFIX_PATH lists them
    ws = tmp_path / "ws"
    files = _colcon_workspace(ws)
    shutil.rmtree(ws / "src")
    with pytest.raises(PackageNotFoundError, match="package 'arm_description' not found; .*--package-dir arm_description=DIR"):
        manipkit.load(files["installed"])
    monkeypatch.setenv("AMENT_PREFIX_PATH", os.pathsep.join(str(ws / "install" / p) for p in ("my_robot", "arm_description")))
    assert tool_z(files["installed"]) == 0.5


def test_packages_nested_below_a_package_are_not_indexed_as_colcon_does(tmp_path):
    outer = package(tmp_path / "ws" / "src" / "outer", "outer_pkg")
    package(outer / "inner", "inner_pkg")
    index = package_index(tmp_path / "ws" / "src")
    assert set(index) == {"outer_pkg"}
    path = top(tmp_path / "ws" / "robot.xacro", "inner_pkg")
    with pytest.raises(PackageNotFoundError, match="package 'inner_pkg' not found"):
        manipkit.load(path)


@pytest.mark.parametrize("marker", ["COLCON_IGNORE", "CATKIN_IGNORE", "AMENT_IGNORE"])
def test_an_ignore_marker_hides_a_folder(tmp_path, marker):
    src = tmp_path / "ws" / "src"
    package(src / "hidden" / "my_pkg", "my_pkg", z=0.1)
    package(src / "shown" / "my_pkg", "my_pkg", z=0.2)
    (src / "hidden" / marker).write_text("")
    path = top(tmp_path / "ws" / "robot.xacro", "my_pkg")
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # a single package: no "found in 2 places" warning
        assert tool_z(path) == 0.2


def test_two_packages_with_the_same_name_use_the_first_and_warn_once(tmp_path):
    src = tmp_path / "ws" / "src"
    first, second = package(src / "a_arm", "my_pkg", z=0.1), package(src / "b_arm", "my_pkg", z=0.2)
    path = top(tmp_path / "ws" / "robot.xacro", "my_pkg")
    with pytest.warns(UserWarning) as caught:
        assert tool_z(path) == 0.1
    messages = [str(w.message) for w in caught if "found in" in str(w.message)]
    assert messages and set(messages) == {
        f"package 'my_pkg' found in 2 places: using {first.resolve()}; not {second.resolve()} "
        "(choose with --package-dir my_pkg=DIR)"
    }
    assert tool_z(path, package_dirs={"my_pkg": second}) == 0.2  # --package-dir chooses


def _mesh_top(path: Path, package_name: str) -> Path:
    """As :func:`top`, and the base has a mesh ``package://package_name/meshes/base.stl`` (not there)."""
    top(path, package_name)
    path.write_text(path.read_text().replace(
        '<link name="base_link"/>', '<link name="base_link"><visual><geometry>'
        f'<mesh filename="package://{package_name}/meshes/base.stl"/></geometry></visual></link>'))
    return path


def test_the_duplicate_warning_is_one_line_on_the_command_line(tmp_path):
    src = tmp_path / "ws" / "src"
    package(src / "a_arm", "my_pkg", z=0.1)
    package(src / "b_arm", "my_pkg", z=0.2)
    path = _mesh_top(tmp_path / "ws" / "robot.xacro", "my_pkg")
    result = run_cli("tf-between", "base_link", "tool", "--robot", path, "--format", "json")
    assert result.returncode == 0, result.stderr
    assert json.loads(result.stdout)["translation"][2] == 0.1
    lines = [line for line in result.stderr.splitlines() if "found in" in line]
    assert lines == [f"warning: package 'my_pkg' found in 2 places: using {(src / 'a_arm').resolve()}; "
                     f"not {(src / 'b_arm').resolve()} (choose with --package-dir my_pkg=DIR)"]


def test_the_duplicate_warning_of_a_find_only_package_reaches_the_command_line(tmp_path):
    # raised during $(find), while xacro runs with stderr captured: recorded and issued once after it
    src = tmp_path / "ws" / "src"
    package(src / "a_arm", "my_pkg", z=0.1)
    package(src / "b_arm", "my_pkg", z=0.2)
    result = run_cli("tf-between", "base_link", "tool", "--robot", top(tmp_path / "ws" / "robot.xacro", "my_pkg"))
    assert result.returncode == 0, result.stderr
    assert [line for line in result.stderr.splitlines() if line.startswith("warning:")] == [
        f"warning: package 'my_pkg' found in 2 places: using {(src / 'a_arm').resolve()}; "
        f"not {(src / 'b_arm').resolve()} (choose with --package-dir my_pkg=DIR)"]


def test_warnings_raised_during_xacro_are_issued_once_each_to_python(tmp_path):
    src = tmp_path / "ws" / "src"
    package(src / "a_arm", "my_pkg", z=0.1)
    package(src / "b_arm", "my_pkg", z=0.2)
    path = top(tmp_path / "ws" / "robot.xacro", "my_pkg")
    path.write_text(path.read_text().replace("<xacro:arm/>", "<xacro:include filename=\"$(find my_pkg)/urdf/empty.xacro\"/>"
                                             "<xacro:arm/>"))
    (src / "a_arm" / "urdf" / "empty.xacro").write_text(f"<robot {XACRO}/>")
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("default")  # as a Python user has it: shown once per text
        assert tool_z(path) == 0.1  # two $(find my_pkg) in one expansion
        assert tool_z(path) == 0.1  # a second load says it again
    found = [str(w.message) for w in caught if "found in 2 places" in str(w.message)]
    assert len(found) == 2 and len(set(found)) == 1
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # a filter of the caller applies to the re-issued warning
        with pytest.raises(UserWarning, match="found in 2 places"):
            tool_z(path)


def test_a_file_missing_in_the_package_found_names_that_folder_the_others_and_package_dir(tmp_path):
    src = tmp_path / "ws" / "src"
    first, second = package(src / "a_arm", "my_pkg"), package(src / "b_arm", "my_pkg")
    (second / "urdf" / "extra.xacro").write_text((second / "urdf" / "arm.xacro").read_text())  # only in the one not used
    path = top(tmp_path / "ws" / "robot.xacro", "my_pkg")
    path.write_text(path.read_text().replace("/urdf/arm.xacro", "/urdf/extra.xacro"))
    result = run_cli("tf-between", "base_link", "base_link", "--robot", path)
    assert result.returncode == 2
    assert result.stderr.splitlines() == [  # one line: the duplicate warning is not printed before an error
        (
        f"tf-between: error: robot.xacro:1: xacro:include: file not found: {first.resolve() / 'urdf' / 'extra.xacro'} "
        f"(package 'my_pkg' was found, {first.resolve()}, but the file is not in it; other copies: {second.resolve()} "
        "(choose one with --package-dir my_pkg=DIR))")]
    assert run_cli("tf-between", "base_link", "base_link", "--robot", path, "--package-dir", f"my_pkg={second}").returncode == 0


def test_a_workspace_package_wins_over_example_robot_data(tmp_path):
    if example_robot_data_dir() is None or not (example_robot_data_dir() / "robots" / "ur_description").is_dir():
        pytest.skip("example-robot-data with ur_description is not installed")
    package(tmp_path / "ws" / "src" / "ur_description", "ur_description", z=0.75)
    path = top(tmp_path / "ws" / "robot.xacro", "ur_description")
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # issue 25: the user's copy beating the built-in one is not a guess: no warning
        assert tool_z(path) == 0.75


def test_the_workspace_index_is_scanned_once_and_again_after_a_change(tmp_path, monkeypatch):
    src = tmp_path / "ws" / "src"
    package(src / "one", "one_pkg")
    scans = []
    real_scan = packages_module._scan
    monkeypatch.setattr(packages_module, "_scan", lambda root, depth: scans.append(root) or real_scan(root, depth))
    resolver = PackageResolver(near=tmp_path / "ws" / "robot.urdf")
    for _ in range(3):
        resolver.find("one_pkg")
    assert PackageResolver(near=tmp_path / "ws" / "robot.urdf").find("one_pkg") == (src / "one").resolve()
    assert scans == [src.resolve()]
    package(src / "two", "two_pkg")  # a new folder: the next resolver scans again and finds it
    assert PackageResolver(near=tmp_path / "ws" / "robot.urdf").find("two_pkg") == (src / "two").resolve()
    assert scans == [src.resolve()] * 2


def test_a_scan_stops_after_the_folder_limit_with_a_warning(tmp_path, monkeypatch):
    monkeypatch.setattr(packages_module, "MAX_SCAN_FOLDERS", 5)
    for index in range(10):
        (tmp_path / "big" / f"d{index}").mkdir(parents=True)
    package(tmp_path / "big" / "z_last", "late_pkg")
    with pytest.warns(UserWarning, match=f"package search in {tmp_path / 'big'} stopped after 5 folders"):
        assert "late_pkg" not in package_index(tmp_path / "big")


def test_a_scan_stops_below_the_depth_limit_with_a_warning(tmp_path):
    deep = tmp_path / "deep"
    folder = deep.joinpath(*[f"l{i}" for i in range(packages_module.MAX_SCAN_DEPTH + 1)])
    package(folder, "deep_pkg")
    package(deep / "l0" / "shallow", "shallow_pkg")
    with pytest.warns(UserWarning, match=f"does not look deeper than {packages_module.MAX_SCAN_DEPTH} folders"):
        assert set(package_index(deep)) == {"shallow_pkg"}


def test_a_symbolic_link_loop_is_scanned_once(tmp_path):
    package(tmp_path / "ws" / "src" / "a", "a_pkg")
    (tmp_path / "ws" / "src" / "loop").symlink_to(tmp_path / "ws" / "src")
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        assert package_index(tmp_path / "ws" / "src") == {"a_pkg": [tmp_path / "ws" / "src" / "a"]}


def test_the_home_folder_and_the_root_are_never_indexed(tmp_path, monkeypatch):
    monkeypatch.setenv("HOME", str(tmp_path))
    package(tmp_path / "other_pkg", "other_pkg")
    assert workspace_root(tmp_path / "robot.urdf") is None  # a file directly in the home folder
    assert workspace_root(Path("/robot.urdf")) is None


# --------------------------------------------------------------------------
# ROS_PACKAGE_PATH and AMENT_PREFIX_PATH, after the workspace
# --------------------------------------------------------------------------


def test_ros_package_path_entries_are_packages_or_folders_of_packages(tmp_path, monkeypatch):
    single = package(tmp_path / "lone" / "single_pkg_folder", "single_pkg", z=0.3)
    package(tmp_path / "many" / "group" / "arm_pkg", "arm_pkg", z=0.4)
    monkeypatch.setenv("ROS_PACKAGE_PATH", os.pathsep.join([str(single), "", str(tmp_path / "many")]))
    assert tool_z(top(tmp_path / "file" / "a.xacro", "single_pkg")) == 0.3
    assert tool_z(top(tmp_path / "file" / "b.xacro", "arm_pkg")) == 0.4


def test_a_ros2_install_space_is_found_through_ament_prefix_path(tmp_path, monkeypatch):
    prefix = tmp_path / "install" / "my_arm_description"
    package(prefix / "share" / "my_arm_description", "my_arm_description", z=0.6)
    monkeypatch.setenv("AMENT_PREFIX_PATH", os.pathsep.join([str(tmp_path / "install" / "other"), str(prefix)]))
    path = top(tmp_path / "elsewhere" / "robot.urdf.xacro", "my_arm_description")
    assert tool_z(path) == 0.6


def test_the_workspace_comes_before_ros_package_path_and_ament(tmp_path, monkeypatch):
    mine = package(tmp_path / "ws" / "src" / "p", "my_pkg", z=0.1)
    ros = package(tmp_path / "ros" / "p", "my_pkg", z=0.2)
    ament = package(tmp_path / "install" / "share" / "my_pkg", "my_pkg", z=0.3)
    monkeypatch.setenv("ROS_PACKAGE_PATH", str(tmp_path / "ros"))
    monkeypatch.setenv("AMENT_PREFIX_PATH", str(tmp_path / "install"))
    path = top(tmp_path / "ws" / "robot.xacro", "my_pkg")
    with pytest.warns(UserWarning, match="found in 3 places") as caught:
        assert tool_z(path) == 0.1
    message = next(str(w.message) for w in caught if "found in" in str(w.message))
    assert message.index(str(mine.resolve())) < message.index(str(ros.resolve())) < message.index(str(ament.resolve()))
    monkeypatch.delenv("ROS_PACKAGE_PATH")
    assert PackageResolver(near=tmp_path / "elsewhere" / "r.urdf").find("my_pkg") == ament.resolve()


def test_not_found_names_every_place_searched_and_package_dir(tmp_path, monkeypatch):
    monkeypatch.setenv("ROS_PACKAGE_PATH", str(tmp_path / "ros"))
    monkeypatch.setenv("AMENT_PREFIX_PATH", str(tmp_path / "install"))
    path = top(tmp_path / "ws" / "src" / "robot" / "robot.xacro", "no_such_pkg")
    result = run_cli("tf-between", "base_link", "tool", "--robot", path,
                     env={"ROS_PACKAGE_PATH": str(tmp_path / "ros"), "AMENT_PREFIX_PATH": str(tmp_path / "install")})
    assert result.returncode == 2 and len(result.stderr.splitlines()) == 1, result.stderr
    line = result.stderr
    assert line.startswith("tf-between: error: ")
    for part in ("package 'no_such_pkg' not found; searched --package-dir (none given)",
                 f"the workspace {(tmp_path / 'ws' / 'src').resolve()}", f"ROS_PACKAGE_PATH ({tmp_path / 'ros'})",
                 f"AMENT_PREFIX_PATH ({tmp_path / 'install' / 'share'})", "built-in (manipkit, example-robot-data",
                 "give it with --package-dir no_such_pkg=DIR"):
        assert part in line, part


# --------------------------------------------------------------------------
# A real catkin workspace: the file path alone picks the workspace's ur_description
# --------------------------------------------------------------------------


def _yourdfpy_pose(path: Path, packages: dict, monkeypatch, q: dict, source: str, target: str) -> np.ndarray:
    """T_source_target from the xacro package's own expansion (``$(find)`` from ``packages``) and yourdfpy."""
    import xacro
    import xacro.substitution_args as substitution_args

    with monkeypatch.context() as patch:
        patch.setattr(substitution_args, "_eval_find", lambda name: str(packages[name]))
        xacro.all_includes.clear()
        with redirect_stdout(io.StringIO()), redirect_stderr(io.StringIO()):
            text = xacro.process_file(str(path)).toxml()
    urdf = yourdfpy.URDF.load(io.StringIO(text), build_scene_graph=True, load_meshes=False)
    urdf.update_cfg(q)
    return urdf.get_transform(target, source)


@pytest.mark.skipif(not UR5E.is_file(), reason=f"the shared real-world workspace is not here ({UR5E})")
def test_real_ur5e_in_a_catkin_workspace_loads_the_workspace_ur_description(monkeypatch):
    packages = {"ur_description": REALWORLD / "src" / "universal_robot" / "ur_description"}
    rng = np.random.default_rng(13)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("default")  # as a Python user has it: once, though $(find) and package:// both ask
        robot = manipkit.load(UR5E)
    # the workspace's copy (it holds the named file) wins over example-robot-data's: nothing to warn about (issue 25)
    assert [str(w.message) for w in caught if "found in" in str(w.message)] == []
    for trial in range(3):
        values = {} if trial == 0 else {
            joint.name: rng.uniform(max(joint.lower, -np.pi), min(joint.upper, np.pi)) for joint in robot.joints
        }
        result = run_cli("tf-between", "base_link", "tool0", "--robot", UR5E, "--format", "json", "--precision", "15",
                         *(["--q", *(f"{k}={v!r}" for k, v in values.items())] if values else []))
        assert result.returncode == 0, result.stderr
        assert "found in" not in result.stderr
        T = np.array(json.loads(result.stdout)["matrix"])
        expected = _yourdfpy_pose(UR5E, packages, monkeypatch, values, "base_link", "tool0")
        np.testing.assert_allclose(T, expected, atol=1e-9, rtol=0)


# --------------------------------------------------------------------------
# --arg k:=v and k=v; load(path, name="value")
# --------------------------------------------------------------------------


def _arg_robot(tmp_path: Path) -> Path:
    """tool at z = arg length (default 1); with hand:=true a hand 0.5 m beyond the tool."""
    path = tmp_path / "args.urdf.xacro"
    path.write_text(
        f'<robot name="r" {XACRO}><xacro:arg name="length" default="1"/><xacro:arg name="hand" default="false"/>'
        '<link name="base_link"/><link name="tool"/>'
        '<joint name="j" type="fixed"><parent link="base_link"/><child link="tool"/>'
        '<origin xyz="0 0 $(arg length)"/></joint>'
        '<xacro:if value="$(arg hand)"><link name="hand"/><joint name="h" type="fixed"><parent link="tool"/>'
        '<child link="hand"/><origin xyz="0 0 0.5"/></joint></xacro:if></robot>'
    )
    return path


def test_load_takes_xacro_arguments_as_keywords(tmp_path):
    path = _arg_robot(tmp_path)
    assert tool_z(path) == 1.0 and "hand" not in manipkit.load(path).frame_names
    robot = manipkit.load(path, hand="true", length="2")
    assert robot.transform("base_link", "hand")[2, 3] == 2.5
    assert manipkit.load(path, hand=True, length=2).transform("base_link", "hand")[2, 3] == 2.5  # values -> strings
    assert robot.xacro_args == {"length": "2", "hand": "true"}


@pytest.mark.parametrize("command", [("tf-between", "base_link", "hand", "--format", "json"),
                                     ("manipkit", "tf", "base_link", "hand", "--format", "json"),
                                     ("manipkit", "frames"), ("manipkit", "tree")])
@pytest.mark.parametrize("style", [":=", "="])
def test_arg_takes_ros_style_and_plain_pairs_in_every_command(tmp_path, command, style):
    path = _arg_robot(tmp_path)
    result = run_cli(*command, "--robot", path, "--arg", f"hand{style}true", "--arg", f"length{style}2")
    assert result.returncode == 0, result.stderr
    if "json" in command:
        assert json.loads(result.stdout)["translation"] == [0, 0, 2.5]
    else:
        assert "hand" in result.stdout
        assert "hand" not in run_cli(*command, "--robot", path, "--arg", f"hand{style}false").stdout
    refused = run_cli(*command, "--robot", path, "--arg", f"colour{style}red")
    assert refused.returncode == 2 and "unknown xacro argument colour" in refused.stderr


def test_arg_values_may_hold_colons_and_equals_signs_and_malformed_ones_are_named(tmp_path):
    from manipkit.app.cli.common import xacro_arg_pairs
    from manipkit.errors import ManipkitError

    assert xacro_arg_pairs(["a:=b=c", "d=e:=f", "g:=", "h=", "url:=http://x"]) == {
        "a": "b=c", "d": "e:=f", "g": "", "h": "", "url": "http://x"}
    with pytest.raises(ManipkitError, match="--arg ':=1': expected NAME:=VALUE or NAME=VALUE"):
        xacro_arg_pairs([":=1"])
    for bad in (":=1", "=1", "hand"):
        result = run_cli("tf-between", "base_link", "tool", "--robot", _arg_robot(tmp_path), "--arg", bad)
        assert result.returncode == 2
        assert result.stderr.strip() == f"tf-between: error: --arg '{bad}': expected NAME:=VALUE or NAME=VALUE"
    twice = run_cli("tf-between", "base_link", "tool", "--robot", _arg_robot(tmp_path), "--arg", "hand:=true", "--arg", "hand=false")
    assert twice.returncode == 2 and "hand given twice" in twice.stderr


def test_of_two_copies_the_one_holding_the_named_file_is_used_without_a_warning(tmp_path):
    # issue 25: with the named copy edited, $(find) took the alphabetically first copy and answered from it
    src = tmp_path / "ws" / "src"
    package(src / "a_arm", "my_pkg", z=0.1)
    edited = package(src / "b_arm", "my_pkg", z=0.2)
    path = top(edited / "urdf" / "robot.urdf.xacro", "my_pkg")  # the user's file, inside copy b
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        assert tool_z(path) == 0.2
    # a file outside both copies still takes the first and says so
    with pytest.warns(UserWarning, match="found in 2 places"):
        assert tool_z(top(tmp_path / "ws" / "robot.xacro", "my_pkg")) == 0.1


def test_a_file_missing_from_the_only_copy_does_not_suggest_package_dir(tmp_path):
    only = package(tmp_path / "ws" / "src" / "arm", "my_pkg")
    path = top(tmp_path / "ws" / "robot.xacro", "my_pkg")
    path.write_text(path.read_text().replace("/urdf/arm.xacro", "/urdf/gone.xacro"))
    result = run_cli("tf-between", "base_link", "base_link", "--robot", path)
    assert result.returncode == 2
    assert result.stderr == (f"tf-between: error: robot.xacro:1: xacro:include: file not found: "
                             f"{only.resolve() / 'urdf' / 'gone.xacro'} (package 'my_pkg' was found, {only.resolve()}, "
                             "but the file is not in it)\n")
