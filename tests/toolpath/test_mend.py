"""Issue 23: the fairness mend is robust, not tuned to the bundled blades.

Sections are built from the traits the issue names, not from the bundled files: flanks
sampled 1-8 mm apart beside small LE/TE nose circles sampled 0.01-0.03 mm apart, closed
with a round or a sharp trailing edge (DCA-style, propeller-style) or open with a blunt
base (blunt-style). Each is perturbed: its spacings, radii and point counts drawn from a
seeded generator, the seam moved, and a few micrometres of seeded noise added to its
flanks. The fit at tol 0.01 must then have no concave stretch deeper than 1 um and stay
within tol of the data's nose circles, for both methods, curves and surfaces (stacked
sections of one shape, scaled and twisted, with ragged point counts), open and closed.
"""

import warnings

import numpy as np
import pytest

from toolpath import (
    as_sections,
    fit_bspline_curve,
    fit_bspline_surface,
    fit_streamline_curve,
    fit_streamline_surface,
)
from toolpath.errors import ConvergenceWarning
from toolpath.fairness import SAMPLES_PER_INTERVAL, curve_fairness, surface_fairness

TOL_MM = 0.01
FITTERS = [fit_streamline_curve, fit_bspline_curve]
STYLES = ["dca", "prop", "blunt"]


def _heading(frm, to):
    return float(np.arctan2(to[1] - frm[1], to[0] - frm[0]))


def _arc_points(centre, radius, a0, a1, steps_mm):
    """Points on an arc from angle ``a0`` to ``a1`` (rad), spaced as ``steps_mm`` scaled to
    the arc's length; the last point (at ``a1``) is left out."""
    s = np.concatenate(([0.0], np.cumsum(steps_mm)))
    a = a0 + (a1 - a0) * s[:-1] / s[-1]
    return centre + radius * np.c_[np.cos(a), np.sin(a)]


def _graded_steps(first_mm, largest_mm, length_mm, growth):
    """Steps growing by ``growth`` from ``first_mm`` to at most ``largest_mm``, then even,
    then shrinking back to ``first_mm`` (symmetric), over ``length_mm``."""
    ramp = [first_mm]
    while ramp[-1] * growth < largest_mm and 2 * sum(ramp) < length_mm:
        ramp.append(ramp[-1] * growth)
    middle = max(length_mm - 2 * sum(ramp), 0.0)
    n_mid = int(np.ceil(middle / largest_mm))
    return np.array(ramp + [middle / n_mid] * n_mid + ramp[::-1]) if n_mid else \
        np.array(ramp + ramp[::-1])


