"""Gouge checks on a surface with a concave pocket smaller than the cutter."""

import numpy as np
import pytest

from toolpath.planning import (
    GougeError,
    PlaneSurface,
    PocketSurface,
    SpherePatch,
    parse_cutter,
    plan_finishing,
)
from toolpath.planning.gouge import (
    CLEARANCE_HORIZON_MM,
    global_clearance,
    local_margin,
    query_capsule,
    sample_surface,
)
from toolpath.planning.local import pass_frame

POCKET = PocketSurface(size_mm=(16.0, 16.0), centre_mm=(8.0, 8.0), depth_mm=1.5, width_mm=2.0)


def test_local_margin_is_one_over_r_minus_the_concave_curvature():
    frame = pass_frame(POCKET, np.array([0.5]), np.array([0.5]))
    cutter = parse_cutter("ball:6")
    margin = local_margin(frame, cutter, np.array([[0.0, 0.0, 1.0]]))
    assert margin[0] == pytest.approx(1.0 / 3.0 - 1.5 / 4.0, rel=1e-9)
    assert 1.0 / frame.max_concave_curvature[0] == pytest.approx(POCKET.min_concave_radius_mm)


def test_cutter_larger_than_the_pocket_radius_is_refused_naming_the_place():
    with pytest.raises(GougeError) as err:
        plan_finishing(POCKET, "ball:6", scallop_mm=0.02, chord_tol_mm=0.01)
    text = str(err.value)
    # the smallest concave radius where it gouges (the bottom), the largest cutter that fits
    assert "ball:6" in text and "2.6667 mm at t=0.50000, s=0.50000" in text
    assert "radius < 2.667" in text and "--on-gouge lift" in text and "--gouge-tol" in text
    # the depth reported is the deepest measured, where it is: a dense sample of the
    # pocket round that contact finds the same
    err_t, err_s = err.value.t, err.value.s
    assert f"would cut {err.value.depth_mm:.4f} mm" in text
    assert f"t={err_t:.5f}, s={err_s:.5f}" in text
    cutter = parse_cutter("ball:6")
    contact, normal = POCKET(err_t, err_s), POCKET.normal(err_t, err_s)
    up = np.array([0.0, 0.0, 1.0])
    tip = cutter.tips_from_contacts(contact[None], normal[None], up[None])
    g = np.linspace(0.0, 1.0, 801)
    dense = POCKET(g, g, grid=True).reshape(-1, 3)
    brute = -cutter.signed_distance(dense, tip, up[None]).min()
    assert err.value.depth_mm == pytest.approx(brute, rel=0.02)
    assert err.value.depth_mm > 0.005
    # a cutter that fits plans without complaint
    _, rep = plan_finishing(POCKET, "ball:5", scallop_mm=0.02, chord_tol_mm=0.01,
                            measure=False)
    # sampled at the cutter locations and on the probe grid: within 0.2 %
    assert rep.min_concave_radius_mm == pytest.approx(2.6667, rel=2e-3)
    assert rep.cutter_radius_there_mm == pytest.approx(2.5)


@pytest.mark.parametrize("spec", ["flat:2", "bull:2:0.5"])
def test_a_flat_end_over_a_concave_pocket_is_told_to_take_a_ball(spec):
    # a flat end spans a concave surface whatever its radius: the pocket's concave
    # radius (2.667 mm) is larger than the cutter's (1 mm), and a smaller cutter of the
    # same kind would still cut in; the advice is a ball that fits
    with pytest.raises(GougeError) as err:
        plan_finishing(POCKET, spec, scallop_mm=0.02, chord_tol_mm=0.01)
    text = str(err.value)
    assert f"use a ball cutter of radius < 2.667 mm ({spec}'s flat end" in text
    assert "use a cutter of radius" not in text
    assert "--on-gouge lift" in text and "--gouge-tol" in text


def test_global_check_sees_the_cutter_inside_the_surface():
    samples = sample_surface(POCKET, 0.25)
    cutter = parse_cutter("ball:6")
    bottom = POCKET(0.5, 0.5)
    axis = np.array([[0.0, 0.0, 1.0]])
    tips = cutter.tips_from_contacts(bottom[None], axis, axis)
    clear = global_clearance(cutter, tips, axis, samples, contacts_mm=bottom[None])
    assert clear.near_mm[0] < -0.005  # the walls of the pocket are inside the ball
    # a cutter raised 1 mm is clear (beyond the horizon: inf)
    clear = global_clearance(cutter, tips + np.array([0.0, 0.0, 1.0]), axis, samples)
    assert np.isinf(clear.min_mm[0])
    # flat plane: the contact touches, nothing is inside
    plane = PlaneSurface()
    samples = sample_surface(plane, 0.5)
    p = plane(0.3, 0.4)
    tip = cutter.tips_from_contacts(p[None], axis, axis)
    clear = global_clearance(cutter, tip, axis, samples, contacts_mm=p[None])
    assert -1e-12 < clear.near_mm[0] < 0.05 and np.isinf(clear.far_mm[0])


