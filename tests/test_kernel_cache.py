"""The compiled kernels' cache is trusted only when it is the user's alone (manipkit.kernel_cache, issue 40).

numba's cache files are pickles, so a file someone else could write there is
code run as the user. Each case plants a pickle whose unpickling creates a
marker file (``N_planted_index_pickle``: the index, which numba unpickles
first; ``N_planted_data_pickle``: a data file behind a valid index) and runs
a subprocess (a process reading the cache another left is the point): where
a folder or file is writable by others, or owned by someone else, the marker
never appears, the answer is right and one line says why the cache was not
used. The control cases plant the same files with the user's own modes and
see the marker appear: the planted files are ones numba does read.

The real command (``tf-between --q-file``, the compiled batched FK, its poses
checked by Pinocchio's FK in this process) runs in the end-to-end cases; the
others run a one-line kernel made by the same :func:`manipkit.kernels.compile_kernel`
(the same cache code, a compile of a second rather than of several).
"""

import csv
import io
import os
import pickle
import stat
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

import manipkit
from manipkit import kernel_cache

REPO = Path(__file__).resolve().parents[1]
BIN = Path(sys.executable).parent
Q_ROWS = [(0.1, -0.4, 0.3, 1.2, -0.5, 0.7, 0.2), (-1.0, 0.5, 0.0, -0.8, 1.5, -0.3, 2.0)]
NOT_USED = "cache is not used"


class _Planted:
    """Unpickling this opens (creates) the marker file: what an attacker's pickle would do, harmlessly."""

    def __init__(self, marker: Path):
        self.marker = str(marker)

    def __reduce__(self):
        return (open, (self.marker, "w"))


def _environment(cache: Path, home: Path, **extra) -> dict:
    env = {key: value for key, value in os.environ.items() if not key.startswith(("NUMBA_", "MANIPKIT_"))}
    env.update(PYTHONPATH=str(REPO / "src"), HOME=str(home), XDG_CACHE_HOME=str(home / ".cache"),
               NUMBA_CACHE_DIR=str(cache), **extra)
    return env


def _q_file(folder: Path) -> Path:
    robot = manipkit.load("iiwa14")
    path = folder / "q.csv"
    path.write_text(",".join(robot.joint_names) + "\n" + "".join(",".join(map(repr, row)) + "\n" for row in Q_ROWS))
    return path


def _poses(env: dict, folder: Path) -> subprocess.CompletedProcess:
    """``tf-between --q-file`` (the compiled batched FK), its poses checked against Pinocchio's FK here."""
    args = [str(BIN / "tf-between"), "base_link", "ee_link", "--robot", "iiwa14", "--q-file", str(_q_file(folder)),
            "--precision", "12"]
    result = subprocess.run(args, capture_output=True, text=True, env=env, cwd=folder, timeout=600)
    assert result.returncode == 0 and "Traceback" not in result.stderr, result.stderr
    robot = manipkit.load("iiwa14")
    rows = [row for row in csv.reader(io.StringIO(result.stdout)) if row and not row[0].startswith("#")]
    values = np.array(rows[1:], dtype=float)
    assert len(values) == len(Q_ROWS)
    for q, printed in zip(Q_ROWS, values):
        np.testing.assert_allclose(printed[:3], robot.transform("base_link", "ee_link", np.array(q))[:3, 3], atol=1e-10)
    return result


TINY = """from manipkit.kernels import compile_kernel


def add_one(x):
    return x + 1


print(compile_kernel(add_one)(41))
"""


@pytest.fixture(scope="module")
def tiny_module(tmp_path_factory) -> Path:
    """The one-line kernel's module, one file for the whole module (numba's cache folder follows its path)."""
    module = tmp_path_factory.mktemp("kernel_module") / "tiny.py"
    module.write_text(TINY)
    return module


def _tiny(env: dict, folder: Path, module: Path) -> subprocess.CompletedProcess:
    """The one-line kernel compiled (or read from the cache) in a process of its own; it must print 42."""
    result = subprocess.run([sys.executable, str(module)], capture_output=True, text=True, env=env, cwd=folder,
                            timeout=600)
    assert result.returncode == 0 and "Traceback" not in result.stderr, result.stderr
    assert result.stdout.strip() == "42"
    return result


def _lines(stderr: str, words: str) -> list[str]:
    """The lines of ``stderr`` with ``words``: notes, and warnings as the CLI (``warning: ...``) or Python shows them
    (``FILE:LINE: KernelCacheWarning: ...``, then the source line, which is not counted)."""
    return [line for line in stderr.splitlines() if words in line
            and (line.startswith(("manipkit:", "warning:")) or "KernelCacheWarning:" in line)]


def _filled(run, root: Path):
    """A cache a first run (``run(env, cwd)``) compiled into: (folder, its files)."""
    cache = root / "cache"
    run(_environment(cache, root), root)
    files = sorted(p for p in cache.rglob("*") if p.suffix in (".nbi", ".nbc"))
    assert any(p.suffix == ".nbi" for p in files) and any(p.suffix == ".nbc" for p in files)
    return cache, files


