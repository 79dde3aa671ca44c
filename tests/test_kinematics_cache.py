"""The compiled kernels' disk cache never ends a run (manipkit.kinematics.fk_kernel.compile_kernel).

Each test runs the real commands as subprocesses in an environment where
numba's cache cannot be used as it stands: a read-only install with a
read-only home (no cache folder at all), a cache whose files were truncated,
a cache that cannot be written in full. Each run must succeed with answers
checked independently (Pinocchio's FK of the printed joint values, a target
pose built by hand), and say once that the kernels were compiled in memory.

Read-only folders do not stop root; as root the commands run without the
capabilities that let root write anywhere (``setpriv``), so the folder
permissions apply as they would to any user.
"""

import csv
import io
import json
import math
import os
import resource
import shutil
import signal
import stat
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

import manipkit

REPO = Path(__file__).resolve().parents[1]
BIN = Path(sys.executable).parent
XYZ, RPY = (0.4, 0.1, 0.5), (3.0, 0.2, -0.4)  # a pose the iiwa reaches (m, rad)
WARNING = "compiled in memory"


def _target_by_hand() -> np.ndarray:
    """T_base_link_ee_link of the target: R = Rz(yaw) Ry(pitch) Rx(roll) (URDF rpy), written out."""
    (r, p, y), T = RPY, np.eye(4)
    Rx = np.array([[1, 0, 0], [0, math.cos(r), -math.sin(r)], [0, math.sin(r), math.cos(r)]])
    Ry = np.array([[math.cos(p), 0, math.sin(p)], [0, 1, 0], [-math.sin(p), 0, math.cos(p)]])
    Rz = np.array([[math.cos(y), -math.sin(y), 0], [math.sin(y), math.cos(y), 0], [0, 0, 1]])
    T[:3, :3], T[:3, 3] = Rz @ Ry @ Rx, XYZ
    return T


def _environment(pythonpath: Path, home: Path, **extra) -> dict:
    env = {key: value for key, value in os.environ.items() if not key.startswith("NUMBA_")}
    env.update(PYTHONPATH=str(pythonpath), HOME=str(home), XDG_CACHE_HOME=str(home / ".cache"), **extra)
    return env


def _as_user(command: list[str]) -> list[str]:
    """``command``; as root, without the capabilities that ignore file permissions."""
    if os.geteuid() != 0:
        return command
    setpriv = shutil.which("setpriv")
    if setpriv is None:
        pytest.skip("running as root without setpriv: read-only folders cannot be made to apply")
    return [setpriv, "--bounding-set=-dac_override,-dac_read_search,-fowner,-linux_immutable", "--", *command]


def _run(args: list[str], env: dict, cwd: Path, preexec_fn=None) -> subprocess.CompletedProcess:
    result = subprocess.run(_as_user([str(BIN / args[0]), *args[1:]]), capture_output=True, text=True, env=env,
                            cwd=cwd, timeout=600, preexec_fn=preexec_fn)
    assert "Traceback" not in result.stderr and "internal error" not in result.stderr, result.stderr
    assert result.returncode == 0, result.stderr
    return result


def _warning_lines(stderr: str) -> list[str]:
    """The warning lines: ``warning: ...`` (the CLI's channel) or Python's ``...: KernelCacheWarning: ...``."""
    return [line for line in stderr.splitlines() if line.startswith("warning:") or "KernelCacheWarning:" in line]


def _warnings_in(stderr: str) -> int:
    """How many warning lines say the kernels were compiled in memory."""
    return sum(WARNING in line for line in _warning_lines(stderr))


def _ik_answer_is_right(stdout: str) -> None:
    """The printed joint values put ee_link at the target, by Pinocchio's FK in this process."""
    answer = json.loads(stdout)
    assert answer["success"] and answer["solutions"]
    robot = manipkit.load("iiwa14")
    for solution in answer["solutions"]:
        q = np.array([solution[name] for name in robot.joint_names])
        T = robot.transform("base_link", "ee_link", q)
        np.testing.assert_allclose(T, _target_by_hand(), atol=1e-8)


