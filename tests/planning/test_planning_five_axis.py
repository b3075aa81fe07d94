"""5-axis tool axes: lead/tilt geometry, smoothing and rate, the singular cone."""

import numpy as np
import pytest

from machines.errors import UnreachableOrientationError
from toolpath.path import MoveKind
from toolpath.planning import PlaneSurface, SpherePatch, plan_finishing
from toolpath.planning.tool_axis import angle_deg, keep_out_of_cone, lead_tilt_axes

PLANE = PlaneSurface(t_vector_mm=(20.0, 0.0, 0.0), s_vector_mm=(0.0, 6.0, 0.0))


@pytest.mark.parametrize("lead, tilt", [(10.0, 0.0), (0.0, 8.0), (15.0, -5.0)])
def test_lead_and_tilt_in_the_pass_frame(lead, tilt):
    path, _ = plan_finishing(PLANE, "ball:6", scallop_mm=0.02, chord_tol_mm=0.01,
                             axis_mode="lead-tilt", lead_deg=lead, tilt_deg=tilt,
                             measure=False)
    n = np.array([0.0, 0.0, 1.0])
    for p in range(path.n_passes):
        idx = np.flatnonzero(path.pass_index == p)
        feed = np.sign(path.positions_mm[idx[-1], 0] - path.positions_mm[idx[0], 0])
        f = np.array([feed, 0.0, 0.0])
        b = np.cross(n, f)
        axes = path.tool_axes[idx]
        np.testing.assert_allclose(axes @ f, np.sin(np.radians(lead)), atol=1e-9)
        np.testing.assert_allclose(axes @ b, np.cos(np.radians(lead))
                                   * np.sin(np.radians(tilt)), atol=1e-9)
        # the ball still touches at the contact: tip = P + R (n - a), P on the plane
        contact = path.positions_mm[idx] - 3.0 * (n - axes)
        np.testing.assert_allclose(contact[:, 2], 0.0, atol=1e-9)


def test_lead_tilt_formula():
    n = np.array([[0.0, 0.0, 1.0]])
    f = np.array([[1.0, 0.0, 0.0]])
    a = lead_tilt_axes(n, f, 30.0, 0.0)[0]
    np.testing.assert_allclose(a, [0.5, 0.0, np.sqrt(3) / 2], atol=1e-12)
    a = lead_tilt_axes(n, f, 0.0, 30.0)[0]
    np.testing.assert_allclose(a, [0.0, 0.5, np.sqrt(3) / 2], atol=1e-12)  # left of +x


def test_axis_turn_rate_is_limited_by_smoothing():
    sphere = SpherePatch(radius_mm=12.0, longitude_deg=(-60.0, 60.0),
                         colatitude_deg=(50.0, 60.0))
    kw = dict(scallop_mm=0.02, chord_tol_mm=0.01, axis_mode="lead-tilt", lead_deg=5.0,
              measure=False)
    _, free = plan_finishing(sphere, "ball:6", max_axis_rate_deg_per_mm=None,
                             axis_smoothing_mm=0.0, **kw)
    _, limited = plan_finishing(sphere, "ball:6", max_axis_rate_deg_per_mm=2.0, **kw)
    assert free.max_axis_rate_deg_per_mm > 3.0
    assert limited.max_axis_rate_deg_per_mm <= 2.0 + 1e-9


def test_singular_cone_is_kept_clear():
    axes = np.array([[0.0, 0.0, 1.0], [np.sin(0.01), 0.0, np.cos(0.01)], [0.6, 0.0, 0.8]])
    out, moved = keep_out_of_cone(axes, 5.0, np.array([[0.0, 1.0, 0.0]] * 3))
    assert moved == 2
    np.testing.assert_allclose(angle_deg(out[:2], [0, 0, 1]), 5.0)
    np.testing.assert_allclose(out[2], axes[2])
    np.testing.assert_allclose(out[1, 1], 0.0, atol=1e-12)  # same azimuth as before
    path, rep = plan_finishing(PLANE, "ball:6", scallop_mm=0.02, chord_tol_mm=0.01,
                               axis_mode="lead-tilt", min_cone_deg=3.0, measure=False)
    cut = path.kinds == MoveKind.CUT
    assert angle_deg(path.tool_axes[cut], [0, 0, 1]).min() >= 3.0 - 1e-9
    assert rep.cone_pushed > 0


