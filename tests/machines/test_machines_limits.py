"""Travel and rate checks report the first offending point and never clip."""

import numpy as np
import pytest

from machines import (
    MachineError,
    Quantity,
    RateLimitError,
    Side,
    TravelLimitError,
    check_rates,
    check_travel,
    inverse,
    load_machine,
    min_segment_times,
    raise_for_violations,
)


def tilted(tilt_deg, azimuth_deg):
    t, a = np.radians(tilt_deg), np.radians(azimuth_deg)
    return np.stack([np.sin(t) * np.cos(a), np.sin(t) * np.sin(a), np.cos(t)], 1)


def test_path_leaving_a_travel_reported_at_the_right_point():
    """The tool axis tilts 0.5 deg per point toward -Y: A = -tilt leaves [-120, 30] at 121."""
    m = load_machine("trunnion-ac")
    tilt = np.arange(1.0, 131.0, 0.5)  # index i has tilt 1 + i/2 deg
    axes = tilted(tilt, np.full(tilt.size, 90.0))
    j = inverse(m, np.zeros((tilt.size, 3)), axes)
    before = j.copy()
    found = check_travel(m, j)
    np.testing.assert_array_equal(j, before)  # never clipped
    a_viol = [v for v in found if v.axis == "A"]
    assert len(a_viol) == 1
    v = a_viol[0]
    first = int(np.flatnonzero(tilt > 120.0)[0])
    assert first == 239
    assert (v.index, v.side, v.limit, v.unit) == (first, Side.MIN, -120.0, "deg")
    assert v.value == pytest.approx(-tilt[first])
    assert v.count == tilt.size - first and v.worst == pytest.approx(-tilt[-1])
    with pytest.raises(TravelLimitError, match=r"point 239: axis 'A' = -120.5 deg .*-120 deg"):
        raise_for_violations(found)


def test_linear_violations_both_sides_sorted_by_point():
    m = load_machine("grbl-router")
    j = np.array(
        [[-10.0, -10.0, -10.0], [-10.0, 5.0, -10.0], [-900.0, -10.0, -10.0], [-10, -10, -130]]
    )
    found = check_travel(m, j)
    assert [(v.index, v.axis, v.side, v.value, v.limit) for v in found] == [
        (1, "Y", Side.MAX, 5.0, 0.0),
        (2, "X", Side.MIN, -900.0, -800.0),
        (3, "Z", Side.MIN, -130.0, -120.0),
    ]
    with pytest.raises(TravelLimitError) as info:
        raise_for_violations(found)
    assert info.value.violations == tuple(found)
    assert "point 1: axis 'Y' = 5 mm is above its maximum 0 mm" in str(info.value)
    assert "2 more violations" in str(info.value)


def test_within_travel_and_tolerance_and_nan():
    m = load_machine("grbl-router")
    assert check_travel(m, [[0.0, -600.0, -120.0]]) == []
    assert check_travel(m, [[1e-9, 0.0, 0.0]]) == []  # round-off at the limit
    found = check_travel(m, [[0.0, np.nan, 0.0]])
    assert found[0].axis == "Y" and np.isnan(found[0].value)
    raise_for_violations([])  # nothing to raise


def test_continuous_c_has_no_travel_limit():
    m = load_machine("trunnion-ac")
    assert check_travel(m, [[0.0, 0.0, -100.0, 0.0, 1e6]]) == []


def test_rate_violation_names_the_segment():
    m = load_machine("trunnion-ac")
    j = np.zeros((4, 5))
    j[:, 2] = -100.0
    j[2:, 4] = 90.0  # C turns 90 deg in segment 1
    assert check_rates(m, j, [1.0, 1.0, 1.0]) == []  # 5400 deg/min
    found = check_rates(m, j, [1.0, 0.1, 1.0])  # 54000 deg/min > 18000
    assert len(found) == 1
    v = found[0]
    assert (v.index, v.axis, v.quantity, v.unit) == (1, "C", Quantity.RATE, "deg/min")
    assert v.value == pytest.approx(54000.0) and v.limit == 18000.0
    with pytest.raises(RateLimitError, match=r"segment 1: axis 'C' rate = 54000 deg/min"):
        raise_for_violations(found)


def test_min_segment_times_respect_every_rate(rng):
    m = load_machine("head-table-bc")
    j = np.cumsum(rng.normal(0.0, 5.0, (200, 5)), axis=0)
    dt = min_segment_times(m, j)
    assert dt.shape == (199,) and (dt > 0).all()
    assert check_rates(m, j, dt) == []
    assert check_rates(m, j, dt * 0.99) != []


def test_bad_durations_and_shapes():
    m = load_machine("grbl-router")
    j = np.zeros((3, 3))
    with pytest.raises(MachineError, match=r"shape \(2,\)"):
        check_rates(m, j, [1.0])
    with pytest.raises(MachineError, match=r"durations\[1\] = -1.0"):
        check_rates(m, j, [1.0, -1.0])
    with pytest.raises(MachineError, match=r"shape \(n, 3\)"):
        check_travel(m, np.zeros((2, 5)))
