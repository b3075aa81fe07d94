"""Sections matched before a surface is built; the error between sections, true and estimated.

The DCA rotor (``dev_rotor_dca_11x181.csv``) has nose point counts that vary and a start
point that moves along the trailing-edge nose; its true surface between sections is
``tests/data/blades/dev_rotor_dca_truth_10x1000.csv`` (10 contours midway between them).
"""

from pathlib import Path

import numpy as np
import pytest
from scipy.spatial import cKDTree

from toolpath import as_sections, fit_bspline_surface, fit_streamline_surface, read_sections
from toolpath.between_sections import interpolation_errors
from toolpath.errors import InvalidPointsError
from toolpath.paper_examples import bundled_data_path
from toolpath.planning.local import project_to_surface

TRUTH = Path(__file__).parent.parent / "data" / "blades" / "dev_rotor_dca_truth_10x1000.csv"
TOL_MM = 0.01


@pytest.fixture(scope="module")
def dca():
    return read_sections(bundled_data_path("dev_rotor_dca_11x181.csv"))


@pytest.fixture(scope="module")
def truth():
    return np.concatenate(read_sections(TRUTH))


def distances_to_surface(surface, points):
    """Distance (mm) from each point to the surface: Newton projection from the nearest
    sample of a start grid (the data columns halved, and uniform for the points the first
    left farther than half the tolerance), the smaller result."""
    tp = surface.t_params
    refined = np.unique(np.concatenate((tp, 0.5 * (tp[1:] + tp[:-1]))))
    best = np.full(len(points), np.inf)
    todo = np.arange(len(points))
    for t_grid in (refined, np.linspace(0.0, 1.0, 2001)):
        t, s = np.meshgrid(t_grid, np.linspace(0.0, 1.0, 41))
        _, nearest = cKDTree(surface(t.ravel(), s.ravel())).query(points[todo])
        _, _, d = project_to_surface(surface, points[todo], t.ravel()[nearest],
                                     s.ravel()[nearest], iterations=8)
        best[todo] = np.minimum(best[todo], d)
        todo = todo[best[todo] > 0.5 * TOL_MM]
    return best


def data_t(grid, j):
    """Matched parameters of section ``j``'s data points, in the grid's order."""
    return grid.t[grid.mask[j]] if grid.mask is not None else grid.t


def farthest_from_first(points):
    """Index of the point farthest from the first (on the DCA: a point of the LE nose)."""
    return int(np.argmax(np.linalg.norm(points - points[0], axis=1)))


# ---------------------------------------------------------------------- matching
@pytest.mark.parametrize("closed", [False, True])
def test_leading_edges_share_one_parameter_whatever_the_start_point(dca, closed):
    rng = np.random.default_rng(7)
    shifted = [np.roll(p, int(rng.integers(-40, 40)), axis=0) for p in dca]
    if not closed:  # an open section keeps its ends: shift only where the loop is closed
        shifted = dca
    for sections in (dca, shifted):
        grid = as_sections(sections, closed=closed)
        t_le = []
        for j, p in enumerate(sections):
            nose = p[farthest_from_first(p)] if not closed else None
            if closed:  # the LE nose point farthest from the section's TE (grid column 0)
                data = grid.points[j][grid.mask[j]]
                nose = data[farthest_from_first(np.vstack((grid.points[j, :1], data)))
                            - 1]
            column = np.flatnonzero(grid.mask[j] & np.all(grid.points[j] == nose, axis=1))
            assert column.size == 1
            t_le.append(grid.t[column[0]])
        # the nose is about 0.0004 apart in t: the same nose place on every section
        assert np.ptp(t_le) < 0.0015, t_le


def test_shuffled_start_gives_the_same_matched_sections(dca):
    rng = np.random.default_rng(3)
    shifted = [np.roll(p, int(rng.integers(1, 180)), axis=0) for p in dca]
    a, b = as_sections(dca, closed=True), as_sections(shifted, closed=True)
    assert a.points.shape == b.points.shape
    assert np.abs(a.t - b.t).max() < 1e-9
    assert np.abs(a.points - b.points).max() < 1e-9
    assert (a.mask == b.mask).all()


@pytest.fixture(scope="module")
def propeller():
    """The propeller's sections: closed, a sharp trailing-edge wedge at point 0 of each."""
    return read_sections(bundled_data_path("dev_prop_7x100.csv"))