def test_lead_tilt_on_a_three_axis_machine_is_refused():
    with pytest.raises(UnreachableOrientationError, match=r"--axis lead-tilt .* use --axis 3"):
        plan_finishing(PLANE, "ball:6", scallop_mm=0.02, chord_tol_mm=0.01,
                       axis_mode="lead-tilt", lead_deg=10, machine="grbl-router")
    with pytest.raises(UnreachableOrientationError,
                       match=r"--fixed-axis 0,0.707107,0.707107 is not \+Z"):
        plan_finishing(PLANE, "ball:6", scallop_mm=0.02, chord_tol_mm=0.01,
                       fixed_axis=(0.0, 1.0, 1.0), machine="grbl-router")


def test_traverses_go_over_an_open_part_not_under_it():
    # one-way passes across a convex 120 deg cylinder patch: each traverse runs from one
    # edge back to the other; the shorter great circle of the clearance sphere passes
    # under the patch, through the material inside the cylinder
    from toolpath.planning import CylinderPatch

    cylinder = CylinderPatch(radius_mm=40.0)
    path, _ = plan_finishing(cylinder, "ball:6", scallop_mm=0.05, chord_tol_mm=0.03,
                             axis_mode="lead-tilt", lead_deg=10.0, linking="oneway",
                             measure=False)
    rapid = path.kinds == MoveKind.RAPID
    off_axis = np.hypot(path.positions_mm[rapid, 1], path.positions_mm[rapid, 2])
    assert rapid.sum() > 10 and off_axis.min() > 40.0


