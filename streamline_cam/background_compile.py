"""A cold job's kernels compiled in helper processes while it runs (issue 27).

The first job after an install compiles every kernel it calls (numba, ``cache=True``), one
after the other, on one core: the fit's, then the planner's stage by stage, the post's,
the check's, the verifier's. On a cold kernel cache, :func:`background_compile` starts
helper processes at the beginning of the job (one per usable core but the job's) that
compile the same kernels for the same argument types into the cache while the job
compiles its own from the first stage on. The processes share the list instead of waiting
for each other (:func:`toolpath.kernel_cache.compile_if_free`): a helper starts half way
into it (:func:`helper_order`), goes on to the end, then back from half way, and skips a
kernel the cache holds or another process compiles; the job loads what a helper compiled,
and when it calls a kernel a helper compiles at that moment, it compiles the next free
kernel of its own meanwhile (:func:`work_ahead`) instead of waiting idle.

The helpers need each kernel's argument types before the job has made its arguments: they
are recorded from real jobs in ``data/job_kernels.json`` (:data:`KERNELS_FILE`), per axis
mode and job stage, in the order the jobs first call them (``python -m
streamline_cam.background_compile --record FILE`` writes it; a test checks it is current).

Not needed for correctness: a kernel no helper reached, or whose recorded types no longer
match, compiles in the job as before; a helper that fails or is slow changes only the
time. The helpers stop with the job (on an error or Ctrl-C too), and by themselves when the
job's process is gone (their standard input closes). They start only when the kernel cache
misses one of the job's kernels and the process may use more than one core, and only for
the ``toolpath plan`` and ``toolpath run`` commands: a warm job, a service worker or a
batch worker never starts one. ``TOOLPATH_BACKGROUND_COMPILE=0`` turns them off.
"""

from __future__ import annotations

import contextlib
import importlib
import json
import os
import subprocess
import sys
import threading
from collections.abc import Callable, Iterable, Iterator, Mapping, Sequence
from pathlib import Path
from typing import Any, Final, NamedTuple

__all__ = ["COARSE", "CORNER_JOBS", "ENV_SWITCH", "KERNELS_FILE", "MAX_HELPERS", "Kernel",
           "RecordedJob", "background_compile", "cache_is_cold", "compile_kernel",
           "compile_kernels", "cutter_kind", "decode_type", "encode_type", "helper_order",
           "job_kernels", "record_job_kernels", "recorded_jobs", "recorded_kernels",
           "say_on_stderr", "usable_cores", "work_ahead"]

#: The recorded kernels and argument types of the jobs (see the module's text).
KERNELS_FILE: Final = Path(__file__).resolve().parent / "data" / "job_kernels.json"
#: Environment variable: ``0`` (or ``off``, ``no``, ``false``) turns the helper off.
ENV_SWITCH: Final = "TOOLPATH_BACKGROUND_COMPILE"
#: Packages whose kernels are recorded.
OUR_PACKAGES: Final = ("toolpath", "verification", "gcode", "machines", "streamline_cam")
#: The helper's module, run with ``python -m``.
HELPER_MODULE: Final = "streamline_cam.background_compile"
#: The argument that makes the module the helper (anything else is refused with usage).
HELPER_FLAG: Final = "--helper"
#: Seconds the job waits for a stopped helper to end before it kills it.
STOP_WAIT_S: Final = 5.0


class Kernel(NamedTuple):
    """One recorded kernel call: where the kernel lives and its argument types (JSON form)."""

    module: str
    name: str
    args: tuple[Any, ...]
    stage: str

    def as_json(self) -> dict[str, Any]:
        """The kernel as a JSON object."""
        return {"module": self.module, "name": self.name, "stage": self.stage,
                "args": list(self.args)}

    @classmethod
    def from_json(cls, entry: Mapping[str, Any]) -> Kernel:
        """The kernel of an :meth:`as_json` object (KeyError, TypeError if malformed)."""
        return cls(entry["module"], entry["name"], tuple(entry["args"]), entry["stage"])


# -- argument types <-> JSON ---------------------------------------------------------------

