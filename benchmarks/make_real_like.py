#!/usr/bin/env python3
# ruff: noqa
# Copied verbatim from shared/data/blades/make_real_like.py: the generator of the real-like blade data.
"""Real-like development blade point sets (numpy only, deterministic).

These files carry the traits of measured or CAD-exported blades that the
clean, cosine-sampled `dev_blade_15x142.csv` lacks: closed contours whose last
point nearly (not exactly) meets the first, round noses sampled 50-100x denser
than the flanks, sections on conical stream surfaces, a blade that straddles a
coordinate plane, blunt trailing edges, elliptic noses, and helical propeller
sections.

Writes into the output directory (default: the directory of this script):
  dev_rotor_dca_11x181.csv   transonic-compressor-style rotor, 11 sections x 181
                             points, closed double-circular-arc (DCA) sections
                             on conical stream surfaces, export-like sampling
  dev_rotor_blunt_9x120.csv  rotor with a blunt (cut-off) 0.4 mm trailing edge,
                             9 sections x 120 points, OPEN sections on
                             cylinders, elliptic (2:1) leading edge
  dev_prop_7x100.csv         one marine-propeller blade (D = 300 mm), 7 closed
                             helical sections x 100 points at r/R = 0.3 ... 0.9

All files: header "section,x,y,z", millimetres, 6 decimals, row order = point
order, section 0 = hub (root).  The engine / shaft axis is z.  Every design
value below was invented for this file; only textbook formulas are used
(circular arcs, ellipses, parabolas, the NACA 4-digit mean line and the NACA
a-series mean line of Abbott & von Doenhoff).  There is no noise: the points
lie exactly on the analytic surfaces (up to the 6-decimal rounding).

The script checks itself (assert) and prints a per-section table for each
file.  Run:  python make_real_like.py [output_dir]
"""
import os
import sys

import numpy as np

# ----------------------------------------------------------------------------
# generic helpers
# ----------------------------------------------------------------------------


def write_csv(path, sections):
    """Write sections (list of (n, 3) arrays) as 'section,x,y,z', 6 decimals."""
    with open(path, "w", newline="\n") as f:
        f.write("section,x,y,z\n")
        for k, sec in enumerate(sections):
            for x, y, z in np.round(sec, 6) + 0.0:      # + 0.0: no "-0.000000"
                f.write(f"{k},{x:.6f},{y:.6f},{z:.6f}\n")


def read_back(path):
    data = np.loadtxt(path, delimiter=",", skiprows=1)
    ks = data[:, 0].astype(int)
    return [data[ks == k, 1:] for k in range(ks.max() + 1)]


def interval_distance(s, lo, hi, period=None):
    """Distance of arc positions s from the interval [lo, hi] (0 inside)."""
    def d(u):
        return np.maximum(0.0, np.maximum(lo - u, u - hi))
    if period is None:
        return d(s)
    return np.minimum(d(s), np.minimum(d(s - period), d(s + period)))


def graded_stations(s0, s1, n_intervals, anchors, h_max, period=None, n_grid=200001):
    """Arc-length stations s0 = s_0 < s_1 < ... < s_n = s1.

    The target spacing is h(s) = min(h_max, min_i(h_i + g * d_i(s))), where
    anchor i is an arc interval [lo_i, hi_i] (a point when lo_i = hi_i) that
    wants spacing h_i and d_i(s) is the distance of s from it; that is, the
    spacing grows linearly away from the anchors (geometric growth per
    point) until it reaches h_max.  The growth rate g is solved by bisection
    so that exactly n_intervals intervals fit between s0 and s1; inside an
    anchor interval the spacing is exactly h_i.  Returns (stations, g).
    """
    s = np.linspace(s0, s1, n_grid)
    dist = [(h_i, interval_distance(s, lo, hi, period)) for lo, hi, h_i in anchors]
    ds = np.diff(s)

    def cumulative(g):
        h = np.full_like(s, h_max)
        for h_i, d_i in dist:
            np.minimum(h, h_i + g * d_i, out=h)
        inv = 1.0 / h
        return np.concatenate([[0.0], np.cumsum(0.5 * (inv[1:] + inv[:-1]) * ds)])

    lo_g, hi_g = 1e-6, 1e3
    if cumulative(hi_g)[-1] > n_intervals:
        raise ValueError("h_max too small for the requested number of points")
    if cumulative(lo_g)[-1] < n_intervals:
        raise ValueError("anchor spacings too large for the requested number of points")
    for _ in range(64):
        g = np.sqrt(lo_g * hi_g)
        if cumulative(g)[-1] > n_intervals:
            lo_g = g
        else:
            hi_g = g
    c = cumulative(hi_g)
    st = np.interp(np.arange(n_intervals + 1) * (c[-1] / n_intervals), c, s)
    st[0], st[-1] = s0, s1
    return st, hi_g


class ParamCurve:
    """A planar curve given by a vectorised function of a parameter p in [0, P].

    `at_arclength(s)` returns the exact curve points at arc lengths s measured
    from p = 0; the arc length is tabulated once on a dense grid (per piece)
    and inverted by interpolation, then the analytic function is evaluated.
    """

    def __init__(self, fun, n_pieces, n_per_piece=100001):
        self.fun = fun
        u = np.linspace(0.0, 1.0, n_per_piece)
        p = np.concatenate([i + u[(0 if i == 0 else 1):] for i in range(n_pieces)])
        pts = fun(p)
        seg = np.hypot(*np.diff(pts, axis=0).T)
        self.p = p
        self.s = np.concatenate([[0.0], np.cumsum(seg)])
        self.length = self.s[-1]

    def s_of_p(self, p):
        return np.interp(p, self.p, self.s)

    def at_arclength(self, s):
        return self.fun(np.interp(s, self.s, self.p))


