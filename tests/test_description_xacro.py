"""xacro made safe: expressions evaluated without running code, bounded cost, safe YAML and includes.

The escapes and bombs as a user meets them (the CLI, one line, exit 2) are in
tests/bad_inputs/cases_xacro.yaml; here the library: every description that
loads expands to exactly what xacro itself makes of it, allowed expressions
give Python's own value, refused ones name what is refused, the names are
xacro's, and files are checked before xacro opens them.
"""

from __future__ import annotations

import glob
import math
import os
import subprocess
import sys
from pathlib import Path

import pytest

import manipkit
from manipkit.description.expressions import MAX_INT_BITS, MAX_SIZE
from manipkit.description.sources import bundled_robots, example_robot_data_dir, resolve_robot
from manipkit.description.xacro import describe, xacro_locator
from manipkit.description.xacro_names import evaluate_eval, evaluate_expression, xacro_globals
from manipkit.errors import DescriptionError, InputFileError

BIN = Path(sys.executable).parent
# shared/ sits beside the repository (CI, /work/main) or beside the folder of worktrees
REALWORLD = next((base / "shared" / "realworld" / "ws_ros1" / "src" for base in Path(__file__).resolve().parents[2:4]
                  if (base / "shared" / "realworld").is_dir()), Path("/nonexistent"))
HEAD = '<?xml version="1.0"?>\n<robot name="r" xmlns:xacro="http://www.ros.org/wiki/xacro">\n'


# --------------------------------------------------------------------------
# Every description that loads expands as xacro itself expands it
# --------------------------------------------------------------------------


def _realworld_packages() -> dict[str, Path]:
    return {Path(p).parent.name: Path(p).parent for p in glob.glob(str(REALWORLD / "*" / "*" / "package.xml"))}


def _descriptions() -> list:
    cases = [pytest.param(path, {}, {}, id=f"bundled-{name}") for name, path in sorted(bundled_robots().items())]
    erd = example_robot_data_dir()
    if erd is not None:
        cases += [pytest.param(Path(p), {}, {}, id=f"erd-{Path(p).name}")
                  for p in sorted(glob.glob(str(erd) + "/**/*.urdf.xacro", recursive=True))]
    packages = _realworld_packages()
    for path in sorted(glob.glob(str(REALWORLD / "**" / "*.xacro"), recursive=True)):
        label = str(Path(path).relative_to(REALWORLD))
        cases.append(pytest.param(Path(path), {}, packages, id=f"ros-{label}"))
        if path.endswith("ur_description/urdf/ur.xacro"):
            cases.append(pytest.param(Path(path), {"robot_model": "ur5e"}, packages, id=f"ros-{label}-ur5e"))
    return cases


def _xacro_itself(path: Path, args: dict, packages: dict, monkeypatch) -> str | None:
    """What the xacro package makes of a file (its own evaluation, ``$(find)`` from ``packages``), or None."""
    import io
    from contextlib import redirect_stderr, redirect_stdout

    import xacro
    import xacro.substitution_args as substitution_args

    monkeypatch.setattr(substitution_args, "_eval_find", lambda package: str(packages[package]))
    xacro.all_includes.clear()
    quiet = io.StringIO()
    try:
        with redirect_stdout(quiet), redirect_stderr(quiet):
            return xacro.process_file(str(path), mappings=dict(args)).toxml()
    except Exception:  # noqa: BLE001 - xacro cannot expand it either
        return None


@pytest.mark.parametrize("path, args, packages", _descriptions())
def test_a_description_expands_exactly_as_xacro_itself_expands_it(path, args, packages, monkeypatch):
    expected = _xacro_itself(path, args, packages, monkeypatch)
    monkeypatch.undo()
    if expected is None:
        with pytest.raises(manipkit.ManipkitError):
            describe(resolve_robot(path), args, packages)
        return
    try:
        text = describe(resolve_robot(path), args, packages).text
    except DescriptionError as exc:
        assert "unknown xacro argument" in str(exc)  # manipkit is stricter about arguments than xacro, nothing else
        return
    assert text == expected


