"""A ball's chord measurement searched from nearer seeds: the same gaps, fewer steps.

``measure_chord`` places a ball once more where each move's gap model is lowest and
highest; its Newton search there starts on the parabola through the feet at ``u = 0,
1/2, 1`` (``_feet_between``), not on the chord between the ends' feet. The search
converges to the same foot either way (it steps on while the foot moves): the full
method here is every search taking six steps (``seeded_newton=6``) from wherever it
starts. The seeds themselves must lie nearer the feet than the chord's (the saving:
a search whose first step moves the foot by under a tenth of ``CONVERGED_MM`` stops
there). Move by move the gaps agree to a nanometre; without the search's further steps
(the seeds' own gaps) some do not.
"""

import numpy as np
import pytest
from measured_plans import planned

from toolpath import fit_streamline_surface
from toolpath.paper_examples import bundled_data_path
from toolpath.planning import EllipticBladeSurface
from toolpath.planning.chord_measure import (
    _cutting_moves,
    _end_contacts,
    _end_slopes,
    _feet_between,
    _move_chunk_gaps,
    _nearest_samples,
    measure_chord,
)
from toolpath.planning.local import CONVERGED_MM
from toolpath.planning.sampling import chord_extremes, cutter_gap, move_gaps, move_poses
from toolpath.planning.setup import centred_on_table, rotation_from_spec


@pytest.fixture(scope="module")
def standing():
    rows = np.loadtxt(bundled_data_path("dev_blade_15x142.csv"), delimiter=",", skiprows=1)
    sections = rows[:, 1:].reshape(15, 142, 3)[::2]  # every other section: a shorter fit
    blade = fit_streamline_surface(sections, tol=0.01, closed=False)
    return planned(centred_on_table(blade, rotation_from_spec("y:-90")), "ball:6",
                   scallop_mm=0.03, chord_tol_mm=0.01, axis_mode="lead-tilt", lead_deg=10.0)


@pytest.fixture(scope="module")
def spiral():
    return planned(EllipticBladeSurface(), "ball:6", scallop_mm=0.05, chord_tol_mm=0.02,
                   axis_mode="lead-tilt", lead_deg=10.0, linking="spiral")


def _moves(measured):
    """The moves' ends with their contacts, the feet at u = 1/2 and the model's lowest u."""
    path, surface, cutter = measured.path, measured.surface, measured.cutter
    move = _cutting_moves(path)
    contacts = _end_contacts(path, surface, cutter, measured.samples, move, 100_000, 4)
    ends, ia, ib = contacts.of_moves(path, move)
    g, t, s = move_gaps(surface, cutter, ends, np.array([0.5]), newton=6)
    slopes = _end_slopes(cutter, ends, contacts.normal[ia], contacts.normal[ib], None)
    u_low = chord_extremes(g, [0.5], end_slopes=slopes)[1]
    return ends, t[:, 0], s[:, 0], u_low


@pytest.mark.parametrize("name", ["standing", "spiral"])
def test_extremes_seeded_on_the_feet_parabola_lie_nearer(name, request):
    measured = request.getfixturevalue(name)
    surface, cutter = measured.surface, measured.cutter
    ends, t_mid, s_mid, u = _moves(measured)
    closed = bool(surface.closed_t)
    tips, axes = move_poses(ends, u[:, None], None)
    dt = ends.t_b - ends.t_a
    dt = dt - np.round(dt) if closed else dt
    t_chord = ends.t_a + u * dt  # the chord's seeds (across the seam the short way)
    chord = (np.mod(t_chord, 1.0) if closed else t_chord, ends.s_a + u * (ends.s_b - ends.s_a))
    t0, s0 = _feet_between(ends, t_mid, s_mid, u, closed)
    _, t, s = cutter_gap(surface, cutter, tips, axes, t0.ravel(), s0.ravel(), newton=8)
    foot = surface(t, s)
    near = {}
    for key, (ts, ss) in {"chord": chord, "parabola": (t0, s0)}.items():
        off = np.linalg.norm(surface(ts.ravel(), ss.ravel()) - foot, axis=1)
        near[key] = float(np.mean(off < 0.1 * CONVERGED_MM))
    assert near["parabola"] > 0.8 > near["chord"] + 0.2, near


