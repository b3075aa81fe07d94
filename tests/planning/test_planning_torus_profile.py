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


def _section(centre, axis, way, x, y, grid):
    """Lowest ``y`` over each cell of ``grid`` (edges along ``x``) of the cutter's torus
    carried along ``way`` into the plane through 0 of normal ``ACROSS`` (``inf``: no
    sample): its lower half, within 0.6 rad of the ring's point nearest the surface."""
    e1 = unit(-(NORMAL - (NORMAL @ axis) * axis))  # the ring's way to the contact
    e2 = np.cross(axis, e1)
    phi = np.linspace(-0.6, 0.6, 4001)[:, None]
    theta = np.linspace(-np.pi, 0.0, 1201)[None, :]
    radial = np.cos(phi)[..., None] * e1 + np.sin(phi)[..., None] * e2  # (k, 1, 3)
    pts = (centre + (BIG_MM - CORNER_MM) * radial
           + CORNER_MM * (np.cos(theta)[..., None] * radial + np.sin(theta)[..., None] * axis))
    pts = pts.reshape(-1, 3)
    pts = pts - ((pts @ ACROSS) / (way @ ACROSS))[:, None] * way
    px, py = pts @ x, pts @ y
    low = np.full(len(grid) - 1, np.inf)
    cell = np.searchsorted(grid, px) - 1
    keep = (cell >= 0) & (cell < len(low))
    np.minimum.at(low, cell[keep], py[keep])
    return low


def _oracle_crossing_heights():
    """The crossing's height over the seed's tangent plane, for the next prism along its
    own way and along the own pass's (profile_ridges keeps the higher where the next pose
    stands far off the plane, as here)."""
    y = unit(NORMAL - (NORMAL @ ACROSS) * ACROSS)
    x = np.cross(y, ACROSS)
    grid = np.linspace(-1.0, 1.0, 1001)
    own = _section(OWN_CENTRE, OWN_AXIS, OWN_WAY, x, y, grid)
    out = []
    for way in (NEXT_WAY, OWN_WAY):
        nxt = _section(NEXT_CENTRE, NEXT_AXIS, way, x, y, grid)
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
