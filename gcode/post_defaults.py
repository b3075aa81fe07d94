"""Defaults of a post request that ``toolpath post --help`` shows (standard library only).

:class:`gcode.post.PostOptions` and :func:`gcode.arcfit.fit_arcs` take their defaults from
here, so the help loads no numpy.
"""

from __future__ import annotations

__all__ = ["DEFAULT_ARC_TOLERANCE_MM", "DEFAULT_CLEARANCE_MM"]

#: Default clearance above the highest point of the path (mm): clears clamps and chips
#: at rapid rate without a long way back down.
DEFAULT_CLEARANCE_MM = 5.0
#: Default arc-fitting tolerance (mm): 5 um, the finest scallop the planner is asked for,
#: five times the 1 um coordinate resolution so rounding of the written arc stays inside.
DEFAULT_ARC_TOLERANCE_MM = 0.005
