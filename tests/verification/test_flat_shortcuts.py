"""Shortcuts of the flat and bull-nose search against their full methods.

* the inner minimisation of :mod:`verification.torus` (bracketed Newton on ``w``) against
  a dense minimisation of the core's distance over the chord;
* :func:`~verification.torus.sweep_bound_within` (the slab first) against
  :func:`~verification.torus.sweep_bound`: the same pieces kept, the same bounds;
* the near search's reach (:func:`~verification.dexels.candidate_reach_mm`, ``hypot`` of
  the core's radius and height) against the sum it replaced, on a wall cut by the flank;
* the near search of samples facing away started at the widest level (``guess_mm``)
  against the deepening from the narrowest.
"""

import numpy as np
import pytest

import verification.dexels as dexels_module
import verification.verify as verify_module
from gcode import Linear, Program, Rapid
from toolpath.planning.analytic import PlaneSurface
from toolpath.planning.cutters import parse_cutter
from verification import VerifyOptions, verify_program
from verification.search import Dexels
from verification.torus import (
    core_signed_distance,
    sweep_bound,
    sweep_bound_within,
    sweep_distance,
)


def _unit(v):
    return v / np.linalg.norm(v, axis=1, keepdims=True)


def _three_axis_pieces(rng, m):
    """Pieces of a fixed +Z axis along chords that climb or fall a little (3-axis passes)."""
    c0 = rng.uniform(-2.0, 2.0, (m, 3))
    across = rng.normal(size=(m, 2)) * rng.choice([0.3, 1.5], (m, 1))
    chord = np.column_stack((across, rng.normal(scale=0.15, size=m)))
    axis = np.tile([0.0, 0.0, 1.0], (m, 1))
    return c0, chord, axis


def _dense_distance(y, c0, chord, axis, height, core, corner):
    """``min_w sd_core(y - C0 - w D) - r``: grids over ``w``, each about the last one's least.

    ``Phi`` is convex in ``w`` (kinked inside the core), so the least of a grid lies
    within one step of the minimiser: four grids of 2001 steps pin it to 1e-13 of the chord.
    """
    lo, hi = 0.0, 1.0
    least = np.inf
    for _ in range(4):
        ws = np.linspace(lo, hi, 2001)
        sd, _ = core_signed_distance(y - c0 - ws[:, None] * chord,
                                     np.tile(axis, (ws.size, 1)), np.full(ws.size, height),
                                     core)
        k = int(np.argmin(sd))
        least = min(least, float(sd[k]) - corner)
        lo, hi = ws[max(k - 1, 0)], ws[min(k + 1, ws.size - 1)]
    return least


