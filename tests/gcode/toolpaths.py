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


def random_mixed(rng: np.random.Generator, pieces: int = 30, *, five_axis: bool = True) -> Toolpath:
    """A random path of mixed pieces: rapids, lines, sampled circles, repeated points and
    (``five_axis``) sweeps that turn the tool axis while the tip moves.

    Lines and circles keep the tool axis (G94, arc candidates on any plane); sweeps turn
    it (G93 where the dialect has it). Pieces are 1 to 80 points long, so runs of moves
    are both shorter and longer than the post's column threshold.
    """
    tip = np.array([0.0, 0.0, 20.0])
    tilt, lean = 0.0, 0.0
    pts, axes, kinds, feeds = [], [], [], []

    def axis_of(t, le):
        t, le = np.radians(t), np.radians(le)
        return np.column_stack([np.sin(t) * np.cos(le), np.sin(t) * np.sin(le), np.cos(t)])

    def add(p, ax, kind, feed):
        pts.append(p)
        axes.append(ax)
        kinds.extend([kind] * len(p))
        feeds.extend([feed] * len(p))

    add(tip[None], axis_of(np.array([0.0]), np.array([0.0])), K.RAPID, 0.0)
    for _ in range(pieces):
        piece = rng.choice(["rapid", "line", "circle", "sweep", "repeat"] if five_axis
                           else ["rapid", "line", "circle", "repeat"])  # fmt: skip
        k = int(rng.integers(1, 81))
        feed = float(rng.choice([300.0, 900.0, 1500.0]))
        if piece == "rapid":
            tip = tip + rng.uniform(-20, 20, 3)
            add(tip[None], axis_of(np.array([tilt]), np.array([lean])), K.RAPID, 0.0)
        elif piece == "line":
            steps = np.outer(np.arange(1, k + 1), rng.uniform(-2, 2, 3))
            p = tip + steps
            add(p, axis_of(np.full(k, tilt), np.full(k, lean)), K.CUT, feed)
            tip = p[-1]
        elif piece == "circle":
            u, v = [(0, 1), (2, 0), (1, 2)][int(rng.integers(3))]
            r = float(rng.uniform(3, 20))
            a0 = float(rng.uniform(0, 2 * np.pi))
            a = a0 + np.linspace(0, rng.choice([-1, 1]) * rng.uniform(0.5, 3), k + 1)[1:]
            centre = tip.copy()
            centre[u] -= r * np.cos(a0)
            centre[v] -= r * np.sin(a0)
            p = np.repeat(tip[None], k, axis=0)
            p[:, u] = centre[u] + r * np.cos(a)
            p[:, v] = centre[v] + r * np.sin(a)
            add(p, axis_of(np.full(k, tilt), np.full(k, lean)), K.CUT, feed)
            tip = p[-1]
        elif piece == "sweep":
            new_tilt = float(rng.uniform(0, 40))
            new_lean = lean + float(rng.uniform(-60, 60))
            s = np.linspace(0, 1, k + 1)[1:]
            p = tip + np.outer(s, rng.uniform(-10, 10, 3))
            add(p, axis_of(tilt + s * (new_tilt - tilt), lean + s * (new_lean - lean)),
                K.CUT, feed)  # fmt: skip
            tip, tilt, lean = p[-1], new_tilt, new_lean
        else:  # the same point again: a move that changes nothing
            k = min(k, 3)
            add(np.repeat(tip[None], k, axis=0),
                axis_of(np.full(k, tilt), np.full(k, lean)), K.CUT, feed)  # fmt: skip
    n = len(kinds)
    return Toolpath(np.vstack(pts), np.vstack(axes), kinds, feeds, [0] * n, {"name": "mixed"})
