"""Issue 27: the bull-nose fine model built per batch, from the segments that can decide.

:class:`verification.fine_lazy.LazyFineSweeps` answers the fine model's near searches of a
flat or bull-nose cutter from the joint segments whose coarse pieces, widened by the
models' tolerances, may enter a dexel below a value fine pieces already reach; the full
method (:meth:`~verification.fine_model.FineModel.around_each` without it) replays every
segment near the boxes. Both on 5-axis passes over a sphere, the axis turning along them.
"""

import math
from dataclasses import replace

import numpy as np
import pytest
from verify_programs import five_axis_cap

import verification.fine_lazy as fine_lazy
import verification.fine_model as fine_model
from gcode import Linear, Program, Rapid
from machines import load_machine
from toolpath.planning.analytic import SpherePatch
from toolpath.planning.cutters import parse_cutter
from verification.dexels import SweepIndex
from verification.fine_model import FineAsk, FineModel, box_centres
from verification.options import DexelMethod
from verification.pieces import cutter_pieces
from verification.replay import replay
from verification.samples import surface_points_normals
from verification.search import Dexels

SPHERE_MM = 12.0
LEVEL_MM, DEPTH_MM = 0.02, 0.02
COARSE_TOL_MM = 5e-3
LIFT_MM = 4e-3


def _model(lazy: bool | None, full_pieces: int = fine_model.FULL_PIECES, *,
           spring: bool = False):
    machine, bull = load_machine("trunnion-ac"), parse_cutter("bull:6:1")
    radius, corner = bull.radius_mm, bull.corner_radius_mm
    height = max(radius - 2.0 * corner, 0.0)
    reach = math.hypot(radius - corner, height) + corner
    step_deg = math.degrees(0.35 / SPHERE_MM)
    # the passes twice, the second time in more blocks and a micrometre deeper; the coarse
    # model lifts the second copy's pieces by 4 um (within its tolerance of the sweep), so
    # it names the first copy's pieces where the fine model finds the second's lower
    once, again = (five_axis_cap(machine, bull, SPHERE_MM - deeper_mm,
                                 longitude_deg=(-12.0, 12.0),
                                 colatitudes_deg=np.arange(40.0, 50.0, step_deg),
                                 points=points, lead_deg=10.0)
                   for points, deeper_mm in ((25, 0.0), (37, 1e-3)))
    # spring: the same blocks twice, bit-equal values (ties); the coarse model lifts the
    # FIRST copy, so it names the second, and the fine search must name the first again
    program = Program(once.blocks + (once if spring else again).blocks)
    motion = replay(program, machine, chord_tol_mm=5e-4, radius_mm=radius)
    # the coarse model: every chord, one copy's pieces lifted along the axis by nearly the
    # tolerance it declares (how far it may stand from the true sweep)
    coarse = cutter_pieces(motion, corner, height, 0.5, reach_mm=reach, rot_tol_mm=5e-4)
    lifted = LIFT_MM * ((coarse.move < len(once.blocks)) if spring else (
        coarse.move >= len(once.blocks)))[:, None] * coarse.axis
    coarse = replace(coarse, a=coarse.a + lifted, mid=coarse.mid + lifted)
    index = SweepIndex(coarse, coarse.taken(np.zeros(coarse.size, dtype=bool)), radius,
                       np.full(3, -SPHERE_MM), np.full(3, SPHERE_MM), base_cell_mm=0.25,
                       reach_limit_mm=radius + LEVEL_MM + DEPTH_MM, corner_radius_mm=corner)
    ev = Dexels(index, radius, (0.005, LEVEL_MM), DEPTH_MM, DexelMethod.NORMAL,
                corner_radius=corner)
    fine = FineModel(motion, machine, ev,
                     lambda stretch: cutter_pieces(stretch, corner, height, 0.5, reach_mm=reach,
                                                   rot_tol_mm=1e-4),
                     model_tol_mm=COARSE_TOL_MM, chord_tol_mm=1e-4,
                     pieces_per_rad=reach / (2.0 * 1e-4), lazy=lazy, full_pieces=full_pieces)
    sphere = SpherePatch(radius_mm=SPHERE_MM, longitude_deg=(-8.0, 8.0),
                         colatitude_deg=(42.0, 48.0))
    return sphere, ev, fine


