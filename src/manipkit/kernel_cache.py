"""Where the compiled kernels' disk cache lives, whether to trust it, and the one line a first compile prints.

numba's cache files are pickles: whoever can write a file there runs code
as every user who loads it. So the cache is a folder only the user can
write, and nothing in it is read unless that still holds:

- the folder is ``NUMBA_CACHE_DIR`` when that is set, else
  ``$XDG_CACHE_HOME/manipkit/kernels`` (``~/.cache/manipkit/kernels``), the
  same for a pip install and a ``make setup`` one (never ``__pycache__``
  beside the source, which belongs to whoever installed);
- the folders manipkit makes there are made with mode 0700;
- the cache folder and every folder below it on the way to a file
  (:func:`untrusted_folder`) must be owned by the user and writable by no
  one else; every folder above it must be owned by the user or root and
  writable by no one else unless sticky (``/tmp``), so that no other user can
  move a folder of their own into its place;
- every file in a kernel's folder (:func:`untrusted_files`) must be a regular
  file owned by the user and writable by no one else, checked before numba
  unpickles anything there.

A cache that fails a check is not used: the kernels are compiled in memory,
and one line says which folder or file and why. No keyed digest is kept:
under these checks only the user (or root) can have written a file, and a
key would have to live where the same user can write, so it would stop no
one the owner and mode checks do not already stop.

Standard library only.
"""

from __future__ import annotations

import os
import stat
from pathlib import Path

__all__ = ["KERNEL_NOTES", "QUIET_BELOW", "cache_root", "compile_note", "hold_lock", "make_private_folder", "release_lock", "tighten",
           "untrusted_files", "untrusted_folder"]

_OTHERS_WRITE = stat.S_IWGRP | stat.S_IWOTH


def cache_root(environ=None) -> Path:
    """The folder of the kernels' disk cache: ``NUMBA_CACHE_DIR``, else ``$XDG_CACHE_HOME/manipkit/kernels``.

    ``XDG_CACHE_HOME`` defaults to ``~/.cache`` (the XDG base directory rule).

    >>> str(cache_root({"NUMBA_CACHE_DIR": "/srv/cache"}))
    '/srv/cache'
    >>> str(cache_root({"XDG_CACHE_HOME": "/home/ada/.cache"}))
    '/home/ada/.cache/manipkit/kernels'
    """
    environ = os.environ if environ is None else environ
    if environ.get("NUMBA_CACHE_DIR"):
        return Path(environ["NUMBA_CACHE_DIR"]).expanduser().absolute()
    base = environ.get("XDG_CACHE_HOME") or str(Path.home() / ".cache")
    return Path(base).expanduser().absolute() / "manipkit" / "kernels"


def make_private_folder(path: Path) -> None:
    """Make ``path`` and any missing parents with mode 0700 (folders that exist are left as they are)."""
    missing = []
    for folder in (path, *path.parents):
        if folder.exists():
            break
        missing.append(folder)
    for folder in reversed(missing):
        try:
            folder.mkdir(mode=0o700)
        except FileExistsError:  # made meanwhile by another process: checked like any other folder
            continue
        folder.chmod(0o700)


def _mode(st: os.stat_result) -> str:
    return f"mode {stat.S_IMODE(st.st_mode):04o}"


def _owner_problem(st: os.stat_result, uid: int) -> str:
    return f"is owned by uid {st.st_uid}, not by you (uid {uid})"


def _not_alone(path: Path, st: os.stat_result, uid: int, is_kind, kind: str) -> str:
    """Why ``path`` (its ``st``) is not a ``kind`` of the user's alone (``is_kind(st_mode)``), or ``""``."""
    if not is_kind(st.st_mode):
        return f"{path} is not {kind}"
    if st.st_uid != uid:
        return f"{path} {_owner_problem(st, uid)}"
    if st.st_mode & _OTHERS_WRITE:
        return f"{path} is writable by others ({_mode(st)})"
    return ""


