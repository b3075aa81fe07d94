"""A flat cutter's feet over thin edges: contacts, and places inside moves.

The dev blade's sections are open: their first and last points stand 0.06-0.13 mm apart
at the blunt trailing edge, so two sheets of the fitted surface (``t`` near 0 and near 1)
pass within a sample spacing of each other there. Laid flat for 3 axes (the job's own
placement) and cut with flat:6, the passes end over that edge with the cutter's disc
hanging past it. A contact searched from the nearest surface sample could end on the
other sheet, whose normal faces away: the chord measure read 0.196 mm of overcut (chord
tolerance 0.02 mm) where the surface rises 0.006 mm into the cutter at most.

The oracle is brute force: dense surface samples over the edge's strip, and for every
cutting move near it the largest height of a sample above the flat end's plane within the
cutter's radius, along the move (along the axis: at least the depth along the surface's
normal that the measure reads, so no overcut near the tolerance stands there).

Inside a move the disc's search starts between its ends' feet: round the small circles of
dev_rotor_blunt's leading edge (laid flat, flat:6, 3 axes) a disc point's search could end
on the far side, whose normal faces away: 2.84 mm of overcut read inside a 0.0006 mm move
whose ends touch (the verifier finds 0.049 mm on that job). Those feet are checked against
the surface samples as the contacts' are.
"""

import dataclasses

import numpy as np
import pytest
from measured_plans import planned
from scipy.spatial import cKDTree

from streamline_cam.fit_report import fit_surface_by_method
from toolpath import as_sections as read_grid
from toolpath import fit_streamline_surface, read_sections
from toolpath.paper_examples import bundled_data_path
from toolpath.path import MoveKind
from toolpath.placement import place_points
from toolpath.sections import as_sections

CHORD_TOL_MM = 0.02


@pytest.fixture(scope="module")
def flat_over_the_edge():
    rows = np.loadtxt(bundled_data_path("dev_blade_15x142.csv"), delimiter=",", skiprows=1)
    raw = as_sections(rows[:, 1:].reshape(15, 142, 3))
    placed, _ = place_points(raw.points, mode="flat", base_mm=5.0)
    surface = fit_streamline_surface(placed, tol=0.01, closed=False)
    return planned(surface, "flat:6", scallop_mm=0.05, chord_tol_mm=CHORD_TOL_MM)


def _brute_overcut(surface, path, radius_mm, t_band=0.02):
    """Largest rise of the surface into the flat cutter over the moves near the edge, mm."""
    t = np.concatenate([np.linspace(0.0, t_band, 41), np.linspace(1.0 - t_band, 1.0, 41)])
    s = np.linspace(0.0, 1.0, 2001)
    strip = surface(t, s, grid=True).reshape(-1, 3)
    tree = cKDTree(strip)
    tips, axes = path.positions_mm, path.tool_axes
    cutting = np.flatnonzero((path.kinds[1:] == MoveKind.CUT) & (path.pass_index[1:] >= 0)
                             & (path.pass_index[:-1] >= 0))
    mid = 0.5 * (tips[cutting] + tips[cutting + 1])
    half = 0.5 * np.linalg.norm(tips[cutting + 1] - tips[cutting], axis=1)
    reach = radius_mm + half + 0.1
    near = np.flatnonzero(tree.query(mid, distance_upper_bound=float(reach.max()))[0] <= reach)
    assert near.size > 20, "no passes end over the trailing edge"
    worst = -np.inf
    for j, at, within in zip(cutting[near], mid[near], reach[near], strict=True):
        pts = strip[tree.query_ball_point(at, within)]
        for u in np.linspace(0.0, 1.0, 21):
            tip = tips[j] + u * (tips[j + 1] - tips[j])
            axis = axes[j] + u * (axes[j + 1] - axes[j])
            axis /= np.linalg.norm(axis)
            rel = pts - tip
            height = rel @ axis
            radial = np.linalg.norm(rel - height[:, None] * axis, axis=1)
            inside = radial <= radius_mm
            if inside.any():
                worst = max(worst, float(height[inside].max()))
    return worst


