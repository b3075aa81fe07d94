"""Where the compiled kernels are kept: one cache per install that every process reuses.

The planner's kernels are numba functions with ``cache=True``: compiled on first use, then
written to disk and loaded by every later process (a service's workers, batch jobs), so
nothing compiles per job. numba keeps them in ``__pycache__`` next to each source file when
that folder is writable (a source checkout, ``pip install -e``), else in a user folder. A
system-wide install (read-only site-packages) run by a user whose home is read-only too (a
service account, a container) would leave numba no folder at all: it then refuses to import
the planner. :func:`ensure_kernel_cache` (run by ``import toolpath``, before any kernel
module loads numba) settles the folder first:

1. ``NUMBA_CACHE_DIR`` when set (e.g. a temporary folder for a cold-start benchmark);
2. numba's own choice when the package folder is writable;
3. else ``$XDG_CACHE_HOME/streamline-cam/kernels`` (``~/.cache/...``), else a folder in the
   system's temporary directory, whichever is writable first (set as ``NUMBA_CACHE_DIR``).

It also makes the cache safe to share and to outlive the code (:func:`hook_numba`, applied
when numba gets imported, so that commands which never load numba do not pay for it):

* **a stale index is dropped, not raised**: numba unpickles a kernel's cache index before
  it checks the source's stamp, and the index names the classes of the kernel's signature
  (the named tuples the kernels take); after an upgrade that renamed or removed one of them
  the unpickling raised ``AttributeError`` at the first call. An index that cannot be read
  now counts as empty: the kernel compiles again and writes a fresh index;
* **a kernel is as fresh as every kernel it may call**: numba stamps a kernel's cache
  with its own source file only, yet a kernel calling a compiled function of another
  module holds that function's machine code too: after an edit of the callee's module (a
  ``git pull`` into an editable install touches only the files that changed) the caller
  loaded from the cache ran the old callee, silently. The stamp of every kernel of
  :data:`KERNEL_PACKAGES` now also holds a digest of all their modules
  (:func:`kernel_sources_digest`; a module without kernels may hold constants a kernel
  compiles in): an edit of any of them compiles those kernels afresh as they are used;
* **one process compiles a kernel, the others wait and load it**: a compile (and the cache
  look-up before it) holds a lock file beside the kernel's index, so processes starting on
  an empty cache at once (the warm-up's jobs, a service's or a batch's workers) never
  compile the same kernel twice.

:func:`compile_if_free` is the same compile for a process that compiles ahead of a job
(the job's helper, the warm-up): it skips a kernel the disk cache holds already (without
loading it) and, if asked, one another process compiles at the moment, so that such
processes share a list of kernels instead of waiting for each other.
"""

from __future__ import annotations

import contextlib
import functools
import hashlib
import importlib.abc
import importlib.util
import os
import sys
import tempfile
import time
from collections.abc import Callable, Iterator, MutableMapping
from pathlib import Path
from types import ModuleType
from typing import Any, Final

try:
    import fcntl
except ImportError:  # (Windows: no lock across processes; each may compile a kernel)
    fcntl = None

__all__ = ["BUSY", "CACHED", "COMPILED", "choose_cache_dir", "compile_if_free",
           "ensure_kernel_cache", "hook_numba", "in_disk_cache", "kernel_sources_digest",
           "working_while_waiting"]

PACKAGE_DIR = Path(__file__).resolve().parent
#: Where the packages whose kernels call each other's lie (the folder holding ``toolpath``).
KERNEL_ROOT = PACKAGE_DIR.parent
#: The packages, under :data:`KERNEL_ROOT`, whose kernels share one source digest (a module
#: with kernels in another package must be listed here: a test checks it).
KERNEL_PACKAGES: tuple[str, ...] = ("toolpath", "verification")


