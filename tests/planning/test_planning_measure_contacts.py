"""The chord measurement's ball contacts, seeded along runs, against the full method.

``measure_chord`` searches a ball's contact from the nearest surface sample at every
``contact_stride``-th location along a run of cutting moves and seeds the locations
between from those contacts; ``contact_stride=1`` seeds every location from its own
nearest sample (the full method, the oracle here). Both must find the same feet: the same
gaps, the same cusp seeds, also where a seed interpolated between the anchors' feet would
start in another local minimum's basin (a groove narrower than the ball).
"""

import numpy as np
import pytest
from measured_plans import planned

import toolpath.planning.chord_measure as chord_measure
from toolpath.path import MoveKind, Toolpath
from toolpath.planning import EllipticBladeSurface, SpherePatch, parse_cutter
from toolpath.planning.gouge import sample_surface
from toolpath.planning.setup import PlacedSurface
from toolpath.surface import ParametricSurface

#: Feet found from either seed agree to within the Newton search's convergence (its last
#: step moves a foot by under a micrometre; the next by far less): mm and parameter.
SAME_GAP_MM = 1e-9
SAME_PARAMETER = 1e-7
#: ... and over a groove's flat shoulders, where the distance changes only to second order
#: with the foot's place, the converged foot is less exact than its distance: 1e-6 of the
#: groove's 20 mm patch is 20 nm (a wrong foot lies tenths of a mm away).
SAME_SHOULDER_PARAMETER = 1e-6


def _chord_inputs(surface, cutter, **options):
    """What the plan's measure stage gives ``measure_chord`` (:mod:`measured_plans`)."""
    measured = planned(surface, cutter, **options)
    args = (measured.path, measured.surface, measured.cutter, measured.samples)
    return args, {"machine": measured.machine}


def _same_contacts(args, kwargs, **full_method):
    """The fast measure and the full method (``full_method``) find the same gaps and seeds."""
    fast = chord_measure.measure_chord(*args, **kwargs)
    full = chord_measure.measure_chord(*args, **kwargs, **(full_method or {"contact_stride": 1}))
    assert full.n_moves == fast.n_moves > 100
    for name in ("max_mm", "overcut_mm", "undercut_mm", "contact_mm"):
        assert getattr(fast, name) == pytest.approx(getattr(full, name), abs=SAME_GAP_MM)
    assert np.array_equal(fast.seeds_pass, full.seeds_pass)
    assert np.abs(fast.seeds_t - full.seeds_t).max() < SAME_PARAMETER
    assert np.abs(fast.seeds_s - full.seeds_s).max() < SAME_PARAMETER
    assert full.max_mm > 0.0


@pytest.mark.parametrize("axis", [{"axis_mode": "3"},
                                  {"axis_mode": "lead-tilt", "lead_deg": 10.0}])
def test_sphere_cap_contacts_match_the_full_method(axis):
    cap = SpherePatch(radius_mm=50.0, longitude_deg=(-20.0, 20.0), colatitude_deg=(15.0, 40.0))
    _same_contacts(*_chord_inputs(cap, "ball:6", scallop_mm=0.02,
                                  chord_tol_mm=0.01, **axis))


@pytest.mark.parametrize("axis", [{"axis_mode": "3"},
                                  {"axis_mode": "lead-tilt", "lead_deg": 10.0}])
def test_sphere_contacts_in_closed_form_match_the_newton_search(axis):
    # a ball's contact on a sphere is its centre's radial projection, every location's own
    # seed (SpherePatch.closest_parameters); the same sphere placed where it is
    # (PlacedSurface: no closed form) is searched by Newton from the surface samples
    cap = SpherePatch(radius_mm=50.0, longitude_deg=(-20.0, 20.0), colatitude_deg=(15.0, 40.0))
    args, kwargs = _chord_inputs(cap, "ball:6", scallop_mm=0.02, chord_tol_mm=0.01, **axis)
    path, _, cutter, samples = args
    placed = PlacedSurface(cap, np.eye(3))
    assert getattr(placed, "closest_parameters", None) is None
    closed = chord_measure.measure_chord(*args, **kwargs)
    for stride in (chord_measure.CONTACT_STRIDE, 1):
        newton = chord_measure.measure_chord(path, placed, cutter, samples, **kwargs,
                                             contact_stride=stride)
        for name in ("max_mm", "overcut_mm", "undercut_mm", "contact_mm"):
            assert getattr(closed, name) == pytest.approx(getattr(newton, name),
                                                          abs=SAME_GAP_MM)
        assert np.array_equal(closed.seeds_pass, newton.seeds_pass)
        assert np.abs(closed.seeds_t - newton.seeds_t).max() < SAME_PARAMETER
        assert np.abs(closed.seeds_s - newton.seeds_s).max() < SAME_PARAMETER
        assert np.abs(closed.seeds_q - newton.seeds_q).max() < SAME_GAP_MM
    assert closed.max_mm > 0.0


