"""One tie rule: of equal values on a dexel, the piece first in program order gives the block.

Programs where many pieces leave exactly the same material on a dexel (a raster cut 0.05 mm
into a floor by a flat end mill, a bull-nose or a ball; passes split into many blocks; a
5-axis raster with a leaned axis) are verified with every search: the compiled walks, the
pair search (the reference), other grids, other levels of the iterative deepening, the fine
model built for each ask rather than shared. Every one must trace each dexel to the same
block as the pair search, and so give the same gouging blocks with the same areas and the
extremes at the same blocks.
"""

import numpy as np
import pytest
from verify_programs import tilted_raster

import verification.fine_lazy as fine_lazy
import verification.verify as verify_module
from gcode import Linear, Program, Rapid
from machines import load_machine
from toolpath.planning.analytic import PlaneSurface
from toolpath.planning.cutters import parse_cutter
from verification import VerifyOptions, verify_program
from verification.dexels import DexelResult, SweepIndex, ranks_before_rows
from verification.extremes import _local_extremes
from verification.fine_model import FineModel
from verification.options import DexelMethod
from verification.pieces import Pieces
from verification.search import Dexels, scatter

DEPTH_MM = 0.05


def _split_raster(y_levels, x0, x1, *, blocks_per_pass, depth_mm=DEPTH_MM):
    """A 3-axis zigzag ``depth_mm`` into the plane z = 0, each pass in equal blocks."""
    blocks = [Rapid(z=5.0), Rapid(x=x0, y=float(y_levels[0])), Linear(z=-depth_mm, feed=300.0)]
    for k, y in enumerate(y_levels):
        x = np.linspace(x0, x1, blocks_per_pass + 1)
        if k % 2:
            x = x[::-1]
        blocks.append(Linear(x=float(x[0]), y=float(y), feed=800.0))
        blocks += [Linear(x=float(v), feed=800.0) for v in x[1:]]
    blocks.append(Rapid(z=5.0))
    return Program(tuple(blocks))


def _index_with(m, *, cell_scale=1.0, **changes):
    """``verify_module.SweepIndex`` replaced by one built with ``changes``, its grid's base
    cell times ``cell_scale``."""

    def build(*args, base_cell_mm, **kw):
        return SweepIndex(*args, base_cell_mm=base_cell_mm * cell_scale, **kw, **changes)

    m.setattr(verify_module, "SweepIndex", build)


def _fine_model_per_ask(m):
    """The fine model built for each ask alone, not one index shared by the asks."""
    shared = FineModel.around_each
    m.setattr(FineModel, "around_each",
              lambda self, asks: [shared(self, [ask])[0] for ask in asks])


def _lazy_fine_model(m):
    """A flat or bull-nose cutter's fine searches answered per batch of 64 dexels from the
    segments that decide them (:mod:`verification.fine_lazy`), whatever the model's size."""
    m.setattr(FineModel, "builds_lazily", lambda self, rows: self.can_build_lazily)
    m.setattr(fine_lazy, "FINE_BATCH", 64)


def _every_search(monkeypatch, program, surface, machine, cutter, options):
    """The report of each search: the pair search first (the reference)."""
    other_levels = VerifyOptions(**{**options.__dict__, "first_level_mm": 0.003})
    variants = {
        "pair search": (lambda m: _index_with(m, compiled=False), options),
        "compiled walk": (lambda m: None, options),
        "coarser grid": (lambda m: _index_with(m, cell_scale=4.0), options),
        "finer grid": (lambda m: _index_with(m, cell_scale=0.5), options),
        "other levels": (lambda m: None, other_levels),
        "fine model per ask": (_fine_model_per_ask, options),
        "lazy fine model": (_lazy_fine_model, options),
    }
    runs = {}
    for name, (setup, opts) in variants.items():
        with monkeypatch.context() as m:
            setup(m)
            runs[name] = verify_program(program, surface, machine, cutter, options=opts)
    return runs