def _writable(folder: Path) -> bool:
    """Whether files can be created in ``folder`` (created if missing)."""
    try:
        folder.mkdir(parents=True, exist_ok=True)
        with tempfile.TemporaryFile(dir=folder):
            return True
    except OSError:
        return False


def choose_cache_dir(environ: MutableMapping[str, str], package_dir: Path = PACKAGE_DIR,
                     writable: Callable[[Path], bool] = _writable) -> Path | None:
    """The kernel cache folder to set, or None where numba's default works (see above).

    ``NUMBA_CACHE_DIR`` from ``environ`` wins; a writable ``package_dir`` keeps numba's
    in-tree ``__pycache__``; else the first writable of the user cache folder and the
    temporary one.
    """
    given = environ.get("NUMBA_CACHE_DIR")
    if given:
        return Path(given)
    if writable(package_dir / "__pycache__"):
        return None
    home = environ.get("XDG_CACHE_HOME") or str(Path(environ.get("HOME") or "~").expanduser()
                                                / ".cache")
    uid = os.getuid() if hasattr(os, "getuid") else "user"
    for folder in (Path(home) / "streamline-cam" / "kernels",
                   Path(tempfile.gettempdir()) / f"streamline-cam-kernels-{uid}"):
        if writable(folder):
            return folder
    return None


def ensure_kernel_cache() -> Path | None:
    """Settle the kernel cache folder for this process (see the module's text).

    Sets ``NUMBA_CACHE_DIR`` (and numba's setting, if numba is loaded already) when the
    package folder is read-only; returns the folder set, or None for numba's default.
    """
    hook_numba()
    folder = choose_cache_dir(os.environ)
    if folder is None or os.environ.get("NUMBA_CACHE_DIR"):
        return folder
    os.environ["NUMBA_CACHE_DIR"] = str(folder)
    config = getattr(sys.modules.get("numba"), "config", None)
    if config is not None:
        config.CACHE_DIR = str(folder)
    return folder


def hook_numba() -> None:
    """Patch numba's kernel cache (see the module's text) now, or when numba is imported.

    Loads nothing: with numba not yet imported, a one-time import hook patches it right
    after its import. Patching twice is a no-op. Also speeds up numba's type inference
    (:mod:`toolpath.typing_speed`: plain error messages among others).
    """
    if "numba" in sys.modules:
        _patch_numba()
    elif not any(isinstance(finder, _NumbaImportHook) for finder in sys.meta_path):
        sys.meta_path.insert(0, _NumbaImportHook())


class _NumbaImportHook(importlib.abc.MetaPathFinder):
    """Runs :func:`_patch_numba` right after ``import numba`` (once, then leaves)."""

    def find_spec(self, fullname: str, path: Any = None, target: Any = None) -> Any:
        if fullname != "numba":
            return None
        with contextlib.suppress(ValueError):
            sys.meta_path.remove(self)
        spec = importlib.util.find_spec(fullname)
        if spec is not None and spec.loader is not None:
            spec.loader = _PatchAfterLoad(spec.loader)
        return spec


class _PatchAfterLoad(importlib.abc.Loader):
    """numba's own loader, then :func:`_patch_numba`."""

    def __init__(self, loader: Any) -> None:
        self._loader = loader

    def __getattr__(self, name: str) -> Any:  # (the rest of the loader's interface)
        return getattr(self._loader, name)

    def create_module(self, spec: Any) -> ModuleType | None:
        return self._loader.create_module(spec)

    def exec_module(self, module: ModuleType) -> None:
        self._loader.exec_module(module)
        _patch_numba()