def _ask(sphere, ev, middle, half):
    t0, s0 = np.array([middle[0]]), np.array([middle[1]])
    centres, slack = box_centres(sphere, t0, s0, half[0], half[1], ev.corner)
    return FineAsk(centres, slack, np.full(1, 1.0 / SPHERE_MM), LEVEL_MM, DEPTH_MM)


def _searches(sphere, ev, fine, middle, half):
    t0, s0 = np.array([middle[0]]), np.array([middle[1]])
    (model,) = fine.around_each([_ask(sphere, ev, middle, half)])
    off = np.linspace(-1.0, 1.0, 21)
    t = (t0 + half[0] * off[:, None] + 0.0 * off).ravel()
    s = (s0 + half[1] * off[None, :] + 0.0 * off[:, None]).ravel()
    pts, nrm, _ = surface_points_normals(sphere, t, s)
    return model, pts, nrm


BOXES = [((0.5, 0.5), (0.03, 0.05)), ((0.3, 0.7), (0.02, 0.02))]


@pytest.mark.parametrize("spring", [False, True], ids=["deeper copy", "tied copy"])
@pytest.mark.parametrize("middle, half", BOXES)
def test_the_lazy_fine_model_finds_what_the_full_one_finds(middle, half, spring):
    # values and blocks alike: on the tied copy the tie rule's earliest block
    sphere, ev, full_fine = _model(lazy=False, spring=spring)
    _, _, lazy_fine = _model(lazy=True, spring=spring)
    assert lazy_fine.can_build_lazily and not full_fine.can_build_lazily
    full, pts, nrm = _searches(sphere, ev, full_fine, middle, half)
    lazy, _, _ = _searches(sphere, lazy_fine.coarse, lazy_fine, middle, half)
    assert isinstance(lazy.index, fine_lazy.LazyFineSweeps)
    lazy.index.batch = 40  # several batches, each with its own segments
    conv = np.full(pts.shape[0], 1.0 / SPHERE_MM)
    for shift_mm in (0.0, 0.004, -0.003, 0.012):
        p = pts + shift_mm * nrm
        a, b = full.search(p, nrm, conv), lazy.search(p, nrm, conv)
        assert np.isfinite(a.lam_mm).all()
        np.testing.assert_allclose(b.lam_mm, a.lam_mm, rtol=0.0, atol=1e-12)
        np.testing.assert_array_equal(b.move, a.move)
    # the work: fewer segments than the full method replays for the box
    assert 0 < lazy.index.rows_built


def test_the_segments_of_each_lowest_coarse_piece_alone_are_not_enough(monkeypatch):
    """The guard of the shortcut: without the widened coarse pieces entering below ``U_q``
    (step 2) the values differ, so the test above checks it."""
    sphere, ev, full_fine = _model(lazy=False)
    _, _, lazy_fine = _model(lazy=True)
    full, pts, nrm = _searches(sphere, ev, full_fine, *BOXES[0])
    lazy, _, _ = _searches(sphere, lazy_fine.coarse, lazy_fine, *BOXES[0])
    conv = np.full(pts.shape[0], 1.0 / SPHERE_MM)
    monkeypatch.setattr(type(lazy_fine.coarse.index), "pieces_entering_below",
                        lambda self, *args, **kwargs: np.zeros(0, dtype=np.int64))
    differs = False
    for shift_mm in (0.0, 0.004, -0.003, 0.012):
        p = pts + shift_mm * nrm
        a, b = full.search(p, nrm, conv), lazy.search(p, nrm, conv)
        assert (b.lam_mm >= a.lam_mm - 1e-12).all()  # fewer pieces: never lower
        differs |= bool(np.any(b.lam_mm > a.lam_mm + 1e-9))
    assert differs


def test_the_full_method_where_its_model_is_small_the_lazy_one_where_large():
    """``lazy=None``: the full method's pieces counted before it builds them decide."""
    sphere, ev, full_fine = _model(lazy=False)
    full, _, _ = _searches(sphere, ev, full_fine, *BOXES[0])
    built = full.index.pieces("near").size
    ask = _ask(sphere, ev, *BOXES[0])
    rows, _, _ = full_fine.rows_around(ask.centres, ask.slack_mm, ask.convexity_per_mm,
                                       level_mm=LEVEL_MM, depth_mm=DEPTH_MM)
    counted = full_fine.full_pieces(rows)
    # the axis split dominates: the count is within a few pieces per segment of the model
    assert built - 3 * rows.shape[0] <= counted <= built
    assert built > 10 * rows.shape[0]  # the axis turns: many pieces per segment
    for budget, lazy in ((counted - 1, True), (counted, False), (10 * counted, False)):
        _, ev, fine = _model(lazy=None, full_pieces=budget)
        (model,) = fine.around_each([_ask(sphere, ev, *BOXES[0])])
        assert isinstance(model.index, fine_lazy.LazyFineSweeps) is lazy


