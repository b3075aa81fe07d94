"""Finishing on analytic surfaces: the measured scallop and chord error stay within the
request (measured on the result, independently of the planning formulas)."""

import numpy as np
import pytest

from toolpath.path import MoveKind
from toolpath.planning import (
    CylinderPatch,
    EllipticBladeSurface,
    PlaneSurface,
    SpherePatch,
    finishing,
    plan_finishing,
)
from toolpath.planning.scallop import scallop_height_mm

SURFACES = {
    "plane": PlaneSurface(t_vector_mm=(30.0, 0.0, 0.0), s_vector_mm=(0.0, 12.0, 0.0)),
    "sphere": SpherePatch(radius_mm=30.0, longitude_deg=(-15.0, 15.0),
                          colatitude_deg=(30.0, 45.0)),
    "bowl": SpherePatch(radius_mm=30.0, longitude_deg=(-15.0, 15.0),
                        colatitude_deg=(135.0, 150.0), inside=True),
    "cylinder-around": CylinderPatch(radius_mm=15.0, angle_deg=(-40.0, 40.0),
                                     length_mm=(0.0, 8.0)),
    "cylinder-along": CylinderPatch(radius_mm=15.0, angle_deg=(-25.0, 25.0),
                                    length_mm=(0.0, 10.0), passes="along"),
}


@pytest.mark.parametrize("name", sorted(SURFACES))
def test_scallop_and_chord_within_request_3_axis(name):
    path, rep = plan_finishing(SURFACES[name], "ball:6", scallop_mm=0.01, chord_tol_mm=0.01)
    assert rep.max_scallop_mm <= 0.01
    assert rep.max_chord_error_mm <= 0.01
    assert rep.uncut_fraction == 0.0
    # the request is used, not wasted (the moves' dip on convex passes lowers the cusps
    # beside them; the concave share goes to the moves standing above the surface), less
    # the reserve for the G-code's rounding (0.001 mm coordinates: sqrt(3)/2 um)
    assert rep.rounding_reserve_mm == pytest.approx(0.5 * np.sqrt(3.0) * 0.001)
    assert rep.planned_scallop_mm == pytest.approx(0.01 - rep.rounding_reserve_mm)
    assert rep.max_scallop_mm <= rep.planned_scallop_mm
    assert rep.max_scallop_mm > 0.7 * rep.planned_scallop_mm
    assert rep.within_request and not rep.unreachable_regions
    assert np.all(np.abs(path.tool_axes - [0, 0, 1]) < 1e-12)


def test_measured_scallop_equals_the_closed_form_on_a_plane():
    surf = SURFACES["plane"]
    path, rep = plan_finishing(surf, "ball:6", scallop_mm=0.005, chord_tol_mm=0.01)
    ys = np.unique(np.round(path.positions_mm[path.pass_index >= 0, 1], 9))
    stepover = np.diff(ys).max()
    expected = float(scallop_height_mm(stepover, 3.0, 0.0))
    assert rep.max_scallop_mm == pytest.approx(expected, abs=1e-7)
    assert rep.n_passes == len(ys)


def test_chord_error_is_measured_where_the_moves_dip():
    # passes around a cylinder are arcs: the moves dip below the surface (overcut), by
    # no more than the tolerance, and the cutter locations touch it exactly
    path, rep = plan_finishing(SURFACES["cylinder-around"], "ball:6", scallop_mm=0.01,
                               chord_tol_mm=0.004)
    assert 0.002 < rep.chord_overcut_mm <= 0.004
    assert rep.chord_undercut_mm < 1e-9
    # the planner's own estimate covers every move it kept (not only its last round's)
    assert rep.planned_chord_error_mm == pytest.approx(rep.max_chord_error_mm, rel=0.01)
    tight, rep2 = plan_finishing(SURFACES["cylinder-around"], "ball:6", scallop_mm=0.01,
                                 chord_tol_mm=0.001)
    assert rep2.max_chord_error_mm <= 0.001 and len(tight) > 1.5 * len(path)


def test_five_axis_spiral_on_closed_sections_is_one_cut():
    surf = EllipticBladeSurface(semi_axes_hub_mm=(15.0, 4.0), semi_axes_tip_mm=(14.0, 3.5),
                                z_range_mm=(0.0, 4.0))
    path, rep = plan_finishing(surf, "ball:6", scallop_mm=0.02, chord_tol_mm=0.01,
                               axis_mode="lead-tilt", lead_deg=10.0, linking="spiral")
    assert rep.within_request and rep.uncut_fraction == 0.0
    kinds = path.kinds
    cut = np.flatnonzero(path.pass_index >= 0)
    # one plunge, then cutting without a retract until the end
    assert np.sum(kinds == MoveKind.PLUNGE) == 1
    assert not np.isin(kinds[cut[0]:cut[-1] + 1], (MoveKind.RAPID, MoveKind.PLUNGE)).any()
    # climbing in s: the first ring at the bottom, the last at the top
    z = path.positions_mm[cut, 2]
    assert z[:5].max() < 0.1 and z[-5:].min() > 3.9


def test_oneway_passes_round_closed_sections_link_across_the_seam():
    # each ring ends at t = 1 where the next starts at t = 0: the link is checked half-way
    # between the two (the short way across the seam; averaging t once checked the far
    # side of the blade, and every pass retracted and plunged again)
    surf = EllipticBladeSurface(semi_axes_hub_mm=(15.0, 4.0), semi_axes_tip_mm=(14.0, 3.5),
                                z_range_mm=(0.0, 4.0))
    path, rep = plan_finishing(surf, "ball:6", scallop_mm=0.02, chord_tol_mm=0.01,
                               axis_mode="lead-tilt", lead_deg=10.0, linking="oneway")
    assert rep.within_request
    assert np.sum(path.kinds == MoveKind.PLUNGE) == 1
    assert np.sum(path.kinds == MoveKind.LINK) == path.n_passes - 1


