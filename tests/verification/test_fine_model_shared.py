"""Issue 27: the fine model is built once for every refinement of a verification.

:meth:`verification.fine_model.FineModel.around_each` replays the stretches every ask
needs in one batch (a segment two asks share once) and indexes them once, each ask with
its own searches; each ask's searches find what its own fine model (the full method,
:meth:`~verification.fine_model.FineModel.around` of that ask alone) finds. The coarse
index answers which pieces come near with a grid it already built. A grid holds at most
``CELLS_PER_PIECE`` cells per piece, and finds what a grid of the search's own cell finds.
"""

import math

import numpy as np
from verify_programs import DEPTH_MM, LEVEL_MM, convex_dome_model, five_axis_cap, zigzag_raster

import verification.fine_model as fine_model
import verification.grid as grid_module
from machines import load_machine
from toolpath.planning.analytic import PlaneSurface, SpherePatch
from toolpath.planning.cutters import parse_cutter
from verification import VerifyOptions, verify_program
from verification.dexels import SweepIndex
from verification.fine_model import FineAsk, FineModel, box_centres
from verification.grid import CELLS_PER_PIECE
from verification.options import DexelMethod
from verification.pieces import ball_pieces
from verification.replay import replay
from verification.samples import surface_points_normals
from verification.search import Dexels

BOXES = [((0.45, 0.5), (0.04, 0.06)), ((0.5, 0.55), (0.04, 0.06)), ((0.9, 0.1), (0.02, 0.03))]


def _ask(dome, ev, middle, half):
    t0, s0 = np.array([middle[0]]), np.array([middle[1]])
    centres, slack = box_centres(dome, t0, s0, half[0], half[1], ev.corner)
    return FineAsk(centres, slack, np.full(1, 1.0 / 1.5), LEVEL_MM, DEPTH_MM), t0, s0, half


def _points(dome, t0, s0, half):
    off = np.linspace(-1.0, 1.0, 7)
    t = (t0 + half[0] * off[:, None] + 0.0 * off).ravel()
    s = (s0 + half[1] * off[None, :] + 0.0 * off[:, None]).ravel()
    return surface_points_normals(dome, t, s)


def _counting(monkeypatch):
    calls = []
    replay_rows = fine_model.replay_rows

    def counted(*args, **kwargs):
        calls.append(args[2].shape[0])
        return replay_rows(*args, **kwargs)

    monkeypatch.setattr(fine_model, "replay_rows", counted)
    return calls


def test_asks_share_one_replay_and_one_index_and_find_what_each_alone_finds(monkeypatch):
    dome, ev, fine = convex_dome_model()
    asks = [_ask(dome, ev, middle, half) for middle, half in BOXES]
    alone = [fine.around(a.centres, a.slack_mm, a.convexity_per_mm, level_mm=a.level_mm,
                         depth_mm=a.depth_mm) for a, _, _, _ in asks]
    before = set(ev.index._grids)
    calls = _counting(monkeypatch)
    shared = fine.around_each([a for a, _, _, _ in asks])
    assert len(calls) == 1  # one replay of every ask's stretches
    assert set(ev.index._grids) == before  # the coarse grid built above is walked again
    assert all(s is not None for s in shared)
    assert len({id(s.index) for s in shared}) == 1  # one index
    index = shared[0].index
    grid = index._grid("near", 0.3)
    # (a grid's bound is met to within its whole cells on each side)
    assert np.prod(grid.dims) <= 1.25 * CELLS_PER_PIECE * index.ball.size
    for (_, t0, s0, half), one, both in zip(asks, alone, shared, strict=True):
        pts, nrm, _ = _points(dome, t0, s0, half)
        conv = np.full(pts.shape[0], 1.0 / 1.5)
        a, b = one.search(pts, nrm, conv), both.search(pts, nrm, conv)
        assert np.isfinite(a.lam_mm).any()
        np.testing.assert_array_equal(b.lam_mm, a.lam_mm)
        np.testing.assert_array_equal(b.move, a.move)
        assert both.horizons == one.horizons and both.depth == one.depth


