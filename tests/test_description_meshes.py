"""manipkit.description.meshes: mesh URIs (package://, file://, relative) to files, with real files in tmp_path."""

from __future__ import annotations

import math
import xml.etree.ElementTree as ET
from pathlib import Path

import pytest

from manipkit.description.meshes import mesh_path, urdf_with_mesh_paths
from manipkit.description.packages import PackageResolver
from manipkit.description.validate import check_urdf, package_uri_warnings
from manipkit.errors import PackageNotFoundError


@pytest.fixture
def files(tmp_path: Path) -> dict[str, Path]:
    """A package ``my_pkg`` with one mesh in a workspace, and a robot folder with a relative mesh."""
    package = tmp_path / "ws" / "my_pkg"
    (package / "meshes").mkdir(parents=True)
    (package / "meshes" / "arm.stl").write_bytes(b"solid arm\nendsolid arm\n")
    robot = tmp_path / "robot"
    (robot / "meshes").mkdir(parents=True)
    (robot / "meshes" / "hand.stl").write_bytes(b"solid hand\nendsolid hand\n")
    elsewhere = tmp_path / "elsewhere"
    elsewhere.mkdir()
    return {"package": package, "robot": robot, "elsewhere": elsewhere}


def resolver_for(files) -> PackageResolver:
    return PackageResolver({"my_pkg": files["package"]})


def mesh_error(uri: str, files, *, relative_to=None) -> str:
    with pytest.raises(PackageNotFoundError) as info:
        mesh_path(uri, resolver_for(files), relative_to=relative_to or files["robot"], link="arm")
    return str(info.value)


# ---------------------------------------------------------------- found


def test_package_uri_is_the_file_in_the_package_folder(files):
    path = mesh_path("package://my_pkg/meshes/arm.stl", resolver_for(files), relative_to=files["robot"], link="arm")
    assert path == files["package"].resolve() / "meshes" / "arm.stl"
    assert path.is_absolute() and path.is_file()


def test_relative_path_is_found_beside_the_description(files, monkeypatch):
    monkeypatch.chdir(files["elsewhere"])  # not in the current folder: relative_to it is
    path = mesh_path("meshes/hand.stl", resolver_for(files), relative_to=files["robot"], link="hand")
    assert path == (files["robot"] / "meshes" / "hand.stl").resolve()


def test_relative_path_is_then_looked_for_in_the_current_folder(files, monkeypatch):
    monkeypatch.chdir(files["robot"])
    path = mesh_path("meshes/hand.stl", resolver_for(files), relative_to=files["elsewhere"], link="hand")
    assert path == (files["robot"] / "meshes" / "hand.stl").resolve()


def test_file_uri_and_absolute_path(files):
    absolute = files["robot"] / "meshes" / "hand.stl"
    for uri in (f"file://{absolute}", str(absolute)):
        assert mesh_path(uri, resolver_for(files), relative_to=files["elsewhere"], link="hand") == absolute.resolve()


# ---------------------------------------------------------------- not found


def test_missing_file_in_a_found_package_names_the_path_and_the_package_folder(files):
    folder = files["package"].resolve()
    assert mesh_error("package://my_pkg/meshes/gone.stl", files) == (
        f"link 'arm': mesh package://my_pkg/meshes/gone.stl resolves to {folder / 'meshes' / 'gone.stl'}, which does "
        f"not exist (package 'my_pkg' was found, {folder}, but the file is not in it)"
    )  # issue 25: one copy of the package, so no --package-dir to suggest: the file is simply missing


def test_missing_package_says_where_it_looked(files):
    message = mesh_error("package://no_such_pkg/a.stl", files)
    assert message.startswith("link 'arm': mesh package://no_such_pkg/a.stl cannot be resolved: "
                              "package 'no_such_pkg' not found; searched --package-dir (my_pkg)")
    assert message.endswith("give it with --package-dir no_such_pkg=DIR")


