"""A flat cutter's disc hanging over an open edge: it reads the edge, not air.

``cutter_gap`` reads the disc's depth below the surface from points of the disc, each at
its foot's tangent plane. Past an open edge that plane runs on into air: a disc hanging
over a propeller's tip read 1.6 mm "inside" the blade from the tip section's far side
(the verifier: no gouge). The cases here have plain answers: a plane patch under a tilted
disc whose low side hangs past the patch's edge, and a closed blade's tip under a level
disc. Without :func:`~toolpath.planning.open_edges.edge_readings` (its call in
``_Disc.signed`` removed) the plane and tip tests fail (gouges of 0.5 to 4.5 mm read in
air); with the edge's depth read as its distance to the cutter (``meets`` never true) the
gouge through the plane's edge reads 0.028 mm, not 0.03 (along the normal, as the
verifier's dexels read it).
"""

import numpy as np
import pytest

from toolpath.planning import EllipticBladeSurface, parse_cutter
from toolpath.planning.analytic import PlaneSurface
from toolpath.planning.open_edges import beyond_open_edges
from toolpath.planning.sampling import cutter_gap

FLAT = parse_cutter("flat:6")
TILT_DEG = 20.0
#: The disc centre's distance in from the plane's edge ``y = 0``, mm: its low side, 3 mm
#: out along the tilt, hangs 2.3 mm past the edge.
INSET_MM = 0.5


def _tilted_disc_over_edge(height_at_edge_mm: float) -> tuple[np.ndarray, np.ndarray]:
    """Tips and axes of a flat disc tilted down towards ``-y``, at ``x = 5 .. 35``.

    The disc stands ``height_at_edge_mm`` above the plane ``z = 0`` where it crosses the
    edge line ``y = 0``, and lower (to ``-0.6`` mm) past it.
    """
    theta = np.radians(TILT_DEG)
    axis = np.array([0.0, -np.sin(theta), np.cos(theta)])
    x = np.linspace(5.0, 35.0, 7)
    # the disc rises along (0, cos, sin): at y = 0 it stands INSET tan(theta) below its centre
    z = height_at_edge_mm + INSET_MM * np.tan(theta)
    tips = np.stack([x, np.full_like(x, INSET_MM), np.full_like(x, z)], axis=1)
    return tips, np.tile(axis, (x.size, 1))


@pytest.mark.parametrize("height_at_edge_mm", [0.02, 0.3])
def test_disc_past_a_plane_edge_clear_of_it(height_at_edge_mm):
    plane = PlaneSurface()  # X = (40 t, 30 s, 0): the edge s = 0 is the line y = 0
    tips, axes = _tilted_disc_over_edge(height_at_edge_mm)
    t0, s0 = tips[:, 0] / 40.0, np.full(len(tips), INSET_MM / 30.0)
    gap, _, s = cutter_gap(plane, FLAT, tips, axes, t0, s0, newton=3, refine_rim=True)
    # the lowest point of the disc over the patch is where it crosses the edge: no gouge,
    # and no more clearance than that (a point just past the edge, above the plane carried
    # on, may read less: its reading stands)
    assert np.all(gap >= 0.0)
    assert np.all(gap <= height_at_edge_mm + 1e-12)
    np.testing.assert_allclose(s, 0.0)


def test_disc_through_a_plane_edge_gouges_it():
    plane = PlaneSurface()
    tips, axes = _tilted_disc_over_edge(-0.03)
    t0, s0 = tips[:, 0] / 40.0, np.full(len(tips), INSET_MM / 30.0)
    gap, _, _ = cutter_gap(plane, FLAT, tips, axes, t0, s0, newton=3, refine_rim=True)
    # the edge itself lies 0.03 mm inside the cutter (along its normal, +z)
    np.testing.assert_allclose(gap, -0.03, atol=1e-9)


BLADE = EllipticBladeSurface()  # closed sections, open at the tip s = 1 (z = 40)


@pytest.mark.parametrize("above_mm", [0.1, 0.5])
def test_level_disc_over_a_blade_tip(above_mm):
    # a flat disc 3 mm across... hung over the tip's thin end (a = 26, b = 4 mm): most of
    # it lies over the tip section, past the edge s = 1
    tips = np.array([[24.5, 0.0, 40.0 + above_mm], [20.0, 1.0, 40.0 + above_mm]])
    axes = np.tile([0.0, 0.0, 1.0], (2, 1))
    gap, _, s = cutter_gap(BLADE, FLAT, tips, axes, np.array([0.0, 0.05]),
                           np.array([1.0, 1.0]), newton=3, refine_rim=True)
    # the tip's edge lies below the disc, clear (beside the nose, a point of the disc just
    # outside the flank carried up reads less clearance: it stands)
    assert np.all(gap >= 0.0)
    assert np.all(gap <= above_mm + 1e-12)
    np.testing.assert_allclose(s, 1.0)


def test_level_disc_below_the_tip_still_gouges():
    # the same disc 0.2 mm below the tip: inside the blade, its points find feet on the
    # flanks (not past the edge) and read the depth as before
    tips = np.array([[24.5, 0.0, 39.8]])
    gap, _, s = cutter_gap(BLADE, FLAT, tips, np.array([[0.0, 0.0, 1.0]]), np.array([0.0]),
                           np.array([1.0]), newton=3, refine_rim=True)
    assert gap[0] < -1.0  # the blade's nose runs 1.5 mm into the disc's side
    assert s[0] < 1.0


def test_feet_on_an_edge_but_not_past_it_are_left():
    plane = PlaneSurface()
    t = np.array([0.5, 0.5, 0.5, 0.5])
    s = np.array([0.0, 0.0, 1.0, 1.0])
    # past s = 0 (y < 0), on the edge's normal line, past s = 1 (y > 30), short of it
    points = np.array([[20.0, -1.0, 0.3], [20.0, 0.0, 0.3], [20.0, 31.0, -0.2],
                       [20.0, 29.0, 0.1]])
    rows, parts = beyond_open_edges(plane, points, t, s)
    np.testing.assert_array_equal(rows, [0, 2])
    np.testing.assert_allclose(parts[0, 0], [[20.0, 0.0, 0.0], [20.0, 30.0, 0.0]])
