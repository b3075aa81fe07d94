"""The uncut area's grid: nodes tried first with the piece the contacts place at them.

:meth:`~toolpath.planning.uncut_area.UncutArea.on_grid` with the chord measurement's
contacts tries each node's piece first (the shortcut) and searches the others; without them
every node is searched (the full method). Both must find the same uncut nodes.
"""

import dataclasses

import numpy as np
import pytest
from measured_plans import planned

from machines import load_machine
from toolpath.path import MoveKind, Toolpath
from toolpath.planning import EllipticBladeSurface, SpherePatch, parse_cutter
from toolpath.planning.chord_measure import measure_chord
from toolpath.planning.cut_volume import CutVolume, cusp_horizon_mm
from toolpath.planning.sweep_kernel import ray_ranges
from toolpath.planning.uncut_area import UncutArea

CAP = SpherePatch(radius_mm=50.0, longitude_deg=(-20.0, 20.0), colatitude_deg=(15.0, 40.0))


def _without_passes(path, passes):
    """The toolpath with the moves along ``passes`` made rapids: those strips stay uncut."""
    kinds = path.kinds.copy()
    kinds[np.isin(path.pass_index, passes)] = MoveKind.RAPID
    return dataclasses.replace(path, kinds=kinds)


def _passes_cut_short(path, passes):
    """The toolpath with the second half of each of ``passes`` made rapids (ended early)."""
    kinds = path.kinds.copy()
    for p in passes:
        rows = np.flatnonzero(path.pass_index == p)
        kinds[rows[rows.size // 2:]] = MoveKind.RAPID
    return dataclasses.replace(path, kinds=kinds)


def _uncut_both_ways(measured, path, scramble=False):
    """The uncut area with the contacts' pieces tried first (the shortcut) and without."""
    chord = measure_chord(path, measured.surface, measured.cutter, measured.samples,
                          machine=measured.machine)
    measured = dataclasses.replace(measured, path=path, chord=chord)
    volume = measured.volume()
    contacts = (chord.contact_t, chord.contact_s)
    assert np.isfinite(contacts[0]).sum() > 100
    if scramble:  # pieces placed at nodes far from them: the search must take over
        rng = np.random.default_rng(3)
        contacts = tuple(rng.permutation(c) for c in contacts)
    h = measured.request_mm
    rho = measured.cutter.corner_radius_mm
    rho = rho if rho > h else measured.cutter.radius_mm
    width_mm = 2.0 * np.sqrt(h * (2.0 * rho - h))
    fast = UncutArea.on_grid(measured.surface, volume, width_mm, contacts)
    full = UncutArea.on_grid(measured.surface, volume, width_mm)
    return fast, full


def _assert_same(fast, full):
    assert full.uncut.any() and (~full.uncut).any()
    assert np.array_equal(fast.uncut, full.uncut)
    assert fast.fraction == full.fraction
    assert np.array_equal(fast.reach, full.reach)


@pytest.mark.parametrize("scramble", [False, True])
def test_the_contacts_pieces_find_the_uncut_area_the_full_search_finds(scramble):
    measured = planned(CAP, "ball:6", scallop_mm=0.02, chord_tol_mm=0.02, axis_mode="3")
    middle = int(measured.path.pass_index.max()) // 2
    path = _without_passes(measured.path, np.arange(middle - 3, middle + 4))
    _assert_same(*_uncut_both_ways(measured, path, scramble))


@pytest.mark.parametrize("cutter, machine", [("flat:8", None), ("bull:8:1", None),
                                             ("bull:6:2", None), ("bull:8:1", "trunnion-ac"),
                                             ("flat:8", "head-table-bc")])
def test_flat_and_bull_nose_uncut_strips_are_found_as_the_full_search_finds_them(cutter,
                                                                                 machine):
    # 5-axis faces, with or without a machine's joint interpolation: a thin uncut strip
    # (one pass left out), a wide one, passes that end early (their second half rapids
    # over the surface): every node the full search finds uncut, and no other
    measured = planned(CAP, cutter, scallop_mm=0.005, chord_tol_mm=0.02,
                       axis_mode="lead-tilt", lead_deg=5.0,
                       machine=None if machine is None else load_machine(machine))
    last = int(measured.path.pass_index.max())
    path = _without_passes(measured.path, [last // 4, *range(last // 2, last // 2 + 3)])
    path = _passes_cut_short(path, [3 * last // 4, 3 * last // 4 + 1])
    fast, full = _uncut_both_ways(measured, path)
    _assert_same(fast, full)


def test_uncut_strips_across_a_closed_seam_are_found_as_the_full_search_finds_them():
    # a closed section's passes cross the seam: the contacts' tracks the short way round
    measured = planned(EllipticBladeSurface(), "bull:8:1", scallop_mm=0.05, chord_tol_mm=0.05,
                       axis_mode="lead-tilt", lead_deg=5.0, linking="spiral")
    assert measured.surface.closed_t
    last = int(measured.path.pass_index.max())
    path = _without_passes(measured.path, np.arange(last // 3, last // 3 + 5))
    _assert_same(*_uncut_both_ways(measured, path))


def test_the_contacts_pieces_decide_almost_every_node_of_a_bull_nose_plan():
    # the bull-nose's cut within the horizon spans a short stretch along its pass round
    # its contact (lead): the piece crossing a node's column cuts it, and the nodes
    # between passes take the nearest pass's; few nodes are left to the full search
    from toolpath.planning.uncut_area import _node_pieces

    measured = planned(CAP, "bull:8:1", scallop_mm=0.01, chord_tol_mm=0.02,
                       axis_mode="lead-tilt", lead_deg=5.0)
    volume = measured.volume()
    h, big = measured.request_mm, measured.cutter.radius_mm
    width_mm = 2.0 * np.sqrt(h * (2.0 * measured.cutter.corner_radius_mm - h))
    full = UncutArea.on_grid(CAP, volume, width_mm)
    n_t, n_s = full.grid.shape[:2]
    node = _node_pieces(volume, measured.chord.contact_t, measured.chord.contact_s, False,
                        n_t, n_s, int(np.ceil(big / width_mm)))
    q = full.grid.reshape(-1, 3)
    t, s = np.meshgrid(np.linspace(0.0, 1.0, n_t), np.linspace(0.0, 1.0, n_s), indexing="ij")
    _, n = CAP.points_and_normals(t.ravel(), s.ravel())
    rows = np.flatnonzero(node >= 0)
    one = np.arange(rows.size)
    cut = np.isfinite(volume.height(q[rows], n[rows], one, one + 1, node[rows], first=True))
    assert cut.sum() >= 0.9 * (~full.uncut).sum()


def _reach_over_every_edge(grid, sources, closed, limit_mm):
    """The full method: Dijkstra from every source over all the grid's 8-neighbour edges."""
    import scipy.sparse
    import scipy.sparse.csgraph

    n_t, n_s = sources.shape
    node = np.arange(n_t * n_s).reshape(n_t, n_s)
    pairs = [(node[1:, :], node[:-1, :]), (node[:, 1:], node[:, :-1]),
             (node[1:, 1:], node[:-1, :-1]), (node[1:, :-1], node[:-1, 1:])]
    if closed:
        pairs.append((node[0, :], node[-1, :]))
    a = np.concatenate([p[0].ravel() for p in pairs])
    b = np.concatenate([p[1].ravel() for p in pairs])
    flat = grid.reshape(-1, 3)
    weight = np.maximum(np.linalg.norm(flat[a] - flat[b], axis=1), 1e-9)
    graph = scipy.sparse.coo_matrix((weight, (a, b)), shape=(node.size,) * 2).tocsr()
    return scipy.sparse.csgraph.dijkstra(graph, directed=False,
                                         indices=np.flatnonzero(sources.ravel()),
                                         min_only=True, limit=limit_mm)


@pytest.mark.parametrize("closed", [False, True])
def test_distances_from_the_uncut_border_are_those_from_every_uncut_node(closed):
    # a large uncut area (its inside never walked) and scattered uncut nodes, on a wavy
    # sheet whose seam joins on closed sections, with a collapsed row: the distances the
    # search from the uncut area's border finds are those from every uncut node
    from toolpath.planning.uncut_area import _surface_reach
    from toolpath.tolerances import LENGTH_SLACK_MM

    assert LENGTH_SLACK_MM == 1e-9  # (the full method's edge floor above)
    n_t, n_s = 40, 30
    t, s = np.meshgrid(np.linspace(0.0, 1.0, n_t), np.linspace(0.0, 1.0, n_s), indexing="ij")
    rng = np.random.default_rng(5)
    grid = np.stack([20.0 * np.cos(2 * np.pi * t), 12.0 * np.sin(2 * np.pi * t) + 3.0 * s,
                     25.0 * s + np.sin(7.0 * t)], axis=2) + rng.normal(0.0, 0.05, (n_t, n_s, 3))
    grid[1] = grid[0]
    sources = rng.random((n_t, n_s)) < 0.02
    sources[5:25, 3:20] = True
    for limit_mm in (4.0, 12.0, np.inf):
        full = _reach_over_every_edge(grid, sources, closed, limit_mm)
        fast = _surface_reach(grid, sources, closed, limit_mm)
        within = full <= limit_mm
        assert within.sum() > sources.sum()
        assert np.array_equal(fast[within], full[within])
        assert np.all(fast[~within] > limit_mm)


def test_the_chords_lengths_are_numpys_norms_bit_for_bit():
    # the reach's edge weights from their components: the same sums of the same squares
    # as np.linalg.norm's, in the same order, whatever the scale
    from toolpath.vectors import lengths as _chords

    rng = np.random.default_rng(11)
    for scale in (1e-6, 1.0, 1e4):
        d = rng.normal(0.0, scale, (100_000, 3)) * rng.uniform(0.0, 2.0, (100_000, 1))
        assert np.array_equal(_chords(d[:, 0], d[:, 1], d[:, 2]), np.linalg.norm(d, axis=1))


def test_the_grids_cross_products_are_numpys_bit_for_bit():
    # the normals' cross products row by row: numpy's own products and differences
    from toolpath.vectors import cross_rows as _cross_rows

    rng = np.random.default_rng(13)
    for scale in (1e-6, 1.0, 1e4):
        a, b = rng.normal(0.0, scale, (2, 50_000, 3))
        assert np.array_equal(_cross_rows(a, b), np.cross(a, b))


def test_a_negative_reach_limit_is_refused_whatever_the_sources():
    # (the search runs only from border sources: with none, scipy's own check is not hit)
    from toolpath.planning.uncut_area import _surface_reach

    grid = np.zeros((4, 5, 3))
    grid[..., 0], grid[..., 1] = np.meshgrid(np.arange(4.0), np.arange(5.0), indexing="ij")
    for sources in (np.ones((4, 5), bool), np.zeros((4, 5), bool)):
        with pytest.raises(ValueError, match="limit must be >= 0 mm"):
            _surface_reach(grid, sources, False, -1.0)


def _node_pieces_by_definition(start, piece_move, contact_t, contact_s, closed, n_t, n_s,
                               spread):
    """Each move's ``(t, s)`` line crossing the grid's columns: the piece holding the
    crossing, offered to the column's nodes within ``spread`` of it, the nearest kept."""
    node = np.full(n_t * n_s, -1, dtype=np.int64)
    nearest = np.full(n_t * n_s, np.inf)
    for m, a in enumerate(start):
        pieces = np.flatnonzero(piece_move == m)
        ta, tb, sa, sb = contact_t[a], contact_t[a + 1], contact_s[a], contact_s[a + 1]
        if not pieces.size or not np.isfinite([ta, tb, sa, sb]).all():
            continue
        if closed:  # the short way across the seam
            tb = tb - 1.0 if tb - ta > 0.5 else tb + 1.0 if ta - tb > 0.5 else tb
        for i in range(n_t):
            for turn in (-1, 0, 1) if closed else (0,):
                ti = i / (n_t - 1) + turn
                if not min(ta, tb) <= ti <= max(ta, tb):
                    continue
                u = float(np.clip((ti - ta) / (tb - ta), 0.0, 1.0)) if tb != ta else 0.0
                piece = pieces[min(int(u * pieces.size), pieces.size - 1)]
                at = (sa + u * (sb - sa)) * (n_s - 1)
                for j in range(n_s):
                    off = abs(j - at)
                    if off <= spread and off < nearest[i * n_s + j]:
                        nearest[i * n_s + j], node[i * n_s + j] = off, piece
    return node


@pytest.mark.parametrize("closed", [False, True])
def test_each_node_gets_the_piece_crossing_its_column_nearest_to_it(closed):
    # the compiled placement against the definition: moves of 1 to 5 pieces, a link
    # between contacts-less points, moves across a closed seam, several tracks crossing a
    # column near one node
    from types import SimpleNamespace

    from toolpath.planning.uncut_area import _node_pieces

    rng = np.random.default_rng(7)
    n_points = 400
    contact_t = np.mod(np.cumsum(rng.uniform(0.0, 0.02, n_points)), 1.0)
    contact_s = np.clip(0.5 + np.cumsum(rng.normal(0.0, 0.01, n_points)), -0.1, 1.1)
    contact_t[100:110] = np.nan  # (a link: no contacts there)
    start = np.sort(rng.choice(n_points - 1, 300, replace=False))
    piece_move = np.repeat(np.arange(len(start)), rng.integers(1, 6, len(start)))
    volume = SimpleNamespace(move_starts=start, piece_move=piece_move,
                             pass_of=np.zeros(len(piece_move), dtype=np.int64))
    for n_t, n_s, spread in ((41, 23, 3), (7, 5, 1), (41, 23, 30)):
        node = _node_pieces(volume, contact_t, contact_s, closed, n_t, n_s, spread)
        expected = _node_pieces_by_definition(start, piece_move, contact_t, contact_s, closed,
                                              n_t, n_s, spread)
        np.testing.assert_array_equal(node, expected)
        assert (node >= 0).sum() > 5


@pytest.mark.parametrize("cutter", ["ball:6", "bull:8:1"])
def test_rays_cut_are_those_entering_a_piece_within_the_horizon(cutter):
    # the full method: every ray meets every piece within the cutter's reach; cut() skips
    # the rays that have none there (counted first), and tries candidates and near pieces
    measured = planned(CAP, cutter, scallop_mm=0.02, chord_tol_mm=0.02, axis_mode="3")
    middle = int(measured.path.pass_index.max()) // 2
    path = _without_passes(measured.path, np.arange(middle - 3, middle + 4))
    measured = dataclasses.replace(measured, path=path)
    volume = measured.volume()
    g = np.linspace(0.0, 1.0, 61)
    t, s = (a.ravel() for a in np.meshgrid(g, g, indexing="ij"))
    q, n = CAP.points_and_normals(t, s)
    full = np.isfinite(volume.height(q, n, *ray_ranges(*volume.pairs(q), len(q)), first=True))
    assert full.any() and (~full).any()
    assert np.array_equal(volume.cut(q, n), full)
    # rays with no piece within the reach: the uncut strip's, and rays far off the part
    off = q + 5.0 * volume.cutter.radius_mm * n
    assert not volume.cut(off, n).any()


def test_only_rays_with_pieces_within_the_reach_seek_the_near_pieces(monkeypatch):
    # cut() counts each ray's pieces within the cutter's reach before it looks among a
    # ball's near pieces: the rays with none (the uncut strip's, rays off the part) are
    # uncut without that search, the others seek them, and the rays cut are the full
    # method's (every ray meets every piece within the reach)
    from toolpath.planning import cut_volume
    from toolpath.planning.clearance_kernel import counts_within

    measured = planned(CAP, "ball:6", scallop_mm=0.02, chord_tol_mm=0.02, axis_mode="3")
    middle = int(measured.path.pass_index.max()) // 2
    path = _without_passes(measured.path, np.arange(middle - 3, middle + 4))
    volume = dataclasses.replace(measured, path=path).volume()
    g = np.linspace(0.0, 1.0, 61)
    t, s = (a.ravel() for a in np.meshgrid(g, g, indexing="ij"))
    q, n = CAP.points_and_normals(t, s)
    q = np.concatenate([q, q[::7] + 5.0 * volume.cutter.radius_mm * n[::7]])
    n = np.concatenate([n, n[::7]])
    full = np.isfinite(volume.height(q, n, *ray_ranges(*volume.pairs(q), len(q)), first=True))
    within = counts_within(volume.cells, q, volume.reach) > 0
    sought = []
    real = cut_volume.pairs_within

    def spy(cells, queries, radius):
        if cells is volume.near_cells:
            sought.append(len(queries))
        return real(cells, queries, radius)

    monkeypatch.setattr(cut_volume, "pairs_within", spy)
    assert np.array_equal(volume.cut(q, n), full)
    assert full.any() and (~full).any() and (~within[:t.size]).sum() > 100
    assert sum(sought) == within.sum()


def test_rays_their_candidate_missed_are_cut_by_near_pieces_without_the_reachs_cells(
        monkeypatch):
    # each ray's candidate: its farthest piece within the reach (a pass or two away,
    # missing it); the near pieces then cut them all, so the reach's cells (binned for the
    # rays with none of them) are never binned, and the rays cut are the full method's
    from toolpath.planning import cut_volume

    measured = planned(CAP, "ball:6", scallop_mm=0.02, chord_tol_mm=0.02, axis_mode="3")
    volume = measured.volume()
    g = np.linspace(0.2, 0.8, 31)
    t, s = (a.ravel() for a in np.meshgrid(g, g, indexing="ij"))
    q, n = CAP.points_and_normals(t, s)
    owner, item = volume.pairs(q)
    far = np.linalg.norm(volume._midpoints(item) - q[owner], axis=1)
    order = np.lexsort((far, owner))  # (each ray's farthest last)
    candidate = np.full(len(q), -1, dtype=np.int64)
    candidate[owner[order]] = item[order]
    one = np.arange(len(q))
    missed = ~np.isfinite(volume.height(q, n, one, one + 1, candidate, first=True))
    full = np.isfinite(volume.height(q, n, *ray_ranges(owner, item, len(q)), first=True))
    binned = []
    real = cut_volume.bin_samples

    def spy(points, reach_mm):
        binned.append(reach_mm)
        return real(points, reach_mm)

    monkeypatch.setattr(cut_volume, "bin_samples", spy)
    volume._cells = None
    assert np.array_equal(volume.cut(q, n, candidate), full)
    assert full.all() and missed.sum() > 100
    assert volume.reach not in binned


def test_a_candidate_beyond_the_cutters_reach_is_not_taken():
    # a flat cutter lying on a plane: its flank touches the rays along it 15 mm from its
    # tip, whose pieces' midpoints (the tip, corner radius 0) lie beyond the reach the
    # full search meets pieces within: a candidate piece there decides nothing, and the
    # rays cut are the full search's (none there)
    from toolpath.path import Toolpath
    from toolpath.planning import parse_cutter
    from toolpath.planning.cut_volume import CutVolume

    tips = np.array([[-20.0, -1.0, 4.0], [-20.0, 1.0, 4.0]])
    path = Toolpath(tips, np.tile([1.0, 0.0, 0.0], (2, 1)),
                    np.array([MoveKind.RAPID, MoveKind.CUT], dtype=np.uint8),
                    np.full(2, 1000.0), np.zeros(2, dtype=np.int32))
    volume = CutVolume(path, parse_cutter("flat:8"), 0.05, 0.005)
    q = np.array([[-5.0, 0.0, 0.0], [-19.0, 0.0, 0.0]])
    n = np.tile([0.0, 0.0, 1.0], (2, 1))
    one = np.arange(2)
    entered = volume.height(q, n, one, one + 1, np.zeros(2, dtype=np.int64), first=True)
    assert np.isfinite(entered).all()  # (the flank and the tip's end touch both rays)
    full = volume.cut(q, n)
    assert full.tolist() == [False, True]
    assert np.array_equal(volume.cut(q, n, np.zeros(2, dtype=np.int64)), full)


@pytest.mark.parametrize("theta_deg", [44.0, 90.0, 140.0])
def test_a_piece_longer_than_the_step_is_within_the_reach_of_rays_it_cuts(theta_deg):
    # a ball's tip-linear move whose axis swings by theta: its centres' pieces run longer
    # than the step; a ray grazing a piece's free end, R + h/2 out along the piece, is cut
    # by it though its midpoint lies more than R + h + step/2 away (the reach was that)
    radius, scallop = 3.0, 0.005
    horizon = cusp_horizon_mm(scallop)
    th = np.radians(theta_deg)
    a0, t0 = np.array([1.0, 0.0, 0.0]), np.array([0.0, 1.0, 0.0])
    a1 = np.cos(th) * a0 + np.sin(th) * t0
    tip_b = radius * (1.0 - np.cos(th)) * a0
    pos = np.array([[0.0, 0.0, 50.0], [0.0, 0.0, 0.0], tip_b, tip_b + np.array([0.0, 0.0, 50.0])])
    kinds = np.array([MoveKind.RAPID, MoveKind.RAPID, MoveKind.CUT, MoveKind.RAPID], np.uint8)
    path = Toolpath(pos, np.array([a0, a0, a1, a1]), kinds, np.array([0.0, 0.0, 1000.0, 0.0]),
                    np.array([-1, 0, 0, -1], np.int32))
    volume = CutVolume(path, parse_cutter("ball:6"), horizon, scallop)
    a, b = volume.a, volume.b
    assert np.linalg.norm(b - a, axis=1).max() > volume.step_mm  # (the case in point)
    for end, other in ((a[0], b[0]), (b[-1], a[-1])):
        out = (end - other) / np.linalg.norm(end - other)
        q, n = (end + (radius + 0.5 * horizon) * out)[None], -out[None]
        every = np.arange(len(a))
        full = np.isfinite(volume.height(np.repeat(q, len(a), 0), np.repeat(n, len(a), 0),
                                         every, every + 1, every, first=True)).any()
        assert full  # some piece cuts the ray ...
        assert volume.cut(q, n).tolist() == [True]  # ... and the grid's search finds it


@pytest.mark.parametrize("cutter", ["flat:6", "bull:8:1"])
def test_rays_that_cannot_climb_to_a_pieces_tip_plane_skip_it_and_are_cut_as_before(cutter):
    # under one tool axis a cutter lies above its tip plane: a ray that does not climb
    # from below a piece's two end tips never enters it (cut() drops those pairs before
    # the search); the rays cut are the full method's, every ray meeting every piece
    # within the reach: the cap's own rays and rays from 0.05 mm under it (climbing to the
    # tip planes over them: cut) and rays 1 mm under it pointing down, away from the
    # cutters (the far side of a thin part: none enters)
    measured = planned(CAP, cutter, scallop_mm=0.02, chord_tol_mm=0.02, axis_mode="3")
    volume = measured.volume()
    g = np.linspace(0.0, 1.0, 41)
    t, s = (a.ravel() for a in np.meshgrid(g, g, indexing="ij"))
    q, n = CAP.points_and_normals(t, s)
    for rays in ((q, n), (q - 0.05 * n, n), (q - 1.0 * n, -n)):
        full = np.isfinite(volume.height(*rays, *ray_ranges(*volume.pairs(rays[0]), len(q)),
                                         first=True))
        assert np.array_equal(volume.cut(*rays), full)
    assert full.sum() == 0 and volume.cut(q - 0.05 * n, n).mean() > 0.9
    owner, item = volume.pairs(q - 1.0 * n)
    kept, _ = volume._enterable(q - 1.0 * n, -n, owner, item)
    assert owner.size > 1000 and kept.size == 0
    # a turning axis keeps every pair
    tilted = planned(CAP, cutter, scallop_mm=0.02, chord_tol_mm=0.02, axis_mode="lead-tilt",
                     lead_deg=10.0).volume()
    assert volume.lowest_tip_mm is not None and tilted.lowest_tip_mm is None
