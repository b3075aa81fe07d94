"""Runs of flat/bull-nose pieces: each inside its dilated reference, and the same search.

The compiled walk measures a run's dilated reference piece first and its pieces only
where that enters below the best value so far (:mod:`verification.piece_runs`): a
shortcut that must hold every piece (checked point by point against the swept-cutter
distance) and leave the very values the pair search over every piece finds (the oracle,
``compiled=False``), on programs whose pieces the turning axis cuts short and on a thin
wall met from behind, where a run below the design point must count for nothing.
"""

import numpy as np
import pytest
from search_oracle import assert_same_material, compiled_and_oracle
from verify_programs import five_axis_cap, five_axis_line

from gcode import Linear, Program, Rapid
from machines import load_machine
from toolpath.planning.analytic import PlaneSurface, SpherePatch
from toolpath.planning.cutters import parse_cutter
from verification import VerifyOptions
from verification.dexels import SweepIndex
from verification.piece_runs import piece_runs
from verification.pieces import Pieces
from verification.replay import replay
from verification.torus import sweep_distance
from verification.verify import _pieces, _settings


def _cap(spec):
    machine = load_machine("trunnion-ac")
    cutter = parse_cutter(spec)
    program = five_axis_cap(machine, cutter, 20.0, colatitudes_deg=(20.0, 26.0, 32.0),
                            longitude_deg=(-20.0, 20.0), points=40, lead_deg=10.0)
    return machine, cutter, program


def _cap_pieces(spec):
    """The cutter and its pieces (the verifier's own) over the cap's 5-axis passes."""
    machine, cutter, program = _cap(spec)
    opts = VerifyOptions()
    _, cfg = _settings(SpherePatch(radius_mm=20.0), cutter, opts)
    motion = replay(program, machine, chord_tol_mm=opts.replay_tol_mm,
                    radius_mm=cutter.radius_mm)
    return cutter, _pieces(motion, cutter, cfg, opts, shank=False)[0]


@pytest.mark.parametrize("spec", ["bull:6:1", "flat:6"])
def test_every_piece_of_a_run_lies_inside_its_dilated_reference(rng, spec):
    cutter, pieces = _cap_pieces(spec)
    corner = cutter.corner_radius_mm
    core = cutter.radius_mm - corner
    runs = piece_runs(pieces, core_radius_mm=core, corner_radius_mm=corner)
    long = np.flatnonzero(runs.stop - runs.start >= 8)
    assert long.shape[0] > 10  # the turning axis cuts pieces short: runs hold many
    for run in rng.choice(long, size=8, replace=False):
        k = rng.integers(runs.start[run], runs.stop[run], size=300)
        # points around the pieces, inside and out, and one point per piece on its path
        x = (pieces.a[k] + rng.uniform(0.0, 1.0, (300, 1)) * pieces.e[k]
             + rng.normal(0.0, 1.0, (300, 3)) * rng.uniform(0.0, cutter.radius_mm + 0.5,
                                                               (300, 1)))
        own = sweep_distance(x, pieces.a[k], pieces.e[k], pieces.axis[k], pieces.height_mm[k],
                             core_radius_mm=core, corner_radius_mm=corner)
        n = x.shape[0]
        ref = sweep_distance(x, np.repeat(runs.c0[[run]], n, axis=0),
                             np.repeat(runs.chord[[run]], n, axis=0),
                             np.repeat(runs.axis[[run]], n, axis=0),
                             np.repeat(runs.height_mm[[run]], n),
                             core_radius_mm=core, corner_radius_mm=corner)
        # outside a piece its distance is exact: the dilated reference is no farther
        outside = own >= 0.0
        assert np.all(ref[outside] - runs.dilation_mm[run] <= own[outside] + 1e-12)
        # inside a piece: inside the dilated reference
        assert np.all(ref[~outside] <= runs.dilation_mm[run])


