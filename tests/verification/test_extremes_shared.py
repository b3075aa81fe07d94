"""Issue 27: the largest scallop is most often the largest excess; searched once.

:func:`verification.extremes.extremes` refines a start that two asks share once, with the
very result of refining each on its own (:func:`verification.extremes.extreme`).
"""

import numpy as np
import pytest

from toolpath.planning.analytic import PlaneSurface
from verification.dexels import DexelResult
from verification.extremes import extreme, extremes
from verification.samples import sample_design


class _Bump:
    """A deviation field known in closed form, counting the dexels it measures.

    ``dev(P) = PEAK - (x - 3)^2 - 4 (y - 1)^2`` mm (normals +Z, dexels along them):
    the largest excess at ``(3, 1)``, the deepest at a corner of the plane.
    """

    PEAK = 0.01

    def __init__(self) -> None:
        self.measured = 0

    def field(self, points):
        return self.PEAK - (points[:, 0] - 3.0) ** 2 - 4.0 * (points[:, 1] - 1.0) ** 2

    def search(self, points, normals, convexity, *, far=False, guess_mm=None):
        del normals, convexity, far, guess_mm
        self.measured += points.shape[0]
        q = points.shape[0]
        return DexelResult(self.field(points), np.zeros(q, dtype=np.int64),
                           np.zeros(q, dtype=bool), np.zeros(q, dtype=bool))

    def deviation(self, result, normals):
        del normals
        return result.lam_mm.copy()


def _bump_grid():
    plane = PlaneSurface((0.0, 0.0, 0.0), (10.0, 0.0, 0.0), (0.0, 4.0, 0.0))
    samples = sample_design(plane, spacing_t_mm=0.7, spacing_s_mm=0.7, max_samples=10_000)
    ev = _Bump()
    res = ev.search(samples.points.reshape(-1, 3), None, None)
    ev.measured = 0
    return plane, samples, ev, res, res.lam_mm.reshape(samples.shape)


def _figures(found):
    return None if found is None else (found.dev, found.t, found.s, found.point.tolist(),
                                       found.move, found.shank)


def test_an_extreme_two_asks_share_is_searched_once_with_the_same_result():
    plane, samples, ev, res, dev = _bump_grid()
    every = np.ones(samples.shape, dtype=bool)
    asks = [(every, True, -np.inf), (every, False, -0.1), (every.copy(), True, -np.inf)]
    one_by_one, measured = [], []
    for eligible, largest, limit in asks:
        ev.measured = 0
        one_by_one.append(extreme(ev, plane, samples, res, dev, eligible, largest=largest,
                                  limit=limit, refine=4, collision=False))
        measured.append(ev.measured)
    assert measured[0] == measured[2] > 0 and measured[1] > 0
    ev.measured = 0
    shared = extremes(ev, plane, samples, res, dev, asks, refine=4, collision=False)
    assert [_figures(e) for e in shared] == [_figures(e) for e in one_by_one]
    assert shared[2] is shared[0]
    assert ev.measured == measured[0] + measured[1]  # the third ask's are the first's
    # refined onto the top of the bump, between the samples
    assert shared[0].dev == pytest.approx(_Bump.PEAK, abs=1e-5)
    assert shared[0].point[:2] == pytest.approx([3.0, 1.0], abs=0.01)


def test_asks_that_differ_in_their_starts_are_each_searched():
    plane, samples, ev, res, dev = _bump_grid()
    every = np.ones(samples.shape, dtype=bool)
    away = every.copy()
    away[:, : samples.shape[1] // 2] = False  # the half without the top of the bump
    found = extremes(ev, plane, samples, res, dev, [(every, True, -np.inf),
                                                   (away, True, -np.inf)],
                     refine=4, collision=False)
    assert found[0].dev == pytest.approx(_Bump.PEAK, abs=1e-5)
    assert found[1].dev < found[0].dev - 1e-3