def _assert_same_blocks(runs):
    ref = runs["pair search"]
    assert ref.max_gouge is not None  # the floor is gouged: a tie-heavy program
    for name, rep in runs.items():
        a, b = rep.deviation_map, ref.deviation_map
        np.testing.assert_allclose(a.deviation_mm, b.deviation_mm, rtol=0.0, atol=1e-9,
                                   err_msg=name)
        differ = int((a.block_index != b.block_index).sum())
        assert differ == 0, f"{name}: {differ} dexels traced to another block"
        assert ([(g.block_index, g.area_mm2, g.depth_mm) for g in rep.gouging_blocks]
                == [(g.block_index, g.area_mm2, g.depth_mm) for g in ref.gouging_blocks]), name
        # deepest first, of equally deep blocks the earlier first
        keys = [(-g.depth_mm, g.block_index) for g in rep.gouging_blocks]
        assert keys == sorted(keys), name
        for f, e in ((rep.max_gouge, ref.max_gouge), (rep.max_scallop, ref.max_scallop)):
            assert (f is None) == (e is None), name
            if f is not None:
                assert (f.block_index, f.shank) == (e.block_index, e.shank), name


@pytest.mark.parametrize("spec", ["flat:6", "bull:6:1", "ball:6"])
def test_a_raster_into_a_floor_gives_every_search_the_same_blocks(monkeypatch, router, spec):
    # passes 4 mm apart, each in 6 blocks, the last one run again (a spring pass): a flat
    # bottom overlaps the next pass's, consecutive blocks of a pass share their ends
    program = _split_raster(np.r_[np.arange(4) * 4.0, 12.0], -6.0, 14.0, blocks_per_pass=6)
    plane = PlaneSurface((0.0, -1.0, 0.0), (8.0, 0.0, 0.0), (0.0, 12.0, 0.0))
    runs = _every_search(monkeypatch, program, plane, router, parse_cutter(spec),
                         VerifyOptions(spacing_mm=0.1, refine=4))
    _assert_same_blocks(runs)


@pytest.mark.parametrize("spec", ["flat:6", "bull:6:1", "ball:6"])
def test_a_five_axis_raster_into_a_floor_gives_every_search_the_same_blocks(monkeypatch,
                                                                          spec):
    machine = load_machine("trunnion-ac")
    cutter = parse_cutter(spec)
    # the last pass run again (a spring pass)
    program = tilted_raster(machine, cutter, np.r_[np.arange(3) * 3.0, 6.0], -4.0, 12.0,
                            blocks_per_pass=8, depth_mm=DEPTH_MM)
    plane = PlaneSurface((0.0, -1.0, 0.0), (8.0, 0.0, 0.0), (0.0, 8.0, 0.0))
    runs = _every_search(monkeypatch, program, plane, machine, cutter,
                         VerifyOptions(spacing_mm=0.15, refine=4))
    _assert_same_blocks(runs)


def test_equally_deep_samples_refine_from_the_earliest():
    # every sample of a floor is equally deep: the starts are the first k in index order
    dev = np.full((99, 99), -0.05)
    dev[0, 5] = -0.06  # one deeper, first; then the earliest of the rest
    starts = _local_extremes(dev, np.ones(dev.shape, bool), False, 0.0, 4)
    assert starts.tolist() == [5, 0, 1, 2]
    assert _local_extremes(np.full((99, 99), 0.02), np.ones((99, 99), bool), True, 0.0,
                           4).tolist() == [0, 1, 2, 3]


def test_the_deepest_gouge_of_a_floor_is_at_the_earliest_gouging_block(router):
    # a flat raster 0.05 mm into a floor: every sample equally deep, so the deepest gouge
    # is the earliest of the tied blocks (the first listed: equally deep in block order)
    program = _split_raster(np.r_[np.arange(4) * 4.0, 12.0], -6.0, 14.0, blocks_per_pass=6)
    plane = PlaneSurface((0.0, -1.0, 0.0), (8.0, 0.0, 0.0), (0.0, 12.0, 0.0))
    rep = verify_program(program, plane, router, parse_cutter("flat:6"),
                         options=VerifyOptions(spacing_mm=0.1, refine=4))
    depths = {g.depth_mm for g in rep.gouging_blocks}
    assert len(depths) == 1  # tied
    assert rep.max_gouge.block_index == rep.gouging_blocks[0].block_index == 4


