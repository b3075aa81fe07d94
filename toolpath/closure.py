"""Is a curve (a blade section) closed? The seam rule for exported point sets.

A closed contour exported by a design tool or a CMM (TE -> suction side -> LE -> pressure
side -> TE) rarely repeats its first point: its last point stops a little short of it,
0.002-0.02 mm on a 100-150 mm contour, and the **closing step** from the last point back to
the first is then a step like the others. An open section with a blunt trailing edge
(the flat TE base left unsampled) also ends near its start, 0.05-0.5 mm away. The rule
tells them apart by what the closing step looks like beside its neighbours.

With ``g = |X_(n-1) − X_0|`` the closing step, ``h_min``, ``h_max`` the shorter and longer of
the two steps beside it (``|X_1 − X_0|`` and ``|X_(n-1) − X_(n-2)|``), ``L`` the length of
the open polygon and ``θ_a``, ``θ_b`` the turning angles at the two ends of the closing step
(between ``X_(n-1) − X_(n-2)`` and ``X_0 − X_(n-1)``, and between that and ``X_1 − X_0``):

- ``g <= CLOSURE_GAP_MM``: the first point **repeated** (closed; the last point is dropped);
- else **closed** when all of

  * ``g <= GAP_SPACING_FACTOR · h_max``: the closing step is no longer than a few local
    steps (a point or two missing at most), and
  * ``g <= GAP_LENGTH_FRACTION · L``: the ends nearly meet on the scale of the contour, and
  * the step is **not a blunt base**: a flat edge between two corners turns about 90° at
    both of its ends (``min(θ_a, θ_b) >= BLUNT_TURN_DEG``, and each turn beyond
    :data:`~toolpath.knots.SCATTER_CONTRAST` times what the points' scatter may turn it,
    :func:`~toolpath.scatter.scatter_turn_rad`: 3 um of scatter turned the DCA rotor's
    closing steps of 17 um by 50-62 deg); a smooth contour continues
    through both ends (both turns small), and a sharp edge sampled at the seam turns at
    one end only. A step turning sharply at both ends but much shorter than its
    neighbours (``g < EDGE_STEP_FRACTION · h_min``) is the tip of a sharp edge falling
    between two samples, not a base: closed.

- else **open**.

Measured (``python -m toolpath.closure FILE``): the DCA rotor closes with ``g`` 0.006-0.009
mm = 0.25-0.31 ``h_max``, turns 4.6-4.9° (closed); the propeller with an ordinary step
``g`` = 0.33 ``h_max``, turns 0.1° and 158-176° (the sharp TE at point 0: closed); the blunt
rotor's 0.4 mm base is 2.7 ``h_max`` and turns 83-86° at both ends (open); the dev blade's
unsampled 0.06-0.13 mm base is 2.1-4.0 ``h_max`` and turns 84-87° at both ends (open).
A sharp edge between two samples with a base of comparable length cannot be told from a
blunt base by the points: give ``--closed`` (``closed=True``) then.
"""

from __future__ import annotations

import sys
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from .knots import SCATTER_CONTRAST
from .scatter import point_wobble_mm, scatter_turn_rad

__all__ = [
    "BLUNT_TURN_DEG",
    "CLOSURE_GAP_MM",
    "EDGE_STEP_FRACTION",
    "GAP_LENGTH_FRACTION",
    "GAP_SPACING_FACTOR",
    "Seam",
    "close_loop",
    "read_seam",
]

#: A last point this close to the first (mm) repeats it: the loop is closed and the
#: duplicate dropped (a seam point 1 um from the first adds nothing a fit can use).
CLOSURE_GAP_MM = 1e-3
#: The closing step may be this many times the longer step beside it (a missing sample or
#: two; nose spacing of real exports is 0.01-0.03 mm and their gaps 0.002-0.02 mm).
GAP_SPACING_FACTOR = 3.0
#: ... and this fraction of the contour's length (5 mm on a 100 mm section at most: a seam
#: on a flank sampled 2.5 mm apart closes with a step of 1-2.5% of the contour).
GAP_LENGTH_FRACTION = 0.05
#: A closing step turning this much (deg) at both ends is a blunt base between two corners.
BLUNT_TURN_DEG = 45.0
#: ... unless it is shorter than this fraction of both steps beside it (a sharp edge whose
#: tip falls between two samples: the step crosses the wedge near its tip).
EDGE_STEP_FRACTION = 0.25