def test_missing_relative_file_lists_both_places(files, monkeypatch):
    monkeypatch.chdir(files["elsewhere"])
    assert mesh_error("meshes/gone.stl", files) == (
        f"link 'arm': mesh meshes/gone.stl not found; looked at {files['robot'] / 'meshes' / 'gone.stl'}, "
        f"{files['elsewhere'] / 'meshes' / 'gone.stl'}"
    )


def test_missing_absolute_file_is_looked_for_once(files):
    gone = files["robot"] / "gone.stl"
    assert mesh_error(str(gone), files) == f"link 'arm': mesh {gone} not found; looked at {gone}"


@pytest.mark.parametrize("uri", ["http://example.com/arm.stl", "model://arm/meshes/arm.stl"])
def test_another_scheme_is_refused(files, uri):
    assert mesh_error(uri, files) == f"link 'arm': mesh {uri}: only package://, file:// and file paths are supported"


# ---------------------------------------------------------------- a whole description


URDF = """<robot name="r">
  <link name="base"><visual><geometry><mesh filename="package://my_pkg/meshes/arm.stl"/></geometry></visual></link>
  <link name="hand"><visual><geometry><mesh filename="meshes/hand.stl" scale="2 2 2"/></geometry></visual>
    <collision><geometry><mesh filename="package://my_pkg/collision/not_read.stl"/></geometry></collision></link>
  <joint name="j" type="fixed"><parent link="base"/><child link="hand"/></joint>
</robot>"""


def test_urdf_with_mesh_paths_makes_visual_meshes_absolute_and_lists_package_parents(files):
    text, folders = urdf_with_mesh_paths(URDF, resolver_for(files), relative_to=files["robot"])
    root = ET.fromstring(text)
    visual = [mesh.get("filename") for mesh in root.iterfind("link/visual/geometry/mesh")]
    assert visual == [str(files["package"].resolve() / "meshes" / "arm.stl"),
                      str((files["robot"] / "meshes" / "hand.stl").resolve())]
    assert root.find("link[@name='hand']/visual/geometry/mesh").get("scale") == "2 2 2"
    # collision meshes are not the viewer's: left as written
    assert root.find("link[@name='hand']/collision/geometry/mesh").get("filename") == "package://my_pkg/collision/not_read.stl"
    assert folders == [str(files["package"].resolve().parent)]


def test_urdf_without_visual_meshes_comes_back_unchanged():
    text = '<robot name="r"><link name="a"><visual><geometry><box size="1 1 1"/></geometry></visual></link></robot>'
    assert urdf_with_mesh_paths(text, PackageResolver(), relative_to=".") == (text, [])


def test_urdf_with_mesh_paths_raises_for_the_first_missing_mesh(files):
    text = URDF.replace("meshes/hand.stl", "meshes/gone.stl")
    with pytest.raises(PackageNotFoundError, match=r"^link 'hand': mesh meshes/gone.stl not found"):
        urdf_with_mesh_paths(text, resolver_for(files), relative_to=files["robot"])


def test_validation_warns_about_the_file_the_viewer_would_look_for(files):
    # the same resolution: the warning names the path mesh_path reports as missing
    text = URDF.replace("meshes/arm.stl", "meshes/gone.stl")
    checked = check_urdf(text, "r.urdf")
    warning, collision = package_uri_warnings(checked.robot, resolver_for(files), "r.urdf")
    assert "mesh package://my_pkg/collision/not_read.stl: no such file" in collision  # validation reads every mesh
    missing = files["package"].resolve() / "meshes" / "gone.stl"
    assert warning == (f"r.urdf:2: link 'base' mesh package://my_pkg/meshes/gone.stl: no such file {missing} "
                       "(kinematics do not need meshes; the viewer does)")
    assert f"resolves to {missing}, which does not exist" in mesh_error("package://my_pkg/meshes/gone.stl", files)


# ---------------------------------------------------------------- relative and file:// meshes warn as package:// ones