def wedge_curvature(surface):
    """Largest principal curvature (1/mm, either sign) beside the seam (``t`` within 0.02
    of it, the seam itself left out), hub to tip."""
    t = np.r_[np.linspace(0.98, 1.0 - 1e-6, 200), np.linspace(1e-6, 0.02, 200)]
    k1, k2 = surface.principal_curvatures(t, np.linspace(0.0, 1.0, 60), grid=True)
    return float(np.abs(np.concatenate([k1.ravel(), k2.ravel()])).max())


@pytest.mark.parametrize("export", ["reversed", "one past the edge", "one before it",
                                    "from the leading edge", "starts apart",
                                    "every other at half the stations"])
def test_a_sharp_trailing_edge_is_the_seam_wherever_the_export_starts(propeller, export):
    # the wedge is a corner of the data: the fit keeps a corner C0 only at the seam, and
    # the planner's passes meet only there. With the points reversed the wedge stood one
    # point before the seam (the sections correspond, so the seams stayed where they
    # were): knots at the wedge and at the seam one point apart bent the hub 0.09 mm
    # round the edge (curvature 11/mm) and a ball cutter cut 0.24 mm into it; starting
    # at the leading edge the corner stood mid-way, in the passes' way (a 5.5 mm gouge
    # after six minutes); rolled apart section by section (columns bunched round the
    # seam on the union grid) the seam read no corner and the fit rounded the wedge; with
    # every other section at half the stations, their entries between points, wrapped
    # round the seam, rounded the wedge the others' data keep sharp, and the fit folded
    # (curvature 4,300/mm beside the seam)
    turned = {"reversed": [p[::-1] for p in propeller],
              "one past the edge": [np.roll(p, -1, axis=0) for p in propeller],
              "one before it": [np.roll(p, 1, axis=0) for p in propeller],
              "from the leading edge": [np.roll(p, -50, axis=0) for p in propeller],
              "starts apart": [np.roll(p, 37 + 5 * j, axis=0)
                               for j, p in enumerate(propeller)],
              "every other at half the stations": [p[::1 + j % 2]
                                                   for j, p in enumerate(propeller)]}[export]
    grid = as_sections(turned)
    wedge = np.array([p[0] for p in propeller])
    assert np.abs(grid.points[:, 0] - wedge).max() < 1e-9  # the seam is the wedge's point
    surface = fit_streamline_surface(turned, tol=TOL_MM)
    assert np.count_nonzero(surface.knots_t == 0.0) == 3  # C0 at the seam
    assert wedge_curvature(surface) < 0.1  # as the export the data come in: 0.026


def test_the_propeller_as_exported_keeps_its_wedge(propeller):
    # the yardstick of the exports above: the bundled order, its seam on the wedge already
    assert wedge_curvature(fit_streamline_surface(list(propeller), tol=TOL_MM)) < 0.1


def test_a_section_running_the_other_way_is_named(dca):
    sections = list(dca)
    sections[4] = sections[4][::-1]
    with pytest.raises(InvalidPointsError, match="section 4 runs the other way round"):
        as_sections(sections, closed=False)


def test_ragged_sections_are_fitted_and_measured_at_their_own_points(dca):
    sections = [p.copy() for p in dca]
    sections[2] = np.delete(sections[2], np.arange(5, 60, 3), axis=0)  # thinner flank
    sections[6] = np.delete(sections[6], [84, 86, 88], axis=0)  # fewer LE nose points
    sections[9] = sections[9][:-7]  # shorter at the end
    counts = [len(p) for p in sections]
    grid = as_sections(sections, closed=False)
    assert grid.data_counts == counts
    for j, p in enumerate(sections):  # every data point is a grid entry, exactly
        assert np.array_equal(grid.points[j][grid.mask[j]], p)
    surface = fit_bspline_surface(grid, tol=TOL_MM)
    own = [np.linalg.norm(surface(data_t(grid, j), np.full(counts[j], grid.s[j])) - p, axis=1)
           for j, p in enumerate(sections)]
    worst = max(e.max() for e in own)
    assert surface.max_error <= TOL_MM
    assert worst == pytest.approx(surface.max_error, abs=1e-9)
    rms = np.sqrt(np.mean(np.concatenate(own) ** 2))
    assert surface.rms_error == pytest.approx(rms, rel=1e-6)


