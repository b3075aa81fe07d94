"""A run's floor (:func:`verification.piece_runs.run_floor`): below every piece, and tight.

The compiled walks drop a run or a half of one whose floor is not below the best value so
far (:mod:`verification.sweep_search`) or a dexel's bound (:mod:`verification.sweep_below`).
The floor takes, besides the dilated reference's entry, the pieces' own support planes at
the dilated reference's normal (:func:`~verification.piece_runs.support_floor`); that must
never stand above what any piece of the run leaves: checked against every piece's exact
entry (``sweep_interval``) over random runs (the axis turning slowly or fast, the path
straight or bending), for dexels from below, nearly along a flat bottom, from behind
(``a . d < BEHIND_COSINE``) and anywhere, with random normals too and the pieces widened
as the fine model's walk widens them. And it must prune: on 5-axis passes with a leading,
turning bull-nose the walk measures a fraction of the halves and pieces the dilated floor
alone opened, with the same values as the pair search. The planes taken block by block
(:func:`~verification.piece_runs.blocked_support_floor`, one plane for a block's pieces
where it does not lie below the best) give the walks the very decisions of the pass over
every piece, and their planes stand within a fraction of a micrometre of the pieces'.
"""

import numpy as np
import pytest
from verify_programs import five_axis_cap

from machines import load_machine
from toolpath.planning.analytic import SpherePatch
from toolpath.planning.cutters import parse_cutter
from verification import VerifyOptions
from verification.capsule_search import pair_values
from verification.dexels import BEHIND_COSINE, SweepIndex
from verification.piece_runs import (
    blocked_support_floor,
    floor_entry,
    piece_runs,
    run_floor,
    span_reference,
    support_floor,
)
from verification.pieces import Pieces
from verification.replay import replay
from verification.torus import line_sweep_interval, sweep_bound
from verification.verify import _pieces, _settings


def _unit(v):
    return v / np.linalg.norm(v, axis=-1, keepdims=True)


def _pieces_turning(rng, n, *, turn_per_mm, bend, height_mm):
    """``n`` short pieces end to end (small gaps now and then) whose axis turns up to
    ``turn_per_mm`` rad/mm about a drifting direction, the path bending by ``bend``."""
    step_mm = 10 ** rng.uniform(-3.0, -1.5)
    axis = _unit(rng.normal(size=3) * 0.3 + [0.0, 0.0, 1.0])
    heading = _unit(np.cross(axis, rng.normal(size=3)))
    side = _unit(np.cross(axis, heading))
    a, e, axes = np.zeros((n, 3)), np.zeros((n, 3)), np.zeros((n, 3))
    p = rng.uniform(-5.0, 5.0, 3)
    for k in range(n):
        a[k], axes[k] = p, axis
        e[k] = heading * step_mm * rng.uniform(0.2, 1.5)
        p = a[k] + e[k] + rng.normal(size=3) * step_mm * 0.2 * (rng.random() < 0.1)
        heading = _unit(heading + bend * rng.normal(size=3))
        angle = turn_per_mm * step_mm * rng.uniform(0.0, 2.0)
        side = _unit(side + rng.normal(size=3) * 0.3)
        axis = _unit(axis + angle * _unit(np.cross(axis, side)))
    ee = np.einsum("ij,ij->i", e, e)
    return Pieces(a, e, ee, a + 0.5 * e, 0.5 * np.sqrt(ee), np.arange(n, dtype=np.int64),
                  np.zeros(n, dtype=bool), axes, np.full(n, np.nan), np.full(n, np.nan),
                  np.zeros(1), np.zeros(1, dtype=np.int64), np.full(n, height_mm))


def _dexels(rng, pieces, first, stop, m, radius_mm, corner_mm, height_mm):
    """``m`` dexels about pieces ``first..stop-1``: a quarter from below (within 30 deg of
    the axis), a quarter within 1e-11..1e-3 rad of the flat bottom's plane, a quarter
    from behind, a quarter anywhere."""
    k = rng.integers(first, stop, m)
    axis = pieces.axis[k]
    across = _unit(np.cross(axis, rng.normal(size=(m, 3))))
    centre = pieces.a[k] + rng.uniform(0.0, 1.0, (m, 1)) * pieces.e[k]
    kind = np.arange(m) % 4
    out = rng.uniform(0.0, radius_mm + 0.3, (m, 1))
    up = np.where(kind == 1, -corner_mm + rng.normal(0.0, 0.01, m),
                  rng.uniform(-corner_mm - 0.5, height_mm + corner_mm + 0.5, m))
    points = centre + across * out + axis * up[:, None]
    tilt = rng.uniform(0.0, 0.5, (m, 1)) * _unit(np.cross(axis, rng.normal(size=(m, 3))))
    dirs = np.where((kind == 0)[:, None], axis + tilt, rng.normal(size=(m, 3)))
    flat = kind == 1
    sign = np.where(rng.random(flat.sum()) < 0.5, -1.0, 1.0)
    off = sign * 10 ** rng.uniform(-11.0, -3.0, flat.sum())
    dirs[flat] = across[flat] + off[:, None] * axis[flat]
    behind = kind == 2
    dirs[behind] = -axis[behind] + 0.4 * tilt[behind]
    return points, _unit(dirs)


