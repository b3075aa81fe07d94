"""How tightly the ball centres' path curves near each piece (the cusp estimate's sink rule).

:func:`~toolpath.planning.cusp_estimates._piece_curving` (compiled,
:func:`~toolpath.planning.cusp_kernel.path_curving`, its neighbours walked to) is checked
against its definition taken piece by piece, whether asked of every piece or of a few,
against a circle's curvature, and at a pass's end.
"""

import numpy as np
import pytest

from toolpath.path import MoveKind, Toolpath
from toolpath.planning import parse_cutter
from toolpath.planning.cusp_estimates import _piece_curving
from toolpath.planning.cut_volume import CutVolume


def _two_passes() -> Toolpath:
    """An arc of radius 20 mm, then (after a rapid) a line with a 30 deg kink."""
    angle = np.linspace(0.0, 1.2, 25)
    arc = np.stack([20.0 * np.cos(angle), 20.0 * np.sin(angle), np.zeros_like(angle)], axis=1)
    line = np.stack([np.linspace(0.0, 12.0, 9), np.full(9, 40.0), np.zeros(9)], axis=1)
    turn = np.radians(30.0)
    kinked = line[-1] + np.outer(np.linspace(1.5, 12.0, 8), [np.cos(turn), np.sin(turn), 0.0])
    points = np.concatenate([arc, line, kinked])
    kinds = np.full(len(points), MoveKind.CUT, dtype=np.uint8)
    kinds[0] = kinds[len(arc)] = MoveKind.RAPID
    passes = np.repeat([0, 1], [len(arc), len(line) + len(kinked)]).astype(np.int32)
    return Toolpath(points, np.array([0.0, 0.0, 1.0]), kinds, np.full(len(points), 1000.0),
                    passes)


def _by_definition(volume: CutVolume, piece: int) -> float:
    """The turn to the pass's pieces ``R / 2`` before and after over the way between."""
    e = volume.b - volume.a
    length = np.linalg.norm(e, axis=1)
    mid = np.cumsum(length) - 0.5 * length
    same = np.flatnonzero(volume.pass_of == volume.pass_of[piece])
    worst = 0.0
    for side in (-0.5, 0.5):
        goal = mid[piece] + side * volume.cutter.radius_mm
        near = int(same[min(np.searchsorted(mid[same], goal), len(same) - 1)])
        cos = e[piece] @ e[near] / (length[piece] * length[near])
        turn = np.arccos(np.clip(cos, -1.0, 1.0))
        worst = max(worst, turn / max(abs(mid[near] - mid[piece]), 1e-300))
    return worst


def test_every_piece_s_curving_is_its_definition():
    volume = CutVolume(_two_passes(), parse_cutter("ball:6"), 0.05, 0.005)
    count = len(volume.pass_of)
    curving = _piece_curving(volume, np.arange(count)[::-1])[::-1]  # every piece at once
    inner = [j for j in range(count)
             if 0 < j < count - 1 and volume.pass_of[j - 1] == volume.pass_of[j + 1]]
    expected = np.array([_by_definition(volume, j) for j in inner])
    assert len(inner) > 40
    assert np.allclose(curving[inner], expected, rtol=1e-9, atol=1e-12)
    few = np.array(inner[::5])  # those asked alone
    assert 2 * len(few) < count
    assert np.allclose(_piece_curving(volume, few), expected[::5], rtol=1e-9, atol=1e-12)
    on_arc = np.array(inner)[volume.pass_of[inner] == 0]
    # (moves of 1 mm turn at their joints: over R / 2 a piece sees two to four of them)
    assert (curving[on_arc] > 0.7 / 20.0).all() and (curving[on_arc] < 1.6 / 20.0).all()
    # the line's pieces within R / 2 of the kink see its whole turn, the others none
    on_line = np.array(inner)[volume.pass_of[inner] == 1]
    assert curving[on_line].min() == 0.0 and curving[on_line].max() > 0.1


def test_a_pass_s_end_piece_reads_no_turn_from_itself():
    # the last piece of a pass has no piece R / 2 beyond it: the walk stops on the piece
    # itself, whose direction against its own reads cos 1 - 1e-16 here (rounding), a turn
    # of 1.5e-8 rad over no length; without the guard that read 1e292 per mm
    from toolpath.planning.cusp_kernel import path_curving

    last = [0.21289824318069073, 0.24718083778387828, 0.07346489669355873]
    norm = np.sqrt(last[0] * last[0] + last[1] * last[1] + last[2] * last[2])
    assert sum(x / norm * x for x in last) / norm < 1.0  # (the premise: rounding)
    e = np.array([[0.3, 0.0, 0.0]] * 12 + [last] + [[0.0, 0.3, 0.0]] * 3)
    pass_of = np.array([0] * 13 + [1] * 3)
    curving = path_curving(np.arange(len(e)), e, pass_of, 3.0, 1e-300)
    assert np.isfinite(curving).all()
    # the last piece: only the turn from the piece R / 2 behind it (the 9th, whose
    # midpoint is the first at or beyond 1.5 mm back), over the way between
    back = 3.6 + 0.5 * norm - (0.15 + 0.3 * 8)
    assert curving[12] == pytest.approx(np.arccos(last[0] / norm) / back, rel=1e-9)
    assert curving[13:].max() == 0.0  # (the next pass runs straight)


def test_pieces_asked_more_than_once_each_read_their_own_curving():
    # the estimate asks each seed's two pieces, many of them more than once and out of
    # path order: each is walked from once, and every answer is its piece's
    volume = CutVolume(_two_passes(), parse_cutter("ball:6"), 0.05, 0.005)
    count = len(volume.pass_of)
    inner = np.array([j for j in range(count)
                      if 0 < j < count - 1 and volume.pass_of[j - 1] == volume.pass_of[j + 1]])
    asked = np.random.default_rng(7).choice(inner, size=3 * len(inner))
    asked[:5] = asked[5]  # (a run of one piece, as neighbouring seeds ask it)
    assert len(np.unique(asked)) < len(asked)
    expected = np.array([_by_definition(volume, j) for j in asked])
    assert np.allclose(_piece_curving(volume, asked), expected, rtol=1e-9, atol=1e-12)
    assert _piece_curving(volume, np.zeros(0, dtype=np.int64)).shape == (0,)
