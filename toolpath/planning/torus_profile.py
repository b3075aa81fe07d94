"""Where two passes of a flat or bull-nose cutter meet across the passes: the profile ridge.

The cutter (radius ``R``, corner radius ``r``, flute length ``L``, axis ``a``) is the union
of the balls of radius ``r`` round its ring circle ``{C + (R - r)(cos phi e1 + sin phi
e2)}`` (``e1, e2`` unit, across ``a``; ``C`` the ring centre, ``r`` up the axis from the
tip), the disk they bound, and that lifted along ``a`` up to ``L - r``. A straight move
along ``u`` sweeps it into a prism whose section in the plane across ``u`` is the solid's
projection along ``u``: with ``x, y`` the plane's axes (``y`` the surface normal's part
across ``u``, away from the surface) and ``P`` the projection onto them, the ring circle
projects to the ellipse ``E = {C + M (cos phi, sin phi)}``, ``M = (R - r) [P e1, P e2]``
(semi-axes ``R - r`` and ``(R - r) |a . u|``), and the section is ``E`` filled, widened
by ``r``, lifted by up to ``L - r`` along ``P a``: convex, with the boundary point of
outward normal ``m`` (unit, 2-D)

    ``b(m) = C + S m / sqrt(m' S m) + r m + (L - r) P a [m . P a > 0]``,  ``S = M M'``

(the support point; its radius of curvature ``det(M)^2 / (m' S m)^(3/2) + r``, at the
ellipse's minor axis ``(R - r) / |a . u| + r``: the cutter's effective radius across the
pass). :func:`profile_ridges` meets two such sections, the seed's own pass's and the next
pass's, where their sides facing each other cross nearest the surface: the bottom of the
cusp's ridge, as two tubes' circles meet for a ball. A prism along another way ``w`` meets
the plane across ``u`` in the solid's projection along ``w`` (oblique: ``P`` as above with
``v - (v . u) / (w . u) w`` for ``v``), the ring's ellipse then ``S = (R - r)^2 P (I - a a')
P'`` and the corner's ``r^2 P P'``, no longer a circle.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np
from numpy.typing import NDArray

from ..tolerances import TINY
from ..vectors import unit
from .torus_kernel import disk_crossings, running_bounds, section_sides, side_crossings

__all__ = ["LEAST_WAY_COSINE", "POSE_OFF_PLANE_SHARE", "PROFILE_SAMPLES", "RidgeProfile",
           "SECTION_EVEN_STEPS", "SECTION_LEVELS", "SECTION_RING_SAMPLES", "SECTION_STEPS",
           "pose_section_ridges", "profile_ridges"]

#: Boundary points per section side. Their normals turn from ``0.25 pi/2`` past straight
#: down to horizontal, spaced as the square of an even step (dense near the contact,
#: where a large effective radius puts the ridge a few hundredths of a radian round):
#: the chords between them lie inside the convex section, so the ridge reads at most
#: their sag high, under a per cent of the cusp on the sweep's cutters and requests.
PROFILE_SAMPLES = 64

#: A pass's section is met only where its way crosses the plane within 60 degrees of
#: square (its cosine to the plane's normal at least this): the projection along the way
#: widens the section by ``1 / cos``, twice at 60 degrees, and a pass that aslant to the
#: seed's line of ``t`` is turning or linking, no straight prism: the ray cast decides.
LEAST_WAY_COSINE = 0.5

#: The next pass's section about its pose's centre carried along the own way is taken
#: too where that centre stands off the plane by more than this share of ``R`` (a lead
#: puts it ``2 (R - r) cos(lead)`` off, a contact across the pass a few hundredths): there
#: the two ways carry it apart; nearer, they carry it alike and its own way's prism holds.
POSE_OFF_PLANE_SHARE = 0.25


class RidgeProfile(NamedTuple):
    """Where two passes' sections meet (:func:`profile_ridges`), and what met there.

    ``point`` (m, 3): the ridge's bottom, mm (where ``found``); ``found`` (m,): False where
    the sides do not cross nearest the surface, or a pass runs too steeply across the
    plane; ``own_normal``, ``next_normal`` (m, 3): each section's outward unit normal at
    the crossing, in the plane (the sample nearest it); ``own_way``, ``next_way`` (m, 3):
    the ways the two prisms run along there (the next's along the own way where its pose's
    section stood higher).
    """

    point: NDArray[np.float64]
    found: NDArray[np.bool_]
    own_normal: NDArray[np.float64]
    next_normal: NDArray[np.float64]
    own_way: NDArray[np.float64]
    next_way: NDArray[np.float64]


def _oblique(way: NDArray[np.float64], across: NDArray[np.float64], x: NDArray[np.float64],
             y: NDArray[np.float64]) -> NDArray[np.float64]:
    """Projection along ``way`` onto the plane of axes ``x, y`` whose normal is ``across``.

    ``P v = (x . v', y . v')``, ``v' = v - (v . across) / (way . across) way`` (along
    ``across`` itself the orthogonal projection): a prism swept along ``way`` meets that
    plane in its section's image under ``P``. All (m, 3), unit; returns ``P`` (m, 2, 3).
    """
    slant = np.einsum("ij,ij->i", way, across)[:, None]
    px = x - (np.einsum("ij,ij->i", x, way)[:, None] / slant) * across
    py = y - (np.einsum("ij,ij->i", y, way)[:, None] / slant) * across
    return np.stack([px, py], axis=1)


def _section_side(centre: NDArray[np.float64], axis: NDArray[np.float64],
                  proj: NDArray[np.float64], psi: NDArray[np.float64], ring_mm: float,
                  corner_mm: float, lift_mm: float
                  ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Boundary points ``b(m)`` (module docstring) at normals ``m = (sin psi, -cos psi)``.

    The section, in a plane, of the prism the solid of ``axis`` sweeps: the solid's image
    under the projection ``proj`` (m, 2, 3; :func:`_oblique`). The ring circle projects to
    the ellipse ``S = ring^2 P (I - a a') P'``, the corner balls to ellipses ``Q = r^2 P P'``
    (circles when orthogonal): support points ``S m / sqrt(m' S m)`` and
    ``r Q m / sqrt(m' Q m)``. ``centre`` (m, 2) in the plane's axes; ``psi`` (k,).
    Returns their ``x`` (never falling along a lower side) and ``y``, (m, k); compiled,
    row by row (:func:`~.torus_kernel.section_sides`).
    """
    pa = np.einsum("ikj,ij->ik", proj, axis)
    q = np.einsum("ikj,ilj->ikl", proj, proj)
    s = ring_mm**2 * (q - pa[:, :, None] * pa[:, None, :])
    return section_sides(centre, pa, q, s, psi, corner_mm, lift_mm)


