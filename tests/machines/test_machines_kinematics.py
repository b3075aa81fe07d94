"""Kinematics: identities, the singular cone, unwrap, branch choice and an external oracle."""

import numpy as np
import pytest
from _machines_support import random_joints, synthetic

from machines import (
    SINGULAR_CONE_DEG,
    KinematicsError,
    KinematicType,
    UnreachableOrientationError,
    Wrap,
    check_travel,
    controller_values,
    forward,
    inverse,
    load_machine,
    solve_inverse,
)
from machines.kinematics import linear_jacobian, tool_point_gradient

LINEAR_TOL = 1e-9  # mm: round-off of a few rotations of ~1 m lever arms
ANGLE_TOL = 1e-9  # deg
AXIS_TOL = 1e-12  # unit-vector components


def axis_from_angles(tilt_deg, azimuth_deg):
    t, a = np.radians(tilt_deg), np.radians(azimuth_deg)
    return np.stack([np.sin(t) * np.cos(a), np.sin(t) * np.sin(a), np.cos(t) * np.ones_like(a)], 1)


def test_inverse_of_forward_is_identity_pointwise(any_machine, rng):
    """inverse(forward(j), start=j) == j for random joints within travel, every machine."""
    j = random_joints(any_machine, rng, 300)
    tips, axes = forward(any_machine, j)
    for i in range(len(j)):
        back = inverse(any_machine, tips[i], axes[i], start=j[i])
        np.testing.assert_allclose(back, j[i], rtol=0, atol=LINEAR_TOL, err_msg=f"pose {i}")


def test_forward_of_inverse_is_identity_along_a_path(any_machine, rng):
    """forward(inverse(tip, axis)) == (tip, axis) for a random path of reachable poses."""
    j = random_joints(any_machine, rng, 2000)
    tips, axes = forward(any_machine, j)
    sol = solve_inverse(any_machine, tips, axes)
    t2, a2 = forward(any_machine, sol.joints)
    np.testing.assert_allclose(t2, tips, rtol=0, atol=LINEAR_TOL)
    out = ~sol.in_cone
    np.testing.assert_allclose(a2[out], axes[out], rtol=0, atol=AXIS_TOL)
    assert (sol.axis_error_deg[out] < 1e-9).all()
    assert (sol.axis_error_deg <= SINGULAR_CONE_DEG + 1e-12).all()


def test_forward_of_inverse_random_axes(five_axis, rng):
    n = 3000
    tips = rng.uniform(-150, 150, (n, 3))
    axes = axis_from_angles(rng.uniform(0.5, 85, n), rng.uniform(-180, 180, n))
    j = inverse(five_axis, tips, axes)
    t2, a2 = forward(five_axis, j)
    np.testing.assert_allclose(t2, tips, rtol=0, atol=LINEAR_TOL)
    np.testing.assert_allclose(a2, axes, rtol=0, atol=AXIS_TOL)


def test_linear_jacobian_is_how_the_linear_joints_follow_the_tip(any_machine, rng):
    """``G(q + d) - G(q) = J d`` at the same rotary joints, every machine, any ``d``."""
    j = random_joints(any_machine, rng, 500)
    tips, axes = forward(any_machine, j)
    sol = solve_inverse(any_machine, tips, axes)
    linear = [any_machine.index(letter) for letter in "XYZ"]
    d = rng.uniform(-40.0, 40.0, (len(j), 3))
    moved = solve_inverse(any_machine, tips + d, axes).joints
    np.testing.assert_array_equal(np.delete(moved, linear, axis=1),
                                  np.delete(sol.joints, linear, axis=1))
    step = np.einsum("nij,nj->ni", linear_jacobian(any_machine, sol.joints), d)
    np.testing.assert_allclose(moved[:, linear] - sol.joints[:, linear], step, rtol=0,
                               atol=LINEAR_TOL)


