"""Corner rule sweep: thin round/elliptic noses read as corners, real corners missed.

Run ``python benchmarks/corner_sweep.py`` (a few seconds). It prints two counts for
:func:`toolpath.knots.detect_corners`:

- **noses read as corners**: half ellipses of vertex radius 0.05-0.3 mm, axes 1-4 : 1,
  6-20 points round at even arc length (or jittered by up to 30 % of the step, five seeds),
  between straight flanks sampled 0.5, 2 or 5 mm apart; any corner found is wrong;
- **real corners missed**: two sides meeting at 10-135 deg, straight or bent at R30 / R100
  mm (the incoming side away from the turn, the outgoing one with it), sampled 0.1, 0.5 or
  2 mm apart on either side, the corner at a sample or a quarter or half step between two;
  anything but exactly one corner is wrong;
- **wedges missed**: sharp trailing-edge wedges, convex flanks (straight, R30 or R100, both
  bending with the turn) meeting at 150 or 165 deg, sampled and placed as above.

``--noise-um`` adds Gaussian noise of that standard deviation to every point of every case
(seeded, so counts repeat); what that scatter may turn a sample is set aside
(:data:`toolpath.knots.SCATTER_CONTRAST`, :data:`toolpath.knots.SCATTER_SHARE`). Without
noise: 0, 12 and 0 failures; at 3 um 36, 129 and 12 (before the scatter was set aside
29, 166 and 20). ``--list`` prints each failure's case. Cases are built from
the traits (thin noses sampled with few points, tangent discontinuities between flanks),
not from any blade file.
"""

from __future__ import annotations

import argparse
import itertools

import numpy as np

from toolpath.knots import detect_corners
from toolpath.parametrize import unit_curve_parameters

NOSE_RADII_MM = (0.05, 0.1, 0.2, 0.3)
NOSE_ASPECTS = (1.0, 2.0, 3.0, 4.0)
NOSE_POINTS = (6, 8, 10, 12, 15, 20)
FLANK_STEPS_MM = (0.5, 2.0, 5.0)
JITTER_SEEDS = (None, 1, 2, 3, 4, 5)  # None: even arc length

CORNER_ANGLES_DEG = (10.0, 20.0, 45.0, 90.0, 135.0)
SIDE_RADII_MM = (None, 30.0, 100.0)
SIDE_STEPS_MM = (0.1, 0.5, 2.0)
CORNER_FRACTIONS = (0.0, 0.25, 0.5)
WEDGE_ANGLES_DEG = (150.0, 165.0)


def nose_section(vertex_radius_mm: float, n_round: int, aspect: float, flank_step_mm: float,
                 seed: int | None = None) -> np.ndarray:
    """Straight flanks 30 mm long either side of a half ellipse with semi-axes ``aspect``
    and ``aspect²`` times the vertex radius (vertex circle ``vertex_radius_mm``), sampled
    ``n_round`` points round at even arc length, or jittered by up to 30 % of the step."""
    b = vertex_radius_mm * aspect
    a = b * aspect
    theta = np.linspace(0.0, np.pi, 4001)
    arc = np.c_[-a * np.sin(theta), b * np.cos(theta)]
    s = np.concatenate(([0.0], np.cumsum(np.linalg.norm(np.diff(arc, axis=0), axis=1))))
    stations = np.linspace(0.0, s[-1], n_round)
    if seed is not None:
        step = s[-1] / (n_round - 1)
        jitter = np.random.default_rng(seed).uniform(-0.3, 0.3, n_round - 2) * step
        stations[1:-1] += jitter
    nose = arc[np.searchsorted(s, stations).clip(0, theta.size - 1)]
    x = flank_step_mm * np.arange(1, int(30.0 / flank_step_mm) + 1)
    return np.vstack((np.c_[x[::-1], np.full(x.size, b)], nose, np.c_[x, np.full(x.size, -b)]))