def polygon_centroid(X, Y):
    Xn, Yn = np.roll(X, -1), np.roll(Y, -1)
    cross = X * Yn - Xn * Y
    area = 0.5 * cross.sum()
    return (X + Xn).dot(cross) / (6.0 * area), (Y + Yn).dot(cross) / (6.0 * area)


def spacings(sec):
    return np.linalg.norm(np.diff(sec, axis=0), axis=1)


# ----------------------------------------------------------------------------
# 1. transonic-compressor-style rotor, DCA sections on cones
# ----------------------------------------------------------------------------
DCA_N_SECTIONS = 11
DCA_N_POINTS = 181
DCA_R_LE = 0.006          # LE nose radius / chord
DCA_R_TE = 0.004          # TE nose radius / chord
DCA_LE_STEP_DEG = 7.0     # angular step of the export on the LE nose
DCA_TE_STEP_DEG = 7.5     # angular step of the export on the TE nose
DCA_H_MAX = 2.5           # largest flank spacing, mm
DCA_Z0 = 16.05            # axial position of the stacking axis (hub LE ends near z = -0.5)


def dca_laws(h):
    """Design values at span fraction h (0 = hub, 1 = tip)."""
    return dict(
        r_stack=140.0 + 75.0 * h,            # radius of the stacking point, mm
        chord=45.0 + 10.0 * h,               # mm
        t_rel=0.06 - 0.03 * h,               # max thickness / chord (at mid-chord)
        camber_deg=30.0 - 25.0 * h,          # circular-arc camber angle
        stagger_deg=35.0 + 27.0 * h,         # chord angle from the meridional direction
        rise=8.0 - 6.0 * h,                  # stream-surface radius rise LE -> TE, mm
        sweep=-3.0 * h ** 2,                 # axial shift of the stacking point, mm
        lean=4.0 * h ** 2,                   # circumferential shift of the stacking point, mm
        gap=0.0060 + 0.0003 * round(10 * h),  # last-to-first point gap, mm
        start_deg=12.0 + 3.0 * round(10 * h),  # start point on the TE nose (deg from TE point)
    )


def _flank_point(P, t, n, k, sig):
    """Circle (signed curvature k, k > 0 bulging along n) through P with
    tangent t and outward normal n, at arc length sig from P."""
    sig = np.asarray(sig, dtype=float)
    S = sig * np.sinc(k * sig / np.pi)                           # sin(k s)/k
    C = 0.5 * k * sig ** 2 * np.sinc(k * sig / (2 * np.pi)) ** 2  # (1 - cos(k s))/k
    return P + S[..., None] * t - C[..., None] * n


def _depth(Q, P, n, k):
    """Signed distance of Q inside the flank circle (positive on the blade side)."""
    w = Q - P
    wn, ww = w @ n, w @ w
    return -(2.0 * wn + k * ww) / (1.0 + np.sqrt(1.0 + 2.0 * k * wn + k * k * ww))


def _solve_flank(P, side, O1, r1, O2, r2, k0):
    """Flank circle through P tangent to the nose circles (O1, r1), (O2, r2)."""
    beta, k = (0.5 * np.pi if side > 0 else -0.5 * np.pi), k0

    def F(b, kk):
        n = np.array([np.cos(b), np.sin(b)])
        return np.array([_depth(O1, P, n, kk) - r1, _depth(O2, P, n, kk) - r2])

    for _ in range(60):
        f = F(beta, k)
        if np.abs(f).max() < 1e-15:
            break
        e = 1e-7
        J = np.column_stack([(F(beta + e, k) - F(beta - e, k)) / (2 * e),
                             (F(beta, k + e) - F(beta, k - e)) / (2 * e)])
        d = np.linalg.solve(J, -f)
        beta, k = beta + d[0], k + d[1]
    n = np.array([np.cos(beta), np.sin(beta)])
    t = side * np.array([np.sin(beta), -np.cos(beta)])          # points LE -> TE
    assert np.abs(F(beta, k)).max() < 1e-12
    return t, n, k


def _foot(ctr, P, t, n, k, s0):
    """Arc length (from P) of the foot of the perpendicular from ctr on the flank."""
    s = s0
    for _ in range(60):
        X = _flank_point(P, t, n, k, s)
        Xp = t * np.cos(k * s) - n * np.sin(k * s)
        Xpp = -k * (t * np.sin(k * s) + n * np.cos(k * s))
        g = (ctr - X) @ Xp
        ds = -g / (-(Xp @ Xp) + (ctr - X) @ Xpp)
        s += ds
        if abs(ds) < 1e-15:
            break
    return s


