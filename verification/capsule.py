r"""Where a line enters and leaves a capsule: the one geometric kernel of the sweep.

A ball of radius ``R`` whose centre moves on a straight segment ``A -> B`` sweeps exactly
the capsule ``{X : dist(X, [A, B]) <= R}``, so every piece of the swept cutter is a capsule:
the ball between two tool instances, and the shank (a cylinder of the same radius above the
ball centre, written as a capsule whose extra top cap is harmless: the holder is there).

For the line ``X(lam) = P + lam d`` (``|d| = 1``), with ``m = P - A`` and ``D = B - A``:

* end spheres: ``|m + lam d|^2 = R^2`` and ``|m - D + lam d|^2 = R^2``, roots
  ``lam = -b +/- sqrt(b^2 - c)``;
* the side: the distance to the line ``AB`` equals ``R``:
  ``qa lam^2 + 2 qb lam + qc = 0`` with ``qa = 1 - (d.D)^2/|D|^2``,
  ``qb = m.d - (m.D)(d.D)/|D|^2``, ``qc = |m|^2 - (m.D)^2/|D|^2 - R^2``; a root counts only
  when its foot ``((m + lam d).D)/|D|^2`` lies in ``[0, 1]``.

The capsule is convex, so the line meets it in one interval; its ends are the smallest
entry and the largest exit over the three parts (an entry through a flat end of the
finite cylinder lies inside an end sphere, whose entry comes first).

Arrays hold one row per pair, ``(m, 3)``; the segment vector ``D`` and ``|D|^2`` are
precomputed per piece.

Examples
--------
>>> import numpy as np
>>> p = np.array([[0.0, 0.0, 0.0]])     # a point on the plane z = 0
>>> d = np.array([[0.0, 0.0, 1.0]])     # its dexel points up
>>> a = np.array([[-5.0, 0.5, 3.0]])    # ball centre line at height R = 3,
>>> e = np.array([[10.0, 0.0, 0.0]])    # 0.5 mm to the side, 10 mm long
>>> lam_in, lam_out = line_capsule_interval(p, d, a, e, (e * e).sum(axis=1), 3.0)
>>> round(float(lam_in[0]), 6), round(3 - (9 - 0.25) ** 0.5, 6)
(0.04196, 0.04196)
"""

from __future__ import annotations

import math

import numba
import numpy as np
from numpy.typing import NDArray

__all__ = ["capsule_interval", "line_capsule_interval"]

FloatArray = NDArray[np.float64]

#: Squared segment length (mm^2) below which a capsule is treated as a sphere: the side
#: equation divides by it.
_DEGENERATE_MM2 = 1e-18


@numba.njit(cache=True)
def capsule_interval(px: float, py: float, pz: float, dx: float, dy: float, dz: float,
                     ax: float, ay: float, az: float, ex: float, ey: float, ez: float,
                     ee: float, r2: float) -> tuple[float, float]:
    """Entry and exit of one line ``P + lam d`` through one capsule (module formulas).

    Scalars: ``P``, ``d``, ``A``, ``D = B - A``, ``|D|^2`` and ``R^2``; ``(+inf, -inf)``
    where the line misses. The one implementation: :func:`line_capsule_interval` runs it
    over arrays and :mod:`verification.capsule_search` inside its grid walk.
    """
    mx, my, mz = px - ax, py - ay, pz - az
    mm = mx * mx + my * my + mz * mz
    md = mx * dx + my * dy + mz * dz
    me = mx * ex + my * ey + mz * ez
    de = dx * ex + dy * ey + dz * ez
    lam_in, lam_out = math.inf, -math.inf
    disc = md * md - (mm - r2)  # sphere at A
    if disc >= 0.0:
        root = math.sqrt(disc)
        lam_in, lam_out = -md - root, -md + root
    mdb = md - de  # sphere at B: m_B = m - D
    disc = mdb * mdb - (mm - 2.0 * me + ee - r2)
    if disc >= 0.0:
        root = math.sqrt(disc)
        lam_in, lam_out = min(lam_in, -mdb - root), max(lam_out, -mdb + root)
    if ee > _DEGENERATE_MM2:  # side of the cylinder
        inv = 1.0 / ee
        qa = 1.0 - de * de * inv
        qb = md - me * de * inv
        disc = qb * qb - qa * (mm - me * me * inv - r2)
        if qa > 1e-12 and disc >= 0.0:
            root = math.sqrt(disc)
            lam = (-qb - root) / qa
            foot = (me + lam * de) * inv
            if 0.0 <= foot <= 1.0:
                lam_in = min(lam_in, lam)
            lam = (-qb + root) / qa
            foot = (me + lam * de) * inv
            if 0.0 <= foot <= 1.0:
                lam_out = max(lam_out, lam)
    return lam_in, lam_out


@numba.njit(cache=True, parallel=True)
def _intervals(points: FloatArray, dirs: FloatArray, a: FloatArray, e: FloatArray,
               ee: FloatArray, r2: float, lam_in: FloatArray, lam_out: FloatArray) -> None:
    for i in numba.prange(points.shape[0]):
        lam_in[i], lam_out[i] = capsule_interval(
            points[i, 0], points[i, 1], points[i, 2], dirs[i, 0], dirs[i, 1], dirs[i, 2],
            a[i, 0], a[i, 1], a[i, 2], e[i, 0], e[i, 1], e[i, 2], ee[i], r2)


def line_capsule_interval(
    points: FloatArray, dirs: FloatArray, a: FloatArray, e: FloatArray, ee: FloatArray,
    radius_mm: float,
) -> tuple[FloatArray, FloatArray]:
    """Entry and exit parameters of lines through capsules, pairwise.

    Parameters
    ----------
    points : ndarray, shape (m, 3)
        Line origins ``P``, mm.
    dirs : ndarray, shape (m, 3)
        Unit line directions ``d``.
    a : ndarray, shape (m, 3)
        Segment starts ``A`` (ball centres), mm.
    e : ndarray, shape (m, 3)
        Segment vectors ``D = B - A``, mm.
    ee : ndarray, shape (m,)
        ``|D|^2``, mm^2.
    radius_mm : float
        Capsule radius ``R``, mm.

    Returns
    -------
    lam_in, lam_out : ndarray, shape (m,)
        Signed distances along ``d`` from ``P`` where the line enters and leaves the
        capsule, mm; ``+inf`` and ``-inf`` where it misses.
    """
    m = np.asarray(ee).shape[0]
    lam_in = np.empty(m)
    lam_out = np.empty(m)
    f = np.ascontiguousarray
    _intervals(f(points, dtype=np.float64), f(dirs, dtype=np.float64),
               f(a, dtype=np.float64), f(e, dtype=np.float64), f(ee, dtype=np.float64),
               float(radius_mm) ** 2, lam_in, lam_out)
    return lam_in, lam_out
