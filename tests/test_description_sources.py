"""manipkit.description.sources: names -> description files, xacro expansion, $(find) without ROS."""

import os
from pathlib import Path

import pytest

import manipkit
from manipkit.description.packages import PackageResolver
from manipkit.description.sources import bundled_robots, example_robot_data_arms, example_robot_data_dir, resolve_robot
from manipkit.description.xacro import urdf_text
from manipkit.errors import DescriptionError, PackageNotFoundError, UnknownRobotError


def test_bundled_robots_are_the_five_of_the_foundation():
    assert {"course_arm", "mobile_manipulator", "iiwa14", "planar_2r", "planar_3r"} <= set(bundled_robots())


def test_default_robot_is_the_course_arm():
    assert resolve_robot().name == "course_arm"


def test_example_robot_data_found_through_package_metadata():
    root = example_robot_data_dir()
    assert root is not None and (root / "robots" / "ur_description").is_dir()
    arms = example_robot_data_arms()
    for name in ("panda", "ur3", "ur5", "ur10", "kinova", "z1", "so_arm"):
        assert name in arms and arms[name].path.is_file()


def test_any_example_robot_data_urdf_by_file_stem():
    source = resolve_robot("double_pendulum")
    assert source.origin == "example-robot-data" and source.path.name == "double_pendulum.urdf"


def test_unknown_robot_suggests_close_names():
    with pytest.raises(UnknownRobotError, match="unknown robot 'pand'; did you mean panda"):
        resolve_robot("pand")


def test_missing_file_is_named():
    with pytest.raises(UnknownRobotError, match="robot file not found: nowhere/robot.urdf"):
        resolve_robot("nowhere/robot.urdf")


def test_file_of_wrong_kind_is_rejected(tmp_path):
    path = tmp_path / "robot.txt"
    path.write_text("<robot/>")
    with pytest.raises(UnknownRobotError, match="give a .urdf, .xacro or MJCF .xml file"):
        resolve_robot(path)


def test_xacro_arguments_change_the_expansion():
    source = resolve_robot("planar_2r")
    assert 'xyz="2.5 0 0"' in urdf_text(source, {"l1": 2.5}).replace("2.5 0.0 0.0", "2.5 0 0")


def test_unknown_xacro_argument_lists_declared_ones():
    with pytest.raises(DescriptionError, match=r"unknown xacro argument l9; declared: l1 \(default 1\)"):
        urdf_text(resolve_robot("planar_2r"), {"l9": 1})


def test_xacro_arguments_declared_in_an_included_file_are_accepted(tmp_path):
    # The argument is declared in the included file only, with single quotes: both are valid xacro.
    (tmp_path / "lengths.xacro").write_text(
        "<robot xmlns:xacro='http://www.ros.org/wiki/xacro'><xacro:arg name='len' default='1'/></robot>"
    )
    top = tmp_path / "arm.urdf.xacro"
    top.write_text(
        '<robot name="arm" xmlns:xacro="http://www.ros.org/wiki/xacro">'
        '<xacro:include filename="lengths.xacro"/>'
        '<link name="a"/><link name="b"/>'
        '<joint name="j" type="fixed"><parent link="a"/><child link="b"/>'
        '<origin xyz="$(arg len) 0 0"/></joint></robot>'
    )
    robot = manipkit.load(top, len=2.5)
    assert robot.xacro_args == {"len": "2.5"}
    assert robot.transform("a", "b")[0, 3] == 2.5  # the value given, not the default 1
    with pytest.raises(DescriptionError, match=r"unknown xacro argument lenght; declared: len \(default 1\)"):
        manipkit.load(top, lenght=2.5)


def test_xacro_arguments_on_plain_urdf_are_an_error():
    with pytest.raises(DescriptionError, match="plain URDF; xacro arguments"):
        urdf_text(resolve_robot("ur5"), {"l1": 1})


def _write_package(root: Path, name: str) -> Path:
    package = root / name
    (package / "urdf").mkdir(parents=True)
    (package / "package.xml").write_text(f"<package><name>{name}</name></package>")
    (package / "urdf" / "arm.xacro").write_text(
        '<robot xmlns:xacro="http://www.ros.org/wiki/xacro">'
        '<xacro:macro name="arm"><link name="tool"/>'
        '<joint name="j" type="continuous"><parent link="base_link"/><child link="tool"/>'
        '<origin xyz="0 0 0.5"/><axis xyz="0 0 1"/></joint></xacro:macro></robot>'
    )
    return package