class DCAProfile:
    """Double-circular-arc section in chord units, closed, counter-clockwise.

    Camber line: circular arc through LE point (0,0) and TE point (1,0) with
    camber angle phi.  Nose circles of radius r_le, r_te are centred on the
    camber tangents, touching the LE/TE points.  Each flank is the circular arc
    through the mid-chord point (0.5, y_c(0.5) +- t/2) tangent to both nose
    circles.  Arc length s starts at the TE point and runs TE nose -> suction
    flank -> LE nose -> pressure flank -> TE nose; every piece is a circular
    arc, so s is evaluated exactly.
    """

    def __init__(self, camber_deg, t_rel, r_le=DCA_R_LE, r_te=DCA_R_TE):
        phi = np.radians(camber_deg)
        self.r_le, self.r_te = r_le, r_te
        half = 0.5 * phi
        self.O1 = r_le * np.array([np.cos(half), np.sin(half)])
        self.O2 = np.array([1.0 - r_te * np.cos(half), r_te * np.sin(half)])
        y_mid = (1.0 - np.cos(half)) / (2.0 * np.sin(half)) if phi > 0 else 0.0
        kc = 2.0 * np.sin(half)                     # camber-line curvature
        kt = 4.0 * t_rel / (0.25 + 0.25 * t_rel ** 2)  # curvature of a t/2-high arc
        flanks = {}
        for side in (+1, -1):
            P = np.array([0.5, y_mid + side * 0.5 * t_rel])
            t, n, k = _solve_flank(P, side, self.O1, r_le, self.O2, r_te, kt + side * kc)
            s1 = _foot(self.O1, P, t, n, k, (self.O1 - P) @ t)
            s2 = _foot(self.O2, P, t, n, k, (self.O2 - P) @ t)
            flanks[side] = (P, t, n, k, s1, s2)
        self.flanks = flanks

        def ang(T, ctr):
            return np.arctan2(T[1] - ctr[1], T[0] - ctr[0])

        T1s = _flank_point(*flanks[1][:4], flanks[1][4])
        T2s = _flank_point(*flanks[1][:4], flanks[1][5])
        T1p = _flank_point(*flanks[-1][:4], flanks[-1][4])
        T2p = _flank_point(*flanks[-1][:4], flanks[-1][5])
        for T, ctr, r in ((T1s, self.O1, r_le), (T1p, self.O1, r_le),
                          (T2s, self.O2, r_te), (T2p, self.O2, r_te)):
            assert abs(np.hypot(*(T - ctr)) - r) < 1e-12          # tangent points on the noses
        a_te = -half
        a_t2s, a_t2p = ang(T2s, self.O2), ang(T2p, self.O2)
        a_t1s = ang(T1s, self.O1)
        a_t1p = ang(T1p, self.O1) % (2 * np.pi)
        if a_t1p < a_t1s:
            a_t1p += 2 * np.pi
        a_le = np.pi + half
        assert a_t2p < a_te < a_t2s and a_t1s < a_le < a_t1p
        P_s, t_s, n_s, k_s, s1s, s2s = flanks[1]
        P_p, t_p, n_p, k_p, s1p, s2p = flanks[-1]
        # pieces: (kind, data, length)
        self.pieces = [
            ("arc", (self.O2, r_te, a_te), r_te * (a_t2s - a_te)),
            ("flank", (P_s, t_s, n_s, k_s, s2s, -1.0), s2s - s1s),
            ("arc", (self.O1, r_le, a_t1s), r_le * (a_t1p - a_t1s)),
            ("flank", (P_p, t_p, n_p, k_p, s1p, +1.0), s2p - s1p),
            ("arc", (self.O2, r_te, a_t2p), r_te * (a_te - a_t2p)),
        ]
        self.starts = np.concatenate([[0.0], np.cumsum([p[2] for p in self.pieces])])
        self.length = self.starts[-1]
        self.s_le = self.starts[2] + r_le * (a_le - a_t1s)            # LE point
        self.le_nose = (self.starts[2], self.starts[3])
        self.te_nose = (self.starts[4] - self.length, self.starts[1])  # wraps through s = 0

    def at(self, s):
        s = np.mod(np.asarray(s, dtype=float), self.length)
        out = np.empty(s.shape + (2,))
        idx = np.clip(np.searchsorted(self.starts, s, side="right") - 1, 0, len(self.pieces) - 1)
        for i, (kind, data, _) in enumerate(self.pieces):
            sel = idx == i
            ds = s[sel] - self.starts[i]
            if kind == "arc":
                ctr, r, a0 = data
                a = a0 + ds / r
                out[sel] = ctr + r * np.column_stack([np.cos(a), np.sin(a)])
            else:
                P, t, n, k, sig0, direction = data
                out[sel] = _flank_point(P, t, n, k, sig0 + direction * ds)
        return out

    def flank_curvatures(self):
        return self.flanks[1][3], self.flanks[-1][3]


def dca_cone(p):
    """Half-angle eps of the section's conical stream surface (rise LE -> TE)."""
    axial_chord_m = p["chord"] * np.cos(np.radians(p["stagger_deg"]))  # meridional
    return np.arcsin(p["rise"] / axial_chord_m)


def dca_to_3d(P2, p, prof_centroid):
    """Chord-unit profile points -> 3-D on the section's cone.

    (m, s): m = meridional distance along the cone generator from the stacking
    point, s = circumferential arc length r*theta at the local radius.
    """
    g = np.radians(p["stagger_deg"])
    c = p["chord"]
    u = c * (P2[:, 0] - prof_centroid[0])
    v = c * (P2[:, 1] - prof_centroid[1])
    m = u * np.cos(g) - v * np.sin(g)
    s = u * np.sin(g) + v * np.cos(g) + p["lean"]
    eps = dca_cone(p)
    r = p["r_stack"] + m * np.sin(eps)
    z = DCA_Z0 + p["sweep"] + m * np.cos(eps)
    theta = s / r
    return np.column_stack([r * np.cos(theta), r * np.sin(theta), z])