@pytest.mark.parametrize("along_mm", [0.0, 3.0, 40.0])
def test_tool_point_gradient_is_the_derivative_of_forward(any_machine, rng, along_mm):
    """``gradient . dq`` is ``w . dP/du`` of ``P = tip + along axis`` with the joints
    moving along ``dq``: against a central difference of :func:`forward` (error ``h^2``
    times the third derivative: 1e-10 of the rates here)."""
    j = random_joints(any_machine, rng, 400)
    dq = random_joints(any_machine, rng, 400) - j
    w = rng.normal(size=(len(j), 3))
    h = 1e-6
    ahead, behind = forward(any_machine, j + h * dq), forward(any_machine, j - h * dq)
    moved = (ahead[0] + along_mm * ahead[1] - behind[0] - along_mm * behind[1]) / (2.0 * h)
    expected = np.einsum("ij,ij->i", moved, w)
    got = np.einsum("ij,ij->i", tool_point_gradient(any_machine, j, along_mm, w), dq)
    np.testing.assert_allclose(got, expected, rtol=0.0, atol=1e-6 * np.abs(expected).max())


def test_tool_point_gradient_rows_must_match():
    m = load_machine("trunnion-ac")
    with pytest.raises(KinematicsError, match="covectors has 2 rows, joints 1"):
        tool_point_gradient(m, np.zeros((1, m.n_axes)), 3.0, np.ones((2, 3)))


def test_joint_columns_follow_machine_order():
    m = synthetic(KinematicType.TABLE_TABLE_AC)
    assert m.letters == "XYZCA"
    j = inverse(m, [0.0, 0.0, 0.0], axis_from_angles([40.0], [0.0])[0])
    assert j[4] == pytest.approx(-40.0) or j[4] == pytest.approx(40.0)  # A in column 4


def test_zero_rotary_is_work_origin_plus_tool_length(any_machine):
    j = inverse(any_machine, [1.0, 2.0, 3.0], [0.0, 0.0, 1.0])
    expected = np.add(any_machine.work_origin, [1.0, 2.0, 3.0 + any_machine.tool_length])
    np.testing.assert_allclose(j[:3], expected, atol=LINEAR_TOL)


def test_trunnion_matches_linuxcnc_xyzac_trt_forward(rng):
    """Oracle: LinuxCNC trtfuncs.c xyzacKinematicsForward (tool-offset 0), transcribed."""
    xr, yr, zr, dy, dz = 4.0, -6.0, -320.0, 2.5, -110.0
    # LinuxCNC: C turns about (xr, yr); A turns about (y = yr + dy, z = zr + dz).
    base = synthetic(KinematicType.TABLE_TABLE_AC)
    m = type(base)(
        name="lcnc",
        kinematics=KinematicType.TABLE_TABLE_AC,
        axes=base.axes,
        dialect="linuxcnc",
        rotary_centre=(xr, yr + dy, zr + dz),
        c_offset=(0.0, -dy, 0.0),
        work_origin=(0.0, 0.0, 0.0),
        tool_length=0.0,
    )
    j = random_joints(m, rng, 500)
    jx, jy, jz = j[:, 0], j[:, 1], j[:, 2]
    a, c = np.radians(j[:, m.index("A")]), np.radians(j[:, m.index("C")])
    sa, ca, sc, cc = np.sin(a), np.cos(a), np.sin(c), np.cos(c)
    px = cc * (jx - xr) + sc * ca * (jy - dy - yr) + sc * sa * (jz - dz - zr) + sc * dy + xr
    py = -sc * (jx - xr) + cc * ca * (jy - dy - yr) + cc * sa * (jz - dz - zr) + cc * dy + yr
    pz = -sa * (jy - dy - yr) + ca * (jz - dz - zr) + dz + zr
    tips, _ = forward(m, j)
    np.testing.assert_allclose(tips, np.stack([px, py, pz], 1), rtol=0, atol=LINEAR_TOL)


# --- branch choice --------------------------------------------------------------------


def test_trunnion_prefers_negative_a_and_takes_the_branch_that_fits():
    m = load_machine("trunnion-ac")
    j = inverse(m, np.zeros((2, 3)), axis_from_angles([20.0, 20.0], [90.0, 90.0]))
    assert j[0, 3] == pytest.approx(-20.0)  # both branches fit A: preferred negative
    # a 60 deg tilt fits A in [-120, 30] only as -60, whatever the preference
    j = inverse(m, np.zeros((1, 3)), axis_from_angles([60.0], [0.0]))
    assert j[0, 3] == pytest.approx(-60.0)


def test_head_table_prefers_positive_b():
    m = load_machine("head-table-bc")
    j = inverse(m, np.zeros((1, 3)), axis_from_angles([25.0], [45.0]))
    assert j[0, 3] == pytest.approx(25.0)
    assert j[0, 4] == pytest.approx(-45.0)  # C turns the part so the axis lies in +X


