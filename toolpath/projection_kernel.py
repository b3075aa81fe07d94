"""The damped Newton step of the closest-point projection, and the closed-seam rule.

Both projections onto a surface take their steps here, so they cannot drift apart: the
compiled one (:mod:`toolpath.compiled`, point by point over a streamline surface's kernel)
and the numpy one (:func:`toolpath.planning.local.project_to_surface`, for surfaces without
a kernel, on rows of partials). The functions are numba kernels; the ``*_rows`` ones run
the same scalar rule over arrays for the numpy caller (:func:`seam_lerp_rows` in numpy,
from :func:`seam_lerp`'s own source). The scalar steps only kernels call
(:func:`newton_step`, :func:`trial`, :func:`clamp_s`, :func:`seam_lerp`,
:func:`near_seam`, :func:`other_face_nearer`, :func:`mirror_nearer`) are compiled without
the wrappers that let Python call them (not in ``__all__``; a first run compiled those
wrappers for each, issue 27); :func:`wrap_t`, :func:`no_farther`, :func:`other_face_t` and
:func:`seam_corner` keep theirs.

**Newton step.** The foot of ``p`` minimizes ``f(t, s) = |X(t, s) - p|^2 / 2``: with
``d = X - p`` the gradient is ``(d.X_t, d.X_s)`` and the Hessian
``[[E + d.X_tt, F + d.X_ts], [F + d.X_ts, G + d.X_ss]]`` (``E, F, G`` the first fundamental
form). The curvature terms matter: from a cutter centre 3 mm off a 0.3 mm leading edge the
first-order (Gauss-Newton) step overshoots tenfold. Where the Hessian is not positive
definite (determinant at most :data:`DEGENERATE_SHARE` of ``E G``, or ``H_tt <= 0``) the
Gauss-Newton matrix ``[[E, F], [F, G]]`` is used. The step is clipped to
:data:`STEP_CLIP` in each parameter; the caller halves it (up to :data:`HALVINGS` times)
while its point is farther from ``p`` than the current foot (:func:`no_farther`), so a step
past a sharp nose cannot land on the far side.

**Seam rule.** ``t`` runs round a closed section (``closed_t``) and wraps: a parameter is
folded by ``t - floor(t)`` (:func:`wrap_t`; clipped to [0, 1] on an open surface), and two
parameters are interpolated the short way across the seam (:func:`seam_lerp`). ``s`` is
never closed: it is clipped (:func:`clamp_s`).

**Seam faces.** Round a thin closed section (a blade's trailing edge) the face across the
seam holds a local minimum of the distance too: a search started there (a move's ends
interpolated across the seam) settles on the wrong face, whose normal reads a point beside
the right one as inside the part by about the edge's thickness (a flat end on a propeller
read 1.4 mm deep). A foot found within :data:`SEAM_SEARCH_T` of the seam is therefore
searched for from the other face too (from :func:`other_face_t`) and the nearer of the two
kept (:func:`other_face_nearer`), signed by its own face's normal. So is a foot farther out
that reads the point inside by more than the point lies from the foot's mirror ``X(1 - t,
s)`` (:func:`mirror_nearer`): deeper than the section is thick there, so beyond the other
face (a true foot 0.05-0.065 from the seam, the wrong one at its mirror just outside the
window, read 2-4 mm deep from points 2 um outside).

**Seam corner.** A closed section may have a corner at its seam, where the foot kept is
replaced by the seam point when that is no farther (:func:`seam_corner`).
"""

from __future__ import annotations

import math

import numba
import numpy as np

from .tolerances import ROUND_OFF, TINY

__all__ = [
    "DEGENERATE_SHARE",
    "HALVINGS",
    "NO_FARTHER_SHARE",
    "SEAM_BEFORE_T",
    "SEAM_SEARCH_T",
    "SEAM_SLACK_MM",
    "STEP_CLIP",
    "halve_rows",
    "newton_step_rows",
    "no_farther",
    "mirror_nearer_rows",
    "other_face_nearer_rows",
    "other_face_t",
    "seam_corner",
    "seam_corner_rows",
    "seam_lerp_rows",
    "wrap_t",
]

