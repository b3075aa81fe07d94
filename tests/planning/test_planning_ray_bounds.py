"""The lower bounds the flat/bull-nose ray cast skips pieces on, checked one by one.

:func:`toolpath.planning.sweep_kernel.nearest_entries` skips a piece when no pose of it can
be entered before the ray's best entry so far. The end-to-end check against the full method
(``test_planning_ray_entries``) cannot tell a bound that is a little too small from a sound
one: at a sampled pose the floor holds even without any shift, and random rays seldom
graze a pose between samples closely enough. So each bound is checked on its own here:

* :func:`_pose_shift` (with :func:`_piece_motion`): over ``|v - u| <= du`` a point ``arm``
  from the tip at ``u`` changes its distance to the cutter by at most the shift (``du`` a
  sample's spacing, and a whole piece: the floor from a piece's start pose), on pieces
  that travel up to 20 mm and turn up to 170 deg, points up to 30 mm out; and the bound is
  nearly reached (so the first check probes it where it is tight: a shift a fifth too small,
  or without its turn term, fails);
* the samples' floor in :func:`_pair_entry`: where it returns no entry, no pose of the
  piece (2,049 of them) is entered up to the ray's best entry so far.
"""

import numba
import numpy as np
import pytest

from toolpath.planning import sweep_kernel as sk
from toolpath.planning.clearance_kernel import Cutter
from toolpath.planning.cutters import parse_cutter

SPECS = ["flat:6", "flat:2", "bull:4:1", "bull:8:1", "bull:10:4"]


def _unit(v):
    return v / np.linalg.norm(v, axis=-1, keepdims=True)


def _cutter(spec: str) -> Cutter:
    cutter = parse_cutter(spec)
    return Cutter(cutter.corner_radius_mm, cutter.radius_mm, cutter.flute_length_mm)


def _pieces(rng, n, max_turn_deg, max_travel_mm):
    """``n`` pieces: tips and unit axes at both ends, half of them turning little."""
    a0 = _unit(rng.normal(size=(n, 3)))
    side = _unit(np.cross(a0, rng.normal(size=(n, 3))))
    turn = np.radians(np.where(rng.random(n) < 0.5, rng.uniform(0.0, max_turn_deg, n),
                               rng.uniform(0.0, 10.0, n)))
    a1 = np.cos(turn)[:, None] * a0 + np.sin(turn)[:, None] * side
    p0 = rng.normal(size=(n, 3))
    travel = np.where(rng.random(n) < 0.5, rng.uniform(0.0, max_travel_mm, n),
                      rng.uniform(0.0, 1.0, n))
    p1 = p0 + travel[:, None] * _unit(rng.normal(size=(n, 3)))
    return sk.Poses(*[np.ascontiguousarray(x) for x in (p0, p1, a0, a1)])


@numba.njit
def _largest_shift_ratio(poses, points, cutter, du, steps):
    """Largest ``|g_v(x) - g_u(x)| / shift`` over sampled poses ``u``, ``|v - u| <= du``."""
    tip_u, axis_u = np.empty(3), np.empty(3)
    tip_v, axis_v = np.empty(3), np.empty(3)
    origin = np.zeros(3)
    largest = 0.0
    for j in range(points.shape[0]):
        travel, rate = sk._piece_motion(poses[0][j], poses[1][j], poses[2][j], poses[3][j])
        for m in range(sk.POSES):
            u = m / (sk.POSES - 1)
            sk._pose_at(u, poses, j, tip_u, axis_u)
            for t in range(steps + 1):
                v = u - du + 2.0 * du * t / steps
                if v < 0.0 or v > 1.0:
                    continue
                sk._pose_at(v, poses, j, tip_v, axis_v)
                for k in range(points.shape[1]):
                    x = points[j, k]
                    arm = np.sqrt(np.sum((x - tip_u) ** 2))
                    shift = sk._pose_shift(travel, rate, du, arm)
                    change = abs(sk._distance(x, origin, 0.0, tip_v, axis_v, cutter)
                                 - sk._distance(x, origin, 0.0, tip_u, axis_u, cutter))
                    largest = max(largest, change / shift)
    return largest