@pytest.mark.parametrize("spec", ["bull:6:1", "flat:6"])
def test_five_axis_passes_over_a_sphere_give_the_pair_searchs_values(monkeypatch, spec):
    machine, cutter, program = _cap(spec)
    sphere = SpherePatch(radius_mm=20.0, colatitude_deg=(21.0, 31.0),
                         longitude_deg=(-15.0, 15.0))
    assert_same_material(*compiled_and_oracle(
        monkeypatch, program, sphere, machine, cutter,
        options=VerifyOptions(spacing_mm=0.25, horizon_mm=0.2, refine=4)))


@pytest.mark.parametrize("spec", ["bull:6:1", "flat:6"])
def test_a_thin_wall_cut_on_top_and_nicked_from_behind(monkeypatch, router, spec):
    # the underside of a 0.5 mm plate: one pass on top, one dipping 0.3 mm through it
    underside = PlaneSurface((0.0, 0.0, 0.0), (0.0, 10.0, 0.0), (10.0, 0.0, 0.0))
    program = Program((Rapid(x=-5.0, y=5.0, z=5.0), Linear(z=0.5, feed=300.0),
                       Linear(x=15.0, feed=800.0), Rapid(z=5.0), Rapid(x=-5.0, y=2.0),
                       Linear(z=-0.3, feed=300.0), Linear(x=15.0, y=3.0, feed=800.0),
                       Rapid(z=5.0)))
    assert_same_material(*compiled_and_oracle(
        monkeypatch, program, underside, router, parse_cutter(spec),
        options=VerifyOptions(spacing_mm=0.1)))


@pytest.mark.parametrize("spec", ["bull:6:1", "flat:6"])
def test_a_turning_tool_through_a_plate_from_behind(monkeypatch, spec):
    # the underside of a plate 0.2 mm above the tip: the cutter pokes 0.2 mm out through
    # it while the axis turns (runs of many pieces). Seen from the underside the runs come
    # from behind and leave the dexels just 0.2 mm past the design point: a run may be
    # dropped only where its dilated sweep leaves at or below it. Without the fine model
    # (extremes_tol_mm=None) the extremes are refined with the very searches compared
    # (the fine model walks compiled in both runs) and each run takes a second, not 14 s
    machine = load_machine("trunnion-ac")
    cutter = parse_cutter(spec)
    program = five_axis_line(machine, cutter, 4, tilt_deg=(5.0, 12.0), length_mm=4.0,
                             lean="y")
    underside = PlaneSurface((0.0, -2.0, 0.2), (0.0, 4.0, 0.0), (4.0, 0.0, 0.0))
    fast, exact = compiled_and_oracle(
        monkeypatch, program, underside, machine, cutter,
        options=VerifyOptions(spacing_mm=0.2, refine=4, extremes_tol_mm=None))
    assert exact.max_gouge_mm == pytest.approx(0.2, abs=0.01)
    assert_same_material(fast, exact)


