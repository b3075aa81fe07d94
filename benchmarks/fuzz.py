"""Fuzz the G-code parser, the fitters and the ``toolpath`` command line (issue 26).

Run:  python benchmarks/fuzz.py [--seconds 300] [--seed 1] [--targets parser,fitters,cli]

Each target gets an equal share of ``--seconds``. Cases come from a seeded generator (the
same seed gives the same sequence of cases) and run in a child process (``spawn``) that
acknowledges each case before running it; the parent kills the child when a case runs past
the target's time-out (a **hang**: the case is printed as a reproducer) and starts a new
one. A **crash** is any outcome but the target's contract:

* parser: ``gcode.parse(line, dialect)`` returns a program or raises ``GCodeError``
  (public API only: random lines mutated from typical blocks, digit runs, huge numbers,
  comments, bad characters);
* fitters: ``fit_streamline_curve``, ``fit_bspline_curve`` and the two surface fitters
  return a fit or raise ``ToolpathError`` (random point sets: NaN/inf, duplicates, int
  dtype, one to three points, huge and tiny scales, random order, random options);
* cli: ``streamline_cam.cli.main(argv)`` on random argv built from the real commands and
  flags and on bad files exits 0, 1 or 2 with no traceback on stderr.

Prints per target the cases tried, crashes and hangs, each with a reproducer (the first
crash of each kind shrunk by delta debugging: parts of the line or argv dropped while it
still fails alike), and a summary line; exit status 1 when anything crashed or hung.
``tests/test_issue_26_fuzz.py`` runs a few seconds of the same generators in CI.
"""

from __future__ import annotations

import argparse
import atexit
import contextlib
import io
import json
import math
import multiprocessing
import os
import shutil
import sys
import tempfile
import time
import traceback
from collections.abc import Callable, Iterator
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

ROOT = Path(__file__).resolve().parents[1]

# ---------------------------------------------------------------------------- parser cases

DIALECTS = ("generic", "grbl", "linuxcnc", "fanuc")
SEED_LINES = (
    "G21 G90 G94", "G0 X10 Y20 Z5", "G1 X-1.5 Y2.25 Z0.001 F800", "G2 X10 Y0 I5 J0 F300",
    "G3 X0 Y10 R5", "G93 G1 X1 A10 C-20 F12.5", "N10 G1 X1 (comment) Y2", "M3 S12000",
    "T2 M6", "G4 P0.5", "G17 G20 G91.1", "G1 X1 ; tail comment", "%", "(only a comment)",
    "G54 G0 X0 Y0", "M30", "G1 X1 Y2 Z3 A4 B5 C6 F100", "G9(c)4 G1 X1 F10", "G92 X0",
    "/G1 X5 F100", "G0 Z.5", "G1 X+1. Y-.5 F1e3", "M8 M9", "G28", "G1 F0",
)
ALPHABET = "GXYZABCIJKFRPNMSTgxyz0123456789.-+ ()[];%!#=*/\t$\x00\x7fé\n"


def parser_case(rng: np.random.Generator, *, hostile: bool = True) -> tuple[str, str]:
    """``(dialect name, line)``: a typical block mutated a few times.

    ``hostile=False`` keeps numbers within float range and digit runs short (no
    backtracking bait): what a parser must take at any speed.
    """
    longest, exponents = (40, [20, 300, 320, 400]) if hostile else (8, [5, 20])
    line = str(rng.choice(SEED_LINES))
    for _ in range(int(rng.integers(0, 6))):
        op = int(rng.integers(0, 7))
        at = int(rng.integers(0, len(line) + 1))
        if op == 0:  # insert a character
            line = line[:at] + str(rng.choice(list(ALPHABET))) + line[at:]
        elif op == 1 and line:  # delete one
            line = line[:at] + line[at + 1:]
        elif op == 2:  # a run of digits (long numbers, backtracking bait)
            digits = "".join(str(d) for d in rng.integers(0, 10, int(rng.integers(1, longest))))
            line = line[:at] + digits + line[at:]
        elif op == 3:  # a word with a huge or tiny number
            exponent = int(rng.choice(exponents))
            number = "1" + "0" * exponent if rng.random() < 0.5 else "0." + "0" * exponent + "1"
            line = line[:at] + str(rng.choice(list("GXNTFRS"))) + number + line[at:]
        elif op == 4:  # several words of digits and a bad character at the end
            words = int(rng.integers(2, 8 if hostile else 4))
            width = int(rng.integers(2, 9 if hostile else 4))
            line = " ".join(f"X{'7' * width}" for _ in range(words)) + "!"
        elif op == 5 and line:  # repeat a span
            end = int(rng.integers(at, len(line) + 1))
            line = line[:at] + line[at:end] * int(rng.integers(2, 5)) + line[end:]
        else:  # an unclosed or nested comment
            line = line[:at] + str(rng.choice(["(", ")", "((", "(a(b)c)", ";"])) + line[at:]
    return str(rng.choice(DIALECTS)), line


