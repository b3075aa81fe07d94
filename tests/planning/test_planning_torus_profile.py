"""The profile ridge of two bull-nose passes against their prisms' sections sampled densely.

The geometry is a seed of the standing dev blade's 5-axis program (bull:8:1, lead 10
degrees, zigzag, scallop 0.005 mm) near a pass's end, where the lead tilts the two passes'
axes apart: the next ring centre stands across the own contact from where its contact
stands. Oriented by the centres, the two sections faced away from each other and met
3.3 mm across, 0.42 mm up (the ray cast: 0.0009 mm; 19,040 of the program's 221,178
seeds read so, all ray cast).

The oracle: each cutter's torus sampled densely and carried along its prism's way into
the plane (the prism's section), the lower envelopes on a fine grid across, their
crossing between the two contacts.
"""

import numpy as np

from toolpath.planning.torus_profile import profile_ridges
from toolpath.vectors import unit

BIG_MM, CORNER_MM, FLUTE_MM = 4.0, 1.0, 24.0

# relative to the seed's contact (through = 0)
OWN_CENTRE = np.array([-3.302322, -0.362944, 0.039762])
NEXT_CENTRE = np.array([1.623013, 2.918221, 0.022588])
OWN_AXIS = unit(np.array([-0.399598, 0.910915, -0.102741]))
NEXT_AXIS = unit(np.array([-0.688191, 0.720994, -0.080997]))
OWN_WAY = unit(np.array([8.318514e-01, 5.549982e-01, -4.605766e-04]))
NEXT_WAY = unit(np.array([-8.324712e-01, -5.540683e-01, 5.105769e-05]))
NORMAL = unit(np.array([-0.552745, 0.828113, -0.093289]))
ACROSS = unit(np.array([-0.831608, -0.540885, 0.125985]))


#: The second seed (the passes' axes leaning apart unequally), relative to its contact.
APART = {"own_centre": np.array([-1.2420934, 3.1248871, -0.4236663]),
         "next_centre": np.array([3.2517390, -0.5266436, 0.5493195]),
         "own_axis": unit(np.array([0.7852414, 0.6186535, -0.0257644])),
         "next_axis": unit(np.array([0.4584732, 0.8858620, -0.0710692])),
         "own_way": unit(np.array([0.7933297, -0.5988644, 0.1094959])),
         "next_way": unit(np.array([-0.7926424, 0.5965887, -0.1256983])),
         "normal": unit(np.array([0.6052585, 0.7940802, -0.0556662])),
         "across": unit(np.array([-0.7922842, 0.5941614, -0.1387730]))}

#: The first seed (the lead's pass end).
LEAD_END = {"own_centre": OWN_CENTRE, "next_centre": NEXT_CENTRE, "own_axis": OWN_AXIS,
            "next_axis": NEXT_AXIS, "own_way": OWN_WAY, "next_way": NEXT_WAY, "normal": NORMAL,
            "across": ACROSS}


def _section(centre, axis, way, x, y, grid, normal=NORMAL, across=ACROSS):
    """Lowest ``y`` over each cell of ``grid`` (edges along ``x``) of the cutter's torus
    carried along ``way`` into the plane through 0 of normal ``ACROSS`` (``inf``: no
    sample): its lower half, within 0.6 rad of the ring's point nearest the surface."""
    e1 = unit(-(normal - (normal @ axis) * axis))  # the ring's way to the contact
    e2 = np.cross(axis, e1)
    phi = np.linspace(-0.6, 0.6, 4001)[:, None]
    theta = np.linspace(-np.pi, 0.0, 1201)[None, :]
    radial = np.cos(phi)[..., None] * e1 + np.sin(phi)[..., None] * e2  # (k, 1, 3)
    pts = (centre + (BIG_MM - CORNER_MM) * radial
           + CORNER_MM * (np.cos(theta)[..., None] * radial + np.sin(theta)[..., None] * axis))
    pts = pts.reshape(-1, 3)
    pts = pts - ((pts @ across) / (way @ across))[:, None] * way
    px, py = pts @ x, pts @ y
    low = np.full(len(grid) - 1, np.inf)
    cell = np.searchsorted(grid, px) - 1
    keep = (cell >= 0) & (cell < len(low))
    np.minimum.at(low, cell[keep], py[keep])
    return low


def _oracle_crossing_heights(seed=LEAD_END):
    """The crossing's height over the seed's tangent plane, for the next prism along its
    own way and along the own pass's (profile_ridges keeps the higher where the next pose
    stands far off the plane, as here)."""
    normal, across = seed["normal"], seed["across"]
    y = unit(normal - (normal @ across) * across)
    x = np.cross(y, across)
    grid = np.linspace(-1.0, 1.0, 1001)
    own = _section(seed["own_centre"], seed["own_axis"], seed["own_way"], x, y, grid, normal,
                   across)
    out = []
    for way in (seed["next_way"], seed["own_way"]):
        nxt = _section(seed["next_centre"], seed["next_axis"], way, x, y, grid, normal, across)
        lo, hi = sorted((int(np.argmin(own)), int(np.argmin(nxt))))
        both = np.minimum(own, nxt)[lo:hi + 1]
        out.append(both[np.isfinite(own[lo:hi + 1]) & np.isfinite(nxt[lo:hi + 1])].max())
    return np.array(out) - own.min()  # over the own contact


def test_the_sections_face_each_other_as_the_contacts_stand():
    row = np.array
    ridge = profile_ridges(row([OWN_CENTRE]), row([NEXT_CENTRE]), row([OWN_AXIS]),
                           row([NEXT_AXIS]), row([OWN_WAY]), row([NEXT_WAY]), row([NORMAL]),
                           through=np.zeros((1, 3)), across=row([ACROSS]), radius_mm=BIG_MM,
                           corner_radius_mm=CORNER_MM, flute_length_mm=FLUTE_MM)
    assert ridge.found[0]
    height = float(ridge.point[0] @ NORMAL)
    # between the contacts, 0.35 mm apart (it met 3.3 mm across, 0.42 mm up)
    assert np.linalg.norm(ridge.point[0] - (ridge.point[0] @ NORMAL) * NORMAL) < 0.35
    oracle = _oracle_crossing_heights()
    assert 0.0 < oracle.min() < 0.005
    # the higher of the two crossings, read a little high (the chords between
    # PROFILE_SAMPLES boundary points lie inside the convex sections), never low
    assert oracle.max() <= height <= 1.2 * oracle.max()


def _ridge(seed):
    """:func:`profile_ridges` of one seed's geometry (its contact at 0)."""
    return profile_ridges(*(seed[k][None] for k in ("own_centre", "next_centre", "own_axis",
                                                     "next_axis", "own_way", "next_way",
                                                     "normal")),
                          through=np.zeros((1, 3)), across=seed["across"][None],
                          radius_mm=BIG_MM, corner_radius_mm=CORNER_MM,
                          flute_length_mm=FLUTE_MM)


def test_the_own_flank_facing_away_is_no_ridge():
    # unequal leans: without the own side held at its bottom's height left of it, the
    # sections met on the own flank facing away, 2.8 mm across, 0.38 mm up
    ridge = _ridge(APART)
    assert ridge.found[0]
    normal = APART["normal"]
    height = float(ridge.point[0] @ normal)
    # between the contacts, 0.35 mm apart
    assert np.linalg.norm(ridge.point[0] - height * normal) < 0.35
    oracle = _oracle_crossing_heights(APART)
    assert 0.0 < oracle.min() < 0.005
    assert oracle.max() <= height <= 1.2 * oracle.max()
