"""A fitted closed blade (sections closing without a repeated point) plans round its seam."""

import numpy as np

from toolpath import fit_streamline_surface
from toolpath.planning import plan_finishing


def test_five_axis_spiral_round_a_fitted_closed_blade():
    # elliptic sections (nose radius about 1 mm) twisting up the span, 60 points each, the
    # seam 0.1 rad past a nose vertex, the first point not repeated: read closed, fitted
    # periodic; the planner meets no corner at the seam (once: concave radius 0 there)
    theta = np.linspace(0.0, 2 * np.pi, 60, endpoint=False) + 0.1
    sections = []
    for j, h in enumerate(np.linspace(0.0, 1.0, 6)):
        a, b, twist = 15.0 - h, 4.0 - 0.5 * h, 0.3 * h
        x, y = a * np.cos(theta), b * np.sin(theta)
        c, s = np.cos(twist), np.sin(twist)
        sections.append(np.c_[c * x - s * y, s * x + c * y, np.full(theta.size, 0.8 * j)])
    surface = fit_streamline_surface(sections, tol=0.005)
    assert surface.closed_t and surface.max_error <= 0.005
    path, report = plan_finishing(surface, "ball:6", scallop_mm=0.02, chord_tol_mm=0.01,
                                  axis_mode="lead-tilt", lead_deg=10.0, linking="spiral")
    assert report.within_request and report.uncut_fraction == 0.0
    assert np.allclose(np.linalg.norm(path.tool_axes, axis=1), 1.0)
    assert report.min_concave_radius_mm > 3.0