@pytest.mark.parametrize("layers_most", [fine_lazy.LAYERS_MOST, 1], ids=["layers", "joined"])
@pytest.mark.parametrize("kept_pieces", [fine_lazy.KEPT_PIECES, 1], ids=["kept", "budget 1"])
def test_segments_kept_across_batches_are_replayed_once_and_change_nothing(kept_pieces,
                                                                           layers_most):
    """Every batch searches the segments kept so far: each replayed once, not per batch,
    the same values and blocks as the full method; over the budget (one piece: every
    batch halved down to single dexels, the kept pieces dropped) the same again. Each
    growth a layer searched after the others, or all joined at each batch's start: the
    same values and blocks."""
    sphere, ev, full_fine = _model(lazy=False, spring=True)
    _, _, lazy_fine = _model(lazy=True, spring=True)
    full, pts, nrm = _searches(sphere, ev, full_fine, *BOXES[0])
    lazy, _, _ = _searches(sphere, lazy_fine.coarse, lazy_fine, *BOXES[0])
    sweeps = lazy.index
    assert isinstance(sweeps, fine_lazy.LazyFineSweeps)
    sweeps.batch, sweeps.kept_pieces, sweeps.layers_most = 40, kept_pieces, layers_most
    conv = np.full(pts.shape[0], 1.0 / SPHERE_MM)
    layers = []
    for shift_mm in (0.0, 0.004, -0.003):
        p = pts + shift_mm * nrm
        a, b = full.search(p, nrm, conv), lazy.search(p, nrm, conv)
        np.testing.assert_allclose(b.lam_mm, a.lam_mm, rtol=0.0, atol=1e-12)
        np.testing.assert_array_equal(b.move, a.move)
        layers.append(len(sweeps.layer_sizes))
    if kept_pieces == 1:
        assert sweeps.drops > 0
    else:
        # 11 batches of 40 dexels, levels and shifts: each segment replayed once
        assert sweeps.drops == 0
        assert sweeps.rows_built == sweeps.rows_kept.shape[0]
        # (joined: at most the two growths of the last batch beside the joined layer)
        assert max(layers) > 3 if layers_most > 3 else max(layers) <= 3


def _floor_raster_model(lazy: bool):
    """Two passes 1.5 mm apart, 0.05 mm into the plane z = 0 by a bull-nose (flat bottom
    1 mm in radius), the first one along y = 0; levels 5 um and 0.3 mm."""
    machine, bull = load_machine("grbl-router"), parse_cutter("bull:4:1")
    radius, corner = bull.radius_mm, bull.corner_radius_mm
    height = max(radius - 2.0 * corner, 0.0)
    reach = math.hypot(radius - corner, height) + corner
    blocks = [Rapid(z=5.0), Rapid(x=-6.0, y=0.0), Linear(z=-0.05, feed=300.0)]
    for k, y in enumerate((0.0, 1.5)):
        x = np.linspace(-6.0, 6.0, 4)[:: 1 - 2 * (k % 2)]
        blocks += [Linear(x=float(x[0]), y=y, feed=800.0)]
        blocks += [Linear(x=float(v), feed=800.0) for v in x[1:]]
    motion = replay(Program((*blocks, Rapid(z=5.0))), machine, chord_tol_mm=5e-4,
                    radius_mm=radius)
    coarse = cutter_pieces(motion, corner, height, 0.5, reach_mm=reach, rot_tol_mm=5e-4)
    index = SweepIndex(coarse, coarse.taken(np.zeros(coarse.size, dtype=bool)), radius,
                       np.full(3, -12.0), np.full(3, 12.0), base_cell_mm=0.25,
                       reach_limit_mm=radius + 0.3 + DEPTH_MM, corner_radius_mm=corner)
    ev = Dexels(index, radius, (0.005, 0.3), DEPTH_MM, DexelMethod.NORMAL,
                corner_radius=corner)
    return ev, FineModel(motion, machine, ev,
                         lambda stretch: cutter_pieces(stretch, corner, height, 0.5,
                                                       reach_mm=reach, rot_tol_mm=1e-4),
                         model_tol_mm=COARSE_TOL_MM, chord_tol_mm=1e-4, lazy=lazy)