def _least_values(points, dirs, pieces, first, stop, radius_mm, corner_mm, widen_mm):
    """Per dexel the least entry and least value (``pair_value``) over pieces
    ``first..stop-1``, each widened by ``widen_mm``: the pair search's measure."""
    m, n = points.shape[0], stop - first
    rows = np.repeat(np.arange(m), n)
    k = np.tile(np.arange(first, stop), m)
    cosine = np.einsum("ij,ij->i", dirs[rows], pieces.axis[k])
    lam_in, lam_out = line_sweep_interval(
        points[rows], dirs[rows], pieces.a[k], pieces.e[k], pieces.axis[k],
        pieces.height_mm[k], core_radius_mm=radius_mm - corner_mm,
        corner_radius_mm=corner_mm + widen_mm, exit_wanted=cosine < BEHIND_COSINE)
    value, _ = pair_values(lam_in, lam_out, cosine, BEHIND_COSINE)
    return lam_in.reshape(m, n).min(axis=1), value.reshape(m, n).min(axis=1)


SPECS = [("bull:6:1", 1.0), ("bull:6:1", 16.0), ("flat:6", 4.0), ("bull:8:2", 0.0)]


@pytest.mark.parametrize(("spec", "height_mm"), SPECS)
def test_a_runs_floor_never_exceeds_what_its_pieces_leave(rng, spec, height_mm):
    cutter = parse_cutter(spec)
    radius, corner = cutter.radius_mm, cutter.corner_radius_mm
    core = radius - corner
    checked = below_entry = 0
    gaps = []
    for turn_per_mm in (0.1, 5.0, 60.0):
        pieces = _pieces_turning(rng, 300, turn_per_mm=turn_per_mm,
                                 bend=float(rng.choice([0.0, 0.05, 0.5])), height_mm=height_mm)
        runs = piece_runs(pieces, core_radius_mm=core, corner_radius_mm=corner)
        for run in rng.choice(np.flatnonzero(runs.stop - runs.start > 1), 6):
            first, stop = int(runs.start[run]), int(runs.stop[run])
            # the run, and a half of it as the walk halves it (its constant-time dilation)
            half_stop = (first + stop) // 2 if stop - first > 2 else stop
            chord = np.empty(3)
            ref, grow = span_reference(first, half_stop - 1, pieces.a, pieces.e, pieces.axis,
                                       pieces.height_mm, runs.along_mm, runs.turned, core,
                                       corner, chord)
            spans = ((first, stop, runs.c0[run], runs.chord[run], runs.axis[run],
                      runs.dilation_mm[run]),
                     (first, half_stop, pieces.a[first], chord.copy(), pieces.axis[ref], grow))
            for lo_k, hi_k, c0, d_chord, ref_axis, dilation in spans:
                points, dirs = _dexels(rng, pieces, lo_k, hi_k, 200, radius, corner, height_mm)
                for widen in (0.0, 0.004):
                    entry, value = _least_values(points, dirs, pieces, lo_k, hi_k, radius,
                                                 corner, widen)
                    for q in range(points.shape[0]):
                        lo, hi = sweep_bound(points[q], dirs[q], c0, d_chord, ref_axis,
                                             height_mm, core, corner + widen + dilation)
                        for best in (np.inf, entry[q] + 1e-4, entry[q] - 0.01):
                            floor = run_floor(points[q], dirs[q], c0, d_chord, ref_axis,
                                              height_mm, core, corner + widen, dilation, lo,
                                              hi, best, lo_k, hi_k, pieces.a, pieces.e,
                                              pieces.axis, pieces.height_mm, runs.block_of,
                                              runs.block_span, runs.block_slack)
                            assert floor <= value[q], (floor, value[q], q)
                            if np.isfinite(entry[q]) and np.isfinite(value[q]):
                                assert floor <= entry[q]
                                checked += 1
                                below_entry += floor < entry[q]
                                if best == np.inf:
                                    dilated = floor_entry(points[q], dirs[q], c0, d_chord,
                                                          ref_axis, height_mm, core,
                                                          corner + widen + dilation, lo, hi,
                                                          best)
                                    gaps.append((entry[q] - floor, entry[q] - dilated))
                        # any normal: the planes hold for every one
                        nu = _unit(rng.normal(size=3))
                        plane = support_floor(points[q], dirs[q], *nu, lo_k, hi_k, pieces.a,
                                              pieces.e, pieces.axis, pieces.height_mm, core,
                                              corner + widen)
                        assert plane <= entry[q]
    assert checked > 3000
    assert below_entry == checked  # the entry margin: strictly below
    # and tighter than the dilated reference's entry alone: medians 0.9-4.4 um against
    # 22-30 um on these runs
    gaps = np.array(gaps)
    assert np.median(gaps[:, 0]) < 0.25 * np.median(gaps[:, 1])