def encode_type(kind: Any) -> Any:
    """A numba argument type as JSON: a scalar's name, an array, a (named) tuple.

    Raises ValueError for other types (such a kernel is not recorded).
    """
    from numba.core import types

    if isinstance(kind, types.Array) and isinstance(kind.dtype, (types.Number, types.Boolean)):
        return {"array": str(kind.dtype), "ndim": kind.ndim, "layout": kind.layout,
                "readonly": not kind.mutable}
    if isinstance(kind, types.BaseTuple):
        entry: dict[str, Any] = {"tuple": [encode_type(item) for item in kind.types]}
        cls = getattr(kind, "instance_class", tuple)
        if cls is not tuple:
            entry["class"] = f"{cls.__module__}:{cls.__qualname__}"
        return entry
    if isinstance(kind, (types.Integer, types.Float, types.Boolean)):
        return str(kind)
    raise ValueError(f"argument type {kind} is not recorded")


def _scalar(name: str) -> Any:
    from numba.core import types

    kind = types.boolean if name == "bool" else getattr(types, name, None)
    if not isinstance(kind, (types.Integer, types.Float, types.Boolean)):
        raise ValueError(f"unknown scalar type {name!r}")
    return kind


def _named(path: str) -> Any:
    """The object ``module:qualname`` (a record class, a kernel)."""
    module, _, qualname = path.partition(":")
    found: Any = importlib.import_module(module)
    for part in qualname.split("."):
        found = getattr(found, part)
    return found


def decode_type(entry: Any) -> Any:
    """The numba type of an :func:`encode_type` entry (ValueError, ImportError if stale)."""
    from numba.core import types

    if isinstance(entry, str):
        return _scalar(entry)
    if "array" in entry:
        return types.Array(_scalar(entry["array"]), entry["ndim"], entry["layout"],
                           readonly=entry["readonly"])
    items = [decode_type(item) for item in entry["tuple"]]
    cls = _named(entry["class"]) if "class" in entry else None
    return types.BaseTuple.from_types(items, cls)


def _dispatcher(kernel: Kernel) -> Any:
    """The kernel's numba dispatcher (ImportError, AttributeError if gone)."""
    found = _named(f"{kernel.module}:{kernel.name}")
    if not hasattr(found, "compile") or not hasattr(found, "py_func"):
        raise AttributeError(f"{kernel.module}.{kernel.name} is not a compiled kernel")
    return found


# -- the recorded jobs ----------------------------------------------------------------------

def job_kernels(axis_mode: str, stages: Sequence[str], cutter: str = "ball",
                path: Path = KERNELS_FILE) -> list[Kernel]:
    """The recorded kernels of a job in ``axis_mode`` reached in ``stages``, in call order.

    ``stages`` in the order the job reaches them. ``cutter``: the job's cutter spec
    (``ball:6``, ``bull:10:2``); a flat or bull-nose job's list adds the
    :data:`CORNER_JOBS`' kernels its axis mode's ball-nose jobs do not call, stage by
    stage. Empty when the file is missing or unreadable, or the axis mode is not recorded.
    """
    try:
        jobs = json.loads(path.read_text(encoding="utf-8"))["jobs"]
        recorded = list(jobs[axis_mode])
        if cutter_kind(cutter) != "ball":
            recorded += jobs.get(CORNER_JOBS, [])
    except (OSError, ValueError, KeyError, TypeError):
        return []
    kernels = _each_once(entry for entry in recorded if entry["stage"] in stages)
    order = list(stages)  # (the job's order)
    return sorted(kernels, key=lambda kernel: order.index(kernel.stage))


def cutter_kind(spec: str) -> str:
    """The kind of a cutter spec, ``ball``, ``flat`` or ``bull`` (its first field, lower case).

    Read without the planner's modules (the job parses and checks the spec itself).
    """
    return spec.strip().split(":", 1)[0].strip().lower()


