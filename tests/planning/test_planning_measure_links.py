"""The measure moves the leads and links as the post emits them, under joint interpolation.

A toolpath checked under a 5-axis machine's joint interpolation keeps its cutting moves
whole in the post; the leads and links the post splits until their tips keep to their
chords (:func:`toolpath.joint_refine.checked_moves`). The measure's cut volume once
moved those unsplit by the joints: on a sphere cap, lead-tilt flipping the lead at each
zigzag link turns C by about 59 deg over a 1.1 mm link, and the joints carried the ball
up to 0.7 mm through the part there, a cut the program never makes. Its centres then
lay below the sheet ``R`` above the surface that the ray casts' pieces are sought on
(:func:`toolpath.planning.cusp_search._bracket_pieces`): casts left such pieces out and
read a full cusp where the phantom cut reached (31 of 424 seeds on trunnion-ac).
"""

import numpy as np
import pytest
from measured_plans import planned

from machines import load_machine
from toolpath.joint_refine import refine_for_joint_interpolation
from toolpath.path import MoveKind
from toolpath.planning import SpherePatch
from toolpath.planning.cusp_search import CuspSearch, SearchSeeds

CAP = SpherePatch(radius_mm=50.0, longitude_deg=(-8.0, 8.0), colatitude_deg=(15.0, 25.0))
BALL_RADIUS_MM = 3.0


@pytest.fixture(scope="module", params=["trunnion-ac", "head-table-bc"])
def measured(request):
    return planned(CAP, "ball:6", scallop_mm=0.01, chord_tol_mm=0.01, axis_mode="lead-tilt",
                   lead_deg=10.0, machine=load_machine(request.param))


def _sheet_depth_mm(centres: np.ndarray) -> np.ndarray:
    """How far ball centres lie inside the sheet ``R`` above the cap (the sphere's R + 3)."""
    return 53.0 - np.linalg.norm(centres - CAP.centre, axis=1)


def test_the_program_never_cuts_into_the_cap(measured):
    # the premise: the posted program (links split) keeps every ball centre on or above
    # the sheet, within the chord tolerance (joints sampled finely inside every move)
    from machines.kinematics import forward

    machine = measured.machine
    path = refine_for_joint_interpolation(measured.path, machine, 0.002)
    feed = np.flatnonzero(path.kinds[1:] != MoveKind.RAPID)
    joints = path.to_machine(machine).joints
    u = np.linspace(0.0, 1.0, 33)[:, None, None]
    tip, axis = forward(machine, (joints[feed] * (1 - u) + joints[feed + 1] * u).reshape(-1, 5))
    assert _sheet_depth_mm(tip + BALL_RADIUS_MM * axis).max() < 0.01


def test_links_move_as_the_post_emits_them(measured):
    volume = measured.volume()
    depth = _sheet_depth_mm(np.concatenate([volume.a, volume.b]))
    assert depth.max() < 0.01  # the unsplit links' joints: 0.70 mm


def test_casts_meet_every_piece_that_cuts(measured):
    def casts(generous: bool) -> CuspSearch:
        volume = measured.volume()
        if generous:  # every piece within 4 R of the bracket
            volume.lateral, volume.lift = 4.0 * BALL_RADIUS_MM, 0.0
            volume.segment_reach = 2.0 * BALL_RADIUS_MM
        seeds, others = SearchSeeds.of(measured.surface, measured.chord)
        search = CuspSearch(volume, measured.surface, seeds, others, 1.0, 20_000)
        search.run(np.ones(len(seeds.t), dtype=bool))
        return search

    cast, oracle = casts(False), casts(True)
    assert np.isfinite(oracle.height).sum() > 100
    same = ((cast.height == oracle.height) | (np.isnan(cast.height) & np.isnan(oracle.height)))
    assert same.all(), (np.flatnonzero(~same)[:5], cast.height[~same][:5],
                        oracle.height[~same][:5])


def test_the_passes_still_move_by_their_joints(measured):
    # the cutting moves of a pass, which the post leaves whole: their pieces' inner ends
    # are the joints' poses (forward kinematics at u = k / c), not the tip-linear ones
    from machines.kinematics import forward
    from toolpath.planning.measure_joints import checked_joints

    volume = measured.volume()
    joints = checked_joints(measured.path, measured.machine)
    path = measured.path
    start = volume.move_starts[volume.piece_move]
    cut = ((path.kinds[start + 1] == MoveKind.CUT)
           & (path.pass_index[start + 1] == path.pass_index[start]))
    first = np.r_[True, volume.piece_move[1:] != volume.piece_move[:-1]]
    inner = np.flatnonzero(cut & ~first)  # pieces starting at an inner pose of their move
    assert inner.size > 100
    move_first = np.flatnonzero(first)[np.searchsorted(np.flatnonzero(first), inner,
                                                       side="right") - 1]
    count = np.bincount(volume.piece_move)[volume.piece_move[inner]]
    u = ((inner - move_first) / count)[:, None]
    tip, axis = forward(measured.machine, joints[start[inner]] * (1 - u)
                        + joints[start[inner] + 1] * u)
    assert np.abs(tip + BALL_RADIUS_MM * axis - volume.a[inner]).max() < 1e-9
    # and they bow off the tip-linear chord where the rotary axes turn
    lerp = (path.positions_mm[start[inner]] * (1 - u) + path.positions_mm[start[inner] + 1] * u)
    assert np.linalg.norm(tip - lerp, axis=1).max() > 1e-4
