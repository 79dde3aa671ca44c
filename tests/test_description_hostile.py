"""Hostile descriptions, second round (issue 26): bounded values, bounded time, what a description may read.

The cases as a user meets them (the CLI, one line, exit 2, under a memory and
time limit) are in tests/bad_inputs/cases_hostile_desc.yaml; here the library:
every value an expression builds is bounded by an estimate before it is built
(integers from any source, formatted text, nesting through slices), YAML loads
count against the budgets, a description reads only its own folder tree, its
packages and the folders the user allows, the Python API names a bad argument,
and the tree prints on a terminal without box-drawing characters.
"""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest
from hypothesis import given
from hypothesis import strategies as st

import manipkit
from manipkit.description import expressions, xacro
from manipkit.description.expression_limits import MAX_INT_BITS, MAX_SIZE, MAX_VALUE_DEPTH, measure, text_estimate
from manipkit.description.sources import resolve_robot
from manipkit.description.xacro import describe
from manipkit.description.xacro_names import MAX_YAML_BYTES, evaluate_expression
from manipkit.errors import (
    DescriptionError,
    OutputError,
    PackageNotFoundError,
    ReadNotAllowedError,
    UnknownRobotError,
)

BIN = Path(sys.executable).parent
HEAD = '<?xml version="1.0"?>\n<robot name="r" xmlns:xacro="http://www.ros.org/wiki/xacro">\n'


def _table(properties):
    import xacro as xacro_package

    table = xacro_package.Table()
    for key, value in properties.items():
        dict.__setitem__(table, key, value)
    return table


def _slices(depth: int):
    value = slice(1, 2, 3)
    for _ in range(depth - 1):
        value = slice(value, None, None)
    return value


# --------------------------------------------------------------------------
# Every value is bounded before it is built
# --------------------------------------------------------------------------

MB = "x" * 1_000_000
REFUSED = [
    # integers of millions of bits, then an uninterruptible division
    ("python.int(h, 16) // 3", {"h": "f" * 100_000},
     "int() of a text of 100000 characters would have up to 400000 bits, above the limit of 10000 bits"),
    ("python.int(h, 0)", {"h": "0x" + "f" * 5000}, "would have up to"),
    ("0x" + "f" * 3000 + " % 2", {}, "an integer literal of 12000 bits, above the limit of 10000 bits"),
    ("big // 3", {"big": 1 << 40_000}, "<40001-bit integer> // 3: an operand of 40001 bits, above the limit"),
    ("big % 3", {"big": 1 << 40_000}, "an operand of 40001 bits"),
    ("python.divmod(big, 3)", {"big": 1 << 40_000}, "an operand of 40001 bits"),
    # nesting through slices (freeing a chain of 475,000 crashed CPython) and containers
    ("python.slice(s, s)", {"s": _slices(MAX_VALUE_DEPTH)}, f"nested more than {MAX_VALUE_DEPTH} levels deep"),
    ("[[[l]]]", {"l": [[[[0]]]] * 1}, None),  # fine: 7 deep
    ("[l]", {"l": eval("[" * 101 + "]" * 101)}, f"nested more than {MAX_VALUE_DEPTH} levels deep"),  # noqa: S307
    ("python.slice(s).start", {"s": [1] * 10}, None),
    # formatting: each field as long as its argument, counted before the text is made
    ("'%(a)s' * 1000 % d", {"d": {"a": MB}}, "the % formatted string would have about 1000005000 characters"),
    ("'%r%r' % (s, s)", {"s": "\x00" * 1_000_000}, "the % formatted string would have about 20000008 characters"),
    ("f.format(s)", {"f": "{0}" * 1000, "s": MB}, "the formatted string would have about 1000003000 characters"),
    ("f.format(a=s)", {"f": "{a}" * 1000, "s": MB}, "the formatted string would have about"),
    ("f'{s}{s}{s}{s}{s}'", {"s": MB}, "the f-string would have more than 4194304 characters"),
    ("f'{l!r}'", {"l": ["\x00" * 900_000] * 4}, "the f-string field {l} would have about"),
    ("f'{1:>999999999}'", {}, "a width or precision of 9 digits in a format spec"),
    ("python.repr([s, s, s, s])", {"s": "\x00" * 900_000}, "repr() of the value would have about"),
    ("str(l)", {"l": list(range(3_000_000))}, "str() of the value would have about"),
]


