"""What the page's 3-D view draws: the fitted surface on a grid and the toolpath, decimated.

Display only: the G-code and the ``.npz`` toolpath are never touched.

The toolpath is cut into runs of one kind: ``cut`` (the finishing passes, one run per pass),
``link`` (plunges, leads, links and retracts: feed moves off the passes) and ``rapid``. Move
``i`` (from point ``i - 1`` to ``i``) has the kind of point ``i``, so a run's polyline starts
at the point where the previous run ended. Every run's first and last point is kept.

Decimation is Ramer-Douglas-Peucker with a point budget instead of a tolerance. RDP splits
a chord ``[a, b]`` at the point farthest from it, at distance

    d_i = | p_i - (a + clamp(((p_i - a) . (b - a)) / |b - a|^2, 0, 1) (b - a)) |,

and a point's *weight* is its ``d_i`` when it was chosen, capped by its parent's weight, so
weights never grow down the tree. Keeping every point of weight ``>= w`` is then RDP at
tolerance ``w``, every dropped point within ``w`` of its kept chord; the budget keeps the
heaviest points. The tree is built breadth first, all chords of one depth at once in
numpy, so a 250,000-point path takes tens of numpy passes, not a Python loop per point.
"""

from __future__ import annotations

import json
import os
import threading
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Final

import numpy as np
from numpy.typing import NDArray

__all__ = [
    "DEFAULT_MAX_POINTS",
    "SURFACE_GRID",
    "Decimation",
    "chord_deviation",
    "decimate_polyline",
    "job_preview",
    "preview",
    "rdp_weights",
    "toolpath_runs",
]

DEFAULT_MAX_POINTS: Final[int] = 50_000
"""Toolpath points sent to the page by default: a WebGL line of this many draws at once."""
SURFACE_GRID: Final[tuple[int, int]] = (48, 72)
"""Surface samples (rows along the span, columns round the section): smooth to the eye,
3,456 points."""
_FLAT_MM: Final[float] = 1e-9
"""A chord whose farthest point is nearer than this is straight: not split further."""
_SAME_AXIS: Final[float] = 1e-9
"""Unit tool axes whose components all agree to this are one axis: a 3-axis path."""

# MoveKind values (toolpath.path) -> run kind
_RAPID, _CUT = 0, 3


@dataclass(frozen=True)
class Decimation:
    """Points kept of a polyline.

    Attributes
    ----------
    keep : ndarray of bool, shape (n,)
    max_deviation_mm : float
        Largest distance of a dropped point from the kept chord around it (0 when none
        was dropped).
    """

    keep: NDArray[np.bool_]
    max_deviation_mm: float


def _chord_distances2(columns: tuple[NDArray[np.float64], ...], idx: NDArray[np.intp],
                      a: NDArray[np.intp], b: NDArray[np.intp], counts: NDArray[np.intp]
                      ) -> NDArray[np.float64]:
    """Squared distance of points ``idx`` from chords ``a -> b`` (mm^2).

    ``idx`` lists ``counts[k]`` points of chord ``k`` after one another; ``columns`` are
    the x, y, z coordinates. Chord quantities are computed once per chord and repeated.
    """
    ab = [c[b] - c[a] for c in columns]
    length2 = ab[0] ** 2 + ab[1] ** 2 + ab[2] ** 2
    inv = np.divide(1.0, length2, out=np.zeros_like(length2), where=length2 > 0.0)
    ap = [c[idx] - np.repeat(c[a], counts) for c in columns]
    abp = [np.repeat(v, counts) for v in ab]
    t = ap[0] * abp[0]
    t += ap[1] * abp[1]
    t += ap[2] * abp[2]
    t *= np.repeat(inv, counts)
    np.clip(t, 0.0, 1.0, out=t)
    d2 = np.zeros(len(idx))
    for u, v in zip(ap, abp, strict=True):
        v *= t
        u -= v
        u *= u
        d2 += u
    return d2