def _patch_numba() -> None:
    """Patch numba's kernel cache and compiler (the module's text).

    Stale indexes are dropped, kernels are stamped with the kernel modules' digest, each
    kernel compiles in one process; its type inference skips work that decides nothing
    (:mod:`toolpath.typing_speed`).
    """
    from numba.core import caching, dispatcher

    from .typing_speed import speed_up_typing

    speed_up_typing()

    # (numba's internals as of 0.68: a numba without them is left as it is)
    located = getattr(caching, "_SourceFileBackedLocatorMixin", None)
    if hasattr(located, "get_source_stamp") and not getattr(located, "_streamline_cam", False):
        located.get_source_stamp = _with_package_digest(located.get_source_stamp)
        located._streamline_cam = True
    index_file = getattr(caching, "IndexDataCacheFile", None)
    if hasattr(index_file, "_load_index") and not getattr(index_file, "_streamline_cam", False):
        index_file._load_index = _readable_index(index_file._load_index)
        index_file._streamline_cam = True
    compiled = getattr(dispatcher, "Dispatcher", None)
    if hasattr(compiled, "compile") and not getattr(compiled, "_streamline_cam", False):
        try:
            compiled.compile = _compile_once(compiled.compile)
        except ImportError:
            return
        compiled._streamline_cam = True


@functools.cache
def kernel_sources_digest() -> bytes:
    """SHA-256 over the path and content of every module of :data:`KERNEL_PACKAGES`.

    Every module, not only those defining kernels: a kernel compiles in the constants it
    reads from others (tolerances, shares). Read once per process (a hundred files, ~3 ms),
    at the first kernel's definition.
    """
    digest = hashlib.sha256()
    for package in KERNEL_PACKAGES:
        for path in sorted((KERNEL_ROOT / package).rglob("*.py")):
            with contextlib.suppress(OSError):
                source = path.read_bytes()
                digest.update(path.relative_to(KERNEL_ROOT).as_posix().encode())
                digest.update(hashlib.sha256(source).digest())
    return digest.digest()


@functools.cache
def _kernel_package_dirs() -> tuple[Path, ...]:
    """The folders of :data:`KERNEL_PACKAGES`, resolved (once per process)."""
    return tuple((KERNEL_ROOT / package).resolve() for package in KERNEL_PACKAGES)


def _with_package_digest(source_stamp: Callable[[Any], Any]) -> Callable[[Any], Any]:
    """Wrap numba's ``get_source_stamp``: kernels of :data:`KERNEL_PACKAGES` add the digest."""

    def get_source_stamp(self: Any) -> Any:
        stamp = source_stamp(self)
        path = getattr(self, "_py_file", None)
        if path and any(Path(path).resolve().is_relative_to(root)
                        for root in _kernel_package_dirs()):
            return stamp, kernel_sources_digest()
        return stamp

    get_source_stamp.__doc__ = source_stamp.__doc__
    return get_source_stamp


def _readable_index(load_index: Callable[[Any], dict]) -> Callable[[Any], dict]:
    """Wrap numba's ``IndexDataCacheFile._load_index``: an unreadable index counts as empty.

    numba unpickles the index (kernel signatures, which name their classes) before it
    compares the source stamp: a class since renamed or removed, a module gone, a damaged
    file raise there. Such an index is stale: removed, and the kernel compiles afresh (its
    next save writes a new index; the old data files are overwritten in turn).
    """

    def _load_index(self: Any) -> dict:
        try:
            return load_index(self)
        except OSError:  # (not the index's content: e.g. another user's unreadable file)
            raise
        except Exception:  # (whatever unpickling raised: the index is stale)
            with contextlib.suppress(OSError):
                os.remove(self._index_path)
            return {}

    _load_index.__doc__ = load_index.__doc__
    return _load_index


#: How long a process waits for another's compile of the same kernel before it compiles
#: the kernel itself (a duplicate compile is harmless; a hung or stopped process, or a
#: future cycle of kernels compiling each other, must not stall every job).
LOCK_WAIT_S = 600.0
#: How often a waiting process tries the lock again.
LOCK_POLL_S = 0.05


def _try_lock(handle: int) -> bool | None:
    """Take an exclusive ``flock`` on ``handle`` now: True; False if another holds it.

    None where the file system has no locks (``flock`` raises, e.g. NFS mounted ``nolock``).
    """
    try:
        fcntl.flock(handle, fcntl.LOCK_EX | fcntl.LOCK_NB)
        return True
    except BlockingIOError:
        return False
    except OSError:
        return None