# ---------------------------------------------------------------------- between sections
@pytest.fixture(scope="module")
def dca_fits(dca, truth):
    out = {}
    for closed in (False, True):
        for name, fit in (("streamline", fit_streamline_surface),
                          ("bspline", fit_bspline_surface)):
            surface = fit(dca, tol=TOL_MM, closed=closed)
            out[name, closed] = surface, float(distances_to_surface(surface, truth).max())
    return out


@pytest.mark.parametrize("closed", [False, True])
@pytest.mark.parametrize("method", ["streamline", "bspline"])
def test_dca_rotor_is_faithful_between_sections(dca_fits, method, closed):
    surface, true_mm = dca_fits[method, closed]
    assert surface.max_error <= TOL_MM
    assert true_mm <= 2.0 * TOL_MM  # 0.043-0.048 mm before the sections were matched


@pytest.mark.parametrize("closed", [False, True])
@pytest.mark.parametrize("method", ["streamline", "bspline"])
def test_between_sections_estimate_is_within_2x_of_the_truth(dca_fits, method, closed):
    surface, true_mm = dca_fits[method, closed]
    assert 0.5 * true_mm <= surface.between_error <= 2.0 * true_mm
    assert surface.loo_error > surface.between_error  # the old figure: an upper bound


def test_unmatched_sections_show_in_the_interpolation_estimate(dca):
    # index-wise columns (params as one array) join nose points to flank points
    matched = as_sections(dca, closed=False)
    by_index = as_sections(dca, closed=False, params=np.linspace(0.0, 1.0, 181))
    assert interpolation_errors(matched.s, matched.points).max() < 0.002
    assert interpolation_errors(by_index.s, by_index.points).max() > 0.05


# ------------------------------------------------- noses meeting their flanks (G1 only)
def nosed_section(chord_mm, le_mm, te_mm, start_deg, z_mm, twist_deg, flank_mm=100.0):
    """A convex closed section: LE and TE nose circles ``chord_mm`` apart joined by two
    flank arcs of radius ``flank_mm`` tangent to both, so the curvature jumps (1/0.2 mm to
    1/100 mm) where a nose meets a flank. Sampled like a CAD export: noses every 7.5 deg,
    flanks 15 % longer per step up to 2.5 mm; the first point on the TE nose
    ``start_deg`` above its tip, the last one step short of it (not repeated)."""
    le, te = np.array([0.0, 0.0]), np.array([chord_mm, 0.0])
    a, b = flank_mm - le_mm, flank_mm - te_mm  # flank centre's distances from the centres
    x = (a * a - b * b + chord_mm**2) / (2 * chord_mm)
    below, above = np.array([x, -np.sqrt(a * a - x * x)]), np.array([x, np.sqrt(a * a - x * x)])

    def angle(v):
        return float(np.mod(np.arctan2(v[1], v[0]), 2 * np.pi))

    up_te, up_le = angle(te - below), angle(le - below)
    down_le, down_te = angle(le - above), angle(te - above)
    pieces = [(te, te_mm, 0.0, up_te), (below, flank_mm, up_te, up_le),
              (le, le_mm, up_le, down_le), (above, flank_mm, down_le, down_te),
              (te, te_mm, down_te, 2 * np.pi)]
    step = np.radians(7.5)
    out = []
    for k, (centre, radius, a0, a1) in enumerate(pieces):
        if radius < flank_mm:  # a nose: every 7.5 deg from its phase
            phase = np.radians(start_deg) if k in (0, 4) else 0.3 * step
            angles = np.arange(a0 + np.mod(phase - a0, step), a1, step)
        else:  # a flank: 15 % longer steps from each end, at most 2.5 mm
            first = te_mm * step
            ends = np.cumsum(first * np.minimum(1.15 ** np.arange(1, 300), 2.5 / first))
            length = radius * (a1 - a0)
            ends = ends[ends < 0.5 * length]
            angles = a0 + np.concatenate((ends, [0.5 * length], length - ends[::-1])) / radius
        out.append(centre + radius * np.c_[np.cos(angles), np.sin(angles)])
    turn = np.radians(twist_deg)
    p = np.vstack(out) @ np.array([[np.cos(turn), np.sin(turn)], [-np.sin(turn), np.cos(turn)]])
    return np.c_[p, np.full(len(p), z_mm)]


@pytest.fixture(scope="module")
def nosed_blade():
    """Six such sections hub to tip, a 0.2 mm TE nose, the start point moving round it."""
    return [nosed_section(50.0 - 2 * j, 0.5, 0.2, 12.0 + 7 * j, 8.0 * j, 3.0 * j)
            for j in range(6)]


