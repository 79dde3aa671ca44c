"""Compiling numba kernels, once per process and cached on disk where that works: :func:`compile_kernel`.

Every compiled function of manipkit (a chain's program in
:mod:`manipkit.kernels.fk` and :mod:`manipkit.kernels.program`, the IK
iteration of :mod:`manipkit.kinematics`, the closed forms of
:mod:`manipkit.closed_form`) is made here, so it sits below those layers: numba's on-disk cache when it
works, else compiled in memory with one :class:`KernelCacheWarning` (a
read-only install with a read-only home, a full disk, a cache folder or file
others can write: :mod:`manipkit.kernel_cache` says where the cache lives and
what it trusts); a cache file that cannot be read (a truncated file) is
recompiled and written again; the cache key holds a digest of the kernel's
own module and what it reads at compile time (:func:`sources_digest`), so a
kernel is compiled again when a kernel it calls changes, and only then. A kernel compiled for its first use says so in one line on
stderr (:func:`manipkit.kernel_cache.compile_note`; ``MANIPKIT_COMPILE_NOTE=0``
silences it), and processes compiling the same kernel at once wait for the
first one's file instead of compiling it twice. numba is imported on the first
compile, never when this module is imported. Standard library only (numba
inside the functions).
"""

from __future__ import annotations

import functools
import os
import sys
import warnings
from pathlib import Path

from manipkit import kernel_cache

__all__ = ["KERNEL_MARKERS", "KernelCacheWarning", "UntrustedCacheError", "compile_kernel", "kernel_closure",
           "lazy_kernel", "sources_digest"]


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
    """The files under ``root`` that ``path`` imports from its own package (``from manipkit.x.y import ...``;
    ``from manipkit.x import y`` names the module ``y`` when there is one, not the package's ``__init__``)."""
    import ast

    package = root.name

    def module_file(name: str) -> Path | None:
        parts = name.split(".")
        if parts[0] != package:
            return None
        for candidate in (root.joinpath(*parts[1:]).with_suffix(".py"), root.joinpath(*parts[1:], "__init__.py")):
            if candidate.is_file():
                return candidate
        return None

    found = set()
    for node in ast.walk(ast.parse(path.read_bytes())):
        if isinstance(node, ast.ImportFrom) and node.module and not node.level:
            submodules = [module_file(f"{node.module}.{alias.name}") for alias in node.names]
            if all(submodules):
                found.update(submodules)
                continue
            names = [node.module]
        elif isinstance(node, ast.Import):
            names = [alias.name for alias in node.names]
        else:
            continue
        found.update(file for file in map(module_file, names) if file is not None)
    return found


def kernel_closure(module: str | os.PathLike, root: str | os.PathLike) -> list[Path]:
    """The files a kernel in ``module`` depends on at compile time, sorted: ``module`` itself, the package modules
    it imports (constants are frozen into a compiled kernel), and, through each of those with compiled code
    (:data:`KERNEL_MARKERS`), the modules they import in turn (a kernel it calls, inlined or not)."""
    base = Path(root)
    start = Path(module)
    seen, todo = {start}, [start]
    while todo:
        for path in _imported_files(todo.pop(), base):
            if path not in seen:
                seen.add(path)
                data = path.read_bytes()
                # through kernel modules, not through this machinery (its imports say where the cache lives)
                if any(marker in data for marker in KERNEL_MARKERS) and b"def compile_kernel(" not in data:
                    todo.append(path)
    return sorted(seen)


def sources_digest(module: str | os.PathLike, root: str | os.PathLike) -> str:
    """SHA-256 (hex) of what a kernel in ``module`` is compiled from (:func:`kernel_closure`: relative path and
    bytes, sorted).

    numba keys a cached kernel by its own function's bytecode and its file's
    time stamp, not by the kernels it calls in other modules: after a change
    to ``lm_kernel.py`` alone, ``numerical_many``'s cached loop would go on running
    the old iteration. manipkit's kernels are keyed by this digest of the
    kernel's module, of what it imports, and of what the kernel modules among
    those import, so such a change compiles them again; a change anywhere else
    (a docstring of the CLI, another kernel's module) does not.
    """
    import hashlib  # here, not at the top: commands that compile nothing do not load OpenSSL

    digest = hashlib.sha256()
    base = Path(root)
    for path in kernel_closure(module, base):
        name = path.relative_to(base) if path.is_relative_to(base) else path  # a kernel outside the package: itself
        digest.update(str(name).encode() + b"\0")
        digest.update(path.read_bytes() + b"\0")
    return digest.hexdigest()


@functools.cache
def _module_digest(module: str) -> str:
    return sources_digest(module, Path(__file__).resolve().parents[1])  # the package is the root