def profile_ridges(own_centre: NDArray[np.float64], next_centre: NDArray[np.float64],
                   own_axis: NDArray[np.float64], next_axis: NDArray[np.float64],
                   along: NDArray[np.float64], next_along: NDArray[np.float64],
                   normal: NDArray[np.float64], *, through: NDArray[np.float64],
                   across: NDArray[np.float64], radius_mm: float, corner_radius_mm: float,
                   flute_length_mm: float, samples: int = PROFILE_SAMPLES) -> RidgeProfile:
    """The bottom of the ridge between two passes' sections in a plane (module docstring).

    The plane passes through ``through`` with normal ``across`` (the seed's contact and
    line of ``t``: the ridge lies where the ray cast seeks it, not a ridge's length along
    the passes, where on a tight bend it stands lower or higher). The own pass's prism
    runs along ``along``, the next pass's along ``next_along``: each meets the plane in
    its solid projected along its way (:func:`_oblique`; ``1 / cos`` of its angle to
    ``across`` wider, as at a move joint, where the two ways differ by the joint's turn),
    about where the way carries its ring centre into the plane. The next pass's section
    is also taken about its centre carried along the own way (the pose itself: its
    contact a lead's ``R - r`` ahead of its ring centre, near the plane, where its own
    way would carry the centre across as far as the pass bends over that reach) where
    that centre stands off the plane by over :data:`POSE_OFF_PLANE_SHARE` of ``R``, and
    the higher crossing kept (the cast rule needs an estimate that does not read low). The
    own section's side towards the next (normals from a little past straight down, ``-y``,
    to ``+x``, with ``x`` across from the own contact towards the next's,
    :func:`_bottoms_apart`) and the next's side towards the
    own, each a polyline through :data:`PROFILE_SAMPLES` boundary points, rise and fall
    across: where the own side first stands at or above the next's, they cross. Left
    of its bottom (``psi < 0``) the own side is taken as standing at its bottom's height:
    there it faces away from the next, and where the two passes' axes lean apart
    unequally (the own more, its section curving up more tightly) it rose above the
    next's falling side again far across, which met it there first (the standing dev
    blade's 5-axis program, bull:8:1, lead 10 degrees, scallop 0.005 mm: 2.8 mm across,
    0.38 mm up, the ray cast 0.001 mm). Held there, a next side already below the own
    bottom (the own contact covered) meets it at the bottom's height.

    Parameters
    ----------
    own_centre, next_centre : ndarray, shape (m, 3)
        Ring centres of the own pass's pose over the contact and of the next pass's
        pose nearest to it, mm.
    own_axis, next_axis, along, next_along, normal : ndarray, shape (m, 3)
        Their unit tool axes, the own and the next pass's unit directions and the
        surface normal.
    through, across : ndarray, shape (m, 3)
        A point of the plane (mm) and its unit normal.
    radius_mm, corner_radius_mm, flute_length_mm : float
        ``R``, ``r`` and ``L``, mm.

    Returns
    -------
    RidgeProfile
        The ridge's bottom (mm) and whether it was found: not where the sides do not
        cross nearest the surface (the next section below the own contact, or the two
        apart) in either of the next's sections, or a pass runs more steeply across the
        plane than :data:`LEAST_WAY_COSINE`; each section's outward normal at the
        crossing and the way its prism runs along (to find the pose that leaves the
        ridge, :func:`~.cusp_estimates.torus_cusp_estimates`).
    """
    m = len(own_centre)
    nu = unit(across)
    # the ways as lines (a zigzag pass runs back), both crossing the plane forwards
    slant_own = np.einsum("ij,ij->i", along, nu)
    slant_next = np.einsum("ij,ij->i", next_along, nu)
    steep = (np.abs(slant_own) < LEAST_WAY_COSINE) | (np.abs(slant_next) < LEAST_WAY_COSINE)
    u = unit(along) * np.where(slant_own < 0.0, -1.0, 1.0)[:, None]
    w = unit(next_along) * np.where(slant_next < 0.0, -1.0, 1.0)[:, None]
    u[steep] = w[steep] = nu[steep]
    y = unit(normal - np.einsum("ij,ij->i", normal, nu)[:, None] * nu)
    x = np.cross(y, nu)

    def carried(v: NDArray[np.float64], way: NDArray[np.float64]) -> NDArray[np.float64]:
        """``v`` carried along ``way`` into the plane (through the origin)."""
        return v - (np.einsum("ij,ij->i", v, nu) / np.einsum("ij,ij->i", way, nu))[:, None] * way

    origin = through + carried(own_centre - through, u)
    d = next_centre - origin
    ways = (w, u)
    centres = [carried(d, way) for way in ways]
    x *= np.where(np.einsum("ij,ij->i", centres[0], x) < 0.0, -1.0, 1.0)[:, None]
    ring, lift = radius_mm - corner_radius_mm, flute_length_mm - corner_radius_mm
    x *= np.where(_bottoms_apart(centres[0], own_axis, next_axis, u, w, nu, x, y, ring,
                                 corner_radius_mm, lift) < 0.0, -1.0, 1.0)[:, None]
    t = np.linspace(-0.5, 1.0, samples)
    psi = 0.5 * np.pi * t * np.abs(t)
    x1, y1 = _section_side(np.zeros((m, 2)), own_axis, _oblique(u, nu, x, y), psi, ring,
                           corner_radius_mm, lift)
    # left of its bottom the own side stands as there (its flank facing away is no ridge)
    bottom = int(np.argmin(np.abs(psi)))
    y1[:, :bottom] = y1[:, bottom, None]
    best_x, best_y = np.zeros(m), np.full(m, -np.inf)
    # each side's outward normal at the crossing kept (psi), and the next's way
    own_psi, next_psi, next_way = np.zeros(m), np.zeros(m), w.copy()
    found = ~steep
    # the pose's own section only where its centre stands off the plane by a lead's reach
    off = np.abs(np.einsum("ij,ij->i", d, nu)) > POSE_OFF_PLANE_SHARE * radius_mm
    for way, c, rows in zip(ways, centres, (np.arange(m), np.flatnonzero(off)), strict=True):
        next_c = np.stack([np.einsum("ij,ij->i", c[rows], x[rows]),
                           np.einsum("ij,ij->i", c[rows], y[rows])], axis=1)
        x2, y2 = _section_side(next_c, next_axis[rows], _oblique(way[rows], nu[rows], x[rows],
                                                                 y[rows]), -psi[::-1], ring,
                               corner_radius_mm, lift)
        x_r, y_r = side_crossings(x1[rows], y1[rows], x2, y2)
        found[rows] &= np.isfinite(y_r)
        higher = y_r > best_y[rows]  # nan (not met) never is
        best_x[rows[higher]], best_y[rows[higher]] = x_r[higher], y_r[higher]
        hit = rows[higher]
        own_psi[hit] = np.maximum(psi[_nearest_sample(x1[hit], y1[hit], x_r[higher],
                                                      y_r[higher])], 0.0)
        next_psi[hit] = -psi[::-1][_nearest_sample(x2[higher], y2[higher], x_r[higher],
                                                   y_r[higher])]
        next_way[hit] = way[hit]
    point = origin + np.where(found, best_x, 0.0)[:, None] * x + np.where(
        found, best_y, 0.0)[:, None] * y

    def normal_at(angle: NDArray[np.float64]) -> NDArray[np.float64]:
        """The outward normal ``m = (sin psi, -cos psi)`` in the plane, 3-D."""
        return np.sin(angle)[:, None] * x - np.cos(angle)[:, None] * y

    return RidgeProfile(point, found, normal_at(own_psi), normal_at(next_psi), u, next_way)


