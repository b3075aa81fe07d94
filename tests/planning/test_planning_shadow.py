"""Stepover of flat and bull-nose cutters from their true section across the pass."""

import numpy as np
import pytest

from toolpath.planning import plan_finishing
from toolpath.planning.analytic import CylinderPatch, PlaneSurface, SpherePatch
from toolpath.planning.cutter_kernel import shadow_point
from toolpath.planning.cutters import CutterShadow, disc_basis, parse_cutter
from toolpath.planning.scallop import shadow_stepover_mm, stepover_mm

E1, E2, UP = np.eye(3)[None, 0], np.eye(3)[None, 1], np.eye(3)[None, 2]


def _leaning(lead_deg):
    lead = np.radians(lead_deg)
    return np.array([[np.sin(lead), 0.0, np.cos(lead)]])


def _swept_cusp_mm(cutter, axis, w_mm):
    """Oracle: the cusp between two straight passes ``w`` apart on the plane z = 0, by
    bisection of the height at ``y = w / 2`` that some instance of the cutter (sliding
    along x at every 0.0025 mm, the contact on z = 0) reaches: independent of the shadow."""
    xs = np.linspace(-6.0, 6.0, 4801)
    tips = np.stack([xs, np.zeros_like(xs), np.zeros_like(xs)], axis=1)
    # the lowest point of the cutter: its core circle's point farthest down, less r
    a = axis[0]
    down = np.array([0.0, 0.0, -1.0])
    radial = down - (down @ a) * a
    lowest = (cutter.corner_radius_mm * a + (cutter.radius_mm - cutter.corner_radius_mm)
              * radial / np.linalg.norm(radial) + cutter.corner_radius_mm * down)
    tips[:, 2] -= lowest[2]
    lo, hi = 0.0, 1.0
    for _ in range(40):
        mid = 0.5 * (lo + hi)
        point = np.array([0.0, 0.5 * w_mm, mid])
        covered = (cutter.signed_distance(point, tips, axis) <= 0.0).any()
        lo, hi = (lo, mid) if covered else (mid, hi)
    return hi


def test_stadium_and_ball_sections_are_exact():
    # a bull-nose standing on a plane: the section is a stadium, w = 2 (R - r) + corners
    for h in (0.01, 0.1, 0.5):
        w = shadow_stepover_mm(h, 4.0, 1.0, UP, UP, E2, 0.0)
        assert w[0] == pytest.approx(6.0 + 2.0 * np.sqrt(h * (2.0 - h)), rel=1e-6)
    # r = R: a ball, whose section is its circle, on convex, flat and concave surfaces
    for k in (-0.05, 0.0, 0.05):
        w = shadow_stepover_mm(0.05, 3.0, 3.0, UP, UP, E2, k)
        assert w[0] == pytest.approx(float(stepover_mm(0.05, 3.0, k)), rel=1e-6)


def test_flat_face_on_a_slope_gets_its_staircase():
    slope = np.radians(30.0)
    normal = np.array([[0.0, -np.sin(slope), np.cos(slope)]])
    across = np.array([[0.0, np.cos(slope), np.sin(slope)]])
    for h in (0.005, 0.05):
        w = shadow_stepover_mm(h, 3.0, 0.0, normal, UP, across, 0.0)
        assert w[0] == pytest.approx(h / np.tan(slope), rel=1e-6)


@pytest.mark.parametrize("h", [0.06, 0.25])
def test_leaning_bull_nose_leaves_the_requested_cusp(h):
    cutter = parse_cutter("bull:8:1")
    axis = _leaning(10.0)
    w = shadow_stepover_mm(h, 4.0, 1.0, UP, axis, E2, 0.0)[0]
    assert _swept_cusp_mm(cutter, axis, w) == pytest.approx(h, rel=2e-3)
    # the osculating circle of the section, which the planner used alone before, gives a
    # wider stepover and a deeper cusp at these heights
    _, _, c22 = cutter.curvature_tensor(UP, axis, E1, E2)
    assert float(stepover_mm(h, 1.0 / c22[0], 0.0)) > 1.02 * w


def test_mirrored_neighbours_take_the_narrower_side():
    tilted = np.array([[0.0, np.sin(np.radians(15.0)), np.cos(np.radians(15.0))]])
    same = shadow_stepover_mm(0.05, 4.0, 1.0, UP, tilted, E2, 0.0)[0]
    mirrored = shadow_stepover_mm(0.05, 4.0, 1.0, UP, tilted, E2, 0.0, mirrored=True)[0]
    assert mirrored < same