def make_dca():
    sections, info = [], []
    for k in range(DCA_N_SECTIONS):
        h = k / (DCA_N_SECTIONS - 1)
        p = dca_laws(h)
        prof = DCAProfile(p["camber_deg"], p["t_rel"])
        c = p["chord"]
        dense = prof.at(np.linspace(0.0, prof.length, 40001)[:-1])
        cen = polygon_centroid(dense[:, 0], dense[:, 1])
        L = prof.length * c                                   # contour length, mm
        h_le = DCA_R_LE * c * np.radians(DCA_LE_STEP_DEG)
        h_te = DCA_R_TE * c * np.radians(DCA_TE_STEP_DEG)
        le_lo, le_hi = prof.le_nose[0] * c, prof.le_nose[1] * c
        te_lo, te_hi = prof.te_nose[0] * c, prof.te_nose[1] * c   # te_lo < 0: wraps
        anchors = [(le_lo, le_hi, h_le), (te_lo, te_hi, h_te)]
        start_deg = p["start_deg"]
        for _ in range(50):                                  # keep samples off the LE point
            s_start = DCA_R_TE * c * np.radians(start_deg)  # on the TE nose, suction side
            st, growth = graded_stations(s_start, s_start + L - p["gap"], DCA_N_POINTS - 1,
                                         anchors, DCA_H_MAX, period=L)
            d_le = np.abs((st - prof.s_le * c + 0.5 * L) % L - 0.5 * L).min()
            if d_le > 0.2 * h_le:
                break
            start_deg += 1.0
        sec = dca_to_3d(prof.at(st / c), p, cen)
        sm = np.mod(st, L)
        info.append(dict(
            k=k, h=h, p=p, sec=sec, eps_deg=np.degrees(dca_cone(p)), growth=growth,
            le=dca_to_3d(prof.at(np.array([prof.s_le])), p, cen)[0],
            te=dca_to_3d(prof.at(np.array([0.0])), p, cen)[0],
            on_le=(sm >= le_lo) & (sm <= le_hi),
            on_te=(sm <= te_hi) | (sm >= te_lo + L),
            d_le=d_le, start_deg=start_deg, kf=prof.flank_curvatures()))
        sections.append(sec)
    return sections, info


def nose_spacings(sec, on):
    """Spacings between consecutive samples that both lie on a nose."""
    both = on[:-1] & on[1:]
    return spacings(sec)[both]


def dca_stats(d):
    sec = d["sec"]
    d["sp"] = spacings(sec)
    d["gap"] = np.linalg.norm(sec[-1] - sec[0])
    d["n_le"], d["n_te"] = int(d["on_le"].sum()), int(d["on_te"].sum())
    d["ds_le"] = nose_spacings(sec, d["on_le"])
    d["ds_te"] = nose_spacings(sec, d["on_te"])


def check_dca(info):
    r_means = []
    for d in info:
        dca_stats(d)
        sec, p = d["sec"], d["p"]
        assert sec.shape == (DCA_N_POINTS, 3)
        assert 0.005 <= d["gap"] <= 0.010, d["gap"]                 # near-closed, 0 not repeated
        assert d["gap"] < d["sp"].min()                              # closing step is the shortest
        assert 15 <= d["n_le"] <= 25 and 15 <= d["n_te"] <= 25, (d["n_le"], d["n_te"])
        assert 0.025 <= d["ds_le"].min() and d["ds_le"].max() <= 0.045, d["ds_le"]
        assert 0.015 <= d["ds_te"].min() and d["ds_te"].max() <= 0.030, d["ds_te"]
        assert 2.0 <= d["sp"].max() <= 3.0, d["sp"].max()            # coarse flanks
        assert d["on_te"][0] and d["on_te"][-1]                       # starts and ends on the TE nose
        assert d["d_le"] > 0.005                                      # no sample at the LE point
        y = sec[:, 1]
        assert y.min() < 0.0 < y.max()                               # straddles the x-z plane
        r = np.hypot(sec[:, 0], sec[:, 1])                           # on its cone: r linear in z
        r_line = p["r_stack"] + (sec[:, 2] - DCA_Z0 - p["sweep"]) * np.tan(np.radians(d["eps_deg"]))
        assert np.abs(r - r_line).max() < 1e-5
        rise = np.hypot(*d["te"][:2]) - np.hypot(*d["le"][:2])       # LE -> TE radius rise
        assert abs(rise - p["rise"]) < 1e-9
        r_means.append(r.mean())
    assert np.all(np.diff(r_means) > 0)                              # hub -> tip
    assert -0.6 < info[0]["sec"][:, 2].min() < -0.4                  # hub LE slightly below z = 0


def print_dca(info):
    print("dev_rotor_dca_11x181.csv  (closed, first point not repeated; lengths in mm)")
    print(" sec  r-range[mm]      chord stagger camber  t/c   rise cone  LE nose: n, ds       "
          "TE nose: n, ds       min-ds max-ds  gap     z-range")
    for d in info:
        sec, p = d["sec"], d["p"]
        r = np.hypot(sec[:, 0], sec[:, 1])
        print(f"{d['k']:3d}  {r.min():6.2f}..{r.max():6.2f}  {p['chord']:5.1f} {p['stagger_deg']:6.1f} "
              f"{p['camber_deg']:6.1f} {p['t_rel']:.3f} {p['rise']:4.1f} {d['eps_deg']:4.1f}  "
              f"{d['n_le']:2d} {d['ds_le'].min():.4f}-{d['ds_le'].max():.4f}  "
              f"{d['n_te']:2d} {d['ds_te'].min():.4f}-{d['ds_te'].max():.4f}  "
              f"{d['sp'].min():.4f} {d['sp'].max():.3f}  {d['gap']:.4f}  "
              f"{sec[:, 2].min():6.2f}..{sec[:, 2].max():6.2f}")