def _rows(lam_mm, move, piece):
    n = len(lam_mm)
    return DexelResult(np.array(lam_mm, float), np.array(move), np.zeros(n, bool),
                       np.zeros(n, bool), 0, np.array(piece))


def test_merges_of_rows_follow_the_tie_rule():
    # equal values: piece 3 before piece 5 (either side); an unknown piece (-1) wins no
    # tie and loses none it holds; a lower value always wins
    best = _rows([1.0, 1.0, 1.0, 1.0, 1.0], [10] * 5, [5, 3, -1, 5, 5])
    new = _rows([1.0, 1.0, 1.0, 0.5, 1.0], [20] * 5, [3, 5, 3, -1, -1])
    first = [True, False, False, True, False]
    assert ranks_before_rows(new.lam_mm, new.piece, best.lam_mm, best.piece).tolist() == first
    merged = best.merged(new)
    assert merged.move.tolist() == [20, 10, 10, 20, 10]
    assert merged.piece.tolist() == [3, 3, -1, -1, 5]
    out = _rows([9.0, 1.0, 1.0, 1.0, 1.0, 1.0], [0] + [10] * 5, [0, 5, 3, -1, 5, 5])
    scatter(out, np.arange(1, 6), new, merge=True)
    assert out.move.tolist() == [0, 20, 10, 10, 20, 10]
    assert out.piece.tolist() == [0, 3, 3, -1, -1, 5]


def _searches_of(monkeypatch, program, surface, machine, cutter, options):
    """The :class:`~verification.search.Dexels` and samples ``verify_program`` searched."""
    seen = {}
    grid_search = verify_module.grid_search

    def spy(ev, samples, stride, **kwargs):
        seen.update(ev=ev, samples=samples)
        return grid_search(ev, samples, stride, **kwargs)

    with monkeypatch.context() as m:
        m.setattr(verify_module, "grid_search", spy)
        verify_program(program, surface, machine, cutter, options=options)
    return seen["ev"], seen["samples"]


def test_the_collision_search_below_a_piece_finds_an_equal_earlier_piece(monkeypatch,
                                                                        router):
    # a ball raster 0.05 mm into a floor, its last pass run again: the near search's piece
    # on each dexel; the collision search below (value, a later piece) finds that piece
    # again (equal, earlier), below (value, that piece) nothing
    program = _split_raster(np.r_[np.arange(4) * 4.0, 12.0], -6.0, 14.0, blocks_per_pass=6)
    plane = PlaneSurface((0.0, -1.0, 0.0), (8.0, 0.0, 0.0), (0.0, 12.0, 0.0))
    ev, samples = _searches_of(monkeypatch, program, plane, router, parse_cutter("ball:6"),
                               VerifyOptions(spacing_mm=0.4, refine=0))
    pts, nrm = samples.points.reshape(-1, 3), samples.normals.reshape(-1, 3)
    conv = samples.convexity_per_mm.ravel()
    near = ev.search(pts, nrm, conv)
    hit = np.isfinite(near.lam_mm)
    assert hit.mean() > 0.5 and (near.piece[hit] >= 0).all()
    later = np.where(hit, near.piece + 1, -1)
    far = ev.search(pts, nrm, conv, near=False, far=True, below_mm=near.lam_mm,
                    below_piece=later)
    np.testing.assert_array_equal(far.lam_mm[hit], near.lam_mm[hit])
    np.testing.assert_array_equal(far.piece[hit], near.piece[hit])
    np.testing.assert_array_equal(far.move[hit], near.move[hit])
    same = ev.search(pts, nrm, conv, near=False, far=True, below_mm=near.lam_mm,
                     below_piece=near.piece)
    assert not np.isfinite(same.lam_mm[hit]).any()