def test_an_ask_nothing_comes_near_gets_no_searches():
    dome, ev, fine = convex_dome_model()
    near, _, _, _ = _ask(dome, ev, *BOXES[0])
    far = FineAsk(near.centres + 50.0, near.slack_mm, near.convexity_per_mm, LEVEL_MM,
                  DEPTH_MM)
    shared = fine.around_each([far, near])
    assert shared[0] is None and shared[1] is not None


def test_pieces_within_walks_a_grid_already_built_and_finds_the_same_pieces():
    _, ev, _ = convex_dome_model()
    index = ev.index
    rng = np.random.default_rng(5)
    centres = rng.uniform(-1.5, 1.5, (40, 3))
    radii = rng.uniform(0.05, 0.9, 40)
    own = index.pieces_within("near", centres, radii)  # its own grid, the full method
    assert len(index._grids) == 1
    index._grids.clear()
    index._grid("near", 0.05)  # a fine grid, as the near searches build
    found = index.pieces_within("near", centres, radii)
    assert len(index._grids) == 1
    np.testing.assert_array_equal(found, own)


def test_a_grid_of_few_cells_per_piece_finds_the_same_values(monkeypatch):
    dome, ev, _ = convex_dome_model()
    # a tenth of the pieces over the same box: a grid of the search's cell is mostly empty
    old = ev.index
    sparse = old.ball.taken(np.arange(old.ball.size) % 10 == 0)
    ev.index = SweepIndex(sparse, old.shank, old.radius_mm, old.lo_mm, old.hi_mm,
                          base_cell_mm=old.base_cell_mm, reach_limit_mm=old.reach_limit_mm)
    rng = np.random.default_rng(6)
    points, normals, _ = surface_points_normals(dome, rng.uniform(0, 1, 400),
                                                rng.uniform(0, 1, 400))
    conv = np.full(400, 1.0 / 1.5)
    few = ev.search(points, normals, conv)
    (grid,) = ev.index._grids.values()
    # the full method: a grid of the search's own cell, however many cells it takes
    monkeypatch.setattr(grid_module, "CELLS_PER_PIECE", 10**9)
    ev.index._grids.clear()
    full = ev.search(points, normals, conv)
    (fine_grid,) = ev.index._grids.values()
    assert np.prod(grid.dims) <= 1.25 * CELLS_PER_PIECE * sparse.size < np.prod(fine_grid.dims)
    assert np.isfinite(full.lam_mm).sum() > 100
    np.testing.assert_array_equal(few.lam_mm, full.lam_mm)
    np.testing.assert_array_equal(few.move, full.move)


def test_a_verification_replays_its_refinements_stretches_once(monkeypatch):
    # gouge and scallop both refined with the fine model: one replay, the figures of each
    # ask refined with a fine model of its own
    machine, ball = load_machine("trunnion-ac"), parse_cutter("ball:6")
    step_deg = math.degrees(0.25 / 1.5)
    program = five_axis_cap(machine, ball, 1.5, longitude_deg=(-60.0, 60.0),
                            colatitudes_deg=np.arange(20.0, 80.0, step_deg), points=40)
    dome = SpherePatch(radius_mm=1.5, longitude_deg=(-40.0, 40.0), colatitude_deg=(30.0, 70.0))
    opts = VerifyOptions(spacing_mm=0.02, scallop_mm=0.005, gouge_tol_mm=1e-6)

    def figures():
        rep = verify_program(program, dome, machine, ball, options=opts)
        return [(loc.deviation_mm, loc.point_mm, loc.block_index)
                for loc in (rep.max_gouge, rep.max_excess, rep.max_scallop)]

    monkeypatch.setattr(FineModel, "around_each", lambda self, asks: [
        FINE_AROUND_EACH(self, [a])[0] for a in asks])
    each_alone = figures()
    monkeypatch.undo()
    calls = _counting(monkeypatch)
    shared = figures()
    assert len(calls) == 1
    assert shared == each_alone


FINE_AROUND_EACH = FineModel.around_each