def test_coarse_bull_nose_plan_stays_within_the_request():
    plane = PlaneSurface(t_vector_mm=(60.0, 0.0, 0.0), s_vector_mm=(0.0, 60.0, 0.0))
    _, report = plan_finishing(plane, "bull:8:1", scallop_mm=0.25, chord_tol_mm=0.03,
                               axis_mode="lead-tilt", lead_deg=10.0)
    assert report.max_scallop_mm <= 0.25


def test_flat_end_mill_on_slopes_is_advised_to_change_cutter():
    cap = SpherePatch(radius_mm=30.0, longitude_deg=(-20.0, 20.0), colatitude_deg=(20.0, 40.0))
    path, report = plan_finishing(cap, "flat:6", scallop_mm=0.02, chord_tol_mm=0.02,
                                  measure=False)
    assert len(report.advice) == 1 and "ball or bull-nose" in report.advice[0]
    assert any(line.startswith("advice") for line in report.lines())
    # the estimate in the advice is the pass count the plan has (within a few)
    estimated = int(report.advice[0].split("(")[1].split()[0])
    assert abs(estimated - path.n_passes) <= 0.05 * path.n_passes
    _, bull = plan_finishing(cap, "bull:6:1", scallop_mm=0.02, chord_tol_mm=0.02,
                             measure=False)
    _, flat_on_plane = plan_finishing(PlaneSurface(), "flat:6", scallop_mm=0.01,
                                      chord_tol_mm=0.01, measure=False)
    assert bull.advice == () and flat_on_plane.advice == ()


def _brute_height_mm(path, cutter, point, normal, lo=-0.05, hi=0.2):
    """Oracle: the lowest height along ``normal`` above ``point`` inside some instance of
    the cutter on a feed move (200 instances a move, bisection on the height)."""
    from toolpath.path import MoveKind

    feed = np.isin(path.kinds[1:], (MoveKind.CUT, MoveKind.LINK, MoveKind.LEAD_IN,
                                    MoveKind.LEAD_OUT))
    a = np.flatnonzero(feed)
    near = np.linalg.norm(path.positions_mm[a] - point, axis=1) < 3.0 * cutter.radius_mm + 8
    a = a[near]
    u = np.linspace(0.0, 1.0, 201)[None, :, None]
    tips = (path.positions_mm[a][:, None] * (1 - u) + path.positions_mm[a + 1][:, None] * u)
    axes = path.tool_axes[a][:, None] * (1 - u) + path.tool_axes[a + 1][:, None] * u
    tips, axes = tips.reshape(-1, 3), axes.reshape(-1, 3)
    axes /= np.linalg.norm(axes, axis=1, keepdims=True)
    for _ in range(40):
        mid = 0.5 * (lo + hi)
        inside = (cutter.signed_distance(point + mid * normal, tips, axes) <= 0.0).any()
        lo, hi = (lo, mid) if inside else (mid, hi)
    return hi


@pytest.mark.parametrize("lead", [0.0, 5.0])
def test_bull_nose_on_a_sphere_in_five_axis_keeps_the_request(lead):
    # passes along latitude circles near the pole: smoothing the axes along them leans
    # the face sideways (the contact jumps to its rim); measured 2.9x the request before
    # the stepover used the axes the cutter will have, and the measurement placed the
    # pieces by the normal alone
    from toolpath.planning.local import pass_frame

    cap = SpherePatch(radius_mm=60.0, longitude_deg=(-20.0, 20.0), colatitude_deg=(5.0, 25.0))
    cutter = parse_cutter("bull:8:1")
    path, report = plan_finishing(cap, cutter, scallop_mm=0.01, chord_tol_mm=0.02,
                                  axis_mode="lead-tilt", lead_deg=lead)
    assert report.max_scallop_mm <= 0.01
    t, s = report.scallop_at
    frame = pass_frame(cap, np.array([t]), np.array([s]))
    oracle = _brute_height_mm(path, cutter, frame.point[0], frame.normal[0])
    assert report.max_scallop_mm == pytest.approx(max(oracle, 0.0), abs=2e-4)


