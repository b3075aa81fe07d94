"""The kernel cache folder: numba's own in a writable package, a user folder otherwise."""

import os
import re
import tempfile
import time
from pathlib import Path

import pytest

from toolpath.kernel_cache import PACKAGE_DIR, _wait_for_lock, choose_cache_dir

try:
    import fcntl
except ImportError:  # (Windows)
    fcntl = None


def test_a_writable_package_keeps_numba_s_folder_and_the_variable_wins(tmp_path):
    assert choose_cache_dir({}, tmp_path) is None
    assert choose_cache_dir({"NUMBA_CACHE_DIR": "/x/y"}, tmp_path,
                            writable=lambda _folder: False) == Path("/x/y")


def test_a_read_only_package_caches_in_the_user_folder(tmp_path):
    read_only = tmp_path / "site-packages" / "toolpath"
    environ = {"XDG_CACHE_HOME": str(tmp_path / "cache")}
    folder = choose_cache_dir(environ, read_only,
                              writable=lambda f: not f.is_relative_to(read_only)
                              and f.mkdir(parents=True, exist_ok=True) is None)
    assert folder == tmp_path / "cache" / "streamline-cam" / "kernels" and folder.is_dir()
    environ = {"HOME": str(tmp_path / "home")}  # no XDG_CACHE_HOME: ~/.cache
    assert choose_cache_dir(environ, read_only, writable=lambda f: f != read_only / "__pycache__"
                            ) == tmp_path / "home" / ".cache" / "streamline-cam" / "kernels"


def test_with_no_writable_home_the_temporary_folder(tmp_path):
    read_only = tmp_path / "ro"
    folder = choose_cache_dir({"HOME": str(read_only)}, read_only,
                              writable=lambda f: not f.is_relative_to(read_only))
    assert folder is not None and folder.parent == Path(tempfile.gettempdir())


def test_the_package_folder_is_the_toolpath_package():
    assert (PACKAGE_DIR / "compiled.py").is_file()


# A kernel taking a named tuple, in a module of its own; ``NAME`` is the tuple's class name.
KERNEL_MODULE = '''
from typing import NamedTuple

import numba


class NAME(NamedTuple):
    a: float
    b: float


@numba.njit(cache=True)
def total(pair):
    return pair.a + 2.0 * pair.b
'''

# Imports toolpath first (which hooks numba, as every command does), then the kernel; prints
# the kernel's result and whether it came from the cache.
RUN_KERNEL = '''
import importlib, sys
import toolpath  # noqa: F401
kernel = importlib.import_module("kernel_mod")
print(kernel.total(getattr(kernel, sys.argv[1])(1.0, 2.0)),
      sum(kernel.total.stats.cache_hits.values()))
'''


def _run_kernel(folder: Path, cls: str) -> tuple[str, int]:
    import os
    import subprocess
    import sys

    root = Path(__file__).resolve().parents[2]
    env = {**os.environ, "PYTHONPATH": os.pathsep.join((str(folder), str(root))),
           "NUMBA_CACHE_DIR": str(folder / "cache")}
    done = subprocess.run([sys.executable, "-c", RUN_KERNEL, cls], cwd=folder, env=env,
                          capture_output=True, text=True, timeout=120)
    assert done.returncode == 0, done.stderr
    value, hits = done.stdout.split()
    return value, int(hits)


def test_a_cache_index_naming_a_renamed_class_is_dropped_and_rewritten(tmp_path):
    module = tmp_path / "kernel_mod.py"
    module.write_text(KERNEL_MODULE.replace("NAME", "Pair"), encoding="utf-8")
    assert _run_kernel(tmp_path, "Pair") == ("5.0", 0)  # compiled, index written
    assert _run_kernel(tmp_path, "Pair") == ("5.0", 1)  # loaded from the cache
    indexes = list((tmp_path / "cache").rglob("*.nbi"))
    assert len(indexes) == 1 and b"Pair" in indexes[0].read_bytes()
    # an upgrade renames the class: the index names a class the module no longer has
    # (numba's unpickling of it raised AttributeError before its stamp check)
    module.write_text(KERNEL_MODULE.replace("NAME", "Couple"), encoding="utf-8")
    assert _run_kernel(tmp_path, "Couple") == ("5.0", 0)  # compiled again
    assert b"Pair" not in indexes[0].read_bytes()
    assert _run_kernel(tmp_path, "Couple") == ("5.0", 1)  # the new index serves