def test_three_axis_reports_the_far_side_as_unreachable():
    surf = CylinderPatch(radius_mm=12.0, angle_deg=(0.0, 360.0), length_mm=(0.0, 4.0))
    path, rep = plan_finishing(surf, "ball:6", scallop_mm=0.02, chord_tol_mm=0.01)
    assert rep.unreachable_fraction == pytest.approx(0.5, abs=0.02)
    (region,) = rep.unreachable_regions
    assert region.reason == "faces away"
    assert region.t_min == pytest.approx(0.25, abs=1e-6)
    assert region.t_max == pytest.approx(0.75, abs=1e-6)
    # nothing is cut from below: every contact faces up
    z_tips = path.positions_mm[path.pass_index >= 0, 2]
    assert z_tips.min() > -1e-6 - 3.0 + 0.0
    assert rep.scallop_interior_mm <= 0.02 and rep.max_chord_error_mm <= 0.01


def test_far_side_gets_few_points_and_the_same_cut(monkeypatch):
    # the probe's unreachable nodes (away from reachable ones) get the longest moves:
    # the far side of a cylinder round its axis; the same passes, reach boundaries and
    # finish as at full density
    surf = CylinderPatch(radius_mm=12.0, angle_deg=(0.0, 360.0), length_mm=(0.0, 4.0))
    kw = dict(scallop_mm=0.02, chord_tol_mm=0.01, probe_t=257)  # (the same probe grid)
    evaluated = []  # points on the passes, reachable or not
    evaluate_points = finishing.evaluate_points
    monkeypatch.setattr(finishing, "evaluate_points",
                        lambda *a: evaluated.append(len(a[-2])) or evaluate_points(*a))
    _, rep = plan_finishing(surf, "ball:6", **kw)
    monkeypatch.setattr(finishing, "_next_to", lambda mask, closed: np.ones_like(mask))
    _, rep_dense = plan_finishing(surf, "ball:6", **kw)
    assert evaluated[0] < 0.6 * evaluated[1]  # (the far side: half the surface)
    assert rep.n_passes == rep_dense.n_passes and rep.within_request
    assert rep.unreachable_fraction == rep_dense.unreachable_fraction
    (a,), (b,) = rep.unreachable_regions, rep_dense.unreachable_regions
    assert (a.t_min, a.t_max) == pytest.approx((b.t_min, b.t_max), abs=1e-9)


def test_probe_columns_three_per_point_of_the_densest_pass_within_bounds():
    t = np.r_[0.0, np.sort(np.random.default_rng(3).random(40)), 1.0]
    def columns(*points_per_level):
        return finishing._probe_columns(t, np.tile(np.array(points_per_level), (t.size, 1)))

    assert columns(50.0, 99.9, 70.0) == 300  # (ceil of 3 x 99.9)
    assert columns(10.0, 20.0) == finishing.MIN_PROBE_T
    assert columns(400.0) == finishing.MAX_PROBE_T
    assert columns(50.0, np.nan) == finishing.MAX_PROBE_T  # (a degenerate frame)


def test_next_to_grows_a_mask_by_one_node_across_the_seam_when_closed():
    mask = np.zeros((6, 5), dtype=bool)
    mask[1, 2] = True
    want = np.zeros_like(mask)
    want[0:3, 1:4] = True
    np.testing.assert_array_equal(finishing._next_to(mask, closed_t=False), want)
    want[5, 1:4] = True  # row 5 (t = 1) is row 0 (t = 0), next to row 1
    np.testing.assert_array_equal(finishing._next_to(mask, closed_t=True), want)


def test_oneway_and_zigzag_link_differently():
    surf = SURFACES["plane"]
    one, _ = plan_finishing(surf, "ball:6", scallop_mm=0.02, chord_tol_mm=0.01,
                            linking="oneway", measure=False)
    zig, _ = plan_finishing(surf, "ball:6", scallop_mm=0.02, chord_tol_mm=0.01,
                            linking="zigzag", measure=False)
    assert np.sum(one.kinds == MoveKind.PLUNGE) == one.n_passes
    assert np.sum(zig.kinds == MoveKind.PLUNGE) == 1
    assert np.sum(zig.kinds == MoveKind.LINK) == zig.n_passes - 1
    # one-way: every pass runs towards +x
    for p in range(one.n_passes):
        x = one.positions_mm[one.pass_index == p, 0]
        assert np.all(np.diff(x) > 0)


def test_progress_callback_and_extension():
    stages = []
    path, _ = plan_finishing(SURFACES["plane"], "ball:6", scallop_mm=0.02,
                             chord_tol_mm=0.01, extend_mm=2.0, linking="oneway",
                             measure=False, progress=lambda s, f: stages.append((s, f)))
    assert stages[0] == ("probe", 0.0) and stages[-1] == ("done", 1.0)
    assert [f for _, f in stages] == sorted(f for _, f in stages)
    # each pass is extended 2 mm past both open edges, straight, before the lead arcs
    lead_x = path.positions_mm[path.kinds == MoveKind.LEAD_IN, 0]
    assert np.isclose(lead_x, -2.0).sum() == path.n_passes