def test_entries_between_a_sections_points_do_not_ring_after_a_nose(nosed_blade):
    # the grid's entries at the other sections' columns turn the way the section does: no
    # concave turn after a nose (the C2 interpolating cubic turned 0.3-0.7 deg concave
    # there on the DCA rotor, and the fit on the grid followed it)
    grid = as_sections(nosed_blade, closed=True)
    assert not grid.mask.all()  # the sections do not correspond: entries interpolated
    for j in range(grid.n_sections):
        ring = grid.points[j][:-1, :2]
        ahead, behind = np.roll(ring, -1, axis=0) - ring, ring - np.roll(ring, 1, axis=0)
        cross = behind[:, 0] * ahead[:, 1] - behind[:, 1] * ahead[:, 0]
        turn = np.arctan2(cross, np.einsum("ij,ij->i", behind, ahead))
        assert turn.min() > -1e-4, f"section {j} turns {np.degrees(turn.min()):.3f} deg"


def test_a_ball_along_the_normal_round_small_noses_does_not_gouge_the_fit(nosed_blade):
    # a ball following a convex surface along its normal offset cannot cut into it: where
    # the fit rang after the TE nose (6 deg concave near the hub, a 6 mm ball cutting
    # 0.009 mm there) it could; at the default --gouge-tol 0.001 mm it must not
    from toolpath.planning.avoid import gouge_depth_mm
    from toolpath.planning.cutters import parse_cutter

    surface = fit_streamline_surface(nosed_blade, tol=TOL_MM, closed=True)
    ball = parse_cutter("ball:6")
    t = np.concatenate((np.linspace(-0.01, 0.01, 81) % 1.0, np.linspace(0.48, 0.52, 81)))
    for s in (0.0, 0.1, 0.5, 0.9, 1.0):
        frame = surface.frame(t, np.full_like(t, s))
        tips = ball.tips_from_contacts(frame.point, frame.normal, frame.normal)
        depth = gouge_depth_mm(surface, ball, t, np.full_like(t, s), tips, frame.normal,
                               speed_t=np.linalg.norm(frame.xt, axis=1),
                               speed_s=np.linalg.norm(frame.xs, axis=1)).depth_mm
        assert depth.max() <= 0.001, f"s={s}: {depth.max():.4f} mm at t={t[depth.argmax()]}"


def _interior_multiple_knots(surface):
    """Interior ``t``-knots of multiplicity DEGREE (corner knots), rounded."""
    values, counts = np.unique(np.round(np.asarray(surface.knots_t), 9), return_counts=True)
    return [float(v) for v, c in zip(values, counts, strict=True) if 0.0 < v < 1.0 and c >= 3]


def _kinked_section(n, z, kink_deg=30.0):
    """An open, gently bent line 50 mm long, then another turning ``kink_deg`` more: a corner."""
    x = np.linspace(0.0, 50.0, n // 2, endpoint=False)
    way = np.array([1.0, 0.2 + np.tan(np.radians(kink_deg))])
    tail = np.array([50.0, 5.0]) + np.linspace(0.0, 50.0, n - n // 2)[:, None] * way / np.hypot(
        *way)
    points = np.vstack([np.c_[x, 0.002 * x**2], tail])
    return np.c_[points, np.full(len(points), z)]


def test_a_union_grids_corners_are_voted_by_its_sections_own_points():
    # the union's columns bunch up where sections' stations fall close together (round the
    # seam): 2 um of scatter turned the DCA rotor's stacked columns there into an 11 deg
    # "corner", a C0 knot at t = 0.0028 turned the fit 8 deg concave within 2 um and a
    # 6 mm ball gouged; none of its 11 sections reads a corner on its own points
    rng = np.random.default_rng(1)
    scattered = as_sections([p + rng.normal(0.0, 0.002, p.shape) for p in
                             read_sections(bundled_data_path("dev_rotor_dca_11x181.csv"))])
    assert scattered.mask is not None
    assert _interior_multiple_knots(fit_bspline_surface(scattered, tol=0.01)) == []
    # a corner every section has stays one (the stacked columns, interleaving the
    # sections' stations, spread its turn and read none: the fit rounded it)
    kinked = as_sections([_kinked_section(60 + 3 * j, 10.0 * j) for j in range(6)])
    assert kinked.mask is not None
    corners = _interior_multiple_knots(fit_bspline_surface(kinked, tol=0.01))
    assert len(corners) == 1 and abs(corners[0] - 0.5) < 0.01