@dataclass(frozen=True)
class Seam:
    """How a curve ends next to its start: the figures of the rule and the verdict.

    Attributes
    ----------
    gap_mm : float
        ``g``, last point to first.
    steps_mm : tuple of float
        The steps beside the closing step: ``|X_1 − X_0|`` and ``|X_(n-1) − X_(n-2)|``.
    length_mm : float
        ``L``, the open polygon's length.
    turns_deg : tuple of float
        ``θ_a`` at the last point and ``θ_b`` at the first.
    repeated : bool
        The last point repeats the first (``g <= CLOSURE_GAP_MM``).
    closed : bool
        The verdict.
    reason : str
        Why, in words (for messages).
    """

    gap_mm: float
    steps_mm: tuple[float, float]
    length_mm: float
    turns_deg: tuple[float, float]
    repeated: bool
    closed: bool
    reason: str


def _turn_deg(u: NDArray[np.float64], v: NDArray[np.float64]) -> float:
    nu, nv = float(np.linalg.norm(u)), float(np.linalg.norm(v))
    if nu == 0.0 or nv == 0.0:
        return 0.0
    return float(np.degrees(np.arccos(np.clip(np.dot(u, v) / (nu * nv), -1.0, 1.0))))


def read_seam(points: NDArray[np.float64]) -> Seam:
    """Apply the seam rule (module docstring) to ordered, validated points ``(n, d)``."""
    p = np.asarray(points, dtype=float)
    steps = np.linalg.norm(np.diff(p, axis=0), axis=1)
    length = float(steps.sum())
    closing = p[0] - p[-1]
    gap = float(np.linalg.norm(closing))
    if gap <= CLOSURE_GAP_MM:
        return Seam(gap, (float(steps[0]), float(steps[-1])), length, (0.0, 0.0), True, True,
                    f"the last point repeats the first ({gap:.4g} mm apart)")
    if len(p) < 3:
        return Seam(gap, (float(steps[0]),) * 2, length, (0.0, 0.0), False, False,
                    "too few points for a closing step")
    # the steps beside the closing step; with a repeated point dropped these are its own
    first, last = float(steps[0]), float(steps[-1])
    turns = (_turn_deg(p[-1] - p[-2], closing), _turn_deg(closing, p[1] - p[0]))
    h_min, h_max = min(first, last), max(first, last)
    base = dict(gap_mm=gap, steps_mm=(first, last), length_mm=length, turns_deg=turns,
                repeated=False)
    if gap > GAP_SPACING_FACTOR * h_max:
        return Seam(**base, closed=False, reason=(
            f"the ends are {gap:.4g} mm apart, {gap / h_max:.3g} times the steps beside "
            f"them (at most {GAP_SPACING_FACTOR:g} closes)"))
    if gap > GAP_LENGTH_FRACTION * length:
        return Seam(**base, closed=False, reason=(
            f"the ends are {gap:.4g} mm apart, {100 * gap / length:.3g}% of the contour's "
            f"length (at most {100 * GAP_LENGTH_FRACTION:g}% closes)"))
    # what the points' scatter may turn each end (3 um turns steps of 20 um by tens of
    # degrees) is no evidence of a base's corners
    wobble = point_wobble_mm(p, steps)
    scatter_deg = np.degrees(SCATTER_CONTRAST * scatter_turn_rad(wobble, [last, gap],
                                                                  [gap, first]))
    least = np.maximum(BLUNT_TURN_DEG, scatter_deg)
    if all(np.asarray(turns) >= least) and gap >= EDGE_STEP_FRACTION * h_min:
        return Seam(**base, closed=False, reason=(
            f"the {gap:.4g} mm from the last point to the first turns {turns[0]:.1f} and "
            f"{turns[1]:.1f} deg at its ends: a blunt edge, not a closing step"))
    return Seam(**base, closed=True, reason=(
        f"the last point stops {gap:.4g} mm short of the first, a step like its neighbours "
        f"({first:.4g} and {last:.4g} mm), turning {turns[0]:.1f} and {turns[1]:.1f} deg"))


def close_loop(p: NDArray[np.float64]) -> NDArray[np.float64]:
    """A closed section with its first point repeated exactly at the end.

    A last point within :data:`CLOSURE_GAP_MM` of the first repeats it and is replaced;
    any other last point is a sample of its own, and the first point is appended after it.
    """
    if np.linalg.norm(p[-1] - p[0]) <= CLOSURE_GAP_MM:
        p = p[:-1]
    return np.vstack((p, p[:1]))


def _main(argv: list[str]) -> int:  # pragma: no cover - a measuring aid
    from .pointio import read_sections

    for path in argv:
        for j, section in enumerate(read_sections(path)):
            seam = read_seam(np.asarray(section, float))
            print(f"{path} section {j}: {'closed' if seam.closed else 'open'}: {seam.reason}")
    return 0


if __name__ == "__main__":  # pragma: no cover
    sys.exit(_main(sys.argv[1:]))