def recorded_kernels(path: Path = KERNELS_FILE) -> list[Kernel]:
    """Every recorded kernel of every kind of job once, stage by stage (for the warm-up).

    Stages in the order the jobs reach them; within one, the first kind's call order.
    Empty when the file is missing or unreadable.
    """
    try:
        jobs = json.loads(path.read_text(encoding="utf-8"))["jobs"]
    except (OSError, ValueError, KeyError, TypeError):
        return []
    kernels = _each_once(entry for recorded in jobs.values() for entry in recorded)
    stages = list(dict.fromkeys(kernel.stage for kernel in kernels))
    return sorted(kernels, key=lambda kernel: stages.index(kernel.stage))


def _each_once(entries: Iterable[Mapping[str, Any]]) -> list[Kernel]:
    """The recorded kernels of ``entries`` (JSON objects), each kernel and types once.

    In the order of their first entry; a later entry of the same kernel and argument types
    (another kind of job's, another stage's) is left out.
    """
    kernels: dict[tuple[str, str, str], Kernel] = {}
    for entry in entries:
        kernel = Kernel.from_json(entry)
        kernels.setdefault((kernel.module, kernel.name, json.dumps(kernel.args)), kernel)
    return list(kernels.values())


def cache_is_cold(kernels: Sequence[Kernel]) -> bool:
    """Whether the kernel cache lacks one of ``kernels`` (or holds it for an older source).

    Reads only whether each kernel's cache index exists and is newer than its source (the
    index lists the compiled signatures; it is written after the source it was made from).
    A kernel that cannot be found counts as present (nothing to compile ahead for it).
    """
    for kernel in kernels:
        try:
            dispatcher = _dispatcher(kernel)
        except (ImportError, AttributeError):
            continue
        index = getattr(getattr(dispatcher._cache, "_cache_file", None), "_index_path", None)
        if index is None:
            continue
        try:
            source = os.stat(dispatcher.py_func.__code__.co_filename).st_mtime
            if os.stat(index).st_mtime < source:
                return True
        except FileNotFoundError:
            return True
        except OSError:
            continue
    return False


def compile_kernel(kernel: Kernel, *, wait: bool = True) -> str:
    """Compile ``kernel`` into the kernel cache unless it is there; what was done.

    :func:`toolpath.kernel_cache.compile_if_free`'s answer: ``"cached"`` (not loaded),
    ``"compiled"``, or with ``wait=False`` ``"busy"`` (another process compiles it now).
    Raises ImportError, AttributeError for a kernel that is gone, ValueError for a stale
    record, numba's errors for a failed compile.
    """
    from toolpath.kernel_cache import compile_if_free

    dispatcher = _dispatcher(kernel)
    return compile_if_free(dispatcher, tuple(decode_type(arg) for arg in kernel.args),
                           wait=wait)


def compile_kernels(kernels: Sequence[Kernel]) -> int:
    """Compile ``kernels`` into the kernel cache here, in this order; returns how many.

    A kernel the cache holds already is skipped (not loaded), and so is one another
    process compiles at the moment (the job, or a second helper: each takes the next
    kernel nobody has). While a compile here waits for another process's compile of a
    kernel it calls, the next free kernel compiles meanwhile (:func:`work_ahead`). A kernel
    that is gone, has a stale record, or fails to compile is skipped too: the job compiles
    it when it calls it.
    """
    from toolpath.kernel_cache import working_while_waiting

    compile_next, done = work_ahead(kernels), 0
    with working_while_waiting(compile_next):
        while compile_next():
            done += 1
    return done


def helper_order(kernels: Sequence[Kernel], helper: int = 0, helpers: int = 1
                 ) -> list[Kernel]:
    """The order in which helper ``helper`` (of ``helpers``) takes a job's ``kernels``.

    From its own share's start on to the last kernel, then from that start back to the
    first: helper ``i`` starts ``(i + 1) / (helpers + 1)`` of the way into the list (one
    helper: half way). The job compiles from the first kernel on as it calls them, so
    each process first takes kernels nobody else will need before it; a process that
    runs out of its share takes the next free kernel of another's (the first the job will
    call among those left, or the last the job reaches before the helper's start).
    """
    start = len(kernels) * (helper + 1) // (helpers + 1)
    return [*kernels[start:], *reversed(kernels[:start])]


