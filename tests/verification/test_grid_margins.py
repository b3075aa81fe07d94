"""The grids' margins: a search sees every piece within its reach, as one over all pieces.

A grid holds the pieces (runs of pieces) whose midpoints lie within its margin of the
samples' box (:func:`~verification.dexels.grid_margin_mm`). Pieces just outside the box
still reach into it: a near search's centre ``P + r n`` stands ``r`` beyond the box, and
a flat or bull-nose cutter's flank (or its shank) stands up to its core height along its
axis above the piece's segment. Each search here is compared with the same search over
every piece (brute force, no grid).
"""

import numpy as np
import pytest

from verification.dexels import SweepIndex, _values
from verification.options import DexelMethod
from verification.pieces import Pieces
from verification.search import Dexels
from verification.torus import line_sweep_interval
from verification.vectors import row_norms

RADIUS_MM = 3.0
HORIZON_MM = 0.1
DEPTH_MM = 0.05
LO, HI = np.zeros(3), np.array([10.0, 2.0, 0.0])


def _pieces(a, e, axis, height_mm, *, shank=False):
    """Pieces from core bottom centres ``a``, chords ``e`` and axes, in path order."""
    a, e = np.asarray(a, dtype=float), np.asarray(e, dtype=float)
    m = a.shape[0]
    axis = np.broadcast_to(np.asarray(axis, dtype=float), (m, 3)).copy()
    ee = np.einsum("ij,ij->i", e, e)
    return Pieces(a, e, ee, a + 0.5 * e, 0.5 * np.sqrt(ee), np.arange(m, dtype=np.int64),
                  np.full(m, shank), axis, np.full(m, np.nan), np.full(m, np.nan),
                  np.zeros(1), np.zeros(1, dtype=np.int64), np.full(m, float(height_mm)))


def _along_y(x_mm, z_mm, *, step_mm=0.1):
    """Core centres moving along +y across the box (and 1 mm past it), short pieces."""
    y = np.arange(-1.0, HI[1] + 1.0, step_mm)
    a = np.column_stack((np.full(y.shape, x_mm), y, np.full(y.shape, z_mm)))
    return a, np.tile([0.0, step_mm, 0.0], (y.shape[0], 1))


def _plane_samples(step_mm=0.25, *, hi_x=HI[0]):
    x, y = np.meshgrid(np.arange(LO[0], hi_x + 1e-9, step_mm),
                       np.arange(LO[1], HI[1] + 1e-9, step_mm), indexing="ij")
    points = np.column_stack((x.ravel(), y.ravel(), np.zeros(x.size)))
    return points, np.tile([0.0, 0.0, 1.0], (points.shape[0], 1))


def _brute_force(points, dirs, pieces, corner_mm):
    """The least material any piece leaves on each dexel: every pair measured."""
    q, m = points.shape[0], pieces.size
    qi, pi = np.repeat(np.arange(q), m), np.tile(np.arange(m), q)
    axis = pieces.axis[pi]
    lam_in, lam_out = line_sweep_interval(
        points[qi], dirs[qi], pieces.a[pi], pieces.e[pi], axis, pieces.height_mm[pi],
        core_radius_mm=RADIUS_MM - corner_mm, corner_radius_mm=corner_mm,
        exit_wanted=np.einsum("ij,ij->i", axis, dirs[qi]) < -0.5)
    value, _ = _values(lam_in, lam_out, axis, dirs[qi])
    return value.reshape(q, m).min(axis=1)


def _dexels(ball, shank, corner_mm, compiled, *, hi=HI):
    # the reach limit the verifier gave before the margins counted the centre's offset
    # and the cores' height: the grids must hold what the searches reach all the same
    index = SweepIndex(ball, shank, RADIUS_MM, LO, hi, base_cell_mm=0.25,
                       reach_limit_mm=RADIUS_MM + HORIZON_MM + DEPTH_MM,
                       corner_radius_mm=corner_mm, compiled=compiled)
    return Dexels(index, RADIUS_MM, (HORIZON_MM,), DEPTH_MM, DexelMethod.NORMAL,
                  corner_radius=corner_mm)