#: Largest Newton step in either parameter (both span [0, 1]): a quarter of the domain. A
#: step from a poor start (the Hessian's model far off, near a leading edge) stays in the
#: neighbourhood its partials describe, and round a closed section never jumps to the
#: far side of the seam.
STEP_CLIP = 0.25
#: Halvings of a step that would move the foot away from ``p`` before the last one is
#: taken as it is: ``2^-8`` of :data:`STEP_CLIP` is about 0.001 in a parameter, under a
#: tenth of a millimetre on a blade, where the next full step takes over.
HALVINGS = 8
#: The Hessian counts as not positive definite where its determinant is at most this share
#: of the Gauss-Newton one (``E G``): relative round-off of the 2 x 2 determinant, scale free.
DEGENERATE_SHARE = ROUND_OFF
#: A trial point counts as no farther than the current foot where its squared distance is
#: larger by at most this share: the round-off of evaluating it, so a converged foot is kept.
NO_FARTHER_SHARE = ROUND_OFF


@numba.njit(cache=True)
def wrap_t(t, closed):
    """``t`` folded into the domain: ``t - floor(t)`` on closed sections, else clipped."""
    if closed:
        return t - math.floor(t)
    return min(max(t, 0.0), 1.0)


@numba.njit(cache=True, no_cpython_wrapper=True, no_cfunc_wrapper=True)
def clamp_s(s):
    """``s`` clipped to [0, 1] (``s`` runs between end sections: never closed)."""
    return min(max(s, 0.0), 1.0)


@numba.njit(cache=True, no_cpython_wrapper=True, no_cfunc_wrapper=True)
def seam_lerp(ta, tb, f, closed):
    """The parameter a fraction ``f`` from ``ta`` to ``tb``: across the seam the short way.

    On closed sections ``tb`` is first moved by a whole turn to within 0.5 of ``ta`` and
    the result folded by :func:`wrap_t`; on open ones the plain interpolation. (Written
    without branches on the values, so that its Python source runs on arrays too:
    :func:`seam_lerp_rows`.)
    """
    if closed:
        tb = tb - (tb - ta > 0.5) + (ta - tb > 0.5)
    t = ta * (1.0 - f) + tb * f
    return t - np.floor(t) if closed else t


@numba.njit(cache=True, no_cpython_wrapper=True, no_cfunc_wrapper=True)
def newton_step(fr, j, p, i):
    """The clipped Newton step towards the foot of ``p[i]`` and ``|X - p|^2`` now.

    ``fr[:, j]`` holds ``X, X_t, X_s, X_tt, X_ts, X_ss`` (that order,
    :data:`toolpath.compiled.ORDERS`) at the current ``(t, s)``. Returns ``step_t, step_s``
    (to subtract from ``t, s``: :func:`trial`) and the squared distance (mm^2). The step is
    the one of the module docstring.
    """
    d0 = fr[0, j, 0] - p[i, 0]
    d1 = fr[0, j, 1] - p[i, 1]
    d2 = fr[0, j, 2] - p[i, 2]
    xt0, xt1, xt2 = fr[1, j, 0], fr[1, j, 1], fr[1, j, 2]
    xs0, xs1, xs2 = fr[2, j, 0], fr[2, j, 1], fr[2, j, 2]
    e_ = xt0 * xt0 + xt1 * xt1 + xt2 * xt2
    f_ = xt0 * xs0 + xt1 * xs1 + xt2 * xs2
    g_ = xs0 * xs0 + xs1 * xs1 + xs2 * xs2
    g1 = d0 * xt0 + d1 * xt1 + d2 * xt2
    g2 = d0 * xs0 + d1 * xs1 + d2 * xs2
    h11 = e_ + d0 * fr[3, j, 0] + d1 * fr[3, j, 1] + d2 * fr[3, j, 2]
    h12 = f_ + d0 * fr[4, j, 0] + d1 * fr[4, j, 1] + d2 * fr[4, j, 2]
    h22 = g_ + d0 * fr[5, j, 0] + d1 * fr[5, j, 1] + d2 * fr[5, j, 2]
    det = h11 * h22 - h12 * h12
    if det <= DEGENERATE_SHARE * (e_ * g_ + TINY) or h11 <= 0.0:
        h11, h12, h22 = e_, f_, g_
    det = max(h11 * h22 - h12 * h12, TINY)
    step_t = min(max((h22 * g1 - h12 * g2) / det, -STEP_CLIP), STEP_CLIP)
    step_s = min(max((h11 * g2 - h12 * g1) / det, -STEP_CLIP), STEP_CLIP)
    return step_t, step_s, d0 * d0 + d1 * d1 + d2 * d2


