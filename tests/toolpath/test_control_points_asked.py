"""Issue 23: ``n_control_points=n`` gives n control points, or says why not."""

import warnings

import numpy as np
import pytest

from toolpath import fit_bspline_curve, fit_streamline_curve, read_points
from toolpath.errors import ConvergenceWarning
from toolpath.knots import refill_knots
from toolpath.paper_examples import bundled_data_path
from toolpath.splinefit import (
    admissible_knots,
    clamped_knots,
    n_coefficients,
    schoenberg_whitney_violation,
)


@pytest.mark.parametrize("fit", [fit_bspline_curve, fit_streamline_curve])
@pytest.mark.parametrize("count", [41, 44, 45, 60])
def test_the_half_profile_gets_the_control_points_asked(fit, count):
    half = read_points(bundled_data_path("dev_half_profile_71.csv"))
    with warnings.catch_warnings():
        warnings.simplefilter("error", ConvergenceWarning)
        assert fit(half, n_control_points=count).n_control_points == count  # 45 gave 44


def test_more_control_points_than_the_data_allow_are_named():
    half = read_points(bundled_data_path("dev_half_profile_71.csv"))
    with pytest.warns(ConvergenceWarning, match="71 control points, not the 100 control "
                      "points asked: no knot span has room"):
        curve = fit_bspline_curve(half, n_control_points=100)
    assert curve.n_control_points == 71


def test_dropped_knots_are_given_back_where_the_data_are():
    t = np.r_[np.linspace(0.0, 0.5, 40), np.linspace(0.55, 1.0, 6)]
    crowded = clamped_knots(np.r_[np.linspace(0.6, 0.95, 12), [0.2, 0.4]])
    kept = admissible_knots(t, crowded)
    assert n_coefficients(kept) < n_coefficients(crowded)  # the sparse end cannot hold them
    refilled = refill_knots(t, kept, n_coefficients(crowded))
    assert n_coefficients(refilled) == n_coefficients(crowded)
    assert schoenberg_whitney_violation(t, refilled) is None


def test_admissible_knots_leave_no_span_without_data():
    t = np.linspace(0.0, 1.0, 30)
    knots = clamped_knots(np.r_[0.5 + 1e-4 * np.arange(1, 3), 0.3])  # two spans between samples
    fixed = admissible_knots(t, knots)
    assert schoenberg_whitney_violation(t, fixed) is None
