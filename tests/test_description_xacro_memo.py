"""A xacro expansion is kept for the process and used again only while everything it read is the same.

A notebook or a test session loads the same robot many times and the expansion is most of a load, so
:func:`manipkit.description.xacro.describe` keeps each expansion (module
``manipkit.description.xacro``). Each case here expands, changes one thing the expansion depends on
and expands again: the second text must be the one xacro itself makes of the changed files (counted
by how often ``xacro.process_file`` runs: once when nothing changed, twice when something did).
"""

from __future__ import annotations

import os
from pathlib import Path

import pytest
import xacro

from manipkit.description.sources import resolve_robot
from manipkit.description.srdf import read_srdf_file
from manipkit.description.xacro import describe

HEAD = '<?xml version="1.0"?>\n<robot name="r" xmlns:xacro="http://www.ros.org/wiki/xacro">\n'


@pytest.fixture
def expansions(monkeypatch):
    """The calls of xacro's own expansion, counted."""
    calls = []
    own = xacro.process_file

    def counted(*args, **kwargs):
        calls.append(args[0])
        return own(*args, **kwargs)

    monkeypatch.setattr(xacro, "process_file", counted)
    return calls


def _box(text: str) -> str:
    """The box size the single link's visual has, as written in the URDF text."""
    return text.split('<box size="', 1)[1].split('"', 1)[0]


def _arm(folder: Path, body: str, name: str = "arm.urdf.xacro") -> Path:
    folder.mkdir(parents=True, exist_ok=True)
    path = folder / name
    path.write_text(HEAD + body + "</robot>\n")
    return path


def _link(size: str) -> str:
    return f'<link name="a"><visual><geometry><box size="{size}"/></geometry></visual></link>\n'


def test_the_same_file_is_expanded_once_and_gives_the_same_text(tmp_path, expansions):
    path = _arm(tmp_path, '<xacro:include filename="part.xacro"/>\n' + _link("${w} 1 1"))
    (tmp_path / "part.xacro").write_text(HEAD + '<xacro:property name="w" value="0.5"/>\n</robot>\n')
    first = describe(resolve_robot(path))
    second = describe(resolve_robot(path))
    assert second == first and _box(second.text) == "0.5 1 1"
    assert len(expansions) == 1


def test_an_include_rewritten_at_once_with_the_same_size_is_read_again(tmp_path, expansions):
    """Within one clock tick a rewrite keeps the file's modification time and size: its bytes tell."""
    path = _arm(tmp_path, '<xacro:include filename="part.xacro"/>\n' + _link("${w} 1 1"))
    part = tmp_path / "part.xacro"
    part.write_text(HEAD + '<xacro:property name="w" value="0.5"/>\n</robot>\n')
    assert _box(describe(resolve_robot(path)).text) == "0.5 1 1"
    stamp = part.stat()
    part.write_text(HEAD + '<xacro:property name="w" value="0.7"/>\n</robot>\n')
    os.utime(part, ns=(stamp.st_atime_ns, stamp.st_mtime_ns))  # the same size and modification time
    assert _box(describe(resolve_robot(path)).text) == "0.7 1 1"
    assert len(expansions) == 2


def test_a_yaml_file_it_loads_is_read_again_when_changed(tmp_path, expansions):
    (tmp_path / "config.yaml").write_text("x: 2\n")
    path = _arm(tmp_path, '<xacro:property name="config" value="${xacro.load_yaml(\'config.yaml\')}"/>\n'
                + _link("${config['x']} 1 1"))
    assert _box(describe(resolve_robot(path)).text) == "2 1 1"
    (tmp_path / "config.yaml").write_text("x: 3\n")
    assert _box(describe(resolve_robot(path)).text) == "3 1 1"
    assert len(expansions) == 2


def test_other_arguments_are_another_expansion(tmp_path, expansions):
    path = _arm(tmp_path, '<xacro:arg name="w" default="1"/>\n' + _link("$(arg w) 1 1"))
    assert _box(describe(resolve_robot(path)).text) == "1 1 1"
    assert _box(describe(resolve_robot(path), {"w": 2}).text) == "2 1 1"
    assert _box(describe(resolve_robot(path)).text) == "1 1 1"
    assert len(expansions) == 2  # the default's expansion is used again


