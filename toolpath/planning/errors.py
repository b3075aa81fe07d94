"""Errors of the planner, narrow subclasses of :class:`toolpath.errors.ToolpathError`.

Every message names the parameter, or the pass and point (and surface parameters) where the
problem is, so a machinist can find it on the part.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import TYPE_CHECKING, Any

from machines.errors import TravelLimitError

from ..errors import ToolpathError

if TYPE_CHECKING:
    from machines.limits import Violation

__all__ = [
    "GougeError",
    "PlanTravelLimitError",
    "PlanningError",
    "UnreachableRegionError",
    "too_many_points",
]


class PlanningError(ToolpathError):
    """A finishing or roughing plan that cannot be made as asked."""


class GougeError(PlanningError):
    """The cutter would cut into the surface (``on_gouge="raise"``).

    Attributes
    ----------
    pass_index : int or None
        0-based pass, when the gouge is on a pass (``None`` for a surface-wide check).
    point_index : int or None
        0-based point within the pass, or within the toolpath for linking moves.
    t, s : float or None
        Surface parameters of the contact (or of the offending surface sample).
    depth_mm : float
        How far the cutter is inside the surface, mm (> 0).
    """

    def __init__(self, message: str, *, pass_index: int | None = None,
                 point_index: int | None = None, t: float | None = None,
                 s: float | None = None, depth_mm: float = 0.0) -> None:
        super().__init__(message)
        self.pass_index = pass_index
        self.point_index = point_index
        self.t = t
        self.s = s
        self.depth_mm = depth_mm


class UnreachableRegionError(PlanningError):
    """Nothing of the surface can be cut with the chosen tool axis."""


class PlanTravelLimitError(TravelLimitError):
    """A finishing plan leaves a machine axis's travel (a :class:`MachineError`).

    The message is the first violation's, followed by where it is on the plan (pass,
    point, surface parameters); ``violations`` lists them all.
    """

    def __init__(self, violations: Sequence[Violation], where: str) -> None:
        super().__init__(violations)
        self.where = where
        self.args = (f"{self.args[0]}; {where}",)


def too_many_points(opts: Any, n: int) -> PlanningError:
    """The error for a plan beyond ``opts.max_points`` cutter locations (names the knobs)."""
    return PlanningError(
        f"the plan needs more than max_points={opts.max_points} cutter locations "
        f"({n} so far): raise --scallop (scallop_mm={opts.scallop_mm!r}) or --chord-tol "
        f"(chord_tol_mm={opts.chord_tol_mm!r}), or max_points")
