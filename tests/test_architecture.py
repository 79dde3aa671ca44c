"""The rules of docs/architecture.md, checked on the source: layers, private names, __all__, sizes.

Each source file is parsed with ``ast`` (nothing is imported); imports under
``if TYPE_CHECKING:`` are annotations only and do not count as layer crossings.
"""

import ast
from pathlib import Path

import pytest

PACKAGE = Path(__file__).resolve().parents[1] / "src" / "manipkit"

# layer -> the manipkit layers it may import at run time (docs/architecture.md, "Layers")
BOTTOM = {"errors", "exports", "text", "outputs"}  # modules beside errors.py that every layer may use
ALLOWED = {
    "errors": set(),
    "exports": set(),
    "text": set(),
    "outputs": {"errors"},
    "ik_result": {"errors", "text"},  # the one IK result type, below the two layers that solve IK
    "spatial": BOTTOM,
    "inputs": BOTTOM | {"spatial"},  # reading files: a pose read is checked as a transform
    "description": BOTTOM | {"inputs", "spatial"},
    "kinematics": BOTTOM | {"inputs", "spatial", "description", "ik_result"},
    "dh": BOTTOM | {"inputs", "spatial"},
    "closed_form": BOTTOM | {"inputs", "spatial", "dh", "ik_result"},
    "analysis": BOTTOM | {"inputs", "spatial", "description", "kinematics", "dh", "closed_form", "ik_result"},
    "app": BOTTOM | {"inputs", "spatial", "description", "kinematics", "dh", "closed_form", "analysis", "ik_result"},
}
MAX_MODULE_LINES = 800
SOURCES = sorted(p for p in PACKAGE.rglob("*.py") if p.name != "__init__.py" or p.parent != PACKAGE)


def layer_of(path: Path) -> str:
    parts = path.relative_to(PACKAGE).parts
    return parts[0].removesuffix(".py")


def runtime_imports(tree: ast.Module):
    """(module, names, line) of each import not under ``if TYPE_CHECKING:``."""
    skip = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.If) and "TYPE_CHECKING" in ast.unparse(node.test):
            skip.update(id(child) for stmt in node.body for child in ast.walk(stmt))
    for node in ast.walk(tree):
        if id(node) in skip:
            continue
        if isinstance(node, ast.ImportFrom) and node.module and node.level == 0:
            yield node.module, [alias.name for alias in node.names], node.lineno
        elif isinstance(node, ast.Import):
            for alias in node.names:
                yield alias.name, [], node.lineno


def ids(paths):
    return [str(p.relative_to(PACKAGE)) for p in paths]


@pytest.mark.parametrize("path", SOURCES, ids=ids(SOURCES))
def test_imports_run_down_the_layers(path):
    layer = layer_of(path)
    crossings = []
    for module, _, line in runtime_imports(ast.parse(path.read_text())):
        parts = module.split(".")
        if parts[0] != "manipkit" or len(parts) < 2:
            continue
        target = parts[1]
        if target != layer and target not in ALLOWED[layer]:
            crossings.append(f"line {line}: {layer} imports {module}")
    assert not crossings, "; ".join(crossings)


@pytest.mark.parametrize("path", SOURCES, ids=ids(SOURCES))
def test_no_private_name_from_another_subpackage(path):
    layer = layer_of(path)
    found = []
    for module, names, line in runtime_imports(ast.parse(path.read_text())):
        parts = module.split(".")
        if parts[0] != "manipkit" or len(parts) < 2 or parts[1] == layer:
            continue
        private = [n for n in names if n.startswith("_")] + [p for p in parts[1:] if p.startswith("_")]
        if private:
            found.append(f"line {line}: {', '.join(private)} from {module}")
    assert not found, "; ".join(found)


@pytest.mark.parametrize("path", SOURCES, ids=ids(SOURCES))
def test_public_module_declares_all_and_stays_small(path):
    text = path.read_text()
    assert len(text.splitlines()) <= MAX_MODULE_LINES
    if not path.name.startswith("_") or path.name == "__init__.py":
        tree = ast.parse(text)
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
    found = [node.lineno for node in ast.walk(ast.parse(path.read_text()))
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

