"""Finishing options: one frozen, validated record; every default with its reason.

Errors name the keyword (the CLI flag names map one to one) and show the value with ``!r``.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, fields
from enum import StrEnum
from typing import Any, Final

import numpy as np

from ..errors import InvalidParameterError
from ..tolerances import NULL_VECTOR
from .cutters import Cutter, CutterKind
from .defaults import DEFAULT_FEED_MM_PER_MIN
from .resolution import GOUGE_TOL_MM, MAX_RESERVE_SHARE

__all__ = [
    "CONCAVE_UNDERCUT_SHARE",
    "DEFAULT_FEED_MM_PER_MIN",
    "TILT_MARGIN_DEG",
    "AxisMode",
    "FinishingOptions",
    "Linking",
    "OnGouge",
    "OnLimit",
    "PlannedOptions",
    "ProgressCallback",
    "chosen_linking",
]

ProgressCallback = Callable[[str, float], None]
"""``progress(stage, fraction)``: ``fraction`` in [0, 1] over the whole plan."""

CONCAVE_UNDERCUT_SHARE: Final[float] = 0.25
"""Share of the scallop allowance given to the chord undercut where passes are concave.

On a concave pass the straight moves stand above the surface (by up to the chord
deviation) and lift the cusps beside them by as much; so there the moves may stand at
most ``min(chord_tol_mm, share * scallop_mm)`` above the surface and the passes are spaced
for ``scallop_mm`` minus that, keeping the material left anywhere within ``scallop_mm``.
A quarter costs about 13 % more passes on concave areas and nothing elsewhere."""


TILT_MARGIN_DEG: Final[float] = 0.05
"""Room kept inside the tilt joint's travel when axes are leaned back, deg: for rounding to
the G-code's 0.001 deg grid, and for the axes the post puts inside moves (the normalized
mean of the ends' axes; between two axes ``d`` apart at the limit ``th`` beyond 90 deg it
bows out by ``|cot th| d^2 / 8``: 0.03 deg for axes 5 deg apart at 120 deg; moves along a
pass turning further are corrected by leaning their ends, links between passes are not)."""


class AxisMode(StrEnum):
    """How the tool axis is chosen."""

    FIXED = "3"  #: one fixed axis (3-axis machine or 3+2 positioning)
    LEAD_TILT = "lead-tilt"  #: from the surface frame with lead and tilt (5-axis)


class Linking(StrEnum):
    """How passes follow each other."""

    AUTO = "auto"  #: spiral round closed sections under a 5-axis tool axis, else zigzag
    SPIRAL = "spiral"  #: closed sections: one continuous cut climbing in s
    ZIGZAG = "zigzag"  #: alternate directions, short links at the ends
    ONEWAY = "oneway"  #: every pass in the same direction, retract between


class OnGouge(StrEnum):
    """What to do where the cutter would cut into the surface."""

    RAISE = "raise"  #: stop with a GougeError naming pass and point
    LIFT = "lift"  #: move the cutter up its axis until clear (leaves material)
    RETILT = "retilt"  #: 5-axis: try other lead/tilt angles at those points


class OnLimit(StrEnum):
    """What to do with machine travel violations."""

    RAISE = "raise"
    REPORT = "report"


def chosen_linking(linking: Linking, closed_t: bool, axis_mode: AxisMode
                   ) -> tuple[Linking, str]:
    """The linking a plan uses and why (``auto`` resolved).

    ``auto`` is what blade shops do: round a closed blade a 5-axis tool axis can follow
    the whole section, so one continuous cut climbs in s (spiral: the rotary table turns
    one way, no retracts); an open surface, or a fixed (3-axis) axis that reaches only one
    side, is cut pass by pass (zigzag).
    """
    if linking is not Linking.AUTO:
        return linking, "as asked (--linking)"
    if closed_t and axis_mode is AxisMode.LEAD_TILT:
        return Linking.SPIRAL, "auto: closed sections under a 5-axis tool axis"
    if closed_t:
        return Linking.ZIGZAG, "auto: a fixed (3-axis) tool axis reaches one side only"
    return Linking.ZIGZAG, "auto: open sections"


def _choice(enum: type[StrEnum], value: Any, name: str) -> Any:
    aliases = {"3-axis": "3", "3axis": "3", "fixed": "3", "5": "lead-tilt",
               "5-axis": "lead-tilt", "one-way": "oneway", "zig-zag": "zigzag"}
    text = aliases.get(str(value).lower(), str(value).lower())
    try:
        return enum(text)
    except ValueError:
        raise InvalidParameterError(
            f"{name} must be one of {[e.value for e in enum]}, got {value!r}") from None


def _length(value: Any, name: str, *, allow_zero: bool = False) -> float:
    try:
        out = float(value)
    except (TypeError, ValueError):
        raise InvalidParameterError(f"{name} must be a number in mm, got {value!r}") from None
    if not math.isfinite(out) or out < 0.0 or (out == 0.0 and not allow_zero):
        bound = ">= 0" if allow_zero else "> 0"
        raise InvalidParameterError(f"{name} must be a finite length {bound} mm, got {value!r}")
    return out


def _angle(value: Any, name: str, limit: float) -> float:
    try:
        out = float(value)
    except (TypeError, ValueError):
        raise InvalidParameterError(f"{name} must be an angle in deg, got {value!r}") from None
    if not math.isfinite(out) or abs(out) > limit:
        raise InvalidParameterError(
            f"{name} must be a finite angle within +/-{limit:g} deg, got {value!r}")
    return out


@dataclass(frozen=True)
class PlannedOptions:
    """What a plan works to (:meth:`FinishingOptions.resolved`), in mm, mm/min and deg.

    The request stays in :class:`FinishingOptions` (``scallop_mm``, ``chord_tol_mm``: what
    the result is measured and reported against); the planned tolerances here are what the
    passes and the points along them are laid out for.

    Attributes
    ----------
    planned_scallop_mm, planned_chord_tol_mm : float
        The request less the rounding reserve (:mod:`~toolpath.planning.resolution`).
    undercut_mm : float
        Height the moves may stand above a concave surface:
        ``min(planned_chord_tol_mm, CONCAVE_UNDERCUT_SHARE * planned_scallop_mm)``.
    plunge_feed_mm_per_min, lead_radius_mm, link_max_mm, gouge_sample_mm : float
    axis_smoothing_mm, max_segment_mm, extend_mm : float
        The options of the same name with their cutter-dependent defaults filled in.
    max_tilt_deg : float
        Largest tilt of the tool axis from the workpiece +Z the plan keeps (``inf``: none).
    """

    planned_scallop_mm: float
    planned_chord_tol_mm: float
    undercut_mm: float
    plunge_feed_mm_per_min: float
    lead_radius_mm: float
    link_max_mm: float
    gouge_sample_mm: float
    axis_smoothing_mm: float
    max_segment_mm: float
    extend_mm: float
    max_tilt_deg: float = math.inf


@dataclass(frozen=True)
class FinishingOptions:
    """Everything :func:`~toolpath.planning.plan_finishing` can be told (mm, deg, mm/min).

    Attributes
    ----------
    scallop_mm, chord_tol_mm : float
        Requested cusp height between passes and chord deviation along them (> 0 and
        below the cutter radius).
    axis_mode : AxisMode
        ``"3"`` (fixed axis) or ``"lead-tilt"``.
    lead_deg, tilt_deg : float
        Lead (forward lean) and tilt (left lean) in the pass frame, within +/-80 deg.
    linking : Linking
        ``auto`` (default: ``spiral`` for closed sections under ``axis_mode="lead-tilt"``,
        ``zigzag`` otherwise; :func:`chosen_linking`), ``spiral`` (closed sections only),
        ``zigzag`` or ``oneway``.
    fixed_axis : tuple of 3 float
        The tool axis in 3-axis mode (unit; default +Z of the workpiece).
    feed_mm_per_min, plunge_feed_mm_per_min : float
        Cutting feed; plunge feed (default a quarter of the feed: plunging loads the
        cutter's centre, which cuts worst).
    clearance_mm : float
        Height of the clearance plane above the part's highest point (3-axis) or margin
        of the clearance sphere beyond the part's bounding sphere (5-axis). 5 mm clears
        clamps' screw heads on a vice-held blade.
    approach_mm : float
        Rapid down to this height above the lead-in start, then plunge (2 mm).
    lead_radius_mm, lead_angle_deg : float
        Lead arcs (default: the cutter radius, 90 deg: a tangential quarter circle).
    extend_mm : float or None
        Straight extension of passes past open edges (0: none). Default: none for a ball;
        the core radius ``R - r`` for flat and bull-nose cutters, whose side that leaves
        the cusps trails or leads the contact along the pass by up to that (with a lead,
        the cusp at the end of a pass that stops at the edge would stand 10 % higher).
    link_max_mm : float
        Longest direct zig-zag / one-way link move (default: the cutter diameter).
    on_gouge : OnGouge
        ``raise`` / ``lift`` / ``retilt``.
    gouge_tol_mm : float
        Penetration counted as a gouge (:data:`~toolpath.planning.gouge.GOUGE_TOL_MM`).
    gouge_sample_mm : float
        Surface sample spacing of the global gouge check (default ``min(R/4, 1)``: a
        pocket narrower than about two samples could hide between them).
    check_flutes : bool
        Check the whole flute length, not only the cutting end, in the global check.
    min_cone_deg : float or None
        Keep tool axes at least this far from the workpiece +Z (the singular cone of
        table-table and head-table machines).
    axis_smoothing_mm : float
        Half-width of the axis smoothing window (default: the cutter radius); passes still
        turning faster than ``max_axis_rate_deg_per_mm`` are then rate limited.
    max_axis_rate_deg_per_mm : float or None
        Turn-rate limit of the tool axis along a pass (default 10 deg/mm: a 90 deg turn
        over 9 mm of travel, which a 5-axis rotary follows at full feed).
    max_lean_deg : float
        Largest angle between the tool axis and the surface normal after smoothing
        (60 deg: a ball's contact then stays 30 deg below its equator, clear of the shank).
    max_tilt_deg : float or None
        Largest angle of the tool axis from the workpiece +Z (5-axis): axes further out are
        leaned back toward +Z, smoothly and within ``max_lean_deg`` of the normal
        (:func:`~toolpath.planning.tool_axis.lean_within_tilt`). Default: what the
        machine's tilt joint reaches (:func:`machines.kinematics.tilt_reach_deg`) less
        :data:`TILT_MARGIN_DEG`; no limit without a machine.
    reach_margin_deg : float
        3-axis: a surface point is reachable when its normal is at least this far above
        the plane perpendicular to the fixed axis (0: up to vertical walls).
    max_segment_mm : float
        Longest move along a pass (default two cutter diameters: keeps 5-axis
        interpolation and gouge sampling faithful on flat stretches).
    probe_t : int or None
        Uniform probe count along ``t`` for the spacing and the chord density (default:
        three per point of the densest pass, from a coarse probe, at least 129 and at most
        513: a sample every 1 to 0.25 mm on a 130 mm blade section); intervals where the
        normal turns more than 2 deg get more, evenly (a leading edge); the chord check
        adds points the probes miss.
    probe_s : int or None
        Probe levels along ``s`` (default: three per pass, at least 65, at most 129; the
        allowed step varies slowly across the span).
    on_limit : OnLimit
        Machine travel violations: ``raise`` (default) or ``report``.
    coordinate_step_mm, angle_step_deg : float
        The grid the G-code writes joints to (0.001 mm and 0.001 deg: the dialects' 3
        decimals). The plan keeps the request minus what rounding to it can move the
        cutter (:mod:`~toolpath.planning.resolution`); 0 plans for the exact request.
    max_points : int
        Refuse plans with more cutter locations (20 million: about 1.5 GB of arrays).
    measure : bool
        Measure scallop and chord error on the result (default True).
    progress : callable or None
        ``progress(stage, fraction)``.
    """

    scallop_mm: float
    chord_tol_mm: float
    axis_mode: AxisMode = AxisMode.FIXED
    lead_deg: float = 0.0
    tilt_deg: float = 0.0
    linking: Linking = Linking.AUTO
    fixed_axis: tuple[float, float, float] = (0.0, 0.0, 1.0)
    feed_mm_per_min: float = DEFAULT_FEED_MM_PER_MIN
    plunge_feed_mm_per_min: float | None = None
    clearance_mm: float = 5.0
    approach_mm: float = 2.0
    lead_radius_mm: float | None = None
    lead_angle_deg: float = 90.0
    extend_mm: float | None = None
    link_max_mm: float | None = None
    on_gouge: OnGouge = OnGouge.RAISE
    gouge_tol_mm: float = GOUGE_TOL_MM
    gouge_sample_mm: float | None = None
    check_flutes: bool = True
    min_cone_deg: float | None = None
    axis_smoothing_mm: float | None = None
    max_axis_rate_deg_per_mm: float | None = 10.0
    max_lean_deg: float = 60.0
    max_tilt_deg: float | None = None
    reach_margin_deg: float = 0.0
    max_segment_mm: float | None = None
    probe_t: int | None = None
    probe_s: int | None = None
    on_limit: OnLimit = OnLimit.RAISE
    coordinate_step_mm: float = 0.001
    angle_step_deg: float = 0.001
    max_points: int = 20_000_000
    measure: bool = True
    progress: ProgressCallback | None = None

    def __post_init__(self) -> None:
        """Check every option (naming it), and store the checked values."""
        put = object.__setattr__
        put(self, "scallop_mm", _length(self.scallop_mm, "scallop_mm"))
        put(self, "chord_tol_mm", _length(self.chord_tol_mm, "chord_tol_mm"))
        put(self, "axis_mode", _choice(AxisMode, self.axis_mode, "axis_mode"))
        put(self, "linking", _choice(Linking, self.linking, "linking"))
        put(self, "on_gouge", _choice(OnGouge, self.on_gouge, "on_gouge"))
        put(self, "on_limit", _choice(OnLimit, self.on_limit, "on_limit"))
        self._check_angles()
        self._check_fixed_axis()
        self._check_lengths()
        self._check_steps()
        self._check_combinations()

    def _check_angles(self) -> None:
        """Lead, tilt, lead-in angle, lean, reach margin and tilt limit, deg."""
        put = object.__setattr__
        put(self, "lead_deg", _angle(self.lead_deg, "lead_deg", 80.0))
        put(self, "tilt_deg", _angle(self.tilt_deg, "tilt_deg", 80.0))
        put(self, "lead_angle_deg", _angle(self.lead_angle_deg, "lead_angle_deg", 180.0))
        put(self, "max_lean_deg", _angle(self.max_lean_deg, "max_lean_deg", 85.0))
        if self.max_lean_deg <= 0.0:
            raise InvalidParameterError(f"max_lean_deg must be > 0 deg, got "
                                        f"{self.max_lean_deg!r}")
        if self.axis_mode is AxisMode.LEAD_TILT and np.degrees(np.arccos(
                np.cos(np.radians(self.lead_deg)) * np.cos(np.radians(self.tilt_deg)))
        ) > self.max_lean_deg:
            raise InvalidParameterError(
                f"lead_deg={self.lead_deg!r} and tilt_deg={self.tilt_deg!r} lean the tool "
                f"more than max_lean_deg={self.max_lean_deg!r} from the normal")
        put(self, "reach_margin_deg", _angle(self.reach_margin_deg, "reach_margin_deg", 89.0))
        if self.max_tilt_deg is not None:
            put(self, "max_tilt_deg", _angle(self.max_tilt_deg, "max_tilt_deg", 180.0))
            if self.max_tilt_deg <= 0.0:
                raise InvalidParameterError(
                    f"max_tilt_deg must be > 0 deg, got {self.max_tilt_deg!r}")

    def _check_fixed_axis(self) -> None:
        """The fixed tool axis: a non-zero 3-vector, stored unit."""
        put = object.__setattr__
        axis = np.asarray(self.fixed_axis, dtype=float)
        if axis.shape != (3,) or not np.isfinite(axis).all() or np.linalg.norm(axis) < NULL_VECTOR:
            raise InvalidParameterError(
                f"fixed_axis must be a non-zero 3-vector, got {self.fixed_axis!r}")
        axis = axis / np.linalg.norm(axis)
        put(self, "fixed_axis", (float(axis[0]), float(axis[1]), float(axis[2])))

    def _check_lengths(self) -> None:
        """Feeds, clearances, tolerances and lengths: positive (or zero where allowed)."""
        put = object.__setattr__
        for name in ("feed_mm_per_min", "clearance_mm"):
            put(self, name, _length(getattr(self, name), name))
        for name in ("approach_mm", "gouge_tol_mm", "coordinate_step_mm"):
            put(self, name, _length(getattr(self, name), name, allow_zero=True))
        if self.extend_mm is not None:
            put(self, "extend_mm", _length(self.extend_mm, "extend_mm", allow_zero=True))
        for name in ("plunge_feed_mm_per_min", "lead_radius_mm", "link_max_mm",
                     "gouge_sample_mm", "axis_smoothing_mm", "max_segment_mm",
                     "max_axis_rate_deg_per_mm"):
            value = getattr(self, name)
            if value is not None:
                zero_ok = name in ("lead_radius_mm", "link_max_mm", "axis_smoothing_mm")
                put(self, name, _length(value, name, allow_zero=zero_ok))

    def _check_steps(self) -> None:
        """The G-code's angle step, the cone kept out of, the probe grid and point budget."""
        put = object.__setattr__
        put(self, "angle_step_deg", _angle(self.angle_step_deg, "angle_step_deg", 1.0))
        if self.angle_step_deg < 0.0:
            raise InvalidParameterError(
                f"angle_step_deg must be >= 0 deg, got {self.angle_step_deg!r}")
        if self.min_cone_deg is not None:
            put(self, "min_cone_deg", _angle(self.min_cone_deg, "min_cone_deg", 60.0))
            if self.min_cone_deg < 0.0:
                raise InvalidParameterError(
                    f"min_cone_deg must be >= 0 deg, got {self.min_cone_deg!r}")
        if self.probe_t is not None and (not isinstance(self.probe_t, int)
                                         or self.probe_t < 17):
            raise InvalidParameterError(f"probe_t must be an integer >= 17 or None (from the "
                                        f"plan), got {self.probe_t!r}")
        if self.probe_s is not None and (not isinstance(self.probe_s, int)
                                         or self.probe_s < 9):
            raise InvalidParameterError(f"probe_s must be an integer >= 9, got "
                                        f"{self.probe_s!r}")
        if not isinstance(self.max_points, int) or self.max_points < 2:
            raise InvalidParameterError(f"max_points must be an integer >= 2, got "
                                        f"{self.max_points!r}")

    def _check_combinations(self) -> None:
        """Options that need another: lead and tilt need 5-axis, and so does re-tilting."""
        if self.axis_mode is AxisMode.FIXED and (self.lead_deg or self.tilt_deg):
            raise InvalidParameterError(
                f"lead_deg={self.lead_deg!r} and tilt_deg={self.tilt_deg!r} need "
                "axis_mode='lead-tilt'; a fixed (3-axis) tool axis has no lead or tilt")
        if self.on_gouge is OnGouge.RETILT and self.axis_mode is AxisMode.FIXED:
            raise InvalidParameterError(
                "on_gouge='retilt' needs axis_mode='lead-tilt' (a 3-axis tool cannot tilt); "
                "use 'lift' or 'raise'")

    def check_cutter(self, cutter: Cutter) -> None:
        """Refuse requests that are absurd for this cutter (naming the parameter)."""
        big = cutter.radius_mm
        for name in ("scallop_mm", "chord_tol_mm"):
            value = getattr(self, name)
            if value >= big:
                raise InvalidParameterError(
                    f"{name}={value!r} mm is not smaller than the cutter radius {big:g} mm "
                    f"({cutter.spec}, diameter {cutter.diameter_mm:g} mm): a finishing "
                    f"tolerance must be a small fraction of the cutter (typically "
                    f"0.001-0.05 mm)")

    def resolved(self, cutter: Cutter, reserve_mm: float = 0.0, *,
                 max_tilt_deg: float = math.inf) -> PlannedOptions:
        """What the plan works to (:class:`PlannedOptions`), defaults filled for ``cutter``.

        The planned tolerances are the request less ``reserve_mm`` (room for the G-code's
        rounding), at most :data:`~toolpath.planning.resolution.MAX_RESERVE_SHARE` of it;
        ``max_tilt_deg`` is the tilt cap the plan keeps (``inf``: none).
        """
        big = cutter.radius_mm
        scallop = self.scallop_mm - min(reserve_mm, MAX_RESERVE_SHARE * self.scallop_mm)
        chord = self.chord_tol_mm - min(reserve_mm, MAX_RESERVE_SHARE * self.chord_tol_mm)
        return PlannedOptions(
            planned_scallop_mm=scallop,
            planned_chord_tol_mm=chord,
            undercut_mm=min(chord, CONCAVE_UNDERCUT_SHARE * scallop),
            plunge_feed_mm_per_min=self.plunge_feed_mm_per_min or self.feed_mm_per_min / 4,
            lead_radius_mm=big if self.lead_radius_mm is None else self.lead_radius_mm,
            link_max_mm=2.0 * big if self.link_max_mm is None else self.link_max_mm,
            gouge_sample_mm=(min(big / 4.0, 1.0) if self.gouge_sample_mm is None
                             else self.gouge_sample_mm),
            axis_smoothing_mm=(big if self.axis_smoothing_mm is None
                               else self.axis_smoothing_mm),
            max_segment_mm=(4.0 * big if self.max_segment_mm is None
                            else self.max_segment_mm),
            extend_mm=((0.0 if cutter.kind is CutterKind.BALL
                        else big - cutter.corner_radius_mm)
                       if self.extend_mm is None else self.extend_mm),
            max_tilt_deg=max_tilt_deg,
        )

    def summary(self) -> dict[str, str]:
        """The options as strings (for toolpath metadata), without the callback."""
        return {f.name: str(getattr(self, f.name)) for f in fields(self)
                if f.name != "progress"}
