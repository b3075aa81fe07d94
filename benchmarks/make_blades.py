#!/usr/bin/env python3
# ruff: noqa
# Copied verbatim from shared/data/blades/make_blades.py: the generator of the bundled blade data.
"""Synthetic compressor-blade point sets for development (numpy only, deterministic).

Writes into the output directory (default: the directory of this script):
  dev_blade_15x142.csv     header "section,x,y,z"  15 sections x 142 points
  dev_half_profile_71.csv  header "x,y,z"          71 points, one half profile

Geometry (all lengths in millimetres):
  * engine axis = z; every section lies exactly on a cylinder x^2 + y^2 = r^2
    (a classical turbomachinery "elementary profile" at constant radius);
  * 2-D section = NACA 4-digit thickness distribution (open/blunt trailing edge,
    coefficient -0.1015) laid perpendicular to a circular-arc camber line;
  * chord, thickness, camber, stagger (twist), sweep and lean vary along span;
  * the 2-D section (m = axial, s = circumferential arc length r*theta) is
    wrapped onto the cylinder: theta = s/r, x = r cos(theta), y = r sin(theta),
    z = m.

Point order of every blade section (142 points, open contour, no point repeated):
  index 0 = suction-side trailing-edge corner, 0..70 along the suction side
  towards the leading edge, 71..141 along the pressure side back to the
  pressure-side trailing-edge corner.  The straight trailing-edge base between
  point 141 and point 0 (0.021*t_rel*chord, about 0.06-0.13 mm) is not
  sampled.  Points are cosine-clustered at LE and TE.

The half profile (71 points) is the suction side of the mid-span section
(section 7, r = 182 mm) re-sampled from the leading edge (point 0, exactly the
LE) to the suction-side trailing-edge corner (point 70), cosine-clustered.

Run:  python make_blades.py [output_dir]
"""
import os
import sys

import numpy as np

N_SECTIONS = 15
N_PER_SIDE = 71
N_PER_SECTION = 2 * N_PER_SIDE           # 142
R_MID = 182.0                            # radius of the mid-span section (mm)
DR = 9.0                                 # radial spacing of sections (mm)
THETA0_DEG = 11.5                        # angular position of the stacking line
Z0 = 145.0                               # axial position of the stacking line (mm)


def span_laws(h):
    """Design parameters at span fraction h in [0, 1] (0 = hub, 1 = tip)."""
    return dict(
        chord=62.0 - 8.0 * h,            # mm, taper 62 -> 54
        t_rel=0.10 - 0.05 * h,           # max thickness / chord, 10% -> 5%
        camber_deg=40.0 - 25.0 * h,      # circular-arc camber angle 40 -> 15 deg
        stagger_deg=10.0 + 16.0 * h,     # chord angle from the axial (z) direction, 10 -> 26 deg
        sweep=6.0 * h ** 2,              # axial shift of the section centroid (mm, +z)
        lean=-6.0 * h ** 2,              # circumferential shift of the centroid (mm, +r*theta)
    )


def naca4_half_thickness(x, t_rel):
    """NACA 4-digit half thickness (chord units), open trailing edge."""
    return 5.0 * t_rel * (0.2969 * np.sqrt(x) - 0.1260 * x - 0.3516 * x ** 2
                          + 0.2843 * x ** 3 - 0.1015 * x ** 4)


def circular_arc_camber(x, camber_deg):
    """Circular-arc camber line through (0,0) and (1,0); returns y_c and slope angle."""
    phi = np.radians(camber_deg)
    radius = 0.5 / np.sin(phi / 2.0)
    y_centre = -radius * np.cos(phi / 2.0)
    root = np.sqrt(radius ** 2 - (x - 0.5) ** 2)
    yc = y_centre + root
    slope = -(x - 0.5) / root
    return yc, np.arctan(slope)


def surface_2d(x, upper, t_rel, camber_deg):
    """Points of the upper (suction) or lower (pressure) surface in chord units."""
    yt = naca4_half_thickness(x, t_rel)
    yc, ang = circular_arc_camber(x, camber_deg)
    sign = 1.0 if upper else -1.0
    return x - sign * yt * np.sin(ang), yc + sign * yt * np.cos(ang)


def contour_params(n_per_side):
    """Chordwise stations for a full contour: TE(upper) -> LE -> TE(lower)."""
    n = 2 * n_per_side
    phi = 2.0 * np.pi * np.arange(n) / (n - 1)
    xc = 0.5 * (1.0 + np.cos(phi))
    upper = np.arange(n) < n_per_side
    return xc, upper