def test_flat_contacts_over_a_blunt_trailing_edge_match_brute_force(flat_over_the_edge):
    measured = flat_over_the_edge
    brute = _brute_overcut(measured.surface, measured.path, measured.cutter.radius_mm)
    # the surface rises into the cutter over the edge by about the tolerance at most ...
    assert 0.0 < brute < 1.2 * CHORD_TOL_MM
    # ... and the measure reads the plan within it (0.196 mm when a pass's end took its
    # contact on the other sheet)
    assert measured.chord.overcut_mm <= CHORD_TOL_MM
    assert measured.chord.contact_mm <= CHORD_TOL_MM


def test_flat_feet_inside_moves_round_a_blunt_leading_edge_stay_on_their_side():
    raw = read_grid(read_sections(bundled_data_path("dev_rotor_blunt_9x120.csv")))
    placed, _ = place_points(raw.points, mode="flat", base_mm=5.0)
    surface, _ = fit_surface_by_method(dataclasses.replace(raw, points=placed),
                                       method="streamline", tol=0.01)
    measured = planned(surface, "flat:6", scallop_mm=0.05, chord_tol_mm=0.05)
    # the contacts touch; the largest overcut inside the moves is the plan's own
    assert measured.chord.contact_mm < 0.01
    assert 0.0 < measured.chord.overcut_mm <= 0.05


def test_a_disc_point_whose_search_cycles_round_a_thin_edge_is_searched_again():
    # the propeller's 5-axis flat:6 job (upright, trunnion-ac, lead 10): a pose a quarter
    # along a move past the leading edge (0.3 mm radius) stands 0.0009 mm into the surface.
    # With 2, 4 or 6 Newton steps one of its disc's 33 points stopped 1.97 mm from its
    # "foot" across the edge, mostly sideways, and read 0.084 mm inside: the plan's chord
    # measure reported 0.084 mm of overcut (asked 0.05) where the verifier finds 0.048. A
    # foot off the normal through its point is searched again from a neighbour's foot:
    # every step count reads the same gap
    from toolpath.planning.cutters import parse_cutter
    from toolpath.planning.sampling import cutter_gap

    surface = _fitted_upright("dev_prop_7x100.csv")
    tip = np.array([[-3.44174377, 4.4398447, 4.58138113]])
    axis = np.array([[-0.14627685, -0.9875021, 0.05867448]])
    axis /= np.linalg.norm(axis)
    t0, s0 = np.array([0.51446670]), np.array([0.05829035])
    gaps = [cutter_gap(surface, parse_cutter("flat:6"), tip, axis, t0, s0, newton=k,
                       refine_rim=True)[0][0] for k in range(1, 7)]
    np.testing.assert_allclose(gaps, -0.00088, atol=2e-5)


def _fitted_upright(name):
    """The job's surface: ``name`` placed upright and fitted as ``toolpath run`` does."""
    raw = as_sections(read_sections(bundled_data_path(name)))
    placed, _ = place_points(raw.points, mode="upright", base_mm=5.0)
    surface, _ = fit_surface_by_method(dataclasses.replace(raw, points=placed),
                                       method="streamline", tol=0.01)
    return surface


def test_a_disc_point_read_behind_the_far_face_is_searched_again_from_its_neighbours():
    # dev_rotor_blunt's 5-axis bull:6:1 job (upright, trunnion-ac, lead 10): a pose past the
    # leading edge that touches the surface at its contact read 3.1 mm deep, and the
    # chord check split it into a stack of points reading the same (its planned error
    # 3.65 mm): one corner-circle point of the disc scan, seeded at the pose's contact,
    # found the far face's foot, on its normal, 2.08 mm behind its plane, where the near
    # face lies 1.30 mm off. A reading that deep is searched again from a neighbour's
    # foot on the near face and the nearer foot kept: the pose reads its contact
    from toolpath.planning.cutters import parse_cutter
    from toolpath.planning.sampling import cutter_gap

    surface = _fitted_upright("dev_rotor_blunt_9x120.csv")
    tip = np.array([[27.5983119, 0.83493117, 41.35153309]])
    axis = np.array([[-0.33360203, -0.94093761, -0.05784552]])
    axis /= np.linalg.norm(axis)
    t0, s0 = np.array([0.5297127709]), np.array([0.4494904489])
    for newton in (1, 3, 6):
        gap, t, _ = cutter_gap(surface, parse_cutter("bull:6:1"), tip, axis, t0, s0,
                               newton=newton, refine_rim=True)
        assert abs(gap[0]) < 1e-4 and abs(t[0] - t0[0]) < 1e-3