@pytest.mark.parametrize("spec", ["flat:6", "bull:8:1"])
def test_flat_faces_reach_open_edges_in_five_axis(spec):
    # with a lead, the side of the face that leaves the cusps trails the contact: passes
    # stopping at an open edge left 5-10 % more there, and direct zig-zag links skipped
    # the extension
    cylinder = CylinderPatch(radius_mm=40.0)
    _, report = plan_finishing(cylinder, spec, scallop_mm=0.05, chord_tol_mm=0.02,
                               axis_mode="lead-tilt", lead_deg=5.0)
    assert report.max_scallop_mm <= 0.05


def test_far_side_of_a_thin_part_is_measured_uncut_and_interior_is_along_the_surface():
    # a 4 mm thin elliptic section lying on the table, bull:8:1 from above: the cutter
    # sweeps pass within reach of the underside through the thickness. That side is not
    # cut (the section there lies behind its points, not over them): the uncut area is
    # the far half, and "away from uncut areas" is measured over the surface (round the
    # edges), not through the 4 mm, which left no cusp counted as interior
    from toolpath.planning import EllipticBladeSurface
    from toolpath.planning.setup import centred_on_table, rotation_from_spec

    thin = EllipticBladeSurface(semi_axes_hub_mm=(15.0, 2.0), semi_axes_tip_mm=(15.0, 2.0),
                                z_range_mm=(0.0, 20.0))
    lying = centred_on_table(thin, rotation_from_spec("x:90"), base_height_mm=0.0)
    _, report = plan_finishing(lying, "bull:8:1", scallop_mm=0.05, chord_tol_mm=0.02,
                               axis_mode="3")
    assert report.unreachable_fraction == pytest.approx(0.5, abs=0.01)
    assert report.uncut_fraction == pytest.approx(report.unreachable_fraction, abs=0.05)
    assert 0.0 < report.scallop_interior_mm <= report.max_scallop_mm <= 0.05


def test_compiled_cutter_distance_equals_the_numpy_solid():
    from toolpath.planning.cutter_kernel import cutter_distance

    rng = np.random.default_rng(5)
    for spec in ("bull:8:1", "flat:6", "ball:6"):
        cutter = parse_cutter(spec)
        axis = rng.normal(size=3)
        axis /= np.linalg.norm(axis)
        points = rng.normal(scale=5.0, size=(200, 3))
        expected = cutter.signed_distance(points, np.zeros(3), axis)
        got = [cutter_distance(*p, *axis, cutter.corner_radius_mm, cutter.radius_mm,
                               cutter.flute_length_mm) for p in points]
        np.testing.assert_allclose(got, expected, atol=1e-12)


def test_ray_entry_into_a_turning_cutter_equals_dense_poses():
    # a bull-nose rolling 40 deg round an edge in one piece: the entry of rays into the
    # removed material equals the first height at which some of 2001 poses (tip linear,
    # axis normalized-linear) holds the ray's point
    from toolpath.planning.sweep_kernel import nearest_entries

    cutter = parse_cutter("bull:8:1")
    turn = np.radians(40.0)
    a0 = np.array([0.0, 0.0, 1.0])
    a1 = np.array([np.sin(turn), 0.0, np.cos(turn)])
    p0 = np.array([-1.0, 0.0, 0.1])
    p1 = np.array([1.0, 0.0, 0.0]) + 0.1 * a1
    rng = np.random.default_rng(2)
    q = np.c_[rng.uniform(-2.0, 2.0, 40), rng.uniform(-4.0, 4.0, 40), np.full(40, -0.5)]
    n = np.tile([0.0, 0.0, 1.0], (40, 1))
    got = nearest_entries(q, n, np.arange(40), np.arange(1, 41), np.zeros(40, dtype=np.int64),
                          p0[None],
                          p1[None], a0[None], a1[None], corner_radius_mm=1.0, radius_mm=4.0,
                          flute_length_mm=cutter.flute_length_mm, horizon_mm=3.0)
    u = np.linspace(0.0, 1.0, 2001)[:, None]
    tips = p0 + u * (p1 - p0)
    axes = a0 + u * (a1 - a0)
    axes /= np.linalg.norm(axes, axis=1, keepdims=True)
    heights = np.linspace(0.0, 3.0, 3001)
    for k in range(40):

        def inside(lifts, k=k):
            # (signed_distance is exact, so it changes by no more than the point moves: a
            # block of heights whose middle stands farther than ``reach`` outside every
            # pose has no height inside one, and its 100 x 2001 distances are not needed)
            reach = 0.5 * (lifts[-1] - lifts[0])
            middle = q[k] + 0.5 * (lifts[0] + lifts[-1]) * n[k]
            if cutter.signed_distance(middle, tips, axes).min() > reach + 1e-9:
                return np.zeros(len(lifts), dtype=bool)
            return (cutter.signed_distance((q[k] + lifts[:, None] * n[k])[:, None], tips,
                                           axes) <= 0.0).any(axis=1)

        expected = _first_height_inside(heights, inside)
        assert got[k] == pytest.approx(expected, abs=2e-3) if np.isfinite(expected) \
            else got[k] == np.inf