@pytest.mark.parametrize("du", [0.5 / (sk.POSES - 1), 1.0])  # (a sample's; a whole piece's)
@pytest.mark.parametrize("spec", SPECS)
def test_the_pose_shift_bounds_how_far_the_cutter_moves_past_a_point(spec, du):
    rng = np.random.default_rng(7)
    cutter = parse_cutter(spec)
    n, per_piece = 120, 40
    poses = _pieces(rng, n, max_turn_deg=170.0, max_travel_mm=20.0)
    u = rng.uniform(0.0, 1.0, (n, per_piece, 1))
    tip = poses.tip0[:, None] + u * (poses.tip1 - poses.tip0)[:, None]
    axis = _unit(poses.axis0[:, None] + u * (poses.axis1 - poses.axis0)[:, None])
    # points near the cutter and far out, up its flutes
    points = (tip + rng.normal(size=(n, per_piece, 3))
              * rng.choice([0.5, 2.0, 6.0, 30.0], (n, per_piece, 1))
              + rng.uniform(0.0, cutter.flute_length_mm, (n, per_piece, 1)) * axis)
    ratio = _largest_shift_ratio(poses, np.ascontiguousarray(points), _cutter(spec), du, 32)
    assert ratio <= 1.0
    assert ratio > 0.9  # the check reaches where the bound is tight


@numba.njit
def _floor_misses(rays, directions, poses, cutter, horizon, below, dense):
    """Rays the floor skipped, and of those, rays a pose of their piece enters up to ``below``.

    Skipped: no entry where the full method finds one (beyond ``below``, if sound).
    """
    tip, axis, values = np.empty(3), np.empty(3), np.empty(sk.POSES)
    skipped, wrong = 0, 0
    for i in range(rays.shape[0]):
        travel, rate = sk._piece_motion(poses[0][i], poses[1][i], poses[2][i], poses[3][i])
        got = sk._pair_entry(rays[i], directions[i], poses, i, travel, rate, cutter, horizon,
                             below[i], -1.0, tip, axis, values)
        if got < np.inf:
            continue
        # the full method: with no best entry yet, no floor and no skipped search
        if sk._pair_entry(rays[i], directions[i], poses, i, travel, rate, cutter, horizon,
                          np.inf, -1.0, tip, axis, values) == np.inf:
            continue
        skipped += 1
        for t in range(dense + 1):
            if sk._entry_at(t / dense, rays[i], directions[i], poses, i, cutter, horizon,
                            tip, axis) <= below[i]:
                wrong += 1
                break
    return skipped, wrong


@pytest.mark.parametrize("spec", ["flat:6", "flat:2", "bull:4:1", "bull:8:1"])
@pytest.mark.parametrize("horizon_mm", [0.6, 3.0, 8.0])
def test_the_samples_floor_skips_no_piece_entered_before_the_best(spec, horizon_mm):
    rng = np.random.default_rng(11)
    cutter = parse_cutter(spec)
    n = 4000
    poses = _pieces(rng, n, max_turn_deg=170.0, max_travel_mm=25.0)
    # rays grazing the cutter at a pose between two samples: its wall, corner or tip face
    u = ((rng.integers(0, sk.POSES - 1, n) + rng.uniform(0.2, 0.8, n)) / (sk.POSES - 1))
    tip = poses.tip0 + u[:, None] * (poses.tip1 - poses.tip0)
    axis = _unit(poses.axis0 + u[:, None] * (poses.axis1 - poses.axis0))
    side = _unit(np.cross(axis, rng.normal(size=(n, 3))))
    up = rng.uniform(-0.2, 2.0 * cutter.corner_radius_mm + 2.0, (n, 1))
    target = tip + up * axis + (cutter.radius_mm - rng.uniform(0.0, 0.05, (n, 1))) * side
    face = rng.random(n) < 0.3
    target[face] = (tip + rng.uniform(0.0, cutter.radius_mm, (n, 1)) * side
                    - rng.uniform(0.0, 0.05, (n, 1)) * axis)[face]
    along = _unit(np.cross(side, rng.normal(size=(n, 3))))
    directions = _unit(along - rng.uniform(0.0, 0.5, (n, 1)) * side)
    rays = target - rng.uniform(0.0, horizon_mm, (n, 1)) * directions
    below = rng.uniform(0.0, horizon_mm, n)
    skipped, wrong = _floor_misses(np.ascontiguousarray(rays), np.ascontiguousarray(directions),
                                   poses, _cutter(spec), horizon_mm, below, 2048)
    assert skipped > 20  # the floor does skip pieces on these rays
    assert wrong == 0
