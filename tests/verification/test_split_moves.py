"""Issue 27: the reported extremes do not depend on how a path is cut into moves.

The same 5-axis path written as few long moves and as many short ones (every move split
into equal joint-space sub-moves at exact split points: the very same path) must verify
to the same deepest gouge and largest scallop, to 0.2 %, and to the figures of the whole
program replayed finely, every chord kept (the oracle). The whole-program model stands
within 1.5 um of the true sweep per move, so without the fine model around the extremes
the two programs measure apart by more.
"""

import numpy as np
import pytest
from verify_programs import five_axis_cap

from gcode import Linear, Program
from gcode.program import AXES
from machines import load_machine
from toolpath.planning.analytic import SpherePatch
from verification import VerifyOptions, verify_program

RADIUS_MM = 30.0
SCALLOP_MM = 0.005
GOUGE_MM = 0.008
SAME = 0.002  # 0.2 %


def split_moves(program: Program, k: int) -> Program:
    """Every linear move as ``k`` equal joint-space sub-moves (split points unrounded)."""
    pos: dict[str, float | None] = dict.fromkeys(AXES)
    out = []
    for b in program.blocks:
        new = {a: getattr(b, a) for a in AXES if getattr(b, a) is not None}
        if type(b) is Linear and all(pos[a] is not None for a in new):
            start = {a: pos[a] for a in new}
            out += [Linear(**{a: start[a] + j / k * (new[a] - start[a]) for a in new},
                           feed=b.feed) for j in range(1, k + 1)]
        else:
            out.append(b)
        pos.update(new)
    return Program(tuple(out))


@pytest.fixture(scope="module")
def dome_programs():
    """5-axis passes along the parallels of a dome, one more pass 8 um into it; split."""
    from toolpath.planning.cutters import parse_cutter

    ball6 = parse_cutter("ball:6")
    machine = load_machine("trunnion-ac")
    dome = SpherePatch(radius_mm=RADIUS_MM, longitude_deg=(-8.0, 8.0),
                       colatitude_deg=(52.0, 58.0))
    step_deg = np.degrees(0.3 / RADIUS_MM)
    passes = five_axis_cap(machine, ball6, RADIUS_MM, longitude_deg=(-12.0, 12.0),
                           colatitudes_deg=np.arange(50.0, 60.0, step_deg), points=14)
    deep = five_axis_cap(machine, ball6, RADIUS_MM - GOUGE_MM, longitude_deg=(-12.0, 12.0),
                         colatitudes_deg=[55.0 + step_deg / 3.0], points=14)
    long_moves = Program(passes.blocks + deep.blocks)
    return machine, ball6, dome, long_moves, split_moves(long_moves, 24)


def _figures(program, surface, machine, cutter, **options):
    rep = verify_program(program, surface, machine, cutter,
                         options=VerifyOptions(scallop_mm=SCALLOP_MM, **options))
    assert rep.max_gouge is not None and rep.max_scallop is not None
    return rep


def test_split_path_verifies_to_the_same_gouge_and_scallop(dome_programs):
    machine, cutter, dome, long_moves, short_moves = dome_programs
    assert len(short_moves) > 10 * len(long_moves)
    a = _figures(long_moves, dome, machine, cutter)
    b = _figures(short_moves, dome, machine, cutter)
    assert b.max_gouge_mm == pytest.approx(a.max_gouge_mm, rel=SAME)
    assert b.max_scallop_mm == pytest.approx(a.max_scallop_mm, rel=SAME)
    # the gouge on the deep pass (its last blocks)
    assert a.max_gouge.line > len(long_moves) - 20 and b.max_gouge.line > len(short_moves) - 400


def test_extremes_match_the_whole_program_modelled_finely(dome_programs):
    machine, cutter, dome, long_moves, short_moves = dome_programs
    oracle = _figures(long_moves, dome, machine, cutter, merge_tol_mm=0.0,
                      replay_tol_mm=1e-5)
    for program in (long_moves, short_moves):
        rep = _figures(program, dome, machine, cutter)
        assert rep.max_gouge_mm == pytest.approx(oracle.max_gouge_mm, rel=SAME)
        assert rep.max_scallop_mm == pytest.approx(oracle.max_scallop_mm, rel=SAME)


def test_coarse_model_alone_may_differ_by_its_tolerance(dome_programs):
    """Without the fine model the figures stay within the coarse model's 1.5 um."""
    machine, cutter, dome, long_moves, short_moves = dome_programs
    a = _figures(long_moves, dome, machine, cutter, extremes_tol_mm=None)
    b = _figures(short_moves, dome, machine, cutter, extremes_tol_mm=None)
    tol = VerifyOptions().replay_tol_mm + VerifyOptions().merge_tol_mm
    assert b.max_gouge_mm == pytest.approx(a.max_gouge_mm, abs=2 * tol)
    assert b.max_scallop_mm == pytest.approx(a.max_scallop_mm, abs=2 * tol)


def test_a_centre_standing_still_keeps_every_joint_segment_it_stands_for():
    # (a flat cutter turning about its tip: its pieces' arcs along the centre's path repeat
    # over several instances; the fine model replays every segment between them)
    from types import SimpleNamespace

    from verification.fine_model import FineModel

    model = FineModel.__new__(FineModel)
    for still in (1, 2, 3, 4, 6):
        path_arc_mm = np.array([0.0] + [1.0] * still + [2.0, 3.0])
        model.motion = SimpleNamespace(rows=SimpleNamespace(
            of_instance=np.arange(path_arc_mm.size)))
        pieces = SimpleNamespace(path_arc_mm=path_arc_mm, arc0_mm=np.array([1.0]),
                                 arc1_mm=np.array([1.0]))
        rows = model._rows(pieces, np.array([0]))
        assert set(range(1, still + 2)) <= set(rows.tolist())