# ----------------------------------------------------------------------------
# 2. rotor with a blunt trailing edge and an elliptic leading edge
# ----------------------------------------------------------------------------
BL_N_SECTIONS = 9
BL_N_POINTS = 120
BL_TE_WIDTH = 0.4          # mm, flat trailing-edge base (not sampled)
BL_H_TE_S = 0.10           # spacing at the suction-side TE corner, mm
BL_H_TE_P = 0.13           # spacing at the pressure-side TE corner, mm
BL_H_MAX = 2.5             # largest flank spacing, mm
BL_THETA0_DEG = 25.0       # angular position of the stacking line
BL_Z0 = 60.0               # axial position of the stacking line, mm


def blunt_laws(h):
    return dict(
        r=110.0 + 80.0 * h,                  # cylinder radius, mm (step 10 mm)
        chord=58.0 - 12.0 * h,               # mm
        t_rel=0.08 - 0.035 * h,              # max thickness / chord
        x_tmax=0.42 + 0.08 * h,              # chordwise position of max thickness
        camber_deg=42.0 - 24.0 * h,          # camber angle (LE + TE mean-line slopes)
        p_camber=0.42 + 0.06 * h,            # chordwise position of max camber
        stagger_deg=24.0 + 28.0 * h,         # chord angle from axial
        a_le=0.016 - 0.004 * h,              # ellipse semi-axis along the chord / chord (2:1)
        sweep=4.0 * h ** 2,                  # axial shift of the centroid, mm
        lean=-3.0 * h,                       # circumferential shift of the centroid, mm
    )


def naca_meanline(x, m, p):
    """NACA 4-digit mean line (two parabolas meeting at x = p, max camber m)."""
    yc = np.where(x < p, m / p ** 2 * (2 * p * x - x ** 2),
                  m / (1 - p) ** 2 * ((1 - 2 * p) + 2 * p * x - x ** 2))
    dyc = np.where(x < p, 2 * m / p ** 2 * (p - x), 2 * m / (1 - p) ** 2 * (p - x))
    return yc, dyc


def naca_m_for_camber(camber_deg, p):
    """Max camber m of the NACA mean line whose end slopes sum to camber_deg."""
    target = np.radians(camber_deg)
    lo, hi = 0.0, 0.5
    for _ in range(200):
        m = 0.5 * (lo + hi)
        if np.arctan(2 * m / p) + np.arctan(2 * m / (1 - p)) < target:
            lo = m
        else:
            hi = m
    return 0.5 * (lo + hi)


class BluntProfile:
    """Open section in chord units: elliptic LE, parabolic flanks, blunt TE.

    Half thickness y_t(x):
      x in [0, x_j]     2:1 ellipse, semi-axes a (along the chord) and a/2,
                        vertex at the LE: x = a(1 - cos tau), y_t = (a/2) sin tau
      x in [x_j, x_m]   parabola with its vertex (max half thickness T) at x_m,
                        tangent to the ellipse at x_j (C1 join)
      x in [x_m, 1]     parabola from the vertex down to y_te = TE_width / 2
    The thickness is laid perpendicular to the NACA 4-digit mean line.
    Parameter p in [0, 4]: upper (suction) x = 1 -> x_j, ellipse tau_j -> 0,
    ellipse 0 -> tau_j (lower), lower x_j -> 1.
    """

    def __init__(self, p, chord):
        self.a = a = p["a_le"]
        self.b = b = 0.5 * a
        self.T = T = 0.5 * p["t_rel"]
        self.xm = xm = p["x_tmax"]
        self.yte = 0.5 * BL_TE_WIDTH / chord
        self.m = naca_m_for_camber(p["camber_deg"], p["p_camber"])
        self.pc = p["p_camber"]
        assert T > b

        def ye(x):
            return 0.5 * np.sqrt(2 * a * x - x * x)

        def dye(x):
            return 0.5 * (a - x) / np.sqrt(2 * a * x - x * x)

        lo, hi = 1e-12, a                 # f(x_j) = y_e + y_e' (x_m - x_j)/2 - T
        for _ in range(200):
            xj = 0.5 * (lo + hi)
            if ye(xj) + dye(xj) * (xm - xj) / 2 - T > 0:
                lo = xj
            else:
                hi = xj
        self.xj = xj = 0.5 * (lo + hi)
        self.y0 = T - dye(xj) * xm ** 2 / (2 * (xm - xj))
        self.tau_j = np.arccos(1.0 - xj / a)
        # C1 checks of the join
        assert abs(ye(xj) - self._yt_front(xj)) < 1e-12
        assert abs(dye(xj) - self._dyt_front(xj)) < 1e-9

    def _yt_front(self, x):
        return self.T - (self.T - self.y0) * ((self.xm - x) / self.xm) ** 2

    def _dyt_front(self, x):
        return 2 * (self.T - self.y0) * (self.xm - x) / self.xm ** 2

    def yt_flank(self, x):
        rear = self.T - (self.T - self.yte) * ((x - self.xm) / (1 - self.xm)) ** 2
        return np.where(x < self.xm, self._yt_front(x), rear)

    def surface(self, x, yt, sign):
        yc, dyc = naca_meanline(x, self.m, self.pc)
        th = np.arctan(dyc)
        return np.column_stack([x - sign * yt * np.sin(th), yc + sign * yt * np.cos(th)])

    def __call__(self, p):
        p = np.atleast_1d(np.asarray(p, dtype=float))
        out = np.empty((p.size, 2))
        piece = np.clip(np.floor(p).astype(int), 0, 3)
        u = p - piece
        for i in range(4):
            sel = piece == i
            ui = u[sel]
            if i in (0, 3):
                x = 1.0 - (1.0 - self.xj) * ui if i == 0 else self.xj + (1.0 - self.xj) * ui
                out[sel] = self.surface(x, self.yt_flank(x), +1 if i == 0 else -1)
            else:
                tau = self.tau_j * (1.0 - ui) if i == 1 else self.tau_j * ui
                x = self.a * (1.0 - np.cos(tau))
                out[sel] = self.surface(x, self.b * np.sin(tau), +1 if i == 1 else -1)
        return out


