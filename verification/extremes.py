"""The extreme deviations, refined: deepest gouge, largest excess, largest scallop.

A grid misses the top of a cusp (a kink) by about ``spacing x slope``, so the most extreme
local extremes of the grid are searched again on three levels of ``9 x 9`` sub-grids around
them (each a quarter of the previous), cutting the spacing by 64. :func:`border` marks the
samples near uncut or hidden ones, so the scallop can be taken away from the flanks of the
uncut stock.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Final

import numpy as np
from numpy.typing import NDArray

from toolpath.surface import ParametricSurface

from .dexels import DexelResult
from .samples import DesignSamples, surface_points_normals
from .search import Dexels

__all__ = ["Extreme", "border", "extreme", "extremes"]

FloatArray = NDArray[np.float64]

_REFINE_GRID: Final[int] = 9


@dataclass(frozen=True)
class Extreme:
    """An extreme deviation: value (mm), parameters, design point (mm), move, shank."""

    dev: float
    t: float
    s: float
    point: FloatArray
    move: int
    shank: bool


def _local_extremes(dev: FloatArray, eligible: NDArray[np.bool_], largest: bool, limit: float,
                    k: int) -> NDArray[np.int64]:
    """Flat indices of up to ``k`` local extremes among eligible samples, most extreme first."""
    sign = 1.0 if largest else -1.0
    val = np.where(eligible & np.isfinite(dev), sign * dev, -np.inf)
    pad = np.pad(val, 1, constant_values=-np.inf)
    n_t, n_s = dev.shape
    top = np.full(dev.shape, -np.inf)
    for di in range(3):
        for dj in range(3):
            if di == 1 and dj == 1:
                continue
            np.maximum(top, pad[di:di + n_t, dj:dj + n_s], out=top)
    cand = np.flatnonzero(((val >= top) & np.isfinite(val) & (val > sign * limit)).ravel())
    if cand.shape[0] > k:
        cand = cand[np.argpartition(-val.ravel()[cand], k - 1)[:k]]
    return cand[np.argsort(-val.ravel()[cand])]


def _refine(ev: Dexels, surface: ParametricSurface, samples: DesignSamples,
            cand: NDArray[np.int64], *, largest: bool, collision: bool) -> Extreme | None:
    """Three levels of 9 x 9 near searches around the local extremes ``cand``.

    ``cand``: flat sample indices, most extreme first (:func:`_local_extremes`). The best
    point of each candidate is searched once more with the collision search (when
    asked), so a deep gouge only that search sees is measured exactly.
    """
    if cand.shape[0] == 0:
        return None
    n_s = samples.shape[1]
    ti, si = samples.t[cand // n_s], samples.s[cand % n_s]
    dt = 1.0 / max(samples.shape[0] - 1, 1)
    ds = 1.0 / max(n_s - 1, 1)
    conv = samples.convexity_per_mm.ravel()[cand]
    off = np.linspace(-1.0, 1.0, _REFINE_GRID)
    ot, os_ = (a.ravel() for a in np.meshgrid(off, off, indexing="ij"))
    closed = bool(getattr(surface, "closed_t", False))
    sign = 1.0 if largest else -1.0
    rows = np.arange(cand.shape[0])
    for scale in (1.0, 0.25, 0.0625):
        t = ti[:, None] + scale * dt * ot[None, :]
        s = np.clip(si[:, None] + scale * ds * os_[None, :], 0.0, 1.0)
        t = np.mod(t, 1.0) if closed else np.clip(t, 0.0, 1.0)
        pts, nrm, _ = surface_points_normals(surface, t.ravel(), s.ravel())
        res = ev.search(pts, nrm, np.repeat(conv, off.size ** 2))
        d = ev.deviation(res, nrm).reshape(cand.shape[0], -1)
        pick = np.argmax(np.where(np.isfinite(d), sign * d, -np.inf), axis=1)
        ti, si = t[rows, pick], s[rows, pick]
    pts, nrm, _ = surface_points_normals(surface, ti, si)
    res = ev.search(pts, nrm, conv, far=collision)
    score = np.where(np.isfinite(d := ev.deviation(res, nrm)), sign * d, -np.inf)
    i = int(np.argmax(score))
    if not np.isfinite(score[i]):
        return None
    return Extreme(float(d[i]), float(ti[i]), float(si[i]), pts[i], int(res.move[i]),
                    bool(res.shank[i]))


def extreme(ev: Dexels, surface: ParametricSurface, samples: DesignSamples,
             res: DexelResult, dev: FloatArray, eligible: NDArray[np.bool_], *,
             largest: bool, limit: float, refine: int, collision: bool) -> Extreme | None:
    """The most extreme deviation among eligible samples beyond ``limit``, refined."""
    return extremes(ev, surface, samples, res, dev, [(eligible, largest, limit)],
                    refine=refine, collision=collision)[0]


def extremes(ev: Dexels, surface: ParametricSurface, samples: DesignSamples,
             res: DexelResult, dev: FloatArray,
             asks: Sequence[tuple[NDArray[np.bool_], bool, float]], *, refine: int,
             collision: bool) -> list[Extreme | None]:
    """:func:`extreme` of each ask ``(eligible, largest, limit)``, searching each start once.

    An extreme depends on its mask only through the most extreme eligible sample and the
    ``refine`` local extremes its refinement starts from: an ask with the same sense,
    limit, sample and starts as an earlier one (the largest scallop is most often the
    largest excess, away from the uncut flanks) has the very same searches, so it takes
    the earlier one's result instead of running them again.
    """
    n_s = samples.shape[1]
    found: dict[tuple[bool, float, int, bytes], Extreme | None] = {}
    out: list[Extreme | None] = []
    for eligible, largest, limit in asks:
        flat = np.where(eligible & np.isfinite(dev), dev, np.nan).ravel()
        if np.isnan(flat).all():
            out.append(None)
            continue
        i = int(np.nanargmax(flat) if largest else np.nanargmin(flat))
        cand = (_local_extremes(dev, eligible, largest, limit, refine) if refine
                else np.zeros(0, dtype=np.int64))
        key = (largest, limit, i, cand.tobytes())
        if key not in found:
            sign = 1.0 if largest else -1.0
            best = Extreme(float(flat[i]), float(samples.t[i // n_s]),
                           float(samples.s[i % n_s]), samples.points.reshape(-1, 3)[i],
                           int(res.move[i]), bool(res.shank[i]))
            if refine:
                fine = _refine(ev, surface, samples, cand, largest=largest,
                                      collision=collision)
                if fine is not None and sign * fine.dev >= sign * best.dev:
                    best = fine
            found[key] = best if sign * best.dev > sign * limit else None
        out.append(found[key])
    return out


def border(bad: NDArray[np.bool_], rt: int, rs: int) -> NDArray[np.bool_]:
    """Samples within ``rt`` x ``rs`` grid steps of a ``bad`` sample (box filter)."""
    c = np.pad(bad.astype(np.int64), ((rt + 1, rt), (rs + 1, rs))).cumsum(0).cumsum(1)
    n_t, n_s = bad.shape
    box = (c[2 * rt + 1:2 * rt + 1 + n_t, 2 * rs + 1:2 * rs + 1 + n_s]
           - c[:n_t, 2 * rs + 1:2 * rs + 1 + n_s]
           - c[2 * rt + 1:2 * rt + 1 + n_t, :n_s] + c[:n_t, :n_s])
    return box > 0