def test_closed_blade_spiral_across_the_seam():
    # one spiral round closed sections: runs cross the seam, where t wraps
    blade = EllipticBladeSurface()
    assert blade.closed_t
    _same_contacts(*_chord_inputs(blade, "ball:6", scallop_mm=0.05,
                                  chord_tol_mm=0.02, axis_mode="lead-tilt", lead_deg=10.0,
                                  linking="spiral"))


def test_seeded_contacts_take_one_newton_step_and_match_more_steps():
    # a ball's contacts seeded by their neighbours' feet (between anchors, inside moves)
    # take SEEDED_CONTACT_NEWTON steps, then more only while the foot still moves; six
    # steps everywhere (the full method) find the same feet (round a closed blade, where
    # one step alone leaves the feet 1e-6 mm off)
    assert chord_measure.SEEDED_CONTACT_NEWTON < 6
    _same_contacts(*_chord_inputs(EllipticBladeSurface(), "ball:6", scallop_mm=0.02,
                                  chord_tol_mm=0.01, axis_mode="lead-tilt", lead_deg=10.0,
                                  linking="spiral"), seeded_newton=6)


def test_flat_and_bull_nose_contacts_keep_their_own_seeds():
    # a guard of the policy, not of a computation: only a ball's contacts are seeded from
    # the anchors' (a flat or bull-nose cutter's disc search and re-seed check keep a
    # sample of their own for every location)
    cap = SpherePatch(radius_mm=50.0, longitude_deg=(-10.0, 10.0), colatitude_deg=(20.0, 30.0))
    args, kwargs = _chord_inputs(cap, "bull:8:1", scallop_mm=0.05,
                                 chord_tol_mm=0.02)
    fast = chord_measure.measure_chord(*args, **kwargs)
    full = chord_measure.measure_chord(*args, **kwargs, contact_stride=1)
    for name in ("max_mm", "overcut_mm", "undercut_mm", "contact_mm", "worst_point"):
        assert getattr(fast, name) == getattr(full, name)
    for name in ("seeds_t", "seeds_s", "seeds_pass"):
        assert np.array_equal(getattr(fast, name), getattr(full, name))


class _GroovedPlane(ParametricSurface):
    """``z = -d exp(-(x - c)^2 / (2 w^2))`` over ``x = L t``, ``y = L_y s``: a groove along y.

    Narrower than a ball of radius 3 (``w`` a few tenths of a mm): a ball over it touches
    its two shoulders, and from a centre off its middle the far shoulder is a local
    minimum of the distance too.
    """

    def __init__(self, depth_mm=2.0, width_mm=0.4, length_mm=20.0, centre_mm=10.0,
                 span_mm=10.0):
        self.d, self.w, self.length, self.c, self.span = (depth_mm, width_mm, length_mm,
                                                          centre_mm, span_mm)

    def _partials(self, t, s, dt, ds):
        u = (self.length * t - self.c) / self.w
        z = -self.d * np.exp(-0.5 * u * u)
        zero = np.zeros_like(t)
        if (dt, ds) == (0, 0):
            return np.stack([self.length * t, self.span * s, z], axis=1)
        if (dt, ds) == (1, 0):
            return np.stack([np.full_like(t, self.length), zero,
                             -u / self.w * z * self.length], axis=1)
        if (dt, ds) == (0, 1):
            return np.stack([zero, np.full_like(t, self.span), zero], axis=1)
        if (dt, ds) == (2, 0):
            return np.stack([zero, zero, (u * u - 1.0) / self.w**2 * z * self.length**2],
                            axis=1)
        return np.zeros((t.size, 3))


def _passes_over_the_groove(groove, dip_mm):
    """Straight 3-axis passes along x, 0.25 mm steps, starting 0.05 mm later each pass.

    The ball dips into the groove (its tip ``dip_mm`` below the plane at the middle, a
    bell of 0.8 mm), so it cuts the shoulders there; the passes' offsets put anchors at
    each place round the groove.
    """
    tips, kinds, passes = [], [], []
    for k, y in enumerate(np.linspace(1.0, 9.0, 5)):
        x = np.arange(2.0 + 0.05 * k, 18.0, 0.25)
        z = -dip_mm * np.exp(-0.5 * ((x - groove.c) / 0.8) ** 2)
        tips.append(np.stack([x, np.full_like(x, y), z], axis=1))
        kinds.append(np.r_[MoveKind.RAPID, np.full(x.size - 1, MoveKind.CUT)])
        passes.append(np.full(x.size, k))
    tips = np.concatenate(tips)
    return Toolpath(tips, np.tile([0.0, 0.0, 1.0], (len(tips), 1)),
                    np.concatenate(kinds).astype(np.uint8), np.full(len(tips), 1000.0),
                    np.concatenate(passes).astype(np.int32))