def _wait_for_lock(handle: int, wait_s: float = LOCK_WAIT_S) -> bool:
    """Take an exclusive ``flock`` on ``handle`` within ``wait_s`` seconds; False if not.

    False too where the file system has no locks (``flock`` raises, e.g. NFS mounted
    ``nolock``): the kernel then compiles unlocked, as numba alone would.
    """
    deadline = time.monotonic() + wait_s
    while (taken := _try_lock(handle)) is False and time.monotonic() < deadline:
        if not _work_while_waiting():
            time.sleep(LOCK_POLL_S)
    return bool(taken)


#: What this process may do instead of sleeping while it waits for another process's
#: compile (innermost last; see :func:`working_while_waiting`), and whether it does it now.
_WHILE_WAITING: list[Callable[[], bool]] = []
_WORKING: list[bool] = [False]


@contextlib.contextmanager
def working_while_waiting(work: Callable[[], bool]) -> Iterator[None]:
    """Inside, a wait for another process's compile of a kernel runs ``work`` meanwhile.

    ``work()`` does one piece of work (e.g. compiles a kernel this process will call later,
    which nobody compiles yet) and returns whether it found one; when it finds none, the
    wait sleeps as before. A wait inside ``work`` itself only sleeps (no nesting).
    """
    _WHILE_WAITING.append(work)
    try:
        yield
    finally:
        _WHILE_WAITING.remove(work)


def _work_while_waiting() -> bool:
    """Run the innermost :func:`working_while_waiting` work once; whether it did some.

    Only in a top-level wait: while this process compiles another kernel (one that calls
    the kernel it waits for), the wait only sleeps. Work done there would
    run inside numba's compile of that outer kernel: a kernel reaching the outer one would
    be typed as recursion and cached broken (later processes loading it crash), and one
    reaching a kernel another process holds while that one waits for the outer kernel's
    lock would stall both for :data:`LOCK_WAIT_S`.
    """
    if not _WHILE_WAITING or _WORKING[0] or _COMPILING[0] > 1:
        return False
    _WORKING[0] = True
    try:
        return _WHILE_WAITING[-1]()
    finally:
        _WORKING[0] = False


#: Lock files this process holds (path -> depth), so that a nested compile of the same
#: kernel does not wait for itself.
_HELD: dict[str, int] = {}
#: How many of numba's compiles this process runs one inside the other (a kernel's
#: compile compiles the kernels it calls). Like :data:`_HELD` and the waiting work, read
#: and changed only under numba's compiler lock, which every thread takes to compile.
_COMPILING: list[int] = [0]


def _compile_once(compile_: Callable[[Any, Any], Any]) -> Callable[[Any, Any], Any]:
    """Wrap numba's ``Dispatcher.compile``: under a lock file beside the kernel's cache index.

    For kernels with a disk cache (``cache=True``) and a signature not yet in this
    process: numba's compile lock, then the kernel's lock file (in that order, as every
    thread of the process takes them: no lock-order cycle), then numba's own cache look-up
    and compile. A second process asking for the kernel meanwhile waits, then loads what
    the first saved. Kernels call kernels but never back (no cycle across processes).
    """
    from numba.core import sigutils
    from numba.core.compiler_lock import global_compiler_lock

    def compile(self: Any, sig: Any) -> Any:
        with global_compiler_lock:
            _COMPILING[0] += 1
            try:
                return _locked(self, sig)
            finally:
                _COMPILING[0] -= 1

    def _locked(self: Any, sig: Any) -> Any:
        index_path = getattr(getattr(self._cache, "_cache_file", None), "_index_path", None)
        if index_path is None or fcntl is None:
            return compile_(self, sig)
        args, _ = sigutils.normalize_signature(sig)
        if tuple(args) in self.overloads:
            return compile_(self, sig)
        with _file_lock(index_path + ".lock"):
            return compile_(self, sig)

    compile.__doc__ = compile_.__doc__
    return compile


