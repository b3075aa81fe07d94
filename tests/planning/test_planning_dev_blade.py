"""The bundled development blade, fitted, finished in 5-axis and in 3-axis."""

import numpy as np
import pytest

from toolpath import fit_streamline_surface
from toolpath.paper_examples import bundled_data_path
from toolpath.planning import parse_cutter, plan_finishing
from toolpath.planning.gouge import sample_surface
from toolpath.planning.local import project_to_surface
from toolpath.planning.setup import centred_on_table, rotation_from_spec
from toolpath.planning.tool_axis import angle_deg


@pytest.fixture(scope="module")
def blade():
    rows = np.loadtxt(bundled_data_path("dev_blade_15x142.csv"), delimiter=",", skiprows=1)
    sections = rows[:, 1:].reshape(15, 142, 3)[::2]  # every other section: a shorter fit
    return fit_streamline_surface(sections, tol=0.01, closed=False)


def test_five_axis_blade_within_request(blade):
    standing = centred_on_table(blade, rotation_from_spec("y:-90"))
    path, rep = plan_finishing(standing, "ball:6", scallop_mm=0.02, chord_tol_mm=0.02,
                               axis_mode="lead-tilt", lead_deg=10.0,
                               machine="trunnion-ac", on_limit="report")
    assert rep.max_scallop_mm <= 0.02 and rep.max_chord_error_mm <= 0.02
    assert rep.uncut_fraction == 0.0 and rep.travel_violations == ()
    # the planner's own estimate covers every move it kept, not only its last round's
    assert rep.planned_chord_error_mm == pytest.approx(rep.max_chord_error_mm, rel=0.02)
    # around the leading edge (radius below 1 mm) the axis turns with the surface but
    # stays within max_lean_deg (60) of the normal at the ball's contact
    cut = path.pass_index >= 0
    centres = path.positions_mm[cut] + 3.0 * path.tool_axes[cut]
    samples = sample_surface(standing, 0.5)
    _, near = samples.tree.query(centres)
    t, s, dist = project_to_surface(standing, centres, samples.t[near], samples.s[near],
                                    iterations=8)
    np.testing.assert_allclose(dist, 3.0, atol=1e-6)
    lean = angle_deg(path.tool_axes[cut], standing.normal(t, s))
    assert lean.max() <= 60.0 + 1e-6 and np.median(lean) == pytest.approx(10.0, abs=1.0)


def test_three_axis_blade_leaves_the_far_side(blade):
    lying = centred_on_table(blade, rotation_from_spec("x:90"), base_height_mm=0.0)
    _, rep = plan_finishing(lying, "ball:6", scallop_mm=0.02, chord_tol_mm=0.02,
                            machine="grbl-router")
    assert 0.3 < rep.unreachable_fraction < 0.7
    assert {r.reason for r in rep.unreachable_regions} >= {"faces away"}
    assert rep.scallop_interior_mm <= 0.02 and rep.max_chord_error_mm <= 0.02
    assert rep.planned_chord_error_mm == pytest.approx(rep.max_chord_error_mm, rel=0.02)


def test_projection_converges_round_the_leading_edge(blade):
    # points up to 4 mm off the leading edge (a bull-nose disc's rim reaches past the
    # 0.2 mm nose), searched from parameters near their own: the few that converge slowly
    # once stopped half-way, their signed distance up to 3 mm wrong (a false 0.58 mm
    # gouge in a measured chord); with enough steps every one ends within 20 um of where
    # a long search does
    from toolpath.planning.local import signed_distance_near

    rng = np.random.default_rng(0)
    n = 20000
    t, s = rng.uniform(0.45, 0.55, n), rng.uniform(0.1, 0.9, n)
    frame = blade.frame(t, s)
    off = rng.normal(size=(n, 3))
    off /= np.linalg.norm(off, axis=1, keepdims=True)
    p = frame.point + frame.normal + off * rng.uniform(0.0, 3.0, n)[:, None]
    t0 = np.clip(t + rng.uniform(-0.02, 0.02, n), 0.0, 1.0)
    short, _, _ = signed_distance_near(blade, p, t0, s, iterations=2)
    long, _, _ = signed_distance_near(blade, p, t0, s, iterations=60)
    assert np.abs(short - long).max() < 0.02


@pytest.mark.parametrize("spec", ["flat:8", "flat:6"])
def test_flat_end_mill_round_the_leading_edge_in_five_axis(blade, spec):
    # a flat face keeps its lead at split points, and the gap check looks for the rim
    # point facing down the surface at the contact itself: round the 0.2 mm nose the
    # disc's samples used to miss it, the contacts read as standing 0.05 mm off, and the
    # splitting never ended (491,000 points, 2 GB arrays); the measurement seeded on the
    # far side of the nose read a 2.2 mm cut through the blade, and its rim samples
    # missed the contact
    from toolpath.planning.chord_measure import measure_chord

    standing = centred_on_table(blade, rotation_from_spec("y:-90"))
    path, rep = plan_finishing(standing, spec, scallop_mm=0.03, chord_tol_mm=0.03,
                               axis_mode="lead-tilt", lead_deg=10.0, measure=False)
    assert rep.n_points < 10_000
    chord = measure_chord(path, standing, parse_cutter(spec), sample_surface(standing, 1.0))
    assert chord.overcut_mm <= 0.03
    # every location touches: the rim's lowest point found within a fraction of a degree
    # (15 deg samples and a parabola read up to 0.065 mm standing off at the nose)
    assert chord.contact_mm < 1e-3