def make_blunt():
    sections, info = [], []
    for k in range(BL_N_SECTIONS):
        h = k / (BL_N_SECTIONS - 1)
        p = blunt_laws(h)
        c, r = p["chord"], p["r"]
        prof = BluntProfile(p, c)
        curve = ParamCurve(lambda q: c * prof(q), 4)
        L = curve.length
        s_n1, s_n2 = curve.s_of_p(1.0), curve.s_of_p(3.0)      # the elliptic nose
        s_le = curve.s_of_p(2.0)                               # the LE point (ellipse vertex)
        h_nose = p["a_le"] * c / 16.0
        h_te = BL_H_TE_P
        for _ in range(50):                                    # keep samples off the LE point
            anchors = [(s_n1, s_n2, h_nose), (0.0, 0.0, BL_H_TE_S), (L, L, h_te)]
            st, growth = graded_stations(0.0, L, BL_N_POINTS - 1, anchors, BL_H_MAX)
            d_le = np.abs(st - s_le).min()
            if d_le > 0.2 * h_nose:
                break
            h_te *= 1.03
        P2 = curve.at_arclength(st)
        dense = curve.at_arclength(np.linspace(0.0, L, 40001))   # closed by the TE base
        cx, cy = polygon_centroid(dense[:, 0], dense[:, 1])
        g = np.radians(p["stagger_deg"])
        u, v = P2[:, 0] - cx, P2[:, 1] - cy
        m = u * np.cos(g) - v * np.sin(g) + BL_Z0 + p["sweep"]
        s = u * np.sin(g) + v * np.cos(g) + r * np.radians(BL_THETA0_DEG) + p["lean"]
        theta = s / r
        sec = np.column_stack([r * np.cos(theta), r * np.sin(theta), m])
        info.append(dict(k=k, p=p, sec=sec, growth=growth, h_te=h_te, xj=prof.xj,
                         on_nose=(st >= s_n1) & (st <= s_n2), d_le=d_le,
                         n_suction=int((st < s_le).sum())))
        sections.append(sec)
    return sections, info


def check_blunt(info):
    prev_r = -np.inf
    for d in info:
        sec, p = d["sec"], d["p"]
        d["sp"] = spacings(sec)
        d["te_width"] = np.linalg.norm(sec[-1] - sec[0])
        d["n_nose"] = int(d["on_nose"].sum())
        d["ds_nose"] = nose_spacings(sec, d["on_nose"])
        assert sec.shape == (BL_N_POINTS, 3)
        r = np.hypot(sec[:, 0], sec[:, 1])
        assert np.abs(r - p["r"]).max() < 1e-5                      # on its cylinder
        assert p["r"] > prev_r                                       # hub -> tip
        prev_r = p["r"]
        assert abs(d["te_width"] - BL_TE_WIDTH) < 1e-3, d["te_width"]  # open: TE base not sampled
        assert 25 <= d["n_nose"] <= 35, d["n_nose"]
        assert 0.03 <= d["ds_nose"].min() and d["ds_nose"].max() <= 0.06
        assert 0.03 <= d["sp"].min() and d["sp"].max() <= BL_H_MAX + 1e-3
        assert d["d_le"] > 0.005                                     # no sample at the LE point


def print_blunt(info):
    print("dev_rotor_blunt_9x120.csv  (open: point 0 = suction TE corner, "
          "point 119 = pressure TE corner)")
    print(" sec   r[mm]  chord stagger camber  t/c   ellipse a[mm]  nose: n, ds          "
          "n_suct  min-ds max-ds  TE base  x-range          y-range          z-range")
    for d in info:
        sec, p = d["sec"], d["p"]
        lo, hi = sec.min(axis=0), sec.max(axis=0)
        print(f"{d['k']:3d}  {p['r']:6.1f}  {p['chord']:5.1f} {p['stagger_deg']:6.1f} "
              f"{p['camber_deg']:6.1f} {p['t_rel']:.4f}  {p['a_le'] * p['chord']:.3f}       "
              f"{d['n_nose']:2d} {d['ds_nose'].min():.4f}-{d['ds_nose'].max():.4f}  "
              f"{d['n_suction']:3d}   {d['sp'].min():.4f} {d['sp'].max():.3f}  "
              f"{d['te_width']:.4f}  {lo[0]:6.2f}..{hi[0]:6.2f}  {lo[1]:6.2f}..{hi[1]:6.2f}  "
              f"{lo[2]:6.2f}..{hi[2]:6.2f}")