# --- the singular cone ----------------------------------------------------------------


@pytest.mark.parametrize("name", ["trunnion-ac", "head-table-bc", "synthetic:table-table-bc"])
def test_c_held_through_vertical(name):
    """The tool axis swings through vertical in one plane: C never moves, tilt crosses 0."""
    from _machines_support import get_machine

    m = get_machine(name)
    tilt = np.linspace(-25.0, 25.0, 161)  # passes exactly through 0 at index 80
    axes = axis_from_angles(tilt, np.full(tilt.size, 30.0))
    tips = np.stack([np.linspace(-50, 50, tilt.size), np.zeros(tilt.size), np.full(161, 20.0)], 1)
    sol = solve_inverse(m, tips, axes)
    c = sol.joints[:, m.index("C")]
    t = sol.joints[:, m.index(m.kinematics.tilt_letter)]
    assert sol.in_cone[80] and sol.in_cone.sum() == 1
    assert np.ptp(c) < ANGLE_TOL
    assert np.all(np.abs(np.diff(t)) < 50.0 / 160 + 1e-9)  # even tilt steps, no flips
    assert abs(t[80]) < ANGLE_TOL
    t2, a2 = forward(m, sol.joints)
    np.testing.assert_allclose(t2, tips, atol=LINEAR_TOL)
    np.testing.assert_allclose(a2, axes, atol=AXIS_TOL)


def test_trunnion_turns_c_instead_of_leaving_a_travel():
    """Through vertical to a 40 deg tilt on the far side: +40 would break A <= 30, so A stays
    negative and C turns 180 deg at the crossing (spread over the cone point)."""
    m = load_machine("trunnion-ac")
    tilt = np.linspace(-40.0, 40.0, 161)
    axes = axis_from_angles(tilt, np.full(tilt.size, 30.0))
    j = inverse(m, np.zeros((tilt.size, 3)), axes)
    assert check_travel(m, j) == []
    a, c = j[:, 3], j[:, 4]
    assert (a <= 1e-12).all()
    np.testing.assert_allclose(np.ptp(c[:80]), 0.0, atol=ANGLE_TOL)
    np.testing.assert_allclose(np.ptp(c[81:]), 0.0, atol=ANGLE_TOL)
    assert abs(c[81] - c[79]) == pytest.approx(180.0)
    head = load_machine("head-table-bc")  # B is symmetric: crosses to +40, C held
    jh = inverse(head, np.zeros((tilt.size, 3)), axes)
    assert np.ptp(jh[:, 4]) < ANGLE_TOL and np.ptp(jh[:, 3]) == pytest.approx(80.0)


def test_near_miss_inside_cone_holds_c_within_cone_error():
    """A pass 0.05 deg from vertical (inside the 0.1 deg cone): C spreads its turn, no jump."""
    m = load_machine("trunnion-ac")
    n = 201
    x = np.linspace(-1.0, 1.0, n)  # deg of lean across the pass
    v = np.stack([np.radians(x), np.full(n, np.radians(0.05)), np.ones(n)], 1)
    axes = v / np.linalg.norm(v, axis=1, keepdims=True)
    sol = solve_inverse(m, np.zeros((n, 3)), axes)
    c = sol.joints[:, 4]
    assert sol.in_cone.any()
    assert np.abs(np.diff(c)).max() < 6.0  # no 180 deg swing: C moves a few deg at most
    assert sol.axis_error_deg.max() <= SINGULAR_CONE_DEG
    tips, _ = forward(m, sol.joints)
    np.testing.assert_allclose(tips, 0.0, atol=LINEAR_TOL)  # tip exact even inside the cone


def test_path_starting_vertical_takes_first_c_and_start_c_is_held():
    m = load_machine("head-table-bc")
    axes = np.vstack([np.tile([0.0, 0.0, 1.0], (5, 1)), axis_from_angles([10.0, 20.0], [70.0] * 2)])
    j = inverse(m, np.zeros((7, 3)), axes)
    np.testing.assert_allclose(j[:5, 4], j[5, 4], atol=ANGLE_TOL)  # backfilled: no move at 5
    start = np.array([0.0, 0.0, 0.0, 0.0, 123.0])
    j = inverse(m, np.zeros((5, 3)), np.tile([0.0, 0.0, 1.0], (5, 1)), start=start)
    np.testing.assert_allclose(j[:, 4], 123.0)