@pytest.mark.parametrize("spec", ["bull:8:1", "flat:6"])
def test_a_ray_among_many_pieces_enters_where_dense_poses_of_all_of_them_say(spec):
    # a pass, its axes leaning to and fro, and one on the far side of a thin wall (axes
    # reversed: rays falling away from it), rays from beside them into the cutters' sides
    # and corners: the entry among all the pieces (tried nearest first, those that cannot
    # be entered before the best so far skipped) is the first height at which some of 51
    # poses of each piece holds the ray's point
    from toolpath.planning.sweep_kernel import nearest_entries

    cutter = parse_cutter(spec)
    rng = np.random.default_rng(5)
    u = np.linspace(-3.0, 3.0, 13)
    p0, p1, a0, a1 = [], [], [], []
    for side in (1.0, -1.0):
        lean = np.radians(5.0 * np.sin(u))
        axis = side * np.c_[np.sin(lean), np.zeros(u.size), np.cos(lean)]
        tip = np.c_[u, np.zeros(u.size), side * (0.5 + 0.03 * u ** 2)]
        p0 += [tip[:-1]]
        p1 += [tip[1:]]
        a0 += [axis[:-1]]
        a1 += [axis[1:]]
    p0, p1, a0, a1 = (np.concatenate(x) for x in (p0, p1, a0, a1))
    m, k = 40, len(p0)
    q = np.c_[rng.uniform(-2.0, 2.0, m), rng.uniform(-cutter.radius_mm - 0.3,
                                                      cutter.radius_mm + 0.3, m),
              rng.uniform(-0.1, 0.1, m)]
    n = rng.normal(size=(m, 3)) * [0.2, 0.2, 1.0] + [0.0, 0.0, 1.0]
    # and some beside the far pass, into its side, falling away from its spindle
    side = np.sign(q[:8, 1])
    q[:8, 1:] = np.c_[side * (cutter.radius_mm + 0.2), np.full(8, -0.8)]
    n[:8] = np.c_[np.zeros(8), -0.9 * side, np.full(8, 0.3)]
    n /= np.linalg.norm(n, axis=1, keepdims=True)
    got = nearest_entries(q, n, np.arange(m) * k, np.arange(1, m + 1) * k,
                          np.tile(np.arange(k), m), p0, p1, a0, a1,
                          corner_radius_mm=cutter.corner_radius_mm, radius_mm=cutter.radius_mm,
                          flute_length_mm=cutter.flute_length_mm, horizon_mm=0.6)
    w = np.linspace(0.0, 1.0, 51)[:, None, None]
    tips = (p0 + w * (p1 - p0)).reshape(-1, 3)
    axes = (a0 + w * (a1 - a0)).reshape(-1, 3)
    axes /= np.linalg.norm(axes, axis=1, keepdims=True)
    heights = np.linspace(0.0, 0.6, 601)
    for i in range(m):
        expected = _first_height_inside(heights, lambda lifts, i=i: (cutter.signed_distance(
            (q[i] + lifts[:, None] * n[i])[:, None], tips, axes) <= 0.0).any(axis=1), block=20)
        assert got[i] == pytest.approx(expected, abs=2e-3) if np.isfinite(expected) \
            else got[i] == np.inf
    assert 0.2 * m < np.isfinite(got).sum() < 0.9 * m