def corner_polyline(angle_deg: float, step_in_mm: float, step_out_mm: float,
                    fraction: float, side_radius_mm: float | None,
                    convex: bool = False) -> np.ndarray:
    """Two sides meeting at ``angle_deg``, at a sample (``fraction`` 0) or ``fraction`` of
    the incoming step past the last sample before it; sides straight or bent at
    ``side_radius_mm`` (the incoming one away from the turn, the outgoing one with it, or
    both with it when ``convex``)."""
    heading = np.radians(angle_deg)
    s_in = step_in_mm * np.arange(25, -1, -1) + fraction * step_in_mm
    s_out = step_out_mm * np.arange(26) + (1.0 - fraction) * step_out_mm
    bend = 0.0 if side_radius_mm is None else 1.0 / side_radius_mm
    incoming = np.c_[-s_in, (0.5 if convex else -0.5) * bend * s_in**2]
    out_dir = np.array([np.cos(heading), np.sin(heading)])
    out_normal = np.array([-out_dir[1], out_dir[0]])
    outgoing = s_out[:, None] * out_dir + (0.5 * bend * s_out**2)[:, None] * out_normal
    return np.vstack((incoming, outgoing if fraction else outgoing[1:]))


def _corners(points: np.ndarray, noise_mm: float, seed: int) -> int:
    if noise_mm > 0.0:
        points = points + np.random.default_rng(seed).normal(0.0, noise_mm, points.shape)
    return len(detect_corners(points, unit_curve_parameters(points)))


def nose_failures(noise_mm: float = 0.0) -> tuple[int, list[tuple]]:
    cases = list(itertools.product(NOSE_RADII_MM, NOSE_POINTS, NOSE_ASPECTS, FLANK_STEPS_MM,
                                   JITTER_SEEDS))
    return len(cases), [c for k, c in enumerate(cases)
                        if _corners(nose_section(*c[:4], seed=c[4]), noise_mm, k) != 0]


def corner_failures(noise_mm: float = 0.0) -> tuple[int, list[tuple]]:
    cases = list(itertools.product(CORNER_ANGLES_DEG, SIDE_STEPS_MM, SIDE_STEPS_MM,
                                   CORNER_FRACTIONS, SIDE_RADII_MM))
    return len(cases), [c for k, c in enumerate(cases)
                        if _corners(corner_polyline(*c), noise_mm, k) != 1]


def wedge_failures(noise_mm: float = 0.0) -> tuple[int, list[tuple]]:
    cases = list(itertools.product(WEDGE_ANGLES_DEG, SIDE_STEPS_MM, SIDE_STEPS_MM,
                                   CORNER_FRACTIONS, SIDE_RADII_MM))
    return len(cases), [c for k, c in enumerate(cases)
                        if _corners(corner_polyline(*c, convex=True), noise_mm, k) != 1]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--list", action="store_true", help="print each failing case")
    parser.add_argument("--noise-um", type=float, default=0.0,
                        help="Gaussian noise added to every point (um, standard deviation)")
    args = parser.parse_args()
    noise_mm = 1e-3 * args.noise_um
    total, noses = nose_failures(noise_mm)
    print(f"noses read as corners: {len(noses)} of {total}")
    if args.list:
        for case in noses:
            print("  radius_mm, n_round, aspect, flank_step_mm, seed =", case)
    total, corners = corner_failures(noise_mm)
    print(f"real corners missed:   {len(corners)} of {total}")
    if args.list:
        for case in corners:
            print("  angle_deg, step_in_mm, step_out_mm, fraction, side_radius_mm =", case)
    total, wedges = wedge_failures(noise_mm)
    print(f"wedges missed:         {len(wedges)} of {total}")
    if args.list:
        for case in wedges:
            print("  angle_deg, step_in_mm, step_out_mm, fraction, side_radius_mm =", case)


if __name__ == "__main__":
    main()
