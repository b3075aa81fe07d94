"""Where two passes' ball tubes meet near a seed (:func:`~toolpath.planning.cusp_kernel.ridges`).

The compiled loop lists the pieces near a seed without a branch, gathers them and takes
their distances in straight loops; it is checked, value for value, against the loop it
replaced written out one piece at a time (:func:`_one_at_a_time`), on passes that bend
and cross and on seeds where two pieces stand exactly equally near.
"""

import math

import numpy as np

from toolpath.planning.clearance_kernel import bin_samples
from toolpath.planning.cusp_kernel import RIDGE_FOUND, RIDGE_NO_PASS, ridges

RADIUS_MM = 3.0
REACH_MM = 0.6


def _foot(p, a, e):
    """The point of the segment ``a + f e`` (``0 <= f <= 1``) nearest to ``p``."""
    ee = e[0] * e[0] + e[1] * e[1] + e[2] * e[2]
    f = (p[0] - a[0]) * e[0] + (p[1] - a[1]) * e[1] + (p[2] - a[2]) * e[2]
    f = min(max(f / ee, 0.0), 1.0) if ee > 0.0 else 0.0
    return a[0] + f * e[0], a[1] + f * e[1], a[2] + f * e[2]


def _one_at_a_time(centre, normal, x_s, own, cells, a, e, pass_of):
    """The full method: each piece within reach met in the cells' order, one at a time.

    (The cells' order is the binned midpoints' order: the grid's cells in index order.)
    """
    out = []
    for i in range(len(centre)):
        p = [float(v) for v in centre[i]]
        near, best = [], {"own": (math.inf, -1, None), "other": (math.inf, -1, None)}
        for jj in range(len(cells.index)):
            d = [float(cells.points[jj, k]) - p[k] for k in range(3)]
            if d[0] * d[0] + d[1] * d[1] + d[2] * d[2] > REACH_MM * REACH_MM:
                continue
            j = int(cells.index[jj])
            near.append(j)
            f = _foot(p, a[j], e[j])
            w = [f[k] - p[k] for k in range(3)]
            dist = math.sqrt(w[0] * w[0] + w[1] * w[1] + w[2] * w[2])
            if pass_of[j] == own[i]:
                if dist < best["own"][0]:
                    best["own"] = (dist, j, f)
            elif w[0] * x_s[i, 0] + w[1] * x_s[i, 1] + w[2] * x_s[i, 2] > 0.0 \
                    and dist < best["other"][0]:
                best["other"] = (dist, j, f)
        (_, j_own, o), (_, j_other, q) = best["own"], best["other"]
        ridge = _ridge(o, q, e[j_own], normal[i], near, (a, e, pass_of), own[i], j_other)
        out.append((*ridge, (j_own, j_other)))
    return out


def _ridge(o, q, u, n, near, pieces, own, j_other):
    """The ridge of the feet ``o``, ``q`` and the depths over ``near`` (as the kernel)."""
    a, e, pass_of = pieces
    if o is None or q is None:
        return None, None, RIDGE_NO_PASS
    length = math.sqrt(u[0] * u[0] + u[1] * u[1] + u[2] * u[2])
    u = [u[k] / length for k in range(3)]
    d = [q[k] - o[k] for k in range(3)]
    along = d[0] * u[0] + d[1] * u[1] + d[2] * u[2]
    c = [d[k] - along * u[k] for k in range(3)]
    half = 0.5 * math.sqrt(c[0] * c[0] + c[1] * c[1] + c[2] * c[2])
    v = [u[1] * c[2] - u[2] * c[1], u[2] * c[0] - u[0] * c[2], u[0] * c[1] - u[1] * c[0]]
    v_len = math.sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2])
    assert half < RADIUS_MM and v_len > 0.0  # (the cases below: tubes that meet)
    up = v[0] * n[0] + v[1] * n[1] + v[2] * n[2]
    drop = math.sqrt(RADIUS_MM * RADIUS_MM - half * half) * (1.0 if up >= 0.0 else -1.0) / v_len
    x = [o[k] + 0.5 * c[k] - drop * v[k] for k in range(3)]
    third = two = 0.0
    for j in near:
        f = _foot(x, a[j], e[j])
        depth = RADIUS_MM - math.sqrt((f[0] - x[0]) ** 2 + (f[1] - x[1]) ** 2
                                      + (f[2] - x[2]) ** 2)
        if pass_of[j] == own or pass_of[j] == pass_of[j_other]:
            two = max(two, depth)
        else:
            third = max(third, depth)
    return x, (third, two), RIDGE_FOUND