@pytest.fixture(scope="module")
def filled_cache(tmp_path_factory):
    """The batched FK compiled by a first ``tf-between --q-file``: (folder, its files)."""
    return _filled(_poses, tmp_path_factory.mktemp("filled"))


@pytest.fixture(scope="module")
def tiny_cache(tmp_path_factory, tiny_module):
    """The one-line kernel compiled by a first run: (folder, its files)."""
    return _filled(lambda env, cwd: _tiny(env, cwd, tiny_module), tmp_path_factory.mktemp("tiny"))


def _copy_cache(filled, destination: Path) -> list[Path]:
    """The filled cache copied to ``destination`` (the same layout, so numba looks for the same files)."""
    cache, files = filled
    copied = []
    for path in files:
        target = destination / path.relative_to(cache)
        target.parent.mkdir(parents=True, exist_ok=True, mode=0o700)
        target.write_bytes(path.read_bytes())
        target.chmod(0o600)
        copied.append(target)
    for folder in {p.parent for p in copied} | {destination}:
        folder.chmod(0o700)
    return copied


def _plant(copied: list[Path], marker: Path, where: str) -> list[Path]:
    """Replace every index (``where="index"``) or every data file (``"data"``) by the planted pickle."""
    planted = [path for path in copied if path.suffix == (".nbi" if where == "index" else ".nbc")]
    for path in planted:
        path.write_bytes(pickle.dumps(_Planted(marker)))
    return planted


def _planted_case(filled, root: Path, where: str, folder: str = "cache"):
    """A copy of ``filled`` at ``root/folder`` with pickles planted: (cache folder, planted files, marker)."""
    cache = root / folder
    copied = _copy_cache(filled, cache)
    marker = root / "marker"
    return cache, _plant(copied, marker, where), marker


def test_a_first_run_makes_the_cache_folders_0700_and_files_0600(filled_cache):
    cache, files = filled_cache
    for folder in {cache, *(p.parent for p in files)}:
        assert stat.S_IMODE(folder.stat().st_mode) == 0o700 and folder.stat().st_uid == os.geteuid(), folder
    for path in files:
        assert stat.S_IMODE(path.stat().st_mode) == 0o600, path


@pytest.mark.parametrize("where", ["index", "data"])
def test_control_a_planted_pickle_in_a_folder_of_ones_own_is_read(tiny_cache, tiny_module, tmp_path, where):
    # the planted files are ones numba reads: with the user's own modes (only the user could have written
    # them, so they are trusted) the marker appears; the other tests show the same files refused
    cache, _, marker = _planted_case(tiny_cache, tmp_path, where)
    _tiny(_environment(cache, tmp_path), tmp_path, tiny_module)
    assert marker.exists()


def test_planted_pickle_in_a_world_writable_folder_under_tmp_never_runs(filled_cache, tmp_path):
    # N_planted_index_pickle, end to end: a folder "someone else" made first under /tmp, open to everyone
    cache, _, marker = _planted_case(filled_cache, tmp_path, "index", "shared")
    cache.chmod(0o777)
    result = _poses(_environment(cache, tmp_path), tmp_path)
    assert not marker.exists()
    lines = _lines(result.stderr, NOT_USED)
    assert len(lines) == 1 and "writable by others (mode 0777)" in lines[0], result.stderr
    assert result.stderr.count("\n") == 1, result.stderr  # that line alone (the FK compiles in about a second)


@pytest.mark.parametrize("mode", [0o777, 0o770, 0o1777])
def test_planted_data_pickle_in_a_folder_others_can_write_never_runs(tiny_cache, tiny_module, tmp_path, mode):
    # N_planted_data_pickle: a valid index, the data file planted; even sticky, an open folder is not one's own
    cache, _, marker = _planted_case(tiny_cache, tmp_path, "data")
    cache.chmod(mode)
    result = _tiny(_environment(cache, tmp_path), tmp_path, tiny_module)
    assert not marker.exists()
    lines = _lines(result.stderr, NOT_USED)
    assert len(lines) == 1 and f"is writable by others (mode {mode:04o})" in lines[0], result.stderr


@pytest.mark.parametrize(("where", "mode"), [("index", 0o602), ("index", 0o620), ("data", 0o660)])
def test_planted_file_writable_by_others_never_runs(tiny_cache, tiny_module, tmp_path, where, mode):
    cache, planted, marker = _planted_case(tiny_cache, tmp_path, where)
    for path in planted:
        path.chmod(mode)
    result = _tiny(_environment(cache, tmp_path), tmp_path, tiny_module)
    assert not marker.exists()
    lines = _lines(result.stderr, NOT_USED)
    assert len(lines) == 1 and f"is writable by others (mode {mode:04o})" in lines[0], result.stderr


def test_a_cache_below_a_folder_others_can_write_is_not_used(tiny_cache, tiny_module, tmp_path):
    # a folder of one's own inside an open, non-sticky folder: another user could swap it for theirs
    cache, _, marker = _planted_case(tiny_cache, tmp_path, "index", "open/cache")
    (tmp_path / "open").chmod(0o777)
    result = _tiny(_environment(cache, tmp_path), tmp_path, tiny_module)
    assert not marker.exists()
    lines = _lines(result.stderr, NOT_USED)
    assert len(lines) == 1 and "above the cache" in lines[0] and "not sticky" in lines[0], result.stderr


