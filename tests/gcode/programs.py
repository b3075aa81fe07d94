"""Hand-built and random programs shared by the gcode tests."""

from __future__ import annotations

import math

import numpy as np

from gcode import (
    Arc,
    Comment,
    Coolant,
    CoolantMode,
    Dialect,
    DistanceMode,
    Dwell,
    FeedMode,
    Linear,
    Plane,
    Program,
    ProgramEnd,
    Rapid,
    SetDistanceMode,
    SetFeedMode,
    SetPlane,
    SetWorkOffset,
    Spindle,
    SpindleDirection,
    ToolChange,
)


def golden_3axis() -> Program:
    """A small pocket-corner program in mm: every block kind GRBL takes."""
    return Program(
        (
            Comment("golden 3-axis: corner with arc"),
            SetWorkOffset(1),
            Spindle(SpindleDirection.CW, 12000.0),
            Coolant(CoolantMode.FLOOD),
            Rapid(x=0.0, y=0.0, z=5.0),
            Linear(z=-1.0, feed=300.0),
            Linear(x=20.0, feed=800.0),
            Linear(y=10.0, feed=800.0),
            Arc(clockwise=False, x=15.0, y=15.0, i=-5.0, j=0.0, feed=800.0),
            Linear(x=-0.0004, y=15.0, feed=800.0),
            Arc(clockwise=True, x=-5.0, y=10.0, r=5.0, feed=600.0),
            Linear(x=-5.0, y=0.1234567, feed=600.0),
            Dwell(0.25),
            Rapid(z=5.0),
            Coolant(CoolantMode.OFF),
            Spindle(SpindleDirection.OFF, 12000.0),
            ProgramEnd(rewind=True),
        ),
        name="GOLDEN3",
        number=1001,
    )


def golden_5axis() -> Program:
    """A 5-axis fragment with a tool change and inverse-time feed (LinuxCNC, Fanuc)."""
    return Program(
        (
            Comment("golden 5-axis: tilted pass"),
            ToolChange(3),
            Spindle(SpindleDirection.CW, 18000.0),
            Coolant(CoolantMode.MIST),
            Rapid(x=10.0, y=-5.0, z=30.0, a=0.0, c=0.0),
            Linear(z=2.0, feed=1500.0),
            SetFeedMode(FeedMode.INVERSE_TIME),
            Linear(x=12.5, y=-4.0, z=1.25, a=15.0, c=-30.0, feed=120.0),
            Linear(x=15.0, y=-2.5, z=0.75, a=22.5, c=-45.0, feed=96.1538),
            Linear(x=17.5, y=0.0, z=0.5, a=30.0, c=-60.0, feed=96.1538),
            SetFeedMode(FeedMode.UNITS_PER_MINUTE),
            SetPlane(Plane.ZX),
            Arc(clockwise=True, x=20.0, z=0.5, i=1.25, k=0.5, plane=Plane.ZX, feed=900.0),
            SetPlane(Plane.XY),
            SetDistanceMode(DistanceMode.INCREMENTAL),
            Rapid(z=20.0),
            SetDistanceMode(DistanceMode.ABSOLUTE),
            Rapid(a=0.0, c=0.0),
            Spindle(SpindleDirection.OFF, 18000.0),
            Coolant(CoolantMode.OFF),
            ProgramEnd(rewind=True),
        ),
        name="GOLDEN5",
        number=1002,
    )


def _q(v: float, decimals: int) -> float:
    return round(v * 10**decimals) / 10**decimals