def rdp_weights(points: NDArray[np.float64], fixed: NDArray[np.bool_], *,
                budget: int | None = None) -> NDArray[np.float64]:
    """RDP weight of every point (see the module); ``fixed`` points get ``inf``.

    Parameters
    ----------
    points : ndarray, shape (n, 3)
    fixed : ndarray of bool, shape (n,)
        Points always kept (the first and last are added).
    budget : int or None
        Only the ``budget`` heaviest free points are wanted: a chord whose cap is below the
        ``budget``-th weight found so far is not split further (its points keep weight 0;
        none of them could be among the heaviest).
    """
    n = len(points)
    weights = np.zeros(n)
    if n == 0:
        return weights
    columns = tuple(np.ascontiguousarray(points[:, k], dtype=float) for k in range(3))
    fixed = fixed.copy()
    fixed[[0, -1]] = True
    weights[fixed] = np.inf
    anchors = np.flatnonzero(fixed)
    starts, ends = anchors[:-1], anchors[1:]
    caps = np.full(len(starts), np.inf)
    found: list[NDArray[np.float64]] = []
    threshold = 0.0
    while True:
        inner = ends - starts - 1
        open_ = (inner > 0) & (caps > threshold)
        starts, ends, caps, inner = starts[open_], ends[open_], caps[open_], inner[open_]
        if len(starts) == 0:
            return weights
        # every inner point of every open chord, chord by chord (chords do not overlap)
        inside = np.zeros(n + 1, dtype=np.int32)
        np.add.at(inside, starts + 1, 1)
        np.add.at(inside, ends, -1)
        idx = np.flatnonzero(np.cumsum(inside[:-1]) > 0)
        first = np.cumsum(inner) - inner
        dist2 = _chord_distances2(columns, idx, starts, ends, inner)
        far2 = np.maximum.reduceat(dist2, first)
        # the first point of each chord reaching its maximum
        at_max = np.flatnonzero(dist2 == np.repeat(far2, inner))
        owner = np.searchsorted(first, at_max, side="right") - 1
        split = idx[at_max[np.concatenate(([True], owner[1:] != owner[:-1]))]]
        far = np.sqrt(far2)
        bent = far > _FLAT_MM
        weight = np.minimum(far, caps)
        weights[split[bent]] = weight[bent]
        s, e, m, w = starts[bent], ends[bent], split[bent], weight[bent]
        starts = np.column_stack((s, m)).ravel()  # (in order along the path)
        ends = np.column_stack((m, e)).ravel()
        caps = np.repeat(w, 2)
        if budget is not None and budget > 0:
            found.append(w)
            every = np.concatenate(found)
            if len(every) > budget:
                threshold = float(np.partition(every, len(every) - budget)[len(every) - budget])
                found = [every[every >= threshold]]


def chord_deviation(points: NDArray[np.float64], keep: NDArray[np.bool_]) -> float:
    """Largest distance of a dropped point from the chord of the kept points around it, mm."""
    n = len(points)
    if n == 0 or keep.all():
        return 0.0
    index = np.arange(n)
    before = np.maximum.accumulate(np.where(keep, index, 0))
    after = np.minimum.accumulate(np.where(keep, index, n - 1)[::-1])[::-1]
    dropped = np.flatnonzero(~keep)
    columns = tuple(np.ascontiguousarray(points[:, k], dtype=float) for k in range(3))
    d2 = _chord_distances2(columns, dropped, before[dropped], after[dropped],
                           np.ones(len(dropped), dtype=np.intp))
    return float(np.sqrt(d2.max()))


def decimate_polyline(points: NDArray[np.float64], max_points: int,
                      fixed: NDArray[np.bool_] | None = None) -> Decimation:
    """Keep at most ``max_points`` of ``points`` (RDP by budget; ``fixed`` always kept).

    When the fixed points alone exceed the budget, they are all kept (and only they).
    """
    points = np.asarray(points, dtype=float)
    n = len(points)
    fixed = np.zeros(n, dtype=bool) if fixed is None else np.asarray(fixed, dtype=bool)
    if n <= max_points:
        return Decimation(np.ones(n, dtype=bool), 0.0)
    room = max_points - int(fixed.sum()) - 2
    weights = rdp_weights(points, fixed, budget=max(room, 0))
    keep = np.isinf(weights)
    room = max_points - int(keep.sum())
    if room > 0:
        free = np.flatnonzero(~keep & (weights > 0.0))
        if len(free) > room:
            free = free[np.argpartition(-weights[free], room - 1)[:room]]
        keep[free] = True
    return Decimation(keep, chord_deviation(points, keep))


def _kind_names(kinds: NDArray[np.integer]) -> NDArray[np.int8]:
    """0 rapid, 1 link, 2 cut, per point (the move arriving at it)."""
    out = np.ones(len(kinds), dtype=np.int8)
    out[kinds == _RAPID] = 0
    out[kinds == _CUT] = 2
    return out


_NAMES: Final[tuple[str, str, str]] = ("rapid", "link", "cut")


