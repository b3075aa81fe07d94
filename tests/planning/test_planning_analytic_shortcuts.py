"""Analytic surfaces' shortcuts against the full method they replace.

A sphere's closest points in closed form (the Newton search), several partials from one
evaluation of the trigonometry (each partial on its own).
"""

import numpy as np
import pytest

from toolpath.planning import EllipticBladeSurface, SpherePatch
from toolpath.planning.local import _newton_search, project_to_surface, signed_distance_near

SPHERES = [
    SpherePatch(radius_mm=150.0, longitude_deg=(-90.0, 90.0), colatitude_deg=(10.0, 70.0)),
    # across the longitude's branch cut (+-180 deg), reversed, and a bowl
    SpherePatch(radius_mm=30.0, centre_mm=(5.0, -2.0, 40.0), longitude_deg=(210.0, 150.0),
                colatitude_deg=(100.0, 40.0), inside=True),
]


def _points_off(surface, n, lift_mm, spread, seed):
    """Points ``lift_mm`` (scattered by ``spread``) off the surface, and their feet's t, s."""
    rng = np.random.default_rng(seed)
    t, s = rng.random(n), rng.random(n)
    x, normal = surface.points_and_normals(t, s)
    lift = lift_mm + spread * rng.normal(size=n)
    return x + lift[:, None] * normal, t, s


@pytest.mark.parametrize("sphere", SPHERES)
@pytest.mark.parametrize("lift_mm", [3.0, -0.02, 0.001])
def test_sphere_feet_in_closed_form_are_the_newton_feet(sphere, lift_mm):
    points, t, s = _points_off(sphere, 400, lift_mm, 0.01, 1)
    rng = np.random.default_rng(2)
    t0 = np.clip(t + 0.01 * rng.normal(size=t.size), 0.0, 1.0)
    s0 = np.clip(s + 0.01 * rng.normal(size=s.size), 0.0, 1.0)
    tc, sc, dc = project_to_surface(sphere, points, t0, s0, iterations=3)
    tn, sn, xn = _newton_search(sphere, points, t0.copy(), s0.copy(), 3)
    assert tc == pytest.approx(tn, abs=1e-9) and sc == pytest.approx(sn, abs=1e-9)
    assert dc == pytest.approx(np.linalg.norm(xn - points, axis=1), abs=1e-9)
    assert tc == pytest.approx(t, abs=1e-9) and sc == pytest.approx(s, abs=1e-9)
    signed, *_ = signed_distance_near(sphere, points, t0, s0, iterations=3)
    _, normal = sphere.points_and_normals(tn, sn)
    assert signed == pytest.approx(np.einsum("ij,ij->i", points - xn, normal), abs=1e-9)


def test_feet_beyond_the_patch_are_searched_as_before():
    # radial projections outside the patch (beyond an edge in t, in s, at a corner): the
    # closed form leaves them to Newton's method from the caller's start
    sphere = SPHERES[0]
    t = np.array([-0.05, 0.5, 1.1, 0.3])
    s = np.array([0.5, 1.08, -0.1, 0.6])
    x, normal = sphere.points_and_normals(t, s)
    points = x + 2.0 * normal
    t0, s0 = np.clip(t, 0.0, 1.0), np.clip(s, 0.0, 1.0)
    *_, exact = sphere.closest_parameters(points)
    assert exact.tolist() == [False, False, False, True]
    tc, sc, dc = project_to_surface(sphere, points, t0, s0, iterations=4)
    tn, sn, xn = _newton_search(sphere, points, t0.copy(), s0.copy(), 4)
    assert tc == pytest.approx(tn, abs=1e-12) and sc == pytest.approx(sn, abs=1e-12)
    assert dc == pytest.approx(np.linalg.norm(xn - points, axis=1), abs=1e-12)


def test_surfaces_without_a_closed_form_are_searched():
    blade = EllipticBladeSurface()
    assert blade.closest_parameters(np.zeros((2, 3))) is None
    points, t, s = _points_off(blade, 50, 3.0, 0.0, 3)
    *_, dc = project_to_surface(blade, points, t, s, iterations=3)
    assert dc == pytest.approx(3.0, abs=1e-9)


@pytest.mark.parametrize("surface", [SPHERES[1], EllipticBladeSurface()])
def test_partials_at_once_are_each_partial(surface):
    rng = np.random.default_rng(4)
    t, s = rng.random(300), rng.random(300)
    orders = ((0, 0), (1, 0), (0, 1), (2, 0), (1, 1), (0, 2))
    many = surface.partials_many(t, s, orders)
    for dt, ds in orders:
        assert np.array_equal(many[dt, ds], surface.derivative(t, s, dt=dt, ds=ds))