@pytest.mark.parametrize("expression, properties, fragment", REFUSED, ids=[e[:40] for e, _, _ in REFUSED])
def test_a_value_beyond_the_bounds_is_refused_before_it_is_built(expression, properties, fragment, monkeypatch):
    monkeypatch.setattr(expressions, "TIME_BUDGET_S", 60.0)  # about the bound, not about time
    if fragment is None:
        evaluate_expression(expression, _table(properties))
        return
    with pytest.raises(DescriptionError) as info:
        evaluate_expression(expression, _table(properties))
    message = str(info.value)
    assert message.startswith("xacro expression ${") and fragment in message and "\n" not in message


def test_values_within_the_bounds_are_pythons_own():
    table = _table({"h": "ff" * 600, "d": {"a": "link"}, "f": "{0}_{1}"})
    assert evaluate_expression("python.int(h, 16)", table) == int("ff" * 600, 16)
    assert evaluate_expression("'%(a)s_%(a)s' % d", table) == "link_link"
    assert evaluate_expression("f.format(1, 'x')", table) == "1_x"
    assert evaluate_expression("python.slice(1, 5, 2)", table) == slice(1, 5, 2)
    assert evaluate_expression("(2 ** 5000) // 3 % 1000", table) == (2 ** 5000) // 3 % 1000
    assert evaluate_expression("f'{1.5:>10.3f}'", table) == f"{1.5:>10.3f}"


def test_measure_walks_a_long_chain_of_slices_without_recursion():
    size, depth, _ = measure(_slices(20_000))  # (a chain of 475,000 crashes CPython when it is freed)
    assert depth == MAX_VALUE_DEPTH + 1 and size < 10 * MAX_VALUE_DEPTH  # stopped past the bound



@given(st.one_of(st.text(max_size=40), st.floats(allow_nan=True, allow_infinity=True)))
def test_a_text_or_float_measures_as_its_one_item_dict_less_the_dict(value):
    # measure returns a str or a float at once; the dict {value: None} goes through the walk, which adds the dict
    # (1), None (1, depth 1) and nests value one level down: the same value must come out of both.
    size, depth, bits = measure({value: None})
    assert measure(value) == (size - 2, depth - 1, bits)

def test_text_estimate_bounds_the_real_length_from_above():
    for value in ["abc", "a'b\\c", "\x00\u202e", 2 ** 3000, -1.5e300, [1, "x", None, (2.5, {"k": b"\x00"})],
                  {1: [slice(1, None, -1)]}, frozenset({1, 2}), range(5), True]:
        assert text_estimate(value) >= len(str(value))
        assert text_estimate(value, quoted=True) >= len(repr(value))


# --------------------------------------------------------------------------
# YAML loads count against the budgets
# --------------------------------------------------------------------------


def _xacro_with(folder: Path, body: str, xyz: str = "0") -> Path:
    path = folder / "arm.urdf.xacro"
    path.write_text(HEAD + body + '<link name="base_link"/>\n<link name="tool"/>\n'
                    '<joint name="j" type="fixed"><parent link="base_link"/><child link="tool"/>\n'
                    f'  <origin xyz="{xyz} 0 0"/></joint>\n</robot>\n')
    return path


def test_a_comprehension_of_yaml_loads_ends_at_the_time_budget(tmp_path):
    (tmp_path / "c.yaml").write_text("".join(f"k{i}: [{i}, {i}.5, abc{i}]\n" for i in range(1000)))
    path = _xacro_with(tmp_path, "", "${len([xacro.load_yaml('c.yaml') for i in python.range(2000)])}")
    with pytest.raises(DescriptionError, match=r"evaluation took more than 2 s \(the time budget\)"):
        describe(resolve_robot(path))