def test_the_descriptions_compared_include_the_real_ones_with_yaml():
    ids = [p.id for p in _descriptions()]
    assert sum(i.startswith("bundled-") for i in ids) == len(bundled_robots())
    if REALWORLD.is_dir():  # ur5e reads four YAML files through xacro.load_yaml
        assert "ros-universal_robot/ur_description/urdf/ur5e.xacro" in ids


# --------------------------------------------------------------------------
# Allowed expressions: Python's own value
# --------------------------------------------------------------------------

PROPERTIES = {"a": 2, "b": 0.5, "name": "arm", "xyz": "0.1 0.2 0.3", "items": [3, 1, 2], "flag": True}


def _table(properties=PROPERTIES):
    import xacro

    table = xacro.Table()
    for key, value in properties.items():
        dict.__setitem__(table, key, value)
    return table


def _python(expression: str):
    """The same expression evaluated by Python itself, with the same names (safe: these are known expressions)."""
    import builtins

    names = {k: v for k, v in vars(math).items() if not k.startswith("_")}
    names.update({k: getattr(builtins, k) for k in ("list", "dict", "map", "len", "str", "float", "int", "bool",
                                                    "min", "max", "round", "sorted", "range")})
    python = type("Python", (), {k: staticmethod(getattr(builtins, k)) if callable(getattr(builtins, k))
                                 else getattr(builtins, k) for k in ("sum", "abs", "zip", "enumerate", "any", "all",
                                                                    "tuple", "set", "reversed", "range", "sorted")})
    return eval(expression, {"__builtins__": {}}, {**names, **PROPERTIES, "python": python, "math": math})  # noqa: S307


ALLOWED = [
    "pi / 2", "-pi/2", "a * b + 1", "a ** 10", "2 ** -1", "7 // a", "7 % a", "-a", "not flag", "~a", "a << 3", "a > b",
    "0 < b < a", "a == 2 and b or 3", "a if flag else b", "max(a, b, 0.1)", "min([3, 4])",
    "round(3.14159, 2)", "fabs(-b)", "radians(90)", "degrees(pi)", "sin(pi / 6)", "cos(0)", "atan2(1, 1)", "sqrt(a)",
    "math.pi", "math.cos(pi)", "int('7') + float('0.5')", "str(a) + '_' + name", "name.upper()",
    "xyz.split(' ')[2]", "float(xyz.split()[1]) * 2", "'%s_link' % name", "'%.3f' % pi", "'{}_{}'.format(name, a)",
    "len(name)", "items[1:]", "items[-1]", "sorted(items)", "list(range(3))", "python.sum(items)",
    "[i * 2 for i in items if i > 1]", "(i for i in items)", "dict(k=1)['k']", "(1, 2) + (3,)", "[0] * 3",
    "'ab' * 3", "f'{a}-{name}'", "f'{pi:.2f}'", "f'{name!r}'", "python.abs(-3)", "1e308 * 10", "a in items",
    "'r' in name", "name is None", "[*items, 4]", "max(*items)", "python.tuple(python.reversed(items))",
    "[x + y for x, y in python.zip(items, items)]", "python.any([0, 1])", "True", "None", "1 if [] else 2",
]


@pytest.mark.parametrize("expression", ALLOWED)
def test_an_allowed_expression_gives_pythons_own_value(expression):
    value = evaluate_expression(expression, _table())
    expected = _python(expression)
    if not isinstance(expected, (int, float, str, bool, list, tuple, dict, set, type(None))):
        expected = list(expected)  # a generator expression is made a list here
    assert value == expected and type(value) is type(expected)


def test_math_and_builtin_names_are_xacros_own_less_type_and_vars():
    import xacro

    theirs = xacro._global_symbols
    ours = xacro_globals()
    assert set(ours) == {name for name in theirs if not name.startswith("__")}  # xacro's eval adds __builtins__
    for namespace in ("python", "math", "xacro"):
        assert set(ours[namespace]) == set(dict.keys(theirs[namespace])) - {"type", "vars"}
    assert ours["pi"] == math.pi and ours["radians"](180) == math.pi