@pytest.mark.parametrize(("core", "height", "corner"), [(3.0, 3.0, 0.0), (2.0, 1.0, 1.0)])
def test_the_inner_minimum_is_the_dense_one(rng, core, height, corner):
    # points near the rim of the swept core (where the minimiser sits on a rim between two
    # faces: false position crawled there) and anywhere around it, 3-axis and turned axes;
    # mutation caught: a Newton step taken outside the bracket (``lo < nw < hi`` dropped in
    # _inner_min) minimises past the chord's ends, below the true distance
    m = 300
    c0, chord, axis = _three_axis_pieces(rng, m)
    axis[m // 2:] = _unit(rng.normal(size=(m - m // 2, 3)))
    w = rng.uniform(-0.3, 1.3, m)[:, None]
    rim = _unit(np.cross(axis, rng.normal(size=(m, 3)))) * core
    y = c0 + w * chord + rim + rng.normal(scale=rng.choice([0.001, 0.3], (m, 1)), size=(m, 3))
    got = sweep_distance(y, c0, chord, axis, np.full(m, height), core_radius_mm=core,
                         corner_radius_mm=corner)
    want = np.array([_dense_distance(y[k], c0[k], chord[k], axis[k], height, core, corner)
                     for k in range(m)])
    # never below the minimum (every value measured is the distance at some w in [0, 1])
    # and within the stopping test's 1e-9 mm of it
    assert (got >= want - 1e-12).all()
    np.testing.assert_allclose(got, want, rtol=0.0, atol=2e-9)


def test_a_bull_noses_steep_ramp_is_minimised_within_the_step_cap(rng):
    # a bull-nose core swept down a steep ramp: Newton steps on the rim's curved slope
    # crawled (each a small share of the one before) and stopped at the step cap 8.7e-3 mm
    # above the minimum; steps over half the one before last now bisect (the review's
    # case, and random steep ramps); mutation caught: the creeping test dropped
    # (``abs(nw - x) > 0.5 * step_before`` in _inner_min)
    y = np.array([[-1.7621, -1.0206, 0.7973]])
    chord = np.array([[1.2687, -3.0920, -2.8688]])
    m = 200
    ramp = _unit(rng.normal(size=(m, 3))) * rng.uniform(2.0, 5.0, (m, 1))
    ramp[:, 2] = -np.abs(ramp[:, 2]) - 2.0
    c0 = np.zeros((m + 1, 3))
    chord = np.vstack((chord, ramp))
    w = rng.uniform(0.0, 1.0, m)[:, None]
    rim = _unit(np.column_stack((rng.normal(size=(m, 2)), np.zeros(m)))) * 2.0
    y = np.vstack((y, w * ramp + rim + rng.normal(scale=0.5, size=(m, 3))))
    axis = np.tile([0.0, 0.0, 1.0], (m + 1, 1))
    got = sweep_distance(y, c0, chord, axis, np.full(m + 1, 1.0), core_radius_mm=2.0,
                         corner_radius_mm=1.0)
    want = np.array([_dense_distance(y[k], c0[k], chord[k], axis[k], 1.0, 2.0, 1.0)
                     for k in range(m + 1)])
    np.testing.assert_allclose(got, want, rtol=0.0, atol=2e-9)


def test_the_slab_first_bound_keeps_what_the_bound_keeps(rng):
    # a walk keeps a piece where lo < below and hi >= above: the same pieces, the same
    # bounds; limits drawn about each pair's own bounds (and the slab's ends) to sit on
    # the edges; mutation caught: the slab's early exit on ``s_lo < below - 1e-3``
    # (dropping pieces whose capsule still holds them)
    m = 20000
    c0, chord, axis = _three_axis_pieces(rng, m)
    p = c0 + rng.normal(scale=2.0, size=(m, 3))
    d = _unit(rng.normal(size=(m, 3)) + np.array([0.0, 0.0, 1.5]))
    height, core, corner = 3.0, 3.0, 0.0
    for k in range(m):
        lo, hi = sweep_bound(p[k], d[k], c0[k], chord[k], axis[k], height, core, corner)
        finite_lo = lo if np.isfinite(lo) else 0.0
        finite_hi = hi if np.isfinite(hi) else 0.0
        below = finite_lo + rng.choice([-1e-3, -1e-6, 0.0, 1e-6, 1e-3, np.inf])
        above = finite_hi + rng.choice([-1e-3, 0.0, 1e-3, -np.inf])
        got_lo, got_hi = sweep_bound_within(p[k], d[k], c0[k], chord[k], axis[k], height,
                                            core, corner, below, above)
        kept = lo < below and hi >= above
        assert (got_lo < below and got_hi >= above) == kept
        if kept:
            assert (got_lo, got_hi) == (lo, hi)
        if below == np.inf and above == -np.inf:
            assert (got_lo, got_hi) == (lo, hi)


def _wall_program(tip_z_mm, y_mm):
    """Flat passes along a vertical wall (the plane y = 0, material at y > 0), its side on it."""
    blocks = [Rapid(z=10.0), Rapid(x=-6.0, y=y_mm)]
    for k, z in enumerate(tip_z_mm):
        x0, x1 = (-6.0, 12.0) if k % 2 == 0 else (12.0, -6.0)
        blocks += [Rapid(x=x0), Linear(z=z, feed=300.0), Linear(x=x1, feed=800.0),
                   Rapid(z=10.0)]
    return Program(tuple(blocks))


def _full_reach(radii_mm, pieces, core_radius_mm):
    del core_radius_mm
    return radii_mm + pieces.max_half_mm + pieces.max_height_mm


@pytest.mark.parametrize("spec", ["flat:6", "bull:6:1"])
def test_the_hypot_reach_finds_the_flank_contacts_of_the_full_reach(router, monkeypatch,
                                                                     spec):
    # the wall (z 0..2.85) is cut by the cutter's side from 0.1 mm above its tip up to its
    # core's top: contacts up the flank, whose core bottom centre stands hypot(rho0, z)
    # from them (the collision search, which would find them too, left out); mutation
    # caught: the flank term dropped from candidate_reach_mm (``hypot(rho0, H) - rho0``
    # -> 0), which leaves the wall's upper part uncut
    cutter = parse_cutter(spec)
    wall = PlaneSurface((0.0, 0.0, 0.0), (6.0, 0.0, 0.0), (0.0, 0.0, 2.85))
    program = _wall_program([-0.1], -cutter.radius_mm - 0.01)
    options = VerifyOptions(spacing_mm=0.1, collision=False)
    fast = verify_program(program, wall, router, cutter, options=options)
    with monkeypatch.context() as m:
        m.setattr(dexels_module, "candidate_reach_mm", _full_reach)
        full = verify_program(program, wall, router, cutter, options=options)
    a, b = fast.deviation_map.deviation_mm, full.deviation_map.deviation_mm
    # the wall is cut, 10 um deep where the cutter's straight side passes (the check has
    # something to find; a bull-nose's corner leaves more at the wall's foot)
    assert np.isfinite(b).mean() > 0.6 and (np.abs(b - 0.01) < 1e-6).mean() > 0.3
    np.testing.assert_array_equal(a, b)
    np.testing.assert_array_equal(fast.deviation_map.block_index,
                                  full.deviation_map.block_index)


def test_samples_facing_away_start_at_the_widest_level_with_the_same_results(router,
                                                                            monkeypatch):
    # a plate 0.3 mm thick (its underside faces away from the +Z axis) under a flat raster
    # that gouges through it: the underside's samples hold material the narrower levels
    # find, so their search must come back to those levels (Dexels._narrower): the same
    # material and blocks as the deepening from the narrowest level; mutation caught: the
    # guess dropped in verify_program (every sample started at the narrowest level again)
    cutter = parse_cutter("flat:6")
    top = PlaneSurface((0.0, 0.0, 0.0), (6.0, 0.0, 0.0), (0.0, 6.0, 0.0))
    program = Program((Rapid(z=5.0), Rapid(x=-5.0, y=1.0), Linear(z=-0.31, feed=300.0),
                       Linear(x=11.0, feed=800.0), Linear(y=4.0, feed=800.0),
                       Linear(x=-5.0, feed=800.0),
                       Rapid(z=5.0)))
    bottom = PlaneSurface((0.0, 0.0, -0.3), (0.0, 6.0, 0.0), (6.0, 0.0, 0.0))
    grid_search = verify_module.grid_search
    for surface in (top, bottom):
        options = VerifyOptions(spacing_mm=0.1)
        guessed = verify_program(program, surface, router, cutter, options=options)
        calls = []

        def no_guess(ev, samples, stride, *, guess_mm=None, _calls=calls):
            _calls.append(guess_mm)
            return grid_search(ev, samples, stride)

        with monkeypatch.context() as m:
            m.setattr(verify_module, "grid_search", no_guess)
            plain = verify_program(program, surface, router, cutter, options=options)
        assert calls and np.isinf(calls[0]).any() == (surface is bottom)
        a, b = guessed.deviation_map.deviation_mm, plain.deviation_map.deviation_mm
        np.testing.assert_array_equal(a, b)
        np.testing.assert_array_equal(guessed.deviation_map.block_index,
                                      plain.deviation_map.block_index)
        assert guessed.max_gouge_mm == plain.max_gouge_mm


def test_a_dexel_started_wide_that_stops_narrower_names_the_narrower_levels_block(
        router, monkeypatch):
    # a bull-nose pass split into two blocks gouges 0.05 mm through the plate's underside
    # (facing away: started at the widest level): where both blocks leave the same 0.05 mm
    # on a dexel, the first block's end lies within the widest level's ball but outside the
    # level the deepening stops at, which holds only the second block: the deepening names
    # the second, the widest level the first (the tie rule). Dexels._narrower searches such
    # dexels again at their level: the same blocks, gouged areas and lines as the deepening
    # from the narrowest level; mutation caught: the ``self._narrower(...)`` call dropped
    # from Dexels.search (122 samples name the other block, the blocks' areas move 1.2 mm2)
    cutter = parse_cutter("bull:6:1")
    bottom = PlaneSurface((0.0, 0.0, -0.3), (0.0, 6.0, 0.0), (6.0, 0.0, 0.0))
    program = Program((Rapid(z=5.0), Rapid(x=-5.0, y=3.0), Linear(z=-0.35, feed=300.0),
                       Linear(x=3.0, feed=800.0), Linear(x=11.0, feed=800.0),
                       Rapid(z=5.0)))
    options = VerifyOptions(spacing_mm=0.1)
    grid_search = verify_module.grid_search

    def no_guess(ev, samples, stride, *, guess_mm=None):
        assert np.isinf(guess_mm).any()  # the underside is started at the widest level
        return grid_search(ev, samples, stride)

    def verify():
        return verify_program(program, bottom, router, cutter, options=options)

    guessed = verify()
    with monkeypatch.context() as m:
        m.setattr(verify_module, "grid_search", no_guess)
        plain = verify()
    with monkeypatch.context() as m:
        m.setattr(Dexels, "_narrower", lambda *args: None)
        widest = verify()
    # the case has ties the narrower levels decide (else it could not fail): both blocks
    # gouge, and the widest level alone names the other block on some samples
    assert [g.block_index for g in plain.gouging_blocks] == [3, 4]
    assert (widest.deviation_map.block_index != plain.deviation_map.block_index).any()
    np.testing.assert_array_equal(guessed.deviation_map.deviation_mm,
                                  plain.deviation_map.deviation_mm)
    np.testing.assert_array_equal(guessed.deviation_map.block_index,
                                  plain.deviation_map.block_index)
    assert guessed.gouging_blocks == plain.gouging_blocks
    assert guessed.max_gouge == plain.max_gouge
