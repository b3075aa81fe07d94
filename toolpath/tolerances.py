"""The small numbers that guard floating-point arithmetic, named once with their reasons.

The tolerances a user sets (scallop, chord, gouge) are options with units; these decide
what counts as zero, as the same value or as within a limit when numbers reach a test by
different routes. Doubles carry about 16 digits (``eps = 2.2e-16``): a quantity of order 1
(mm, deg, a parameter in [0, 1]) after a few hundred operations is good to about 1e-13.
Plain floats, so numba kernels read them as compile-time constants.
"""

from __future__ import annotations

__all__ = ["ANGLE_SLACK_DEG", "FLAT_PER_MM", "LENGTH_SLACK_MM", "LIMIT_SLACK", "NO_MEAN_AXIS",
           "NULL_VECTOR", "ROUND_OFF", "SAME_POINT_MM", "TINY"]

#: Floor of a denominator that can vanish (the length of a zero vector, the curvature of
#: a flat, a degenerate determinant): far below any value divided by (mm, rad, their
#: powers), it only keeps the quotient finite where the caller bounds or discards it.
TINY = 1e-300

#: Relative round-off of a quantity computed twice by different routes: about 5000 eps,
#: the error of a few hundred operations. Within it two values are the same one; a
#: determinant this small against its diagonal's product is singular.
ROUND_OFF = 1e-12

#: Two points closer than this (mm) are the same point (a repeated cutter location, a
#: segment of no length): a picometre, above the round-off of coordinates of a few hundred
#: mm (1e-13 mm) and far below any machine's resolution (1e-4 mm).
SAME_POINT_MM = 1e-12

#: How far (relative) a computed value may pass a limit it was built to meet and still
#: meet it: well above round-off (:data:`ROUND_OFF`), far below any limit a user sets
#: (rates, reach and lean are given to 1e-3 or so).
LIMIT_SLACK = 1e-9

#: :data:`LIMIT_SLACK` for angles, deg: above the round-off of an angle from ``atan2``
#: of unit vectors (1e-14 deg), and no turn at all on a machine (rotary resolution
#: 1e-3 deg).
ANGLE_SLACK_DEG = 1e-9

#: :data:`LIMIT_SLACK` for lengths, mm: a nanometre, far below a machine's resolution.
LENGTH_SLACK_MM = 1e-9

#: A curvature below this (1/mm: a radius over 1e12 mm) is a plane's: the formulas for a
#: curved surface would divide by it, and its sign (concave or convex) is round-off.
FLAT_PER_MM = 1e-12

#: A direction a user gives (the roughing ``up``, a fixed tool axis) with a norm below this
#: is none: such a vector is a typo or a zero, not a direction to normalise (a real one is
#: given to 1e-3 or so, and below 1e-9 its unit components are round-off of the input).
NULL_VECTOR = 1e-9

#: A weighted mean of two unit tool axes shorter than this has no direction: the axes are
#: (nearly) opposite, and normalising would amplify round-off by 1e6 or more; callers take
#: another direction (or skip the middle) instead.
NO_MEAN_AXIS = 1e-6
