import numpy as np
import pytest

from machines import MM_PER_INCH, MachineError, Unit, convert_feed, convert_joints, from_mm, to_mm
from machines.units import convert_length


def test_mm_per_inch_is_exact():
    assert MM_PER_INCH == 25.4
    assert to_mm(1.0, Unit.INCH) == 25.4
    assert from_mm(25.4, Unit.INCH) == 1.0
    assert to_mm(3.0, Unit.MM) == 3.0


def test_round_trip_inch_mm(rng):
    x = rng.uniform(-1000, 1000, 1000)
    back = convert_length(convert_length(x, Unit.MM, Unit.INCH), Unit.INCH, Unit.MM)
    np.testing.assert_allclose(back, x, rtol=1e-15, atol=1e-12)
    np.testing.assert_array_equal(convert_feed(x, Unit.MM, Unit.MM), x)


def test_rotary_columns_never_scaled():
    j = np.array([[1.0, 2.0, 3.0, 90.0, 370.0]])
    out = convert_joints(j, "XYZAC", Unit.INCH, Unit.MM)
    np.testing.assert_allclose(out, [[25.4, 50.8, 76.2, 90.0, 370.0]], rtol=1e-15)
    assert out[0, 3] == 90.0 and out[0, 4] == 370.0
    back = convert_joints(out, "XYZAC", Unit.MM, Unit.INCH)
    np.testing.assert_allclose(back, j, rtol=1e-15)
    assert back[0, 3] == 90.0 and back[0, 4] == 370.0


def test_unit_parse_and_gcode():
    assert Unit.parse("G20") is Unit.INCH and Unit.parse(" mm ") is Unit.MM
    assert Unit.INCH.gcode == "G20" and Unit.MM.gcode == "G21"
    with pytest.raises(MachineError, match="'furlong'"):
        Unit.parse("furlong")
    with pytest.raises(MachineError, match="do not match"):
        convert_joints([[1.0, 2.0]], "XYZ", Unit.MM, Unit.INCH)