def _ik(env: dict, cwd: Path) -> subprocess.CompletedProcess:
    args = ["manipkit", "ik", "--robot", "iiwa14", "--xyz", *map(str, XYZ), "--rpy", *map(str, RPY), "--format", "json"]
    return _run(args, env, cwd)


Q_ROWS = [(0.1, -0.4, 0.3, 1.2, -0.5, 0.7, 0.2), (-1.0, 0.5, 0.0, -0.8, 1.5, -0.3, 2.0)]


def _q_file_answer_is_right(folder: Path, run) -> None:
    """``tf-between --q-file`` poses (compiled chain kernel) equal Pinocchio's FK in this process."""
    robot = manipkit.load("iiwa14")
    path = folder / "q.csv"
    path.write_text(",".join(robot.joint_names) + "\n" + "".join(",".join(map(repr, row)) + "\n" for row in Q_ROWS))
    result = run(["tf-between", "base_link", "ee_link", "--robot", "iiwa14", "--q-file", str(path), "--precision", "12"])
    rows = [row for row in csv.reader(io.StringIO(result.stdout)) if row and not row[0].startswith("#")]
    header, values = rows[0], np.array(rows[1:], dtype=float)
    assert header[:3] == ["x", "y", "z"] and len(values) == len(Q_ROWS)
    for q, printed in zip(Q_ROWS, values):
        np.testing.assert_allclose(printed[:3], robot.transform("base_link", "ee_link", np.array(q))[:3, 3], atol=1e-10)
    return result


@pytest.fixture(scope="module")
def read_only_install(tmp_path_factory):
    """A copy of the package (and the bundled robots) and a home, all read-only; no __pycache__ anywhere."""
    root = tmp_path_factory.mktemp("read_only_install")
    shutil.copytree(REPO / "src" / "manipkit", root / "src" / "manipkit",
                    ignore=shutil.ignore_patterns("__pycache__", "*.pyc", "*.nbi", "*.nbc"))
    shutil.copytree(REPO / "robots", root / "robots")
    (root / "home" / ".cache").mkdir(parents=True)
    (root / "work").mkdir()
    for path in [root / "src", root / "robots", root / "home", *(root / "src").rglob("*"), *(root / "robots").rglob("*"),
                 *(root / "home").rglob("*")]:
        mode = path.lstat().st_mode
        path.chmod(mode & ~(stat.S_IWUSR | stat.S_IWGRP | stat.S_IWOTH))
    yield root
    for path in root.rglob("*"):
        if path.is_dir():
            path.chmod(path.stat().st_mode | stat.S_IWUSR)


def _no_cache_files_written(root: Path) -> None:
    assert not [p for p in root.rglob("*") if p.suffix in (".nbi", ".nbc") or p.name == "__pycache__"]


def test_ik_in_a_read_only_install_with_a_read_only_home_compiles_in_memory(read_only_install):
    env = _environment(read_only_install / "src", read_only_install / "home")
    result = _ik(env, read_only_install / "work")
    _ik_answer_is_right(result.stdout)
    assert _warnings_in(result.stderr) == 1, result.stderr
    assert "NUMBA_CACHE_DIR" in result.stderr
    _no_cache_files_written(read_only_install / "src")


def test_dh_check_and_q_file_in_a_read_only_install_compile_in_memory(read_only_install):
    env = _environment(read_only_install / "src", read_only_install / "home")
    check = _run(["manipkit", "dh", "check", "iiwa14", "--robot", "iiwa14", "--samples", "50"], env, read_only_install / "work")
    assert "PASS" in check.stdout and _warnings_in(check.stderr) == 1, check.stdout + check.stderr
    work = read_only_install / "work_q"
    work.mkdir(exist_ok=True)
    result = _q_file_answer_is_right(work, lambda args: _run(args, env, work))
    assert _warnings_in(result.stderr) == 1, result.stderr
    _no_cache_files_written(read_only_install / "src")


