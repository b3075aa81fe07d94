"""The next pass's piece for a flat or bull-nose cusp estimate, against every piece in numpy.

:func:`toolpath.planning.cusp_kernel.next_pieces` meets the pieces in the cells its reach
overlaps; the oracle measures the distance from each seed's foot to every piece of another
pass: the nearest on the ``+s`` side within the reach (of equally near ones, as the two
pieces meeting at a joint, either).
"""

import numpy as np

from toolpath.planning.clearance_kernel import bin_samples
from toolpath.planning.cusp_kernel import next_pieces


def _passes(rng, n_passes, per_pass):
    """Zigzag-free passes along x, 0.3 mm apart in y, wavy in z; pieces of about 0.1 mm."""
    starts, vectors, owners = [], [], []
    for k in range(n_passes):
        x = np.sort(rng.uniform(0.0, 10.0, per_pass + 1))
        y = 0.3 * k + rng.normal(scale=0.02, size=x.size)
        z = 0.2 * np.sin(x + k) + rng.normal(scale=0.01, size=x.size)
        p = np.column_stack([x, y, z])
        starts.append(p[:-1])
        vectors.append(np.diff(p, axis=0))
        owners.append(np.full(per_pass, k))
    return np.concatenate(starts), np.concatenate(vectors), np.concatenate(owners)


def _distances(foot, x_s, own, a, e, pass_of, apart):
    """Each seed's distance to every piece: ``inf`` where of its pass, behind or too far."""
    f = np.clip(np.einsum("pij,ij->pi", foot[:, None] - a, e)
                / np.einsum("ij,ij->i", e, e), 0.0, 1.0)
    nearest = a + f[..., None] * e
    way = nearest - foot[:, None]
    dist = np.linalg.norm(way, axis=2)
    ok = (pass_of[None] != own[:, None]) & (np.einsum("pij,pj->pi", way, x_s) > 0.0)
    return np.where(ok & (dist <= apart), dist, np.inf)


def test_next_pieces_equal_the_nearest_piece_of_another_pass_ahead_among_all():
    rng = np.random.default_rng(5)
    a, e, pass_of = _passes(rng, 12, 100)
    m = 400
    own = rng.integers(0, 12, m)
    foot = np.column_stack([rng.uniform(0.5, 9.5, m), 0.3 * own, 0.2 * np.sin(5.0 + own)])
    x_s = np.tile([0.0, 1.0, 0.0], (m, 1)) * rng.choice([-1.0, 1.0], (m, 1))
    for apart, share in ((0.2, (0.0, 0.1)), (0.35, (0.5, 1.0)), (1.0, (0.5, 1.0))):
        cells = bin_samples(a + 0.5 * e, 2.0 * apart)
        got = next_pieces(foot, x_s, own, cells, apart, a, e, pass_of)
        dist = _distances(foot, x_s, own, a, e, pass_of, apart)
        least = dist.min(axis=1)
        np.testing.assert_array_equal(got >= 0, np.isfinite(least))
        # the nearest (of pieces equally near, as at a joint two pieces share, either)
        found = np.flatnonzero(got >= 0)
        np.testing.assert_array_equal(dist[found, got[found]], least[found])
        # (passes 0.3 mm apart: none within 0.2 mm; beyond, the first and last passes
        # have none on one side)
        assert share[0] <= np.mean(got >= 0) < share[1]
