"""The rules of docs/architecture.md, checked on the source: layers, private names, __all__, sizes.

Each source file is parsed with ``ast`` (nothing is imported); imports under
``if TYPE_CHECKING:`` are annotations only and do not count as layer crossings.
"""

import ast
import functools
from pathlib import Path

import pytest

PACKAGE = Path(__file__).resolve().parents[1] / "src" / "manipkit"

# layer -> the manipkit layers it may import at run time (docs/architecture.md, "Layers")
BOTTOM = {"errors", "exports", "text", "memo", "outputs", "bounds", "kernels"}  # modules beside errors.py that every layer may use
ALLOWED = {
    "errors": set(),
    "exports": set(),
    "kernels": {"errors", "exports", "kernel_cache"},  # compiling numba kernels, a chain's compiled program (numpy, numba)
    "kernel_cache": set(),  # where the kernels' cache lives and what it trusts (standard library)
    "text": set(),
    "memo": set(),  # the one rule by which a table kept for the process stays bounded
    "outputs": {"errors", "text"},
    "bounds": {"errors", "text"},  # the bounds of every number and count
    "spatial": BOTTOM,
    "inputs": BOTTOM | {"spatial"},  # reading files: a pose read is checked as a transform
    "description": BOTTOM | {"inputs", "spatial"},
    "kinematics": BOTTOM | {"inputs", "spatial", "description"},
    "dh": BOTTOM | {"inputs", "spatial"},
    "closed_form": BOTTOM | {"inputs", "spatial", "dh"},
    "ik": BOTTOM | {"inputs", "spatial", "description", "kinematics", "dh", "closed_form"},
    "statics": BOTTOM | {"spatial", "kinematics"},
    "paths": BOTTOM | {"inputs", "spatial", "description", "kinematics", "ik"},  # task paths over every IK branch
    "analysis": BOTTOM | {"inputs", "spatial", "description", "kinematics", "dh", "closed_form", "ik", "statics",
                          "paths"},
    "app": BOTTOM | {"inputs", "spatial", "description", "kinematics", "dh", "closed_form", "ik", "statics", "paths",
                     "analysis"},
}
#: One module of a layer another layer may import beside ALLOWED (docs/architecture.md, "Layers"): none.
NARROW: set[tuple[str, str]] = set()
MAX_MODULE_LINES = 800
SOURCES = sorted(p for p in PACKAGE.rglob("*.py") if p.name != "__init__.py" or p.parent != PACKAGE)


@functools.cache
def parsed(path: Path) -> ast.Module:
    """The parsed source of ``path``, once a session: every rule reads the same tree and none changes it."""
    return ast.parse(path.read_text())


def layer_of(path: Path) -> str:
    parts = path.relative_to(PACKAGE).parts
    return parts[0].removesuffix(".py")


def package_of(path: Path) -> list[str]:
    """The dotted package a source file is in, as parts: ``manipkit/kinematics/robot.py`` -> manipkit, kinematics."""
    parts = ["manipkit", *path.relative_to(PACKAGE).parts]
    return parts[:-1]


def lazy_homes() -> dict[str, str]:
    """Name -> module for the names ``manipkit/__init__.py`` loads on first use (its ``_LAZY`` and ``_LAZY_MODULES``
    tables), read from the source."""
    tree = ast.parse((PACKAGE / "__init__.py").read_text())
    tables = [ast.literal_eval(node.value) for node in tree.body if isinstance(node, ast.Assign)
              and any(isinstance(t, ast.Name) and t.id in ("_LAZY", "_LAZY_MODULES") for t in node.targets)]
    return {name: home for table in tables for name, home in table.items()}


LAZY = lazy_homes()