def test_a_disc_point_read_from_a_far_foot_on_a_face_turned_to_the_tool_is_searched_again():
    # dev_rotor_blunt's 5-axis flat:6 job re-planned at scallop 0.0431 mm (upright,
    # trunnion-ac, lead 10): a contact over the 0.4 mm leading edge touches (its rim point
    # 0.005 mm off the surface), but the rim point's search, seeded at the contact, stopped
    # on the edge's nose, on its normal, 0.83 mm off and behind its plane, a face turned
    # 83 deg from the axis (not away from it): the chord measure reported 0.83 mm of
    # overcut (asked 0.05) and the planner 1.6. The pose's expected contact stands nearer
    # to that point than the foot: the foot is no closest point and is searched again
    from toolpath.planning.cutters import parse_cutter
    from toolpath.planning.sampling import cutter_gap

    surface = _fitted_upright("dev_rotor_blunt_9x120.csv")
    tip = np.array([[25.2947416392, 1.4948577861, 13.8837453311]])
    axis = np.array([[0.6905833422, -0.7190679603, -0.0776911575]])
    axis /= np.linalg.norm(axis)
    t0, s0 = np.array([0.5127]), np.array([0.1104])
    for newton in (1, 2, 6):
        gap, t, _ = cutter_gap(surface, parse_cutter("flat:6"), tip, axis, t0, s0,
                               newton=newton, refine_rim=True)
        assert abs(gap[0]) < 1e-4 and abs(t[0] - 0.5127) < 1e-3


@pytest.mark.parametrize("tip,axis,t0,s0", [
    ([27.0158310117, 2.8763042943, 16.9513462251], [-0.2263975931, -0.9730837438, -0.0430366995],
     0.5362203919, 0.1469408379),
    ([27.1798094590, 2.5406885377, 20.8547343460], [-0.2435121035, -0.9688958280, -0.0440764097],
     0.5363931603, 0.1955537396)])
def test_a_disc_centre_read_deep_from_the_far_face_is_no_lowest_point(tip, axis, t0, s0):
    # the same re-planned job: poses a millimetre or two past the leading edge's contact,
    # touching there; the disc's centre, 0.48 mm clear of the near face, found the far
    # face's nose from the pose's contact (and from there again), on its normal, 1.35 to
    # 1.40 mm behind its plane, a face turned away from the axis: the planner's chord check
    # split those moves into stacks of points reading 1.4 to 1.8 mm deep (16,489 points
    # where 15,215 do). An inner point of the disc read deep from a face turned away is no
    # lowest point (where a cutter cuts in, its deepest reading stands on a face turned
    # towards it): the pose reads its contact
    from toolpath.planning.cutters import parse_cutter
    from toolpath.planning.sampling import cutter_gap

    surface = _fitted_upright("dev_rotor_blunt_9x120.csv")
    axis = np.array([axis]) / np.linalg.norm(axis)
    for newton in (1, 3):
        gap, t, _ = cutter_gap(surface, parse_cutter("flat:6"), np.array([tip]), axis,
                               np.array([t0]), np.array([s0]), newton=newton,
                               refine_rim=True)
        assert abs(gap[0]) < 1e-4 and abs(t[0] - t0) < 1e-3


