import math

import numpy as np
import pytest

from machines import Axis, AxisKind, MachineError, Wrap


def test_defaults_and_properties():
    x = Axis("X", AxisKind.LINEAR, -10.0, 10.0, max_rate=1000.0, max_accel=100.0)
    assert x.wrap is Wrap.NONE and x.unit == "mm" and x.is_limited and x.span == 20.0
    a = Axis("A", AxisKind.ROTARY, -120.0, 30.0, max_rate=9000.0, max_accel=600.0)
    assert a.wrap is Wrap.LIMITED and a.unit == "deg" and a.is_rotary
    np.testing.assert_array_equal(a.within([-120.0, 30.0, 30.1, np.nan]), [1, 1, 0, 0])
    c = Axis("C", "rotary", max_rate=1.0, max_accel=1.0, wrap="continuous")
    assert not c.is_limited and math.isinf(c.span)


def test_controller_value_modulo():
    c = Axis("C", AxisKind.ROTARY, max_rate=1.0, max_accel=1.0, wrap=Wrap.SHORTEST)
    out = c.controller_value([-90.0, 725.0, 360.0, -1e-17])
    np.testing.assert_allclose(out, [270.0, 5.0, 0.0, 0.0])
    assert ((out >= 0) & (out < 360)).all()


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        ({"letter": "Q", "kind": "linear", "min": 0, "max": 1}, "unknown axis letter"),
        ({"letter": "A", "kind": "linear", "min": 0, "max": 1}, "is rotary"),
        ({"letter": "X", "kind": "linear", "min": 1, "max": 1}, "not below"),
        ({"letter": "X", "kind": "linear"}, "finite travel"),
        ({"letter": "C", "kind": "rotary", "wrap": "continuous", "min": 0.0}, "no travel"),
        ({"letter": "X", "kind": "linear", "min": 0, "max": 1, "max_rate": 0}, "max_rate"),
        ({"letter": "X", "kind": "linear", "min": 0, "max": 1, "wrap": "shortest"}, "cannot"),
    ],
)
def test_invalid_axes(kwargs, match):
    with pytest.raises(MachineError, match=match):
        Axis(**kwargs)


def test_axis_is_frozen():
    x = Axis("X", AxisKind.LINEAR, 0.0, 1.0)
    with pytest.raises(AttributeError):
        x.min = -1.0  # type: ignore[misc]