def _same_deviations(one, both, pts, nrm, conv):
    """Shared and alone searches: the same entries, moves and deviations."""
    a, b = one.search(pts, nrm, conv), both.search(pts, nrm, conv)
    np.testing.assert_array_equal(b.lam_mm, a.lam_mm)
    np.testing.assert_array_equal(b.move, a.move)
    np.testing.assert_array_equal(both.deviation(b, nrm), one.deviation(a, nrm))
    return a


def test_an_ask_keeps_its_own_level_and_depth_beside_a_coarser_one():
    """A finer ask beside a coarser one: its own levels, not the largest (the union's)."""
    dome, ev, fine = convex_dome_model()
    (coarse, _, _, _), (finer, t0, s0, half) = (_ask(dome, ev, (0.5, 0.45), (0.02, 0.02)),
                                                _ask(dome, ev, (0.5, 0.55), (0.02, 0.02)))
    finer = FineAsk(finer.centres, finer.slack_mm, finer.convexity_per_mm,
                    0.5 * LEVEL_MM, 0.5 * DEPTH_MM)
    one = fine.around(finer.centres, finer.slack_mm, finer.convexity_per_mm,
                      level_mm=finer.level_mm, depth_mm=finer.depth_mm)
    both = fine.around_each([coarse, finer])[1]
    assert both.horizons == one.horizons and both.depth == one.depth
    pts, nrm, _ = _points(dome, t0, s0, half)
    conv = np.full(pts.shape[0], 1.0 / 1.5)
    for shift_mm in (0.0, -0.015, 0.005):
        _same_deviations(one, both, pts + shift_mm * nrm, nrm, conv)


def test_asks_far_apart_and_in_either_order_find_what_each_alone_finds():
    """Asks at opposite corners of a raster, the later one first: the union's box and rows
    hold both (neither ask's alone)."""
    radius_mm, level_mm, depth_mm = 3.0, 0.02, 0.02
    machine = load_machine("grbl-router")
    plane = PlaneSurface(origin_mm=(0.0, 0.0, 0.0), t_vector_mm=(40.0, 0.0, 0.0),
                         s_vector_mm=(0.0, 30.0, 0.0))
    program = zigzag_raster(np.arange(0.0, 30.01, 0.5), -5.0, 45.0, shift={20: -0.01})
    motion = replay(program, machine, chord_tol_mm=5e-4, radius_mm=radius_mm)
    coarse = ball_pieces(motion, radius_mm, 0.5, merge_tol_mm=1e-3)
    index = SweepIndex(coarse, coarse.taken(np.zeros(coarse.size, dtype=bool)), radius_mm,
                       np.zeros(3), np.array([40.0, 30.0, 0.0]), base_cell_mm=0.25,
                       reach_limit_mm=radius_mm + level_mm + depth_mm)
    ev = Dexels(index, radius_mm, (level_mm,), depth_mm, DexelMethod.NORMAL)
    fine = FineModel(motion, machine, ev, lambda stretch: ball_pieces(stretch, radius_mm, 0.5),
                     model_tol_mm=1.5e-3, chord_tol_mm=1e-5)

    def ask(middle):
        centres, slack = box_centres(plane, np.array([middle[0]]), np.array([middle[1]]),
                                     0.01, 0.01, ev.corner)
        return FineAsk(centres, slack, np.zeros(1), level_mm, depth_mm)

    off = np.linspace(-1.0, 1.0, 9)
    for first, second in (((0.9, 0.9), (0.1, 0.1)), ((0.1, 0.1), (0.9, 0.9))):
        asks = [ask(first), ask(second)]
        shared = fine.around_each(asks)
        for middle, a, both in zip((first, second), asks, shared, strict=True):
            one = fine.around(a.centres, a.slack_mm, a.convexity_per_mm, level_mm=level_mm,
                              depth_mm=depth_mm)
            t = np.repeat(middle[0] + 0.01 * off, 9)
            s = np.tile(middle[1] + 0.01 * off, 9)
            pts, nrm, _ = surface_points_normals(plane, t, s)
            found = _same_deviations(one, both, pts, nrm, np.zeros(pts.shape[0]))
            assert np.isfinite(found.lam_mm).all()