@numba.njit(cache=True, no_cpython_wrapper=True, no_cfunc_wrapper=True)
def trial(t, s, step_t, step_s, closed):
    """The parameters a step leads to, kept in the domain (the seam rule)."""
    return wrap_t(t - step_t, closed), clamp_s(s - step_s)


@numba.njit(cache=True)
def no_farther(dist2, here):
    """Whether a trial point at squared distance ``dist2`` is no farther than ``here``.

    (Scalars or arrays alike.)
    """
    return dist2 <= here * (1.0 + NO_FARTHER_SHARE)


@numba.njit(cache=True)
def newton_step_rows(fr, p, t, s, closed, step_t, step_s, here, new_t, new_s):
    """:func:`newton_step` and :func:`trial` at every row: into the last five arrays."""
    for j in range(p.shape[0]):
        a, b, h = newton_step(fr, j, p, j)
        step_t[j], step_s[j], here[j] = a, b, h
        new_t[j], new_s[j] = trial(t[j], s[j], a, b, closed)


@numba.njit(cache=True)
def halve_rows(rows, t, s, closed, step_t, step_s, new_t, new_s):
    """At ``rows``: the steps halved and their :func:`trial` points, in place."""
    for j in rows:
        step_t[j] *= 0.5
        step_s[j] *= 0.5
        new_t[j], new_s[j] = trial(t[j], s[j], step_t[j], step_s[j], closed)


def seam_lerp_rows(ta, tb, u, closed):
    """:func:`seam_lerp` from ``ta[j]`` to ``tb[j]`` at each fraction ``u[j, q]``: (m, k).

    In numpy: :func:`seam_lerp`'s own source on arrays (the same numbers; a compiled loop
    would cost more to load in a fresh process than these few array operations).
    """
    ta, tb = np.asarray(ta, dtype=float), np.asarray(tb, dtype=float)
    return seam_lerp.py_func(ta[:, None], tb[:, None], np.asarray(u, dtype=float), bool(closed))


#: ``t`` just before a closed surface's seam: its normal there is the one from below.
SEAM_BEFORE_T = 1.0 - 1e-12
#: A foot found within this of a closed surface's seam (in ``t``) is searched for from the
#: other face too and compared with the seam point (module docstring). A search started
#: across the seam settles on the far face at the mirror of the true foot (dev_prop_7x100,
#: brute force: from ``t = 0.02`` a point beside ``t = 0.97``), and a foot stalled at the
#: corner lands up to ``HALVINGS`` halvings of :data:`STEP_CLIP` (0.001) off it: a window
#: of a twentieth of the section (5-10 mm round a blade) holds both, for one more search.
#: A mirror settled just beyond it is caught by the depth it reads (:func:`mirror_nearer`).
SEAM_SEARCH_T = 0.05
#: The seam point is taken where no farther than the foot found by more than this (mm).
SEAM_SLACK_MM = 1e-6


@numba.njit(cache=True, no_cpython_wrapper=True, no_cfunc_wrapper=True)
def near_seam(t):
    """Whether a foot at ``t`` is within :data:`SEAM_SEARCH_T` of a closed surface's seam."""
    return min(t, 1.0 - t) <= SEAM_SEARCH_T


@numba.njit(cache=True)
def other_face_t(t):
    """Where the search from the other face of the seam starts: ``t`` mirrored, ``1 - t``.

    The same distance from the seam on its other side; a foot on the seam itself (``t = 0``)
    mirrors to :data:`SEAM_BEFORE_T`, just before it (1 would fold back onto 0). (Scalars
    or arrays alike.)
    """
    return np.minimum(1.0 - t, SEAM_BEFORE_T)


@numba.njit(cache=True, no_cpython_wrapper=True, no_cfunc_wrapper=True)
def other_face_nearer(p, foot, other):
    """Whether the foot ``other`` (found from the other face) is nearer ``p`` than ``foot``.

    Both are local minima of the distance (or stalled beside the seam's corner); the nearer
    is the closest point there, and its own face's normal signs it.
    """
    a = 0.0
    b = 0.0
    for k in range(3):
        a += (p[k] - foot[k]) ** 2
        b += (p[k] - other[k]) ** 2
    return b < a