# ----------------------------------------------------------------------------
# 3. marine propeller blade, helical sections
# ----------------------------------------------------------------------------
PR_DIAMETER = 300.0
PR_X = (0.3, 0.4, 0.5, 0.6, 0.7, 0.8, 0.9)
PR_N_POINTS = 100
PR_A = 0.8                 # NACA a-series mean line, a = 0.8
PR_XT = 0.45               # chordwise position of max thickness
PR_KLE = 0.55              # LE radius = PR_KLE * t^2 * c
PR_TE_SLOPE = 2.0          # -d(y_t/(t/2))/dx at the TE (closed, thin wedge)


def prop_laws(x):
    """Design values at r/R = x."""
    w = 0.5 if x <= 0.7 else 0.36
    return dict(
        pitch_ratio=1.10 - 0.35 * (x - 0.7) ** 2,                 # P/D
        chord=PR_DIAMETER * 0.24 * np.sqrt(1.0 - ((x - 0.7) / w) ** 2),
        thickness=PR_DIAMETER * (0.038 - 0.034 * x),             # max thickness, mm
        camber_rel=0.032 - 0.020 * x,                            # max camber / chord
        skew_deg=20.0 * ((x - 0.3) / 0.7) ** 2,                  # 20 deg at r/R = 1
    )


def _xlogx(u):
    u = np.asarray(u, dtype=float)
    out = np.zeros_like(u)
    pos = u > 0
    out[pos] = u[pos] * np.log(u[pos])
    return out


def a_meanline_shape(x, a=PR_A):
    """NACA a-series mean line (Abbott & von Doenhoff), up to the factor c_li."""
    g = -1.0 / (1 - a) * (a ** 2 * (0.5 * np.log(a) - 0.25) + 0.25)
    h = 1.0 / (1 - a) * (0.5 * (1 - a) ** 2 * np.log(1 - a) - 0.25 * (1 - a) ** 2) + g
    am, om = np.abs(a - x), 1.0 - x
    y = (1.0 / (1 - a) * (0.5 * am * _xlogx(am) - 0.5 * om * _xlogx(om)
                          + 0.25 * om ** 2 - 0.25 * (a - x) ** 2)
         - _xlogx(x) + g - h * x)
    return y / (2 * np.pi * (a + 1))


def prop_thickness_coeffs():
    """y_t/(t/2) = a0 sqrt(x) + a1 x + a2 x^2 + a3 x^3 + a4 x^4 with
    LE radius PR_KLE t^2 c, max 1 at PR_XT (zero slope), y(1) = 0 and
    y'(1) = -PR_TE_SLOPE.  Returns (a0..a4)."""
    a0 = 2.0 * np.sqrt(2.0 * PR_KLE)
    xm = PR_XT
    A = np.array([[1, 1, 1, 1],
                  [xm, xm ** 2, xm ** 3, xm ** 4],
                  [1, 2 * xm, 3 * xm ** 2, 4 * xm ** 3],
                  [1, 2, 3, 4]], dtype=float)
    rhs = np.array([-a0, 1 - a0 * np.sqrt(xm), -a0 * 0.5 / np.sqrt(xm), -PR_TE_SLOPE - 0.5 * a0])
    return np.concatenate([[a0], np.linalg.solve(A, rhs)])