def test_the_hook_waits_for_numba_and_patches_it_once():
    import subprocess
    import sys

    code = ("import sys, toolpath\n"
            "assert 'numba' not in sys.modules\n"
            "from numba.core import caching, dispatcher\n"
            "from toolpath.kernel_cache import hook_numba\n"
            "compile_, load = dispatcher.Dispatcher.compile, "
            "caching.IndexDataCacheFile._load_index\n"
            "hook_numba()\n"
            "assert dispatcher.Dispatcher.compile is compile_\n"
            "assert caching.IndexDataCacheFile._load_index is load\n"
            "print(compile_.__module__, load.__module__)\n")
    root = Path(__file__).resolve().parents[2]
    done = subprocess.run([sys.executable, "-c", code], cwd=root, capture_output=True,
                          text=True, timeout=120)
    assert done.returncode == 0, done.stderr
    assert done.stdout.split() == ["toolpath.kernel_cache"] * 2


# Waits for the file ``go`` (both processes ready), then calls the kernel: prints whether it
# compiled it (a cache miss) or loaded it.
RACE_KERNEL = '''
import importlib, os, sys, time
import toolpath  # noqa: F401
kernel = importlib.import_module("kernel_mod")
print("ready", flush=True)
while not os.path.exists("go"):
    time.sleep(0.01)
print(kernel.total(kernel.Pair(1.0, 2.0)), sum(kernel.total.stats.cache_misses.values()))
'''