def _write_top(path: Path, package: str) -> Path:
    path.write_text(
        '<robot name="mine" xmlns:xacro="http://www.ros.org/wiki/xacro">'
        f'<xacro:include filename="$(find {package})/urdf/arm.xacro"/>'
        '<link name="base_link"/><xacro:arm/></robot>'
    )
    return path


def test_find_resolves_a_package_given_with_package_dir(tmp_path):
    package = _write_package(tmp_path / "elsewhere", "my_arm_description")
    top = _write_top(tmp_path / "top.urdf.xacro", "my_arm_description")
    robot = manipkit.load(top, package_dirs={"my_arm_description": package})
    assert robot.transform("base_link", "tool")[2, 3] == 0.5


def test_find_resolves_a_package_in_the_same_workspace(tmp_path):
    # ws/src/my_arm_description and ws/src/my_robot/urdf/top.urdf.xacro, as in a ROS workspace.
    _write_package(tmp_path / "ws" / "src", "my_arm_description")
    (tmp_path / "ws" / "src" / "my_robot" / "urdf").mkdir(parents=True)
    top = _write_top(tmp_path / "ws" / "src" / "my_robot" / "urdf" / "top.urdf.xacro", "my_arm_description")
    assert manipkit.load(top).joint_names == ("j",)


def test_unresolved_package_lists_the_places_searched(tmp_path):
    top = _write_top(tmp_path / "top.urdf.xacro", "no_such_pkg")
    with pytest.raises(PackageNotFoundError) as info:
        manipkit.load(top)
    message = str(info.value)
    assert "package 'no_such_pkg' not found" in message
    assert str(tmp_path) in message and "--package-dir no_such_pkg=DIR" in message


def test_package_uri_resolves_to_example_robot_data_meshes():
    resolver = PackageResolver()
    path = resolver.resolve_uri("package://example-robot-data/robots/ur_description/meshes/ur5/visual/base.dae")
    assert os.path.isfile(path)


def test_xacro_error_names_the_file(tmp_path):
    path = tmp_path / "bad.urdf.xacro"
    path.write_text('<robot name="r" xmlns:xacro="http://www.ros.org/wiki/xacro"><link name="${1/0}"/></robot>')
    with pytest.raises(DescriptionError, match=r"bad.urdf.xacro:1: xacro expression \$\{1/0\}: division by zero"):
        manipkit.load(path)


def test_xacro_missing_include_names_the_missing_file(tmp_path):
    path = tmp_path / "top.xacro"
    path.write_text('<robot name="r" xmlns:xacro="http://www.ros.org/wiki/xacro"><xacro:include filename="gone.xacro"/></robot>')
    with pytest.raises(DescriptionError, match="gone.xacro"):
        manipkit.load(path)


def test_find_hook_is_removed_after_each_expansion_even_a_failed_one(tmp_path):
    # expand_xacro patches xacro's $(...) handler (and, at the first $(...), $(find)) for one call only.
    import xacro
    import xacro.substitution_args as substitution_args

    xacro_own = (xacro.eval_extension, substitution_args._eval_find)
    package = _write_package(tmp_path / "elsewhere", "my_arm_description")
    top = _write_top(tmp_path / "top.urdf.xacro", "my_arm_description")
    manipkit.load(top, package_dirs={"my_arm_description": package})
    assert (xacro.eval_extension, substitution_args._eval_find) == xacro_own
    with pytest.raises(PackageNotFoundError):
        manipkit.load(_write_top(tmp_path / "other.urdf.xacro", "no_such_pkg"))
    assert (xacro.eval_extension, substitution_args._eval_find) == xacro_own
    manipkit.load("course_arm")  # no $(...) at all
    assert (xacro.eval_extension, substitution_args._eval_find) == xacro_own


def test_the_description_package_exports_its_api_without_importing_heavy_modules():
    import subprocess
    import sys

    code = (
        "import sys, manipkit.description as d; heavy = ['lxml', 'xacro', 'yaml', 'yourdfpy', 'matplotlib'];"
        "print([m for m in heavy if m in sys.modules]);"
        "from manipkit.description.packages import PackageResolver; from manipkit.description.tree import tree_text;"
        "print(d.PackageResolver is PackageResolver, d.tree_text is tree_text, sorted(d.__all__) == d.__all__)"
    )
    result = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=60, check=True)
    assert result.stdout.split("\n")[:2] == ["[]", "True True True"]