def test_properties_are_evaluated_lazily_through_the_safe_evaluator():
    import xacro

    table = xacro.Table()
    table["width"] = "${2 * length}"
    table["length"] = "0.5"
    assert evaluate_expression("width + 1", table) == 2.0


def test_eval_substitution_has_xacros_names_and_the_arguments(tmp_path):
    path = tmp_path / "eval.urdf.xacro"
    path.write_text(HEAD + '<xacro:arg name="l1" default="0.5"/>\n'
                    '<link name="a"><visual><geometry><box size="$(eval l1 * 2) $(eval pi) $(eval true and 3)"/>'
                    "</geometry></visual></link>\n</robot>\n")
    text = describe(resolve_robot(path)).text
    assert 'size="1.0 3.141592653589793 3"' in text
    assert evaluate_eval("max(2, 3) + abs(-1)") == "4"


# --------------------------------------------------------------------------
# Refused expressions: nothing runs, one line names the expression and why
# --------------------------------------------------------------------------

REFUSED = [
    ("(lambda: 0)()", "lambda is not allowed"),
    ("().__class__", "attribute '__class__' is not allowed"),
    ("[c for c in ().__class__.__base__.__subclasses__()]", "attribute '__"),
    ("[g.gi_frame for g in [(i for i in [1])]]", "'list' object has no attribute 'gi_frame'"),
    ("'{0.__class__}'.format(1)", "format field '{0.__class__}' is not allowed"),
    ("'{0[0]}'.format('ab')", "format field '{0[0]}' is not allowed"),
    ("f'{().__class__}'", "attribute '__class__' is not allowed"),
    ("getattr(1, 'real')", "name 'getattr' is not defined"),
    ("python.type(1)", "name 'type' is not defined"),
    ("python.vars()", "name 'vars' is not defined"),
    ("__import__('os')", "name '__import__' is not allowed"),
    ("__builtins__", "name '__builtins__' is not allowed"),
    ("str.join", "attribute 'join' of type values is not allowed"),
    ("math.sin.__self__", "attribute '__self__' is not allowed"),
    ("[].append(1)", "attribute 'append' of list values is not allowed"),
    ("[1 for name.x in [1]]", "a comprehension assigns to names only"),
    ("a @ a", "the @ operator is not allowed"),
    ("(y := 1)", "assignment (:=) is not allowed"),
    ("items.__len__", "attribute '__len__' is not allowed"),
    ("1 if True else (lambda: 0)", "lambda is not allowed"),
    ("9**9**9 % 7", "9 ** 387420489 would have about 1.55e+09 bits, above the limit of 10000 bits"),
    ("'ab' * 10**10", "repeating a str of size 2 10000000000 times"),
    ("[[0] * 1000] * 100000", "repeating a list of size 1002 100000 times"),
    ("1 << 10**9", "1 << 1000000000 would have about 1e+09 bits"),
    ("'%999999999d' % 1", "a width or precision of 9 digits in a % format"),
    ("'%*d' % (5, 1)", "a '*' width or precision in a % format is not allowed"),
    ("f'{1:>999999999}'", "a width or precision of 9 digits in a format spec"),
    ("'x'.center(10**9)", "str.center(1000000000) would make a string above the limit"),
    ("math.factorial(10**6)", "factorial(1000000) would have more than 10000 bits"),
    ("list(python.range(10**12))", "range(1000000000000,) has 1000000000000 items"),
    ("[1 for i in python.range(10**6)]", "comprehensions ran more than 10000 steps"),
    ("python.sum([[1]], [])", "python.sum adds numbers only"),
    ("-(" * 120 + "1" + ")" * 120, "nested more than 100 levels deep"),
]


