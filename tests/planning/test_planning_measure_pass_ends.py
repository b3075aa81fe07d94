"""The flat and bull-nose estimate round the lying blade's leading edge, where passes end.

In 3 axes the passes run down the lying dev blade's leading edge (the wall's normal
horizontal, across the cutter's axis) to the lowest reachable point and turn there to
link. A prism along a pass's way carried the cutter into the plane of the seed's line of
``t`` from poses the pass never takes (below its end, the next pass's tip 0.45 mm over
the plane; down the wall, along the cutter's axis, its whole height squashed into the
section): the estimate read down to 0.07 times the ray cast (flat:6) and 0.16 (bull:8:1),
and only the ray cast of neighbouring seeds kept the measured scallop right. Such seeds
are cast (``CARRY_TURN``, ``AXIS_WAY_COSINE`` in :mod:`toolpath.planning.cusp_estimates`).

Where the passes bend away from the surface, on the far side in 5 axes, the margin the
estimate keeps grows with the bend (``BEND_AWAY_GROWTH``).

The oracle is the ray cast (:class:`~toolpath.planning.cusp_search.CuspSearch`, the full
method) of the seeds round the edge whose cusps are estimated.
"""

from types import SimpleNamespace

import numpy as np
import pytest
from measured_plans import planned

from toolpath import fit_streamline_surface
from toolpath.paper_examples import bundled_data_path
from toolpath.planning.cusp_estimates import _runs_on, torus_cusp_estimates
from toolpath.planning.cusp_search import CuspSearch, SearchSeeds
from toolpath.planning.setup import centred_on_table, rotation_from_spec

#: The estimate may read high (more seeds cast) but not this far low (as in
#: test_planning_measure_estimate: the cast rule skips seeds estimated below the top).
LEAST_ESTIMATE_SHARE = 0.97


@pytest.fixture(scope="module")
def lying():
    rows = np.loadtxt(bundled_data_path("dev_blade_15x142.csv"), delimiter=",", skiprows=1)
    sections = rows[:, 1:].reshape(15, 142, 3)[::2]  # every other section: a shorter fit
    blade = fit_streamline_surface(sections, tol=0.01, closed=False)
    return centred_on_table(blade, rotation_from_spec("x:90"), base_height_mm=0.0)


@pytest.mark.parametrize("cutter", ["flat:6", "bull:8:1"])
def test_the_section_estimate_does_not_read_low_where_passes_end_down_the_edge(lying, cutter):
    measured = planned(lying, cutter, scallop_mm=0.1, chord_tol_mm=0.05, axis_mode="3")
    volume = measured.volume()
    seeds, others = SearchSeeds.of(measured.surface, measured.chord)
    guess = torus_cusp_estimates(volume, measured.surface, seeds)
    # the leading edge lies along t = 0.5; its largest cusps stand where the passes end
    edge = (seeds.t > 0.49) & (seeds.t < 0.52)
    cast = edge & np.isfinite(guess)
    assert cast.sum() > 50
    search = CuspSearch(volume, measured.surface, seeds, others, 1.0, 20_000)
    search.run(cast)
    h = search.height[cast]
    high = np.isfinite(h) & (h > 0.5 * np.nanmax(h))
    assert high.sum() >= 5
    ratio = guess[cast][high] / h[high]
    assert ratio.min() >= LEAST_ESTIMATE_SHARE, np.sort(ratio)[:5]
    # most of the edge is still estimated: only where passes end or run down the wall
    assert np.isfinite(guess[edge]).mean() > 0.3


@pytest.mark.parametrize("cutter", ["flat:6", "bull:8:1"])
def test_the_section_estimate_margins_the_ridge_as_far_as_the_passes_bend_away(lying, cutter):
    # the lying blade's far side in 5 axes (lead 10 degrees): the passes' ring centres bend
    # away from the surface (kappa_n R 0.05 to 0.1), the sweep lands material off the
    # plane higher than the prisms carry it, and with a flat 4 % margin the estimate read
    # down to 0.90 times the ray cast; the margin grows with the bend (BEND_AWAY_GROWTH)
    measured = planned(lying, cutter, scallop_mm=0.1, chord_tol_mm=0.05,
                       axis_mode="lead-tilt", lead_deg=10.0)
    volume = measured.volume()
    seeds, others = SearchSeeds.of(measured.surface, measured.chord)
    guess = torus_cusp_estimates(volume, measured.surface, seeds)
    far = (seeds.t > 0.6) & (seeds.t < 1.0) & np.isfinite(guess)
    assert far.sum() > 500
    search = CuspSearch(volume, measured.surface, seeds, others, 1.0, 20_000)
    search.run(far)
    h = search.height[far]
    high = np.isfinite(h) & (h > 0.25 * np.nanmax(h))
    assert high.sum() > 300
    ratio = guess[far][high] / h[high]
    assert ratio.min() >= LEAST_ESTIMATE_SHARE, np.sort(ratio)[:5]
    assert np.median(ratio) < 1.2  # a margin, not a guess far above every cusp


def _pieces(runs):
    """A cut volume's pieces (only what :func:`_runs_on` reads): ``runs`` of (pass, points),
    each run's consecutive points a piece; a bull-nose 8 mm, corner 1 mm, flutes 20 mm."""
    a, b, pass_of = [], [], []
    for index, points in runs:
        points = np.asarray(points, dtype=float)
        a += list(points[:-1])
        b += list(points[1:])
        pass_of += [index] * (len(points) - 1)
    cutter = SimpleNamespace(radius_mm=4.0, corner_radius_mm=1.0, flute_length_mm=20.0)
    return SimpleNamespace(piece_a=np.array(a), piece_b=np.array(b),
                           pass_of=np.array(pass_of), cutter=cutter)


def _holds(volume, piece, centre_x, ridge_x):
    """Whether the pass through (centre_x, 0, 0) on ``piece``, way +x, axis +z, holds the
    pose that leaves a ridge at (ridge_x, 0, 0) in the plane x = ridge_x (normal +y)."""
    row = np.array
    return bool(_runs_on(volume, row([piece]), row([[centre_x, 0.0, 0.0]]),
                         row([[0.0, 0.0, 1.0]]), row([[1.0, 0.0, 0.0]]),
                         row([[0.0, 1.0, 0.0]]), row([[ridge_x, 0.0, 0.0]]),
                         row([[1.0, 0.0, 0.0]]))[0])


def test_a_pass_holds_a_pose_only_where_it_cuts_on_to_it():
    # one pass cut over x 0..5, then, after a rapid under the same pass index, over 8..10:
    # the pose past x = 5 is never taken (the walk read the rapid as cut)
    xs = np.arange(11.0)
    line = [[x, 0.0, 0.0] for x in xs]
    split = _pieces([(0, line[:6]), (0, line[8:])])
    assert _holds(split, 3, 3.5, 4.5)
    assert not _holds(split, 3, 3.5, 5.5)
    assert not _holds(split, 3, 3.5, 6.5)
    # a pass out to x = 10 and straight back under one index never reaches x = 12
    spike = _pieces([(0, line + line[::-1][1:])])
    assert _holds(spike, 5, 5.5, 9.5)
    assert not _holds(spike, 5, 5.5, 12.0)