# --- unwrap ---------------------------------------------------------------------------


def test_c_unwraps_past_360_on_a_path_circling_the_part():
    m = load_machine("trunnion-ac")
    assert m.axis("C").wrap is Wrap.CONTINUOUS
    az = np.linspace(0.0, 3 * 360.0 + 45.0, 2000)  # three turns and a bit
    axes = axis_from_angles(np.full(az.size, 35.0), az)
    r = 80.0
    tips = np.stack([r * np.cos(np.radians(az)), r * np.sin(np.radians(az)), az / 20.0], 1)
    j = inverse(m, tips, axes)
    c = j[:, 4]
    assert np.abs(np.diff(c)).max() < 1.0  # 0.55 deg per step, never a 360 jump
    assert np.ptp(c) == pytest.approx(3 * 360.0 + 45.0, abs=1e-9)
    assert abs(c[-1]) > 360.0 and -180.0 <= c[0] <= 180.0
    np.testing.assert_allclose(j[:, 3], -35.0, atol=ANGLE_TOL)
    t2, a2 = forward(m, j)
    np.testing.assert_allclose(t2, tips, atol=LINEAR_TOL)
    np.testing.assert_allclose(a2, axes, atol=AXIS_TOL)


def test_modulo_axis_unwrapped_in_joints_wrapped_for_controller():
    m = load_machine("head-table-bc")
    az = np.linspace(-170.0, 550.0, 500)
    j = inverse(m, np.zeros((az.size, 3)), axis_from_angles(np.full(az.size, 30.0), az))
    assert np.abs(np.diff(j[:, 4])).max() < 2.0
    sent = controller_values(m, j)
    assert ((sent[:, 4] >= 0.0) & (sent[:, 4] < 360.0)).all()
    np.testing.assert_allclose(np.mod(sent[:, 4] - j[:, 4], 360.0) % 360.0, 0.0, atol=1e-9)
    np.testing.assert_array_equal(sent[:, :4], j[:, :4])


def test_limited_c_path_is_shifted_by_whole_turns_to_fit_travel():
    m = synthetic(KinematicType.HEAD_TABLE_BC, c_wrap=Wrap.LIMITED, c_limits=(-300.0, 400.0))
    az = np.linspace(-100.0, -700.0, 300)  # C = -az grows from 100 to 700: too high
    j = inverse(m, np.zeros((az.size, 3)), axis_from_angles(np.full(az.size, 30.0), az))
    c = j[:, m.index("C")]
    np.testing.assert_allclose([c[0], c[-1]], [-260.0, 340.0])  # one turn down fits
    free = synthetic(KinematicType.HEAD_TABLE_BC)  # continuous C: starts in [-180, 180]
    c = inverse(free, np.zeros((az.size, 3)), axis_from_angles(np.full(az.size, 30.0), az))
    np.testing.assert_allclose(c[[0, -1], free.index("C")], [100.0, 700.0])


def test_continuing_from_start_equals_one_pass():
    m = load_machine("trunnion-ac")
    az = np.linspace(0.0, 900.0, 400)
    tilt = 20.0 + 15.0 * np.sin(np.radians(az))
    axes = axis_from_angles(tilt, az)
    tips = np.zeros((az.size, 3))
    whole = inverse(m, tips, axes)
    second = inverse(m, tips[200:], axes[200:], start=whole[199])
    np.testing.assert_allclose(second, whole[200:], atol=1e-9)


# --- bad input ------------------------------------------------------------------------


def test_three_axis_rejects_a_tilted_tool_axis():
    m = load_machine("grbl-router")
    axes = np.tile([0.0, 0.0, 1.0], (10, 1))
    axes[[4, 7]] = axis_from_angles([3.0, 5.0], [0.0, 90.0])
    with pytest.raises(UnreachableOrientationError, match=r"point 4 .*3 deg from \+Z") as info:
        inverse(m, np.zeros((10, 3)), axes)
    assert info.value.indices == (4, 7)
    assert "2 such points" in str(info.value)


