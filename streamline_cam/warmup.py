"""Compile the kernels a job uses, once per install: ``toolpath warm-up`` (``make install``).

The planner's kernels (numba, ``cache=True``) are compiled on first use and kept in the
kernel cache (:mod:`toolpath.kernel_cache`: next to the sources, or a user cache folder
when the package folder is read-only), so the first job after an install pays for them
and every later process loads them. The warm-up runs that first job ahead of time: two
small verified jobs on bundled blades (3-axis on ``grbl-router``: a coarse copy of the
development blade, open sections; 5-axis on ``trunnion-ac``: the propeller blade, closed
sections, a spiral), which compile every kernel a job reaches for the argument types jobs
pass. Nothing depends on it: a kernel it did not reach compiles when a job first calls it.
"""

from __future__ import annotations

import tempfile
import time
import warnings
from collections.abc import Callable
from pathlib import Path

from toolpath.paper_examples import bundled_data_path

__all__ = ["WARM_JOBS", "warm_up"]

#: The warm-up's jobs: (label, bundled blade or None for the coarse development blade,
#: machine, axis mode). Coarse settings: the kernels matter here, not the figures.
WARM_JOBS = (("3-axis", None, "grbl-router", "3"),
             ("5-axis", "dev_prop_7x100.csv", "trunnion-ac", "lead-tilt"))
#: Every SECTION_STEP-th section (and the last) and every POINT_STEP-th point of the
#: development blade: the same kind of surface (open sections, a blunt trailing edge left
#: unsampled), a sixth of the data.
SECTION_STEP, POINT_STEP = 3, 2


def _coarse_blade(folder: Path) -> Path:
    """A CSV of the development blade thinned to a few sections of fewer points."""
    lines = bundled_data_path("dev_blade_15x142.csv").read_text(encoding="utf-8").splitlines()
    rows: dict[str, list[str]] = {}
    for line in lines[1:]:
        rows.setdefault(line.split(",", 1)[0], []).append(line)
    names = list(rows)
    keep = names[::SECTION_STEP] + ([names[-1]] if (len(names) - 1) % SECTION_STEP else [])
    out = [lines[0]]
    for i, name in enumerate(keep):
        out += [f"{i}," + row.split(",", 1)[1] for row in rows[name][::POINT_STEP]]
    path = folder / "warm_blade.csv"
    path.write_text("\n".join(out) + "\n", encoding="utf-8")
    return path


def warm_up(say: Callable[[str], None] | None = None) -> float:
    """Run the warm-up jobs in a temporary folder; returns the seconds taken.

    ``say`` gets one line as each job starts and ends (progress), e.g. ``print``.
    """
    from .pipeline import JobRequest, run_job

    say = say or (lambda _text: None)
    start = time.perf_counter()
    with (tempfile.TemporaryDirectory(prefix="toolpath-warm-up-") as folder,
          warnings.catch_warnings()):
        warnings.simplefilter("ignore")  # the coarse fit's figures do not matter here
        for i, (label, name, machine, axis_mode) in enumerate(WARM_JOBS, 1):
            blade = _coarse_blade(Path(folder)) if name is None else bundled_data_path(name)
            job_start = time.perf_counter()
            say(f"warm-up {i}/{len(WARM_JOBS)}: {label} job on {machine} "
                "(fit, plan, post, check, verify) ...")
            request = JobRequest(blade, machine=machine, axis_mode=axis_mode,
                                 scallop_mm=0.05, chord_tol_mm=0.02)
            run_job(request, Path(folder) / label, verify=True)
            say(f"warm-up {i}/{len(WARM_JOBS)}: {label} done in "
                f"{time.perf_counter() - job_start:.1f} s")
    return time.perf_counter() - start