@functools.cache
def _source_keyed_cache():
    """numba's ``FunctionCache`` in :func:`manipkit.kernel_cache.cache_root`, checked, keyed by :func:`sources_digest`
    of the kernel's module."""
    from numba.core.caching import CompileResultCacheImpl, FunctionCache, UserProvidedCacheLocator

    class TrustedLocator(UserProvidedCacheLocator):
        """numba's locator for a folder of the user's choosing, put in the checked cache root (made 0700)."""

        def __init__(self, py_func, py_file):
            super().__init__(py_func, py_file)
            self._cache_path = str(kernel_cache.cache_root() / self.get_suitable_cache_subpath(py_file))

        def ensure_cache_path(self):
            kernel_cache.make_private_folder(Path(self._cache_path))
            problem = kernel_cache.untrusted_folder(Path(self._cache_path), kernel_cache.cache_root())
            if problem:
                raise UntrustedCacheError(problem)
            super().ensure_cache_path()  # numba's own check that a file can be written there

        @classmethod
        def from_function(cls, py_func, py_file):
            locator = cls(py_func, py_file)
            locator.ensure_cache_path()  # raises: numba's other locators (__pycache__, ...) are never tried
            return locator

    class TrustedImpl(CompileResultCacheImpl):
        _locator_classes = [TrustedLocator]

    class SourceKeyedCache(FunctionCache):
        _impl_class = TrustedImpl

        def _index_key(self, sig, codegen):
            return (*super()._index_key(sig, codegen), _module_digest(self._py_func.__code__.co_filename))

    return SourceKeyedCache


class UntrustedCacheError(PermissionError):
    """The kernels' cache folder or one of its files is not the user's alone (:mod:`manipkit.kernel_cache`)."""


#: The outermost kernel being compiled in this process: [(its cache, signature, lock)] (numba compiles one at a time).
_compiling: list = []


def _kernel_name(py_func) -> str:
    return f"{Path(py_func.__code__.co_filename).stem}.{py_func.__qualname__}"


def _say_compiling(py_func, folder) -> None:
    """The one line on stderr before an outermost kernel compiles, if it takes a while (``MANIPKIT_COMPILE_NOTE=0``: none)."""
    note = kernel_cache.compile_note(_kernel_name(py_func), kernel_cache.cache_root() if folder is not None else None)
    if note and os.environ.get("MANIPKIT_COMPILE_NOTE", "1") != "0" and sys.stderr is not None:
        print(note, file=sys.stderr, flush=True)


def _compile_ended(cache, sig) -> None:
    if _compiling and _compiling[0][:2] == (cache, sig):
        kernel_cache.release_lock(_compiling.pop()[2])


class _ForgivingCache:
    """numba's ``FunctionCache`` for one kernel, made on first use, whose failures fall back to memory.

    numba raises when no cache folder is writable ("no locator available"),
    when a file cannot be saved (a full disk) and when a cache file does not
    unpickle (a truncated file); each of these would end the run. Here: no
    usable folder, a folder or file others could have written, or a failed
    save -> the kernel stays compiled in memory (one warning); an unreadable
    entry -> the index is rewritten empty (``flush``) and the kernel
    recompiled, so the next save replaces the bad file. Implements the
    interface numba's dispatcher calls on ``_cache``.
    """

    def __init__(self, py_func):
        self._py_func = py_func
        self._disk = None  # numba.core.caching.FunctionCache, made on the first load
        self._usable = True

    def _cache(self):
        if self._disk is None and self._usable:
            try:
                disk = _source_keyed_cache()(self._py_func)
                problem = _untrusted_files(disk.cache_path)  # before numba unpickles anything there
                if problem:
                    raise UntrustedCacheError(problem)
                self._disk = disk
            except (RuntimeError, OSError) as exc:  # no writable folder for the cache: numba's RuntimeError
                self._give_up(exc)
        return self._disk

    def _give_up(self, exc: BaseException) -> None:
        self._usable, self._disk = False, None
        if isinstance(exc, UntrustedCacheError):
            _warn_cache(f"the compiled kernels' cache is not used: {exc} (a file there could run code as you); "
                        "they are compiled in memory for this run; remove it, or set NUMBA_CACHE_DIR to a folder "
                        "only you can write")
            return
        _warn_cache(
            f"the compiled kernels cannot use numba's disk cache ({_reason(exc)}); they are compiled in memory "
            "for this run (a few seconds each run); set NUMBA_CACHE_DIR to a writable folder to cache them"
        )

    @property
    def cache_path(self):
        return self._disk.cache_path if self._disk is not None else None

    def load_overload(self, sig, target_context):
        cache = self._cache()
        found = self._load(cache, sig, target_context)
        if found is None and not _compiling:  # an outermost kernel to compile (its callees load inside)
            folder = Path(cache.cache_path) if cache is not None else None
            lock = kernel_cache.hold_lock(folder, _kernel_name(self._py_func)) if folder is not None else None
            _compiling.append((self, sig, lock))
            found = self._load(self._disk, sig, target_context)  # another process may have made it meanwhile
            if found is not None:
                _compile_ended(self, sig)
            else:
                _say_compiling(self._py_func, folder)
        return found

    def _load(self, cache, sig, target_context):
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
        try:
            if cache is not None:
                cache.save_overload(sig, data)
                kernel_cache.tighten(Path(cache.cache_path))
        except Exception as exc:  # a full disk, a folder made read-only, a corrupt index: keep it in memory
            self._give_up(exc)
        finally:
            _compile_ended(self, sig)

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


#: The cache folders whose files were checked in this process (the folders are the user's alone, so what is
#: added later was written by the user's own processes).
_checked: set = set()


def _untrusted_files(folder: str) -> str:
    if folder in _checked:
        return ""
    problem = kernel_cache.untrusted_files(Path(folder))
    if not problem:
        _checked.add(folder)
    return problem


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