@pytest.mark.parametrize("expression, fragment", REFUSED, ids=[e[:40] for e, _ in REFUSED])
def test_a_refused_expression_names_itself_and_why_in_one_line(expression, fragment):
    with pytest.raises(DescriptionError) as info:
        evaluate_expression(expression, _table())
    message = str(info.value)
    assert message.startswith("xacro expression ${") and fragment in message
    assert "\n" not in message


def test_the_limits_leave_room_for_real_values():
    assert evaluate_expression("2 ** 1000", _table()) == 2 ** 1000
    assert len(evaluate_expression("'x' * 1000000", _table())) == 1_000_000
    assert MAX_INT_BITS >= 1000 and MAX_SIZE >= 1_000_000


def test_a_time_budget_ends_an_evaluation_that_passes_every_size_limit():
    table = _table({"s": "x" * 1_000_000})
    with pytest.raises(DescriptionError, match=r"evaluation took more than 2 s \(the time budget\)"):
        evaluate_expression("[len(sorted(s)) for i in python.range(10000)]", table)


def test_a_refused_expression_in_a_file_names_the_file_and_line(tmp_path):
    path = tmp_path / "arm.urdf.xacro"
    path.write_text(HEAD + '<link name="a"/>\n<link name="${().__class__.__name__}"/>\n</robot>\n')
    with pytest.raises(DescriptionError, match=r"^arm.urdf.xacro:4: xacro expression \$\{\(\).__class__.__name__\}: "
                                               r"attribute '__"):
        manipkit.load(path)


def test_the_escape_of_the_issue_runs_nothing(tmp_path):
    marker = tmp_path / "ran"
    path = tmp_path / "arm.urdf.xacro"
    payload = (f"(lambda: [c for c in ().__class__.__base__.__subclasses__() if c.__name__ == 'catch_warnings'][0]()"
               f"._module.sys.modules['os'].system('touch {marker}'))()")
    path.write_text(HEAD + f'<link name="${{{payload}}}"/>\n</robot>\n')
    with pytest.raises(DescriptionError, match="lambda is not allowed"):
        manipkit.load(path)
    assert not marker.exists()


# --------------------------------------------------------------------------
# xacro.load_yaml and includes
# --------------------------------------------------------------------------


def _with_yaml(tmp_path, yaml_text: str, expression: str = "config['x']") -> Path:
    (tmp_path / "config.yaml").write_text(yaml_text)
    path = tmp_path / "arm.urdf.xacro"
    path.write_text(HEAD + '<xacro:property name="config" value="${xacro.load_yaml(\'config.yaml\')}"/>\n'
                    f'<link name="a"><visual><geometry><box size="${{{expression}}} 1 1"/></geometry></visual></link>\n'
                    "</robot>\n")
    return path


def test_load_yaml_reads_plain_yaml_and_xacros_unit_tags(tmp_path):
    path = _with_yaml(tmp_path, "x: !degrees 90\ny: {z: 2}\n", "config['x'] + config.y.z")
    assert f'size="{math.pi / 2 + 2} 1 1"' in describe(resolve_robot(path)).text


def test_load_yaml_refuses_python_tags_and_names_the_yaml_line(tmp_path):
    path = _with_yaml(tmp_path, "# runs a command with an unsafe loader\nx: !!python/object/apply:os.system ['touch ran']\n")
    with pytest.raises(DescriptionError, match=r"arm.urdf.xacro:3: xacro expression \$\{xacro.load_yaml\('config.yaml'\)\}: "
                                               r"config.yaml:2: could not determine a constructor for the tag"):
        describe(resolve_robot(path))
    assert not (tmp_path / "ran").exists() and not Path("ran").exists()


