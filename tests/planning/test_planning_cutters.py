"""Cutters: spec parsing, placement from the contact, curvature, signed distance."""

import numpy as np
import pytest

from toolpath.errors import InvalidParameterError
from toolpath.planning import Cutter, CutterKind, parse_cutter
from toolpath.planning.tool_axis import lead_tilt_axes


def test_spec_number_is_the_diameter():
    ball = parse_cutter("ball:6")
    assert (ball.kind, ball.radius_mm, ball.corner_radius_mm) == (CutterKind.BALL, 3.0, 3.0)
    flat = parse_cutter("flat:10")
    assert (flat.radius_mm, flat.corner_radius_mm) == (5.0, 0.0)
    bull = parse_cutter("bull:10:2:flute=40")
    assert (bull.radius_mm, bull.corner_radius_mm, bull.flute_length_mm) == (5.0, 2.0, 40.0)
    assert parse_cutter(bull.spec) == Cutter(CutterKind.BULL, 5.0, 2.0, 30.0)
    assert ball.flute_length_mm == 18.0  # three diameters by default


@pytest.mark.parametrize("spec, words", [
    ("ball", "takes 1 number"), ("drill:6", "unknown kind"), ("ball:x", "not a number"),
    ("bull:10", "takes 2 number"), ("bull:10:6", "strictly between"), ("ball:-6", "> 0"),
    ("flat:6:flute=2", "at least the radius")])
def test_bad_specs_name_the_spec_and_the_convention(spec, words):
    with pytest.raises(InvalidParameterError) as err:
        parse_cutter(spec)
    assert repr(spec) in str(err.value) and words in str(err.value)


def _min_height_over_cutter(cutter, tip, axis, point, normal, n=20000):
    """Lowest point of the cutter's cutting end along -normal, by dense sampling."""
    rng = np.random.default_rng(1)
    b1 = np.cross(axis, [1.0, 0.0, 0.0] if abs(axis[0]) < 0.9 else [0.0, 1.0, 0.0])
    b1 /= np.linalg.norm(b1)
    b2 = np.cross(axis, b1)
    phi = rng.uniform(0, 2 * np.pi, n)
    psi = rng.uniform(0, np.pi / 2, n)  # lower quarter of the corner circle
    r, big = cutter.corner_radius_mm, cutter.radius_mm
    radial = np.cos(phi)[:, None] * b1 + np.sin(phi)[:, None] * b2
    pts = (tip + r * axis + (big - r) * radial + r * (np.sin(psi)[:, None] * radial
                                                      - np.cos(psi)[:, None] * axis))
    face = tip + (big - r) * np.sqrt(rng.uniform(0, 1, (n, 1))) * radial
    return float(np.min(np.concatenate([pts, face]) @ normal - point @ normal))


@pytest.mark.parametrize("spec", ["ball:6", "bull:10:2", "flat:8"])
def test_cutter_location_touches_the_tangent_plane_at_the_contact(spec, rng):
    cutter = parse_cutter(spec)
    for _ in range(5):
        normal = rng.normal(size=3)
        normal[2] = abs(normal[2]) + 0.5
        normal /= np.linalg.norm(normal)
        axis = lead_tilt_axes(normal[None], np.cross(normal, [0.3, 1.0, 0.2])[None]
                              / np.linalg.norm(np.cross(normal, [0.3, 1.0, 0.2])),
                              rng.uniform(2, 30), rng.uniform(-20, 20))[0]
        point = rng.normal(size=3) * 10
        tip = cutter.tips_from_contacts(point, normal, axis)
        # the cutter rests on the tangent plane (lowest point at height 0) ...
        assert abs(_min_height_over_cutter(cutter, tip, axis, point, normal)) < 2e-3
        # ... and touches it exactly at the contact
        assert abs(cutter.signed_distance(point, tip, axis)) < 1e-9


def test_ball_tip_formula():
    cutter = parse_cutter("ball:6")
    n, a = np.array([0.0, 0.6, 0.8]), np.array([0.0, 0.0, 1.0])
    np.testing.assert_allclose(cutter.tips_from_contacts(np.zeros(3), n, a), 3.0 * (n - a))


def test_bull_effective_radius_across_a_lead_is_the_classical_one():
    cutter = parse_cutter("bull:10:2")
    n = np.array([[0.0, 0.0, 1.0]])
    feed = np.array([[1.0, 0.0, 0.0]])
    for lead in (5.0, 15.0, 40.0):
        axis = lead_tilt_axes(n, feed, lead, 0.0)
        across = np.cross(n, feed)
        expected = (5.0 - 2.0) / np.sin(np.radians(lead)) + 2.0
        np.testing.assert_allclose(cutter.effective_radius_mm(n, axis, across), expected)
        # along the feed, the corner radius
        np.testing.assert_allclose(cutter.effective_radius_mm(n, axis, feed), 2.0)
    ball = parse_cutter("ball:6")
    np.testing.assert_allclose(ball.effective_radius_mm(n, lead_tilt_axes(n, feed, 20, 10),
                                                        feed), 3.0)


def test_signed_distance_of_known_points():
    cutter = parse_cutter("bull:10:2")
    tip, axis = np.zeros(3), np.array([0.0, 0.0, 1.0])
    pts = np.array([[0, 0, -1.0], [8.0, 0, 10.0], [0, 0, 5.0], [5.0, 0, 2.0]])
    np.testing.assert_allclose(cutter.signed_distance(pts, tip, axis),
                               [1.0, 3.0, -5.0, 0.0], atol=1e-12)


@pytest.mark.parametrize("spec", ["flat:6", "bull:6:1", "bull:10:2"])
def test_flat_and_bull_gap_matches_a_scan_of_the_whole_disc(spec):
    # the rim window facing down the surface finds what 33 samples of the disc find (or
    # lower), tool axes upright and leaning, over a sphere of radius 20 mm
    from toolpath.planning import SpherePatch
    from toolpath.planning.sampling import _Disc, cutter_gap

    rng = np.random.default_rng(3)
    sphere = SpherePatch(radius_mm=20.0, longitude_deg=(-40.0, 40.0),
                         colatitude_deg=(5.0, 60.0))
    cutter = parse_cutter(spec)
    t, s = rng.random(300), rng.random(300)
    frame = sphere.frame(t, s)
    axes = np.tile([0.0, 0.0, 1.0], (300, 1)) + 0.3 * rng.normal(size=(300, 3)) * (
        rng.random(300) < 0.5)[:, None]
    axes /= np.linalg.norm(axes, axis=1, keepdims=True)
    tips = cutter.tips_from_contacts(frame.point, frame.normal, axes)
    tips = tips + rng.normal(scale=0.01, size=tips.shape)
    gap, _, _ = cutter_gap(sphere, cutter, tips, axes, t, s, newton=3)
    r = cutter.corner_radius_mm
    disc = _Disc(sphere, cutter, tips, axes, 4, (t, s))
    scanned = disc.scan(np.arange(300), t, s)[0][0]
    assert np.all(gap <= scanned - r + 5e-4)
    assert np.median(np.abs(gap - (scanned - r))) < 1e-5
    # in chunks of poses (the disc's samples of a million moves would take gigabytes),
    # the same gaps
    whole, _, _ = cutter_gap(sphere, cutter, tips, axes, t, s, newton=2, refine_rim=True)
    chunked, _, _ = cutter_gap(sphere, cutter, tips, axes, t, s, newton=2, refine_rim=True,
                               chunk=70)
    np.testing.assert_array_equal(chunked, whole)
