"""A spiral's tool axes turned about +Z one way only, so the rotary table never turns back.

Round a closed blade the surface normal's azimuth about the part's span axis (+Z, the C
table's axis once the part stands upright) grows by a turn per ring, but not steadily: on
a concave pressure side it turns back by the camber (15-20 deg on a compressor rotor), and
a C table following it would reverse there, every ring (backlash marks, a reversal the
controller must stop for). :func:`one_way_azimuth` takes the axes' unwrapped azimuth
``u`` along the cut (signed so that it grows overall) and replaces it by the mean of its
running maximum and its running minimum from the end,
``u* = (max_{j <= i} u_j + min_{j >= i} u_j) / 2``: both are non-decreasing, so ``u*`` is,
it equals ``u`` wherever ``u`` is already monotone, departs from it by at most half of a
back-turn, and turns no faster than ``u`` (its slope is the mean of 0 or ``u'``). Each
axis is turned about +Z by ``u* - u`` (its angle from +Z, the tilt joint, unchanged).
Where that would lean an axis further than ``max_lean_deg`` from its normal, the axes are
left as they were (the report then says C turns back and forth).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from ..tolerances import ANGLE_SLACK_DEG, ROUND_OFF
from .tool_axis import angle_deg

__all__ = ["OneWay", "one_way_azimuth"]


@dataclass(frozen=True)
class OneWay:
    """The axes and how far they were turned about +Z (deg)."""

    axes: NDArray[np.float64]
    turned_points: int
    max_turn_deg: float


def one_way_azimuth(axes: NDArray[np.float64], normals: NDArray[np.float64],
                    max_lean_deg: float) -> OneWay:
    """Axes (in cutting order) whose azimuth about +Z never turns back (see the module)."""
    axes = np.asarray(axes, dtype=float)
    if len(axes) < 3:
        return OneWay(axes, 0, 0.0)
    phi = np.unwrap(np.arctan2(axes[:, 1], axes[:, 0]))
    total = phi[-1] - phi[0]
    if abs(total) < ROUND_OFF:
        return OneWay(axes, 0, 0.0)
    sense = np.sign(total)
    u = sense * phi
    target = 0.5 * (np.maximum.accumulate(u) + np.minimum.accumulate(u[::-1])[::-1])
    turn = sense * (target - u)
    moved = np.abs(turn) > ROUND_OFF
    if not moved.any():
        return OneWay(axes, 0, 0.0)
    c, s = np.cos(turn), np.sin(turn)
    out = axes.copy()
    out[:, 0] = c * axes[:, 0] - s * axes[:, 1]
    out[:, 1] = s * axes[:, 0] + c * axes[:, 1]
    lean_before = angle_deg(axes, normals)
    lean_after = angle_deg(out, normals)
    if (lean_after[moved] > np.maximum(max_lean_deg, lean_before[moved]) + ANGLE_SLACK_DEG).any():
        return OneWay(axes, 0, 0.0)
    return OneWay(out, int(moved.sum()), float(np.degrees(np.abs(turn).max())))