@pytest.mark.parametrize("layers_most", [fine_lazy.LAYERS_MOST, 1], ids=["layers", "joined"])
@pytest.mark.parametrize("kept_pieces", [fine_lazy.KEPT_PIECES, 1], ids=["kept", "budget 1"])
def test_a_tie_between_two_levels_names_the_full_models_block(kept_pieces, layers_most):
    """Dexels leaning 45 deg under the floor both passes cut (70 um under it): the flat
    bottoms of both enter each one at the same value, bit for bit; the later pass's pieces
    stand near the search centre (the first level finds them), the first pass's farther
    (the second level only). The full model names the first pass's block (the tie rule);
    so must the lazy one, in batches of 40 dexels, and with the kept pieces dropped."""
    x, y = np.meshgrid(np.linspace(-2.0, 2.0, 9), np.linspace(-1.0, 2.5, 41), indexing="ij")
    pts = np.stack([x.ravel(), y.ravel(), np.full(x.size, -0.12)], axis=1)
    nrm = np.tile([0.0, math.sqrt(0.5), math.sqrt(0.5)], (pts.shape[0], 1))
    conv = np.zeros(pts.shape[0])
    found = {}
    for lazy in (False, True):
        ev, fine = _floor_raster_model(lazy)
        ask = FineAsk((pts + ev.corner * nrm)[None], np.zeros(1), np.zeros(1), 0.3, DEPTH_MM)
        (model,) = fine.around_each([ask])
        assert isinstance(model.index, fine_lazy.LazyFineSweeps) is lazy
        if lazy:
            model.index.batch, model.index.kept_pieces = 40, kept_pieces
            model.index.layers_most = layers_most
        found[lazy] = model.search(pts, nrm, conv)
        if lazy and kept_pieces > 1:
            # (the batches' growths searched as layers, one after the other, or joined)
            assert (len(model.index.layer_sizes) > 1) is (layers_most > 1)
        if not lazy:
            first = Dexels(model.index, model.radius, model.horizons[:1], model.depth,
                           model.method, corner_radius=model.corner).search(pts, nrm, conv)
    a, b = found[False], found[True]
    # the case: the first level names another block at the very value the second finds
    tied = (first.lam_mm == a.lam_mm) & (first.move != a.move)
    assert tied.sum() >= 10
    np.testing.assert_array_equal(b.lam_mm, a.lam_mm)
    np.testing.assert_array_equal(b.move, a.move)
    if kept_pieces == 1:
        assert model.index.drops > 0


