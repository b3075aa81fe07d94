"""A job's files: which exist, their media types, and the plots drawn on first request.

Plots (``surface``: sections, streamlines and fit error; ``deviation``: the verified
deviation map of the program; ``toolpath``: the passes over the surface, when
:mod:`toolpath.plotting_paths` is installed) are drawn by the library's
headless plotting modules (imported lazily, so the service starts without matplotlib) into
``<job>/plots/NAME.png`` once, under one lock per service (pyplot keeps global state), then
served from disk.
"""

from __future__ import annotations

import importlib.util
import json
import os
import threading
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Final

import numpy as np

from .store import JobRecord

__all__ = ["FILES", "Artefact", "plot_names", "render_plot"]


@dataclass(frozen=True)
class Artefact:
    """A result file: its name in the job folder, media type, and download suffix."""

    file: str
    media_type: str
    suffix: str


#: Resource name -> file written by the pipeline.
FILES: Final[dict[str, Artefact]] = {
    "report": Artefact("report.json", "application/json", ".json"),
    "gcode": Artefact("part.nc", "text/plain; charset=utf-8", ".nc"),
    "toolpath": Artefact("toolpath.npz", "application/octet-stream", ".npz"),
    "surface": Artefact("surface.json", "application/json", ".json"),
}

Renderer = Callable[[Path, JobRecord, Path], None]


def _placed_sections(job_dir: Path, record: JobRecord) -> np.ndarray:
    """The sections as fitted: read again and placed by the report's placement."""
    from toolpath import as_sections, read_sections
    from toolpath.placement import Placement

    raw = as_sections(read_sections(job_dir / record.input_name))
    placement = (record.report or {}).get("placement", {})
    if not placement:
        return raw.points
    return Placement(np.asarray(placement["rotation"], dtype=float),
                     np.asarray(placement["offset_mm"], dtype=float),
                     str(placement["mode"])).apply(raw.points)


def job_surface(job_dir: Path) -> Any:
    """The fitted surface of the finished job in ``job_dir`` (placed as the job planned it)."""
    from toolpath import surface_from_dict

    return surface_from_dict(json.loads((job_dir / "surface.json").read_text("utf-8")))


def _surface_plot(job_dir: Path, record: JobRecord, out: Path) -> None:
    from toolpath.plotting import plot_surface_fit

    surface = job_surface(job_dir)
    plot_surface_fit(_placed_sections(job_dir, record), surface, out,
                     title=f"{record.parameters.get('method', '')} fit: {record.input_name}")


def _toolpath_plot(job_dir: Path, record: JobRecord, out: Path) -> None:
    from toolpath import Toolpath
    from toolpath.plotting_paths import plot_toolpath

    surface = job_surface(job_dir)
    plot_toolpath(surface, Toolpath.load(job_dir / "toolpath.npz"), out,
                  title=f"toolpath: {record.input_name}")


def _deviation_plot(job_dir: Path, record: JobRecord, out: Path) -> None:
    """The verified deviation map: the job's program checked again as the job checked it.

    The pipeline's verify stage (:func:`~streamline_cam.pipeline.verify_program` of
    ``part.nc`` against the placed surface, the job's machine, cutter, dialect and scallop),
    so its extremes are the report's ``verify`` figures; the map itself is not kept by the job.
    """
    from gcode.dialects import dialect_by_name
    from machines.machine import load_machine
    from verification.plotting import plot_deviation_map

    from ..pipeline import verify_program

    params = record.parameters
    dialect = dialect_by_name(params["dialect"]) if params.get("dialect") else None
    plot_deviation_map(verify_program(job_dir / "part.nc", job_surface(job_dir),
                                      load_machine(params["machine"]), params["cutter"],
                                      dialect, params["scallop_mm"]), out)


def _renderers() -> dict[str, Renderer]:
    """The plots this installation can draw."""
    renderers: dict[str, Renderer] = {"surface": _surface_plot, "deviation": _deviation_plot}
    if importlib.util.find_spec("toolpath.plotting_paths") is not None:
        renderers["toolpath"] = _toolpath_plot
    return renderers


def plot_names() -> list[str]:
    """Names accepted by ``GET /jobs/{id}/plots/{name}``."""
    return sorted(_renderers())


def render_plot(name: str, job_dir: Path, record: JobRecord, lock: threading.Lock) -> Path:
    """The PNG of plot ``name`` for a finished job, drawn now if it is not on disk yet.

    Raises
    ------
    KeyError
        Unknown plot name.
    """
    renderer = _renderers()[name]
    out = job_dir / "plots" / f"{name}.png"
    if out.is_file():
        return out
    with lock:
        if not out.is_file():
            out.parent.mkdir(exist_ok=True)
            partial = out.with_suffix(f".{os.getpid()}.part.png")
            renderer(job_dir, record, partial)
            partial.replace(out)  # atomic: a reader never sees half a PNG
    return out