def runtime_imports(tree: ast.Module, path: Path | None = None):
    """(module, names, line) of each import not under ``if TYPE_CHECKING:``.

    Also seen: relative imports (resolved against ``path``'s package),
    ``from manipkit import X`` (the module ``X`` comes from, by the package's
    lazy table), and ``importlib.import_module("manipkit....")`` /
    ``__import__`` with a string that starts with ``manipkit.`` (an f-string's
    constant head is enough to know the subpackage).
    """
    skip = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.If) and "TYPE_CHECKING" in ast.unparse(node.test):
            skip.update(id(child) for stmt in node.body for child in ast.walk(stmt))
    for node in ast.walk(tree):
        if id(node) in skip:
            continue
        if isinstance(node, ast.ImportFrom):
            module = node.module or ""
            if node.level:
                base = package_of(path) if path is not None else ["manipkit"]
                base = base[: len(base) - (node.level - 1)] if node.level > 1 else base
                module = ".".join([*base, module] if module else base)
            names = [alias.name for alias in node.names]
            if module == "manipkit":
                for name in names:
                    home = LAZY.get(name, f"manipkit.{name}")
                    yield home, [name], node.lineno
                continue
            yield module, names, node.lineno
        elif isinstance(node, ast.Import):
            for alias in node.names:
                yield alias.name, [], node.lineno
        elif isinstance(node, ast.Call) and node.args and _is_import_call(node.func):
            head = node.args[0]
            if isinstance(head, ast.JoinedStr) and head.values and isinstance(head.values[0], ast.Constant):
                head = head.values[0]
            if isinstance(head, ast.Constant) and isinstance(head.value, str) and head.value.startswith("manipkit."):
                yield head.value.rstrip("."), [], node.lineno


def _is_import_call(func: ast.expr) -> bool:
    return (isinstance(func, ast.Attribute) and func.attr == "import_module") or (
        isinstance(func, ast.Name) and func.id in ("import_module", "__import__"))


def ids(paths):
    return [str(p.relative_to(PACKAGE)) for p in paths]


@pytest.mark.parametrize("path", SOURCES, ids=ids(SOURCES))
def test_imports_run_down_the_layers(path):
    layer = layer_of(path)
    crossings = []
    for module, _, line in runtime_imports(parsed(path), path):
        parts = module.split(".")
        if parts[0] != "manipkit" or len(parts) < 2:
            continue
        target = parts[1]
        if target != layer and target not in ALLOWED[layer] and (layer, module) not in NARROW:
            crossings.append(f"line {line}: {layer} imports {module}")
    assert not crossings, "; ".join(crossings)


@pytest.mark.parametrize("path", SOURCES, ids=ids(SOURCES))
def test_no_private_name_from_another_module(path):
    found = []
    own_module = ".".join([*package_of(path), path.stem])
    for module, names, line in runtime_imports(parsed(path), path):
        parts = module.split(".")
        if parts[0] != "manipkit" or len(parts) < 2 or module == own_module:
            continue
        private = [n for n in names if n.startswith("_") and not n.startswith("__")]
        private += [p for p in parts[1:] if p.startswith("_") and not p.startswith("__")]
        if private:
            found.append(f"line {line}: {', '.join(private)} from {module}")
    assert not found, "; ".join(found)


@pytest.mark.parametrize("path", SOURCES, ids=ids(SOURCES))
def test_public_module_declares_all_and_stays_small(path):
    text = path.read_text()
    assert len(text.splitlines()) <= MAX_MODULE_LINES
    if not path.name.startswith("_") or path.name == "__init__.py":
        tree = parsed(path)
        assigned = {t.id for node in tree.body if isinstance(node, ast.Assign) for t in node.targets
                    if isinstance(t, ast.Name)}
        assert "__all__" in assigned or path.name in ("__init__.py", "__main__.py")


def test_the_layer_table_names_every_subpackage():
    subpackages = {p.name for p in PACKAGE.iterdir() if (p / "__init__.py").is_file()}
    modules = {p.stem for p in PACKAGE.glob("*.py") if p.name != "__init__.py"}
    assert subpackages | modules == set(ALLOWED)


def test_a_crossing_is_caught():
    """The checker itself: an upward import and a TYPE_CHECKING one, parsed from text."""
    tree = ast.parse(
        "from typing import TYPE_CHECKING\n"
        "from manipkit.kinematics.robot import Robot\n"
        "if TYPE_CHECKING:\n"
        "    from manipkit.app.cli import main\n"
    )
    modules = [module for module, _, _ in runtime_imports(tree)]
    assert "manipkit.kinematics.robot" in modules and "manipkit.app.cli" not in modules