def make_prop():
    R = 0.5 * PR_DIAMETER
    coef = prop_thickness_coeffs()
    xx = np.linspace(0, 1, 200001)
    shape = a_meanline_shape(xx)
    shape_max = shape.max()
    yt_n = coef[0] * np.sqrt(xx) + coef[1] * xx + coef[2] * xx ** 2 + coef[3] * xx ** 3 + coef[4] * xx ** 4
    imax = np.argmax(yt_n)
    assert abs(yt_n.max() - 1.0) < 1e-8 and abs(xx[imax] - PR_XT) < 1e-4
    assert np.all(np.diff(yt_n[:imax]) > 0) and np.all(np.diff(yt_n[imax:]) < 0)   # one hump
    sections, info = [], []
    k_idx = np.arange(PR_N_POINTS)
    phi_k = 2.0 * np.pi * k_idx / PR_N_POINTS
    xc = 0.5 * (1.0 + np.cos(phi_k))               # k = 0: TE, k = 50: LE
    side = np.where(k_idx <= PR_N_POINTS // 2, 1.0, -1.0)   # +1 suction (back)
    for k, x in enumerate(PR_X):
        p = prop_laws(x)
        r, c = x * R, p["chord"]
        t_rel = p["thickness"] / c
        P = p["pitch_ratio"] * PR_DIAMETER
        phi = np.arctan(P / (2 * np.pi * r))
        yt = 0.5 * t_rel * (coef[0] * np.sqrt(xc) + coef[1] * xc + coef[2] * xc ** 2
                            + coef[3] * xc ** 3 + coef[4] * xc ** 4)
        yt = np.maximum(yt, 0.0)
        yc = p["camber_rel"] * a_meanline_shape(xc) / shape_max
        eta = yc + side * yt              # thickness perpendicular to the nose-tail line
        ths = np.radians(p["skew_deg"])
        s_mid, z_mid = -r * ths, r * ths * np.tan(phi)      # skew back along the helix
        e_c = np.array([-np.cos(phi), np.sin(phi)])         # LE -> TE in (s, z)
        n_s = np.array([-np.sin(phi), -np.cos(phi)])        # suction side faces upstream
        s = s_mid + c * (xc - 0.5) * e_c[0] + c * eta * n_s[0]
        z = z_mid + c * (xc - 0.5) * e_c[1] + c * eta * n_s[1]
        theta = s / r
        sec = np.column_stack([r * np.cos(theta), r * np.sin(theta), z])
        info.append(dict(k=k, x=x, r=r, p=p, sec=sec, phi_deg=np.degrees(phi),
                         P=P, t_rel=t_rel))
        sections.append(sec)
    return sections, info


def check_prop(info):
    prev = -np.inf
    i_le = PR_N_POINTS // 2
    for d in info:
        sec = d["sec"]
        d["sp"] = spacings(sec)
        d["close"] = np.linalg.norm(sec[-1] - sec[0])
        theta = np.arctan2(sec[:, 1], sec[:, 0])
        # pitch of the nose-tail line from the LE (point 50) and TE (point 0) samples
        d["pitch"] = 2 * np.pi * (sec[0, 2] - sec[i_le, 2]) / (theta[i_le] - theta[0])
        assert sec.shape == (PR_N_POINTS, 3)
        r = np.hypot(sec[:, 0], sec[:, 1])
        assert np.abs(r - d["r"]).max() < 1e-5                      # on its cylinder r = const
        assert d["r"] > prev                                         # root -> tip
        prev = d["r"]
        assert abs(d["pitch"] - d["P"]) < 1e-2, (d["pitch"], d["P"])  # nose-tail line on the helix
        assert 0.0 < d["close"] <= 0.1                               # closed, point 0 not repeated
        assert 0.04 <= d["sp"].min() and d["sp"].max() <= 2.5
        assert sec[i_le, 2] < sec[0, 2]                              # LE upstream (low z)


def print_prop(info):
    print("dev_prop_7x100.csv  (closed, point 0 = TE, point 50 = LE, first point not repeated)")
    print(" sec  r/R  r[mm]  chord  t/c    f/c    P/D    pitch-angle skew   min-ds max-ds  "
          "last->first  x-range          y-range          z-range")
    for d in info:
        sec, p = d["sec"], d["p"]
        lo, hi = sec.min(axis=0), sec.max(axis=0)
        print(f"{d['k']:3d}  {d['x']:.1f}  {d['r']:5.1f}  {p['chord']:5.2f}  {d['t_rel']:.4f} "
              f"{p['camber_rel']:.4f} {p['pitch_ratio']:.4f}  {d['phi_deg']:6.2f}    "
              f"{p['skew_deg']:5.2f}  {d['sp'].min():.4f} {d['sp'].max():.3f}  {d['close']:.4f}     "
              f"{lo[0]:6.2f}..{hi[0]:6.2f}  {lo[1]:7.2f}..{hi[1]:6.2f}  {lo[2]:6.2f}..{hi[2]:6.2f}")


# ----------------------------------------------------------------------------


def dca_truth(n_points=1000):
    """The DCA rotor's true surface between its sections: one contour at each span fraction
    midway between two data sections (h = (k + 0.5) / 10), sampled uniformly in arc length
    (n_points per contour, closed, first point not repeated).  For measuring a fit's error
    between sections: distance from these points to the fitted surface."""
    sections = []
    for k in range(DCA_N_SECTIONS - 1):
        h = (k + 0.5) / (DCA_N_SECTIONS - 1)
        p = dca_laws(h)
        prof = DCAProfile(p["camber_deg"], p["t_rel"])
        dense = prof.at(np.linspace(0.0, prof.length, 40001)[:-1])
        cen = polygon_centroid(dense[:, 0], dense[:, 1])
        u = np.linspace(0.0, prof.length, n_points + 1)[:-1]
        sections.append(np.round(dca_to_3d(prof.at(u), p, cen), 6) + 0.0)
    return sections


def main():
    out_dir = sys.argv[1] if len(sys.argv) > 1 else os.path.dirname(os.path.abspath(__file__))
    os.makedirs(out_dir, exist_ok=True)
    jobs = [("dev_rotor_dca_11x181.csv", make_dca, check_dca, print_dca),
            ("dev_rotor_blunt_9x120.csv", make_blunt, check_blunt, print_blunt),
            ("dev_prop_7x100.csv", make_prop, check_prop, print_prop)]
    for name, make, check, show in jobs:
        sections, info = make()
        sections = [np.round(sec, 6) + 0.0 for sec in sections]   # what the file will hold
        for d, sec in zip(info, sections):
            d["sec"] = sec
        check(info)                                  # checks run on the rounded points
        path = os.path.join(out_dir, name)
        write_csv(path, sections)
        back = read_back(path)
        assert len(back) == len(sections)
        assert all(np.abs(b - s).max() < 1e-9 for b, s in zip(back, sections))
        show(info)
        print()
    truth = dca_truth()
    path = os.path.join(out_dir, "dev_rotor_dca_truth_10x1000.csv")
    write_csv(path, truth)
    print(f"wrote {os.path.basename(path)}: the true surface midway between the DCA sections")


if __name__ == "__main__":
    main()