@pytest.mark.parametrize("scallop_mm", [0.1, 0.25])
def test_bull_nose_rolling_round_a_tight_edge_keeps_the_scallop(scallop_mm):
    # a thin elliptic section (0.27 mm radius at its ends) and a bull-nose 8 mm across in
    # 5-axis: round the ends the axis turns about a line under the contact, and the points
    # of the cutter beside the contact rise off the surface instead of sweeping straight
    # under it (a straight shadow left 1.1x and 1.6x the request here)
    from toolpath.planning import EllipticBladeSurface

    thin = EllipticBladeSurface(semi_axes_hub_mm=(15.0, 2.0), semi_axes_tip_mm=(15.0, 2.0),
                                z_range_mm=(0.0, 20.0))
    _, report = plan_finishing(thin, "bull:8:1", scallop_mm=scallop_mm, chord_tol_mm=0.03,
                               axis_mode="lead-tilt", lead_deg=10.0)
    assert 0.0 < report.max_scallop_mm <= scallop_mm


def _first_height_inside(heights, inside, block=100):
    """The first of the (ascending) ``heights`` where ``inside(heights[i:j])`` holds, or inf.

    The dense oracles' scan, a block of heights at a time, stopping at the first block
    that enters: the same height as testing all of them.
    """
    for start in range(0, len(heights), block):
        hit = inside(heights[start:start + block])
        if hit.any():
            return heights[start + int(np.argmax(hit))]
    return np.inf


def _segments_and_rays(rng, n_segments, n_rays):
    """Random segments ``a b`` and rays ``q + l n`` (unit ``n``) round the origin."""
    a, b = rng.normal(size=(n_segments, 3)), rng.normal(size=(n_segments, 3))
    q = rng.normal(scale=2.0, size=(n_rays, 3))
    n = rng.normal(size=(n_rays, 3))
    return a, b, q, n / np.linalg.norm(n, axis=1, keepdims=True)


def test_capsule_entries_and_segment_distances_equal_dense_samples():
    from toolpath.planning.sweep_kernel import capsule_entries, segment_distances

    rng = np.random.default_rng(8)
    a, b, q, n = _segments_and_rays(rng, 30, 30)
    pairs = np.arange(30)
    got = capsule_entries(q, n, pairs, pairs + 1, pairs, a, b, 0.7)
    u = np.linspace(0.0, 1.0, 2001)
    heights = np.linspace(0.0, 6.0, 6001)
    for k in range(30):
        axis = a[k] + u[:, None] * (b[k] - a[k])

        def inside(lifts, k=k, axis=axis):
            # a block of heights spans a stretch of the ray (n is a unit vector) within
            # ``reach`` of its middle: when no sample stands within 0.7 + reach of the
            # middle, none stands within 0.7 of any of its heights (triangle inequality),
            # and the block's 100 x 2001 distances are not needed to say so
            reach = 0.5 * (lifts[-1] - lifts[0])
            middle = q[k] + 0.5 * (lifts[0] + lifts[-1]) * n[k]
            if np.linalg.norm(axis - middle, axis=1).min() > 0.7 + reach + 1e-9:
                return np.zeros(len(lifts), dtype=bool)
            return (np.linalg.norm((q[k] + lifts[:, None] * n[k])[:, None] - axis[None],
                                   axis=2) <= 0.7).any(axis=1)

        expected = _first_height_inside(heights, inside)
        if np.isfinite(expected):
            assert got[k] == pytest.approx(expected, abs=2e-3)
        else:
            assert got[k] > 5.99
    c, d = rng.normal(size=(30, 3)), rng.normal(size=(30, 3))
    dist = segment_distances(a, b, pairs, c, d, pairs)
    for k in range(30):
        on_first = a[k] + u[::4, None] * (b[k] - a[k])
        on_second = c[k] + u[::4, None] * (d[k] - c[k])
        sampled = np.linalg.norm(on_first[:, None] - on_second[None], axis=2).min()
        assert dist[k] == pytest.approx(sampled, abs=1e-3)
        assert dist[k] <= sampled + 1e-12


def test_segment_distances_to_a_point_take_its_foot_on_the_other_segment():
    # a segment of zero length (a repeated tip, an axis turning in place) is a point: the
    # distance is to its foot on the other segment, whichever side it is given on
    from toolpath.planning.sweep_kernel import segment_distances

    one = np.array([0])
    point = np.array([[1.0, 1.0, 0.0]])
    start, end = np.array([[-3.0, 0.0, 0.0]]), np.array([[3.0, 0.0, 0.0]])
    assert segment_distances(start, end, one, point, point, one)[0] == pytest.approx(1.0)
    assert segment_distances(point, point, one, start, end, one)[0] == pytest.approx(1.0)
    assert segment_distances(point, point, one, 2 * point, 2 * point, one)[0] == (
        pytest.approx(np.sqrt(2.0)))