def work_ahead(kernels: Sequence[Kernel]) -> Callable[[], bool]:
    """A process's work while it waits for another's compile: its next free kernel.

    Each call compiles the first of ``kernels`` not taken yet that neither this process
    nor the cache has and no other process compiles now; False when none is left. (The
    job's, in call order; a helper's, in its :func:`helper_order`.)
    """
    left = list(kernels)

    def compile_next() -> bool:
        while left:
            try:
                if compile_kernel(left.pop(0), wait=False) == "compiled":
                    return True
            except Exception:  # (the job compiles it when it calls it, and reports why)
                continue
        return False

    return compile_next


def say_on_stderr(text: str) -> None:
    """Print ``text`` on standard error (a command's note that the helper started)."""
    print(text, file=sys.stderr, flush=True)


#: cgroup v2 file of the CPU quota (``max`` or ``QUOTA PERIOD`` in microseconds).
CGROUP_CPU_MAX: Final = Path("/sys/fs/cgroup/cpu.max")


def usable_cores() -> int:
    """The cores this process may use (one core: a helper would only take turns).

    The smaller of the CPU affinity and a container's CPU quota (``docker --cpus=1`` leaves
    every host core in the affinity but gives one core's time).
    """
    cores = len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else (
        os.cpu_count() or 1)
    with contextlib.suppress(OSError, ValueError):
        quota, period = CGROUP_CPU_MAX.read_text().split()[:2]
        if quota != "max":
            cores = min(cores, max(1, int(int(quota) / int(period))))
    return cores


def _switched_off(environ: Mapping[str, str]) -> bool:
    return environ.get(ENV_SWITCH, "").strip().lower() in ("0", "off", "no", "false")


#: At most this many helper processes: a job's 30-40 recorded kernels keep four processes
#: busy to the end, while each process loads numba and the kernels' modules (a few hundred
#: MB): on a many-core machine more would cost memory, not time.
MAX_HELPERS = 3


@contextlib.contextmanager
def background_compile(kernels: Sequence[Kernel], say: Callable[[str], None] | None = None
                       ) -> Iterator[list[subprocess.Popen]]:
    """Around a job: on a cold cache, helper processes compiling the job's ``kernels``.

    One helper per usable core but the job's (:func:`usable_cores`), at most
    :data:`MAX_HELPERS` and one per kernel, each taking the kernels in its
    :func:`helper_order`; they and the job share the list (none compiles a kernel another
    does, see the module's text). Yields the helper processes: none on a warm cache, with
    nothing recorded, on one core, with ``TOOLPATH_BACKGROUND_COMPILE=0``, or when no
    process could start. ``say`` gets one line
    when they start. On leaving (an error and Ctrl-C too) the helpers are stopped and
    waited for.
    """
    helpers: list[subprocess.Popen] = []
    count = min(usable_cores() - 1, MAX_HELPERS, len(kernels))
    if count > 0 and not _switched_off(os.environ) and cache_is_cold(kernels):
        helpers = [helper for helper in (_start_helper(helper_order(kernels, i, count))
                                         for i in range(count)) if helper is not None]
        if helpers and say is not None:
            what = "a second process" if len(helpers) == 1 else f"{len(helpers)} more processes"
            say(f"toolpath: the kernel cache lacks this job's kernels: compiling them in "
                f"{what} too ({ENV_SWITCH}=0 turns it off)")
    meanwhile: contextlib.AbstractContextManager = contextlib.nullcontext()
    if helpers:  # (the job compiles its next free kernel while it waits for a helper's)
        from toolpath.kernel_cache import working_while_waiting

        meanwhile = working_while_waiting(work_ahead(kernels))
    try:
        with meanwhile:
            yield helpers
    finally:
        for helper in helpers:
            _stop_helper(helper)


