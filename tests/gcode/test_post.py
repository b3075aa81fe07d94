"""The post: golden text per dialect, kinematics round trip, feeds, arcs, safe start/end."""

import os
from dataclasses import replace

import numpy as np
import pytest
from conftest import DATA
from toolpaths import blade_5axis, pocket_3axis, random_5axis

from gcode import (
    FANUC,
    GENERIC,
    GRBL,
    LINUXCNC,
    Arc,
    Coolant,
    Linear,
    PostError,
    PostOptions,
    Program,
    ProgramEnd,
    Rapid,
    SetFeedMode,
    Spindle,
    SpindleDirection,
    Units,
    emit_text,
    interpret,
    parse,
    post,
)
from gcode.check import check_program
from gcode.machine_frame import joint_columns, work_offsets
from machines import forward, load_machine
from toolpath import MoveKind, Toolpath

GOLDEN = DATA / "golden"
REGEN = os.environ.get("GCODE_REGEN_GOLDEN") == "1"
# name -> (machine, dialect, toolpath factory, options)
CASES = {
    "post_grbl": ("grbl-router", GRBL, pocket_3axis, PostOptions()),
    "post_linuxcnc": ("trunnion-ac", LINUXCNC, blade_5axis,
                      PostOptions(tool=4, joint_tolerance_mm=None)),
    "post_fanuc": ("head-table-bc", FANUC, blade_5axis,
                   PostOptions(tool=4, number=77, joint_tolerance_mm=None)),
    "post_generic_inch": (
        "trunnion-ac", GENERIC, pocket_3axis, PostOptions(units=Units.INCH, coolant=None),
    ),
}  # fmt: skip
# Tool-tip error of the posted, written and re-read program (mm): 1 um coordinates and
# 0.001 degree angles at up to ~250 mm from the rotary axes (4.4 um), with margin.
FK_TIP_TOL_MM = 0.01
FK_AXIS_TOL_DEG = 0.002


def _posted(name):
    machine, dialect, make, options = CASES[name]
    return post(make(), load_machine(machine), dialect, options=options), dialect


@pytest.mark.parametrize("name", sorted(CASES))
def test_post_matches_golden_text_byte_for_byte(name):
    program, dialect = _posted(name)
    text = emit_text(program, dialect)
    path = GOLDEN / f"{name}.nc"
    if REGEN:
        path.write_text(text, encoding="ascii", newline="\n")
    assert text == path.read_text(encoding="ascii")


@pytest.mark.parametrize("name", sorted(CASES))
def test_posted_text_reads_back_to_the_same_program_and_checks_clean(name):
    program, dialect = _posted(name)
    back = parse(emit_text(program, dialect), dialect)
    assert back.blocks[len(dialect.preamble) :] == program.blocks  # exact: words on the grid
    assert check_program(program, load_machine(CASES[name][0]), dialect) == []


def _tips_of_program(program, dialect, machine):
    seg = interpret(parse(emit_text(program, dialect), dialect), work_offsets=work_offsets(machine))
    return seg, forward(machine, joint_columns(machine, seg.end))


@pytest.mark.parametrize("machine_name", ["trunnion-ac", "head-table-bc"])
@pytest.mark.parametrize("seed", [0, 1, 2])
def test_forward_kinematics_of_parsed_joints_reproduces_the_toolpath(machine_name, seed):
    machine = load_machine(machine_name)
    tp = random_5axis(np.random.default_rng(seed))
    program = post(tp, machine, options=PostOptions(arcs=False, joint_tolerance_mm=None))
    seg, (tips, axes) = _tips_of_program(program, LINUXCNC, machine)
    # four approach rapids (Z, rotary, XY, down to point 0), then one segment per move
    n = len(tp)
    tip_err = np.linalg.norm(tips[3 : 3 + n] - tp.positions_mm, axis=1)
    cos = np.clip((axes[3 : 3 + n] * tp.tool_axes).sum(axis=1), -1.0, 1.0)
    assert tip_err.max() < FK_TIP_TOL_MM
    assert np.degrees(np.arccos(cos)).max() < FK_AXIS_TOL_DEG
    assert (seg.kind[4 : 3 + n] == 1).all() and seg.inverse_time[4 : 3 + n].all()


def test_inverse_time_blocks_take_the_planned_time_within_every_rate_limit():
    machine = load_machine("trunnion-ac")
    tp = random_5axis(np.random.default_rng(7))
    program = post(tp, machine, options=PostOptions(arcs=False, joint_tolerance_mm=None))
    seg, _ = _tips_of_program(program, LINUXCNC, machine)
    planned = tp.segment_times_s(machine)
    got = seg.durations()[4 : 3 + len(tp)]
    # F is written with 4 decimals and rounded down: never faster, at most 1e-4 slower
    assert (got >= planned * (1 - 1e-9)).all()
    assert np.allclose(got, planned, rtol=1e-3)
    assert check_program(program, machine) == []


