"""Compile the kernels a job uses, once per install: ``toolpath warm-up`` (``make install``).

The planner's kernels (numba, ``cache=True``) are compiled on first use and kept in the
kernel cache (:mod:`toolpath.kernel_cache`: next to the sources, or a user cache folder
when the package folder is read-only), so the first job after an install pays for them
and every later process loads them. The warm-up runs that first job ahead of time: two
small jobs on bundled blades at coarse settings (3-axis on ``grbl-router``: the development
blade, open sections, verified; 5-axis on ``trunnion-ac``: the propeller blade, closed
sections, a spiral), which compile every kernel a job reaches for the argument types jobs
pass. Nothing depends on it: a kernel it did not reach compiles when a job first calls it,
and a warm-up job that stops (bad data would be a bug) is reported and skipped.
"""

from __future__ import annotations

import tempfile
import time
import warnings
from collections.abc import Callable
from pathlib import Path

from gcode.errors import GCodeError
from machines.errors import MachineError
from toolpath.errors import ToolpathError
from toolpath.paper_examples import bundled_data_path

__all__ = ["COARSE", "WARM_JOBS", "warm_up"]

#: The warm-up's jobs: (label, bundled blade, machine, axis mode, verify). Coarse settings
#: (COARSE): the kernels matter here, not the figures. One verification reaches the
#: verifier's code; a second (5-axis) would only repeat it, at a cost.
WARM_JOBS = (("3-axis", "dev_blade_15x142.csv", "grbl-router", "3", True),
             ("5-axis", "dev_prop_7x100.csv", "trunnion-ac", "lead-tilt", False))
COARSE = {"scallop_mm": 0.05, "chord_tol_mm": 0.02}


def warm_up(say: Callable[[str], None] | None = None) -> float:
    """Run the warm-up jobs in a temporary folder; returns the seconds taken.

    ``say`` gets one line as each job starts and ends (progress), e.g. ``print``.
    """
    from .pipeline import JobRequest, run_job

    say = say or (lambda _text: None)
    start = time.perf_counter()
    with (tempfile.TemporaryDirectory(prefix="toolpath-warm-up-") as folder,
          warnings.catch_warnings()):
        warnings.simplefilter("ignore")  # figures of coarse settings do not matter here
        for i, (label, name, machine, axis_mode, verify) in enumerate(WARM_JOBS, 1):
            job_start = time.perf_counter()
            say(f"warm-up {i}/{len(WARM_JOBS)}: {label} job on {machine} ({name}: fit, plan, "
                f"post, check{', verify' if verify else ''}) ...")
            request = JobRequest(bundled_data_path(name), machine=machine,
                                 axis_mode=axis_mode, **COARSE)
            try:
                result = run_job(request, Path(folder) / label, verify=verify)
            except (ToolpathError, GCodeError, MachineError) as exc:
                say(f"warm-up {i}/{len(WARM_JOBS)}: {label} stopped ({exc}); what it did not "
                    "reach compiles on first use")
                continue
            stages = ", ".join(f"{stage} {seconds:.1f}"
                               for stage, seconds in result.report["seconds"].items())
            say(f"warm-up {i}/{len(WARM_JOBS)}: {label} done in "
                f"{time.perf_counter() - job_start:.1f} s ({stages} s)")
    return time.perf_counter() - start