@contextlib.contextmanager
def _file_lock(path: str, wait_s: float = LOCK_WAIT_S) -> Iterator[bool]:
    """Hold an exclusive lock on ``path`` (created if missing); a no-op where it cannot.

    Waits up to ``wait_s`` seconds for another process's lock, then goes on without it.
    Yields True (held, or no lock to be had), or False, holding nothing, when ``wait_s`` is
    0 and another process holds the lock.
    """
    if _HELD.get(path):
        _HELD[path] += 1
        try:
            yield True
        finally:
            _HELD[path] -= 1
        return
    try:
        handle = os.open(path, os.O_RDWR | os.O_CREAT, 0o666)
    except OSError:  # (a read-only cache: numba will not save there either)
        yield True
        return
    try:
        taken = _try_lock(handle)
        if taken is False and wait_s > 0.0:  # (held too long: compile unlocked)
            taken = _wait_for_lock(handle, wait_s) or None
        if taken is False:  # (another process holds it, and we do not wait)
            yield False
            return
        if taken is None:  # (no locks on this file system, or held too long)
            yield True
            return
        _HELD[path] = 1
        try:
            yield True
        finally:
            del _HELD[path]
            fcntl.flock(handle, fcntl.LOCK_UN)
    finally:
        os.close(handle)


#: What :func:`compile_if_free` did: found it in the disk cache (not loaded), found another
#: process compiling it (with ``wait=False``), compiled it (and saved it to the cache).
CACHED: Final = "cached"
BUSY: Final = "busy"
COMPILED: Final = "compiled"


def _index_path(dispatcher: Any) -> str | None:
    """The path of the kernel's cache index, or None for a kernel without a disk cache."""
    return getattr(getattr(dispatcher._cache, "_cache_file", None), "_index_path", None)


def in_disk_cache(dispatcher: Any, args: tuple[Any, ...]) -> bool:
    """Whether the kernel cache holds ``dispatcher`` compiled for the numba types ``args``.

    Reads the kernel's cache index only (the key numba looks up: the signature, the target
    machine and a hash of the kernel's bytecode); loads nothing.
    """
    cache = dispatcher._cache
    if _index_path(dispatcher) is None:
        return False
    key = cache._index_key(tuple(args), dispatcher.targetctx.codegen())
    return key in cache._cache_file._load_index()


def compile_if_free(dispatcher: Any, args: tuple[Any, ...], *, wait: bool = True) -> str:
    """Compile ``dispatcher`` for the numba types ``args`` into the cache, unless it is there.

    Under the kernel's lock file (as :func:`hook_numba`'s compile): :data:`CACHED` when the
    cache holds the kernel already (it is not loaded here: a process compiling ahead of a
    job does not need it), else compiled and saved: :data:`COMPILED`. A kernel this process
    compiles already (further up its stack) is :data:`BUSY`; with ``wait=False``, so is a
    kernel whose lock another process holds (it compiles the kernel, or a kernel calling
    it): left to it, at once. Compile errors are raised.
    """
    from numba.core.compiler_lock import global_compiler_lock

    args = tuple(args)
    index_path = _index_path(dispatcher)
    if args in dispatcher.overloads:
        return CACHED
    if index_path is None or fcntl is None:
        dispatcher.compile(args)
        return COMPILED
    if _HELD.get(index_path + ".lock"):  # (this process compiles it now, further up)
        return BUSY
    with global_compiler_lock, _file_lock(index_path + ".lock",
                                          LOCK_WAIT_S if wait else 0.0) as held:
        if not held:
            return BUSY
        if in_disk_cache(dispatcher, args):
            return CACHED
        dispatcher.compile(args)
        return COMPILED