def test_ray_entry_into_a_piece_of_zero_length_or_a_long_turning_one():
    # no piece is skipped on a bound that does not hold: a flat end mill standing still
    # (its tip segment a point), and a long piece whose axis turns 10 deg, the ray
    # starting just above the middle pose's tip plane
    from toolpath.planning.sweep_kernel import nearest_entries

    one = np.array([0])
    tip, up = np.array([[0.0, 0.0, 0.0]]), np.array([[0.0, 0.0, 1.0]])
    q, n = np.array([[-4.0, 0.5, -5.0]]), np.array([[0.6, 0.0, 0.8]])
    got = nearest_entries(q, n, one, one + 1, one, tip, tip.copy(), up, up.copy(),
                          corner_radius_mm=0.0, radius_mm=2.0, flute_length_mm=10.0,
                          horizon_mm=8.0)
    assert got[0] == pytest.approx(5.0 / 0.8)  # through the tip plane, 0.56 mm off axis
    turn = np.radians(10.0)
    end_tip, end_axis = np.array([[20.0, 0.0, -2.0]]), np.array([[np.sin(turn), 0, np.cos(turn)]])
    middle_axis = (up + end_axis)[0] / np.linalg.norm(up + end_axis)
    inside = 0.5 * (tip + end_tip)[0] + 0.01 * middle_axis
    for climb in (1.0, -1.0):
        n = np.array([[0.0, 0.0, climb]])
        got = nearest_entries(inside[None] - 0.05 * n, n, one, one + 1, one, tip, end_tip,
                              up, end_axis, corner_radius_mm=0.0, radius_mm=0.1,
                              flute_length_mm=1.0, horizon_mm=1.0)
        assert got[0] < 0.05  # the middle pose holds the ray's point 0.05 mm along it


def test_each_ray_takes_the_nearest_of_its_own_pieces():
    # pairs listed in any order, rays with no piece, one, or several: ray_ranges groups
    # them, and a ray's entry is the smallest over its own pieces (inf with none)
    from toolpath.planning.sweep_kernel import capsule_entries, ray_ranges

    rng = np.random.default_rng(9)
    a, b, q, n = _segments_and_rays(rng, 40, 12)
    owner = rng.integers(0, 10, 60)  # rays 10 and 11 get no piece
    item = rng.integers(0, 40, 60)
    shuffle = rng.permutation(60)
    lo, hi, grouped = ray_ranges(owner[shuffle], item[shuffle], len(q))
    got = capsule_entries(q, n, lo, hi, grouped, a, b, 0.7)
    one = np.arange(60)
    single = capsule_entries(q[owner], n[owner], one, one + 1, item, a, b, 0.7)
    for ray in range(len(q)):
        mine = single[owner == ray]
        assert got[ray] == (mine.min() if mine.size else np.inf)
    assert np.isinf(got[10:]).all() and (hi - lo)[:10].sum() == 60


def test_shadow_boundary_point_is_the_torus_support_point_and_its_depth():
    # the compiled boundary point with outward normal nu = (sin th, -cos th) of the cutting
    # end seen along d = ex x ez is the point of the projected torus farthest along nu;
    # its depth is where along d the torus point casting it lies (dense torus samples)
    rng = np.random.default_rng(3)
    big, r = 4.0, 1.0
    around = np.linspace(0.0, 2 * np.pi, 721)
    u, v = np.meshgrid(np.linspace(0.0, 2 * np.pi, 121), np.linspace(-np.pi / 2, np.pi / 2, 61))
    ball = r * np.stack([np.cos(v) * np.cos(u), np.cos(v) * np.sin(u), np.sin(v)], -1)
    for _ in range(5):
        axis = rng.normal(size=3)
        axis /= np.linalg.norm(axis)
        ez = rng.normal(size=3)
        ez /= np.linalg.norm(ez)
        ex = np.cross(ez, rng.normal(size=3))
        ex /= np.linalg.norm(ex)
        d = np.cross(ex, ez)
        shadow = CutterShadow.seen_along(big - r, r, np.zeros((1, 3)), axis[None], ex[None],
                                         ez[None])
        b1, b2 = disc_basis(axis[None])
        rim = (big - r) * (np.cos(around)[:, None] * b1 + np.sin(around)[:, None] * b2)
        # the torus samples are every rim sample plus every ball sample: the one farthest
        # along nu is the farthest rim sample plus the farthest ball sample (without the
        # 721 x 7381 sums)
        ball_samples = ball.reshape(-1, 3)
        for theta in np.linspace(-np.pi, np.pi, 9):
            x, z, depth = shadow_point(*(c[0] for c in shadow.matrix),
                                       *(c[0] for c in shadow.depth_matrix), r, theta)
            nu = np.sin(theta) * ex - np.cos(theta) * ez
            far = rim[np.argmax(rim @ nu)] + ball_samples[np.argmax(ball_samples @ nu)]
            assert np.sin(theta) * x - np.cos(theta) * z == pytest.approx(far @ nu, abs=1e-3)
            assert x == pytest.approx(far @ ex, abs=0.05)
            assert z == pytest.approx(far @ ez, abs=0.05)
            assert depth == pytest.approx(far @ d, abs=0.05)


