"""The measurement's lean steps against the plain ones they stand for, bit for bit.

Each lean step does less work for the same numbers (issue 27: the plan's measurement at
most as long as the planning it measures): vector lengths, cross products and unit normals
without numpy's set-up for any shapes; the distance from the uncut area from gathered
coordinates; the nearest contact of another pass asked of fewer neighbours first; a ball's
end slopes read where the contacts lie; the seeds of moves that all cut into the surface
taken whole. Each test names the mutation of the lean step it catches.
"""

import numpy as np
import pytest
from measured_plans import planned

from toolpath.planning import SpherePatch
from toolpath.planning.chord_measure import (
    _cusp_seeds,
    _cutting_moves,
    _end_contacts,
    _end_slopes,
)
from toolpath.planning.cusp_search import MOST_NEIGHBOURS, _OtherPasses
from toolpath.planning.uncut_area import _distance_from
from toolpath.surface import outward_normals
from toolpath.vectors import cross_rows, row_lengths, unit

CAP = SpherePatch(radius_mm=50.0, longitude_deg=(-20.0, 20.0), colatitude_deg=(15.0, 40.0))


def test_unit_vectors_and_normals_are_numpys_bit_for_bit():
    # mutations caught: row_lengths summing dy^2 + dz^2 first (another rounding), and
    # cross_rows taking a product the other way round
    rng = np.random.default_rng(5)
    for scale in (1e-6, 1.0, 1e4):
        v = rng.normal(0.0, scale, (40_000, 3)) * rng.uniform(0.0, 2.0, (40_000, 1))
        v[:3] = 0.0  # (zero vectors stay zero)
        norm = np.linalg.norm(v, axis=-1, keepdims=True)
        assert np.array_equal(row_lengths(v), norm[:, 0])
        assert np.array_equal(unit(v), v / np.where(norm > 0.0, norm, 1.0))
        grid = v.reshape(200, 200, 3)  # (any leading shape)
        assert np.array_equal(cross_rows(grid, grid[::-1]), np.cross(grid, grid[::-1]))
    xt, xs = rng.normal(size=(2, 5_000, 3))
    for orientation in (1.0, -1.0):
        surface = type("Oriented", (), {"orientation": orientation})()
        assert np.array_equal(outward_normals(surface, xt, xs),
                              orientation * unit(np.cross(xt, xs)))


def _distance_by_norms(reach, grid, points, t, s):
    """The distance from the uncut area as numpy's norms give it (the plain method)."""
    n_t, n_s = grid.shape[:2]
    node = np.arange(n_t * n_s).reshape(n_t, n_s)
    flat = grid.reshape(-1, 3)
    i0 = np.clip(np.floor(t * (n_t - 1)).astype(np.int64), 0, n_t - 2)
    j0 = np.clip(np.floor(s * (n_s - 1)).astype(np.int64), 0, n_s - 2)
    best = np.full(len(points), np.inf)
    for di in (0, 1):
        for dj in (0, 1):
            k = node[i0 + di, j0 + dj]
            best = np.minimum(best, reach[k] + np.linalg.norm(points - flat[k], axis=1))
    return best


def test_distance_from_the_uncut_area_is_the_best_of_four_nodes_bit_for_bit():
    # mutation caught: a corner node left out (e.g. (i0 + 1, j0 + 1)): each corner is the
    # best one for some points here
    rng = np.random.default_rng(17)
    n_t, n_s = 7, 11
    grid = rng.normal(0.0, 5.0, (n_t, n_s, 3))
    reach = rng.uniform(0.0, 4.0, n_t * n_s)
    reach[rng.choice(reach.size, 15, replace=False)] = np.inf  # (beyond the limit)
    t = np.concatenate([rng.uniform(0.0, 1.0, 4_000), [0.0, 1.0, 1.0, 0.0]])
    s = np.concatenate([rng.uniform(0.0, 1.0, 4_000), [0.0, 1.0, 0.0, 1.0]])
    points = rng.normal(0.0, 5.0, (t.size, 3))
    lean = _distance_from(reach, grid, points, t, s)
    assert np.array_equal(lean, _distance_by_norms(reach, grid, points, t, s))
    # (the premise: every corner decides somewhere)
    i0 = np.clip(np.floor(t * (n_t - 1)).astype(np.int64), 0, n_t - 2)
    j0 = np.clip(np.floor(s * (n_s - 1)).astype(np.int64), 0, n_s - 2)
    corners = np.stack([reach[(i0 + di) * n_s + j0 + dj] + np.linalg.norm(
        points - grid[i0 + di, j0 + dj], axis=1) for di in (0, 1) for dj in (0, 1)])
    assert set(np.argmin(corners, axis=0)) == {0, 1, 2, 3}


