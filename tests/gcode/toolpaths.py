"""Small toolpaths shared by the post, check and CLI tests."""

from __future__ import annotations

import numpy as np

from toolpath import MoveKind, Toolpath

K = MoveKind


def _toolpath(segments, axes=None, name="test"):
    """Concatenate (points, kind, feed, pass) pieces into a Toolpath."""
    pts, kinds, feeds, passes = [], [], [], []
    for p, kind, feed, pi in segments:
        p = np.atleast_2d(np.asarray(p, dtype=float))
        pts.append(p)
        kinds += [kind] * len(p)
        feeds += [feed] * len(p)
        passes += [pi] * len(p)
    pos = np.vstack(pts)
    tool_axes = np.array([0.0, 0.0, 1.0]) if axes is None else axes
    return Toolpath(pos, tool_axes, kinds, feeds, passes, {"name": name})


def pocket_3axis() -> Toolpath:
    """A 3-axis pass: plunge, line, a sampled quarter circle in XY, a line, a ZX bowl, out.

    The quarter circle (radius 10 mm about (10, 10)) and the half circle in the plane
    Y = 20 (radius 5 mm about X 25, Z 4) are sampled within a 5 um chord tolerance, so
    the post fits arcs.
    """
    t = np.linspace(-np.pi / 2, 0.0, 41)[1:]
    quarter = np.column_stack([10 + 10 * np.cos(t), 10 + 10 * np.sin(t), np.full(t.size, -1.0)])
    s = np.linspace(np.pi, 2 * np.pi, 61)[1:]
    bowl = np.column_stack([25 + 5 * np.cos(s), np.full(s.size, 20.0), 4 + 5 * np.sin(s)])
    return _toolpath(
        [
            ([0.0, 0.0, 5.0], K.RAPID, 0.0, -1),
            ([0.0, 0.0, -1.0], K.PLUNGE, 300.0, 0),
            ([10.0, 0.0, -1.0], K.CUT, 800.0, 0),
            (quarter, K.CUT, 800.0, 0),
            ([20.0, 20.0, -1.0], K.CUT, 800.0, 0),
            ([20.0, 20.0, 4.0], K.LINK, 600.0, -1),
            (bowl, K.CUT, 700.0, 1),
            ([30.0, 20.0, 10.0], K.RETRACT, 1000.0, -1),
        ],
        name="pocket 3-axis",
    )


def blade_5axis(n: int = 9) -> Toolpath:
    """A tilted 5-axis pass: the tool axis leans from 10 to 40 degrees while the tip moves.

    Then a few points at a fixed tilt (written in G94) and a retract along the last axis.
    """
    t = np.linspace(0.0, 1.0, n)
    tips = np.column_stack([-20 + 40 * t, 6 * np.sin(2.5 * t), 2.0 - t])
    tilt = np.radians(10 + 30 * t)
    lean = np.radians(20 + 40 * t)
    axes = np.column_stack(
        [np.sin(tilt) * np.cos(lean), np.sin(tilt) * np.sin(lean), np.cos(tilt)]
    )
    flat = tips[-1] + np.array([[0.0, -3.0, 0.0], [0.0, -6.0, 0.0]])
    out = tips[-1] + 10.0 * axes[-1]
    start = tips[0] + 10.0 * axes[0]
    pos = np.vstack([start, tips, flat, out])
    ax = np.vstack([axes[:1], axes, axes[-1:], axes[-1:], axes[-1:]])
    kinds = [K.RAPID, K.PLUNGE] + [K.CUT] * (n - 1) + [K.CUT, K.CUT, K.RETRACT]
    feeds = [0.0, 400.0] + [900.0] * (n - 1) + [900.0, 900.0, 2000.0]
    passes = [-1] + [0] * (n + 2) + [-1]
    return Toolpath(pos, ax, kinds, feeds, passes, {"name": "blade 5-axis", "surface": "test"})


def random_5axis(rng: np.random.Generator, n: int = 60) -> Toolpath:
    """A smooth random 5-axis cut (tilt up to 50 degrees), reached by a rapid."""
    t = np.linspace(0.0, 1.0, n)
    c = rng.uniform(-1.0, 1.0, (4, 3))
    tips = c[0] * 30 + np.outer(t, c[1] * 40) + np.outer(np.sin(3 * t), c[2] * 10)
    tilt = np.radians(5 + 45 * np.abs(np.sin(2 * t + c[3, 0])))
    lean = np.radians(180 * c[3, 1] + 120 * t)
    axes = np.column_stack(
        [np.sin(tilt) * np.cos(lean), np.sin(tilt) * np.sin(lean), np.cos(tilt)]
    )
    kinds = [K.RAPID] + [K.CUT] * (n - 1)
    feeds = [0.0] + [1200.0] * (n - 1)
    return Toolpath(tips, axes, kinds, feeds, [0] * n, {})