def _turning_pieces(rng, *, turn_per_mm, flute_mm, paths=3, steps=400):
    """Flat/bull-nose pieces along wandering paths whose axis turns ``turn_per_mm``
    (rad/mm, at random up to twice that per step), with jumps and new turn directions."""
    a, e, axes = [], [], []
    for _ in range(paths):
        tip = rng.uniform(-3.0, 3.0, 3)
        axis = rng.normal(size=3)
        axis[2] = abs(axis[2]) + 0.5
        axis /= np.linalg.norm(axis)
        way = rng.normal(size=3)
        way /= np.linalg.norm(way)
        side = np.cross(axis, rng.normal(size=3))
        side /= np.linalg.norm(side)
        step_mm = rng.uniform(0.001, 0.05)
        for _ in range(steps):
            a.append(tip.copy())
            e.append(way * step_mm)
            axes.append(axis.copy())
            tip = tip + way * step_mm
            if rng.random() < 0.02:
                tip = tip + rng.normal(size=3) * 0.3
            angle = turn_per_mm * step_mm * rng.uniform(0.0, 2.0)
            axis = np.cos(angle) * axis + np.sin(angle) * side
            side = np.cross(np.cross(axis, side), axis)
            side /= np.linalg.norm(side)
            if rng.random() < 0.05:
                side = np.cross(axis, rng.normal(size=3))
                side /= np.linalg.norm(side)
            way = way + rng.normal(size=3) * 0.2
            way /= np.linalg.norm(way)
    a, e, axes = np.array(a), np.array(e), np.array(axes)
    ee = np.einsum("ij,ij->i", e, e)
    m = a.shape[0]
    return Pieces(a, e, ee, a + 0.5 * e, 0.5 * np.sqrt(ee), np.arange(m, dtype=np.int64),
                  np.zeros(m, dtype=bool), axes, np.full(m, np.nan), np.full(m, np.nan),
                  np.zeros(1), np.zeros(1, dtype=np.int64), np.full(m, flute_mm))


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_pieces_turning_fast_on_long_flutes_give_the_pair_searchs_values(seed):
    # a turn strays a point of the cutter farthest at the top of its flank (16 mm up): the
    # rotation bound must count the core's height, not the radius alone
    radius_mm, corner_mm = 3.0, 1.0
    rng = np.random.default_rng(seed)
    for turn_per_mm in (5.0, 40.0):
        pieces = _turning_pieces(rng, turn_per_mm=turn_per_mm, flute_mm=16.0)
        k = rng.integers(0, pieces.size, 3000)
        centre = pieces.a[k] + rng.uniform(0.0, 1.0, (3000, 1)) * pieces.e[k]
        axis = pieces.axis[k]
        out = rng.normal(size=(3000, 3))
        out -= np.einsum("ij,ij->i", out, axis)[:, None] * axis
        out /= np.linalg.norm(out, axis=1, keepdims=True)
        kind = rng.integers(0, 3, 3000)  # near the flank, anywhere inside, at the tip
        up = np.where(kind == 2, -corner_mm + rng.normal(0.0, 0.05, 3000),
                      rng.uniform(-corner_mm, 16.0 + corner_mm, 3000))
        across = np.where(kind == 0, radius_mm + rng.normal(0.0, 0.05, 3000),
                          rng.uniform(0.0, radius_mm + 0.3, 3000))
        points = centre + out * across[:, None] + axis * up[:, None]
        dirs = rng.normal(size=(3000, 3))
        back = rng.random(3000) < 0.5
        dirs[back] = -axis[back] + rng.normal(size=(back.sum(), 3)) * 0.3
        dirs /= np.linalg.norm(dirs, axis=1, keepdims=True)
        reach = np.full(3000, rng.uniform(0.5, 3.0))
        none_taken = pieces.taken(np.zeros(pieces.size, dtype=bool))
        found = [SweepIndex(pieces, none_taken, radius_mm, points.min(0), points.max(0), 0.25,
                            30.0, corner_radius_mm=corner_mm, compiled=compiled
                            ).search("near", points, dirs, points, reach).lam_mm
                 for compiled in (True, False)]
        assert np.array_equal(np.isinf(found[0]), np.isinf(found[1]))
        finite = np.isfinite(found[1])
        assert finite.sum() > 2000
        np.testing.assert_allclose(found[0][finite], found[1][finite], rtol=0.0, atol=1e-9)


def _turning_run(rng, n, step_mm, bend):
    """``n`` pieces end to end (small random gaps), the path bending by ``bend`` per piece,
    the axis turning by up to a few hundredths of a radian per piece."""
    def unit(v):
        return v / np.linalg.norm(v)

    axes = [unit(rng.normal(size=3))]
    for _ in range(n - 1):
        axes.append(unit(axes[-1] + rng.normal(size=3) * 10 ** rng.uniform(-5.0, -1.5)))
    a, e = np.zeros((n, 3)), np.zeros((n, 3))
    p, heading = np.zeros(3), unit(rng.normal(size=3))
    for k in range(n):
        heading = unit(heading + bend * rng.normal(size=3))
        a[k] = p
        e[k] = heading * step_mm * rng.uniform(0.0, 1.5)
        p = a[k] + e[k] + rng.normal(size=3) * step_mm * 0.3 * (rng.random() < 0.3)
    return a, e, np.array(axes)