def _nearest_other_pass(points, passes, rows):
    """The plain method: sort every contact by distance, the first of another pass among
    the :data:`MOST_NEIGHBOURS` nearest (inf: none there)."""
    out = np.full(len(rows), np.inf)
    for i, r in enumerate(rows):
        d = np.linalg.norm(points - points[r], axis=1)
        order = np.argsort(d, kind="stable")[:MOST_NEIGHBOURS]
        other = order[passes[order] != passes[r]]
        if other.size:
            out[i] = d[other[0]]
    return out


def test_nearest_contact_of_another_pass_through_every_round():
    # one pass of 4,000 contacts 0.01 mm apart on a line and single contacts of other
    # passes beside it, nearest to a contact at neighbour ranks of about 5, 20, 100, 700
    # and 1,400 (the contacts asked lie far enough apart that each one's is its own):
    # found in each round of the widening search but the last, which the plain method
    # does not reach either (mutations caught: a last round short of MOST_NEIGHBOURS,
    # which misses the one at rank 700; a round past it, which finds the one at 1,400)
    line = np.stack([np.arange(4000) * 0.01, np.zeros(4000), np.zeros(4000)], axis=1)
    queried = np.array([200, 700, 1200, 2000, 3000])
    off = np.array([0.025, 0.1, 0.5, 3.5, 7.0])
    beside = line[queried] + off[:, None] * np.array([0.0, 1.0, 0.0])
    points = np.concatenate([line, beside])
    passes = np.concatenate([np.zeros(4000, dtype=np.int64), np.arange(1, 6)])
    lean = _OtherPasses(points, passes).distance(queried)
    plain = _nearest_other_pass(points, passes, queried)
    assert np.array_equal(lean, plain)
    assert np.array_equal(lean[:4], off[:4])
    assert np.isinf(lean[4])


@pytest.fixture(scope="module")
def cap3():
    return planned(CAP, "ball:6", scallop_mm=0.02, chord_tol_mm=0.02, axis_mode="3")


def test_tip_linear_ball_slopes_read_in_place_are_ball_slopes_bit_for_bit(cap3):
    # mutation caught: the slopes read from the rows after the moves' first (ia + 1)
    path, surface, cutter = cap3.path, cap3.surface, cap3.cutter
    move = _cutting_moves(path)
    contacts = _end_contacts(path, surface, cutter, cap3.samples, move, 100_000, 4)
    ends, ia, ib = contacts.of_moves(path, move)
    plain = _end_slopes(cutter, ends, contacts.normal[ia], contacts.normal[ib], None)
    assert len(plain) > 100 and np.abs(plain).max() > 0.0
    assert np.array_equal(contacts.tip_linear_slopes(cutter.radius_mm, ia), plain)


class _ClosedAlongT:
    """``surface`` said to close along ``t`` (the seeds' ``t`` then taken modulo 1)."""

    closed_t = True

    def __init__(self, surface):
        self._surface = surface

    def __getattr__(self, name):
        return getattr(self._surface, name)


@pytest.mark.parametrize("closed", [False, True])
def test_seeds_of_moves_that_all_cut_in_are_their_contacts_whole(cap3, closed):
    # every move's middle below the surface: the seeds are the moves' first contacts in
    # order, as the general assembly places them (mutations caught: the frames of the
    # rows after, first + 1; on a surface closed along t, the contacts' t a turn on
    # (t + 1) not taken modulo 1)
    path, surface, cutter = cap3.path, cap3.surface, cap3.cutter
    move = _cutting_moves(path)
    contacts = _end_contacts(path, surface, cutter, cap3.samples, move, 100_000, 4)
    ends, ia, _ = contacts.of_moves(path, move)
    mid_t = ends.t_a
    if closed:
        surface = _ClosedAlongT(surface)
        ends = ends._replace(t_a=ends.t_a + (np.arange(len(move)) % 2))
    below = (np.full(len(move), -1e-3), mid_t, ends.s_a)
    some_above = (np.where(np.arange(len(move)) == 3, 1e-3, -1e-3), mid_t, ends.s_a)
    passes = path.pass_index[move]
    lean = _cusp_seeds(surface, contacts, ia, ends, below, passes)
    general = _cusp_seeds(surface, contacts, ia, ends, some_above, passes)
    keep = np.arange(len(move) + 1) != 4  # (the general path's one middle, after move 3)
    for a, b in zip(lean, general, strict=True):
        assert a.dtype == b.dtype
        assert np.array_equal(a, b[keep])
    if closed:  # (on the open cap t = 1 is a contact's own)
        assert ((lean[0] >= 0.0) & (lean[0] < 1.0)).all()