def _bottoms_apart(next_centre: NDArray[np.float64], own_axis: NDArray[np.float64],
                   next_axis: NDArray[np.float64], own_way: NDArray[np.float64],
                   next_way: NDArray[np.float64], across: NDArray[np.float64],
                   x: NDArray[np.float64], y: NDArray[np.float64], ring_mm: float,
                   corner_mm: float, lift_mm: float) -> NDArray[np.float64]:
    """How far along ``x`` the next section's bottom stands beyond the own one's, mm.

    The bottoms are the sections' points of outward normal ``-y`` (``psi = 0``): the two
    passes' contacts. ``next_centre`` (m, 3) the next ring centre in the plane, relative to
    the own one (:func:`profile_ridges`). Where a zigzag's lead tilts the two passes' axes
    apart (the standing dev blade's pass ends, bull:8:1, lead 10 degrees) the next ring
    centre can stand on the ``+x`` side while its contact stands on the ``-x`` side of the
    own contact: facing away from each other, the sides met 3.3 mm across, their flanks
    0.4 mm up (about 450 times the ray cast; the next pass's contact 0.35 mm away).
    """
    m = len(next_centre)
    psi = np.zeros(1)
    own_x, _ = _section_side(np.zeros((m, 2)), own_axis, _oblique(own_way, across, x, y), psi,
                             ring_mm, corner_mm, lift_mm)
    centre = np.stack([np.einsum("ij,ij->i", next_centre, x),
                       np.einsum("ij,ij->i", next_centre, y)], axis=1)
    next_x, _ = _section_side(centre, next_axis, _oblique(next_way, across, x, y), psi, ring_mm,
                              corner_mm, lift_mm)
    return next_x[:, 0] - own_x[:, 0]


