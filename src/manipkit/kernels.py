"""Compiling numba kernels, once per process and cached on disk where that works: :func:`compile_kernel`.

Every compiled function of manipkit (the batched FK and IK of
:mod:`manipkit.kinematics`, the closed forms of :mod:`manipkit.closed_form`)
is made here, so it sits below both layers: numba's on-disk cache when it
works, else compiled in memory with one :class:`KernelCacheWarning` (a
read-only install with a read-only home, a full disk); a cache file that
cannot be read (a truncated file) is recompiled and written again; the cache
key holds a digest of the package's source (:func:`sources_digest`), so a
kernel is compiled again when a kernel it calls changes. numba is
imported on the first compile, never when this module is imported.
Standard library only (numba inside the functions).
"""

from __future__ import annotations

import functools
import hashlib
import os
import warnings
from pathlib import Path

__all__ = ["KERNEL_MARKERS", "KernelCacheWarning", "compile_kernel", "kernel_sources", "lazy_kernel", "sources_digest"]


class KernelCacheWarning(UserWarning):
    """numba's on-disk cache of the compiled kernels could not be used; they were compiled in memory."""


_cache_warned = False


def _warn_cache(message: str) -> None:
    """One :class:`KernelCacheWarning` per process (every kernel meets the same folder)."""
    global _cache_warned
    if not _cache_warned:
        _cache_warned = True
        warnings.warn(" ".join(message.split()), KernelCacheWarning, stacklevel=2)


def _reason(exc: BaseException) -> str:
    text = " ".join(str(exc).split())
    text = text if len(text) <= 200 else text[:200] + "..."
    return f"{type(exc).__name__}: {text}" if text else type(exc).__name__


#: What marks a module as holding compiled code: it makes kernels with this module's functions.
KERNEL_MARKERS = (b"compile_kernel(", b"lazy_kernel(", b"@inlined_kernel")


def _imported_files(path: Path, root: Path) -> set[Path]:
    """The files under ``root`` that ``path`` imports from its own package (``from manipkit.x.y import ...``)."""
    import ast

    package = root.name
    found = set()
    for node in ast.walk(ast.parse(path.read_bytes())):
        names = [node.module] if isinstance(node, ast.ImportFrom) and node.module and not node.level else (
            [alias.name for alias in node.names] if isinstance(node, ast.Import) else [])
        for name in names:
            parts = name.split(".")
            if parts[0] != package:
                continue
            for candidate in (root.joinpath(*parts[1:]).with_suffix(".py"), root.joinpath(*parts[1:], "__init__.py")):
                if candidate.is_file():
                    found.add(candidate)
    return found


def kernel_sources(root: str | os.PathLike) -> list[Path]:
    """The modules under ``root`` with compiled code (they call :func:`compile_kernel` or :func:`lazy_kernel`),
    and the package modules each of them imports (constants read at compile time), sorted."""
    base = Path(root)
    kernels = {path for path in base.rglob("*.py") if any(m in path.read_bytes() for m in KERNEL_MARKERS)}
    return sorted(kernels.union(*(_imported_files(path, base) for path in kernels)))


def sources_digest(root: str | os.PathLike) -> str:
    """SHA-256 (hex) of the kernel modules under ``root`` (:func:`kernel_sources`: relative path and bytes, sorted).

    numba keys a cached kernel by its own function's bytecode and its file's
    time stamp, not by the kernels it calls in other modules: after a change
    to ``ik_kernel.py`` alone, ``ik_many``'s cached loop would go on running
    the old iteration. manipkit's kernels are keyed by this digest of every
    module with compiled code, and of what those modules import (constants
    are frozen into a compiled kernel), so such a change compiles them again;
    a change anywhere else (a docstring of the CLI) does not.
    """
    digest = hashlib.sha256()
    base = Path(root)
    for path in kernel_sources(base):
        digest.update(str(path.relative_to(base)).encode() + b"\0")
        digest.update(path.read_bytes() + b"\0")
    return digest.hexdigest()


@functools.cache
def _package_digest() -> str:
    return sources_digest(Path(__file__).resolve().parent)


@functools.cache
def _source_keyed_cache():
    """numba's ``FunctionCache`` with the package's :func:`sources_digest` in every index key."""
    from numba.core.caching import FunctionCache

    class SourceKeyedCache(FunctionCache):
        def _index_key(self, sig, codegen):
            return (*super()._index_key(sig, codegen), _package_digest())

    return SourceKeyedCache