@pytest.mark.skipif(os.geteuid() != 0, reason="giving a folder to another user needs root")
@pytest.mark.parametrize("what", ["folder", "file"])
def test_a_cache_owned_by_someone_else_is_not_used(tiny_cache, tiny_module, tmp_path, what):
    cache, planted, marker = _planted_case(tiny_cache, tmp_path, "index")
    for path in [cache] if what == "folder" else planted:
        os.chown(path, 12345, 12345)
    result = _tiny(_environment(cache, tmp_path), tmp_path, tiny_module)
    assert not marker.exists()
    lines = _lines(result.stderr, NOT_USED)
    assert len(lines) == 1 and "owned by uid 12345" in lines[0], result.stderr


def test_the_note_says_once_what_is_compiled_and_a_second_run_says_nothing(tiny_module, tmp_path):
    first = _tiny(_environment(tmp_path / "cache", tmp_path), tmp_path, tiny_module)
    notes = _lines(first.stderr, "manipkit: compiling")
    assert len(notes) == 1 and "tiny.add_one" in notes[0] and str(tmp_path / "cache") in notes[0], first.stderr
    assert first.stderr.count("\n") == 1, first.stderr  # nothing else on stderr
    second = _tiny(_environment(tmp_path / "cache", tmp_path), tmp_path, tiny_module)
    assert second.stderr == "", second.stderr
    quiet = _tiny(_environment(tmp_path / "other", tmp_path, MANIPKIT_COMPILE_NOTE="0"), tmp_path, tiny_module)
    assert quiet.stderr == "", quiet.stderr
    # the real kernels' notes name what they compute; a compile of about a second says nothing
    assert kernel_cache.compile_note("numerical_many._solve_many", None).startswith(
        "manipkit: compiling the numerical IK of many targets (numerical_many._solve_many) for its first use, about")
    assert kernel_cache.compile_note("fk._poses", None) == ""
    # a kernel with a note of its own (the closed forms, one per family) wins over its module's
    ur = kernel_cache.compile_note("arms_kernel._solve_check_one_ur", None)
    assert "UR" in ur and "OPW" not in ur and "(arms_kernel._solve_check_one_ur)" in ur, ur
    assert "spherical-wrist" in kernel_cache.compile_note("arms_kernel._solve_rows_all_opw", None)
    assert kernel_cache.compile_note("arms_kernel._rows", None) == ""  # the row loop: about a second


def test_untrusted_folder_allows_a_private_folder_below_a_sticky_one(tmp_path):
    sticky = tmp_path / "sticky"
    sticky.mkdir()
    sticky.chmod(0o1777)
    private = sticky / "mine"
    kernel_cache.make_private_folder(private / "sub")
    assert stat.S_IMODE(private.stat().st_mode) == 0o700 and stat.S_IMODE((private / "sub").stat().st_mode) == 0o700
    assert kernel_cache.untrusted_folder(private / "sub", private) == ""
    assert "sub is writable by others (mode 0770)" in (
        (private / "sub").chmod(0o770) or kernel_cache.untrusted_folder(private / "sub", private))


def _waits_for_a_lock(pid: int) -> bool:
    """Whether process ``pid`` is blocked on a file lock (a ``->`` line of /proc/locks names the waiters)."""
    return any(line.split()[1] == "->" and line.split()[5] == str(pid)
               for line in Path("/proc/locks").read_text().splitlines() if len(line.split()) > 5)


@pytest.mark.skipif(not Path("/proc/locks").exists(), reason="needs Linux's /proc/locks to see a waiting process")
def test_a_process_waits_for_another_compiling_the_same_kernel_and_reads_its_file(tiny_cache, tiny_module, tmp_path):
    import fcntl

    filled, files = tiny_cache
    cache = tmp_path / "cache"
    folder = cache / files[0].parent.relative_to(filled)
    kernel_cache.make_private_folder(folder)
    env = _environment(cache, tmp_path, NUMBA_DEBUG_CACHE="1")
    with open(folder / "tiny.add_one.lock", "w") as lock:  # this process is "compiling" the kernel
        fcntl.flock(lock, fcntl.LOCK_EX)
        waiter = subprocess.Popen([sys.executable, str(tiny_module)], env=env, cwd=tmp_path, stdout=subprocess.PIPE,
                                  stderr=subprocess.PIPE, text=True)
        while not _waits_for_a_lock(waiter.pid):  # it found no file and waits for the lock
            assert waiter.poll() is None, waiter.communicate()
        for path in files:  # the compile "ends": its files are written, then the lock released
            target = cache / path.relative_to(filled)
            target.write_bytes(path.read_bytes())
            target.chmod(0o600)
    out, err = waiter.communicate(timeout=600)
    assert waiter.returncode == 0 and out.splitlines()[-1] == "42", err
    assert not [line for line in out.splitlines() if "data saved" in line]  # it read the file, compiled nothing
    assert "manipkit: compiling" not in err, err