@pytest.mark.parametrize("path", SOURCES, ids=ids(SOURCES))
def test_user_errors_raise_a_subclass_not_the_base(path):
    """Every user error is a ManipkitError subclass that says what kind it is (errors.py); none raises the base."""
    found = [node.lineno for node in ast.walk(parsed(path))
             if isinstance(node, ast.Raise) and isinstance(node.exc, ast.Call)
             and isinstance(node.exc.func, ast.Name) and node.exc.func.id == "ManipkitError"]
    assert not found, f"raise ManipkitError(...) at lines {found}: raise the subclass for its kind (errors.py)"


MODULES = sorted({".".join(["manipkit", *p.relative_to(PACKAGE).with_suffix("").parts]).removesuffix(".__init__")
                  for p in PACKAGE.rglob("*.py") if p.name != "__main__.py"})


@pytest.mark.parametrize("name", MODULES)
def test_all_is_declared_and_true(name):
    """Every module and package says what it exports, and every name it lists is there (packages load lazily)."""
    import importlib

    module = importlib.import_module(name)
    assert isinstance(getattr(module, "__all__", None), (list, tuple)), f"{name} declares no __all__"
    missing = [n for n in module.__all__ if not hasattr(module, n)]
    assert not missing, f"{name}.__all__ lists {missing}, which it does not have"



def test_packages_export_one_way():
    """Every subpackage's __init__ builds its exports with manipkit.exports.lazy_exports (the one style)."""
    other = []
    for init in PACKAGE.rglob("__init__.py"):
        if init.parent == PACKAGE or init.parent.name == "cli":  # the root (0.1 aliases) and the CLI's entry module
            continue
        if "lazy_exports(__name__" not in init.read_text():
            other.append(str(init.relative_to(PACKAGE)))
    assert not other, f"these packages export another way: {other}"


#: Private names of other libraries that manipkit must reach, with why (the only ones allowed).
FOREIGN_PRIVATE = {
    ("description/xacro_names.py", "_global_symbols"): "xacro's expression namespace, replaced by the safe one",
    ("description/xacro_names.py", "_eval_env"): "xacro's $(env), refused",
    ("description/xacro_names.py", "_eval_optenv"): "xacro's $(optenv), refused",
    ("description/xacro_names.py", "_eval_find"): "xacro's $(find), resolved without ROS",
    ("description/xacro_names.py", "_eval_arg"): "xacro's $(arg), checked",
    ("description/xacro_names.py", "_eval_dirname"): "xacro's $(dirname)",
    ("app/cli/path_place.py", "_actions"): "argparse lists a parser's options only there: the printed command "
                                           "spells out the ones the user abbreviated",
}


def private_names_defined(tree: ast.Module) -> set[str]:
    """The private attribute names a module defines: assigned as ``x._name``, ``def _name``, class attributes, slots."""
    names = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.Attribute) and isinstance(node.ctx, ast.Store) and node.attr.startswith("_"):
            names.add(node.attr)
        elif isinstance(node, (ast.FunctionDef, ast.ClassDef)) and node.name.startswith("_"):
            names.add(node.name)
        elif isinstance(node, ast.Name) and isinstance(node.ctx, ast.Store) and node.id.startswith("_"):
            names.add(node.id)
        elif isinstance(node, ast.Constant) and isinstance(node.value, str) and node.value.startswith("_"):
            names.add(node.value)  # __slots__ entries, object.__setattr__(self, "_x", ...)
    return names


@pytest.mark.parametrize("path", SOURCES, ids=ids(SOURCES))
def test_no_private_attribute_of_another_module(path):
    """``obj._x`` only where this module defines ``_x`` (its own classes): another module's privates are not an API."""
    tree = parsed(path)
    own = private_names_defined(tree)
    where = str(path.relative_to(PACKAGE))
    found = sorted({
        f"line {node.lineno}: {ast.unparse(node)}" for node in ast.walk(tree)
        if isinstance(node, ast.Attribute) and node.attr.startswith("_") and not node.attr.startswith("__")
        and not (isinstance(node.value, ast.Name) and node.value.id in ("self", "cls"))
        and node.attr not in own and (where, node.attr) not in FOREIGN_PRIVATE
    })
    assert not found, "; ".join(found)