def test_load_yaml_refuses_aliases_that_expand_past_the_limit(tmp_path):
    lines = ['a: &a ["lol", "lol", "lol", "lol", "lol", "lol", "lol", "lol", "lol"]']
    for previous, name in zip("abcdefgh", "bcdefghi"):
        lines.append(f"{name}: &{name} [" + ", ".join([f"*{previous}"] * 9) + "]")
    path = _with_yaml(tmp_path, "\n".join(lines) + "\n", "len(str(config))")
    with pytest.raises(DescriptionError, match="expands \\(through its aliases\\) to more than"):
        describe(resolve_robot(path))


def test_load_yaml_accepts_a_few_aliases(tmp_path):
    path = _with_yaml(tmp_path, "base: &b {x: 1.5}\nx: *b\n", "config['x']['x']")
    assert 'size="1.5 1 1"' in describe(resolve_robot(path)).text


def test_load_yaml_checks_the_file_before_reading_it(tmp_path):
    path = _with_yaml(tmp_path, "x: 1\n")
    (tmp_path / "config.yaml").unlink()
    (tmp_path / "config.yaml").mkdir()
    with pytest.raises(DescriptionError, match="YAML file .*config.yaml is a folder, not a regular file"):
        describe(resolve_robot(path))


def _run(*args, cwd) -> subprocess.CompletedProcess:
    return subprocess.run([str(BIN / "tf-between"), *map(str, args)], capture_output=True, text=True, cwd=cwd,
                          timeout=60)


@pytest.mark.skipif(not hasattr(os, "mkfifo"), reason="needs FIFOs")
def test_an_include_of_a_fifo_is_refused_before_xacro_opens_it(tmp_path):
    os.mkfifo(tmp_path / "parts.xacro")  # opening it would block until a writer comes: forever
    path = tmp_path / "arm.urdf.xacro"
    path.write_text(HEAD + '<link name="base_link"/>\n<xacro:include filename="parts.xacro"/>\n</robot>\n')
    result = _run("base_link", "base_link", "--robot", path, cwd=tmp_path)
    assert result.returncode == 2, result.stderr
    assert result.stderr == (f"tf-between: error: arm.urdf.xacro:4: xacro:include: xacro file {tmp_path / 'parts.xacro'} "
                             "is a FIFO (named pipe), not a regular file; give a file\n")


@pytest.mark.skipif(not hasattr(os, "mkfifo"), reason="needs FIFOs")
def test_load_yaml_of_a_fifo_is_refused_before_it_is_opened(tmp_path):
    path = _with_yaml(tmp_path, "x: 1\n")
    (tmp_path / "config.yaml").unlink()
    os.mkfifo(tmp_path / "config.yaml")
    result = _run("a", "a", "--robot", path, cwd=tmp_path)
    assert result.returncode == 2 and result.stderr.count("\n") == 1, result.stderr
    assert "config.yaml is a FIFO (named pipe), not a regular file" in result.stderr


def test_an_include_of_a_huge_file_is_refused(tmp_path, monkeypatch):
    import manipkit.description.xacro as xacro_module

    monkeypatch.setattr(xacro_module, "MAX_DESCRIPTION_BYTES", 1000)
    (tmp_path / "parts.xacro").write_text("<robot>" + " " * 2000 + "</robot>")
    path = tmp_path / "arm.urdf.xacro"
    path.write_text(HEAD + '<link name="base_link"/>\n<xacro:include filename="parts.xacro"/>\n</robot>\n')
    with pytest.raises(InputFileError, match=r"^arm.urdf.xacro:4: xacro:include: xacro file .*parts.xacro is 1.97 kB, "
                                             r"above the limit of 1000 bytes"):
        describe(resolve_robot(path))


def test_a_file_that_includes_itself_says_so_with_the_chain(tmp_path):
    (tmp_path / "parts.xacro").write_text('<robot xmlns:xacro="http://www.ros.org/wiki/xacro">\n'
                                          '<xacro:include filename="arm.urdf.xacro"/>\n</robot>\n')
    path = tmp_path / "arm.urdf.xacro"
    path.write_text(HEAD + '<link name="base_link"/>\n<xacro:include filename="parts.xacro"/>\n</robot>\n')
    with pytest.raises(DescriptionError) as info:
        describe(resolve_robot(path))
    assert str(info.value) == ("parts.xacro:2: xacro:include: arm.urdf.xacro includes itself "
                               "(arm.urdf.xacro -> parts.xacro -> arm.urdf.xacro); a file cannot include itself, "
                               "directly or through other files")