def _relative_robot(folder: Path) -> Path:
    """``folder/arm.urdf``: a relative mesh that is there, a relative one and a ``file://`` one that are not."""
    path = folder / "arm.urdf"
    path.write_text(f"""<robot name="r">
  <link name="base_link"><visual><geometry><mesh filename="meshes/hand.stl"/></geometry></visual></link>
  <link name="link_0"><visual><geometry><mesh filename="meshes/link_0.stl"/></geometry></visual></link>
  <link name="link_1"><visual><geometry><mesh filename="file://{folder}/gone/link_1.stl"/></geometry></visual></link>
  <joint name="j0" type="fixed"><parent link="base_link"/><child link="link_0"/></joint>
  <joint name="j1" type="fixed"><parent link="link_0"/><child link="link_1"/></joint>
</robot>""")
    return path


def test_missing_relative_and_file_meshes_warn_beside_the_description(files, monkeypatch):
    monkeypatch.chdir(files["elsewhere"])
    path = _relative_robot(files["robot"])
    checked = check_urdf(path.read_text(), "arm.urdf")
    warnings = package_uri_warnings(checked.robot, PackageResolver(near=path), "arm.urdf")
    assert warnings == [
        f"arm.urdf:3: link 'link_0' mesh meshes/link_0.stl: no such file {files['robot'] / 'meshes' / 'link_0.stl'}, "
        "nor in the current folder (kinematics do not need meshes; the viewer does)",
        f"arm.urdf:4: link 'link_1' mesh file://{files['robot']}/gone/link_1.stl: no such file "
        f"{files['robot'] / 'gone' / 'link_1.stl'} (kinematics do not need meshes; the viewer does)",
    ]
    for uri in ("meshes/link_0.stl", f"file://{files['robot']}/gone/link_1.stl"):  # the viewer agrees: not found
        with pytest.raises(PackageNotFoundError, match="not found"):
            mesh_path(uri, PackageResolver(near=path), relative_to=files["robot"], link="l")


def test_a_relative_mesh_in_the_current_folder_is_not_missing(files, monkeypatch):
    path = _relative_robot(files["robot"])
    (files["elsewhere"] / "meshes").mkdir()
    (files["elsewhere"] / "meshes" / "link_0.stl").write_bytes(b"solid l\nendsolid l\n")
    monkeypatch.chdir(files["elsewhere"])
    warnings = package_uri_warnings(check_urdf(path.read_text(), "arm.urdf").robot, PackageResolver(near=path), "arm.urdf")
    assert [w.split(":")[1] for w in warnings] == ["4"]  # only the file:// one


def test_relative_meshes_are_not_checked_without_a_description_file(files):
    text = _relative_robot(files["robot"]).read_text()
    warnings = package_uri_warnings(check_urdf(text, "<string>").robot, PackageResolver(), "<string>")
    assert len(warnings) == 1 and "file://" in warnings[0]  # an absolute path is still checked


def test_missing_relative_mesh_is_a_warning_of_the_robot_and_on_the_command_line(files):
    from cli_helper import run_cli

    import manipkit

    path = _relative_robot(files["robot"])
    robot = manipkit.load(path)
    assert len(robot.mesh_warnings) == 2 and robot.mesh_warnings == robot.warnings
    result = run_cli("tf-between", "base_link", "link_1", "--robot", path, cwd=files["elsewhere"])
    assert result.returncode == 0, result.stderr
    assert result.stderr.splitlines() == [f"warning: {w}" for w in robot.mesh_warnings]


# ---------------------------------------------------------------- missing meshes drawn another way (issue 25)


