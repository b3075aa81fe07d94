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


def test_a_propeller_exported_the_other_way_round_plans_round_its_sharp_edge():
    # the propeller's sections run the other way round (the pressure side first): the sharp
    # trailing-edge wedge at their last point, one point before the seam. The seam moves
    # onto the wedge (C0 there, as the export in the bundled order): before, the fit bent
    # round the hub's wedge and the plan stopped on a 4.5 mm gouge there
    from toolpath import read_sections
    from toolpath.paper_examples import bundled_data_path

    sections = [p[::-1] for p in read_sections(bundled_data_path("dev_prop_7x100.csv"))]
    surface = fit_streamline_surface(sections, tol=0.01)
    _, report = plan_finishing(surface, "ball:6", scallop_mm=0.05, chord_tol_mm=0.05,
                               axis_mode="lead-tilt", lead_deg=10.0, measure=False)
    assert report.min_concave_radius_mm > 3.0
