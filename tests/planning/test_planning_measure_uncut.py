"""The uncut area's grid: nodes tried first with the piece the contacts place at them.

:meth:`~toolpath.planning.uncut_area.UncutArea.on_grid` with the chord measurement's
contacts tries each node's piece first (the shortcut) and searches the others; without them
every node is searched (the full method). Both must find the same uncut nodes.
"""

import dataclasses

import numpy as np
import pytest
from measured_plans import planned

from toolpath.path import MoveKind
from toolpath.planning import SpherePatch
from toolpath.planning.chord_measure import measure_chord
from toolpath.planning.sweep_kernel import ray_ranges
from toolpath.planning.uncut_area import UncutArea

CAP = SpherePatch(radius_mm=50.0, longitude_deg=(-20.0, 20.0), colatitude_deg=(15.0, 40.0))


def _without_passes(path, passes):
    """The toolpath with the moves along ``passes`` made rapids: those strips stay uncut."""
    kinds = path.kinds.copy()
    kinds[np.isin(path.pass_index, passes)] = MoveKind.RAPID
    return dataclasses.replace(path, kinds=kinds)


@pytest.mark.parametrize("scramble", [False, True])
def test_the_contacts_pieces_find_the_uncut_area_the_full_search_finds(scramble):
    measured = planned(CAP, "ball:6", scallop_mm=0.02, chord_tol_mm=0.02, axis_mode="3")
    middle = int(measured.path.pass_index.max()) // 2
    path = _without_passes(measured.path, np.arange(middle - 3, middle + 4))
    chord = measure_chord(path, CAP, measured.cutter, measured.samples)
    measured = dataclasses.replace(measured, path=path, chord=chord)
    volume = measured.volume()
    contacts = (chord.contact_t, chord.contact_s)
    assert np.isfinite(contacts[0]).sum() > 200
    if scramble:  # pieces placed at nodes far from them: the search must take over
        rng = np.random.default_rng(3)
        contacts = tuple(rng.permutation(c) for c in contacts)
    width_mm = 2.0 * np.sqrt(0.02 * (2.0 * 3.0 - 0.02))
    fast = UncutArea.on_grid(CAP, volume, width_mm, contacts)
    full = UncutArea.on_grid(CAP, volume, width_mm)
    assert full.uncut.any() and (~full.uncut).any()
    assert np.array_equal(fast.uncut, full.uncut)
    assert fast.fraction == full.fraction
    assert np.array_equal(fast.reach, full.reach)


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


def test_a_negative_reach_limit_is_refused_whatever_the_sources():
    # (the search runs only from border sources: with none, scipy's own check is not hit)
    from toolpath.planning.uncut_area import _surface_reach

    grid = np.zeros((4, 5, 3))
    grid[..., 0], grid[..., 1] = np.meshgrid(np.arange(4.0), np.arange(5.0), indexing="ij")
    for sources in (np.ones((4, 5), bool), np.zeros((4, 5), bool)):
        with pytest.raises(ValueError, match="limit must be >= 0 mm"):
            _surface_reach(grid, sources, False, -1.0)


def _node_pieces_by_definition(start, piece_move, contact_t, contact_s, closed, n_t, n_s):
    """Each piece's middle ``(t, s)`` between its move's contacts, rounded to a node."""
    count = np.bincount(piece_move, minlength=len(start))
    rank = np.arange(len(piece_move)) - (np.cumsum(count) - count)[piece_move]
    u = (rank + 0.5) / count[piece_move]
    a = start[piece_move]
    ta, tb, sa, sb = contact_t[a], contact_t[a + 1], contact_s[a], contact_s[a + 1]
    rows = np.flatnonzero(np.isfinite(ta) & np.isfinite(tb) & np.isfinite(sa)
                          & np.isfinite(sb))
    ta, tb, sa, sb, u = ta[rows], tb[rows], sa[rows], sb[rows], u[rows]
    if closed:  # the short way across the seam
        tb = np.where(tb - ta > 0.5, tb - 1.0, np.where(ta - tb > 0.5, tb + 1.0, tb))
    t = ta * (1.0 - u) + tb * u
    t = np.mod(t, 1.0) if closed else t
    s = sa + u * (sb - sa)
    i = np.rint(np.clip(t, 0.0, 1.0) * (n_t - 1)).astype(np.int64)
    j = np.rint(np.clip(s, 0.0, 1.0) * (n_s - 1)).astype(np.int64)
    node = np.full(n_t * n_s, -1, dtype=np.int64)
    for piece, k in zip(rows, i * n_s + j, strict=True):  # the last one placed stays
        node[k] = piece
    return node


@pytest.mark.parametrize("closed", [False, True])
def test_each_node_gets_the_piece_its_move_s_contacts_place_there(closed):
    # the compiled placement against the definition, piece by piece: moves of 1 to 5
    # pieces, a link between contacts-less points, moves across a closed seam, several
    # pieces at one node
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
    for n_t, n_s in ((41, 23), (7, 5)):
        node = _node_pieces(volume, contact_t, contact_s, closed, n_t, n_s)
        expected = _node_pieces_by_definition(start, piece_move, contact_t, contact_s, closed,
                                              n_t, n_s)
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