def two_link_urdf(files) -> str:
    """``arm`` has a found mesh and a missing one; ``hand`` only a missing one and a box collision; ``tip`` a missing one."""
    return f"""<robot name="r">
  <link name="arm">
    <visual><geometry><mesh filename="package://my_pkg/meshes/arm.stl"/></geometry></visual>
    <visual><geometry><mesh filename="package://my_pkg/meshes/gone.stl"/></geometry></visual>
  </link>
  <link name="hand">
    <visual><geometry><mesh filename="{files['robot'] / 'meshes' / 'gone.stl'}"/></geometry></visual>
    <collision><origin xyz="0 0 0.05"/><geometry><box size="0.1 0.1 0.1"/></geometry></collision>
    <collision><geometry><mesh filename="package://my_pkg/meshes/gone.stl"/></geometry></collision>
  </link>
  <link name="tip"><visual><geometry><mesh filename="package://my_pkg/meshes/gone.stl"/></geometry></visual></link>
  <joint name="j1" type="revolute"><parent link="arm"/><child link="hand"/><origin xyz="0 0 0.3"/>
    <axis xyz="0 0 1"/><limit lower="-1" upper="1" effort="1" velocity="1"/></joint>
  <joint name="j2" type="fixed"><parent link="hand"/><child link="tip"/><origin xyz="0.2 0 0"/></joint>
</robot>"""


def test_missing_meshes_are_left_out_and_their_links_drawn_by_collision_shapes_or_a_ball(files):
    from manipkit.description.meshes import visual_urdf

    with pytest.raises(PackageNotFoundError, match="gone.stl"):
        visual_urdf(two_link_urdf(files), resolver_for(files), relative_to=files["robot"])
    text, folders, missing = visual_urdf(two_link_urdf(files), resolver_for(files), relative_to=files["robot"],
                                         missing="draw")
    root = ET.fromstring(text)
    visuals = {link.get("name"): [v.find("geometry")[0] for v in link.findall("visual")] for link in root.iter("link")}
    # arm keeps its found mesh (as a file path) and drops the missing one; hand gets its box collision (with its
    # origin); tip, a leaf with no collision, gets a ball at its origin
    assert [(g.tag, g.get("filename")) for g in visuals["arm"]] == [("mesh", str(files["package"] / "meshes" / "arm.stl"))]
    assert [g.tag for g in visuals["hand"]] == ["box"]
    assert root.find("link[@name='hand']/visual/origin").get("xyz") == "0 0 0.05"
    assert [g.tag for g in visuals["tip"]] == ["sphere"]
    assert folders == [str(files["package"].parent)]
    assert (len(missing.missing), missing.total, missing.by_collision, missing.by_lines) == (3, 4, ("hand",), ("tip",))
    assert missing.message("r").startswith("r: 3 of 4 visual mesh files are missing (the first: link 'arm' mesh "
                                           "package://my_pkg/meshes/gone.stl: resolves to ")
    assert missing.message("r").endswith("drawn instead: 1 link by their collision shapes, 1 link as lines between "
                                         "joint origins")


def test_a_link_without_collision_shapes_gets_a_line_to_each_child_joint(files):
    from manipkit.description.meshes import visual_urdf

    urdf = two_link_urdf(files).replace('<collision><origin xyz="0 0 0.05"/><geometry><box size="0.1 0.1 0.1"/>'
                                        '</geometry></collision>', "")
    text, _, missing = visual_urdf(urdf, resolver_for(files), relative_to=files["robot"], missing="draw")
    hand = ET.fromstring(text).find("link[@name='hand']")
    stick = [v for v in hand.findall("visual") if v.find("geometry/cylinder") is not None]
    assert len(stick) == 1 and missing.by_lines == ("hand", "tip")
    # the line to j2 (0.2 m along x): a cylinder 0.2 m long centred at (0.1, 0, 0), its z axis turned onto x
    assert float(stick[0].find("geometry/cylinder").get("length")) == pytest.approx(0.2, abs=1e-15)
    assert [float(v) for v in stick[0].find("origin").get("xyz").split()] == pytest.approx([0.1, 0, 0], abs=1e-15)
    assert [float(v) for v in stick[0].find("origin").get("rpy").split()] == pytest.approx([0, math.pi / 2, 0], abs=1e-15)


def test_an_unknown_missing_mode_is_an_option_error(files):
    from manipkit.description.meshes import visual_urdf
    from manipkit.errors import OptionError

    with pytest.raises(OptionError, match="missing='skip': give one of error, draw"):
        visual_urdf(two_link_urdf(files), resolver_for(files), relative_to=files["robot"], missing="skip")
