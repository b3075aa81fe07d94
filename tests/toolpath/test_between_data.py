"""The between-data estimate (toolpath.between_data) against the truth between the points."""

import itertools
import sys
import warnings
from pathlib import Path

import numpy as np
import pytest
import scipy.interpolate
from scipy.spatial import cKDTree

from streamline_cam.fit_report import fit_curve_by_method
from toolpath import fit_bspline_curve, fit_streamline_curve
from toolpath.between_data import (
    BETWEEN_DATA,
    DATA_SHARE,
    between_data_errors,
    between_data_estimate,
    between_data_over,
    between_data_parts,
)
from toolpath.errors import ConvergenceWarning

sys.path.insert(0, str(Path(__file__).resolve().parents[2] / "benchmarks"))
import between_data_truth  # the real-like blades' true sections


def _airfoil(phi):
    """A closed thin section (chord 60 mm, 3 mm thick, cambered) at angles ``phi``."""
    x = 30.0 * (1.0 + np.cos(phi))
    y = 3.0 * np.sin(phi) * (1.0 - 0.3 * np.cos(phi)) + 2.0 * np.sin(np.pi * x / 60.0)
    return np.c_[x, y]


def _truth_distance(query, dense):
    """Distance (mm) from each query point to the dense true polyline."""
    a, ab = dense[:-1], np.diff(dense, axis=0)
    rel = query[:, None, :] - a[None]
    w = np.clip(np.einsum("qij,ij->qi", rel, ab) / np.einsum("ij,ij->i", ab, ab), 0.0, 1.0)
    return np.linalg.norm(rel - w[..., None] * ab[None], axis=2).min(axis=1)


@pytest.mark.parametrize("fit", [fit_streamline_curve, fit_bspline_curve])
def test_the_estimate_is_within_2x_of_the_true_error_between_sparse_points(fit):
    # 80 points round: flanks ~2.4 mm apart, the noses sampled on a cosine
    phi = np.linspace(0.0, 2.0 * np.pi, 81)
    points = _airfoil(phi)
    curve = fit(points[:-1], tol=0.01, closed=True)
    t = np.append(curve.params, 1.0)
    estimate = between_data_errors(curve, t, points, closed=True)
    dense = _airfoil(np.linspace(0.0, 2.0 * np.pi, 40 * 400 + 1))
    true = np.array([_truth_distance(curve(np.linspace(a, b, 23)[1:-1]), dense).max()
                     for a, b in itertools.pairwise(t)])
    assert np.isfinite(estimate).all()
    assert 0.7 * true.max() <= estimate.max() <= 2.0 * true.max()
    flank = np.linalg.norm(np.diff(points, axis=0), axis=1) > 2.0
    assert np.abs(estimate[flank] - true[flank]).max() < 0.3 * true.max()


def test_a_corner_interval_is_not_estimated_and_open_ends_are():
    # a right-angle corner between two samples: the data cannot tell where it lies
    x = np.linspace(0.0, 10.0, 11)
    points = np.vstack((np.c_[x, np.zeros(11)], np.c_[np.full(10, 10.4), x[1:]]))
    t = np.linspace(0.0, 1.0, len(points))
    errors = between_data_errors(lambda u: np.interp(u, t, points[:, 0])[:, None]
                                 * [1.0, 0.0] + np.interp(u, t, points[:, 1])[:, None]
                                 * [0.0, 1.0], t, points)
    assert np.isnan(errors[10]) and np.isfinite(np.delete(errors, 10)).all()
    assert np.nanmax(errors) < 1e-9  # the polyline is its own data curve there
    mm, where = between_data_estimate(lambda u: np.c_[u, 0.0 * u] * 10.0, t[:11] / t[10],
                                      points[:11])
    assert mm < 1e-9 and where is not None


def test_the_fit_report_gives_the_estimate():
    points = _airfoil(np.linspace(0.0, 2.0 * np.pi, 81))[:-1]
    _, report = fit_curve_by_method(points, method="bspline", tol=0.01, closed=True)
    data = report.as_dict()
    assert 0.0 < data["between_data_mm"] < 0.05 and 0.0 <= data["between_data_t"] <= 1.0
    assert any(line.startswith("between data") for line in report.lines())


def test_the_criterion_holds_the_fit_to_the_data_curve_where_the_data_are_uncertain():
    # a fit 0.006 mm off a straight run of points: over tol - h where Hall's term h is
    # small; where h is over half the tolerance only the fit's own part counts
    x = np.linspace(0.0, 20.0, 21)
    t = x / 20.0
    points = np.c_[x, np.zeros(21)]
    off = between_data_over(lambda u: np.c_[20.0 * u, np.full(np.size(u), 0.006)], t,
                            points, 0.005)
    assert len(off) == 20 and all(kind == BETWEEN_DATA for *_, kind in off)
    assert between_data_over(lambda u: np.c_[20.0 * u, np.full(np.size(u), 0.006)], t,
                             points, 0.01) == []
    fit_mm, data_mm = between_data_parts(lambda u: np.c_[20.0 * u, np.zeros(np.size(u))],
                                         t, points)
    assert np.allclose(fit_mm, 0.0, atol=1e-9) and np.allclose(data_mm, 0.0, atol=1e-9)
    assert DATA_SHARE < 1.0


def test_intervals_off_the_data_come_worst_first_by_the_estimate_they_report():
    # a fit 0.014 mm off the data curve where the data are certain, and 0.012 mm off it
    # beside a bump where Hall's term is over half the tolerance: the criterion ranks the
    # first higher (Hall's term left out there), the estimate reported the second
    x = np.linspace(0.0, 20.0, 21)
    t = x / 20.0
    y = np.where(np.arange(21) == 10, 0.08, 0.0)
    data_curve = scipy.interpolate.CubicSpline(x, y)

    def fitted_at(u):
        off_mm = np.where((u > 0.1) & (u < 0.15), 0.014,
                          np.where((u > 0.45) & (u < 0.55), 0.012, 0.0))
        return np.c_[20.0 * u, data_curve(20.0 * u) + off_mm]

    off = between_data_over(fitted_at, t, np.c_[x, y], 0.01)
    assert len(off) == 3 and off[-1][0] == pytest.approx(0.1)
    assert [mm for _, _, mm, *_ in off] == sorted((mm for _, _, mm, *_ in off), reverse=True)


@pytest.mark.parametrize("fit", [fit_streamline_curve, fit_bspline_curve])
@pytest.mark.parametrize("section", [3, 6])
def test_thin_le_curve_fits_stay_within_tol_between_the_data(fit, section):
    # the real-like propeller's LE (radius 0.05-0.1 mm sampled 0.1-0.4 mm apart, as
    # coarsely as its radius) beside flanks 2 mm apart: the fits were within tol at the
    # data and 0.0111 / 0.0126 mm off the true section between them (streamline)
    points = between_data_truth.load("prop")[section]
    dense = between_data_truth.true_sections("prop")[section]
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", ConvergenceWarning)
        curve = fit(points, tol=0.01, closed=None)
    assert curve.closed and curve.max_error <= 0.01
    t = np.append(curve.params, 1.0)
    true = between_data_truth.between_true(curve, t, dense, cKDTree(dense))
    assert true.max() <= 0.0101  # the estimate reads the flanks within 2 % of the truth