def test_three_axis_joints_and_forward():
    m = load_machine("grbl-router")
    tips = np.array([[10.0, 20.0, 5.0], [0.0, 0.0, 0.0]])
    j = inverse(m, tips, np.tile([0.0, 0.0, 1.0], (2, 1)))
    np.testing.assert_allclose(j, tips + np.array(m.work_origin))
    t2, a2 = forward(m, j)
    np.testing.assert_allclose(t2, tips)
    np.testing.assert_array_equal(a2, np.tile([0.0, 0.0, 1.0], (2, 1)))


@pytest.mark.parametrize(
    ("tips", "axes", "match"),
    [
        (np.zeros((3, 2)), np.zeros((3, 3)), r"shape \(n, 3\)"),
        (np.zeros((3, 3)), np.tile([0.0, 0.0, 1.0], (2, 1)), "3 rows but axes has 2"),
        (np.zeros((2, 3)), np.array([[0.0, 0.0, 1.0], [0.0, 0.0, 2.0]]), r"tool axis 1 .*norm"),
        (np.array([[0.0, 0.0, 0.0], [np.nan, 0, 0]]), np.tile([0, 0, 1.0], (2, 1)), r"tips\[1\]"),
    ],
)
def test_bad_input_shapes_and_values(tips, axes, match):
    m = load_machine("trunnion-ac")
    with pytest.raises(KinematicsError, match=match):
        inverse(m, tips, axes)


def test_bad_cone_and_joint_shape():
    m = load_machine("trunnion-ac")
    with pytest.raises(KinematicsError, match="cone_deg"):
        inverse(m, [0.0, 0.0, 0.0], [0.0, 0.0, 1.0], cone_deg=-1.0)
    with pytest.raises(KinematicsError, match=r"shape \(n, 5\)"):
        forward(m, np.zeros((4, 3)))


def test_empty_path(any_machine):
    j = inverse(any_machine, np.zeros((0, 3)), np.zeros((0, 3)))
    assert j.shape == (0, any_machine.n_axes)
    tips, axes = forward(any_machine, j)
    assert tips.shape == axes.shape == (0, 3)


def _with_middles(tips, axes, at):
    """The path with a point inserted in the middle of each move ``at -> at + 1``."""
    mid_axes = axes[at] + axes[at + 1]
    mid_axes /= np.linalg.norm(mid_axes, axis=1, keepdims=True)
    was = np.insert(np.arange(len(tips)), at + 1, -1)
    return (np.insert(tips, at + 1, 0.5 * (tips[at] + tips[at + 1]), axis=0),
            np.insert(axes, at + 1, mid_axes, axis=0), was)


def _wandering_path(rng, n=400):
    """Tips and axes that cross the vertical, turn the azimuth fast and slowly, lean far."""
    tilt = np.concatenate([np.linspace(60, 0, n // 4), np.zeros(n // 8),
                           np.linspace(0, 100, n - n // 4 - n // 8)])
    azimuth = np.cumsum(rng.normal(0.0, 25.0, n))
    tips = np.cumsum(rng.normal(0.0, 1.0, (n, 3)), axis=0)
    return tips, axis_from_angles(tilt, azimuth)


def test_solving_again_after_inserts_gives_the_whole_solve(five_axis, rng):
    # rows kept from the path before (their C and cone unchanged) must be the values a
    # whole solve gives, bit for bit; inserts inside the cone move the C carried through
    # it by index, and one across a fast azimuth turn can change the branch of what follows
    tips, axes = _wandering_path(rng)
    before = solve_inverse(five_axis, tips, axes)
    cone = np.flatnonzero(before.in_cone[:-1])
    for at in (np.arange(0, len(tips) - 1, 7), cone[::3], np.arange(len(tips) - 1)):
        new_tips, new_axes, was = _with_middles(tips, axes, at)
        whole = solve_inverse(five_axis, new_tips, new_axes)
        again = solve_inverse(five_axis, new_tips, new_axes, previous=(before, was))
        np.testing.assert_array_equal(again.joints, whole.joints)
        np.testing.assert_array_equal(again.in_cone, whole.in_cone)
        np.testing.assert_array_equal(again.axis_error_deg, whole.axis_error_deg)
    with pytest.raises(KinematicsError, match="previous rows"):
        solve_inverse(five_axis, tips, axes, previous=(before, np.arange(len(tips) + 1)))