def _turning_pieces(rng):
    """Pieces of a flat or bull-nose cutter's moves: tips and unit axes at their ends.

    A pass leaning to and fro; long pieces turning 10 to 30 deg; pieces of zero length
    turning on the spot (the tip fixed) or standing still; a pass with its axes reversed
    (rays climbing towards it fall away from its spindle).
    """
    u = np.linspace(-3.0, 3.0, 25)
    lean = np.radians(8.0 * np.sin(2.0 * u))
    axis = np.c_[np.sin(lean), np.zeros(u.size), np.cos(lean)]
    tip = np.c_[u, np.zeros(u.size), 0.5 + 0.03 * u ** 2]
    p0, p1, a0, a1 = [tip[:-1]], [tip[1:]], [axis[:-1]], [axis[1:]]
    p0 += [tip[:-1] * [1.0, 1.0, -1.0] + [0.0, 2.0, 0.0]]
    p1 += [tip[1:] * [1.0, 1.0, -1.0] + [0.0, 2.0, 0.0]]
    a0 += [-axis[:-1]]
    a1 += [-axis[1:]]
    for place, turn in enumerate(np.radians([10.0, 20.0, 30.0])):
        start = np.array([0.0, 20.0 * (place + 1), 0.0])  # apart from the rest
        first = rng.normal(size=3)
        first /= np.linalg.norm(first)
        side = np.cross(first, rng.normal(size=3))
        side /= np.linalg.norm(side)
        last = np.cos(turn) * first + np.sin(turn) * side
        for travel in (6.0, 0.0):  # a long turning piece, and one turning on the spot
            p0 += [(start + 10.0 * (travel == 0.0))[None]]
            p1 += [(start + 10.0 * (travel == 0.0) + travel * rng.normal(size=3) / 1.7)[None]]
            a0 += [first[None]]
            a1 += [last[None]]
    p0 += [np.array([[0.0, -20.0, 0.0]])]  # standing still
    p1 += [np.array([[0.0, -20.0, 0.0]])]
    a0 += [np.array([[0.0, 0.0, 1.0]])]
    a1 += [np.array([[0.0, 0.0, 1.0]])]
    return [np.concatenate(x) for x in (p0, p1, a0, a1)]