def test_turning_bull_nose_passes_open_few_halves_with_the_pair_searchs_values(monkeypatch):
    # 5-axis passes over a sphere, the bull-nose leaning 10 deg along them: pieces cut
    # short by the turning axis gather in runs whose dilated references stand tens of um
    # off; the support planes bound them within a micrometre, so the walk halves few runs
    machine = load_machine("trunnion-ac")
    cutter = parse_cutter("bull:6:1")
    sphere = SpherePatch(radius_mm=20.0, colatitude_deg=(21.0, 31.0),
                         longitude_deg=(-15.0, 15.0))
    program = five_axis_cap(machine, cutter, 20.0, colatitudes_deg=(20.0, 23.0, 26.0, 29.0, 32.0),
                            longitude_deg=(-20.0, 20.0), points=40, lead_deg=10.0)
    opts = VerifyOptions()
    _, cfg = _settings(sphere, cutter, opts)
    motion = replay(program, machine, chord_tol_mm=opts.replay_tol_mm,
                    radius_mm=cutter.radius_mm)
    pieces, _ = _pieces(motion, cutter, cfg, opts, shank=False)
    corner = cutter.corner_radius_mm
    rng = np.random.default_rng(5)
    theta = np.radians(rng.uniform(21.0, 31.0, 3000))
    phi = np.radians(rng.uniform(-15.0, 15.0, 3000))
    normal = np.column_stack([np.sin(theta) * np.cos(phi), np.sin(theta) * np.sin(phi),
                              np.cos(theta)])
    points = 20.0 * normal
    reach = np.full(3000, 3.5)
    found = {}
    for compiled in (True, False):
        none = pieces.taken(np.zeros(pieces.size, dtype=bool))
        index = SweepIndex(pieces, none, cutter.radius_mm, points.min(0), points.max(0), 0.5,
                           20.0, corner_radius_mm=corner, compiled=compiled)
        found[compiled] = index.search("near", points, normal, points + corner * normal,
                                       reach)
    fast, exact = found[True], found[False]
    assert np.isfinite(exact.lam_mm).mean() > 0.9
    assert np.array_equal(fast.lam_mm, exact.lam_mm)
    assert np.array_equal(fast.piece, exact.piece)
    # runs and halves floored and pieces measured per dexel (the pair search measures
    # 4,581): 75.3 with the dilated floors alone (before the support planes), 29.4 with them
    assert fast.pairs / points.shape[0] < 45.0


def _rotated(u, w, angle):
    """Unit ``u`` turned by ``angle`` about unit ``w`` (perpendicular to it)."""
    return _unit(u * np.cos(angle) + np.cross(w, u) * np.sin(angle))