def _nearest_sample(xs: NDArray[np.float64], ys: NDArray[np.float64], x: NDArray[np.float64],
                    y: NDArray[np.float64]) -> NDArray[np.int64]:
    """Per row, the sample ``(xs, ys)`` (m, k) nearest to ``(x, y)`` (m,)."""
    return np.argmin((xs - x[:, None]) ** 2 + (ys - y[:, None]) ** 2, axis=1)


#: Ring points of each pose sampled within its window about the contact
#: (:func:`pose_section_ridges`): corner balls ``(R - r) dphi`` apart, whose disks' lower
#: envelope sags at most ``((R - r) dphi)^2 / 8 r`` between them (the bound adds it).
SECTION_RING_SAMPLES = 65

#: Bisection steps for where the two poses' sections cross (:func:`pose_section_ridges`):
#: the bracket ends ``2^-steps`` of the contacts' distance apart.
SECTION_STEPS = 32

#: Halvings of the grid towards the contact poses' crossing over which several poses'
#: sections are bounded (:func:`~.torus_kernel.running_bounds`): the intervals next to it
#: ``2^-levels`` of the contacts' distance wide (a sloping side reads at most its slope
#: times that high there).
SECTION_LEVELS = 12

#: ... and the grid cut into this many even steps too (:func:`~.torus_kernel.running_bounds`,
#: where its intervals read above the bound over the finer grid): a side whose poses stand
#: apart covered a wide interval with no one disk and the other side's far end read the
#: bound. On the user's 5-axis job (standing dev blade, trunnion-ac, bull:8:1, lead 10
#: degrees, scallop 0.005 mm, 221,178 seeds) the estimates standing above ESTIMATE_SHARE
#: times the largest cusp (each ray cast) fell from 8,816 to 2,622, the seeds cast from
#: 15,298 to 7,597 (the pose bounds above it: 8,260 -> under 2,184; even grids alone of
#: 256 and 2,048 steps: 1,849 and 1,767), for 4 s more of running_bounds' CPU (each
#: interval weighed by y; weighed by its height over the surface, the seeds cast fell
#: from 15,437 to 7,605 and measure_scallop's CPU from 41.9 to 32.2 s).
SECTION_EVEN_STEPS = 64