def run_parser_case(case: tuple[str, str]) -> None:
    """Parse the line; only ``GCodeError`` may come out."""
    from gcode import parse
    from gcode.dialects import dialect_by_name
    from gcode.errors import GCodeError

    name, line = case
    with contextlib.suppress(GCodeError):
        parse(line, dialect_by_name(name))


def parser_reproducer(case: tuple[str, str]) -> str:
    name, line = case
    return f"gcode.parse({line!r}, gcode.dialects.dialect_by_name({name!r}))"


# ---------------------------------------------------------------------------- fitter cases

FITTERS = ("fit_streamline_curve", "fit_bspline_curve", "fit_streamline_surface",
           "fit_bspline_surface")


def _curve(rng: np.random.Generator, n: int, dim: int) -> np.ndarray:
    t = np.linspace(0.0, 1.0, n)
    shape = int(rng.choice(5, p=[0.3, 0.15, 0.25, 0.05, 0.25]))
    if shape == 0:  # an arc
        a = 0.3 + 2.0 * t
        pts = np.c_[30 * np.cos(a), 30 * np.sin(a), 5 * t]
    elif shape == 1:  # a straight line
        pts = np.c_[t, 2 * t, -t] * 40
    elif shape == 2:  # a random walk
        pts = np.cumsum(rng.normal(size=(n, 3)), axis=0)
    elif shape == 3:  # one point repeated
        pts = np.tile(rng.normal(size=3), (n, 1))
    else:  # a closed loop
        a = 2 * np.pi * t
        pts = np.c_[20 * np.cos(a), 8 * np.sin(a), np.zeros(n)]
    return pts[:, :dim]


def _spoil(rng: np.random.Generator, pts: np.ndarray) -> np.ndarray:
    """One or two of: scale, duplicates, NaN/inf, shuffled order, an outlier, int dtype."""
    flat = pts.reshape(-1, pts.shape[-1]).copy()
    for how in np.sort(rng.choice(6, size=int(rng.integers(1, 3)), replace=False)):
        if how == 0:
            flat = flat * 10.0 ** rng.uniform(-9, 9)
        elif how == 1 and len(flat):
            flat[rng.integers(len(flat)), rng.integers(flat.shape[1])] = rng.choice(
                [np.nan, np.inf, -np.inf])
        elif how == 2 and len(flat) > 1:
            i = int(rng.integers(len(flat) - 1))
            flat[i + 1] = flat[i]
        elif how == 3:
            rng.shuffle(flat)
        elif how == 4 and len(flat):
            flat[rng.integers(len(flat))] += rng.normal(size=flat.shape[1]) * 1e3
        elif how == 5 and np.isfinite(flat).all():
            flat = np.round(flat).astype(int)
    return flat.reshape(pts.shape)


def _options(rng: np.random.Generator) -> dict[str, Any]:
    """A tolerance, a count, a bound or a closure; bad values a quarter of the time."""
    bad = rng.random() < 0.25
    kind = int(rng.integers(0, 4))
    if kind == 0:
        good_tols, bad_tols = [1e-6, 1e-3, 0.01, 0.1, 1.0, 1e6], [0.0, -1.0, np.nan, np.inf]
        return {"tol": float(rng.choice(bad_tols if bad else good_tols))}
    if kind == 1:
        return {"n_control_points": int(rng.choice([-1, 0, 1, 3, 10**6] if bad
                                                   else [4, 5, 7, 12, 25]))}
    if kind == 2:
        return {"tol": 0.01, "max_control_points": int(rng.choice([0, 1, 3] if bad
                                                                  else [4, 6, 12]))}
    return {"tol": 0.01, "closed": bool(rng.random() < 0.5)}


