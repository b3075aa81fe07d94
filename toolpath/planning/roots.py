"""Roots of many one-dimensional functions at once, each in its own bracket.

:func:`illinois_roots` closes brackets ``[pos, neg]`` with ``f(pos) >= 0 > f(neg)`` (the
ends may lie either way round on the axis) on every row at once, a vectorized call of
``f`` per step over the rows still open. Regula falsi with the Illinois rule: the next
point is the secant's root ``x = neg - f_neg (neg - pos) / (f_neg - f_pos)``, and where
the same end is kept twice running the value at the other end is halved, so that end
closes in too (superlinear where ``f`` is smooth, Dowell and Jarratt 1971). Where the
secant's root does not fall strictly inside the bracket (round-off, a step), and after
``secant_steps``, the bracket is bisected, which no crease, step or flat zero slows. A row
stops when its bracket is within ``x_tol`` or the value at its ``pos`` end, evaluated
here (never a given end), is within ``f_tol`` of 0 (with ``either_end``, at either end:
for a caller that takes whichever end it found nearer the root).

Used for the reach boundary of 3-axis passes (:mod:`.passes`) and for the cusp between
two passes (:mod:`.measure`).
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
from numpy.typing import NDArray

__all__ = ["illinois_roots"]


def illinois_roots(f: Callable[[NDArray[np.float64], NDArray[np.int64]], NDArray[np.float64]],
                   pos: NDArray[np.float64], neg: NDArray[np.float64],
                   f_pos: NDArray[np.float64], f_neg: NDArray[np.float64], *,
                   secant_steps: int, bisect_steps: int, x_tol: NDArray[np.float64] | float,
                   f_tol: float, either_end: bool = False
                   ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Close the brackets (module docstring); returns their ``pos`` and ``neg`` ends.

    Parameters
    ----------
    f : callable
        ``f(x, rows)``: the values at ``x`` of the functions of brackets ``rows``.
    pos, neg : ndarray, shape (m,)
        Bracket ends, ``f(pos) >= 0 > f(neg)``.
    f_pos, f_neg : ndarray, shape (m,)
        The values there.
    secant_steps : int
        Regula falsi steps (at most) before bisection.
    bisect_steps : int
        Bisection steps (at most) after them.
    x_tol : float or ndarray, shape (m,)
        A row stops when ``|pos - neg| <= x_tol``.
    f_tol : float
        ... or when ``f`` is within ``[0, f_tol]`` at its ``pos`` end, evaluated here.
    either_end : bool
        ... or within ``f_tol`` of 0 at either end, evaluated here.
    """
    pos, neg = np.array(pos, dtype=float), np.array(neg, dtype=float)
    v_pos, v_neg = np.array(f_pos, dtype=float), np.array(f_neg, dtype=float)
    tol = np.broadcast_to(np.asarray(x_tol, dtype=float), pos.shape)
    above = np.full(pos.size, np.inf)  # |f| at the end last evaluated here (pos: no either_end)
    last = np.zeros(pos.size, dtype=np.int64)  # the end replaced last: +1 pos, -1 neg

    def open_rows(rows: NDArray[np.int64]) -> NDArray[np.int64]:
        return rows[(np.abs(neg[rows] - pos[rows]) > tol[rows]) & (above[rows] > f_tol)]

    rows = open_rows(np.arange(pos.size))
    for step in range(secant_steps + bisect_steps):
        if not rows.size:
            break
        p, n, fp, fn = pos[rows], neg[rows], v_pos[rows], v_neg[rows]
        x = 0.5 * (p + n)
        if step < secant_steps:
            with np.errstate(divide="ignore", invalid="ignore"):
                secant = n - fn * (n - p) / (fn - fp)
            x = np.where((secant - p) * (n - secant) > 0.0, secant, x)
        fx = f(x, rows)
        up = fx >= 0.0
        on_pos, on_neg = rows[up], rows[~up]
        pos[on_pos], v_pos[on_pos], above[on_pos] = x[up], fx[up], fx[up]
        neg[on_neg], v_neg[on_neg] = x[~up], fx[~up]
        if either_end:
            above[on_neg] = -fx[~up]
        # Illinois: an end kept twice running halves the value at the other end
        v_neg[on_pos[last[on_pos] == 1]] *= 0.5
        v_pos[on_neg[last[on_neg] == -1]] *= 0.5
        last[rows] = np.where(up, 1, -1)
        rows = open_rows(rows)
    return pos, neg
