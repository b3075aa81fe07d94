"""Errors of the planner, narrow subclasses of :class:`toolpath.errors.ToolpathError`.

Every message names the parameter, or the pass and point (and surface parameters) where the
problem is, so a machinist can find it on the part.
"""

from __future__ import annotations

from ..errors import ToolpathError

__all__ = ["GougeError", "PlanningError", "UnreachableRegionError"]


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