def _disks(centre: NDArray[np.float64], axis: NDArray[np.float64],
           normal: NDArray[np.float64], phi: NDArray[np.float64],
           frame: tuple[NDArray[np.float64], ...], ring_mm: float, corner_mm: float
           ) -> tuple[NDArray[np.float64], ...]:
    """The corner balls round ring points ``phi`` (m, S) about the contact, cut by the plane.

    ``frame``: the plane's point, normal and axes ``x, y`` (each (m, 3)). Returns each
    disk's centre ``x, y`` and squared radius (m, S; negative where the ball misses).
    """
    through, nu, x, y = frame
    w = unit(-(normal - np.einsum("ij,ij->i", normal, axis)[:, None] * axis))
    v = np.cross(axis, w)
    p = (centre[:, None] - through[:, None]
         + ring_mm * (np.cos(phi)[..., None] * w[:, None] + np.sin(phi)[..., None] * v[:, None]))
    delta = np.einsum("ksj,kj->ks", p, nu)
    return (np.einsum("ksj,kj->ks", p, x), np.einsum("ksj,kj->ks", p, y),
            corner_mm * corner_mm - delta * delta)


def pose_section_ridges(own_centre: NDArray[np.float64], next_centre: NDArray[np.float64],
                        own_axis: NDArray[np.float64], next_axis: NDArray[np.float64],
                        normal: NDArray[np.float64], toward: NDArray[np.float64], *,
                        through: NDArray[np.float64], across: NDArray[np.float64],
                        reach_mm: NDArray[np.float64], radius_mm: float,
                        corner_radius_mm: float,
                        more_poses: tuple[NDArray[np.float64], ...] | None = None,
                        bend_per_mm: NDArray[np.float64] | None = None,
                        within_mm: NDArray[np.float64] | None = None, chunk: int = 4_000
                        ) -> tuple[NDArray[np.float64], NDArray[np.bool_]]:
    """An upper bound on the ridge between two passes from one pose of each, no prism.

    A pass removes at least its cutter at any one of its poses, so the material left
    between two passes in a plane stands no higher than where the two poses' sections
    meet: a bound wherever a prism along the way is none (a cutter turning round its
    contact, a pass ending or bending away; :func:`~.cusp_estimates.torus_cusp_estimates`).
    Of each cutter only the balls of radius ``r`` round its ring circle near the contact,
    ``p(phi) = C + (R - r)(cos phi w + sin phi v)`` (``w`` the ring's way to the contact,
    across the axis towards ``-n``; ``v = a x w``; ``|phi|`` up to 1.5 times the reach
    across over ``R - r``, :data:`SECTION_RING_SAMPLES`), are taken: ball ``p`` cuts the
    plane in a disk of radius ``sqrt(r^2 - delta^2)`` about ``p``'s foot (``delta`` its
    distance from the plane); each pose's section reads the lowest of its disks' lower
    arcs. From the own contact (``x = 0``, the own section below the next's) to the next
    (``x = reach``, above it) the two cross: bisected (:data:`SECTION_STEPS`), over the last
    bracket ``[x_a, x_b]`` each disk's arc (convex) stands no higher than at its ends, so
    the lesser of the two sections' ``min_i max(f_i(x_a), f_i(x_b))`` bounds the crossing;
    plus the disks' sag between neighbours (convex sections: the crossing is the ridge).

    ``normal``, ``toward`` (m, 3): the seed's surface normal and a way from the own contact
    towards the next (``x``'s sign); ``through``, ``across``: the plane; ``reach_mm``
    (m,): how far across the next contact stands. Returns the bound's point (m, 3) and
    whether it was found (not where the sections do not cross between the contacts or a
    disk covers neither bracket end). A flat (``r = 0``: its rim balls have no section)
    gets none: the ray cast decides (a flat's whole sections searched up to the next
    contact read down to 0.30 of the ray cast near an elliptic blade's trailing edge, the
    ridge standing beyond that reach).

    With ``more_poses`` (own ring centres, own axes, next ring centres, next axes; each
    (m, K, 3)): more poses each pass takes (:func:`~.cusp_estimates.torus_cusp_estimates`:
    its pieces' poses round the contact pose), whose disks join their side's. One pose
    reads the ridge 1.1 to 1.5 times the ray cast where a bull-nose turns round its contact
    (the user's 5-axis blade job, bull:8:1): the pass's poses beside it cut deeper between
    the contacts. The sides, lower envelopes of several poses' disks, need not be convex,
    nor cross once: the bound over them is :func:`~.torus_kernel.running_bounds` (both
    sides' arcs bounded over each interval of a grid halving towards the contact poses'
    crossing: every disk lies in a cutter, so no sag is owed), plus the sag
    all the same, as a margin: the ridge's height over the surface is read at first order
    (:func:`~.cusp_estimates._ridge_heights`) and the ray cast runs along the normal at the
    crest, not the plane's ``y``; without it a seed of the standing dev blade (5-axis,
    bull:8:1, scallop 0.03 mm) read 0.9915 of a fine ray cast, with it 1.004 and up. The
    lower of the two bounds is taken.

    ``bend_per_mm`` (m,; None: 0): the surface's normal curvature along the plane's ``x``
    at the seed (negative where it falls away from ``normal``, as on a convex part). What
    is bounded is the ridge's height over the surface, and where the surface falls away
    across the passes the highest ridge need not be the highest ``y``: with several poses
    a side each grid interval is weighed by how high its bound stands over the surface's
    section ``bend x^2 / 2`` (:func:`~.torus_kernel.running_bounds`), and the one pose a
    side's crossing and the several poses' bound compared by that height. (Weighed by
    ``y``, the bound read 0.739 of the ray cast on a sphere of radius 10 mm, bull:8:1, lead
    30 deg, trunnion-ac, where the surface falls away across the passes;
    test_planning_measure_pose_sections.) The
    one pose a side's crossing stays a bound of the height: beyond it the next section,
    convex, less the surface's section, concave where it falls away, is convex, no higher
    than at its ends, the crossing and the next contact (nothing left), and so on the own
    side. ``within_mm`` (m,; None: no limit): how far across the surface runs (the ray
    cast's bracket ends at its edge): no ridge is sought, nor its height read, beyond
    (on a sphere of radius 10 mm, bull:6:1, lead 30 deg, a bound read at 1.02 mm across,
    0.33 mm past the edge, stood 0.51 of the ray cast); without ``more_poses`` a crossing
    beyond it is not found.
    """
    m = len(own_centre)
    point, found = np.zeros((m, 3)), np.zeros(m, dtype=bool)
    bend = np.zeros(m) if bend_per_mm is None else np.asarray(bend_per_mm, dtype=float)
    limit = np.full(m, np.inf) if within_mm is None else np.asarray(within_mm, dtype=float)
    ring, r = radius_mm - corner_radius_mm, corner_radius_mm
    if not m or r <= 0.0:
        return point, found
    nu = unit(across)
    y = unit(normal - np.einsum("ij,ij->i", normal, nu)[:, None] * nu)
    x = np.cross(y, nu)
    x *= np.where(np.einsum("ij,ij->i", x, toward) < 0.0, -1.0, 1.0)[:, None]
    steps = np.linspace(-1.0, 1.0, SECTION_RING_SAMPLES)
    for lo in range(0, m, chunk):
        rows = slice(lo, lo + chunk)
        reach = reach_mm[rows]
        frame = (through[rows], nu[rows], x[rows], y[rows])
        window = np.minimum(np.arcsin(np.clip(1.5 * reach / max(ring, TINY), 0.0, 1.0))
                            + 0.05, 0.5 * np.pi)
        phi = window[:, None] * steps
        sag = (ring * 2.0 * window / (SECTION_RING_SAMPLES - 1)) ** 2 / (8.0 * r)
        own = _disks(own_centre[rows], own_axis[rows], normal[rows], phi, frame, ring, r)
        nxt = _disks(next_centre[rows], next_axis[rows], normal[rows], phi, frame, ring, r)
        xb, bound, ok = disk_crossings(own, nxt, reach, SECTION_STEPS)
        height = bound + sag
        if more_poses is not None:
            own_c, own_a, next_c, next_a = (
                np.concatenate([one[rows, None], many[rows]], axis=1)
                for one, many in zip((own_centre, own_axis, next_centre, next_axis),
                                     more_poses, strict=True))
            x_more, h_more = running_bounds(frame, normal[rows], (own_c, own_a, next_c, next_a),
                                            phi, ring, r, reach, xb, SECTION_LEVELS,
                                            bend[rows], limit[rows], SECTION_EVEN_STEPS)
            h_more = h_more + sag
            # (the lower over the surface: each read where its surface stands lowest; the
            # one pose a side's crossing none beyond the edge)
            lower = (h_more - 0.5 * bend[rows] * x_more**2 < height - 0.5 * bend[rows] * xb**2
                     ) | (xb > limit[rows])
            xb, height = np.where(lower, x_more, xb), np.where(lower, h_more, height)
        else:
            ok &= ~(xb > limit[rows])  # (one pose a side: none beyond the edge)
        ok &= np.isfinite(height)
        point[rows] = (through[rows] + xb[:, None] * x[rows]
                       + np.where(ok, height, 0.0)[:, None] * y[rows])
        found[rows] = ok
    return point, found