def _assert_sees_every_value(found, brute):
    """Every value within the horizon found, and none lower than a piece leaves."""
    within = brute <= HORIZON_MM
    assert within.sum() >= 9  # the flank meets a strip of samples along the box's edge
    np.testing.assert_allclose(found[within], brute[within], rtol=0.0, atol=1e-9)
    assert np.all(found >= brute - 1e-9)


@pytest.mark.parametrize("compiled", [True, False])
def test_a_shank_rubbing_the_boxs_edge_from_far_beyond_is_seen_by_the_collision_search(
        compiled):
    # a flat end mill lying on its side, its tip 20 mm beyond the box: its shank (24 mm of
    # flank) rubs the plane 0.01 mm deep over x in [5.5, 9.5], the cutter's end, far out,
    # nothing. The core bottom centres stand beyond the margin that left out the height
    # (R + e + g + h) and the grid's last whole cell (16 mm for this search's reach): the
    # pair search missed the rub (the runs' grid, wider by the runs' spread, held it)
    corner = 0.0
    hi_x = 9.5
    a, e = _along_y(hi_x + 20.0, RADIUS_MM - 0.01)
    ball = _pieces(a, e, [-1.0, 0.0, 0.0], RADIUS_MM)
    shank = _pieces(a, e, [-1.0, 0.0, 0.0], 24.0, shank=True)
    points, normals = _plane_samples(hi_x=hi_x)
    ev = _dexels(ball, shank, corner, compiled, hi=np.array([hi_x, HI[1], HI[2]]))
    found = ev.search(points, normals, np.zeros(points.shape[0]), near=False, far=True)
    brute = _brute_force(points, normals, ball.concat(shank), corner)
    assert brute.min() == pytest.approx(-0.01, abs=1e-6)
    _assert_sees_every_value(found.lam_mm, brute)
    assert found.shank[np.isfinite(found.lam_mm)].all()


def test_pieces_within_a_ball_search_around_centres_beyond_the_box_are_all_found():
    # ball pieces all around the box; searches around P + R n on the box's top face and
    # its x ends, R + e + g wide: as far beyond the box as 2 R + e + g
    rng = np.random.default_rng(7)
    a = rng.uniform(LO - 8.0, HI + 8.0, (20000, 3))
    e = rng.normal(0.0, 0.05, (20000, 3))
    ball = _pieces(a, e, [0.0, 0.0, 1.0], 0.0)
    index = SweepIndex(ball, ball.taken(np.zeros(ball.size, dtype=bool)), RADIUS_MM, LO, HI,
                       base_cell_mm=0.25, reach_limit_mm=RADIUS_MM + HORIZON_MM + DEPTH_MM)
    points, normals = _plane_samples(0.5)
    normals[points[:, 0] == LO[0]] = [-1.0, 0.0, 0.0]
    normals[points[:, 0] == HI[0]] = [1.0, 0.0, 0.0]
    centres = points + RADIUS_MM * normals
    radii = np.full(points.shape[0], RADIUS_MM + HORIZON_MM + DEPTH_MM)
    found = index.pieces_within("near", centres, radii)
    # every piece whose segment comes within the radius of a centre (heights are 0)
    v = centres[:, None, :] - ball.a[None, :, :]
    f = np.clip(np.einsum("qmi,mi->qm", v, ball.e) / ball.ee, 0.0, 1.0)
    gap = row_norms((v - f[..., None] * ball.e[None]).reshape(-1, 3)).reshape(f.shape)
    brute = np.flatnonzero((gap <= radii[:, None]).any(axis=0))
    assert brute.shape[0] > 100
    np.testing.assert_array_equal(found, brute)
