"""The verification report: frozen records, their JSON form and a text summary.

Signs: a deviation is the material remaining on the design surface, measured along the
outward normal, mm: positive is excess (scallops, uncut stock), negative a gouge. Depths
(``depth_mm``) are positive numbers.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass, field, replace
from typing import Any

import numpy as np
from numpy.typing import NDArray

__all__ = [
    "BlockGouge",
    "DeviationMap",
    "DeviationStats",
    "JointDeviation",
    "Location",
    "VerificationReport",
]

FloatArray = NDArray[np.float64]

#: Area-weighted percentiles reported (percent).
PERCENTILES: tuple[float, ...] = (0.1, 1.0, 5.0, 25.0, 50.0, 75.0, 95.0, 99.0, 99.9)


@dataclass(frozen=True)
class Location:
    """Where an extreme deviation is, and which block made it.

    Attributes
    ----------
    deviation_mm : float
        Remaining material there, mm (negative: gouge).
    point_mm : tuple of 3 float
        The design-surface point, mm (workpiece frame).
    t, s : float
        Its surface parameters.
    block_index : int or None
        0-based position in ``Program.blocks`` of the move whose cutter came lowest there.
    line : int or None
        Its 1-based source line.
    rapid : bool or None
        That move is a rapid (G0).
    shank : bool
        The shank, not the ball, came lowest.
    """

    deviation_mm: float
    point_mm: tuple[float, float, float]
    t: float
    s: float
    block_index: int | None
    line: int | None
    rapid: bool | None
    shank: bool = False


@dataclass(frozen=True)
class BlockGouge:
    """One block that gouges: its deepest point and the area it gouges.

    Attributes
    ----------
    block_index : int
        0-based position in ``Program.blocks``.
    line : int
        1-based source line.
    depth_mm : float
        Deepest gouge of the block, mm (> 0).
    area_mm2 : float
        Design area it gouges deeper than the tolerance, mm^2.
    point_mm : tuple of 3 float
        Where the deepest gouge is, mm.
    rapid : bool
        The block is a rapid.
    """

    block_index: int
    line: int
    depth_mm: float
    area_mm2: float
    point_mm: tuple[float, float, float]
    rapid: bool


@dataclass(frozen=True)
class DeviationStats:
    """Distribution of the deviation over the design surface (area-weighted).

    Attributes
    ----------
    area_mm2 : float
        Design area sampled, mm^2.
    cut_area_mm2 : float
        Area the cutter came within the horizon of, mm^2.
    uncut_area_mm2 : float
        Area with more than the horizon left (the cutter never came close), mm^2.
    hidden_area_mm2 : float
        Area a Z-map cannot see (walls and overhangs, normal below 87 deg from +Z) or with
        a degenerate normal, mm^2.
    gouge_area_mm2 : float
        Area gouged deeper than the gouge tolerance, mm^2.
    mean_mm, rms_mm, min_mm, max_mm : float
        Over the cut area, mm (NaN when nothing is cut).
    percentiles_mm : dict of str to float
        ``"p50"`` etc. over the cut area, mm.
    histogram_edges_mm : tuple of float
        Bin edges, mm.
    histogram_area_mm2 : tuple of float
        Cut area per bin, mm^2.
    """

    area_mm2: float
    cut_area_mm2: float
    uncut_area_mm2: float
    hidden_area_mm2: float
    gouge_area_mm2: float
    mean_mm: float
    rms_mm: float
    min_mm: float
    max_mm: float
    percentiles_mm: dict[str, float]
    histogram_edges_mm: tuple[float, ...]
    histogram_area_mm2: tuple[float, ...]

    @classmethod
    def of(cls, deviation_mm: FloatArray, area_mm2: FloatArray, gouge_tol_mm: float,
           bins: int = 20) -> DeviationStats:
        """Statistics of a deviation field (NaN hidden, ``+inf`` beyond the horizon).

        Parameters
        ----------
        deviation_mm, area_mm2 : ndarray
            Deviation and area of each sample (same shape), mm and mm^2.
        gouge_tol_mm : float
            Depth counted as a gouge, mm.
        bins : int
            Histogram bins.

        Returns
        -------
        DeviationStats
        """
        dev = np.asarray(deviation_mm, dtype=float).ravel()
        area = np.asarray(area_mm2, dtype=float).ravel()
        hidden = np.isnan(dev)
        uncut = np.isposinf(dev)
        cut = ~hidden & ~uncut
        a_cut = area[cut]
        d_cut = dev[cut]
        total = float(a_cut.sum())
        nan = float("nan")
        if total > 0.0:
            mean = float((a_cut * d_cut).sum() / total)
            rms = float(np.sqrt((a_cut * d_cut * d_cut).sum() / total))
            order = np.argsort(d_cut)
            a_sorted, d_sorted = a_cut[order], d_cut[order]
            cum = np.cumsum(a_sorted)
            cum = (cum - 0.5 * a_sorted) / total
            pct = {f"p{p:g}": float(np.interp(p / 100.0, cum, d_sorted)) for p in PERCENTILES}
            lo, hi = float(d_cut.min()), float(d_cut.max())
            counts, edges = np.histogram(d_cut, bins=bins, range=(lo, hi if hi > lo else lo + 1e-9),
                                         weights=a_cut)
        else:
            mean = rms = lo = hi = nan
            pct = {f"p{p:g}": nan for p in PERCENTILES}
            counts, edges = np.zeros(0), np.zeros(0)
        return cls(
            area_mm2=float(area.sum()), cut_area_mm2=total,
            uncut_area_mm2=float(area[uncut].sum()), hidden_area_mm2=float(area[hidden].sum()),
            gouge_area_mm2=float(area[cut & (dev < -gouge_tol_mm)].sum()),
            mean_mm=mean, rms_mm=rms, min_mm=lo, max_mm=hi, percentiles_mm=pct,
            histogram_edges_mm=tuple(float(e) for e in edges),
            histogram_area_mm2=tuple(float(c) for c in counts))


@dataclass(frozen=True)
class JointDeviation:
    """How far 5-axis blocks move the tip off the straight line between their ends.

    Attributes
    ----------
    max_mm : float
        Largest distance of a block's true tip path from its chord, mm.
    block_index, line : int or None
        The block where it happens.
    rotary_deg : float
        That block's largest rotary travel, deg.
    blocks_over_tol : int
        Blocks whose tip path leaves the chord by more than the gouge tolerance.
    substeps : int
        Joint-space samples used in all (1 per block moving linear axes only).
    """

    max_mm: float
    block_index: int | None
    line: int | None
    rotary_deg: float
    blocks_over_tol: int
    substeps: int


@dataclass(frozen=True, eq=False)
class DeviationMap:
    """The deviation field on the sample grid (for plots; not part of the JSON).

    Attributes
    ----------
    t, s : ndarray
        Grid parameters, shapes ``(n_t,)`` and ``(n_s,)``.
    points_mm : ndarray, shape (n_t, n_s, 3)
        Design samples, mm.
    deviation_mm : ndarray, shape (n_t, n_s)
        NaN hidden, ``+inf`` beyond the horizon, else the remaining material, mm.
    block_index : ndarray of int64, shape (n_t, n_s)
        Block that came lowest (``-1`` none).
    """

    t: FloatArray
    s: FloatArray
    points_mm: FloatArray
    deviation_mm: FloatArray
    block_index: NDArray[np.int64]


@dataclass(frozen=True)
class VerificationReport:
    """What the program cuts compared with the design surface.

    Attributes
    ----------
    machine, cutter, method : str
        Machine name, cutter spec, dexel method (``normal`` or ``z``).
    blocks, motion_blocks, tool_instances, pieces : int
        Program size and the sweep's size.
    samples : tuple of int
        Sample grid ``(n_t, n_s)``.
    spacing_mm : tuple of float
        Largest sample spacing along ``t`` and ``s``, mm.
    horizon_mm, gouge_tol_mm, requested_scallop_mm : float
        The horizon, the gouge tolerance and the scallop asked for (NaN if none), mm.
    max_gouge : Location or None
        The deepest gouge deeper than the tolerance (refined), or None.
    max_excess : Location or None
        The largest remaining material within the horizon (refined), anywhere cut: on
        the border of an uncut area it is the flank of the uncut stock.
    max_scallop : Location or None
        The same away from uncut and hidden areas and from areas facing away from a fixed
        tool axis (farther than ``sqrt(2 R horizon)``, where a ball's profile rises by the
        horizon): the worst scallop between passes.
    unswept_moves : int
        Moves at the start not swept: until every axis has been programmed the tool's
        position is not known.
    gouging_blocks : tuple of BlockGouge
        Up to ten blocks, deepest first.
    stats : DeviationStats
        The distribution over the surface.
    joints : JointDeviation
        Joint-interpolation figures of the replay.
    pairs : int
        Candidate (dexel, piece) pairs tested.
    timings_s : dict of str to float
        Seconds per stage, in this order: ``replay``; ``samples``, taking the design
        samples (given samples taken ahead in another thread, as ``toolpath run
        --verify`` takes them while it posts and checks the program: the time they took
        there, :meth:`with_samples_taken_ahead`); ``samples_wait``, only then: the time
        the verification waited for them (0 when they were ready); ``pieces``;
        ``search``; ``refine``; ``total``, the verification's own time (the wait counted,
        samples taken ahead not).
    faces_away_area_mm2 : float
        Area facing away from every tool axis the program cuts with (a fixed-axis
        program's one axis; a 5-axis program's range of axes), mm^2: no move cuts to it,
        so what is left there is reported as unreachable, never as a scallop.
    unreachable_area_mm2 : float
        Area facing away, or covered by no pass (no cutting move comes within the
        horizon), mm^2.
    design_area_mm2 : float
        Area of the design surface, mm^2 (``unreachable_fraction`` in the JSON is the
        unreachable share of it).
    deviation_map : DeviationMap or None
        The field on the grid (not in the JSON, not compared).
    """

    machine: str
    cutter: str
    method: str
    blocks: int
    motion_blocks: int
    tool_instances: int
    pieces: int
    samples: tuple[int, int]
    spacing_mm: tuple[float, float]
    horizon_mm: float
    gouge_tol_mm: float
    requested_scallop_mm: float
    max_gouge: Location | None
    max_excess: Location | None
    max_scallop: Location | None
    unswept_moves: int
    gouging_blocks: tuple[BlockGouge, ...]
    stats: DeviationStats
    joints: JointDeviation
    pairs: int
    timings_s: dict[str, float]
    faces_away_area_mm2: float = 0.0
    unreachable_area_mm2: float = 0.0
    design_area_mm2: float = 0.0
    deviation_map: DeviationMap | None = field(default=None, compare=False, repr=False)

    @property
    def max_gouge_mm(self) -> float:
        """Depth of the deepest gouge, mm (0 when none beyond the tolerance)."""
        return 0.0 if self.max_gouge is None else -self.max_gouge.deviation_mm

    @property
    def max_excess_mm(self) -> float:
        """Largest remaining material within the horizon, mm (NaN when nothing is cut)."""
        return float("nan") if self.max_excess is None else self.max_excess.deviation_mm

    @property
    def max_scallop_mm(self) -> float:
        """Largest scallop away from uncut areas, mm (NaN when there is no such area)."""
        return float("nan") if self.max_scallop is None else self.max_scallop.deviation_mm

    def with_samples_taken_ahead(self, samples_s: float, wait_s: float) -> VerificationReport:
        """The report with the timings of design samples taken ahead in another thread.

        The verification given them timed only handing them over (``samples`` ~0):
        ``samples`` becomes their own time ``samples_s`` where they were taken, the new
        ``samples_wait`` the time ``wait_s`` the verification waited for them, and
        ``total`` counts the wait instead.
        """
        timings: dict[str, float] = {}
        for name, seconds in self.timings_s.items():
            if name == "samples":
                timings.update(samples=float(samples_s), samples_wait=float(wait_s))
            elif name == "total":
                timings[name] = seconds - self.timings_s.get("samples", 0.0) + float(wait_s)
            else:
                timings[name] = seconds
        return replace(self, timings_s=timings)

    def to_dict(self) -> dict[str, Any]:
        """JSON-able form (NaN written as None), without the deviation map."""
        out = asdict(self)
        out.pop("deviation_map", None)
        out["max_gouge_mm"] = self.max_gouge_mm
        out["max_excess_mm"] = self.max_excess_mm
        out["max_scallop_mm"] = self.max_scallop_mm
        out["unreachable_fraction"] = self.unreachable_area_mm2 / max(self.design_area_mm2,
                                                                      1e-300)
        return _clean(out)

    def lines(self) -> list[str]:
        """A human summary, one fact per line."""
        s = self.stats
        out = [
            f"machine {self.machine}, cutter {self.cutter}, dexels along {self.method}",
            f"program: {self.blocks} blocks, {self.motion_blocks} moves "
            f"({self.unswept_moves} before every axis is programmed, not swept), "
            f"{self.tool_instances} tool instances, {self.pieces} swept pieces",
            f"design samples: {self.samples[0]} x {self.samples[1]}, spacing "
            f"{self.spacing_mm[0]:.4g} x {self.spacing_mm[1]:.4g} mm; {self.pairs} pairs tested",
        ]
        if self.max_gouge is None:
            out.append(f"gouge: none deeper than {self.gouge_tol_mm:g} mm")
        else:
            g = self.max_gouge
            out.append(f"gouge: {self.max_gouge_mm:.4f} mm deep at line {g.line} (block "
                       f"{g.block_index}{', rapid' if g.rapid else ''}"
                       f"{', shank' if g.shank else ''}) point "
                       f"({g.point_mm[0]:.3f}, {g.point_mm[1]:.3f}, {g.point_mm[2]:.3f}); "
                       f"area {s.gouge_area_mm2:.4g} mm^2")
        if self.gouging_blocks:
            out.append("  deepest per block: " + ", ".join(
                f"line {b.line} {b.depth_mm:.4f} mm" for b in self.gouging_blocks))
        req = ("" if np.isnan(self.requested_scallop_mm)
               else f" (requested {self.requested_scallop_mm:g} mm)")
        for name, loc in (("scallop", self.max_scallop), ("largest excess", self.max_excess)):
            if loc is not None:
                out.append(f"{name}: {loc.deviation_mm:.4f} mm"
                           f"{req if name == 'scallop' else ''} at line {loc.line} point "
                           f"({loc.point_mm[0]:.3f}, {loc.point_mm[1]:.3f}, "
                           f"{loc.point_mm[2]:.3f})")
        p = s.percentiles_mm
        out.append(f"deviation over the cut area: mean {s.mean_mm:.4f}, rms {s.rms_mm:.4f}, "
                   f"p1 {p['p1']:.4f}, p50 {p['p50']:.4f}, p99 {p['p99']:.4f} mm")
        out.append(f"area: {s.area_mm2:.1f} mm^2, cut {s.cut_area_mm2:.1f}, not cut (more "
                   f"than {self.horizon_mm:g} mm left) {s.uncut_area_mm2:.1f}, hidden "
                   f"{s.hidden_area_mm2:.1f}"
                   + (f", facing away from the tool axis (unreachable, no scallop taken) "
                      f"{self.faces_away_area_mm2:.1f}" if self.faces_away_area_mm2 else "")
                   + (f"; unreachable (facing away or covered by no pass) "
                      f"{self.unreachable_area_mm2:.1f} of {self.design_area_mm2:.1f}"
                      if self.unreachable_area_mm2 else ""))
        j = self.joints
        if j.block_index is not None and j.max_mm > 0.0:
            out.append(f"joint interpolation: tip leaves the chord by up to {j.max_mm:.4f} mm "
                       f"at line {j.line} ({j.rotary_deg:.3g} deg rotary); "
                       f"{j.blocks_over_tol} block(s) over {self.gouge_tol_mm:g} mm")
        return out


def _clean(value: Any) -> Any:
    if isinstance(value, dict):
        return {k: _clean(v) for k, v in value.items()}
    if isinstance(value, list | tuple):
        return [_clean(v) for v in value]
    if isinstance(value, float | np.floating):
        f = float(value)
        return None if not np.isfinite(f) else f
    if isinstance(value, np.integer):
        return int(value)
    if isinstance(value, np.bool_):
        return bool(value)
    return value
