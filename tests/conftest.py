"""Test-suite settings and shared fixtures.

Hypothesis runs derandomized by default so that `make test` (and CI) give the
same result on every run; `HYPOTHESIS_PROFILE=explore` draws fresh random
examples each run (use it when hunting for bugs, as `make fuzz` does).

Robots are loaded once per session: ``load_robot("name", **xacro_args)``
returns a shared, immutable :class:`manipkit.Robot` (the model/data split:
nothing a test does changes a Robot), and the fixtures ``course_arm``,
``iiwa14``, ``planar_2r``, ``planar_3r`` and ``panda`` name the ones most
files use.

``tmp_path`` is one folder deeper than pytest's (``.../test_name0/t``): a
test that makes its folder a ROS package would otherwise make pytest's
shared base folder a workspace (the outermost run of folders holding
packages, :class:`manipkit.description.packages.PackageResolver`), so every
other test's files would be indexed with it, and a test's package search,
warnings and messages would depend on which tests ran before it in the
same worker.
"""

import functools
import os

import pytest
from hypothesis import settings

# The line a first compile prints on stderr (manipkit.kernel_cache.compile_note) would land in whichever test
# compiles a kernel first and change what it sees; tests/test_kernel_cache.py checks the line itself.
os.environ.setdefault("MANIPKIT_COMPILE_NOTE", "0")

settings.register_profile("ci", derandomize=True, print_blob=True)
settings.register_profile("explore", derandomize=False, print_blob=True)
settings.load_profile(os.environ.get("HYPOTHESIS_PROFILE", "ci"))


@pytest.fixture
def tmp_path(tmp_path):
    """pytest's ``tmp_path`` one level down: a package made here is not beside another test's folder."""
    folder = tmp_path / "t"
    folder.mkdir()
    return folder


@functools.cache
def _load(name: str, xacro_args: tuple) -> "manipkit.Robot":  # noqa: F821
    import manipkit

    return manipkit.load(name, **dict(xacro_args))


@pytest.fixture(scope="session")
def load_robot():
    """``load_robot(name, **xacro_args)``: a robot loaded once for the whole session."""

    def load(name: str, **xacro_args):
        return _load(name, tuple(sorted(xacro_args.items())))

    return load


@pytest.fixture(scope="session")
def course_arm(load_robot):
    return load_robot("course_arm")


@pytest.fixture(scope="session")
def iiwa14(load_robot):
    return load_robot("iiwa14")


@pytest.fixture(scope="session")
def planar_2r(load_robot):
    return load_robot("planar_2r")


@pytest.fixture(scope="session")
def planar_3r(load_robot):
    return load_robot("planar_3r")


@pytest.fixture(scope="session")
def panda(load_robot):
    return load_robot("panda")