def test_lift_leaves_no_gouge_and_reports_what_it_lifted():
    path, rep = plan_finishing(POCKET, "ball:6", scallop_mm=0.02, chord_tol_mm=0.01,
                               on_gouge="lift", measure=False)
    assert rep.n_lifted > 0 and rep.max_lift_mm > 0.01
    samples = sample_surface(POCKET, 0.1)
    clear = global_clearance(parse_cutter("ball:6"), path.positions_mm, path.tool_axes,
                             samples)
    assert clear.min_mm.min() >= -1e-4
    # the material left in the pocket shows as a scallop beyond the request there
    _, measured = plan_finishing(POCKET, "ball:6", scallop_mm=0.02, chord_tol_mm=0.01,
                                 on_gouge="lift")
    assert not measured.within_request or measured.max_scallop_mm > 0.02


def test_retilt_cannot_save_a_ball_in_a_small_hollow():
    with pytest.raises(GougeError, match="a ball cannot re-tilt"):
        plan_finishing(POCKET, "ball:6", scallop_mm=0.02, chord_tol_mm=0.01,
                       axis_mode="lead-tilt", lead_deg=10, on_gouge="retilt", measure=False)


def test_projection_keeps_going_until_the_foot_point_is_found():
    # one Newton step asked for, from a start far along the pass: the search goes on for
    # the points not yet converged (a half-found foot gives a meaningless signed distance);
    # the Newton search itself (project_to_surface takes a sphere's feet in closed form)
    from toolpath.planning import SpherePatch
    from toolpath.planning.local import _newton_search

    sphere = SpherePatch(radius_mm=50.0, longitude_deg=(-40.0, 40.0),
                         colatitude_deg=(15.0, 60.0))
    target_t, target_s = np.array([0.8, 0.3]), np.array([0.5, 0.6])
    foot = sphere(target_t, target_s)
    points = foot + 3.0 * sphere.normal(target_t, target_s)
    t, s, x = _newton_search(sphere, points, np.array([0.2, 0.35]), np.array([0.5, 0.55]),
                             iterations=1)
    dist = np.linalg.norm(x - points, axis=1)
    assert t == pytest.approx(target_t, abs=1e-7) and s == pytest.approx(target_s, abs=1e-7)
    assert dist == pytest.approx([3.0, 3.0], abs=1e-9)


def _capsule_distance(points, tips, axes, low, high):
    """Distance of each of ``points`` to the segment ``low .. high`` up the axis."""
    e = points - tips
    z = np.clip(e @ axes, low, high)
    return np.linalg.norm(e - z[:, None] * axes, axis=1)


@pytest.mark.parametrize("flutes", [True, False])
@pytest.mark.parametrize("spec", ["ball:6", "bull:8:1:flute=20", "flat:4:flute=12"])
def test_global_clearance_equals_brute_force_over_every_sample(spec, flutes):
    # the binned search must find every sample inside the query capsule: compare with
    # the signed distance to all samples, masked by the same capsule
    surface = SpherePatch(radius_mm=30.0, longitude_deg=(-40.0, 40.0),
                          colatitude_deg=(20.0, 70.0))
    samples = sample_surface(surface, 0.4)
    cutter = parse_cutter(spec)
    rng = np.random.default_rng(7)
    n = 300
    t, s = rng.random(n), rng.random(n)
    contacts = surface(t, s)
    axes = surface.normal(t, s) + rng.normal(scale=0.4, size=(n, 3))
    axes[:20] = rng.normal(size=(20, 3))  # lying, pointing any way
    axes[20:25] = [[0.0, 0.0, 1.0], [0.0, 1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, -1.0],
                   [0.0, -1.0, 0.0]]  # along the grid's cells
    axes /= np.linalg.norm(axes, axis=1, keepdims=True)
    tips = contacts + rng.normal(scale=1.5, size=(n, 3))  # some inside, some clear
    got = global_clearance(cutter, tips, axes, samples, contacts_mm=contacts, flutes=flutes)
    low, high, reach = query_capsule(cutter, CLEARANCE_HORIZON_MM, flutes)
    assert reach == cutter.radius_mm + CLEARANCE_HORIZON_MM
    assert (low, high) == ((cutter.corner_radius_mm, cutter.flute_length_mm
                            - cutter.corner_radius_mm) if flutes else (low, low))
    pts = samples.points
    found = 0
    for i in range(n):
        inside = _capsule_distance(pts, tips[i], axes[i], low, high) <= reach
        dist = cutter.signed_distance(pts, tips[i], axes[i])
        if flutes:  # the capsule holds every point within the horizon of the cutter
            assert (inside | (dist > CLEARANCE_HORIZON_MM)).all(), i
        near = np.linalg.norm(pts - contacts[i], axis=1) <= 2.0 * cutter.radius_mm
        for mask, value in ((inside & near, got.near_mm[i]), (inside & ~near, got.far_mm[i])):
            want = dist[mask].min() if mask.any() else np.inf
            want = np.inf if want > CLEARANCE_HORIZON_MM else want
            assert value == pytest.approx(want, abs=1e-12), (i, spec)
            found += np.isfinite(want)
    assert found > 50  # (the test sees clearances, not only misses)