def trait_section(style, seed):
    """A perturbed section with the issue's traits (module doc), in 3-D, and its closure."""
    rng = np.random.default_rng(seed)
    chord, half = 50.0, rng.uniform(1.5, 3.0)
    flank_radius = rng.uniform(60.0, 120.0)
    le_r = rng.uniform(0.2, 0.45)
    te_r = {"dca": rng.uniform(0.1, 0.2), "prop": 0.0, "blunt": 0.0}[style]
    nose_step = rng.uniform(0.01, 0.03)
    flank_max = rng.uniform(1.0, 8.0)
    growth = rng.uniform(1.15, 1.6)
    d, mid = flank_radius - half, 0.5 * chord
    upper_c, lower_c = np.array([mid, -d]), np.array([mid, d])
    le = np.array([mid - np.sqrt((flank_radius - le_r) ** 2 - d**2), 0.0])
    if style == "dca":
        te = np.array([mid + np.sqrt((flank_radius - te_r) ** 2 - d**2), 0.0])
    else:  # the flanks meet at the TE (prop: a sharp wedge) or stop short of it (blunt)
        te = np.array([mid + np.sqrt(flank_radius**2 - d**2), 0.0])

    def flank(centre, frm, to):
        """The flank arc from the point ``frm`` to ``to`` on the circle round ``centre``."""
        a0, a1 = _heading(centre, frm), _heading(centre, to)
        steps = _graded_steps(nose_step * rng.uniform(1.0, 2.0), flank_max,
                              abs(a1 - a0) * flank_radius, growth)
        return _arc_points(centre, flank_radius, a0, a1,
                           steps * rng.uniform(0.9, 1.1, steps.size))

    def nose(centre, r, a0, a1):
        a1 = a0 + np.mod(a1 - a0, 2 * np.pi)
        n = int(np.ceil((a1 - a0) * r / nose_step))
        return _arc_points(centre, r, a0, a1, np.ones(n))

    def meets(centre, end):
        """Where the flank circle round ``centre`` meets the nose (or edge) at ``end``:
        on the ray from its centre through the nose circle's (internally tangent)."""
        return centre + flank_radius * (end - centre) / np.linalg.norm(end - centre)

    upper = flank(upper_c, meets(upper_c, te), meets(upper_c, le))
    lower = flank(lower_c, meets(lower_c, le), meets(lower_c, te))
    parts = [upper, nose(le, le_r, _heading(upper_c, le), _heading(lower_c, le)), lower]
    if style == "dca":
        parts.append(nose(te, te_r, _heading(lower_c, te), _heading(upper_c, te)))
    loop = np.vstack(parts)
    if style == "blunt":  # drop the last stretch of each flank: an open, blunt base
        cut = loop[:, 0] > chord - 0.8
        loop = loop[~cut]
        closed = False
    else:
        closed = True
    # a few micrometres of noise across the flanks; on a nose sampled 0.02 mm apart it
    # would swamp the data's own turning (the circle through three points), so the noses
    # stay exact
    steps = np.linalg.norm(np.diff(loop, axis=0), axis=1)
    on_flank = np.r_[steps, steps[-1]] > 0.3
    tangent = np.gradient(loop, axis=0)
    normal = np.c_[-tangent[:, 1], tangent[:, 0]] / np.linalg.norm(tangent, axis=1)[:, None]
    loop = loop + (on_flank * rng.normal(0.0, 0.002, len(loop)))[:, None] * normal
    if closed:
        loop = np.roll(loop, -int(rng.integers(len(loop))), axis=0)
    angle = rng.uniform(0, 2 * np.pi)
    rot = np.array([[np.cos(angle), -np.sin(angle)], [np.sin(angle), np.cos(angle)]])
    loop = loop @ rot.T
    return np.c_[loop, 0.05 * loop[:, 0]] + [120.0, -30.0, 8.0], closed


def test_trait_sections_have_the_traits():
    for style in STYLES:
        for seed in range(3):
            points, closed = trait_section(style, seed)
            ring = np.vstack((points, points[:1])) if closed else points
            steps = np.linalg.norm(np.diff(ring, axis=0), axis=1)
            assert closed == (style != "blunt")
            assert 0.01 <= steps.min() <= 0.03 * 2  # nose steps (a flank's first is 1-2x)
            assert 1.0 <= steps.max() <= 8.0  # flank steps


# the seeds of the harness runs (seeds 0-49, 150 sections, both methods) that the earlier
# mend left unfair (1-7 um stretches): nose-flank joins with graded spacing, dense noses
HARD = [("dca", 2), ("dca", 13), ("prop", 16), ("prop", 19), ("blunt", 7), ("blunt", 23),
        # seeds 0-99 (600 fits): a TE wedge 0.008 mm past a seam on a dense nose (the
        # closed driver's seam knot took a copy of the wedge's corner knot), and a ring
        # after a TE nose meeting its flank that only letting go of the points there mends
        ("prop", 57), ("dca", 69),
        # the last two of the 600: a nose meeting its flank G1 (curvature 2.5/mm to
        # 0.01/mm at one sample) that a C2 fit rings across however dense its knots; a
        # double knot at the join sample mends it
        ("prop", 10), ("prop", 84),
        # on an AMD EPYC CI runner: a DCA TE ring beside the seam that every jump knot
        # failed to mend (the knot on a sample came back from the driver's view rounded
        # past it, leaving a span with no data point), left 1.1 um concave
        ("dca", 62)]


@pytest.mark.parametrize("style,seed", HARD)
@pytest.mark.parametrize("fit", FITTERS)
def test_perturbed_trait_sections_fit_fair(fit, style, seed):
    points, closed = trait_section(style, seed)
    with warnings.catch_warnings():
        warnings.simplefilter("error", ConvergenceWarning)
        curve = fit(points, tol=TOL_MM, closed=closed)
    fairness = curve_fairness(curve, points, closed=closed)
    assert curve.max_error <= TOL_MM
    assert fairness.n_concave == 0, fairness.line()
    assert fairness.nose_error_mm <= TOL_MM, fairness.nose_line()