def section_2d(p, xc, upper):
    X = np.empty_like(xc)
    Y = np.empty_like(xc)
    for flag in (True, False):
        sel = upper == flag
        X[sel], Y[sel] = surface_2d(xc[sel], flag, p["t_rel"], p["camber_deg"])
    return X, Y


def polygon_centroid(X, Y):
    Xn, Yn = np.roll(X, -1), np.roll(Y, -1)
    cross = X * Yn - Xn * Y
    area = 0.5 * cross.sum()
    return (X + Xn).dot(cross) / (6.0 * area), (Y + Yn).dot(cross) / (6.0 * area)


def to_3d(X, Y, p, r):
    """Chord-unit 2-D profile -> 3-D points on the cylinder of radius r."""
    # centroid from a dense version of the same contour (sampling independent)
    xd, ud = contour_params(5001)
    Xd, Yd = section_2d(p, xd, ud)
    cx, cy = polygon_centroid(Xd, Yd)
    g = np.radians(p["stagger_deg"])
    c = p["chord"]
    u, v = c * (X - cx), c * (Y - cy)
    m = u * np.cos(g) - v * np.sin(g)          # axial
    s = u * np.sin(g) + v * np.cos(g)          # circumferential arc length
    m = m + Z0 + p["sweep"]
    s = s + r * np.radians(THETA0_DEG) + p["lean"]
    theta = s / r
    return np.column_stack([r * np.cos(theta), r * np.sin(theta), m])


def radii():
    k = np.arange(N_SECTIONS)
    return R_MID + DR * (k - (N_SECTIONS - 1) // 2)


def make_blade():
    rs = radii()
    out = []
    xc, upper = contour_params(N_PER_SIDE)
    for k, r in enumerate(rs):
        h = k / (N_SECTIONS - 1)
        p = span_laws(h)
        X, Y = section_2d(p, xc, upper)
        out.append(to_3d(X, Y, p, r))
    return rs, out


def make_half_profile():
    k_mid = (N_SECTIONS - 1) // 2
    h = k_mid / (N_SECTIONS - 1)
    p = span_laws(h)
    i = np.arange(N_PER_SIDE)
    xc = 0.5 * (1.0 - np.cos(np.pi * i / (N_PER_SIDE - 1)))   # LE -> TE
    X, Y = surface_2d(xc, True, p["t_rel"], p["camber_deg"])
    return to_3d(X, Y, p, radii()[k_mid])


def write_csv(path, pts, sections=None):
    with open(path, "w", newline="\n") as f:
        if sections is None:
            f.write("x,y,z\n")
            for x, y, z in pts:
                f.write(f"{x:.6f},{y:.6f},{z:.6f}\n")
        else:
            f.write("section,x,y,z\n")
            for k, sec in enumerate(sections):
                for x, y, z in sec:
                    f.write(f"{k},{x:.6f},{y:.6f},{z:.6f}\n")


def main():
    out_dir = sys.argv[1] if len(sys.argv) > 1 else os.path.dirname(os.path.abspath(__file__))
    os.makedirs(out_dir, exist_ok=True)
    rs, secs = make_blade()
    write_csv(os.path.join(out_dir, "dev_blade_15x142.csv"), None, secs)
    half = make_half_profile()
    write_csv(os.path.join(out_dir, "dev_half_profile_71.csv"), half)
    print("sec  r[mm]  chord  t/c   camber stagger sweep lean   x-range          y-range        z-range")
    for k, (r, s) in enumerate(zip(rs, secs)):
        p = span_laws(k / (N_SECTIONS - 1))
        lo, hi = s.min(axis=0), s.max(axis=0)
        print(f"{k:3d} {r:6.1f} {p['chord']:6.2f} {p['t_rel']:.4f} {p['camber_deg']:6.2f} "
              f"{p['stagger_deg']:6.2f} {p['sweep']:5.2f} {p['lean'] + 0.0:5.2f}  "
              f"{lo[0]:7.2f}..{hi[0]:7.2f} {lo[1]:6.2f}..{hi[1]:6.2f} {lo[2]:7.2f}..{hi[2]:7.2f}")
    lo, hi = half.min(axis=0), half.max(axis=0)
    print(f"half profile: x {lo[0]:.2f}..{hi[0]:.2f}  y {lo[1]:.2f}..{hi[1]:.2f}  z {lo[2]:.2f}..{hi[2]:.2f}")


if __name__ == "__main__":
    main()