@pytest.mark.parametrize("radius_mm", [0.3, 2.5])
def test_pairs_within_equal_brute_force(radius_mm):
    # binned in cells of 1 mm, queried with radii below and above the cell
    from toolpath.planning.clearance_kernel import bin_samples, pairs_within

    rng = np.random.default_rng(4)
    points = rng.uniform(-5.0, 5.0, size=(3000, 3))
    queries = rng.uniform(-6.0, 6.0, size=(200, 3))
    owner, item = pairs_within(bin_samples(points, 1.0), queries, radius_mm)
    assert (np.diff(owner) >= 0).all()
    close = np.linalg.norm(queries[:, None] - points[None], axis=2) <= radius_mm
    expected = set(zip(*np.nonzero(close), strict=True))
    assert set(zip(owner.tolist(), item.tolist(), strict=True)) == expected
    assert len(owner) == len(expected)


def test_pass_frame_on_a_sphere():
    # every normal curvature -1/R (convex), none twisted; a latitude circle's geodesic
    # curvature cot(colatitude) / R; the frame orthonormal, the normal outward
    from toolpath.planning import SpherePatch

    sphere = SpherePatch(radius_mm=20.0, longitude_deg=(-40.0, 40.0),
                         colatitude_deg=(5.0, 60.0))
    rng = np.random.default_rng(2)
    frame = pass_frame(sphere, rng.random(500), rng.random(500))
    np.testing.assert_allclose(frame.s11, -0.05, atol=1e-12)
    np.testing.assert_allclose(frame.s22, -0.05, atol=1e-12)
    np.testing.assert_allclose(frame.s12, 0.0, atol=1e-12)
    colatitude = np.arccos(frame.point[:, 2] / 20.0)
    np.testing.assert_allclose(frame.kg, 1.0 / np.tan(colatitude) / 20.0, rtol=1e-9)
    basis = np.stack([frame.e1, frame.e2, frame.normal], axis=1)
    np.testing.assert_allclose(basis @ basis.transpose(0, 2, 1), np.broadcast_to(
        np.eye(3), basis.shape), atol=1e-12)
    np.testing.assert_allclose(frame.normal, frame.point / 20.0, atol=1e-12)


def test_lift_until_clear_lifts_by_the_depth_found_and_puts_back_what_it_cannot_clear():
    # the floor z = 0: a pose 1 mm under it clears in one round, lifted 1 mm plus the
    # tolerance; a pose whose axis runs along the floor never clears and is put back
    from toolpath.planning.avoid import LIFT_ROUNDS, lift_until_clear

    tips = np.array([[0.0, 0.0, -1.0], [5.0, 0.0, -0.5], [9.0, 0.0, 2.0]])
    axes = np.array([[0.0, 0.0, 1.0], [1.0, 0.0, 0.0], [0.0, 0.0, 1.0]])
    calls = []

    def depth_at(rows, tips_mm):
        calls.append(rows.tolist())
        return -tips_mm[:, 2]

    lifted = lift_until_clear(tips, axes, np.array([0, 1]), np.array([1.0, 0.5]), 0.01,
                              depth_at)
    assert lifted.tips[0, 2] == pytest.approx(0.01)
    assert lifted.lift_mm.tolist() == pytest.approx([1.01, 0.0, 0.0])
    assert lifted.stuck.tolist() == [1]
    np.testing.assert_allclose(lifted.tips[1:], tips[1:], atol=1e-12)
    assert lifted.stuck_depth_mm.tolist() == [0.5]
    assert lifted.stuck_lift_mm[0] == pytest.approx(LIFT_ROUNDS * 0.51)
    assert calls == [[0, 1]] + [[1]] * (LIFT_ROUNDS - 1)