def test_window_means_are_the_interpolated_integral_over_each_window():
    # the compiled moving average equals the mean from np.interp of the cumulative
    # trapezoid integral, windows of any width clipped to their pass (walked or searched)
    from toolpath.planning.tool_axis import box_window, window_average

    # (20,000 points: the blocks run one after another, passes across their edges)
    rng = np.random.default_rng(3)
    n, per_pass = 20_000, 2_500
    x = np.cumsum(rng.random(n) + 0.01)
    values = rng.normal(size=(n, 3))
    pid = np.repeat(np.arange(n // per_pass), per_pass)
    lo_x, hi_x = x[pid * per_pass], x[pid * per_pass + per_pass - 1]
    half = rng.random(n) * 40.0
    centred = rng.random(n) < 0.5
    got = window_average(values, x, box_window(x, lo_x, hi_x, half, centred))
    w = np.where(centred, np.minimum(half, np.minimum(x - lo_x, hi_x - x)), half)
    lo, hi = np.maximum(x - w, lo_x), np.minimum(x + w, hi_x)
    cum = np.r_[np.zeros((1, 3)), np.cumsum(0.5 * (values[1:] + values[:-1])
                                            * np.diff(x)[:, None], axis=0)]
    for k in range(3):
        mean = (np.interp(hi, x, cum[:, k]) - np.interp(lo, x, cum[:, k])) / np.maximum(
            hi - lo, 1e-300)
        expected = np.where(hi - lo > 1e-12, mean, values[:, k])
        np.testing.assert_allclose(got[:, k], expected, atol=1e-12)
    assert angle_deg(np.array([1.0, 0.0, 0.0]), np.array([0.0, 1.0, 0.0])) == \
        pytest.approx(90.0)


def _round_nose(radius_mm=2.0, flat_mm=20.0, step_mm=0.05):
    """A pass along a flat, round a half-circle nose and back along the other flat.

    In the x-z plane: normals +z, turning through +x to -z on the nose; feed along the
    path. Returns normals, feed directions and arc length.
    """
    flat = np.arange(0.0, flat_mm, step_mm)
    nose = np.arange(0.0, np.pi * radius_mm, step_mm) / radius_mm
    n = np.concatenate([np.tile([0.0, 0.0, 1.0], (flat.size, 1)),
                        np.stack([np.sin(nose), 0 * nose, np.cos(nose)], 1),
                        np.tile([0.0, 0.0, -1.0], (flat.size, 1))])
    f = np.concatenate([np.tile([1.0, 0.0, 0.0], (flat.size, 1)),
                        np.stack([np.cos(nose), 0 * nose, -np.sin(nose)], 1),
                        np.tile([-1.0, 0.0, 0.0], (flat.size, 1))])
    arclen = np.arange(len(n)) * step_mm
    return n, f, arclen


@pytest.mark.parametrize("limit_share", [1.5, 0.5])
def test_rate_limit_round_a_nose_leans_ahead_within_the_lean_limit(limit_share):
    # the normal turns 180 deg over the nose (pi * 2 mm); within a 60 deg lean the axis
    # must turn at least (180 - 2 * 60) / (2 pi) = 9.55 deg/mm. A limit above that is
    # kept, leaning ahead of the nose; one below it gives the smallest rate that fits
    from toolpath.planning.tool_axis import smooth_axes

    n, f, arclen = _round_nose()
    needed = 60.0 / (2.0 * np.pi)
    limit = limit_share * needed
    nominal = lead_tilt_axes(n, f, 0.0, 0.0)
    pid = np.zeros(len(n), dtype=np.int64)
    free = smooth_axes(nominal, n, f, arclen, pid, smoothing_mm=0.0,
                       max_rate_deg_per_mm=None, max_lean_deg=60.0)
    assert free.max_rate_deg_per_mm > 25.0  # the nominal axes follow the normal
    out = smooth_axes(nominal, n, f, arclen, pid, smoothing_mm=0.0,
                      max_rate_deg_per_mm=limit, max_lean_deg=60.0)
    assert out.rate_limited_passes == 1
    assert angle_deg(out.axes, n).max() <= 60.0 + 1e-6
    if limit_share > 1.0:
        assert out.max_rate_deg_per_mm <= limit + 1e-9
    else:
        assert out.max_rate_deg_per_mm == pytest.approx(needed, rel=0.01)
    # the axis leans ahead (towards the feed, where the normal will turn) before the nose
    # and still lags behind after it
    before, after = 399, len(n) - 400
    assert out.axes[before] @ f[before] > np.sin(np.radians(5.0))
    assert out.axes[after] @ f[after] < -np.sin(np.radians(5.0))
    # far from the nose and at the ends the axes are the nominal ones
    np.testing.assert_allclose(out.axes[[0, -1]], nominal[[0, -1]], atol=1e-9)
    assert angle_deg(out.axes[:100], nominal[:100]).max() < 1e-6


def test_rate_limit_keeps_the_lead_of_a_flat_or_bull_nose_face():
    # a face must not cross the normal: the axis leans ahead round the nose but never
    # less than the lead (it then turns faster than a ball's axis could)
    from toolpath.planning.tool_axis import smooth_axes

    n, f, arclen = _round_nose()
    nominal = lead_tilt_axes(n, f, 10.0, 0.0)
    pid = np.zeros(len(n), dtype=np.int64)
    kw = dict(smoothing_mm=0.0, max_rate_deg_per_mm=10.0, max_lean_deg=60.0)
    ball = smooth_axes(nominal, n, f, arclen, pid, **kw)
    face = smooth_axes(nominal, n, f, arclen, pid, keep_lead=True, **kw)
    lead_ball = np.degrees(np.arctan2(np.einsum("ij,ij->i", ball.axes, f),
                                      np.einsum("ij,ij->i", ball.axes, n)))
    lead_face = np.degrees(np.arctan2(np.einsum("ij,ij->i", face.axes, f),
                                      np.einsum("ij,ij->i", face.axes, n)))
    assert lead_ball.min() < 0.0 < 10.0 - 1e-6 <= lead_face.min()
    assert ball.max_rate_deg_per_mm <= 10.0 + 1e-9 < face.max_rate_deg_per_mm
    assert angle_deg(face.axes, n).max() <= 60.0 + 1e-6


def test_rate_limit_finds_the_bend_of_a_slightly_twisted_pass():
    # a 30 deg bend over 1 mm between long flats, the pass twisting 3 deg along its
    # length: the axis the normals turn about is the bend's (their turn vectors), not
    # the mean normal (the least spread of the normals themselves); and a segment of no
    # length where the axis must turn ends the search instead of looping
    from toolpath.planning.rate_limit import rate_limited_axes
    from toolpath.planning.tool_axis import smooth_axes

    m = 600
    x = np.linspace(0.0, 12.0, m)
    bend = np.clip((x - 5.5) / 1.0, 0.0, 1.0) * np.radians(30.0)
    twist = np.radians(3.0) * x / 12.0
    n = np.stack([np.sin(bend), np.sin(twist) * np.cos(bend),
                  np.cos(bend) * np.cos(twist)], 1)
    n /= np.linalg.norm(n, axis=1, keepdims=True)
    f = np.tile([1.0, 0.0, 0.0], (m, 1))
    f -= np.einsum("ij,ij->i", f, n)[:, None] * n
    f /= np.linalg.norm(f, axis=1, keepdims=True)
    nominal = lead_tilt_axes(n, f, 0.0, 0.0)
    out = smooth_axes(nominal, n, f, x, np.zeros(m, dtype=np.int64), smoothing_mm=0.0,
                      max_rate_deg_per_mm=10.0, max_lean_deg=60.0)
    assert out.max_rate_deg_per_mm <= 10.0 + 1e-9
    stuck = x.copy()
    stuck[301] = stuck[300]
    tilted = nominal.copy()
    tilted[301:] = lead_tilt_axes(n[301:], f[301:], 0.0, 20.0)
    axes = rate_limited_axes(tilted, n, f, stuck, np.array([0]), max_rate_deg_per_mm=10.0,
                             max_lean_deg=60.0)
    assert np.isfinite(axes).all()
    np.testing.assert_allclose(np.linalg.norm(axes, axis=1), 1.0)


def _round_edge(alpha_deg):
    """Contacts, normals and feeds over a 0.3 mm round edge along y (feed over its top)."""
    al = np.radians(np.atleast_1d(alpha_deg))
    n = np.stack([np.sin(al), np.zeros_like(al), np.cos(al)], axis=1)
    f = np.stack([np.cos(al), np.zeros_like(al), -np.sin(al)], axis=1)
    return 0.3 * n, n, f


def _leaning(n, f, lean_deg, direction_deg):
    """An axis leaning ``lean_deg`` from ``n``, towards ``direction_deg`` from ``f`` round it."""
    b = np.cross(n, f)
    th, ph = np.radians(lean_deg), np.radians(direction_deg)
    return np.cos(th) * n + np.sin(th) * (np.cos(ph) * f + np.sin(ph) * b)


def test_a_flat_face_goes_round_the_normal_keeping_its_lean():
    # round a leading edge the axes' lean may swing from ahead to behind and beside (the
    # normal turning faster than the axes may): in between the face keeps its lean and
    # its contact on the rim, so the tip moves smoothly round the contact; a slerp leans
    # less, down to none, and the tip jumps across the face (5 mm in one move cut a 5 mm
    # gouge into a propeller's edge)
    from toolpath.planning.cutters import parse_cutter
    from toolpath.planning.tool_axis import lean_interpolated, slerp

    cutter = parse_cutter("flat:6")
    _, (na,), (fa,) = _round_edge(-5.0)
    _, (nb,), (fb,) = _round_edge(5.0)
    a, b = _leaning(na, fa, 10.0, 0.0), _leaning(nb, fb, 10.0, 130.0)
    w = np.linspace(0.0, 1.0, 201)
    p, n, f = _round_edge(-5.0 + 10.0 * w)
    one = np.ones((w.size, 1))
    axes = lean_interpolated(a * one, na * one, fa * one, b * one, nb * one, fb * one, w, n, f)
    np.testing.assert_allclose(np.linalg.norm(axes, axis=1), 1.0)
    np.testing.assert_allclose(axes[[0, -1]], [a, b], atol=1e-12)
    np.testing.assert_allclose(angle_deg(axes, n), 10.0, atol=1e-9)
    tips = cutter.tips_from_contacts(p, n, axes)
    steps = np.linalg.norm(np.diff(tips, axis=0), axis=1)
    assert steps.max() < 0.05  # (3 mm round 130 degrees in 200 steps: 0.034 mm each)
    # every disc clear of the edge: its points no nearer the edge's axis than 0.3 mm
    rho, psi = np.meshgrid(np.linspace(0.0, 3.0, 13), np.radians(np.arange(0, 360, 5)))
    for tip, ax in zip(tips, axes, strict=True):
        u = np.cross(ax, [0.0, 1.0, 0.0])
        u /= np.linalg.norm(u)
        v = np.cross(ax, u)
        disc = tip + (rho * np.cos(psi))[..., None] * u + (rho * np.sin(psi))[..., None] * v
        assert np.hypot(disc[..., 0], disc[..., 2]).min() > 0.3 - 1e-9
    # the slerp between the same ends: the lean halves (4.2 degrees), and with the
    # lead kept the tip jumps by over 5 mm
    mid = slerp(a[None], b[None], np.array([0.5]))
    assert angle_deg(mid, n[100:101])[0] < 5.0
    lead = _leaning(n, f, 10.0, 0.0)
    jumps = cutter.tips_from_contacts(p, n, np.where((angle_deg(slerp(
        a * one, b * one, w), n) < 10.0 - 1e-9)[:, None], lead, slerp(a * one, b * one, w)))
    assert np.linalg.norm(np.diff(jumps, axis=0), axis=1).max() > 5.0


def test_leans_alike_interpolate_like_a_slerp_and_upright_ends_by_their_lean_vectors():
    from toolpath.planning.tool_axis import lean_interpolated, slerp

    _, n, f = _round_edge(np.linspace(-1.0, 1.0, 11))
    w = np.linspace(0.0, 1.0, 11)
    a, b = _leaning(n[0], f[0], 10.0, 3.0), _leaning(n[-1], f[-1], 10.5, -2.0)
    one = np.ones((11, 1))
    got = lean_interpolated(a * one, n[0] * one, f[0] * one, b * one, n[-1] * one, f[-1] * one,
                            w, n, f)
    np.testing.assert_allclose(angle_deg(got, slerp(a * one, b * one, w)), 0.0, atol=0.05)
    # an upright end (no lean, no direction): the lean vectors are interpolated
    up = n[0]
    got = lean_interpolated(up * one, n[0] * one, f[0] * one, b * one, n[-1] * one,
                            f[-1] * one, w, n, f)
    assert np.isfinite(got).all()
    np.testing.assert_allclose(angle_deg(got, n), 10.5 * w, atol=0.05)
    # ends leaning less than the lead (5 and 6 degrees, held back by a tilt limit): the new
    # axes lean between the two, not up to the lead (raised to 10 degrees a new point
    # stood 4 degrees off both ends, its tip 1.5 mm out of the move)
    a, b = _leaning(n[0], f[0], 5.0, -60.0), _leaning(n[-1], f[-1], 6.0, -44.0)
    got = lean_interpolated(a * one, n[0] * one, f[0] * one, b * one, n[-1] * one, f[-1] * one,
                            w, n, f)
    np.testing.assert_allclose(angle_deg(got, n), 5.0 + w, atol=1e-9)
    assert (angle_deg(got[1:], got[:-1]) < 0.5).all()


def test_axes_leaning_too_far_turn_back_onto_the_lean_cone_in_their_own_plane():
    # an axis leaning more than the limit turns towards the normal, in the plane of the
    # two, until it leans exactly the limit; one within the limit is left alone
    from toolpath.planning.tool_axis import limit_lean

    rng = np.random.default_rng(11)
    n = rng.normal(size=(200, 3))
    n /= np.linalg.norm(n, axis=1, keepdims=True)
    axes = rng.normal(size=(200, 3))
    axes /= np.linalg.norm(axes, axis=1, keepdims=True)
    # and some exactly on the cone or within round-off of it (decided by the angle)
    perp = axes[:30] - np.einsum("ij,ij->i", axes[:30], n[:30])[:, None] * n[:30]
    perp /= np.linalg.norm(perp, axis=1, keepdims=True)
    lean_rad = np.radians(30.0) + np.repeat([0.0, 1e-12, -1e-12], 10)
    axes[:30] = np.cos(lean_rad)[:, None] * n[:30] + np.sin(lean_rad)[:, None] * perp
    out, over = limit_lean(axes, n, 30.0)
    lean = angle_deg(axes, n)
    assert over.tolist() == (lean > 30.0).tolist() and 0 < over.sum() < 200
    np.testing.assert_allclose(angle_deg(out[over], n[over]), 30.0, atol=1e-9)
    np.testing.assert_allclose(angle_deg(out[over], axes[over]), lean[over] - 30.0, atol=1e-9)
    np.testing.assert_array_equal(out[~over], axes[~over])
    np.testing.assert_allclose(np.linalg.norm(out, axis=1), 1.0, atol=1e-12)
