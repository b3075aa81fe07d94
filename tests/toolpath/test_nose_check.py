"""Issue 23: the nose check measures the fit between the data, not the circles' own error.

Between two nose points the data tell only that the curve runs between their two circles
(:func:`toolpath.fairness._nose_error`); an interval whose step spans more than
``NOSE_STEP_ARC_DEG`` of either circle is not resolved by its data and is not checked.
"""

import numpy as np

from toolpath.fairness import curve_fairness


class _Ellipse:
    """The exact ellipse ``(a cos 2πt, b sin 2πt)``, optionally with an outward bump of
    ``bump`` mm centred at ``t = at`` and ``width`` wide (in t)."""

    def __init__(self, a, b, params, bump=0.0, at=0.0, width=1.0):
        self.a, self.b, self.params = a, b, params
        self.bump, self.at, self.width = bump, at, width

    def _r(self, t, order):
        """Radial bump g(t) and its derivatives."""
        u = (t - self.at) / self.width
        g = self.bump * np.exp(-0.5 * u**2)
        return [g, -u / self.width * g, (u**2 - 1) / self.width**2 * g][order]

    def _xy(self, t, order):
        w = 2 * np.pi
        c, s = np.cos(w * t), np.sin(w * t)
        base = [np.c_[self.a * c, self.b * s], w * np.c_[-self.a * s, self.b * c],
                -w**2 * np.c_[self.a * c, self.b * s]][order]
        unit = [np.c_[c, s], w * np.c_[-s, c], -w**2 * np.c_[c, s]]
        bumped = sum(_binomial(order, k) * self._r(t, k)[:, None] * unit[order - k]
                     for k in range(order + 1))
        return np.c_[base + bumped, np.zeros(len(t))]

    def __call__(self, t):
        return self._xy(np.asarray(t, float), 0)

    def derivative(self, t, order=1):
        return self._xy(np.asarray(t, float), order)


def _binomial(n, k):
    return [[1], [1, 1], [1, 2, 1]][n][k]


def _ellipse_data(a=30.0, b=8.0, n=60):
    """A 60-point ellipse, first point repeated (the closed fixture of conftest.py)."""
    t = np.linspace(0.0, 1.0, n)
    return t, np.c_[a * np.cos(2 * np.pi * t), b * np.sin(2 * np.pi * t), np.zeros(n)]


def test_the_exact_curve_is_not_off_its_own_nose_circles():
    t, points = _ellipse_data()
    fairness = curve_fairness(_Ellipse(30.0, 8.0, t), points, closed=True)
    assert fairness.nose_error_mm < 1e-9  # the nearer circle alone read 0.0087 mm


def test_a_bump_between_nose_points_is_measured():
    t, points = _ellipse_data(n=241)  # 1.5 deg apart: the circles agree between the points
    # 0.02 mm out from the centre at the vertex, between data points 0 and 1
    at = 0.5 * (t[0] + t[1])
    curve = _Ellipse(30.0, 8.0, t, bump=0.02, at=at, width=0.1 * (t[1] - t[0]))
    fairness = curve_fairness(curve, points, closed=True)
    assert 0.018 < fairness.nose_error_mm <= 0.0201
    assert abs(fairness.nose_t - at) < 0.1 * (t[1] - t[0])
    noses = [u for u in fairness.unfair(0.01) if "nose" in u[3]]
    assert len(noses) == 1 and noses[0][0] <= at <= noses[0][1]  # that interval, to mend
    assert curve_fairness(_Ellipse(30.0, 8.0, t), points, closed=True).nose_error_mm < 1e-6


def test_a_nose_its_data_do_not_resolve_is_not_checked():
    # a 0.1 mm nose sampled 0.11 mm apart (a propeller's LE): the circle through three
    # points is no model of the curve between them, whatever the fit does there
    t, points = _ellipse_data(a=30.0, b=1.7, n=60)  # vertex radius b^2/a ~ 0.1 mm
    curve = _Ellipse(30.0, 1.7, t, bump=0.02, at=0.5 * (t[0] + t[1]),
                     width=0.1 * (t[1] - t[0]))
    assert curve_fairness(curve, points, closed=True).nose_error_mm < 1e-9