def test_g94_fallback_gives_the_same_times_as_inverse_time():
    machine = load_machine("head-table-bc")
    tp = random_5axis(np.random.default_rng(3))
    opts = PostOptions(arcs=False, joint_tolerance_mm=None)
    g93 = post(tp, machine, options=opts)
    g94 = post(tp, machine, options=replace(opts, inverse_time=False))
    assert not any(isinstance(b, SetFeedMode) for b in g94.blocks)
    t93, _ = _tips_of_program(g93, LINUXCNC, machine)
    t94, _ = _tips_of_program(g94, LINUXCNC, machine)
    assert np.allclose(t93.durations(), t94.durations(), rtol=2e-3)


def test_feed_is_reduced_to_the_slowest_axis_rate():
    tp = Toolpath(
        [[0, 0, 5], [0, 0, -5], [100, 0, -5], [100, 30, -5]],
        [0, 0, 1],
        [MoveKind.RAPID, MoveKind.PLUNGE, MoveKind.CUT, MoveKind.CUT],
        [0, 20000, 20000, 5000],
        [-1, 0, 0, 0],
    )
    program = post(tp, load_machine("grbl-router"), options=PostOptions(arcs=False))
    feeds = [b.feed for b in program.blocks if isinstance(b, Linear)]
    assert feeds == [3000.0, 8000.0, 5000.0]  # Z max 3000, X max 8000, as asked


def test_five_axis_toolpath_is_refused_for_a_three_axis_machine_or_dialect():
    with pytest.raises(PostError, match=r"3-axis machine 'grbl-router'.*point 0") as info:
        post(blade_5axis(), load_machine("grbl-router"))
    assert info.value.code == 20
    with pytest.raises(PostError, match=r"dialect 'grbl' has no A, C words"):
        post(pocket_3axis(), load_machine("trunnion-ac"), GRBL)


def test_safe_start_retracts_z_before_any_other_axis_and_safe_end_stops_everything():
    program = post(blade_5axis(), load_machine("trunnion-ac"))
    blocks = list(program.blocks)
    first_move = next(i for i, b in enumerate(blocks) if isinstance(b, Rapid | Linear | Arc))
    assert blocks[first_move] == Rapid(z=blocks[first_move].z)
    rotary, xy = blocks[first_move + 1], blocks[first_move + 2]
    assert (rotary.x, rotary.y, rotary.z) == (None, None, None) and rotary.a is not None
    assert (xy.z, xy.a, xy.c) == (None, None, None)
    spindle = next(i for i, b in enumerate(blocks) if isinstance(b, Spindle))
    assert spindle < first_move and blocks[spindle].direction is SpindleDirection.CW
    assert isinstance(blocks[spindle + 1], Coolant)
    safe_z = blocks[first_move].z
    assert blocks[-4] == Rapid(z=safe_z)
    assert blocks[-3] == Spindle(SpindleDirection.OFF, 12000.0)
    assert isinstance(blocks[-2], Coolant) and blocks[-1] == ProgramEnd(rewind=True)
    seg = interpret(program)
    assert seg.end[:, 2].max() == safe_z  # nothing goes above the clearance height


def test_arcs_replace_sampled_circles_within_tolerance():
    tp = pocket_3axis()
    machine = load_machine("grbl-router")
    tol = 0.005
    program = post(tp, machine, GRBL, options=PostOptions(arc_tolerance_mm=tol))
    lines_only = post(tp, machine, GRBL, options=PostOptions(arcs=False))
    arcs = [b for b in program.blocks if isinstance(b, Arc)]
    assert len(arcs) == 2 and len(program) < len(lines_only) - 20
    # every original point lies within tol of the programmed path (arcs followed finely)
    seg = interpret(parse(emit_text(program, GRBL), GRBL)).linearize(1e-5)
    a, b = seg.start[:, :3], seg.end[:, :3]
    ab = b - a
    for p in tp.positions_mm:
        t = np.clip(((p - a) * ab).sum(axis=1) / np.maximum((ab * ab).sum(axis=1), 1e-300), 0, 1)
        dist = np.linalg.norm(a + t[:, None] * ab - p, axis=1).min()
        assert dist <= tol + 1e-4


def test_no_arcs_when_the_dialect_or_the_options_say_so():
    machine = load_machine("grbl-router")
    cases = ((replace(GRBL, arcs=False), PostOptions()), (GRBL, PostOptions(arcs=False)))
    for dialect, opts in cases:
        program = post(pocket_3axis(), machine, dialect, options=opts)
        assert not any(isinstance(b, Arc) for b in program.blocks)


