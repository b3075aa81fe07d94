"""What a plan achieved, measured on the result: :class:`PlanningReport`.

The scallop and chord figures come from :mod:`toolpath.planning.measure` and
:mod:`toolpath.planning.chord_measure` (independent of the planning formulas); clearances
from the global gouge check; unreachable regions from the reach and shadow tests of 3-axis
plans.
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass, field
from typing import Any

from machines.limits import Violation

from .blunt_edge import BluntFace
from .gouge import GOUGE_TOL_MM
from .rotary_rate import RotaryRates

__all__ = ["PlanningReport", "UnreachableRegion", "UnreachableSpan", "merge_spans"]

#: The rounding reserve and the request less the planned tolerance are the same length
#: (mm) by two routes when the reserve fits in the quarter kept for it: within this
#: round-off (of values ~0.01 mm) no "needs more than the quarter" warning.
_RESERVE_ROUND_OFF_MM = 1e-12


@dataclass(frozen=True)
class UnreachableSpan:
    """A stretch of one pass that is not cut.

    Attributes
    ----------
    pass_index : int
    s : float
        The pass's ``s`` (its mean, for a spiral ring).
    t_start, t_end : float
        Parameter range not cut.
    reason : str
        ``"faces away"`` (the normal turns away from the fixed axis: the far side needs
        another setup or 5-axis) or ``"shadowed"`` (the tool would hit another part of the
        surface) or ``"too short"`` (a reachable stretch too short to cut).
    """

    pass_index: int
    s: float
    t_start: float
    t_end: float
    reason: str


@dataclass(frozen=True)
class UnreachableRegion:
    """Spans of consecutive passes with overlapping ``t`` ranges and the same reason."""

    reason: str
    first_pass: int
    last_pass: int
    s_min: float
    s_max: float
    t_min: float
    t_max: float

    def describe(self) -> str:
        """One line for the report."""
        return (f"{self.reason}: passes {self.first_pass}-{self.last_pass} "
                f"(s {self.s_min:.4f}..{self.s_max:.4f}, t {self.t_min:.4f}..{self.t_max:.4f})")


def merge_spans(spans: list[UnreachableSpan]) -> tuple[UnreachableRegion, ...]:
    """Group spans into regions: same reason, consecutive passes, overlapping ``t``."""
    open_regions: list[list[Any]] = []
    done: list[list[Any]] = []
    for span in sorted(spans, key=lambda x: (x.pass_index, x.t_start)):
        merged = False
        for reg in open_regions:
            if (reg[0] == span.reason and reg[2] >= span.pass_index - 1
                    and span.t_start <= reg[6] and span.t_end >= reg[5]):
                reg[2] = span.pass_index
                reg[3], reg[4] = min(reg[3], span.s), max(reg[4], span.s)
                reg[5], reg[6] = min(reg[5], span.t_start), max(reg[6], span.t_end)
                merged = True
                break
        if not merged:
            open_regions.append([span.reason, span.pass_index, span.pass_index, span.s,
                                 span.s, span.t_start, span.t_end])
        still = []
        for reg in open_regions:
            (still if reg[2] >= span.pass_index - 1 else done).append(reg)
        open_regions = still
    return tuple(UnreachableRegion(*reg) for reg in done + open_regions)


def _fmt(value: float | None, unit: str = "mm", digits: int = 5) -> str:
    if value is None:
        return "not measured"
    if math.isinf(value):
        return "none" if value > 0 else "-inf"
    return f"{value:.{digits}f} {unit}"


@dataclass(frozen=True)
class PlanningReport:
    """Figures of a finishing plan (mm, deg, s).

    Attributes
    ----------
    cutter, axis_mode, linking : str
    scallop_request_mm, chord_tol_mm : float
        What was asked.
    n_passes, n_points, n_cut_points : int
        Passes, toolpath points, and cutter locations on the passes.
    max_scallop_mm : float or None
        Largest scallop measured on the result (``None`` with ``measure=False``): on the
        toolpath as planned, its joints interpolated as the machine does, *before* the
        post rounds them to the G-code's grid. The program as written leaves a scallop up
        to about ``rounding_reserve_mm`` higher (:attr:`written_scallop_bound_mm`), which
        is what ``toolpath verify`` measures: on the dev blade, bull:8:1 in 5 axes on the
        trunnion, 0.0016 mm here and 0.0026 mm verified, where rounding to 0.001 mm and
        0.001 deg moved the cutter by up to 1.8 um.
    scallop_interior_mm : float or None
        The same away from uncut areas (excludes the slivers along unreachable borders).
    scallop_at : tuple of float or None
        ``(t, s)`` of the largest scallop.
    uncut_fraction : float or None
        Area fraction of the surface no cutter came near.
    max_chord_error_mm : float or None
        Largest cutter-to-surface deviation along cutting moves, measured.
    chord_overcut_mm, chord_undercut_mm : float or None
        Its two sides (into the surface / left above it).
    chord_worst_point : int or None
        Toolpath point the worst move arrives at.
    planned_chord_error_mm : float
        Largest cutter-to-surface gap the planner's own chord check estimates on any
        cutting move it kept (the gap model through three gaps per move, or a ball's
        end slopes and one gap).
    n_stalled_moves : int
        Cutting moves the chord check left whole beyond its tolerance because splitting
        them did not shrink their gap and the cutter at their own ends reads it too
        (:data:`~toolpath.planning.passes.STALLED_SHARE`,
        :data:`~toolpath.planning.passes.STALLED_END_SHARE`): mostly a gap misread beside
        an edge, so the measured chord error and ``toolpath verify`` judge them (a move
        whose ends sit on the surface is split on: its gap is the chord's);
        ``stalled_gap_mm`` the largest such planned gap (0: none).
        Their gaps count in ``planned_chord_error_mm``.
    min_clearance_mm : float
        Smallest distance from the cutter to any surface sample away from its contact
        (the global gouge check); ``inf`` beyond the check's horizon; negative is a gouge.
    min_concave_radius_mm : float
        Smallest concave radius of curvature met by a cutter location (``inf``: none).
    cutter_radius_there_mm : float
        The cutter's smallest section radius at that location.
    n_lifted, n_retilted : int
        Cutter locations moved to avoid gouges (``on_gouge``); ``max_lift_mm``.
    unreachable_spans, unreachable_regions : tuple
        What was not cut and why.
    unreachable_fraction : float
        Area fraction of the surface left uncut by the plan's own reach tests.
    max_axis_rate_deg_per_mm : float or None
        Largest tool-axis turn rate along a pass (5-axis).
    cone_pushed : int
        Axes moved out of the singular cone.
    machine : str or None
    travel_violations, rate_violations : tuple of Violation
        Travel (positions) and rate (the feed would be slowed) records, point indices of
        the toolpath.
    estimated_time_s : float or None
        At the machine's rate limits (acceleration ignored).
    length_mm, cutting_length_mm : float
    seconds : dict
        Time per planning stage.
    gouge_tol_mm : float
        Penetration counted as a gouge.
    axis_rate_limit_deg_per_mm : float or None
        The turn-rate limit asked for (5-axis).
    rounding_reserve_mm : float
        How far rounding the joints to the G-code's grid can move the cutter; the plan
        aims for the request less this (at most a quarter of it). The measured figures
        (scallop, chord error) are the toolpath's, before that rounding.
    planned_scallop_mm, planned_chord_tol_mm : float or None
        What the plan aimed for.
    tilt_leaned_points : int
        5-axis: cutter locations whose tool axis was leaned toward +Z to keep the tilt
        joint within its travel; ``max_tilt_lean_deg`` the largest lean, deg.
    max_tilt_deg : float or None
        The largest angle of a tool axis from +Z the plan allowed (the machine's tilt
        reach), deg.
    linking_reason : str
        Why the plan links its passes the way it does (``auto`` resolved).
    rotary_rates : RotaryRates or None
        The machine's rotary joints along the cut: the largest rate (deg/mm of path, deg/s
        at the programmed feed, against the axis' limit) and whether C turns one way
        (5-axis machines; :mod:`~toolpath.planning.rotary_rate`).
    blunt_face : BluntFace or None
        An open blade's unfitted edge face between the sections' last and first points,
        left uncut (:mod:`~toolpath.planning.blunt_edge`).
    n_fold_points : int
        Poses inserted into cutting moves that crossed a fold of the surface
        (:func:`~toolpath.planning.checks.fold_moves`); ``max_fold_lift_mm`` their largest
        lift along the tool axis, mm.
    advice : tuple of str
        Suggestions for a better plan (e.g. a flat end mill whose stepover the staircase
        of its face on slopes keeps tiny).
    """

    cutter: str
    axis_mode: str
    linking: str
    scallop_request_mm: float
    chord_tol_mm: float
    n_passes: int
    n_points: int
    n_cut_points: int
    max_scallop_mm: float | None
    scallop_interior_mm: float | None
    scallop_at: tuple[float, float] | None
    uncut_fraction: float | None
    max_chord_error_mm: float | None
    chord_overcut_mm: float | None
    chord_undercut_mm: float | None
    chord_worst_point: int | None
    planned_chord_error_mm: float
    min_clearance_mm: float
    min_concave_radius_mm: float
    cutter_radius_there_mm: float
    n_lifted: int
    max_lift_mm: float
    n_retilted: int
    unreachable_spans: tuple[UnreachableSpan, ...]
    unreachable_regions: tuple[UnreachableRegion, ...]
    unreachable_fraction: float
    max_axis_rate_deg_per_mm: float | None
    cone_pushed: int
    machine: str | None
    travel_violations: tuple[Violation, ...]
    rate_violations: tuple[Violation, ...]
    estimated_time_s: float | None
    length_mm: float
    cutting_length_mm: float
    seconds: dict[str, float] = field(default_factory=dict)

    gouge_tol_mm: float = GOUGE_TOL_MM
    axis_rate_limit_deg_per_mm: float | None = None
    rounding_reserve_mm: float = 0.0
    planned_scallop_mm: float | None = None
    planned_chord_tol_mm: float | None = None
    advice: tuple[str, ...] = ()
    tilt_leaned_points: int = 0
    max_tilt_lean_deg: float = 0.0
    max_tilt_deg: float | None = None
    linking_reason: str = ""
    rotary_rates: RotaryRates | None = None
    blunt_face: BluntFace | None = None
    n_stalled_moves: int = 0
    stalled_gap_mm: float = 0.0
    n_fold_points: int = 0
    max_fold_lift_mm: float = 0.0

    @property
    def within_request(self) -> bool:
        """Scallop (away from uncut areas), chord error, gouge and travel all as asked."""
        ok = not self.travel_violations and self.min_clearance_mm >= -self.gouge_tol_mm
        if self.scallop_interior_mm is not None:
            ok = ok and self.scallop_interior_mm <= self.scallop_request_mm
        if self.max_chord_error_mm is not None:
            ok = ok and self.max_chord_error_mm <= self.chord_tol_mm
        return bool(ok)

    @property
    def written_scallop_bound_mm(self) -> float | None:
        """About the most scallop the program as written leaves, mm (None: not measured).

        ``max_scallop_mm + rounding_reserve_mm``: rounding a pose's joints to the G-code's
        grid moves every point of the cutter by at most about the reserve (the tip by at
        most the reserve, the rest of the cutter turned with it by the rotary joints' half
        step, ``< 1e-5`` rad, times its few mm from the tip), so the machined surface
        stands at most that much higher along the design normal (a little more where it
        slopes against the normal: ``1 / cos`` of its slope, ``< 1 %`` on a cusp's
        flanks). The reserve itself is the planner's estimate from sample poses
        (:func:`~toolpath.planning.resolution.rounding_reserve_mm`).
        """
        if self.max_scallop_mm is None:
            return None
        return self.max_scallop_mm + self.rounding_reserve_mm

    def lines(self) -> list[str]:
        """The report as text lines."""
        out = [*self._figure_lines(), *self._rounding_lines(), *self._uncut_lines()]
        if self.max_axis_rate_deg_per_mm is not None:
            out.append(self._axis_rate_line())
        if self.rotary_rates is not None:
            out.append(f"rotary joints     {self.rotary_rates.describe()}")
        if self.blunt_face is not None:
            out.append(f"uncut edge face   {self.blunt_face.describe()}")
        if self.tilt_leaned_points:
            out.append(f"tool-axis lean    {self.tilt_leaned_points} points leaned toward +Z "
                       f"by up to {self.max_tilt_lean_deg:.3f} deg (the tilt joint reaches "
                       f"{_fmt(self.max_tilt_deg, unit='deg', digits=2)} from +Z)")
        out.extend(self._machine_lines())
        out.extend(f"advice            {line}" for line in self.advice)
        out.append(f"length            {self.length_mm:.1f} mm "
                   f"({self.cutting_length_mm:.1f} mm feeding)")
        total = sum(self.seconds.values())
        out.append(f"planning time     {total:.2f} s (" + ", ".join(
            f"{k} {v:.2f}" for k, v in self.seconds.items()) + ")")
        return out

    @property
    def scallop_horizon_mm(self) -> float:
        """Height above which the measure counts a scallop as uncut, mm.

        Ten times the request, at least 0.05 mm. A scallop of ``inf`` stands above it:
        where the measure's coarse uncut-area grid missed an uncut sliver, its cusp still
        reads higher than this (:func:`~toolpath.planning.cut_volume.cusp_horizon_mm`).
        """
        from .cut_volume import cusp_horizon_mm

        return cusp_horizon_mm(self.scallop_request_mm)

    def _fmt_scallop(self, value: float | None) -> str:
        """A scallop figure; one beyond the horizon says so (not ``none``)."""
        if value is not None and value == math.inf:
            return f"above {self.scallop_horizon_mm:g} mm (the measure's horizon)"
        return _fmt(value)

    def _figure_lines(self) -> list[str]:
        """What was asked and what the plan achieved: passes, scallop, chord, clearance."""
        return [
            f"cutter            {self.cutter}",
            f"axis / linking    {self.axis_mode} / {self.linking}"
            + (f" ({self.linking_reason})" if self.linking_reason else ""),
            f"passes            {self.n_passes}",
            f"points            {self.n_points} ({self.n_cut_points} on passes)",
            f"scallop           {self._fmt_scallop(self.max_scallop_mm)} on the toolpath, "
            f"before the G-code's rounding (request {self.scallop_request_mm:g} mm; away from "
            f"uncut areas {self._fmt_scallop(self.scallop_interior_mm)})",
            f"chord error       {_fmt(self.max_chord_error_mm)} "
            f"(tolerance {self.chord_tol_mm:g} mm; overcut {_fmt(self.chord_overcut_mm)}, "
            f"undercut {_fmt(self.chord_undercut_mm)})",
            f"clearance         {_fmt(self.min_clearance_mm)} to the surface away from "
            f"the contacts (resolved up to 0.1 mm)",
            f"concave radius    {_fmt(self.min_concave_radius_mm, digits=3)} smallest met "
            f"(cutter {self.cutter_radius_there_mm:.3f} mm there)",
        ]

    def _rounding_lines(self) -> list[str]:
        """The G-code grid's rounding reserve, and a warning when it needs more than it has."""
        if not self.rounding_reserve_mm:
            return []
        out = [f"G-code grid       rounding moves the cutter up to "
               f"{self.rounding_reserve_mm:.5f} mm; planned for scallop "
               f"{_fmt(self.planned_scallop_mm)}, chord "
               f"{_fmt(self.planned_chord_tol_mm)}"]
        bound = self.written_scallop_bound_mm
        if bound == math.inf:
            out.append(f"  as written (rounded) the scallop stands above the measure's horizon "
                       f"({self.scallop_horizon_mm:g} mm) as planned "
                       f"(toolpath verify measures the program)")
        elif bound is not None:
            out.append(f"  as written (rounded) the scallop may stand up to that much higher: "
                       f"at most about {_fmt(bound)} (toolpath verify measures the program)")
        short = min(self.scallop_request_mm - (self.planned_scallop_mm or 0.0),
                    self.chord_tol_mm - (self.planned_chord_tol_mm or 0.0))
        if self.rounding_reserve_mm > short + _RESERVE_ROUND_OFF_MM:
            out.append(f"  the grid needs more than the quarter of the request kept for "
                       f"it: the written program may exceed the request by up to "
                       f"{self.rounding_reserve_mm - short:.5f} mm (write more decimals, "
                       f"or ask for less)")
        return out

    def _uncut_lines(self) -> list[str]:
        """Area left uncut, cutter locations moved off gouges and folds, unreachable regions."""
        out = []
        if self.n_stalled_moves:
            out.append(f"chord check       {self.n_stalled_moves} move(s) left whole: splitting "
                       f"did not shrink their planned gap, read at their ends too "
                       f"(up to {self.stalled_gap_mm:.4f} mm: a gap misread beside an edge, "
                       f"or a real one; the measured chord error above and `toolpath "
                       f"verify` judge them)")
        if self.uncut_fraction is not None:
            out.append(f"uncut area        {100 * self.uncut_fraction:.2f} % of the surface")
        if self.n_lifted or self.n_retilted:
            out.append(f"gouge avoidance   {self.n_lifted} lifted (max {self.max_lift_mm:.4f} "
                       f"mm), {self.n_retilted} re-tilted")
        if self.n_fold_points:
            out.append(f"folds             {self.n_fold_points} pose(s) inserted into moves "
                       f"across a fold (max lift {self.max_fold_lift_mm:.4f} mm)")
        if self.unreachable_regions:
            out.append(f"unreachable       {100 * self.unreachable_fraction:.1f} % of the "
                       f"surface in {len(self.unreachable_regions)} region(s):")
            out.extend(f"  {reg.describe()}" for reg in self.unreachable_regions[:10])
        return out

    def _axis_rate_line(self) -> str:
        """The largest tool-axis turn rate, against its limit (5-axis)."""
        rate = self.max_axis_rate_deg_per_mm
        limit = ("" if self.axis_rate_limit_deg_per_mm is None
                 else f" (limit {self.axis_rate_limit_deg_per_mm:g}"
                 + ("; exceeded: the slowest turn within max_lean_deg of the normal, a "
                    "flat or bull-nose face never leaning less than the lead)"
                    if rate > self.axis_rate_limit_deg_per_mm else ")"))
        return (f"axis turn rate    {rate:.3f} deg/mm max" + limit
                + (f", {self.cone_pushed} axes kept off the singular cone"
                   if self.cone_pushed else ""))

    def _machine_lines(self) -> list[str]:
        """The machine: travel and feed-rate violations, estimated time (none: no machine)."""
        if self.machine is None:
            return []
        out = [f"machine           {self.machine}"]
        out.extend(f"  travel: {v.message()}" for v in self.travel_violations)
        out.extend(f"  feed limited: {v.message()}" for v in self.rate_violations[:5])
        if self.estimated_time_s is not None:
            out.append(f"estimated time    {self.estimated_time_s / 60.0:.2f} min")
        return out

    def as_dict(self) -> dict[str, Any]:
        """JSON-able dict (infinities as None).

        ``scallop_above_horizon`` tells a scallop beyond :attr:`scallop_horizon_mm` from one
        not measured.
        """
        data = asdict(self)
        data["scallop_horizon_mm"] = self.scallop_horizon_mm
        data["scallop_above_horizon"] = self.max_scallop_mm == math.inf
        data["travel_violations"] = [v.message() for v in self.travel_violations]
        data["rate_violations"] = [v.message() for v in self.rate_violations]
        data["within_request"] = self.within_request
        data["written_scallop_bound_mm"] = self.written_scallop_bound_mm

        def clean(value: Any) -> Any:
            if isinstance(value, float) and not math.isfinite(value):
                return None
            if isinstance(value, dict):
                return {k: clean(v) for k, v in value.items()}
            if isinstance(value, list | tuple):
                return [clean(v) for v in value]
            return value

        return clean(data)