def test_a_tilted_disc_over_a_thin_edge_reads_its_far_rim_from_its_contact():
    # dev_rotor_blunt's 5-axis flat:6 job at scallop 0.005 mm (upright, trunnion-ac, lead
    # 10): a pose touching the leading edge (the rim's lowest point 2e-13 mm off; every rim
    # point's search seeded at the contact reads 0.0005 mm or more), its disc tilted over
    # the edge, read 1.07 mm deep: the window of rim points seeded at the disc centre's
    # foot, 2.4 mm off, put a far rim point's foot on the far face (a face turned away),
    # and its search again from a neighbour's foot found a stationary point 0.78 mm
    # behind a face at 89 deg to the axis (0.09 mm clear). The chord check split that
    # move into 29 points 0.08 um apart and the plan ended "chord error 1.0677 mm". A
    # reading still deep is searched again from the pose's contact and the nearer foot
    # kept: the pose reads its contact
    from toolpath.planning.cutters import parse_cutter
    from toolpath.planning.sampling import cutter_gap

    surface = _fitted_upright("dev_rotor_blunt_9x120.csv")
    tip = np.array([[25.0455349, -1.12047908, 45.31295489]])
    axis = np.array([[0.66122156, -0.74803406, -0.05684275]])
    axis /= np.linalg.norm(axis)
    t0, s0 = np.array([0.5122760834]), np.array([0.5001628013])
    for newton in (1, 3, 6):
        gap, t, _ = cutter_gap(surface, parse_cutter("flat:6"), tip, axis, t0, s0,
                               newton=newton, refine_rim=True)
        assert abs(gap[0]) < 1e-4 and abs(t[0] - t0[0]) < 1e-3


def test_a_rim_that_dips_twice_over_a_thin_edge_is_refined_round_both_dips():
    # dev_rotor_dca's 5-axis flat:6 job at scallop 0.02 mm (upright, trunnion-ac, lead 10):
    # a pose of the first pass at the hub edge, over the leading edge, touches at a rim
    # point 22 deg round (its neighbours' contacts read 0). Searched from the nearest
    # surface sample, the disc's rim samples dipped twice: 0.071 mm at 90 deg (the lowest
    # sample, refined round it) and 0.074 mm at 30 deg, beside the contact: the chord
    # measure read 0.071 mm of undercut there (asked 0.02) and the plan ended over its
    # request. The rim is refined round its other dip too: the pose reads its contact
    # whatever the Newton steps
    from toolpath.planning.cutters import parse_cutter
    from toolpath.planning.sampling import cutter_gap

    surface = _fitted_upright("dev_rotor_dca_11x181.csv")
    tip = np.array([[0.9712313241, 5.4880143601, 2.4081589217]])
    axis = np.array([[0.2008899928, -0.9680251456, -0.1502349102]])
    axis /= np.linalg.norm(axis)
    for newton in (1, 2, 6):
        gap, t, s = cutter_gap(surface, parse_cutter("flat:6"), tip, axis,
                               np.array([0.5022222222]), np.array([0.0]), newton=newton,
                               refine_rim=True)
        assert abs(gap[0]) < 1e-5 and abs(t[0] - 0.50585) < 1e-4 and s[0] < 1e-3


def test_a_contact_reading_above_its_neighbours_is_searched_from_their_contact():
    # dev_rotor_dca's 5-axis flat:6 job at scallop 0.01 mm (upright, trunnion-ac, lead 10):
    # two poses of a pass over the leading edge, both touching. The second's search from
    # the surface sample nearest its disc's centre (on the hub edge, s = 0) read 0.036 mm
    # of undercut with two Newton steps: the chord measure reported it (asked 0.02) and
    # the plan ended over its request. A contact reading above a run neighbour's is
    # searched again from the neighbour's contact, the lower reading kept
    from toolpath.planning.chord_measure import _mend_from_neighbours
    from toolpath.planning.cutters import parse_cutter
    from toolpath.planning.sampling import cutter_gap

    surface = _fitted_upright("dev_rotor_dca_11x181.csv")
    cutter = parse_cutter("flat:6")
    tips = np.array([[-0.3753681621, 4.8746842234, 3.6739838666],
                     [-0.7472765701, 4.8324814685, 3.8284307087]])
    axes = np.array([[0.0983179828, -0.9839083865, -0.1491906874],
                     [0.0698477242, -0.9873521179, -0.1423274071]])
    axes /= np.linalg.norm(axes, axis=1)[:, None]
    gap, t, s = cutter_gap(surface, cutter, tips, axes, np.array([0.506489, 0.5038095238]),
                           np.array([0.020439, 0.0]), newton=2, refine_rim=True)
    assert abs(gap[0]) < 1e-5 and gap[1] > 0.03  # (the second as its sample left it)
    _mend_from_neighbours(surface, cutter, tips, axes, (gap, t, s), np.array([0]))
    assert np.all(np.abs(gap) < 1e-5) and abs(s[1] - 0.0204) < 1e-3
