"""Illinois regula falsi with a bisection fallback (toolpath.planning.roots)."""

import numpy as np
import pytest

from toolpath.planning.roots import illinois_roots


def test_smooth_roots_either_way_round_in_few_evaluations():
    roots = np.array([0.3, 0.52, 0.7071, 0.9])
    steep = np.array([1.0, 40.0, 3.0, 400.0])
    calls = []

    def f(x, rows):
        calls.append(len(rows))
        return np.tanh(steep[rows] * (roots[rows] - x))  # >= 0 below the root

    pos = np.array([0.2, 0.5, 0.6, 0.85])
    neg = np.array([0.4, 0.6, 0.8, 0.95])
    rows = np.arange(4)
    p, n = illinois_roots(f, pos, neg, f(pos, rows), f(neg, rows), secant_steps=12,
                          bisect_steps=40, x_tol=1e-12, f_tol=1e-10)
    assert (f(p, rows) >= 0.0).all() and (f(n, rows) < 0.0).all()
    assert np.all(np.abs(p - roots) < 1e-10 / steep + 1e-12)
    assert len(calls) - 2 <= 12  # superlinear: no bisection needed
    # the ends the other way round on the axis
    p, n = illinois_roots(lambda x, r: -f(x, r), neg, pos, -f(neg, rows), -f(pos, rows),
                          secant_steps=12, bisect_steps=40, x_tol=1e-12, f_tol=1e-10)
    assert np.all(p >= roots) and np.all(p - roots < 1e-10 / steep + 1e-12)


@pytest.mark.parametrize("secant_steps", [0, 3, 12])
def test_a_step_is_closed_by_bisection_to_the_tolerance(secant_steps):
    root = 0.3 + 1e-3 * np.pi

    def f(x, rows):
        return np.where(x < root, 1.0, -1e-6)

    pos, neg = np.array([0.2]), np.array([0.4])
    p, n = illinois_roots(f, pos, neg, f(pos, None), f(neg, None),
                          secant_steps=secant_steps, bisect_steps=40, x_tol=1e-9, f_tol=0.0)
    assert p[0] < root <= n[0] and n[0] - p[0] <= 1e-9


def test_either_end_stops_where_the_root_is_the_far_end():
    # f >= 0 only at the given pos end (its value there a poor guess): the neg end closes
    # in on it, and only either_end lets the row stop before the bracket is tiny
    def f(x, rows):
        return -(x - 0.1) * 10.0

    counts = {}
    for either in (False, True):
        seen = []

        def counted(x, rows, seen=seen):
            seen.append(len(rows))
            return f(x, rows)

        p, n = illinois_roots(counted, np.array([0.1]), np.array([0.5]), np.array([5.0]),
                              f(np.array([0.5]), None), secant_steps=8, bisect_steps=16,
                              x_tol=1e-6, f_tol=1e-4, either_end=either)
        counts[either] = len(seen)
        assert p[0] == 0.1 and abs(n[0] - 0.1) <= max(1e-6, 1e-5)
    assert counts[True] < counts[False]