def test_truncated_cache_files_are_recompiled_and_rewritten(tmp_path):
    cache = tmp_path / "numba_cache"
    env = _environment(REPO / "src", tmp_path, NUMBA_CACHE_DIR=str(cache))
    # The chain FK kernel of `tf-between --q-file` (compiled in seconds; any cached kernel would do)
    def run(args):
        return _run(args, env, tmp_path)

    first = _q_file_answer_is_right(tmp_path, run)
    files = sorted(p for p in cache.rglob("*") if p.suffix in (".nbi", ".nbc"))
    assert any(p.suffix == ".nbi" for p in files) and any(p.suffix == ".nbc" for p in files)
    assert _warnings_in(first.stderr) == 0, first.stderr
    for path in files:  # as a run killed while writing, or a full disk, leaves them
        path.write_bytes(path.read_bytes()[: path.stat().st_size // 2])

    second = _q_file_answer_is_right(tmp_path, run)
    lines = _warning_lines(second.stderr)
    assert len(lines) == 1 and "could not be read" in lines[0], second.stderr

    third = _q_file_answer_is_right(tmp_path, run)  # the cache was rewritten: read back without a word
    assert third.stderr == "", third.stderr


def _small_file_size_limit():
    """Files of at most 2 kB (writes beyond fail with EFBIG, as on a full disk), for the subprocess."""
    signal.signal(signal.SIGXFSZ, signal.SIG_IGN)
    resource.setrlimit(resource.RLIMIT_FSIZE, (2048, 2048))


def test_cache_that_cannot_be_written_in_full_falls_back_to_memory(tmp_path):
    cache = tmp_path / "numba_cache"
    env = _environment(REPO / "src", tmp_path, NUMBA_CACHE_DIR=str(cache))
    robot = manipkit.load("iiwa14")
    path = tmp_path / "q.csv"
    path.write_text(",".join(robot.joint_names) + "\n" + "".join(",".join(map(repr, row)) + "\n" for row in Q_ROWS))
    result = _run(["tf-between", "base_link", "ee_link", "--robot", "iiwa14", "--q-file", str(path), "--precision", "12"],
                  env, tmp_path, preexec_fn=_small_file_size_limit)
    assert _warnings_in(result.stderr) == 1 and "File too large" in result.stderr, result.stderr
    again = _q_file_answer_is_right(tmp_path, lambda args: _run(args, env, tmp_path))  # no limit: cached again
    assert again.stderr == "" or "could not be read" in again.stderr, again.stderr


def test_analytic_ik_in_a_read_only_install_needs_no_kernel(read_only_install):
    env = _environment(read_only_install / "src", read_only_install / "home")
    args = ["manipkit", "ik", "--robot", "planar_2r", "--analytic", "--xyz", "1", "1", "0", "--format", "json"]
    result = _run(args, env, read_only_install / "work")
    assert result.stderr == "", result.stderr  # importing the IK module no longer touches numba's cache
    robot = manipkit.load("planar_2r")
    for solution in json.loads(result.stdout)["solutions"]:  # unit links: (1, 1) is reached by both elbows
        q = np.array([solution[name] for name in robot.joint_names])
        np.testing.assert_allclose(robot.transform("base_link", "ee_link", q)[:2, 3], [1.0, 1.0], atol=1e-12)


def test_a_kernel_is_compiled_again_when_a_kernel_it_calls_changes(tmp_path):
    # numba keys a cached kernel by its own file; the batch loop calls the LM iteration (ik.lm_kernel), so a change to
    # lm_kernel.py alone must not leave the old iteration running from the cache (kernels.sources_digest).
    # Processes are the point: the cache is what one run leaves for the next. The runs compile a two-module probe
    # put into a copy of the package (a kernel calling a compiled function of another module, as numerical_many
    # calls lm_kernel's) through the same compile_kernel and cache; that the real loop's key covers lm_kernel.py
    # is checked on the package itself.
    from manipkit.kernels import kernel_closure

    package = REPO / "src" / "manipkit"
    assert package / "ik" / "lm_kernel.py" in kernel_closure(package / "ik" / "numerical_many.py", package)
    shutil.copytree(REPO / "src", tmp_path / "src", ignore=shutil.ignore_patterns("__pycache__"))
    copy = tmp_path / "src" / "manipkit"
    (copy / "probe_callee.py").write_text("from manipkit.kernels.compile import compile_kernel\n\n\n"
                                          "@compile_kernel\ndef step(x):\n    return 2.0 * x\n")
    (copy / "probe_kernel.py").write_text("from manipkit.kernels.compile import lazy_kernel\n"
                                          "from manipkit.probe_callee import step\n\n\n"
                                          "def twice(x):\n    return step(step(x))\n\n\nkernel = lazy_kernel(twice)\n")
    env = {**os.environ, "NUMBA_CACHE_DIR": str(tmp_path / "cache"), "NUMBA_DEBUG_CACHE": "1",
           "PYTHONPATH": str(tmp_path / "src")}
    script = "from manipkit.probe_kernel import kernel\nprint('answer', kernel()(1.5))\n"

    def run() -> tuple[float, bool]:
        """The probe's answer and whether its kernel was compiled and saved in this process."""
        result = subprocess.run([sys.executable, "-c", script], env=env, cwd=tmp_path, capture_output=True, text=True,
                                timeout=600)
        assert result.returncode == 0, result.stderr[-2000:]
        lines = result.stdout.splitlines()
        answer = float(next(line for line in lines if line.startswith("answer")).split()[1])
        return answer, any("data saved" in line and "probe_kernel.twice" in line for line in lines)

    assert run() == (6.0, True)  # 2 * (2 * 1.5), compiled and saved
    assert run() == (6.0, False)  # read back
    (copy / "probe_callee.py").write_text((copy / "probe_callee.py").read_text().replace("2.0 * x", "3.0 * x"))
    assert run() == (13.5, True)  # probe_kernel.py did not change, yet its kernel is compiled again: 3 * (3 * 1.5)


def test_the_sources_digest_covers_a_kernels_module_and_what_it_compiles_from_only(tmp_path):
    from manipkit.kernels import kernel_closure, sources_digest

    root = tmp_path / "manipkit"
    (root / "sub").mkdir(parents=True)
    (root / "consts.py").write_text("N = 8\n")
    (root / "inner.py").write_text("from manipkit.consts import N\n@inlined_kernel\ndef h(): pass\n")
    (root / "sub" / "k.py").write_text("from manipkit.inner import h\nf = compile_kernel(g)\n")
    (root / "other.py").write_text("from manipkit.consts import N\nf = compile_kernel(o)\n")
    (root / "cli.py").write_text("print('help')\n")
    kernel = root / "sub" / "k.py"
    # k.py, the kernel module it imports, and what that one imports in turn; not the other kernel, not the CLI
    assert kernel_closure(kernel, root) == [root / "consts.py", root / "inner.py", kernel]
    first = sources_digest(kernel, root)
    assert sources_digest(kernel, root) == first
    (root / "cli.py").write_text("print('other help')\n")  # not compiled, imported by no kernel: same key
    (root / "other.py").write_text("from manipkit.consts import N\nf = compile_kernel(p)\n")  # another kernel
    assert sources_digest(kernel, root) == first
    (root / "consts.py").write_text("N = 9\n")  # a constant the inlined callee reads at compile time: a new key
    assert sources_digest(kernel, root) != first
    second = sources_digest(kernel, root)
    (root / "sub" / "k.py").write_text("from manipkit.inner import h\nf = compile_kernel(q)\n")
    assert sources_digest(kernel, root) != second
