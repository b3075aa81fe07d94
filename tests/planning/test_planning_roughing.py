"""Z-level roughing: contour-parallel rings keep the allowance from the part."""

import numpy as np
import pytest

from toolpath.errors import InvalidParameterError
from toolpath.path import MoveKind
from toolpath.planning import EllipticBladeSurface, plan_roughing

BLADE = EllipticBladeSurface(semi_axes_hub_mm=(20.0, 5.0), semi_axes_tip_mm=(16.0, 3.0),
                             z_range_mm=(0.0, 20.0))


def _ellipse_distance(xy, a, b, n=20000):
    th = np.linspace(0, 2 * np.pi, n, endpoint=False)
    ring = np.stack([a * np.cos(th), b * np.sin(th)], 1)
    d = np.linalg.norm(xy[:, None, :] - ring[None, :, :], axis=2)
    return d.min(axis=1)


def test_rings_keep_the_allowance_from_the_blade():
    path, rep = plan_roughing(BLADE, "bull:8:1", step_down_mm=5.0, allowance_mm=0.5)
    assert rep.min_wall_clearance_mm >= 0.5 - 1e-3
    assert len(rep.levels_mm) == 5 and rep.n_rings > 5
    cut = np.flatnonzero(np.isin(path.kinds, (MoveKind.CUT, MoveKind.LINK)))
    pts = path.positions_mm[cut]
    assert np.all(np.isin(np.round(pts[:, 2], 9), np.round(rep.levels_mm, 9)))
    # independent check on the analytic ellipse: the tool centre keeps R + allowance from
    # every section at or above its level (the blade tapers: the hub is the widest)
    for level in rep.levels_mm:
        at = pts[np.isclose(pts[:, 2], level)]
        s_here = max(level, 0.0) / 20.0
        a, b = 20.0 - 4.0 * s_here, 5.0 - 2.0 * s_here
        inside = (at[:, 0] / a) ** 2 + (at[:, 1] / b) ** 2 < 1.0
        assert not inside.any()
        sub = at[:: max(1, len(at) // 400)]
        assert _ellipse_distance(sub[:, :2], a, b).min() >= 4.0 + 0.5 - 2e-3
    assert np.all(path.tool_axes == [0.0, 0.0, 1.0])


def test_roughing_bad_input():
    with pytest.raises(InvalidParameterError, match="stepover_mm"):
        plan_roughing(BLADE, "bull:8:1", step_down_mm=5.0, stepover_mm=6.0)
    with pytest.raises(InvalidParameterError, match="step_down_mm"):
        plan_roughing(BLADE, "bull:8:1", step_down_mm=0.0)