def test_the_same_file_included_twice_side_by_side_is_fine(tmp_path):
    (tmp_path / "colours.xacro").write_text('<robot xmlns:xacro="http://www.ros.org/wiki/xacro">'
                                            '<material name="grey"/></robot>\n')
    path = tmp_path / "arm.urdf.xacro"
    path.write_text(HEAD + '<link name="base_link"/>\n<xacro:include filename="colours.xacro"/>\n'
                    '<xacro:include filename="colours.xacro"/>\n</robot>\n')
    assert describe(resolve_robot(path)).text.count('<material name="grey"/>') == 2


def test_a_bad_value_from_an_argument_names_the_file_the_expansion_read():
    # planar_2r includes planar_link.xacro, whose planar_base_link macro writes base_link (line 53);
    # course_arm.urdf.xacro beside it also writes a base_link but is no part of planar_2r.
    with pytest.raises(DescriptionError, match=r"^planar_link.xacro:53: link 'base_link' <inertial> <origin> "
                                               r"xyz=\"0 0 nan\": 'nan' is not finite"):
        manipkit.load("planar_2r", l1="nan")
    locate = xacro_locator(bundled_robots()["planar_2r"])
    assert locate("link", "base_link") == "planar_link.xacro:53"


def test_xacros_own_functions_are_restored_after_an_expansion(tmp_path):
    import xacro

    own = (xacro.safe_eval, xacro.eval_extension, xacro.parse, xacro.eval_text, xacro.eval_all)
    manipkit.load("planar_3r")
    path = tmp_path / "bad.urdf.xacro"
    path.write_text(HEAD + '<link name="${().__class__}"/>\n</robot>\n')
    with pytest.raises(DescriptionError):
        manipkit.load(path)
    assert (xacro.safe_eval, xacro.eval_extension, xacro.parse, xacro.eval_text, xacro.eval_all) == own


def test_tokenize_takes_its_separators_as_characters():
    # xacro puts them in a regular expression as they are: this one would backtrack without end
    assert evaluate_expression("xacro.tokenize('a,b; c')", _table()) == ["a", "b", "c"]
    assert evaluate_expression("xacro.tokenize('aaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaac', 'x](a+)+b[y')", _table()) == ["c"]


def test_an_include_namespace_is_looked_up_as_names_are(tmp_path):
    (tmp_path / "parts.xacro").write_text('<robot xmlns:xacro="http://www.ros.org/wiki/xacro">'
                                          '<xacro:property name="w" value="2"/></robot>\n')
    path = tmp_path / "arm.urdf.xacro"
    path.write_text(HEAD + '<xacro:include filename="parts.xacro" ns="parts"/>\n'
                    '<link name="a${parts.w + parts[\'w\']}"/>\n</robot>\n')
    assert '<link name="a4"/>' in describe(resolve_robot(path)).text
    path.write_text(HEAD + '<xacro:include filename="parts.xacro" ns="parts"/>\n'
                    '<link name="${parts[\'python\'].type}"/>\n</robot>\n')
    with pytest.raises(DescriptionError, match="name 'type' is not defined"):
        describe(resolve_robot(path))


def test_elements_nested_too_deeply_do_not_blame_a_macro(tmp_path):
    path = tmp_path / "deep.urdf.xacro"
    path.write_text(HEAD + "<a>" * 3000 + "</a>" * 3000 + "\n</robot>\n")
    with pytest.raises(DescriptionError) as info:
        describe(resolve_robot(path))
    assert str(info.value) == ("deep.urdf.xacro: xacro recursion too deep (elements or properties nested more than "
                               "about a few hundred levels)")
    assert "?" not in str(info.value)