def _passes():
    """Wavy passes along ``x`` 0.35 mm apart, ball centres ``R`` up, and one crossing them.

    Each pass's pieces are the segments between its points; the crossing pass (its
    pieces' midpoints binned among theirs) lies inside the other tubes' ridges. Pass 1
    ends in a right-angled corner at (5, 0.35, 3): a seed beyond it stands exactly as near
    to the corner's two pieces (its foot on each is the corner, in floating point too).
    """
    xs = np.linspace(0.0, 10.0, 41)
    chains = []
    for k in range(6):
        y = 0.35 * k + 0.05 * np.sin(0.7 * xs + k)
        chains.append(np.stack([xs, y, RADIUS_MM + 0.03 * np.cos(1.3 * xs + k)], axis=1))
    corner = np.array([[4.75, 0.35, RADIUS_MM], [5.0, 0.35, RADIUS_MM], [5.0, 0.6, RADIUS_MM]])
    chains[1] = np.concatenate([chains[1][xs < 4.0], corner])
    t = np.linspace(0.0, 1.0, 30)
    chains.append(np.stack([1.0 + 8.0 * t, 1.9 * t - 0.1, RADIUS_MM - 0.05 + 0.0 * t], axis=1))
    a = np.concatenate([c[:-1] for c in chains])
    e = np.concatenate([np.diff(c, axis=0) for c in chains])
    pass_of = np.concatenate([np.full(len(c) - 1, k) for k, c in enumerate(chains)])
    return a, e, pass_of.astype(np.int64)


_A, _E, _PASS_OF = _passes()


def _seeds(rng):
    """Seeds over passes 0 .. 4 (ball centres a little off them) and one beyond the corner."""
    own = rng.integers(0, 5, size=300)
    x = rng.uniform(0.5, 9.5, size=300)
    centre = np.stack([x, 0.35 * own + rng.normal(0.0, 0.05, 300),
                       RADIUS_MM + rng.normal(0.0, 0.02, 300)], axis=1)
    centre = np.concatenate([centre, [[5.1, 0.25, RADIUS_MM]]])
    own = np.concatenate([own, [1]])
    normal = np.tile([0.0, 0.0, 1.0], (len(own), 1))
    x_s = np.tile([0.0, 1.0, 0.0], (len(own), 1))
    return centre, normal, x_s, own


def test_ridges_equal_the_pieces_taken_one_at_a_time(rng):
    """Mutations caught: ``dist[k] <= d_own`` (the last of equally near pieces wins, not
    the first: the corner seed), ``near[n_near] = jj`` in ``_near_pieces`` (binned order
    is not piece order: the crossing pass's midpoints lie among the others' cells), and
    the depths' ``_distances`` taken from ``P`` rather than the ridge."""
    centre, normal, x_s, own = _seeds(rng)
    mid = _A + 0.5 * _E
    cells = bin_samples(mid, 2.0 * REACH_MM)
    assert not np.array_equal(cells.index, np.sort(cells.index))  # (binned order differs)
    point, inside, state, pieces = ridges(centre, normal, x_s, own, cells, REACH_MM, _A, _E,
                                          _PASS_OF, RADIUS_MM)
    expected = _one_at_a_time(centre, normal, x_s, own, cells, _A, _E, _PASS_OF)
    for i, (x, depths, st, found) in enumerate(expected):
        assert state[i] == st, i
        assert tuple(pieces[i]) == found, i
        if st == RIDGE_FOUND:
            assert tuple(point[i]) == tuple(x), i
            assert tuple(inside[i]) == depths, i
    found = state == RIDGE_FOUND
    assert found.mean() > 0.8  # (the cases exercise the ridge and both depths)
    assert (inside[found, 0] > 0.0).any() and (inside[found, 1] > 0.0).any()
    corner = np.flatnonzero((_PASS_OF == 1) & (_A[:, 0] >= 4.75))  # its two pieces
    seed = centre[-1]
    feet = [_foot(seed, _A[j], _E[j]) for j in corner]
    assert len(corner) == 2 and feet[0] == feet[1]  # (the seed's tie)
    assert pieces[-1, 0] in corner