# ---------------------------------------------------------------- issue 15: files that are not regular files


def test_an_empty_name_is_not_the_current_folder():
    with pytest.raises(UnknownRobotError, match="the robot name is empty; give a bundled name \\(course_arm"):
        resolve_robot("")
    with pytest.raises(UnknownRobotError, match="the robot name is empty"):
        resolve_robot("  ")


def test_a_fifo_is_refused_without_being_opened(tmp_path):
    from manipkit.errors import InputFileError

    fifo = tmp_path / "arm.urdf"
    os.mkfifo(fifo)  # opening it would block until a writer comes
    with pytest.raises(InputFileError, match="robot file .*arm.urdf is a FIFO \\(named pipe\\), not a regular file"):
        resolve_robot(fifo)


def test_a_device_is_refused_even_without_a_description_suffix():
    from manipkit.errors import InputFileError

    with pytest.raises(InputFileError, match="robot file /dev/zero is a character device, not a regular file"):
        resolve_robot("/dev/zero")


def test_a_symlink_loop_is_not_called_missing(tmp_path):
    from manipkit.errors import InputFileError

    loop = tmp_path / "loop.urdf"
    loop.symlink_to("loop.urdf")
    with pytest.raises(InputFileError, match="loop.urdf is a symlink loop"):
        resolve_robot(loop)


def test_a_description_above_the_size_limit_is_refused_before_it_is_read(tmp_path):
    from manipkit.errors import InputFileError
    from manipkit.inputs import MAX_DESCRIPTION_BYTES

    huge = tmp_path / "huge.urdf"
    with open(huge, "wb") as stream:
        stream.truncate(MAX_DESCRIPTION_BYTES + 1)  # sparse
    with pytest.raises(InputFileError, match=r"is 67,108,865 bytes, above the limit of 64 MB \(67,108,864 bytes\) for a robot file"):
        resolve_robot(huge)


def test_a_dh_table_that_is_a_fifo_or_a_folder_is_named_as_such(tmp_path):
    from manipkit.description.sources import resolve_dh_table
    from manipkit.errors import InputFileError

    fifo = tmp_path / "table.yaml"
    os.mkfifo(fifo)
    with pytest.raises(InputFileError, match="DH table .*table.yaml is a FIFO \\(named pipe\\)"):
        resolve_dh_table(fifo)
    with pytest.raises(InputFileError, match="is a folder, not a regular file"):
        resolve_dh_table(tmp_path)


def test_a_package_xml_above_the_table_limit_is_not_read(tmp_path):
    from manipkit.inputs import MAX_TABLE_BYTES

    folder = tmp_path / "ws" / "src" / "renamed_folder"
    folder.mkdir(parents=True)
    with open(folder / "package.xml", "w") as stream:
        stream.write("<package><name>my_pkg</name></package>")
        stream.truncate(MAX_TABLE_BYTES + 1)
    resolver = PackageResolver(near=tmp_path / "ws" / "robot.urdf")
    with pytest.raises(PackageNotFoundError, match="package 'my_pkg' not found"):
        resolver.find("my_pkg")
    (folder / "package.xml").write_text("<package><name>my_pkg</name></package>")
    assert PackageResolver(near=tmp_path / "ws" / "robot.urdf").find("my_pkg") == folder.resolve()


def test_the_example_robot_data_folder_is_the_one_importlib_metadata_locates(monkeypatch, tmp_path):
    """The ``sys.path`` scan finds the folder ``importlib.metadata`` gives; with no dist-info on the path the
    answer falls back to ``importlib.metadata``, which finds none either (None)."""
    from importlib import metadata

    example_robot_data_dir.cache_clear()
    try:
        dist = metadata.distribution("example-robot-data")
        assert example_robot_data_dir() == Path(dist.locate_file("cmeel.prefix/share/example-robot-data"))
        example_robot_data_dir.cache_clear()
        monkeypatch.setattr("sys.path", [str(tmp_path)])
        assert example_robot_data_dir() is None
    finally:
        example_robot_data_dir.cache_clear()