@pytest.mark.parametrize("core_mm", [25.0, 100.0])
def test_a_large_flat_bottoms_floor_keeps_axes_1e8_rad_apart(rng, core_mm):
    """The review's case: a flat cutter of large radius (flat:50, flat:200) whose pieces'
    axes differ by ~1.5e-8 rad (a long move turning a rotary axis by 0.001 deg), a dexel
    up the axis under the dipping rim. There ``1 - c^2`` rounds to 0 and the support
    plane lost ``core * 1.5e-8`` (0.4-1.5 um, past the 0.1 um margin): the floor stood
    above a piece's entry in 146-220 of 400 dexels."""
    height_mm, above = 10.0, 0
    for _ in range(300):
        u0 = _unit(rng.normal(size=3))
        w = _unit(np.cross(u0, rng.normal(size=3)))
        theta = 1.5e-8
        axes = np.array([_rotated(u0, w, theta * rng.uniform(0.3, 1.0)), u0,
                         _rotated(u0, -w, theta * rng.uniform(0.3, 1.0))])
        head = _unit(np.cross(u0, rng.normal(size=3)))
        a = np.arange(3)[:, None] * 1e-3 * head + rng.uniform(-5.0, 5.0, 3)
        e = np.tile(1e-3 * head, (3, 1))
        ee = np.einsum("ij,ij->i", e, e)
        pieces = Pieces(a, e, ee, a + 0.5 * e, 0.5 * np.sqrt(ee), np.arange(3),
                        np.zeros(3, dtype=bool), axes, np.full(3, np.nan), np.full(3, np.nan),
                        np.zeros(1), np.zeros(1, dtype=np.int64), np.full(3, height_mm))
        runs = piece_runs(pieces, core_radius_mm=core_mm, corner_radius_mm=0.0)
        assert runs.size == 1
        rim = _unit(np.cross(w, u0))
        rim = -rim * np.sign(np.dot(axes[0] - u0, rim))  # where piece 0's bottom dips
        p = a[0] + (core_mm - 1e-6) * rim * rng.choice([1.0, -1.0]) - 3.0 * u0
        d = u0.copy()
        lo, hi = sweep_bound(p, d, runs.c0[0], runs.chord[0], runs.axis[0], height_mm, core_mm,
                             runs.dilation_mm[0])
        floor = run_floor(p, d, runs.c0[0], runs.chord[0], runs.axis[0], height_mm, core_mm,
                          0.0, runs.dilation_mm[0], lo, hi, np.inf, 0, 3, pieces.a, pieces.e,
                          pieces.axis, pieces.height_mm, runs.block_of, runs.block_span,
                          runs.block_slack)
        _, least = _least_values(p[None], d[None], pieces, 0, 3, core_mm, 0.0, 0.0)
        above += bool(floor > least[0])
    assert above == 0


@pytest.mark.parametrize(("block", "height_mm"), [(4, 1.0), (16, 16.0), (128, 1.0)])
def test_block_planes_take_the_pass_over_every_pieces_decisions(rng, block, height_mm):
    # the shortcut against the full pass (support_floor), on paths bending and jumping,
    # axes turning fast and slowly: below a limit the same value (bit for bit), at or
    # above it wherever the pass is; each block's plane alone (a limit of -inf opens
    # none) a lower bound on its pieces'
    core, corner = 3.0, 1.0
    decided = checked = 0
    for turn_per_mm, bend in ((0.1, 0.0), (5.0, 0.05), (60.0, 0.5), (5.0, 0.0)):
        pieces = _pieces_turning(rng, 400, turn_per_mm=turn_per_mm, bend=bend,
                                 height_mm=height_mm)
        runs = piece_runs(pieces, core_radius_mm=core, corner_radius_mm=corner,
                          block_pieces=block)
        spans = runs.block_span
        assert spans[0, 0] == 0 and spans[-1, 1] == pieces.size
        assert np.array_equal(spans[1:, 0], spans[:-1, 1])
        assert np.all(spans[:, 1] - spans[:, 0] <= block)
        assert np.all(runs.block_of[spans[:, 0]] == np.arange(spans.shape[0]))
        blocks = (runs.block_of, runs.block_span, runs.block_slack)
        for _ in range(12):
            run = int(rng.integers(runs.size))
            first, stop = int(runs.start[run]), int(runs.stop[run])
            if rng.random() < 0.5 and stop - first > 2:  # a half, as the walks halve
                first, stop = sorted(int(x) for x in rng.integers(first, stop + 1, 2))
                stop = max(stop, first + 1)
            points, dirs = _dexels(rng, pieces, first, stop, 40, core + corner, corner,
                                   height_mm)
            for q in range(points.shape[0]):
                k = int(rng.integers(first, stop))
                # a normal about where the pieces' bottoms face the dexel, or any
                nu = _unit(-pieces.axis[k] + rng.normal(size=3) * rng.choice([0.05, 1.0]))
                args = (pieces.a, pieces.e, pieces.axis, pieces.height_mm, core, corner)
                full = support_floor(points[q], dirs[q], *nu, first, stop, *args)
                if not np.isfinite(full):
                    continue
                alone = blocked_support_floor(points[q], dirs[q], *nu, first, stop, -np.inf,
                                              *args, *blocks)
                assert alone <= full
                checked += 1
                for limit in (full - 1e-3, full - 1e-9, full, full + 1e-9, full + 1e-3,
                              np.inf):
                    got = blocked_support_floor(points[q], dirs[q], *nu, first, stop, limit,
                                                *args, *blocks)
                    if full < limit:
                        assert got == full, (got, full, limit)
                    else:
                        assert got >= limit, (got, full, limit)
                        decided += got != full
    assert checked > 500
    assert decided > 0