def untrusted_folder(folder: Path, root: Path, uid: int | None = None) -> str:
    """Why ``folder`` (``root`` or a folder below it) may not hold the cache, or ``""`` when it may.

    ``root`` and the folders from it down to ``folder`` must be the user's
    (uid ``uid``, default the effective uid) and writable by no one else; the
    folders above ``root`` must be the user's or root's and writable by no
    one else unless sticky. Symbolic links are followed (their targets are
    what is checked).

    >>> import tempfile
    >>> with tempfile.TemporaryDirectory() as tmp:
    ...     shared = Path(tmp, "shared"); shared.mkdir(); shared.chmod(0o777)
    ...     untrusted_folder(shared, shared)
    '... is writable by others (mode 0777)'
    """
    uid = os.geteuid() if uid is None else uid
    folder, root = Path(folder).absolute(), Path(root).absolute()
    own = [root, *reversed([p for p in folder.parents if p != root and root in p.parents])]
    own += [folder] if folder != root else []
    for path in own:
        try:
            st = path.stat()
        except OSError as exc:
            return f"{path} cannot be examined ({exc.strerror or exc})"
        problem = _not_alone(path, st, uid, stat.S_ISDIR, "a folder")
        if problem:
            return problem
    for path in root.parents:
        try:
            st = path.stat()
        except OSError as exc:
            return f"{path} cannot be examined ({exc.strerror or exc})"
        if st.st_uid not in (uid, 0):
            return f"{path} (above the cache) {_owner_problem(st, uid)} or root"
        if st.st_mode & _OTHERS_WRITE and not st.st_mode & stat.S_ISVTX:
            return f"{path} (above the cache) is writable by others and not sticky ({_mode(st)})"
    return ""


def untrusted_files(folder: Path, prefix: str = "", uid: int | None = None) -> str:
    """Why a file in ``folder`` whose name starts with ``prefix`` may not be read, or ``""`` when none.

    Each must be a regular file (not a link) owned by the user and writable
    by no one else; checked with ``lstat``, before anything is unpickled.

    >>> import tempfile
    >>> with tempfile.TemporaryDirectory() as tmp:
    ...     planted = Path(tmp, "k.nbi"); _ = planted.write_bytes(b""); planted.chmod(0o666)
    ...     untrusted_files(Path(tmp), "k.")
    '... is writable by others (mode 0666)'
    """
    uid = os.geteuid() if uid is None else uid
    try:
        entries = [entry for entry in os.scandir(folder) if entry.name.startswith(prefix)]
    except FileNotFoundError:
        return ""
    except OSError as exc:
        return f"{folder} cannot be listed ({exc.strerror or exc})"
    for entry in entries:
        path = Path(folder, entry.name)
        try:
            st = path.lstat()
        except FileNotFoundError:  # replaced meanwhile by the user's own process (numba writes by rename)
            continue
        problem = _not_alone(path, st, uid, stat.S_ISREG, "a regular file")
        if problem:
            return problem
    return ""


def tighten(folder: Path, prefix: str = "") -> None:
    """Files of the user's in ``folder`` starting with ``prefix``: mode 0600 (numba writes them by the umask)."""
    try:
        entries = list(os.scandir(folder))
    except OSError:
        return
    for entry in entries:
        if entry.name.startswith(prefix) and entry.is_file(follow_symlinks=False):
            try:
                if entry.stat(follow_symlinks=False).st_uid == os.geteuid():
                    os.chmod(entry.path, 0o600)
            except OSError:
                continue


