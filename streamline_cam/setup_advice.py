"""Whether a saved surface, as ``toolpath plan`` places it, faces a 5-axis machine's spindle.

``toolpath run`` places the measured points itself (:func:`toolpath.placement.place_points`);
``toolpath plan`` takes a fitted surface where its points were, unless ``--rotate`` and
``--on-table`` say otherwise. A blade fitted in its engine frame may then face the table:
wherever its outward normal stands further from +Z than the tilt joint reaches, the
planner leans the tool back toward +Z (up to 97 deg off the lead and tilt on the DCA rotor
as fitted, trunnion-ac) and still reports a plan. :func:`placement_warning` says so, with
the ``--rotate`` of the upright setup ``toolpath run`` takes, when that setup faces the
spindle clearly better.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from toolpath.placement import place_points
from toolpath.planning.setup import PlacedSurface, spec_from_rotation
from toolpath.surface import ParametricSurface
from toolpath.vectors import row_lengths

__all__ = ["FACING_AWAY_SHARE", "away_share", "placement_warning", "upright_advice",
           "upright_rotation"]

#: The share of the surface's area facing beyond the tilt joint's reach from which the
#: part reads as not placed for the machine (the bundled blades as ``toolpath run`` places
#: them: 0 to 0.3 %; the DCA rotor as fitted: 26 %) ...
FACING_AWAY_SHARE = 0.02
#: ... when the upright setup would leave at most this share of what it does now.
UPRIGHT_GAIN = 0.5
#: Grid of ``(t, s)`` samples judged (area-weighted by ``|X_t x X_s|``).
_SAMPLES = 65


def away_share(surface: ParametricSurface, max_tilt_deg: float) -> float:
    """The share of the surface's area whose outward normal is over ``max_tilt_deg`` from +Z."""
    g = np.linspace(0.0, 1.0, _SAMPLES)
    t, s = np.meshgrid(g, g, indexing="ij")
    parts = surface.partials_many(t.ravel(), s.ravel(), ((1, 0), (0, 1)))
    normal = surface.orientation * np.cross(parts[1, 0], parts[0, 1])
    area = row_lengths(normal)
    cos_z = normal[:, 2] / np.maximum(area, 1e-300)
    away = cos_z < np.cos(np.radians(max_tilt_deg))
    total = float(area.sum())
    return float(area[away].sum() / total) if total > 0.0 else 0.0


def upright_rotation(surface: ParametricSurface) -> NDArray[np.float64]:
    """The rotation of ``toolpath run``'s upright setup (span along +Z, hub down)."""
    g = np.linspace(0.0, 1.0, _SAMPLES)
    # sections hub to tip along the first axis, as place_points reads them
    points = surface(g, g, grid=True).transpose(1, 0, 2)
    return place_points(points, mode="upright")[1].rotation


def upright_advice(loaded: ParametricSurface, placed: ParametricSurface,
                   max_tilt_deg: float) -> tuple[float, str] | None:
    """The share of ``placed`` facing away, and the upright setup's ``--rotate`` advice.

    None when at most :data:`FACING_AWAY_SHARE` faces away, or when the upright setup of
    ``loaded`` (the surface as saved) would not leave at most :data:`UPRIGHT_GAIN` of it.
    """
    now = away_share(placed, max_tilt_deg)
    if now < FACING_AWAY_SHARE:
        return None
    rotation = upright_rotation(loaded)
    upright = away_share(PlacedSurface(loaded, rotation), max_tilt_deg)
    if upright > UPRIGHT_GAIN * now:
        return None
    spec = spec_from_rotation(rotation)
    flags = f"--rotate '{spec}' --on-table" if spec else "--on-table without --rotate"
    return now, (f"the part is not placed for the machine ('toolpath run' places it): "
                 f"from the surface as saved, {flags} stands it upright, span along Z "
                 f"({100 * upright:.1f} % of it then faces away, {100 * now:.0f} % now)")


def placement_warning(loaded: ParametricSurface, placed: ParametricSurface,
                      max_tilt_deg: float | None, leaned_points: int, max_lean_deg: float,
                      n_points: int) -> str | None:
    """A warning when the plan leaned tool axes and ``placed`` faces away from the spindle.

    ``max_tilt_deg`` is the tilt joint's reach from +Z (None or infinite: no warning);
    the leaned points and their largest lean as the plan reports them.
    """
    if max_tilt_deg is None or not np.isfinite(max_tilt_deg) or not leaned_points:
        return None
    advice = upright_advice(loaded, placed, max_tilt_deg)
    if advice is None:
        return None
    now, text = advice
    return (f"{100 * now:.0f} % of the surface faces further from +Z than the tilt joint "
            f"reaches ({max_tilt_deg:.2f} deg): {leaned_points} of {n_points} points "
            f"leaned their tool up to {max_lean_deg:.1f} deg toward +Z; {text}")