def _start_helper(kernels: Sequence[Kernel]) -> subprocess.Popen | None:
    """Start ``python -m streamline_cam.background_compile`` with ``kernels`` on its stdin."""
    env = {**os.environ, "NUMBA_NUM_THREADS": "1", ENV_SWITCH: "0"}
    try:
        helper = subprocess.Popen(
            [sys.executable, "-m", HELPER_MODULE, HELPER_FLAG], stdin=subprocess.PIPE,
            stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, env=env,
            start_new_session=True)  # (Ctrl-C goes to the job, which stops the helper)
    except OSError:  # (no process could start: the job goes on alone)
        return None
    try:
        assert helper.stdin is not None
        helper.stdin.write(json.dumps([k.as_json() for k in kernels]).encode() + b"\n")
        helper.stdin.flush()
    except OSError:  # (it died at once)
        _stop_helper(helper)
        return None
    return helper


def _stop_helper(helper: subprocess.Popen) -> None:
    """End the helper: close its stdin, terminate it, kill it if it does not end."""
    with contextlib.suppress(OSError):
        if helper.stdin is not None:
            helper.stdin.close()
    if helper.poll() is None:
        helper.terminate()
        try:
            helper.wait(timeout=STOP_WAIT_S)
        except subprocess.TimeoutExpired:
            helper.kill()
            helper.wait()


def _helper_main() -> int:
    """The helper process: kernels from stdin's first line, compiled; exits on stdin's EOF."""
    line = sys.stdin.buffer.readline()

    def exit_when_the_job_is_gone() -> None:
        # (the file descriptor, not sys.stdin: a daemon thread holding the buffer's lock
        # would abort the interpreter's shutdown)
        while os.read(sys.stdin.fileno(), 4096):  # (b"" when the job closes it or ends)
            pass
        os._exit(0)

    threading.Thread(target=exit_when_the_job_is_gone, daemon=True).start()
    import toolpath  # noqa: F401  (the kernel cache's folder and lock, before numba loads)

    try:
        kernels = [Kernel.from_json(k) for k in json.loads(line)]
    except (ValueError, KeyError, TypeError):
        return 2
    compile_kernels(kernels)
    return 0


# -- recording ------------------------------------------------------------------------------

class RecordedJob(NamedTuple):
    """A recorded job: a bundled blade, the machine and cutter it is cut with, its axis mode."""

    blade: str
    machine: str
    axis_mode: str
    cutter: str = "ball:6"


#: The kind of recorded jobs whose kernels a flat or bull-nose job adds to its axis mode's.
CORNER_JOBS: Final = "flat-bull"

#: The recorded jobs per kind, coarse (:data:`COARSE`) and verified: the axis modes'
#: ball-nose jobs on the open development blade and the closed propeller blade (both kinds
#: of section reach their kernels), and a bull-nose job (:data:`CORNER_JOBS`) for the flat
#: and bull-nose cutters' kernels: the torus contact and envelope, the swept-cutter search
#: of the planner and of the verifier (a flat cutter calls some of them). The bull-nose job
#: is 3-axis: a 5-axis one's verification refines with the fine model, about a minute on
#: these blades, which the test that the recording is current would re-run. The one kernel
#: only that refinement calls (``sweep_below._mark``) compiles at its first use.
RECORDED_JOBS: Final = {
    "3": (RecordedJob("dev_blade_15x142.csv", "grbl-router", "3"),),
    "lead-tilt": (RecordedJob("dev_blade_15x142.csv", "trunnion-ac", "lead-tilt"),
                  RecordedJob("dev_prop_7x100.csv", "trunnion-ac", "lead-tilt")),
    CORNER_JOBS: (RecordedJob("dev_blade_15x142.csv", "grbl-router", "3", "bull:8:1"),),
}

#: The recorded jobs' settings: the kernels matter here, not the figures.
COARSE: Final = {"scallop_mm": 0.05, "chord_tol_mm": 0.02}