def random_program(rng: np.random.Generator, dialect: Dialect, n: int = 60) -> Program:
    """A random valid program whose values are exact at the dialect's resolution.

    Coordinates are multiples of 0.001 mm, angles of 0.001 degree, feeds of 0.1 mm/min
    (0.0001 1/min in inverse time), so ``parse(emit(p))`` must reproduce them exactly.
    """
    dec = dialect.decimals
    blocks: list = []
    pos = [0.0] * 6
    incremental = False
    inverse = False
    axes = list(dialect.axes)

    def coord(name: str) -> float:
        d = dec.angle if name in "abc" else dec.coord_mm
        lim = 360.0 if name in "abc" else 200.0
        return _q(float(rng.uniform(-lim, lim)), d)

    def feed() -> float:
        if inverse:
            return _q(float(rng.uniform(0.05, 500.0)), dec.inverse_time) or 1.0
        return _q(float(rng.uniform(10.0, 5000.0)), dec.feed_mm)

    for _ in range(n):
        r = rng.random()
        if r < 0.55:
            names = [a for a in axes if rng.random() < 0.5] or [axes[int(rng.integers(len(axes)))]]
            vals = {a: coord(a) for a in names}
            for a, v in vals.items():
                k = "xyzabc".index(a)
                pos[k] = float("nan") if incremental else v
            if rng.random() < 0.3:
                blocks.append(Rapid(**vals))
            else:
                blocks.append(Linear(**vals, feed=feed()))
        elif r < 0.65 and not incremental and not (math.isnan(pos[0]) or math.isnan(pos[1])):
            radius = float(rng.uniform(1.0, 50.0))
            a0 = float(rng.uniform(0, 2 * math.pi))
            i, j = _q(-radius * math.cos(a0), 3), _q(-radius * math.sin(a0), 3)
            cx, cy = pos[0] + i, pos[1] + j
            rr = math.hypot(i, j)
            a1 = float(rng.uniform(0, 2 * math.pi))
            x, y = _q(cx + rr * math.cos(a1), 3), _q(cy + rr * math.sin(a1), 3)
            blocks.append(Arc(clockwise=bool(rng.random() < 0.5), x=x, y=y, i=i, j=j, feed=feed()))
            pos[0], pos[1] = x, y
        elif r < 0.70:
            blocks.append(Dwell(_q(float(rng.uniform(0, 3)), 3)))
        elif r < 0.75:
            d = SpindleDirection(int(rng.choice([3, 4, 5])))
            blocks.append(Spindle(d, float(int(rng.integers(0, 24000)))))
        elif r < 0.79:
            blocks.append(Coolant(CoolantMode(int(rng.choice([7, 8, 9])))))
        elif r < 0.82:
            blocks.append(Comment(f"note {int(rng.integers(1000))} [x]"))
        elif r < 0.85:
            blocks.append(SetWorkOffset(int(rng.integers(1, 7))))
        elif r < 0.89:
            incremental = not incremental
            mode = DistanceMode.INCREMENTAL if incremental else DistanceMode.ABSOLUTE
            blocks.append(SetDistanceMode(mode))
        elif r < 0.93 and dialect.inverse_time:
            inverse = not inverse
            blocks.append(
                SetFeedMode(FeedMode.INVERSE_TIME if inverse else FeedMode.UNITS_PER_MINUTE)
            )
        elif r < 0.96 and dialect.tool_change:
            blocks.append(ToolChange(int(rng.integers(0, 30))))
        else:
            blocks.append(Rapid(z=_q(float(rng.uniform(0, 50)), 3)))
            if not incremental:
                pos[2] = blocks[-1].z
    blocks.append(ProgramEnd(rewind=bool(rng.random() < 0.5)))
    return Program(tuple(blocks), name="RANDOM", number=int(rng.integers(1, 9999)))


def assert_blocks_close(got, want, *, length_tol: float, angle_tol: float, feed_tol: float):
    """Blocks equal field by field, floats within the given tolerances (mm, deg, feed)."""
    assert len(got) == len(want), (len(got), len(want))
    for n, (g, w) in enumerate(zip(got, want, strict=False)):
        assert type(g) is type(w), (n, g, w)
        for name in getattr(type(w), "__dataclass_fields__", {}):
            a, b = getattr(g, name), getattr(w, name)
            if isinstance(b, float) and not isinstance(b, bool):
                tol = (
                    angle_tol
                    if name in "abc"
                    else feed_tol
                    if name == "feed"
                    else 0.0005
                    if name in ("seconds", "rpm")
                    else length_tol
                )
                if name == "rpm":
                    tol = 0.5
                assert a is not None and abs(a - b) <= tol, (n, name, a, b, g, w)
            else:
                assert a == b, (n, name, a, b)
