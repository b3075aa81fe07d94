"""Arc fitting: spans verified against the tolerance, direction, refusals."""

import itertools

import numpy as np
import pytest

from gcode.arcfit import ARC_MIN_POINTS, arc_deviation_mm, fit_arcs


def _arc(centre, radius, a0, a1, n):
    t = np.linspace(a0, a1, n)
    return np.column_stack([centre[0] + radius * np.cos(t), centre[1] + radius * np.sin(t)])


def _assert_spans_within(points, spans, tol):
    for s in spans:
        pts = points[s.start : s.end + 1]
        r = np.hypot(*(pts - s.centre).T)
        assert np.abs(r - r[0]).max() <= tol + 1e-12
        assert np.abs(r - r.mean()).max() <= s.max_error_mm + tol
        assert s.end - s.start + 1 >= ARC_MIN_POINTS
        # points go round the centre one way, in order
        ang = np.unwrap(np.arctan2(pts[:, 1] - s.centre[1], pts[:, 0] - s.centre[0]))
        steps = np.diff(ang)
        assert (steps < 0).all() if s.clockwise else (steps > 0).all()


def test_a_sampled_arc_is_one_span_with_its_centre_and_direction():
    pts = _arc((3.0, -2.0), 12.0, 2.0, 0.5, 100)  # decreasing angle: clockwise
    (span,) = fit_arcs(pts, 0.001)
    assert (span.start, span.end, span.clockwise) == (0, 99, True)
    assert np.allclose(span.centre, (3.0, -2.0), atol=1e-9)


def test_lines_and_polygons_are_not_arcs():
    line = np.column_stack([np.linspace(0, 10, 20), np.linspace(0, 5, 20)])
    zigzag = np.column_stack([np.arange(20.0), np.tile([0.0, 1.0], 10)])
    square = np.array([[0, 0], [1, 0], [1, 1], [0, 1], [0, 0], [1, 0]], dtype=float)
    for pts in (line, zigzag, square):
        assert fit_arcs(pts, 0.01) == []


def test_line_arc_line_finds_the_arc_and_spans_share_end_points():
    line1 = np.column_stack([np.linspace(-10, 0, 6), np.full(6, -5.0)])
    arc = _arc((0.0, 0.0), 5.0, -np.pi / 2, 0.0, 30)[1:]
    line2 = np.column_stack([np.full(5, 5.0), np.linspace(1, 5, 5)])
    pts = np.vstack([line1, arc, line2])
    spans = fit_arcs(pts, 0.005)
    _assert_spans_within(pts, spans, 0.005)
    assert any(s.end - s.start >= 25 and np.allclose(s.centre, 0, atol=1e-6) for s in spans)
    for a, b in itertools.pairwise(spans):
        assert a.end <= b.start


@pytest.mark.parametrize("seed", range(4))
def test_every_span_on_noisy_and_random_curves_is_within_tolerance(seed):
    rng = np.random.default_rng(seed)
    t = np.linspace(0, 12, 600)
    spiral = np.column_stack([t * np.cos(t), t * np.sin(t)])
    noisy = spiral + rng.normal(0, 0.001, spiral.shape)
    wiggle = np.column_stack([t, np.sin(t * rng.uniform(0.5, 3))])
    for pts in (spiral, noisy, wiggle):
        for tol in (0.001, 0.01):
            spans = fit_arcs(pts, tol)
            _assert_spans_within(pts, spans, tol)


def test_noise_beyond_the_tolerance_breaks_the_arc():
    pts = _arc((0.0, 0.0), 10.0, 0.0, 1.5, 30)
    pts[15] += [0.02, 0.0]
    spans = fit_arcs(pts, 0.005)
    assert all(not (s.start < 15 < s.end) for s in spans)


def test_deviation_is_measured_from_the_start_radius():
    pts = [[1.0, 0.0], [0.0, 1.002], [-1.0, 0.0]]
    assert arc_deviation_mm(pts, [0.0, 0.0]) == pytest.approx(0.002)


def test_bad_input_is_refused_with_the_offending_value():
    with pytest.raises(ValueError, match=r"shape \(n, 2\)"):
        fit_arcs(np.zeros((5, 3)))
    with pytest.raises(ValueError, match=r"points\[2\] is not finite"):
        fit_arcs([[0, 0], [1, 0], [np.nan, 1], [2, 2]])
    with pytest.raises(ValueError, match="tol_mm"):
        fit_arcs(np.zeros((5, 2)), 0.0)
    with pytest.raises(ValueError, match="min_points"):
        fit_arcs(np.zeros((5, 2)), min_points=2)
    assert fit_arcs(np.zeros((2, 2))) == []