@numba.njit(cache=True)
def other_face_nearer_rows(p, foot, other, out):
    """:func:`other_face_nearer` at each row of (n, 3) arrays, into the bool array ``out``."""
    for j in range(p.shape[0]):
        out[j] = other_face_nearer(p[j], foot[j], other[j])


@numba.njit(cache=True, no_cpython_wrapper=True, no_cfunc_wrapper=True)
def mirror_nearer(p, mirror, signed):
    """Whether ``p``, read ``signed`` (mm) from its foot ``X(t, s)``, is nearer the mirror.

    ``mirror`` is ``X(1 - t, s)``, the point across the seam as far from it as the foot (on a
    thin section about the other face's foot of ``p``). A point read inside (``signed < 0``)
    that lies nearer the mirror than ``|signed|`` (its distance from an orthogonal foot) is
    not at its closest point: the read depth exceeds the section's thickness there, and the
    foot is a wrong face's, its search settled beyond :data:`SEAM_SEARCH_T`. A point read
    outside is never re-searched this way (one surface point, only for points read inside).
    """
    if signed >= 0.0:
        return False
    d2 = 0.0
    for k in range(3):
        d2 += (p[k] - mirror[k]) ** 2
    return d2 < signed * signed


@numba.njit(cache=True)
def mirror_nearer_rows(p, mirror, signed, out):
    """:func:`mirror_nearer` at each row of (n, 3) arrays, into the bool array ``out``."""
    for j in range(p.shape[0]):
        out[j] = mirror_nearer(p[j], mirror[j], signed[j])


@numba.njit(cache=True)
def seam_corner(p, foot, seam_x, n_before, n_after):
    """The seam point instead of a foot beside it, and its signed distance (mm).

    A closed section may have a corner at its seam (a sharp trailing edge: the periodic
    fit keeps a seam knot of full multiplicity, the surface only ``C0`` there), where the
    normal jumps between its one-sided values ``n-`` (``t -> 1``, at
    :data:`SEAM_BEFORE_T`) and ``n+`` (``t -> 0``), by up to 180 deg round a knife edge.
    A point beside the edge whose closest point is the corner itself (a cutter resting on
    the edge) has no orthogonal foot: the Newton search stalls beside the corner, and the
    normal of one side reads it as cut into the part. For the foot ``X`` kept
    :func:`near_seam` (the nearer of both faces') the seam point ``X(0, s)`` is taken
    instead where it is no farther from ``p`` (to :data:`SEAM_SLACK_MM`); there the
    distance is ``|p - X|`` signed by ``(p - X) . (n- + n+)`` (outside a convex corner
    exactly when ``p - X`` is in the normals' cone; on a smooth seam, ``n- = n+``, the
    usual ``(p - X) . n``).

    ``p``, ``foot``, ``seam_x`` points (mm), the normals outward unit vectors (3,).
    Returns whether the seam point is taken and its signed distance (0 where not).
    """
    f0, f1, f2 = p[0] - foot[0], p[1] - foot[1], p[2] - foot[2]
    d0, d1, d2 = p[0] - seam_x[0], p[1] - seam_x[1], p[2] - seam_x[2]
    size = math.sqrt(d0 * d0 + d1 * d1 + d2 * d2)
    if size > math.sqrt(f0 * f0 + f1 * f1 + f2 * f2) + SEAM_SLACK_MM:
        return False, 0.0  # a foot off the seam, nearer: on a face
    side = (d0 * (n_before[0] + n_after[0]) + d1 * (n_before[1] + n_after[1])
            + d2 * (n_before[2] + n_after[2]))
    return True, size if side >= 0.0 else -size


@numba.njit(cache=True)
def seam_corner_rows(p, foot, seam_x, n_before, n_after, rows, t, signed):
    """:func:`seam_corner` at each of ``rows`` (arrays of (n, 3)); ``t``, ``signed`` in place.

    Where the seam point is taken, ``t[row]`` becomes 0 and ``signed[row]`` its distance.
    """
    for j in range(rows.size):
        row = rows[j]
        at_seam, value = seam_corner(p[row], foot[row], seam_x[j], n_before[j], n_after[j])
        if at_seam:
            t[row], signed[row] = 0.0, value