@pytest.mark.parametrize(("depth_mm", "width_mm", "dip_mm"), [
    # anchors on either shoulder: seeds between them start in the groove, some on the
    # wrong wall, and from there Newton climbs to the far shoulder (a gouge read as a gap)
    (2.0, 0.4, 0.2),
    # shallower and narrower, the ball deeper in: a foot on the far shoulder reads a gouge
    # of 0.258 mm as 0.163 mm, its gap between the anchors' and their feet close enough;
    # only a neighbour's foot nearer to the centre than its own gives it away
    (0.5, 0.2, 0.3),
])
def test_groove_narrower_than_the_ball_matches_the_full_method(depth_mm, width_mm, dip_mm):
    groove = _GroovedPlane(depth_mm=depth_mm, width_mm=width_mm)
    path = _passes_over_the_groove(groove, dip_mm)
    args = (path, groove, parse_cutter("ball:6"), sample_surface(groove, 0.25))
    fast = chord_measure.measure_chord(*args)
    full = chord_measure.measure_chord(*args, contact_stride=1)
    assert full.overcut_mm > 0.05  # the shoulders are cut
    for name in ("max_mm", "overcut_mm", "undercut_mm", "contact_mm"):
        assert getattr(fast, name) == pytest.approx(getattr(full, name), abs=SAME_GAP_MM)
    assert np.array_equal(fast.seeds_pass, full.seeds_pass)
    assert np.abs(fast.seeds_t - full.seeds_t).max() < SAME_SHOULDER_PARAMETER
    assert np.abs(fast.seeds_s - full.seeds_s).max() < SAME_SHOULDER_PARAMETER


@pytest.mark.parametrize("binned_mm", [None, 1.0, 4.0])
def test_the_nearest_sample_in_the_cells_is_the_k_d_tree_s(binned_mm):
    # the samples' cells (none binned yet, or binned finer or coarser than the reach for
    # another search) give each point the sample the k-d tree gives, within the reach,
    # and none beyond it; lifted points beyond the reach get the tree's nearest of all
    from toolpath.planning.gouge import SurfaceSamples

    rng = np.random.default_rng(7)
    t, s = rng.random(4000), rng.random(4000)
    points = np.stack([40.0 * t, 25.0 * s, 3.0 * np.sin(6.0 * t) * np.cos(4.0 * s)], axis=1)
    samples = SurfaceSamples(points=points, t=t, s=s, spacing_mm=0.6)
    if binned_mm is not None:
        samples.cells(binned_mm)
    lift = rng.choice([0.5, 3.0, 6.0], 3000)[:, None]
    normal = rng.normal(size=(3000, 3))
    normal /= np.linalg.norm(normal, axis=1)[:, None]
    queries = points[rng.integers(0, 4000, 3000)] + lift * normal
    reach = 3.0 + samples.spacing_mm
    found = samples.nearest(queries, reach)
    want = samples.tree.query(queries, distance_upper_bound=reach)[1]
    within = want < len(points)
    assert 0 < within.sum() < len(queries)
    assert np.array_equal(found >= 0, within)
    assert np.array_equal(found[within], want[within])
    nearest = chord_measure._nearest_samples(samples, queries, 3.0)
    assert np.array_equal(nearest, samples.tree.query(queries)[1])


def test_the_nearest_sample_of_two_as_near_is_the_lower_and_none_at_the_reach():
    # a closed surface's seam samples its points twice: of two copies the lower index,
    # whichever cell each lies in; a sample exactly at the reach is not within it
    from toolpath.planning.gouge import SurfaceSamples

    points = np.array([[5.0, 0.0, 0.0], [0.0, 0.0, 0.0], [9.0, 9.0, 9.0], [0.0, 0.0, 0.0]])
    samples = SurfaceSamples(points=points, t=np.zeros(4), s=np.zeros(4), spacing_mm=1.0)
    samples.cells(0.5)
    queries = np.array([[0.0, 0.0, 1.0], [2.0, 0.0, 0.0], [0.0, 3.0, 0.0]])
    assert samples.nearest(queries, 3.0).tolist() == [1, 1, -1]