@pytest.mark.parametrize("name", ["standing", "spiral"])
def test_chord_same_as_the_full_search(name, request):
    measured = request.getfixturevalue(name)
    args = (measured.path, measured.surface, measured.cutter, measured.samples)
    fast = measured.chord
    full = measure_chord(*args, seeded_newton=6)
    assert fast.n_moves == full.n_moves > 100
    for key in ("max_mm", "overcut_mm", "undercut_mm"):
        assert getattr(fast, key) == pytest.approx(getattr(full, key), abs=1e-9)
    assert fast.worst_point == full.worst_point


@pytest.mark.parametrize("name", ["standing", "spiral"])
def test_every_moves_extremes_same_as_the_full_search(name, request):
    # move by move: the largest gaps above come from a few moves; the seeds serve all
    measured = request.getfixturevalue(name)
    surface, cutter = measured.surface, measured.cutter
    path = measured.path
    move = _cutting_moves(path)
    gaps = {}
    for newton in (1, 6):
        contacts = _end_contacts(path, surface, cutter, measured.samples, move, 100_000, 4)
        ends, ia, ib = contacts.of_moves(path, move)
        slopes = _end_slopes(cutter, ends, contacts.normal[ia], contacts.normal[ib], None)
        gaps[newton] = _move_chunk_gaps(surface, cutter, ends, contacts.gap[ia],
                                        contacts.gap[ib], 0.0, None, slopes, newton)[0]
    np.testing.assert_allclose(gaps[1], gaps[6], rtol=0.0, atol=1e-9)


def test_nearest_samples_within_a_reach_are_the_tree_s_nearest(spiral):
    # points a ball radius off the surface, and some lifted far above: those have no
    # sample within the reach and are asked again without one
    samples = spiral.samples
    rng = np.random.default_rng(3)
    rows = rng.choice(len(samples.points), 500, replace=False)
    normals = spiral.surface.normal(samples.t[rows], samples.s[rows])
    lift = np.where(np.arange(rows.size) % 5 == 0, 40.0, 3.0)
    points = samples.points[rows] + lift[:, None] * normals
    near = _nearest_samples(samples, points, 3.0)
    assert near.max() < len(samples.points)
    # as near as the tree's nearest (where two samples tie, e.g. on a closed seam, either)
    found = np.linalg.norm(samples.points[near] - points, axis=1)
    np.testing.assert_array_equal(found, samples.tree.query(points)[0])


def test_tip_linear_poses_are_the_ends_interpolated_at_each_move_s_fractions():
    # move_poses without joints, each move at its own fractions (m, k), rows move by move:
    # the tip a + u (b - a), the axis the same, normalized; the definition row by row, to
    # the last bit (the compiled loop it replaces summed the same terms in this order)
    from toolpath.planning.sampling import MoveEnds

    rng = np.random.default_rng(11)
    m, k = 9, 4
    tips_a, tips_b = rng.normal(0.0, 20.0, (m, 3)), rng.normal(0.0, 20.0, (m, 3))
    axes_a, axes_b = rng.normal(size=(m, 3)), rng.normal(size=(m, 3))
    axes_a /= np.linalg.norm(axes_a, axis=1)[:, None]
    axes_b /= np.linalg.norm(axes_b, axis=1)[:, None]
    ends = MoveEnds(tips_a, tips_b, axes_a, axes_b, *rng.random((4, m)))
    u = rng.random((m, k))
    tips, axes = move_poses(ends, u, None)
    assert tips.shape == axes.shape == (m * k, 3)
    for i in range(m):
        for j in range(k):
            tip = tips_a[i] + u[i, j] * (tips_b[i] - tips_a[i])
            axis = axes_a[i] + u[i, j] * (axes_b[i] - axes_a[i])
            size = np.sqrt(axis[0] * axis[0] + axis[1] * axis[1] + axis[2] * axis[2])
            assert np.array_equal(tips[i * k + j], tip)
            assert np.array_equal(axes[i * k + j], axis / size)


def test_a_move_turning_its_axis_half_a_turn_is_named():
    # end axes pointing opposite ways: no axis halfway along the move; the error names the
    # move instead of a division by zero (or NaN axes) further on
    from toolpath.planning.sampling import MoveEnds

    up, down = np.array([[0.0, 0.0, 1.0], [0.0, 0.0, 1.0]]), np.array([[0.0, 0.0, 1.0],
                                                                     [0.0, 0.0, -1.0]])
    ends = MoveEnds(np.zeros((2, 3)), np.ones((2, 3)), up, down, *np.zeros((4, 2)))
    with pytest.raises(ValueError, match=r"move 1 of this chunk turns its tool axis half a turn"):
        move_poses(ends, np.array([[0.25, 0.5], [0.25, 0.5]]), None)