def test_an_expansion_reading_the_environment_is_never_kept(tmp_path, expansions, monkeypatch):
    path = _arm(tmp_path, _link("$(optenv MANIPKIT_TEST_SIZE 1) 1 1"))
    with pytest.warns(UserWarning, match="MANIPKIT_TEST_SIZE"):
        assert _box(describe(resolve_robot(path)).text) == "1 1 1"
    monkeypatch.setenv("MANIPKIT_TEST_SIZE", "4")
    with pytest.warns(UserWarning, match="MANIPKIT_TEST_SIZE"):
        assert _box(describe(resolve_robot(path)).text) == "4 1 1"
    assert len(expansions) == 2


def test_a_wildcard_include_is_never_kept_a_new_file_may_match_it(tmp_path, expansions):
    path = _arm(tmp_path, '<xacro:include filename="parts/*.xacro"/>\n' + _link("${w} 1 1"))
    _arm(tmp_path / "parts", '<xacro:property name="w" value="0.5"/>\n', "a.xacro")
    assert _box(describe(resolve_robot(path)).text) == "0.5 1 1"
    _arm(tmp_path / "parts", '<xacro:property name="w" value="0.9"/>\n', "b.xacro")  # read after a.xacro
    assert _box(describe(resolve_robot(path)).text) == "0.9 1 1"
    assert len(expansions) == 2


def _package(folder: Path, name: str, width: str) -> Path:
    folder.mkdir(parents=True)
    (folder / "package.xml").write_text(f"<package><name>{name}</name></package>\n")
    (folder / "part.xacro").write_text(HEAD + f'<xacro:property name="w" value="{width}"/>\n</robot>\n')
    return folder


def test_a_package_found_elsewhere_now_is_read_from_there(tmp_path, expansions, monkeypatch):
    """$(find) is asked again: the first copy on ROS_PACKAGE_PATH wins, so a new first entry changes it."""
    monkeypatch.delenv("AMENT_PREFIX_PATH", raising=False)
    first = _package(tmp_path / "one" / "parts_pkg", "parts_pkg", "0.2")
    second = _package(tmp_path / "two" / "parts_pkg", "parts_pkg", "0.3")
    # the arm in a workspace of its own (ws/src) that holds neither copy
    path = _arm(tmp_path / "ws" / "src" / "robot",
                '<xacro:include filename="$(find parts_pkg)/part.xacro"/>\n' + _link("${w} 1 1"))
    monkeypatch.setenv("ROS_PACKAGE_PATH", str(first))
    assert _box(describe(resolve_robot(path)).text) == "0.2 1 1"
    assert _box(describe(resolve_robot(path)).text) == "0.2 1 1"
    assert len(expansions) == 1
    monkeypatch.setenv("ROS_PACKAGE_PATH", str(second))
    assert _box(describe(resolve_robot(path)).text) == "0.3 1 1"
    assert _box(describe(resolve_robot(path), package_dirs={"parts_pkg": first}).text) == "0.2 1 1"
    assert len(expansions) == 3


def test_a_kept_expansion_is_the_callers_own_copy(tmp_path):
    path = _arm(tmp_path, '<xacro:arg name="w" default="1"/>\n' + _link("$(arg w) 1 1"))
    describe(resolve_robot(path)).declared["w"] = "changed"
    assert describe(resolve_robot(path)).declared == {"w": "1"}


def test_an_srdf_rewritten_at_once_with_the_same_size_is_parsed_again(tmp_path):
    srdf = tmp_path / "r.srdf"
    rule = '<robot name="r"><disable_collisions link1="{}" link2="b" reason="Adjacent"/></robot>\n'
    srdf.write_text(rule.format("a"))
    assert read_srdf_file(srdf).disabled == (("a", "b", "Adjacent"),)
    assert read_srdf_file(srdf) is read_srdf_file(srdf)  # parsed once
    stamp = srdf.stat()
    srdf.write_text(rule.format("c"))
    os.utime(srdf, ns=(stamp.st_atime_ns, stamp.st_mtime_ns))
    assert read_srdf_file(srdf).disabled == (("b", "c", "Adjacent"),)


def test_a_load_from_a_deleted_working_folder_answers_and_keeps_nothing(tmp_path, monkeypatch, expansions):
    """The kept expansion's key holds the working folder; where it is gone (os.getcwd() raises) the load still
    answers, as xacro alone does, and nothing is kept: each load expands again."""
    path = _arm(tmp_path / "robot", _link("0.5 1 1"))
    gone = tmp_path / "gone"
    gone.mkdir()
    monkeypatch.chdir(gone)
    gone.rmdir()
    assert _box(describe(resolve_robot(path)).text) == "0.5 1 1"
    assert _box(describe(resolve_robot(path)).text) == "0.5 1 1"
    assert len(expansions) == 2