def test_a_private_attribute_of_another_module_is_caught():
    tree = ast.parse("def f(solver):\n    return solver._geometry\n")
    assert "_geometry" not in private_names_defined(tree)


@pytest.mark.parametrize("path", SOURCES, ids=ids(SOURCES))
def test_functions_stay_under_80_lines_or_say_why(path):
    """A function over 80 lines carries a comment 'Over 80 lines: <why>' (docs/architecture.md)."""
    lines = path.read_text().splitlines()
    long = [f"{node.name} (line {node.lineno}, {node.end_lineno - node.lineno + 1} lines)"
            for node in ast.walk(parsed(path))
            if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)) and node.end_lineno - node.lineno >= 80
            and not any("Over 80 lines:" in line for line in lines[node.lineno - 1:node.end_lineno])]
    assert not long, f"functions over 80 lines without a reason: {', '.join(long)}"


# --------------------------------------------------------------------------
# No import circles: no two modules import each other, directly or through others

#: Import circles whose modules others are changing: each entry is the modules of one circle; a circle among them
#: (or among a part of them) passes. Delete an entry when its work lands (test_every_circle_in_transit_is_still_there).
KNOWN_CYCLES_IN_TRANSIT: set[frozenset[str]] = set()


def module_name(path: Path, root: Path = PACKAGE) -> str:
    """``src/manipkit/analysis/reachmap/map.py`` -> ``manipkit.analysis.reachmap.map`` (a package by its name)."""
    return ".".join(["manipkit", *path.relative_to(root).with_suffix("").parts]).removesuffix(".__init__")


def lazy_table(init: Path) -> dict[str, str]:
    """Name -> home module of a package's lazy table (``homes_of(...)`` rows and ``"name": "module"`` entries)."""
    if init.parent == PACKAGE:
        return LAZY
    homes = {}
    for node in ast.walk(parsed(init)):
        if isinstance(node, ast.Call) and isinstance(node.func, ast.Name) and node.func.id == "homes_of":
            module, *names = (arg.value for arg in node.args)
            homes.update(dict.fromkeys(names, module))
        elif isinstance(node, ast.Call) and isinstance(node.func, ast.Name) and node.func.id == "lazy_exports":
            for table in node.args[1:]:
                if isinstance(table, ast.Dict):
                    homes.update({k.value: v.value for k, v in zip(table.keys, table.values)
                                  if isinstance(k, ast.Constant) and isinstance(v, ast.Constant)})
    return homes


def import_graph(root: Path = PACKAGE) -> dict[str, set[str]]:
    """Module -> the manipkit modules it imports at run time (in functions too; not under ``if TYPE_CHECKING:``).

    ``from PACKAGE import name`` is an import of the submodule ``name`` if
    there is one, else of the module the package's lazy table names for it
    (a lazy table is not an import: it loads on first use), else of the package.
    """
    paths = {module_name(p, root): p for p in root.rglob("*.py")}
    packages = {module_name(p, root) for p in paths.values() if p.name == "__init__.py"}
    tables = {name: lazy_table(paths[name]) for name in packages}

    def home(module: str, name: str | None) -> str | None:
        if module in packages and name is not None:
            if f"{module}.{name}" in paths:
                return f"{module}.{name}"
            if name in tables[module]:
                return home(tables[module][name], None)
        return module if module in paths else None

    graph = {}
    for name, path in paths.items():
        targets = set()
        for module, names, _ in runtime_imports(parsed(path), path):
            if module == "manipkit" or module.startswith("manipkit."):
                targets.update(home(module, n) for n in names or [None])
        graph[name] = targets - {None, name}
    return graph


