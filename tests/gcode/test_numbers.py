"""The one number formatter and reader: edge cases, vector == scalar, round trip."""

import locale
import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from gcode import ErrorCode, GCodeError, format_array, format_number, read_number
from gcode.numbers import Decimals, NumberKind, format_matrix

finite = st.floats(allow_nan=False, allow_infinity=False, min_value=-1e300, max_value=1e300)


def test_negative_zero_is_never_written():
    assert format_number(-0.0004, 3) == "0"
    assert format_number(-0.0, 3) == "0"
    assert format_number(-0.0005, 3) == "0"  # half to even: -0.5 -> -0
    assert format_number(-0.0004, 3, trim=False) == "0.000"
    assert format_array([-0.0004, -0.0, -1e-300], 3) == ["0", "0", "0"]


def test_huge_and_tiny_values_never_use_an_exponent():
    for v in (1e-20, -1e-20, 5e-324, 1e15, 1.5e16, 1e21, -1e100, 1.7976931348623157e308):
        s = format_number(v, 3)
        assert "e" not in s.lower() and "inf" not in s
        assert math.isclose(float(s), round(v, 3), rel_tol=1e-15) or abs(v) < 1e-3
    assert format_number(1e21, 3) == "1000000000000000000000"
    assert format_array([1e21, 1e-20, 2.5], 3) == ["1000000000000000000000", "0", "2.5"]


def test_trim_and_keep_point():
    assert format_number(2.0, 3) == "2"
    assert format_number(2.5, 3) == "2.5"
    assert format_number(2.0, 3, keep_point=True) == "2."
    assert format_number(2.0, 3, trim=False) == "2.000"
    assert format_number(12000.4, 0, keep_point=True) == "12000"
    assert format_number(0.1234567, 4) == "0.1235"


def test_nan_and_inf_are_refused():
    for v in (math.nan, math.inf, -math.inf):
        with pytest.raises(GCodeError) as info:
            format_number(v, 3)
        assert info.value.code is ErrorCode.NOT_FINITE
        with pytest.raises(GCodeError):
            format_array([1.0, v], 3)


@settings(max_examples=300, deadline=None, derandomize=True)
@given(st.lists(finite, min_size=1, max_size=20), st.integers(0, 9), st.booleans(), st.booleans())
def test_vector_path_writes_exactly_what_the_scalar_path_writes(values, decimals, trim, point):
    kw = {"trim": trim, "keep_point": point}
    assert format_array(values, decimals, **kw) == [
        format_number(v, decimals, **kw) for v in values
    ]


@settings(max_examples=500, deadline=None, derandomize=True)
@given(st.floats(allow_nan=False, allow_infinity=False, min_value=-1e12, max_value=1e12),
       st.integers(0, 6))  # fmt: skip
def test_read_of_format_is_within_half_a_step(value, decimals):
    text = format_number(value, decimals)
    assert "e" not in text.lower()
    assert not (text.startswith("-") and float(text) == 0.0)  # never -0
    back = read_number(text)
    step = 10.0**-decimals
    assert abs(back - value) <= step / 2 + abs(value) * 4e-16
    assert format_number(back, decimals) == text  # formatting is idempotent


def test_reader_rejects_what_the_formatter_never_writes():
    for bad in ("1e-3", "1E3", "", "-", ".", "1,5", "nan", "inf", " 1", "1 ", "+-1", "1.2.3",
                "\u0661", "0x10", "1_000"):  # fmt: skip
        with pytest.raises(GCodeError) as info:
            read_number(bad)
        assert info.value.code is ErrorCode.BAD_NUMBER_FORMAT
    assert read_number("-.5") == -0.5 and read_number("10.") == 10.0 and read_number("+3") == 3.0


def test_locale_does_not_change_output():
    values = [1234.5, -0.25, 1e6]
    before = format_array(values, 3), [format_number(v, 3) for v in values]
    old = locale.setlocale(locale.LC_ALL)
    for name in ("de_DE.UTF-8", "fr_FR.UTF-8", "de_DE", "C.UTF-8"):
        try:
            locale.setlocale(locale.LC_ALL, name)
        except locale.Error:
            continue
        try:
            assert (format_array(values, 3), [format_number(v, 3) for v in values]) == before
            assert read_number("1234.5") == 1234.5
        finally:
            locale.setlocale(locale.LC_ALL, old)
    assert before[1] == ["1234.5", "-0.25", "1000000"]


def test_decimals_table():
    d = Decimals()
    assert d.of(NumberKind.COORD_MM) == 3 and d.of(NumberKind.COORD_INCH) == 4
    assert d.of(NumberKind.ANGLE) == 3 and d.of(NumberKind.SPINDLE) == 0
    with pytest.raises(ValueError):
        Decimals(coord_mm=12)


def test_format_matrix_declines_values_beyond_int64():
    assert format_matrix(np.array([1e17]), 3) is None
    assert format_array(np.array([1e17, 1.0]), 3) == ["100000000000000000", "1"]


def test_table_formatter_matches_the_scalar_one_over_many_magnitudes(rng):
    mags = 10.0 ** rng.uniform(-6, 14, 20000)
    values = np.concatenate([mags * rng.choice([-1.0, 1.0], mags.size), [-0.0, 0.0, 9999.9995]])
    values = np.concatenate([values, np.round(values, 3), np.round(values, 1)])
    for decimals in (0, 1, 3, 4, 6):
        for trim, point in ((True, False), (False, True)):
            kw = {"trim": trim, "keep_point": point}
            assert format_array(values, decimals, **kw) == [
                format_number(v, decimals, **kw) for v in values
            ]