def fitter_case(rng: np.random.Generator) -> dict[str, Any]:
    """``{"fitter", "points", "options"}``; points a nested list (ragged sections too)."""
    fitter = str(rng.choice(FITTERS))
    few = rng.random() < 0.2  # fewer points (or sections) than a cubic needs
    n = int(rng.choice([0, 1, 2, 3] if few else [4, 5, 8, 20, 40, 60]))
    if fitter.endswith("curve"):
        points: Any = _curve(rng, n, int(rng.choice([2, 3, 3])))
        points = (_spoil(rng, points) if rng.random() < 0.6 else points).tolist()
    else:
        m = int(rng.choice([1, 2, 3] if rng.random() < 0.2 else [4, 5, 6, 7]))
        base = _curve(rng, max(n, 1), 3)
        lifts = [np.array([0.0, 0.0, 10.0 * j]) for j in range(m)]
        sections = [_spoil(rng, base + lift) if rng.random() < 0.2 else base + lift
                    for lift in lifts]
        if rng.random() < 0.15 and m > 1:  # ragged: one section shorter
            sections[int(rng.integers(m))] = sections[0][: max(1, n // 2)]
        points = [s.tolist() for s in sections]
    options = _options(rng)
    if fitter.endswith("surface"):
        options.pop("max_control_points", None)
        if rng.random() < 0.5:
            options["closed"] = options.get("closed", None)
    return {"fitter": fitter, "points": points, "options": options}


def run_fitter_case(case: dict[str, Any]) -> None:
    """Fit; only ``ToolpathError`` may come out."""
    import toolpath
    from toolpath.errors import ToolpathError

    fitter = getattr(toolpath, case["fitter"])
    points = case["points"]
    array: Any = points
    if case["fitter"].endswith("curve") or _rectangular(points):
        array = np.asarray(points)
    with contextlib.suppress(ToolpathError):
        fitter(array, **case["options"])


def _rectangular(points: list) -> bool:
    return len({len(s) for s in points}) <= 1


def _literal(value: Any) -> str:
    """A Python literal for nested lists of numbers with NaN/inf spelled out."""
    if isinstance(value, list):
        return "[" + ", ".join(_literal(v) for v in value) + "]"
    if isinstance(value, float) and not math.isfinite(value):
        return f"float({str(value)!r})"
    return repr(value)


def fitter_reproducer(case: dict[str, Any]) -> str:
    options = ", ".join(f"{k}={_literal(v)}" for k, v in case["options"].items())
    return (f"toolpath.{case['fitter']}(numpy.asarray({_literal(case['points'])}), "
            f"{options})")


# ---------------------------------------------------------------------------- CLI cases

#: Commands and the flags they take with candidate values (``{name}`` names a fuzz file).
CLI_COMMANDS: dict[tuple[str, ...], dict[str, list[str | None]]] = {
    ("fit", "curve"): {"": ["{curve}", "{sections}", "{binary}", "{empty}", "{nan}",
                            "{missing}", "{one_point}", "{huge}"],
                       "--tol": ["0.01", "0", "-1", "nan", "inf", "x", "1e300"],
                       "--method": ["streamline", "bspline", "P0", "P2", "nope"],
                       "--closed": [None], "--open": [None], "--json": [None],
                       "-o": ["{out}/c.json", "{missing}/c.json", "{binary}/c.json", "{out}"],
                       "--plot": ["{missing}/c.png"]},
    ("fit", "surface"): {"": ["{sections}", "{three}", "{binary}", "{empty}", "{nan}",
                              "{curve}", "{ragged}", "{huge}"],
                         "--tol": ["0.01", "0", "-5", "nan", "1e-12"],
                         "--method": ["streamline", "bspline", "zz"],
                         "--closed": [None], "--open": [None], "--json": [None],
                         "-o": ["{missing}/s.json", "{binary}/s.json", "{out}"],
                         "--plot": ["{missing}/s.png"]},
    ("plan",): {"": ["{binary}", "{empty}", "{json_list}", "{json_bad}", "{missing}",
                     "{npz}"],
                "--machine": ["grbl-router", "trunnion-ac", "nope", "{binary}"],
                "--cutter": ["ball:6", "flat:0", "bull:6:9", "x"],
                "--scallop": ["0", "-1", "nan", "0.05"], "--axis": ["3", "lead-tilt"],
                "--fixed-axis": ["0,0,1", "0,0,0", "a,b", "nan,0,1"],
                "--rotate": ["y:-90", "q:1", "y:x"], "--translate": ["1,2", "1,2,inf"],
                "-o": ["{missing}/p.npz", "{binary}/p.npz"], "--json": [None]},
    ("post",): {"": ["{binary}", "{npz}", "{empty}", "{json_list}", "{missing}", "{zip}"],
                "--machine": ["grbl-router", "trunnion-ac", "nope"],
                "--dialect": ["grbl", "fanuc", "x"], "--rpm": ["-1", "nan", "0"],
                "--tool": ["-3", "2"], "--arc-tol": ["0", "-1"],
                "-o": ["{missing}/p.nc", "{binary}/p.nc", "{out}"], "--inch": [None]},
    ("check",): {"": ["{binary}", "{gcode}", "{gcode_bad}", "{empty}", "{missing}", "{out}"],
                 "--machine": ["grbl-router", "trunnion-ac", "nope", "{binary}"],
                 "--dialect": ["grbl", "linuxcnc", "fanuc", "generic", "x"]},
    ("gcode-info",): {"": ["{binary}", "{gcode}", "{gcode_bad}", "{empty}", "{missing}"],
                      "--machine": ["grbl-router", "nope"],
                      "--dialect": ["grbl", "linuxcnc", "x"],
                      "--rapid-rate": ["0", "-1", "nan", "5000"]},
    ("verify",): {"": ["{gcode}", "{binary}", "{gcode_bad}", "{missing}"],
                  "--surface": ["{binary}", "{json_bad}", "{json_list}", "{missing}"],
                  "--machine": ["grbl-router", "nope"], "--cutter": ["ball:6", "x", "ball:-1"],
                  "--plot": ["{missing}/v.png"], "--stock": ["-1", "nan"]},
    ("run",): {"": ["{binary}", "{three}", "{empty}", "{nan}", "{missing}", "{curve}"],
               "--machine": ["grbl-router", "nope"], "--cutter": ["ball:6", "flat:-2"],
               "--scallop": ["0", "nan", "-1"], "--fit-tol": ["0", "nan"],
               "-o": ["{binary}/x.nc", "{out}"], "--quiet": [None]},
    ("send",): {"": ["{gcode}", "{binary}", "{missing}", "{empty}"],
                "--port": ["socket://127.0.0.1:", "socket://:99999", "socket://[::1", "",
                           "socket://127.0.0.1:0", "{missing}"],
                "--modbus": ["tcp://", "rtu:", "tcp://127.0.0.1:notaport"],
                "--machine": ["grbl-router", "nope"], "--resume-from": ["x", "-5", "journal"],
                "--journal": ["{missing}/j.jsonl"], "--no-progress": [None]},
    ("serve",): {"--port": ["99999", "-1", "x", "65536"],  # always one (it would serve)
                 "--data-dir": ["{binary}/data", "{out}"], "--workers": ["0", "x", "1"],
                 "--max-upload-mb": ["-1", "nan"], "--target": ["x", "a=", "=b"]},
}
POSITIONAL = ""


@dataclass
class CliFiles:
    """The files CLI cases name, written once per run into a temporary folder."""

    root: Path
    names: dict[str, str] = field(default_factory=dict)

    @classmethod
    def create(cls, root: Path) -> CliFiles:
        blade = (ROOT / "toolpath" / "data" / "dev_blade_15x142.csv").read_text().splitlines()
        def rows(keep: str, step: int = 1) -> str:
            body = [r for r in blade[1:] if r.split(",")[0] in keep][::step]
            return "\n".join([blade[0], *body]) + "\n"
        rng = np.random.default_rng(0)
        files = {
            "curve": "x,y,z\n" + "\n".join(f"{np.cos(a):.6f},{np.sin(a):.6f},{a:.3f}"
                                         for a in np.linspace(0, 2, 30)) + "\n",
            "sections": rows("0123", 4), "three": rows("012", 4),
            "ragged": rows("0123", 4).rsplit("\n", 6)[0] + "\n",
            "nan": "x,y,z\n1,2,3\nnan,1,2\n4,5,inf\n",
            "huge": "x,y,z\n" + "\n".join(f"{v:.1e},1,2" for v in (1e300, -1e300, 1e308)) + "\n",
            "one_point": "x,y,z\n1,2,3\n", "empty": "",
            "json_list": "[1, 2, 3]", "json_bad": '{"kind": "streamline_surface"}',
            "gcode": "G21 G90\nG0 Z5\nG1 Z0 F300\nG1 X10 F800\nM30\n",
            "gcode_bad": "G21\nG1 X1e400 F10\nG2 X1\nG1 X" + "9" * 400 + "\n",
        }
        names = {"out": str(root), "missing": str(root / "no_such_folder")}
        for name, text in files.items():
            path = root / f"{name}.txt"
            path.write_text(text)
            names[name] = str(path)
        (root / "binary.bin").write_bytes(rng.bytes(512))
        names["binary"] = str(root / "binary.bin")
        (root / "zip.npz").write_bytes(b"PK\x03\x04" + rng.bytes(200))
        names["zip"] = str(root / "zip.npz")
        np.savez(root / "foreign.npz", a=np.arange(3))
        names["npz"] = str(root / "foreign.npz")
        return cls(root, names)


def cli_case(rng: np.random.Generator) -> list[str]:
    """A random argv: a real command, a positional argument and a few of its flags."""
    commands = list(CLI_COMMANDS)
    command = commands[int(rng.integers(len(commands)))]
    flags = CLI_COMMANDS[command]
    argv = list(command)
    if POSITIONAL in flags and rng.random() < 0.95:
        argv.append(str(rng.choice(flags[POSITIONAL])))
    options = [f for f in flags if f != POSITIONAL]
    for flag in rng.choice(options, size=min(len(options), int(rng.integers(0, 4))),
                           replace=False):
        argv.append(str(flag))
        value = flags[str(flag)][int(rng.integers(len(flags[str(flag)])))]
        if value is not None:
            argv.append(value)
    if command[0] in ("plan", "run", "verify") and rng.random() < 0.9 and "--machine" not in argv:
        argv += ["--machine", "grbl-router"]
    if command[0] == "verify" and "--surface" not in argv:
        argv += ["--surface", "{binary}"]
    if command[0] == "verify" and "--cutter" not in argv:
        argv += ["--cutter", "ball:6"]
    if command[0] == "serve" and "--port" not in argv:
        argv += ["--port", str(rng.choice(flags["--port"]))]
    return argv


def _fill(argv: list[str], files: CliFiles) -> list[str]:
    return [a.format(**files.names) for a in argv]


def _cli_files() -> CliFiles:
    """The fuzz files of this process, made on first use; the process works in their folder
    (``run`` writes ``job/`` there) and removes it at exit."""
    global _FILES
    if _FILES is None:
        root = Path(tempfile.mkdtemp(prefix="toolpath-fuzz-"))
        atexit.register(shutil.rmtree, root, True)
        _FILES = CliFiles.create(root)
        os.chdir(root)
    return _FILES


_FILES: CliFiles | None = None


class CliCrash(AssertionError):
    """A CLI case that broke the contract (exit status, traceback)."""


def run_cli_case(argv: list[str]) -> None:
    """``main(argv)`` exits 0, 1 or 2 and prints no traceback."""
    from streamline_cam.cli import main

    err, out = io.StringIO(), io.StringIO()
    with contextlib.redirect_stderr(err), contextlib.redirect_stdout(out):
        try:
            status = main(_fill(argv, _cli_files()))
        except SystemExit as exc:  # argparse: usage errors exit 2, --help 0
            status = exc.code if isinstance(exc.code, int) else 2
    text = err.getvalue()
    if status not in (0, 1, 2) or "Traceback" in text:
        raise CliCrash(f"exit status {status}; stderr: {text[-600:]}")


def cli_reproducer(argv: list[str]) -> str:
    return "toolpath " + " ".join(repr(a) if " " in a or not a else a for a in argv)


# ---------------------------------------------------------------------------- the runner


@dataclass(frozen=True)
class Target:
    """What one target fuzzes: a case generator, its runner, a reproducer, a time-out (s)."""

    name: str
    make: Callable[[np.random.Generator], Any]
    run: Callable[[Any], None]
    reproducer: Callable[[Any], str]
    timeout_s: float


TARGETS = {
    "parser": Target("parser", parser_case, run_parser_case, parser_reproducer, 2.0),
    "fitters": Target("fitters", fitter_case, run_fitter_case, fitter_reproducer, 60.0),
    "cli": Target("cli", cli_case, run_cli_case, cli_reproducer, 120.0),
}


def check_case(target: Target, case: Any) -> str | None:
    """Run one case in this process: ``None`` when it keeps the contract, else the problem."""
    try:
        target.run(case)
    except Exception as exc:  # the contract's own errors were suppressed by the runner
        last = traceback.format_exception_only(type(exc), exc)[-1].strip()
        return last[:600]
    return None


def _child(name: str, conn: Any) -> None:
    """Run cases sent by the parent; ack each before running it."""
    import warnings

    warnings.simplefilter("ignore")
    target = TARGETS[name]
    with contextlib.suppress(Exception):  # warm the imports before the clock matters
        check_case(target, target.make(np.random.default_rng(0)))
    conn.send("ready")
    while (case := conn.recv()) is not None:
        conn.send("start")
        conn.send(check_case(target, case))


@dataclass
class Tally:
    """Cases tried, crashes and hangs of one target."""

    name: str
    cases: int = 0
    crashes: list[tuple[str, str]] = field(default_factory=list)
    hangs: list[str] = field(default_factory=list)


class _Worker:
    """A child process running one target's cases."""

    def __init__(self, name: str) -> None:
        ctx = multiprocessing.get_context("spawn")
        self.conn, child = ctx.Pipe()
        self.process = ctx.Process(target=_child, args=(name, child), daemon=True)
        self.process.start()
        child.close()
        if not self.conn.poll(300.0):
            raise RuntimeError(f"the {name} fuzz worker did not start")
        self.conn.recv()

    def run(self, case: Any, timeout_s: float) -> tuple[bool, str | None]:
        """``(finished, problem)``; not finished: it hung (the worker is killed)."""
        self.conn.send(case)
        if not self.conn.poll(30.0):
            raise RuntimeError("the fuzz worker does not answer")
        self.conn.recv()  # "start"
        if not self.conn.poll(timeout_s):
            self.close(kill=True)
            return False, None
        return True, self.conn.recv()

    def close(self, *, kill: bool = False) -> None:
        if kill:
            self.process.kill()
        else:
            with contextlib.suppress(OSError):
                self.conn.send(None)
        self.process.join(10.0)


def fuzz(target: Target, seconds: float, seed: int) -> Tally:
    """Run ``target`` for ``seconds`` of wall time from ``seed``."""
    rng = np.random.default_rng([seed, sum(map(ord, target.name))])
    tally = Tally(target.name)
    shrunk: set[str] = set()
    worker = _Worker(target.name)
    deadline = time.monotonic() + seconds
    try:
        while time.monotonic() < deadline:
            case = target.make(rng)
            finished, problem = worker.run(case, target.timeout_s)
            tally.cases += 1
            if not finished:
                tally.hangs.append(target.reproducer(case))
                worker = _Worker(target.name)
            elif problem is not None:
                kind = problem.split(":")[0]
                if kind not in shrunk:  # the first of each kind, made small
                    case, worker = _shrink(target, case, kind, worker)
                    shrunk.add(kind)
                tally.crashes.append((target.reproducer(case), problem))
    finally:
        worker.close()
    return tally


def _smaller(case: Any) -> Iterator[Any]:
    """Candidates one step smaller: chunks of the parser's line, elements of an argv."""
    if isinstance(case, tuple):  # parser: (dialect, line)
        name, line = case
        size = len(line) // 2
        while size >= 1:
            for start in range(0, len(line), size):
                yield name, line[:start] + line[start + size:]
            size //= 2
    elif isinstance(case, list) and all(isinstance(a, str) for a in case):  # cli argv
        for i in range(len(case)):
            yield case[:i] + case[i + 1:]


SHRINK_TRIES = 400


def _shrink(target: Target, case: Any, kind: str, worker: _Worker) -> tuple[Any, _Worker]:
    """Delta debugging: drop parts of ``case`` while it still fails with ``kind``.

    Each candidate runs in the worker under the target's time-out (a candidate that hangs
    is not kept, and the worker is replaced). Returns the smallest case and the worker.
    """
    tries = 0
    progress = True
    while progress and tries < SHRINK_TRIES:
        progress = False
        for candidate in _smaller(case):
            tries += 1
            finished, problem = worker.run(candidate, target.timeout_s)
            if not finished:
                worker = _Worker(target.name)
            elif problem is not None and problem.split(":")[0] == kind:
                case, progress = candidate, True
                break
            if tries >= SHRINK_TRIES:
                break
    return case, worker


def cases(target: Target, seed: int, count: int, **make: Any) -> Iterator[Any]:
    """The first ``count`` cases of ``target`` from ``seed`` (what :func:`fuzz` tries).

    ``make``: keywords of the generator (``hostile=False`` for the parser's).
    """
    rng = np.random.default_rng([seed, sum(map(ord, target.name))])
    for _ in range(count):
        yield target.make(rng, **make)


def _report(tally: Tally, timeout_s: float, shown: int) -> list[str]:
    lines = [f"{tally.name:<8} {tally.cases:>8} cases  {len(tally.crashes):>4} crashes  "
             f"{len(tally.hangs):>3} hangs (> {timeout_s:g} s)"]
    kinds: dict[str, list[str]] = {}
    for reproducer, problem in tally.crashes:
        kinds.setdefault(problem.split(":")[0], []).append(f"{problem}\n      {reproducer}")
    for kind, items in sorted(kinds.items()):
        lines.append(f"  crash {kind} ({len(items)}):")
        lines += [f"    {item}" for item in items[:shown]]
    lines += [f"  hang: {reproducer}" for reproducer in tally.hangs[:shown]]
    return lines


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seconds", type=float, default=60.0, help="total wall time (60)")
    parser.add_argument("--seed", type=int, default=1)
    parser.add_argument("--targets", default="parser,fitters,cli",
                        help="comma-separated: parser, fitters, cli")
    parser.add_argument("--show", type=int, default=3, help="reproducers shown per kind (3)")
    args = parser.parse_args(argv)
    names = [n.strip() for n in args.targets.split(",") if n.strip()]
    unknown = sorted(set(names) - set(TARGETS))
    if unknown:
        parser.error(f"unknown target(s) {unknown}; known: {sorted(TARGETS)}")
    share = args.seconds / len(names)
    print(f"fuzz: seed {args.seed}, {share:g} s per target, targets {', '.join(names)}")
    failed = False
    for name in names:
        tally = fuzz(TARGETS[name], share, args.seed)
        print("\n".join(_report(tally, TARGETS[name].timeout_s, args.show)), flush=True)
        failed |= bool(tally.crashes or tally.hangs)
    print("cli reproducers: {name} is a file of CliFiles.create ({binary}: random bytes, "
          "{missing}: a missing folder, {out}: an existing folder)")
    print(json.dumps({"seed": args.seed, "seconds": args.seconds, "failed": failed}))
    return 1 if failed else 0


if __name__ == "__main__":
    sys.path.insert(0, str(ROOT))
    sys.exit(main())