def _pass_line(spans_x, z_mm):
    """Ball pieces along the line y = 0 at height ``z_mm``, one per ``(x0, x1)``, in order."""
    a = np.array([[x0, 0.0, z_mm] for x0, _ in spans_x])
    e = np.array([[x1 - x0, 0.0, 0.0] for x0, x1 in spans_x])
    ee = np.einsum("ij,ij->i", e, e)
    n = a.shape[0]
    arc0 = np.r_[0.0, np.cumsum(np.sqrt(ee))[:-1]]
    arc1 = arc0 + np.sqrt(ee)
    ball = Pieces(a, e, ee, a + 0.5 * e, 0.5 * np.sqrt(ee), np.arange(n), np.zeros(n, bool),
                  np.tile([0.0, 0.0, 1.0], (n, 1)), arc0, arc1, np.r_[arc0, arc1[-1]],
                  np.r_[np.arange(n), n - 1], np.zeros(n))
    return ball, ball.taken(np.zeros(n, bool))


@pytest.mark.parametrize("spans_x, lower_by_rounding", [
    # the walk meets the later piece 3 first and must still measure piece 1, bit-equal
    ([(-5.0, -2.0), (-2.0, 1.0), (-5.0, 0.0), (0.0, 1.0)], False),
    # splits swapped: on a few dexels piece 3 is a rounding step (4e-16 mm) lower than
    # piece 1, whose value the walk meets first (seeded by the previous dexel) and whose
    # bound for piece 3 rounds above that value: piece 3 must still be measured
    ([(-5.0, 0.0), (0.0, 1.0), (-5.0, -2.0), (-2.0, 1.0)], True),
])
def test_the_capsule_walk_finds_a_piece_whose_bound_rounds_above_its_value(
        spans_x, lower_by_rounding):
    # a ball pass and a spring pass split elsewhere: past x = 1 pieces 1 and 3 leave equal
    # values (to rounding) on vertical dexels, their end spheres being one; the walk must
    # name the piece the pair search (which measures all) names
    radius = 3.0
    ball, shank = _pass_line(spans_x, radius - DEPTH_MM)
    q = 4000
    x = 1.0 + np.random.default_rng(0).uniform(0.0, 0.05, q)
    points = np.c_[x, np.zeros(q), np.zeros(q)]
    dirs = np.tile([0.0, 0.0, 1.0], (q, 1))
    found = {}
    for compiled in (False, True):
        index = SweepIndex(ball, shank, radius, np.full(3, -10.0), np.full(3, 10.0),
                           base_cell_mm=1.0, reach_limit_mm=20.0, compiled=compiled)
        found[compiled] = index.search("near", points, dirs, points + radius * dirs,
                                       np.full(q, 2.0))
    tied = found[False].piece == 1
    assert tied.sum() > q // 2  # ties (or piece 1 lower): the pair search names piece 1
    if lower_by_rounding:
        assert (found[False].piece == 3).any()
    np.testing.assert_array_equal(found[True].lam_mm, found[False].lam_mm)
    np.testing.assert_array_equal(found[True].piece, found[False].piece)


def test_a_wider_level_finds_an_equal_earlier_piece_the_first_one_missed():
    # two ball pieces ending at (1, 0, 3.25): piece 0 long (from x = -7), piece 1 short
    # (from x = 0.5); a vertical dexel at x = 2 meets both on their common end sphere,
    # bit-equal (3.25 - sqrt(8): every sum exact). The first level's ball holds only the
    # short piece's midpoint, the second both: the levels' merge must give piece 0
    radius = 3.0
    ball, shank = _pass_line([(-7.0, 1.0), (0.5, 1.0)], radius + 0.25)
    index = SweepIndex(ball, shank, radius, np.full(3, -10.0), np.full(3, 10.0),
                       base_cell_mm=1.0, reach_limit_mm=20.0)
    ev = Dexels(index, radius, (0.01, 0.5), 0.1, DexelMethod.NORMAL)
    point, normal = np.array([[2.0, 0.0, 0.0]]), np.array([[0.0, 0.0, 1.0]])
    first = index.search("near", point, normal, point + radius * normal,
                         ev.near_radius_mm(0.01, 0.1, np.zeros(1)))
    assert first.piece.tolist() == [1]  # only the short piece in the first level
    res = ev.search(point, normal, np.zeros(1))
    assert res.lam_mm[0] == first.lam_mm[0] == 3.25 - np.sqrt(8.0)
    assert res.piece.tolist() == [0]