@pytest.mark.parametrize("spec", ["bull:6:1", "flat:6", "bull:8:2"])
def test_a_half_runs_constant_time_bound_holds_its_pieces(rng, spec):
    # the walk halves runs and bounds each half's dilation from prefix sums
    # (span_reference): the axis steps summed and the path's length (the spheroid about
    # the chord); every piece of the half lies inside its reference dilated by that bound
    from verification.piece_runs import ENTRY_MARGIN_MM, _dilation, _prefixes, span_reference

    cutter = parse_cutter(spec)
    corner = cutter.corner_radius_mm
    core = cutter.radius_mm - corner
    height = cutter.radius_mm - 2.0 * corner if corner else 0.0
    for _ in range(40):
        n = int(rng.integers(2, 40))
        a, e, axes = _turning_run(rng, n, 10 ** rng.uniform(-4.0, -1.0),
                                  float(rng.choice([0.0, 0.3, 2.0])))
        h = np.full(n, height)
        along, turned = _prefixes(a, e, axes, np.array([0]), np.array([n]))
        for _ in range(5):
            first = int(rng.integers(0, n - 1))
            last = int(rng.integers(first + 1, n))
            chord = np.empty(3)
            ref, bound = span_reference(first, last, a, e, axes, h, along, turned, core,
                                        corner, chord)
            bound -= ENTRY_MARGIN_MM
            assert _dilation(first, last, a, e, axes, h, core, corner) <= bound * (1 + 1e-9)
            k = rng.integers(first, last + 1, size=200)
            x = (a[k] + rng.uniform(0.0, 1.0, (200, 1)) * e[k]
                 + rng.normal(0.0, 1.0, (200, 3)) * rng.uniform(0.0, cutter.radius_mm + 0.5,
                                                                   (200, 1)))
            own = sweep_distance(x, a[k], e[k], axes[k], h[k], core_radius_mm=core,
                                 corner_radius_mm=corner)
            far = sweep_distance(x, np.repeat(a[[first]], 200, axis=0),
                                 np.repeat(chord[None, :], 200, axis=0),
                                 np.repeat(axes[[ref]], 200, axis=0), np.full(200, height),
                                 core_radius_mm=core, corner_radius_mm=corner)
            outside = own >= 0.0
            assert np.all(far[outside] - bound <= own[outside] + 1e-12)
            assert np.all(far[~outside] <= bound + 1e-12)


def test_the_runs_are_the_same_in_one_thread_or_two_and_break_at_each_slice(monkeypatch):
    import numba

    import verification.piece_runs as runs_module

    cutter, pieces = _cap_pieces("bull:6:1")
    corner = cutter.corner_radius_mm
    kw = {"core_radius_mm": cutter.radius_mm - corner, "corner_radius_mm": corner}
    whole = piece_runs(pieces, **kw)
    slice_pieces = max(8, pieces.size // 9)
    monkeypatch.setattr(runs_module, "RUN_SLICE_PIECES", slice_pieces)
    threads = numba.get_num_threads()
    try:
        numba.set_num_threads(1)
        one = piece_runs(pieces, **kw)
        numba.set_num_threads(min(2, numba.config.NUMBA_NUM_THREADS))
        two = piece_runs(pieces, **kw)
    finally:
        numba.set_num_threads(threads)
    for name in ("start", "stop", "dilation_mm", "mid", "spread_mm"):
        np.testing.assert_array_equal(getattr(one, name), getattr(two, name), err_msg=name)
    # the runs cover every piece once, none across a slice's end, and they are the
    # unsliced runs up to the first of those that crosses one
    assert one.start[0] == 0 and one.stop[-1] == pieces.size
    np.testing.assert_array_equal(one.start[1:], one.stop[:-1])
    np.testing.assert_array_equal(one.start // slice_pieces, (one.stop - 1) // slice_pieces)
    crossing = np.flatnonzero(whole.start // slice_pieces != (whole.stop - 1) // slice_pieces)
    assert crossing.shape[0] > 0
    np.testing.assert_array_equal(one.start[:crossing[0] + 1], whole.start[:crossing[0] + 1])
    np.testing.assert_array_equal(one.stop[:crossing[0]], whole.stop[:crossing[0]])
    assert one.stop[crossing[0]] < whole.stop[crossing[0]]