def test_a_yaml_file_above_its_bound_is_refused_before_it_is_read(tmp_path):
    (tmp_path / "c.yaml").write_text("x: [" + "1, " * (MAX_YAML_BYTES // 3) + "1]\n")
    path = _xacro_with(tmp_path, "", "${xacro.load_yaml('c.yaml')['x'][0]}")
    with pytest.raises(DescriptionError, match=r"c.yaml is 262,150 bytes, above the limit of 256 kB"):
        describe(resolve_robot(path))


def test_yaml_nested_beyond_the_bound_and_huge_yaml_integers_are_refused(tmp_path):
    (tmp_path / "deep.yaml").write_text("x: " + "[" * 150 + "]" * 150 + "\n")
    path = _xacro_with(tmp_path, "", "${len(xacro.load_yaml('deep.yaml'))}")
    with pytest.raises(DescriptionError, match=f"deep.yaml: the YAML document expands \\(through its aliases\\) to "
                       f"more than {MAX_VALUE_DEPTH} levels of nesting"):
        describe(resolve_robot(path))
    (tmp_path / "big.yaml").write_text("x: 0x" + "f" * 5000 + "\ny: " + ":".join(["59"] * 3000) + "\n")
    path = _xacro_with(tmp_path, "", "${len(xacro.load_yaml('big.yaml'))}")
    with pytest.raises(DescriptionError, match="a YAML integer of 5002 characters may have more than 10000 bits"):
        describe(resolve_robot(path))


def test_the_expansion_budget_bounds_every_evaluation_in_it(tmp_path, monkeypatch):
    monkeypatch.setattr(xacro, "EXPANSION_SECONDS", 0.3)
    path = _xacro_with(tmp_path, '<xacro:property name="s" value="${\'x\' * 1000000}"/>\n',
                       "${len([len(sorted(s)) for i in python.range(10000)])}")
    with pytest.raises(DescriptionError, match=r"arm.urdf.xacro: xacro expansion took more than 0.3 s, the limit"):
        describe(resolve_robot(path))


def test_what_xacro_prints_is_bounded(tmp_path):
    path = _xacro_with(tmp_path, "", "${len([xacro.message('x' * 1000000) for i in python.range(200)])}")
    assert 'xyz="200 0 0"' in describe(resolve_robot(path)).text  # 200 MB printed would be kept before
    assert xacro.MAX_XACRO_OUTPUT <= 1 << 20


# --------------------------------------------------------------------------
# What a description may read
# --------------------------------------------------------------------------


@pytest.fixture
def outside(tmp_path):
    """``tmp_path/desc/`` (the description's own folder) and ``tmp_path/secret/`` beside it."""
    (tmp_path / "desc").mkdir()
    (tmp_path / "secret").mkdir()
    (tmp_path / "secret" / "s.yaml").write_text("password: hunter2\n")
    (tmp_path / "secret" / "part.xacro").write_text(HEAD + '<link name="secret_link"/>\n</robot>\n')
    return tmp_path


def test_load_yaml_outside_the_description_is_refused_with_the_path_and_the_way_to_allow_it(outside):
    path = _xacro_with(outside / "desc", "", "${xacro.load_yaml('../secret/s.yaml')}")
    with pytest.raises(ReadNotAllowedError) as info:
        describe(resolve_robot(path))
    message = str(info.value)
    assert f"xacro.load_yaml: {outside / 'secret' / 's.yaml'} is outside what arm.urdf.xacro may read" in message
    assert f"--allow-read {outside / 'secret'}" in message and "hunter2" not in message


def test_allow_read_lets_the_description_read_a_folder(outside):
    path = _xacro_with(outside / "desc", "", "${len(xacro.load_yaml('../secret/s.yaml'))}")
    assert 'xyz="1 0 0"' in describe(resolve_robot(path), allow_read=(outside / "secret",)).text
    robot = manipkit.load(path, allow_read=outside / "secret")
    assert robot.allow_read == (outside / "secret",)


def test_allow_read_given_as_one_string_is_one_folder_not_its_characters(outside):
    path = _xacro_with(outside / "desc", "", "${xacro.load_yaml('/etc/passwd')}")
    with pytest.raises(ReadNotAllowedError, match="/etc/passwd is outside"):
        describe(resolve_robot(path), allow_read=str(outside / "secret"))  # tuple("/...") would allow "/"


def test_an_include_outside_the_description_is_refused_and_a_package_is_allowed(outside):
    path = _xacro_with(outside / "desc", '<xacro:include filename="../secret/part.xacro"/>\n')
    with pytest.raises(ReadNotAllowedError, match=r"arm.urdf.xacro:3: xacro:include: .*secret/part.xacro is outside"):
        describe(resolve_robot(path))
    path = _xacro_with(outside / "desc", '<xacro:include filename="$(find secret_pkg)/part.xacro"/>\n')
    text = describe(resolve_robot(path), package_dirs={"secret_pkg": outside / "secret"}).text
    assert "secret_link" in text


def test_a_link_inside_the_tree_to_a_file_outside_is_refused(outside):
    (outside / "desc" / "s.yaml").symlink_to(outside / "secret" / "s.yaml")
    path = _xacro_with(outside / "desc", "", "${xacro.load_yaml('s.yaml')}")
    with pytest.raises(ReadNotAllowedError, match=r"s.yaml \(a link to .*secret/s.yaml\) is outside"):
        describe(resolve_robot(path))


def test_the_package_around_a_description_is_its_tree(outside):
    package = outside / "desc"
    (package / "package.xml").write_text("<package><name>desc</name></package>\n")
    (package / "config").mkdir()
    (package / "config" / "c.yaml").write_text("x: 2\n")
    (package / "urdf").mkdir()
    path = _xacro_with(package / "urdf", "", "${xacro.load_yaml('../config/c.yaml')['x']}")
    assert 'xyz="2 0 0"' in describe(resolve_robot(path)).text


def test_a_mesh_outside_the_description_is_named_not_looked_at(outside):
    path = outside / "desc" / "arm.urdf"
    path.write_text('<robot name="r"><link name="base_link"><visual><geometry><mesh filename="/etc/passwd"/>'
                    "</geometry></visual></link></robot>\n")
    robot = manipkit.load(path)
    assert any("/etc/passwd is outside what the description may read" in w for w in robot.warnings)
    with pytest.raises(ReadNotAllowedError, match="link 'base_link': mesh /etc/passwd: /etc/passwd is outside"):
        robot.visual_model()


def test_environment_variables_a_description_reads_are_named_in_a_warning(tmp_path, monkeypatch):
    monkeypatch.setenv("MANIPKIT_TEST_SECRET", "s3cret")
    path = _xacro_with(tmp_path, '<xacro:property name="v" value="$(env MANIPKIT_TEST_SECRET)"/>\n'
                       '<xacro:property name="w" value="$(optenv MANIPKIT_TEST_UNSET none)"/>\n', "${len(v + w) * 0}")
    with pytest.warns(UserWarning, match=r"arm.urdf.xacro: reads environment variable\(s\) MANIPKIT_TEST_SECRET, "
                      r"MANIPKIT_TEST_UNSET \(\$\(env\)/\$\(optenv\)\)"):
        describe(resolve_robot(path))


# --------------------------------------------------------------------------
# The Python API names a bad argument
# --------------------------------------------------------------------------

API_CASES = [
    ({"robot": 5}, UnknownRobotError, "robot: expected a name or a path (str or pathlib.Path), not int 5"),
    ({"robot": b"arm.urdf"}, UnknownRobotError, "robot: expected a name or a path"),
    ({"robot": "arm\x00.urdf"}, UnknownRobotError, "robot: 'arm\\x00.urdf' holds a NUL byte (character 4)"),
    ({"package_dirs": ["a"]}, PackageNotFoundError, "package_dirs: expected a dict of package name -> folder, not list"),
    ({"package_dirs": {1: "/tmp"}}, PackageNotFoundError, "package_dirs: a package name is a non-empty line of text"),
    ({"package_dirs": {"p": 5}}, PackageNotFoundError, "package_dirs['p']: expected a folder path"),
    ({"package_dirs": {"p": "/no/such/folder"}}, PackageNotFoundError,
     "package_dirs['p'] (--package-dir p=DIR): /no/such/folder: no such folder"),
    ({"package_dirs": {"p": "a\x00b"}}, PackageNotFoundError, "package_dirs['p']: 'a\\x00b' is not a folder path"),
    ({"allow_read": 5}, DescriptionError, "allow_read: expected a folder or a list of folders, not int"),
    ({"allow_read": ["/no/such/folder"]}, DescriptionError, "allow_read: '/no/such/folder' is not a folder"),
]


@pytest.mark.parametrize("kwargs, error, fragment", API_CASES, ids=[repr(k)[:40] for k, _, _ in API_CASES])
def test_a_bad_argument_of_load_is_a_manipkit_error_naming_it(kwargs, error, fragment):
    kwargs = {"robot": "planar_2r", **kwargs}
    with pytest.raises(error) as info:
        manipkit.load(kwargs.pop("robot"), **kwargs)
    assert fragment in str(info.value)


# --------------------------------------------------------------------------
# The tree: any terminal, a bounded image
# --------------------------------------------------------------------------


@pytest.mark.parametrize("environment", [{"PYTHONIOENCODING": "ascii"}, {"LC_ALL": "C", "PYTHONIOENCODING": ""}])
def test_tree_prints_on_a_terminal_without_box_drawing_characters(environment):
    env = {**os.environ, **environment}
    result = subprocess.run([str(BIN / "manipkit"), "tree", "--robot", "course_arm"], capture_output=True,
                            text=True, env=env, timeout=60)
    assert result.returncode == 0 and result.stderr == "", result.stderr
    assert "arm_base_joint (continuous, axis 0 0 1)" in result.stdout


def test_tree_text_in_ascii_has_the_same_lines():
    from manipkit.description.tree import parse_structure, tree_text

    description = parse_structure(manipkit.load("course_arm").urdf)
    boxed, plain = tree_text(description), tree_text(description, ascii_only=True)
    assert plain.isascii() and "`-- arm_base_joint (continuous, axis 0 0 1) -- arm_base" in plain
    assert plain == boxed.replace("└── ", "`-- ").replace("├── ", "|-- ").replace("│   ", "|   ").replace(" ── ", " -- ")


def test_a_tree_image_beyond_its_bound_is_refused_with_the_numbers_before_drawing(tmp_path):
    from manipkit.description.tree import MAX_IMAGE_LINKS, parse_structure, write_tree_image

    links = "".join(f'<link name="l{i}"/><joint name="j{i}" type="fixed"><parent link="l0"/><child link="l{i}"/></joint>'
                    for i in range(1, MAX_IMAGE_LINKS + 1))
    description = parse_structure(f'<robot name="wide"><link name="l0"/>{links}</robot>')
    with pytest.raises(OutputError, match=f"cannot draw a tree image of {MAX_IMAGE_LINKS + 1} links \\(t.png\\); an "
                       f"image shows up to {MAX_IMAGE_LINKS} links"):
        write_tree_image(description, tmp_path / "t.png")
    assert not (tmp_path / "t.png").exists()


def test_the_bounds_leave_room_for_real_values():
    assert MAX_INT_BITS >= 1000 and MAX_SIZE >= 1_000_000 and MAX_VALUE_DEPTH >= 20 and MAX_YAML_BYTES >= 64 * 1024


def test_a_chain_of_lazy_iterators_through_properties_is_bounded_like_a_container():
    table = _table({})
    chain = evaluate_expression("python.zip([1])", table)
    with pytest.raises(DescriptionError, match=f"python.zip\\(...\\) would be nested more than {MAX_VALUE_DEPTH} "
                       "levels deep"):
        for _ in range(MAX_VALUE_DEPTH):  # each wraps the one before, as a chain of properties would
            dict.__setitem__(table, "p", chain)
            chain = evaluate_expression("python.zip(p)", table)
    assert evaluate_expression("python.list(python.map(python.abs, [-1, 2]))", table) == [1, 2]


def test_a_message_from_a_description_reaches_python_without_terminal_controls(tmp_path):
    path = _xacro_with(tmp_path, "", "${xacro.fatal('\\x1b[2J\\x1b]0;pwned\\x07\\u202egone')}")
    with pytest.raises(DescriptionError) as info:
        describe(resolve_robot(path))
    message = str(info.value)
    assert not any(c in message for c in "\x1b\x07\u202e") and "\\x1b[2J\\x1b]0;pwned\\x07\\u202egone" in message