@pytest.mark.parametrize("spec", ["bull:8:1", "flat:6"])
def test_a_ray_beside_a_long_or_turning_piece_enters_where_dense_poses_say(spec):
    # rays from beside a piece's middle poses, into its cutters: where the piece is long
    # or turns, its end poses stand far off the ray while a middle one holds it near its
    # origin (the pieces skipped on their end poses' distance, the searches skipped on
    # the best sample's, must not be these); the entry is the first height at which some
    # of 801 poses (101 a piece of the pass) holds the ray's point, rays alone or with the
    # others of their pass
    from toolpath.planning.sweep_kernel import nearest_entries

    cutter = parse_cutter(spec)
    rng = np.random.default_rng(11)
    p0, p1, a0, a1 = _turning_pieces(rng)
    m, k = 120, len(p0)
    home = np.r_[rng.integers(0, k, m - 60), rng.integers(k - 8, k, 60)]
    w = rng.uniform(0.2, 0.8, (m, 1))
    axis = a0[home] + w * (a1[home] - a0[home])
    axis /= np.linalg.norm(axis, axis=1, keepdims=True)
    # across the axis and the way (where the piece moves), or any way across the axis
    side = np.cross(axis, p1[home] - p0[home] + rng.normal(scale=1e-3, size=(m, 3)))
    side /= np.linalg.norm(side, axis=1, keepdims=True)
    q = (p0[home] + w * (p1[home] - p0[home])
         + (cutter.radius_mm + rng.uniform(0.0, 0.3, (m, 1))) * side
         + rng.uniform(-0.3, 1.0, (m, 1)) * axis)
    n = -side + rng.normal(scale=0.3, size=(m, 3)) + rng.uniform(-0.5, 0.5, (m, 1)) * axis
    # and every other ray from over the flutes' top (the end poses of a turning piece
    # swing it farthest off)
    top = np.arange(m) % 2 == 1
    q[top] = (p0[home] + w * (p1[home] - p0[home]) + rng.uniform(-3.0, 3.0, (m, 1)) * side
              + (cutter.flute_length_mm + rng.uniform(0.0, 0.3, (m, 1))) * axis)[top]
    n[top] = (-axis + rng.normal(scale=0.3, size=(m, 3)))[top]
    n /= np.linalg.norm(n, axis=1, keepdims=True)
    kw = dict(corner_radius_mm=cutter.corner_radius_mm, radius_mm=cutter.radius_mm,
              flute_length_mm=cutter.flute_length_mm, horizon_mm=0.6)
    one = np.arange(m)
    alone = nearest_entries(q, n, one, one + 1, home, p0, p1, a0, a1, **kw)
    # the pass's 24 pieces for rays beside it (the others lie apart from each other)
    passes = home < 24
    lo = np.where(passes, 0, home)
    hi = np.where(passes, 24, home + 1)
    among = nearest_entries(q, n, one * k + lo, one * k + hi, np.tile(np.arange(k), m),
                            p0, p1, a0, a1, **kw)
    heights = np.linspace(0.0, 0.6, 601)
    for i in range(m):
        u = np.linspace(0.0, 1.0, 101 if passes[i] else 801)[:, None, None]
        tips = (p0[lo[i]:hi[i]] + u * (p1[lo[i]:hi[i]] - p0[lo[i]:hi[i]])).reshape(-1, 3)
        axes = (a0[lo[i]:hi[i]] + u * (a1[lo[i]:hi[i]] - a0[lo[i]:hi[i]])).reshape(-1, 3)
        axes /= np.linalg.norm(axes, axis=1, keepdims=True)
        expected = _first_height_inside(heights, lambda lifts, i=i, tips=tips, axes=axes: (
            cutter.signed_distance((q[i] + lifts[:, None] * n[i])[:, None], tips, axes)
            <= 0.0).any(axis=1),
            block=10)
        got = among[i] if passes[i] else alone[i]
        assert got == pytest.approx(expected, abs=2e-3) if np.isfinite(expected) \
            else got == np.inf
    entered = (among > 0.0) & np.isfinite(among)
    assert entered.sum() > 0.3 * m and np.isinf(among).sum() > 0.02 * m


def test_a_search_between_samples_beats_an_earlier_tried_pieces_entry():
    # a bull-nose moving 6 mm in one piece, a ray rising under its corner between the
    # piece's first two sampled poses (both enter it 0.035 up), and a still cutter tried
    # first (nearest) that it enters 0.033 up: the search between the samples still runs
    # and finds the pose right over the ray, 3.2 mm off its axis, 0.0302 up
    from toolpath.planning.sweep_kernel import nearest_entries

    cutter = parse_cutter("bull:8:1")
    x_ray = -3.0 + 0.375
    tips0 = np.array([[-3.0, 0.0, 0.0], [x_ray, 3.2, 0.023]])
    tips1 = np.array([[3.0, 0.0, 0.0], [x_ray, 3.2, 0.023]])
    axes = np.tile([0.0, 0.0, 1.0], (2, 1))
    q, n = np.array([[x_ray, 3.2, -0.01]]), np.array([[0.0, 0.0, 1.0]])
    got = nearest_entries(q, n, np.array([0]), np.array([2]), np.array([0, 1]), tips0, tips1,
                          axes, axes.copy(), corner_radius_mm=1.0, radius_mm=4.0,
                          flute_length_mm=cutter.flute_length_mm, horizon_mm=0.3)
    assert got[0] == pytest.approx(0.01 + 1.0 - np.sqrt(1.0 - 0.2 ** 2), abs=1e-6)