@pytest.mark.skipif(fcntl is None, reason="no flock here: kernels compile unlocked")
def test_processes_starting_at_once_compile_a_kernel_once(tmp_path):
    import os
    import subprocess
    import sys

    (tmp_path / "kernel_mod.py").write_text(KERNEL_MODULE.replace("NAME", "Pair"),
                                            encoding="utf-8")
    root = Path(__file__).resolve().parents[2]
    env = {**os.environ, "PYTHONPATH": os.pathsep.join((str(tmp_path), str(root))),
           "NUMBA_CACHE_DIR": str(tmp_path / "cache")}
    runs = [subprocess.Popen([sys.executable, "-c", RACE_KERNEL], cwd=tmp_path, env=env,
                             stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
            for _ in range(2)]
    for run in runs:
        assert run.stdout.readline().strip() == "ready"
    (tmp_path / "go").touch()  # both call the kernel now, on an empty cache
    results = []
    for run in runs:
        out, err = run.communicate(timeout=120)
        assert run.returncode == 0, err
        results.append(out.split())
    # one compiled it, the other waited and loaded it
    assert sorted(results) == [["5.0", "0"], ["5.0", "1"]]


@pytest.mark.skipif(fcntl is None, reason="no flock here")
def test_a_lock_held_too_long_is_given_up_and_a_free_one_taken(tmp_path):
    path = tmp_path / "kernel.nbi.lock"
    holder = os.open(path, os.O_RDWR | os.O_CREAT)
    waiter = os.open(path, os.O_RDWR)
    try:
        fcntl.flock(holder, fcntl.LOCK_EX)
        assert _wait_for_lock(waiter, wait_s=0.2) is False  # compile unlocked, not hang
        fcntl.flock(holder, fcntl.LOCK_UN)
        assert _wait_for_lock(waiter, wait_s=0.2) is True
    finally:
        os.close(waiter)
        os.close(holder)


# Two kernels; the process prints each step. "ahead": calls ``first`` (whose lock the test
# holds) while ``working_while_waiting`` may compile ``second``; "free": compile_if_free of
# both, twice, and of ``first`` without waiting.
TWO_KERNELS = '''
import numba


@numba.njit(cache=True)
def first(x):
    return x + 1.0


@numba.njit(cache=True)
def second(x):
    return x * 2.0
'''

WHILE_WAITING = '''
import sys
from numba.core import types
from toolpath.kernel_cache import compile_if_free, working_while_waiting
import two_kernels

print(two_kernels.first._cache._cache_file._index_path + ".lock", flush=True)
sys.stdin.readline()  # (the test holds first's lock now)
left = [two_kernels.second]


def work():
    if not left:
        return False
    print(compile_if_free(left.pop(), (types.float64,)), "second", flush=True)
    return True


with working_while_waiting(work):
    print(two_kernels.first(1.0), flush=True)
print(sum(two_kernels.second.stats.cache_misses.values()), flush=True)
'''


def _waiting_for_first(tmp_path, kernels: str, script: str):
    """``script`` run in a process over the module ``kernels``, told to go on once this
    test holds the lock of its kernel ``first`` (as another process compiling it would);
    returns the process and the lock's handle (locked)."""
    import subprocess
    import sys

    (tmp_path / "two_kernels.py").write_text(kernels, encoding="utf-8")
    root = Path(__file__).resolve().parents[2]
    env = {**os.environ, "PYTHONPATH": os.pathsep.join((str(tmp_path), str(root))),
           "NUMBA_CACHE_DIR": str(tmp_path / "cache")}
    run = subprocess.Popen([sys.executable, "-c", script], cwd=tmp_path, env=env,
                           stdin=subprocess.PIPE, stdout=subprocess.PIPE, text=True)
    lock = os.open(run.stdout.readline().strip(), os.O_RDWR | os.O_CREAT)
    fcntl.flock(lock, fcntl.LOCK_EX)  # "another process" compiles first
    run.stdin.write("go\n")
    run.stdin.flush()
    return run, lock


@pytest.mark.skipif(fcntl is None, reason="no flock here")
def test_a_process_waiting_for_another_s_compile_compiles_its_next_kernel(tmp_path):
    run, lock = _waiting_for_first(tmp_path, TWO_KERNELS, WHILE_WAITING)
    try:
        # while it waits for first's lock, it compiles second
        assert run.stdout.readline().split() == ["compiled", "second"]
        fcntl.flock(lock, fcntl.LOCK_UN)
        out, _ = run.communicate(timeout=120)
    finally:
        os.close(lock)
    assert run.returncode == 0
    assert out.split() == ["2.0", "1"]  # then it compiled first itself; second once


# "nested": the waited-for kernel is called by one this process compiles (``outer``)
NESTED_KERNELS = TWO_KERNELS + '''

@numba.njit(cache=True)
def outer(x):
    return 3.0 * first(x)
'''

NESTED_WAIT = WHILE_WAITING.replace("two_kernels.first(1.0)", "two_kernels.outer(1.0)").replace(
    "print(sum(two_kernels.second.stats.cache_misses.values()), flush=True)",
    "print(len(left), flush=True)")


@pytest.mark.skipif(fcntl is None, reason="no flock here")
def test_a_wait_inside_another_kernel_s_compile_only_sleeps(tmp_path):
    """Work done there would run inside numba's compile of the outer kernel: a kernel
    reaching it would be typed as recursion and cached broken, and a lock held by another
    process could close a cycle."""
    run, lock = _waiting_for_first(tmp_path, NESTED_KERNELS, NESTED_WAIT)
    try:
        time.sleep(1.5)  # it compiles outer and waits for first (polled every 0.05 s)
        fcntl.flock(lock, fcntl.LOCK_UN)
        out, _ = run.communicate(timeout=120)
    finally:
        os.close(lock)
    assert run.returncode == 0
    assert out.split() == ["6.0", "1"]  # outer's value; second left alone

FREE = '''
import json, os, sys
from numba.core import types
from toolpath.kernel_cache import compile_if_free
import two_kernels

states = [compile_if_free(two_kernels.second, (types.float64,))]
lock = two_kernels.first._cache._cache_file._index_path + ".lock"
print(lock, flush=True)
sys.stdin.readline()  # (the test holds first's lock now)
states.append(compile_if_free(two_kernels.first, (types.float64,), wait=False))
print(json.dumps(states), flush=True)
'''


@pytest.mark.skipif(fcntl is None, reason="no flock here")
def test_compile_if_free_compiles_once_and_leaves_a_busy_kernel(tmp_path):
    import json
    import subprocess
    import sys

    (tmp_path / "two_kernels.py").write_text(TWO_KERNELS, encoding="utf-8")
    root = Path(__file__).resolve().parents[2]
    env = {**os.environ, "PYTHONPATH": os.pathsep.join((str(tmp_path), str(root))),
           "NUMBA_CACHE_DIR": str(tmp_path / "cache")}
    for expected in (["compiled", "busy"], ["cached", "busy"]):  # (second run: the cache)
        run = subprocess.Popen([sys.executable, "-c", FREE], cwd=tmp_path, env=env,
                               stdin=subprocess.PIPE, stdout=subprocess.PIPE, text=True)
        lock = os.open(run.stdout.readline().strip(), os.O_RDWR | os.O_CREAT)
        try:
            fcntl.flock(lock, fcntl.LOCK_EX)
            run.stdin.write("go\n")
            run.stdin.flush()
            out, _ = run.communicate(timeout=120)
        finally:
            os.close(lock)
        assert run.returncode == 0 and json.loads(out) == expected


# Two kernel modules of a package ``pkg``: ``caller`` calls ``callee``'s kernel, which reads
# a constant of ``consts`` (no kernels there). Run with the package as the only kernel
# package; prints the caller's result.
CALLEE = '''
import numba

from pkg.consts import SHARE


@numba.njit(cache=True)
def value():
    return VALUE + SHARE
'''
CALLER = '''
import numba

from pkg.callee import value


@numba.njit(cache=True)
def tenfold():
    return 10 * value()
'''
RUN_CALLER = '''
import sys
from pathlib import Path
import toolpath.kernel_cache as kc
kc.KERNEL_ROOT, kc.KERNEL_PACKAGES = Path(sys.argv[1]), ("pkg",)
from pkg.caller import tenfold
print(tenfold())
'''


def test_a_cached_kernel_runs_its_callee_s_new_code_after_an_edit(tmp_path):
    import subprocess
    import sys

    package = tmp_path / "pkg"
    package.mkdir()
    (package / "__init__.py").write_text("", encoding="utf-8")
    (package / "caller.py").write_text(CALLER, encoding="utf-8")
    root = Path(__file__).resolve().parents[2]
    env = {**os.environ, "PYTHONPATH": os.pathsep.join((str(tmp_path), str(root))),
           "NUMBA_CACHE_DIR": str(tmp_path / "cache")}

    def run() -> str:
        done = subprocess.run([sys.executable, "-c", RUN_CALLER, str(tmp_path)], cwd=tmp_path,
                              env=env, capture_output=True, text=True, timeout=120)
        assert done.returncode == 0, done.stderr
        return done.stdout.strip()

    for value, share in ((1, 0), (2, 0), (3, 0), (3, 1)):  # (numba alone kept 10 from its
        # cache after the callee changed; a constant's module has no kernel to stamp)
        (package / "consts.py").write_text(f"SHARE = {share}\n", encoding="utf-8")
        (package / "callee.py").write_text(CALLEE.replace("VALUE", str(value)),
                                           encoding="utf-8")
        assert run() == str(10 * (value + share))
        assert run() == str(10 * (value + share))  # (from the cache, still right)


#: How a module defines a compiled function: numba's decorators, called or bare.
KERNEL_DEFINED = re.compile(r"numba\.(njit|jit|vectorize|guvectorize|cfunc|generated_jit)\b"
                            r"|^\s*@(njit|jit|vectorize|guvectorize|cfunc)\b", re.M)


def test_every_module_with_kernels_is_in_a_kernel_package():
    from toolpath import kernel_cache

    root = kernel_cache.KERNEL_ROOT
    packages = {path.parent.name for path in root.glob("*/__init__.py")}
    with_kernels = {path.relative_to(root).parts[0]
                    for package in packages for path in (root / package).rglob("*.py")
                    if KERNEL_DEFINED.search(path.read_text(encoding="utf-8", errors="replace"))}
    assert with_kernels and with_kernels <= set(kernel_cache.KERNEL_PACKAGES)