#: What the kernels of a module compute and about how long compiling the outermost one (with the kernels it
#: calls) takes on an idle 2-core machine, in seconds: module (the file's name) -> (words, seconds), or
#: ``module.function`` for one kernel whose cost differs from its module's (looked up first). Measured with an
#: empty cache, one command at a time (the table in docs/site/guides/kernels.md); the closed forms' per-family
#: kernels as the compile's CPU seconds, one kernel per process (docs/site/internals/kernels.md).
KERNEL_NOTES = {
    "fk": ("the batched forward kinematics", 1),
    "program": ("the batched Jacobian", 2),
    "jacobian": ("the batched Jacobian", 2),
    "manipulability": ("the manipulability indices", 1),
    "gravity_kernel": ("the batched static torques", 2),
    "lm_kernel": ("the numerical IK", 8),
    "numerical_many": ("the numerical IK of many targets", 10),
    "arms_kernel": ("the closed-form IK's rows, residuals and labels", 2),
    "arms_kernel._solve_check_one_ur": ("the closed-form IK of UR-type arms", 52),
    "arms_kernel._solve_check_one_opw": ("the closed-form IK of spherical-wrist (OPW) arms", 59),
    "arms_kernel._solve_rows_all_ur": ("the closed-form IK of many targets of UR-type arms", 44),
    "arms_kernel._solve_rows_all_opw": ("the closed-form IK of many targets of spherical-wrist (OPW) arms", 54),
    "arms_kernel._solve_all_ur": ("the branches of UR-type arms for many targets", 42),
    "arms_kernel._solve_all_opw": ("the branches of spherical-wrist (OPW) arms for many targets", 40),
    "srs_kernel": ("the closed-form IK of 7R arms with an arm angle", 15),
    "srs_kernel._arm_angles_all": ("the arm angles of 7R SRS configurations", 2),
    "ladder_kernel": ("the task path ladder's dynamic program", 4),  # CPU s, measured on a shared machine
    "general6r_kernel": ("the general 6R elimination", 30),  # with its eigenvalues and polisher; a shared machine
    "aliases_kernel": ("the 2 pi aliases of IK rows", 2),
    "check_kernel.measure_rows": ("the forward kinematics and residuals of IK rows", 2),
}
#: Compiles shorter than this (s) are not worth a line: the command answers about as soon as it would have.
QUIET_BELOW = 3


def compile_note(name: str, folder: Path | None) -> str:
    """The one line said before a kernel (``module.function``) is compiled for its first use; "" for a short one.

    >>> compile_note("lm_kernel.lm_attempt", Path("/home/ada/.cache/manipkit/kernels"))
    'manipkit: compiling the numerical IK (lm_kernel.lm_attempt) for its first use, about 8 s; kept in /home/ada/.cache/manipkit/kernels for later runs'
    >>> compile_note("fk._poses", None)
    ''
    """
    words, seconds = KERNEL_NOTES.get(name) or KERNEL_NOTES.get(name.split(".")[0], ("compiled code", None))
    if seconds is not None and seconds < QUIET_BELOW:
        return ""
    about = ("a few seconds or more" if seconds is None else
             f"about {seconds} s" if seconds < 120 else f"about {round(seconds / 60)} min")
    where = f"kept in {folder} for later runs" if folder is not None else "in memory for this run only"
    return f"manipkit: compiling {words} ({name}) for its first use, {about}; {where}"


def hold_lock(folder: Path, name: str):
    """An exclusive lock on ``folder/name.lock`` (made 0600), waited for; the open file, or None if none can be made.

    Two processes that would compile the same kernel at once: the second
    waits here and then reads the first one's file instead of compiling it.
    """
    import fcntl

    try:
        fd = os.open(folder / f"{name}.lock", os.O_RDWR | os.O_CREAT | os.O_NOFOLLOW | os.O_CLOEXEC, 0o600)
    except OSError:
        return None
    try:
        fcntl.flock(fd, fcntl.LOCK_EX)
    except OSError:
        os.close(fd)
        return None
    return fd


def release_lock(fd) -> None:
    """Release a lock :func:`hold_lock` took (``None``: nothing to release)."""
    if fd is not None:
        os.close(fd)  # closing the file releases its flock