@pytest.mark.parametrize("lazy", [False, True], ids=["full", "lazy"])
def test_a_guess_that_skips_the_narrower_levels_changes_nothing(lazy, monkeypatch):
    """The near search started at a wider level (``guess_mm``, as the refinement guesses
    from a coarser model or the previous level): the same values and blocks, ties across
    levels included, as the deepening through every level; only the searches differ.

    The floor raster's leaning dexels, from just under the floor (their material within
    the first level: they stop there) to 70 um under it (the tie of two passes the first
    level names wrongly), and the sphere's passes; guesses none, beyond every level,
    random."""
    x, y = np.meshgrid(np.linspace(-2.0, 2.0, 5), np.linspace(-1.0, 2.5, 15), indexing="ij")
    ev, fine = _floor_raster_model(lazy)
    rng = np.random.default_rng(27)
    for z in (-0.052, -0.0533, -0.07, -0.12):
        pts = np.stack([x.ravel(), y.ravel(), np.full(x.size, z)], axis=1)
        nrm = np.tile([0.0, math.sqrt(0.5), math.sqrt(0.5)], (pts.shape[0], 1))
        conv = np.zeros(pts.shape[0])
        ask = FineAsk((pts + ev.corner * nrm)[None], np.zeros(1), np.zeros(1), 0.3, DEPTH_MM)
        (model,) = fine.around_each([ask])
        if lazy:
            model.index.batch = 16
        base = model.search(pts, nrm, conv)
        for guess in (np.full(pts.shape[0], np.inf), rng.uniform(0.0, 0.2, pts.shape[0])):
            got = model.search(pts, nrm, conv, guess_mm=guess)
            np.testing.assert_array_equal(got.lam_mm, base.lam_mm)
            np.testing.assert_array_equal(got.move, base.move)
            np.testing.assert_array_equal(got.piece, base.piece)
    # the sphere's passes, a deeper copy and a tied one
    for spring in (False, True):
        sphere, ev, fine = _model(lazy=lazy, spring=spring)
        model, pts, nrm = _searches(sphere, ev, fine, *BOXES[0])
        conv = np.full(pts.shape[0], 1.0 / SPHERE_MM)
        for shift_mm in (0.0, 0.004, 0.012):
            p = pts + shift_mm * nrm
            base = model.search(p, nrm, conv)
            got = model.search(p, nrm, conv, guess_mm=np.full(p.shape[0], np.inf))
            np.testing.assert_array_equal(got.lam_mm, base.lam_mm)
            np.testing.assert_array_equal(got.move, base.move)
    # the work: straight to the last level, one search of the index for every dexel, a
    # second at the first level for those whose material lies within it
    p = pts - 0.00485 * nrm  # some dexels hold less than the first level, some more
    stops = int(np.sum(model.search(p, nrm, conv).lam_mm <= model.horizons[0]))
    assert 0 < stops < p.shape[0]
    calls: list[int] = []
    index_search = type(model.index).search

    def count(self, which, points, *args, **kwargs):
        calls.append(points.shape[0])
        return index_search(self, which, points, *args, **kwargs)

    monkeypatch.setattr(type(model.index), "search", count)
    model.search(p, nrm, conv, guess_mm=np.full(p.shape[0], np.inf))
    assert calls == [p.shape[0], stops]


def test_the_runs_walk_lists_the_pieces_near_the_boxes_the_pair_search_lists():
    """The segments the fine model may need, found over the coarse runs in compiled code
    (``fine_model._runs_within``): the very pieces of the numpy pair search
    (:meth:`~verification.dexels.SweepIndex.pieces_within`), balls of several radii."""
    sphere, ev, fine = _model(lazy=True)
    ask = _ask(sphere, ev, *BOXES[0])
    _, middles, reach = fine.rows_around(ask.centres, ask.slack_mm, ask.convexity_per_mm,
                                         level_mm=LEVEL_MM, depth_mm=DEPTH_MM)
    rng = np.random.default_rng(27)
    centres = np.concatenate([middles, ask.centres[0][::7]])
    for radius_mm in (0.05, 0.5, float(reach[0]), 3.0 * float(reach[0])):
        radii = radius_mm * rng.uniform(0.5, 1.0, centres.shape[0])
        want = ev.index.pieces_within("near", centres, radii)
        got = fine_model._runs_within(ev.index, centres, radii)
        assert want.shape[0] > 0
        np.testing.assert_array_equal(got, want)


def test_step_two_leaves_out_the_pieces_whose_segments_are_kept(monkeypatch):
    """Step 2 lists coarse pieces for their segments; those whose segments are all kept
    already are not walked (``listed``): never listed, the same values and blocks as the
    full method, in batches of 40 over the kept segments."""
    sphere, ev, full_fine = _model(lazy=False, spring=True)
    _, _, lazy_fine = _model(lazy=True, spring=True)
    full, pts, nrm = _searches(sphere, ev, full_fine, *BOXES[0])
    lazy, _, _ = _searches(sphere, lazy_fine.coarse, lazy_fine, *BOXES[0])
    lazy.index.batch = 40
    calls = []
    below = SweepIndex.pieces_entering_below

    def spy(self, *args, listed=None):
        out = below(self, *args, listed=listed)
        calls.append((listed, out))
        return out

    monkeypatch.setattr(SweepIndex, "pieces_entering_below", spy)
    conv = np.full(pts.shape[0], 1.0 / SPHERE_MM)
    for shift_mm in (0.0, 0.004, -0.003):
        p = pts + shift_mm * nrm
        a, b = full.search(p, nrm, conv), lazy.search(p, nrm, conv)
        np.testing.assert_array_equal(b.lam_mm, a.lam_mm)
        np.testing.assert_array_equal(b.move, a.move)
    given = [(listed, out) for listed, out in calls if listed is not None]
    assert given and max(int(listed[-1]) for listed, _ in given) > 0
    for listed, out in given:
        assert not np.any(listed[out + 1] - listed[out])