def trait_blade(style, seed, n_sections=4, ragged=True):
    """Sections of one trait section's shape, scaled and twisted from hub to tip, each with
    a few flank points of its own dropped (``ragged``: the counts differ) and its seam
    moved."""
    base, closed = trait_section(style, seed)
    rng = np.random.default_rng(seed + 1000)
    centre = base.mean(axis=0)
    sections = []
    for j in range(n_sections):
        scale, twist = 1.0 - 0.04 * j, np.radians(3.0 * j)
        rot = np.array([[np.cos(twist), -np.sin(twist), 0.0],
                        [np.sin(twist), np.cos(twist), 0.0], [0.0, 0.0, 1.0]])
        points = (base - centre) @ rot.T * scale + centre + [0.0, 0.0, 12.0 * j]
        steps = np.linalg.norm(np.diff(points, axis=0), axis=1)
        flank = np.flatnonzero(steps[:-1] > 1.0) + 1  # interior points with long steps
        keep = np.setdiff1d(np.arange(len(points)),
                            rng.choice(flank, size=min(j if ragged else 0, flank.size),
                                       replace=False))
        points = points[keep]
        if closed:
            points = np.roll(points, int(rng.integers(-3, 4)), axis=0)
        sections.append(points)
    return sections, closed


@pytest.mark.parametrize("style,seed", [("dca", 1), ("blunt", 2)])
@pytest.mark.parametrize("fit", [fit_streamline_surface, fit_bspline_surface])
def test_perturbed_trait_blades_fit_fair(fit, style, seed):
    sections, closed = trait_blade(style, seed)
    assert len({len(p) for p in sections}) > 1  # ragged: a matched (union) grid
    grid = as_sections(sections, closed=closed)
    with warnings.catch_warnings():
        warnings.simplefilter("error", ConvergenceWarning)
        surface = fit(grid, tol=TOL_MM)
    fairness = surface_fairness(surface, grid.points,
                                per_interval=grid.samples_per_column(SAMPLES_PER_INTERVAL))
    assert surface.closed_t == closed and surface.max_error <= TOL_MM
    assert fairness.n_concave == 0, fairness.line()
    assert fairness.nose_error_mm <= TOL_MM, fairness.nose_line()


def test_sections_sampled_alike_from_other_starts_share_columns():
    # the same relative stations, seams moved: the matched parameters agree to rounding,
    # one column each (two would repeat every section's point: a 0/0 in the corner test)
    sections, closed = trait_blade("dca", 1, ragged=False)
    grid = as_sections(sections, closed=closed)
    steps = np.linalg.norm(np.diff(grid.stacked, axis=0), axis=1)
    assert steps.min() > 0.0
    with warnings.catch_warnings():
        warnings.simplefilter("error", RuntimeWarning)
        assert fit_bspline_surface(grid, tol=TOL_MM).max_error <= TOL_MM


@pytest.mark.parametrize("copies", [1, 2])
def test_jump_knot_goes_in_once_for_stretches_sharing_a_jump(copies):
    """Two concave stretches within reach of one curvature jump (a nose circle meeting a
    straight flank) pick the same interval: its knot goes in ``copies`` times in all, not
    once per stretch (a 4-fold knot would break the cubic there and read as a corner)."""
    from toolpath.adaptive import _jump_knots
    from toolpath.splinefit import DEGREE

    a = np.linspace(0.5 * np.pi, 1.5 * np.pi, 15)
    nose = np.c_[np.cos(a), np.sin(a)]
    upper = np.c_[np.linspace(5.0, 0.3, 10), np.ones(10)]
    lower = np.c_[np.linspace(0.3, 5.0, 10), -np.ones(10)]
    points = np.vstack((upper, nose, lower))
    t = np.linspace(0.0, 1.0, len(points))
    knots = np.r_[[0.0] * (DEGREE + 1), np.linspace(0.0, 1.0, 9)[1:-1], [1.0] * (DEGREE + 1)]
    one = [(0.55, 0.6, 0.01, "a", "x")]
    two = [*one, (0.6, 0.65, 0.01, "b", "x")]
    alone = _jump_knots(knots, points, t, one, copies)
    shared = _jump_knots(knots, points, t, two, copies)
    assert alone.size == knots.size + copies  # the jump does get its knot
    np.testing.assert_array_equal(shared, alone)
    _, counts = np.unique(shared, return_counts=True)
    assert counts[1:-1].max() <= copies