@contextlib.contextmanager
def _calls_from_python(stage: list[str]) -> Iterator[list[Kernel]]:
    """Record each cached kernel of ours the first time Python calls it (with its types).

    Only first calls in this process are seen: run in a fresh process.
    """
    from numba.core import dispatcher, sigutils

    compile_ = dispatcher.Dispatcher.compile
    calls: list[Kernel] = []
    seen: set[tuple[str, str, str]] = set()
    depth = threading.local()  # calls made while compiling another kernel are not first calls

    def compile(self: Any, sig: Any) -> Any:
        func = self.py_func
        level = getattr(depth, "level", 0)
        if level == 0 and func.__module__.split(".")[0] in OUR_PACKAGES \
                and getattr(self._cache, "_cache_file", None) is not None:
            args, _ = sigutils.normalize_signature(sig)
            with contextlib.suppress(ValueError):
                encoded = tuple(encode_type(arg) for arg in args)
                key = (func.__module__, func.__qualname__, json.dumps(encoded))
                if key not in seen:
                    seen.add(key)
                    calls.append(Kernel(func.__module__, func.__qualname__, encoded, stage[0]))
        depth.level = level + 1
        try:
            return compile_(self, sig)
        finally:
            depth.level = level

    dispatcher.Dispatcher.compile = compile
    try:
        yield calls
    finally:
        dispatcher.Dispatcher.compile = compile_


def record_job_kernels(kind: str) -> list[Kernel]:
    """Run the :data:`RECORDED_JOBS` of ``kind`` here and record their kernels.

    In a fresh process (kernels called before are not seen): in the order the jobs first
    call them, each with the job stage that did; a later job adds only what is new.
    """
    import tempfile
    import warnings

    import toolpath  # noqa: F401  (the kernel cache's hook first)
    from toolpath.paper_examples import bundled_data_path

    from .pipeline import STAGES, JobRequest, run_job

    stage = ["fit"]

    def progress(name: str, _fraction: float) -> None:
        stage[0] = name

    with _calls_from_python(stage) as calls, \
            tempfile.TemporaryDirectory(prefix="toolpath-record-") as folder:
        for job in RECORDED_JOBS[kind]:
            request = JobRequest(bundled_data_path(job.blade), machine=job.machine,
                                 axis_mode=job.axis_mode, cutter=job.cutter, **COARSE)
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                run_job(request, Path(folder) / job.blade, progress=progress, verify=True)
    return sorted(calls, key=lambda kernel: STAGES.index(kernel.stage))  # (stable)


def recorded_jobs() -> dict[str, Any]:
    """:data:`KERNELS_FILE`'s content as recorded now: each kind of job in a fresh process."""
    import numba

    jobs = {}
    for kind in RECORDED_JOBS:
        command = [sys.executable, "-m", HELPER_MODULE, "--record-mode", kind]
        done = subprocess.run(command, capture_output=True, text=True, timeout=1200)
        if done.returncode != 0:
            raise RuntimeError(f"recording the {kind!r} jobs' kernels failed "
                               f"(exit {done.returncode}): {' '.join(command[1:])}\n"
                               f"{done.stderr[-3000:]}")
        jobs[kind] = json.loads(done.stdout)
    return {"numba": numba.__version__,
            "note": "python -m streamline_cam.background_compile --record FILE writes it",
            "jobs": jobs}


def _record_main(argv: list[str]) -> int:
    """``--record FILE``: write :func:`recorded_jobs`; ``--record-mode KIND``: print one."""
    if argv[0] == "--record-mode":
        print(json.dumps([k.as_json() for k in record_job_kernels(argv[1])]))
        return 0
    data = recorded_jobs()
    Path(argv[1]).write_text(json.dumps(data, indent=1) + "\n", encoding="utf-8")
    print(f"wrote {argv[1]}: " + ", ".join(f"{mode} {len(kernels)} kernels"
                                          for mode, kernels in data["jobs"].items()))
    return 0


USAGE: Final = (f"usage: python -m {HELPER_MODULE} --record FILE | --record-mode KIND\n"
                "(the job starts the helper itself)")

if __name__ == "__main__":
    if sys.argv[1:] == [HELPER_FLAG]:
        sys.exit(_helper_main())
    if sys.argv[1:2] in (["--record"], ["--record-mode"]) and len(sys.argv) == 3:
        sys.exit(_record_main(sys.argv[1:]))
    print(USAGE, file=sys.stderr)
    sys.exit(2)