def strongly_connected(graph: dict[str, set[str]]) -> list[list[str]]:
    """The strongly connected components of ``graph`` with more than one node (Tarjan's algorithm, iterative)."""
    index, low, on_stack, stack, found, counter = {}, {}, set(), [], [], [0]
    for root in sorted(graph):
        if root in index:
            continue
        work = [(root, iter(sorted(graph[root])))]
        index[root] = low[root] = counter[0]
        counter[0] += 1
        stack.append(root)
        on_stack.add(root)
        while work:
            node, edges = work[-1]
            for nxt in edges:
                if nxt not in index:
                    index[nxt] = low[nxt] = counter[0]
                    counter[0] += 1
                    stack.append(nxt)
                    on_stack.add(nxt)
                    work.append((nxt, iter(sorted(graph.get(nxt, ())))))
                    break
                if nxt in on_stack:
                    low[node] = min(low[node], index[nxt])
            else:
                work.pop()
                if work:
                    low[work[-1][0]] = min(low[work[-1][0]], low[node])
                if low[node] == index[node]:
                    component = []
                    while True:
                        member = stack.pop()
                        on_stack.discard(member)
                        component.append(member)
                        if member == node:
                            break
                    if len(component) > 1:
                        found.append(sorted(component))
    return found


def circle_text(graph: dict[str, set[str]], component: list[str]) -> str:
    """One circle through the component's first module, as a chain: ``a -> b -> c -> a`` (the shortest, by BFS)."""
    start, members = component[0], set(component)
    previous, queue = {start: None}, [start]
    for node in queue:
        for nxt in sorted(graph[node] & members):
            if nxt == start:
                chain = [node]
                while previous[chain[-1]] is not None:
                    chain.append(previous[chain[-1]])
                return " -> ".join([*reversed(chain), start])
            if nxt not in previous:
                previous[nxt] = node
                queue.append(nxt)
    return " <-> ".join(component)  # not reached: a component of two or more nodes has a circle through each


@pytest.fixture(scope="module")
def graph():
    """The package's import graph, read once for the two tests that walk it."""
    return import_graph()


def test_no_two_modules_import_each_other(graph):
    """No module imports itself through others: a circle is reported as the chain of modules around it."""
    circles = [c for c in strongly_connected(graph) if not any(set(c) <= known for known in KNOWN_CYCLES_IN_TRANSIT)]
    assert not circles, "import circles: " + "; ".join(circle_text(graph, c) for c in circles)


def test_every_circle_in_transit_is_still_there(graph):
    """An entry of KNOWN_CYCLES_IN_TRANSIT whose circle is gone is deleted, so it cannot hide a new one."""
    components = strongly_connected(graph)
    gone = [sorted(known) for known in KNOWN_CYCLES_IN_TRANSIT if not any(set(c) <= known for c in components)]
    assert not gone, f"these circles are gone: delete them from KNOWN_CYCLES_IN_TRANSIT: {gone}"


def test_a_circle_is_caught_and_read_as_a_chain(tmp_path):
    """The checker itself, on a package written here: a -> b -> c -> a, through an import inside a function, a plain
    import and ``from PACKAGE import name`` read through the package's lazy table; a TYPE_CHECKING import is no edge."""
    root = tmp_path / "manipkit"
    (root / "pkg").mkdir(parents=True)
    files = {
        "__init__.py": "",
        "a.py": "def f():\n    from manipkit.b import g\n",
        "b.py": "import manipkit.c\n",
        "c.py": "from manipkit.pkg import name\n",
        "d.py": "from typing import TYPE_CHECKING\nif TYPE_CHECKING:\n    from manipkit.a import f\nimport manipkit.b\n",
        "pkg/__init__.py": 'from manipkit.exports import homes_of, lazy_exports\n'
                           '__all__, __getattr__, __dir__ = lazy_exports(__name__, {**homes_of("manipkit.a", "name")})\n',
    }
    for name, text in files.items():
        (root / name).write_text(text)
    graph = import_graph(root)
    assert graph["manipkit.d"] == {"manipkit.b"} and graph["manipkit.c"] == {"manipkit.a"}
    components = strongly_connected(graph)
    assert components == [["manipkit.a", "manipkit.b", "manipkit.c"]]
    assert circle_text(graph, components[0]) == "manipkit.a -> manipkit.b -> manipkit.c -> manipkit.a"