def toolpath_runs(kinds: NDArray[np.integer], pass_index: NDArray[np.integer]
                  ) -> list[tuple[str, int | None, int, int]]:
    """Runs of one kind (and one pass for cuts): ``(kind, pass, first, last)`` point indices.

    A run's polyline is points ``first - 1 .. last`` (its moves arrive at ``first .. last``);
    point 0, the start, opens the first run.
    """
    n = len(kinds)
    if n == 0:
        return []
    kind = _kind_names(np.asarray(kinds))
    passes = np.where(kind == 2, np.asarray(pass_index), -1)
    change = np.flatnonzero((kind[1:] != kind[:-1]) | (passes[1:] != passes[:-1])) + 1
    firsts = np.concatenate(([1], change)) if n > 1 else np.array([0])
    lasts = np.concatenate((change - 1, [n - 1]))
    runs = []
    for first, last in zip(firsts.tolist(), lasts.tolist(), strict=True):
        if last < first:
            continue
        k = int(kind[last])
        runs.append((_NAMES[k], int(passes[last]) if k == 2 else None, first, last))
    return runs


def _flat(values: NDArray[np.float64], decimals: int) -> list[float]:
    return np.round(values, decimals).ravel().tolist()


def preview(surface: Any, toolpath: Any, *, max_points: int = DEFAULT_MAX_POINTS,
            grid: tuple[int, int] = SURFACE_GRID) -> dict[str, Any]:
    """The preview's JSON (see ``GET /jobs/{id}/preview``) of a surface and a toolpath.

    Parameters
    ----------
    surface : toolpath.surface.ParametricSurface
    toolpath : toolpath.Toolpath
    max_points : int
        Toolpath points at most (shared run ends counted in each run), unless the run
        ends alone are more.
    grid : (rows, cols)
        Surface samples along the span (``s``) and round the section (``t``).
    """
    rows, cols = grid
    s = np.linspace(0.0, 1.0, rows)
    t = np.linspace(0.0, 1.0, cols)
    mesh = np.asarray(surface(t, s, grid=True)).transpose(1, 0, 2)  # (rows, cols, 3)
    positions = np.asarray(toolpath.positions_mm, dtype=float)
    axes = np.asarray(toolpath.tool_axes, dtype=float)
    n = len(positions)
    five_axis = bool(n) and not np.allclose(axes, axes[0], atol=_SAME_AXIS)
    runs = toolpath_runs(toolpath.kinds, toolpath.pass_index)
    fixed = np.zeros(n, dtype=bool)
    for _, _, first, last in runs:
        fixed[max(first - 1, 0)] = fixed[last] = True
    shared = max(len(runs) - 1, 0)  # run ends sent twice
    kept = decimate_polyline(positions, max(max_points - shared, 2), fixed)
    segments = []
    for kind, pass_, first, last in runs:
        lo = max(first - 1, 0)
        index = lo + np.flatnonzero(kept.keep[lo:last + 1])
        segment: dict[str, Any] = {"kind": kind, "pass": pass_,
                                   "points": _flat(positions[index], 4)}
        if five_axis:
            segment["tool_axis"] = _flat(axes[index], 5)
        segments.append(segment)
    everything = np.concatenate((mesh.reshape(-1, 3), positions)) if n else mesh.reshape(-1, 3)
    return {
        "surface": {"rows": rows, "cols": cols, "points": _flat(mesh, 4),
                    "closed": bool(getattr(surface, "closed_t", False))},
        "segments": segments,
        "bounds_mm": {"min": _flat(everything.min(axis=0), 4),
                      "max": _flat(everything.max(axis=0), 4)},
        "points": sum(len(seg["points"]) // 3 for seg in segments),
        "source_points": n,
        "five_axis": five_axis,
        "max_deviation_mm": round(kept.max_deviation_mm, 6),
    }


def job_preview(job_dir: Path, max_points: int) -> bytes:
    """The preview JSON of the finished job in ``job_dir``, cached there once computed."""
    cache = job_dir / "preview" / f"{max_points}.json"
    if cache.is_file():
        return cache.read_bytes()
    from toolpath import Toolpath

    from .artefacts import job_surface

    surface = job_surface(job_dir)
    body = json.dumps(preview(surface, Toolpath.load(job_dir / "toolpath.npz"),
                              max_points=max_points), separators=(",", ":")).encode()
    cache.parent.mkdir(exist_ok=True)
    partial = cache.with_suffix(f".{os.getpid()}-{threading.get_ident()}.part")
    partial.write_bytes(body)
    partial.replace(cache)  # atomic: a reader never sees half of it
    return body