class _ForgivingCache:
    """numba's ``FunctionCache`` for one kernel, made on first use, whose failures fall back to memory.

    numba raises when no cache folder is writable ("no locator available"),
    when a file cannot be saved (a full disk) and when a cache file does not
    unpickle (a truncated file); each of these would end the run. Here: no
    usable folder or a failed save -> the kernel stays compiled in memory
    (one warning); an unreadable entry -> the index is rewritten empty
    (``flush``) and the kernel recompiled, so the next save replaces the bad
    file. Implements the interface numba's dispatcher calls on ``_cache``.
    """

    def __init__(self, py_func):
        self._py_func = py_func
        self._disk = None  # numba.core.caching.FunctionCache, made on the first load
        self._usable = True

    def _cache(self):
        if self._disk is None and self._usable:
            try:
                self._disk = _source_keyed_cache()(self._py_func)
            except (RuntimeError, OSError) as exc:  # no writable folder for the cache: numba's RuntimeError
                self._give_up(exc)
        return self._disk

    def _give_up(self, exc: BaseException) -> None:
        self._usable, self._disk = False, None
        _warn_cache(
            f"the compiled kernels cannot use numba's disk cache ({_reason(exc)}); they are compiled in memory "
            "for this run (a few seconds each run); set NUMBA_CACHE_DIR to a writable folder to cache them"
        )

    @property
    def cache_path(self):
        return self._disk.cache_path if self._disk is not None else None

    def load_overload(self, sig, target_context):
        cache = self._cache()
        if cache is None:
            return None
        try:
            return cache.load_overload(sig, target_context)
        except Exception as exc:  # any failure to read a cache entry (UnpicklingError, EOFError, ...): recompile
            _warn_cache(f"numba's disk cache of the compiled kernel {self._py_func.__name__} could not be read "
                        f"({_reason(exc)}); it is compiled again and the cache rewritten")
            try:
                cache.flush()  # an empty index: the recompiled kernel is saved as a fresh entry
            except OSError as flush_exc:
                self._give_up(flush_exc)
            return None

    def save_overload(self, sig, data):
        cache = self._cache()
        if cache is None:
            return
        try:
            cache.save_overload(sig, data)
        except Exception as exc:  # a full disk, a folder made read-only, a corrupt index: keep it in memory
            self._give_up(exc)

    def enable(self):
        self._usable = True

    def disable(self):
        self._usable, self._disk = False, None

    def flush(self):
        cache = self._cache()
        if cache is not None:
            try:
                cache.flush()
            except OSError as exc:
                self._give_up(exc)


def lazy_kernel(py_func, **options):
    """A function returning ``compile_kernel(py_func, **options)``, made on its first call and kept.

    So importing a module with a kernel does not import numba; the first use
    does (``kernel()(arguments)``).
    """
    made = []

    def kernel():
        if not made:
            made.append(compile_kernel(py_func, **options))
        return made[0]

    kernel.__doc__ = f":func:`{py_func.__name__}` compiled with numba on first use (:func:`compile_kernel`)."
    return kernel


def compile_kernel(py_func, **options):
    """``py_func`` compiled by numba (``njit(**options)``), cached on disk where that works.

    Like ``njit(cache=True, **options)(py_func)``, except that the disk cache
    never ends a run: when no cache folder is writable (a read-only install
    and home, ``NUMBA_CACHE_DIR`` unset), a file cannot be written (a full
    disk) or read (a truncated file), the kernel is compiled in memory and
    one :class:`KernelCacheWarning` says so; an unreadable entry is replaced
    by the recompiled kernel. Compilation itself happens on the first call.

    Parameters
    ----------
    py_func : function
        A function numba can compile in nopython mode.
    **options
        Passed to ``numba.njit`` (``error_model="numpy"``, ...); not ``cache``.

    Returns
    -------
    numba dispatcher
    """
    from numba import njit

    dispatcher = njit(**options)(py_func)
    # numba offers no option for a cache that falls back; its dispatcher calls load_overload/save_overload
    # on `_cache` (what `enable_caching` sets), so ours goes there
    dispatcher._cache = _ForgivingCache(py_func)
    return dispatcher