def test_g20_and_g21_posts_parse_to_the_same_millimetres():
    machine = load_machine("grbl-router")
    mm = post(pocket_3axis(), machine, GRBL)
    inch = post(pocket_3axis(), machine, GRBL, options=PostOptions(units=Units.INCH))
    seg_mm = interpret(parse(emit_text(mm, GRBL), GRBL)).linearize(0.001)
    seg_in = interpret(parse(emit_text(inch, GRBL), GRBL)).linearize(0.001)
    assert emit_text(inch, GRBL).startswith("G20\n")
    # same path to the inch resolution (2.54 um) plus the mm one (1 um)
    assert np.abs(seg_mm.bounds()[0] - seg_in.bounds()[0]).max() < 0.0035
    assert np.abs(seg_mm.bounds()[1] - seg_in.bounds()[1]).max() < 0.0035
    assert abs(seg_mm.lengths().sum() - seg_in.lengths().sum()) < 0.05
    assert abs(seg_mm.durations().sum() - seg_in.durations().sum()) < 0.01


def test_moves_that_change_nothing_are_dropped_and_unchanged_words_left_out():
    tp = Toolpath(
        [[0, 0, 5], [0, 0, -1], [0, 0, -1.0001], [10, 0, -1], [10, 5, -1]],
        [0, 0, 1],
        [MoveKind.RAPID] + [MoveKind.CUT] * 4,
        [0, 300, 300, 800, 800],
        [0] * 5,
    )
    program = post(tp, load_machine("grbl-router"), options=PostOptions(arcs=False))
    moves = [b for b in program.blocks if isinstance(b, Linear)]
    assert moves == [Linear(z=-1.0, feed=300.0), Linear(x=10.0, feed=800.0),
                     Linear(y=5.0, feed=800.0)]  # fmt: skip


def test_bad_options_are_refused():
    with pytest.raises(ValueError, match="work_offset"):
        PostOptions(work_offset=7)
    with pytest.raises(ValueError, match="arc_tolerance_mm"):
        PostOptions(arc_tolerance_mm=0.0)


def test_tool_change_becomes_a_comment_on_grbl():
    program = post(pocket_3axis(), load_machine("grbl-router"), options=PostOptions(tool=3))
    text = emit_text(program, GRBL)
    assert "(load tool 3 by hand: grbl has no M6)" in text and "T3" not in text
    assert isinstance(program, Program) and program.name == "pocket 3-axis"


@pytest.mark.parametrize("machine_name", ["trunnion-ac", "head-table-bc"])
def test_joint_interpolation_keeps_the_tip_on_the_planned_chords(machine_name):
    from toolpath.joint_refine import joint_path_deviation_mm, refine_for_joint_interpolation

    machine = load_machine(machine_name)
    tp = blade_5axis()
    before = joint_path_deviation_mm(machine, tp.positions_mm, tp.to_machine(machine).joints)
    refined = refine_for_joint_interpolation(tp, machine, 0.002)
    after = joint_path_deviation_mm(machine, refined.positions_mm,
                                    refined.to_machine(machine).joints)
    assert before.max() > 0.05 and after.max() <= 0.002
    # the refined chords lie on the planned ones: every planned point is still there
    kept = (refined.positions_mm[:, None, :] == tp.positions_mm[None]).all(axis=2).any(axis=0)
    assert kept.all()
    # the post splits the same moves (and says so in one header comment)
    plain = post(tp, machine, options=PostOptions(arcs=False, joint_tolerance_mm=None))
    split = post(tp, machine, options=PostOptions(arcs=False, joint_tolerance_mm=0.002))
    assert len(split.blocks) - len(plain.blocks) == len(refined) - len(tp) + 1


@pytest.mark.parametrize("machine_name", ["trunnion-ac", "head-table-bc"])
def test_joint_interpolated_rapids_keep_near_their_planned_chords(machine_name):
    """A rapid that turns the rotary axes strays off its chord (over the clearance) under
    joint interpolation, through the part: it is split too, to within a millimetre."""
    from toolpath.joint_refine import (
        RAPID_TOLERANCE_MM,
        joint_path_deviation_mm,
        refine_for_joint_interpolation,
    )

    machine = load_machine(machine_name)
    tilt = np.radians(50.0)
    tips = np.array([[0.0, 0.0, 60.0], [60.0, 0.0, 40.0], [80.0, 30.0, 20.0]])
    axes = np.array([[0.0, 0.0, 1.0], [np.sin(tilt), 0.0, np.cos(tilt)],
                     [0.0, np.sin(tilt), np.cos(tilt)]])
    kinds = [MoveKind.RAPID, MoveKind.RAPID, MoveKind.CUT]
    tp = Toolpath(tips, axes, kinds, [0.0, 0.0, 1000.0], [-1, -1, 0])
    before = joint_path_deviation_mm(machine, tp.positions_mm, tp.to_machine(machine).joints)
    refined = refine_for_joint_interpolation(tp, machine, 0.002)
    rapid = refined.kinds[1:] == MoveKind.RAPID
    after = joint_path_deviation_mm(machine, refined.positions_mm,
                                    refined.to_machine(machine).joints)
    assert before[0] > 5.0 * RAPID_TOLERANCE_MM
    assert after[rapid].max() <= RAPID_TOLERANCE_MM and after[~rapid].max() <= 0.002