def test_a_blocks_plane_is_as_tight_as_its_pieces_on_a_smooth_turn(rng):
    # the fine model's pieces on the bull-nose blade: a fraction of a micrometre each,
    # the axis turning ~13 urad a piece along a bending pass; a block's one plane (ends
    # and the sagittas zeta) then stands within nanometres of its pieces' least, so it
    # decides wherever a piece's plane would by more than that (pairing a piece's end
    # with its own axis at one place on the block's segment charged 0.3 um)
    core, corner, height_mm, n = 3.0, 1.0, 20.0, 2000
    s = np.arange(n + 1) * 3e-4  # 0.3 um pieces along an arc of radius 20 mm
    path = np.column_stack([20.0 * np.sin(s / 20.0), 20.0 * (1.0 - np.cos(s / 20.0)),
                            np.zeros(n + 1)])
    angle = np.arange(n) * 13e-6
    axes = np.column_stack([np.sin(angle) * 0.2, np.sin(angle), np.cos(angle)])
    axes = _unit(axes)
    a, e = path[:-1], np.diff(path, axis=0)
    ee = np.einsum("ij,ij->i", e, e)
    pieces = Pieces(a, e, ee, a + 0.5 * e, 0.5 * np.sqrt(ee), np.arange(n, dtype=np.int64),
                    np.zeros(n, dtype=bool), axes, np.full(n, np.nan), np.full(n, np.nan),
                    np.zeros(1), np.zeros(1, dtype=np.int64), np.full(n, height_mm))
    runs = piece_runs(pieces, core_radius_mm=core, corner_radius_mm=corner)
    blocks = (runs.block_of, runs.block_span, runs.block_slack)
    assert runs.block_span.shape[0] > 10
    gaps = []
    for _ in range(300):
        b = int(rng.integers(runs.block_span.shape[0]))
        first, stop = (int(x) for x in runs.block_span[b])
        k = int(rng.integers(first, stop))
        # a normal square to the path, as the sweep's where a dexel enters its side
        tangent = _unit(e[k])
        nu = -axes[k] + rng.normal(size=3) * 0.2
        nu = _unit(nu - np.dot(nu, tangent) * tangent)
        p = pieces.mid[k] + rng.uniform(0.5, 3.0) * nu
        d = -nu
        args = (pieces.a, pieces.e, pieces.axis, pieces.height_mm, core, corner)
        full = support_floor(p, d, *nu, first, stop, *args)
        alone = blocked_support_floor(p, d, *nu, first, stop, -np.inf, *args, *blocks)
        assert alone <= full
        gaps.append(full - alone)
    assert np.max(gaps) < 5e-5


def test_a_blocks_plane_stays_under_pieces_whose_sine_rounds_up():
    # a flat bottom seen along its axis: nu = -axis to an ulp, where a piece's sine as
    # computed (sqrt(1 - c^2), c rounded) stands up to ~3.7e-8 above |nu x u| ~ 1e-16; a
    # flat 50's core makes that 1e-6 mm: the block's plane must still lie at or below
    # the inner piece's (the reviewer's case: it stood 3.7e-7 mm above before)
    core, corner, height = 25.0, 0.0, 10.0
    w = _unit(np.array([0.3, -0.5, 0.8]))
    axes = np.array([w, _unit(w + np.array([0.0, 1e-16, 3e-16])), w])
    head = _unit(np.cross(w, [1.0, 0.0, 0.0]))
    a = np.arange(3)[:, None] * 1e-3 * head
    e = np.tile(1e-3 * head, (3, 1))
    ee = np.einsum("ij,ij->i", e, e)
    pieces = Pieces(a, e, ee, a + 0.5 * e, 0.5 * np.sqrt(ee), np.arange(3),
                    np.zeros(3, bool), axes, np.full(3, np.nan), np.full(3, np.nan),
                    np.zeros(1), np.zeros(1, np.int64), np.full(3, height))
    runs = piece_runs(pieces, core_radius_mm=core, corner_radius_mm=corner)
    blocks = (runs.block_of, runs.block_span, runs.block_slack)
    args = (pieces.a, pieces.e, pieces.axis, pieces.height_mm, core, corner)
    nu, p, d = -w, a[1] + 0.5 * e[1] - 3.0 * w, w.copy()
    full = support_floor(p, d, *nu, 0, 3, *args)
    alone = blocked_support_floor(p, d, *nu, 0, 3, -np.inf, *args, *blocks)
    assert alone <= full
    for limit in (np.nextafter(full, np.inf), full + 1e-7, full + 1e-6):
        assert blocked_support_floor(p, d, *nu, 0, 3, limit, *args, *blocks) == full
