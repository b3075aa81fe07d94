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

import numpy as np
from numpy.typing import NDArray

__all__ = ["line_capsule_interval"]

FloatArray = NDArray[np.float64]

#: Squared segment length (mm^2) below which a capsule is treated as a sphere: the side
#: equation divides by it.
_DEGENERATE_MM2 = 1e-18


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
    r2 = radius_mm * radius_mm
    m = points - a
    mm = np.einsum("ij,ij->i", m, m)
    md = np.einsum("ij,ij->i", m, dirs)
    me = np.einsum("ij,ij->i", m, e)
    de = np.einsum("ij,ij->i", dirs, e)
    del m
    lam_in = np.full(mm.shape, np.inf)
    lam_out = np.full(mm.shape, -np.inf)
    # sphere at A
    _take_roots(-md, md * md - (mm - r2), lam_in, lam_out)
    # sphere at B: m_B = m - D
    mdb = md - de
    _take_roots(-mdb, mdb * mdb - (mm - 2.0 * me + ee - r2), lam_in, lam_out)
    # side of the cylinder
    ok = ee > _DEGENERATE_MM2
    inv = np.divide(1.0, ee, out=np.zeros_like(ee), where=ok)
    qa = 1.0 - de * de * inv
    qb = md - me * de * inv
    disc = qb * qb - qa * (mm - me * me * inv - r2)
    ok &= (qa > 1e-12) & (disc >= 0.0)
    if ok.any():
        root = np.sqrt(np.where(ok, disc, 0.0))
        qa_safe = np.where(ok, qa, 1.0)
        for sign, out, pick in ((-1.0, lam_in, np.minimum), (1.0, lam_out, np.maximum)):
            lam = (-qb + sign * root) / qa_safe
            foot = (me + lam * de) * inv
            valid = ok & (foot >= 0.0) & (foot <= 1.0)
            pick(out, np.where(valid, lam, out), out=out)
    return lam_in, lam_out


def _take_roots(mid: FloatArray, disc: FloatArray, lam_in: FloatArray, lam_out: FloatArray) -> None:
    """Fold the sphere roots ``mid -/+ sqrt(disc)`` (where ``disc >= 0``) into the interval."""
    hit = disc >= 0.0
    root = np.sqrt(np.where(hit, disc, 0.0))
    np.minimum(lam_in, np.where(hit, mid - root, np.inf), out=lam_in)
    np.maximum(lam_out, np.where(hit, mid + root, -np.inf), out=lam_out)
