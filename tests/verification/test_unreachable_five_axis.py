"""Issue 24: the verifier tells unreachable areas for 5-axis programs too.

An area no tool axis of the program can touch (facing away from every axis its cutting
moves use), or that no pass covers, is unreachable: reported apart, never as a scallop.
"""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np
import pytest
from test_five_axis import OPTIONS, PLANE
from verify_programs import five_axis_line

from machines import load_machine
from verification import verify_program
from verification.verify import AXIS_BIN, faces_away


def _motion(axes):
    """A replayed motion's fields faces_away reads: every instance cutting."""
    axes = np.asarray(axes, dtype=float)
    return SimpleNamespace(axes=axes, rapid=np.zeros(len(axes), dtype=bool),
                           move_of_instance=np.arange(len(axes)))


def test_a_turning_axis_reaches_round_but_not_behind():
    # axes swinging from +Z over to +X (a 5-axis pass round a nose)
    angle = np.radians(np.linspace(0.0, 90.0, 50))
    motion = _motion(np.column_stack((np.sin(angle), np.zeros(50), np.cos(angle))))
    normals = np.array([[0.0, 0.0, 1.0],   # faces the axes
                        [1.0, 0.0, 0.0],   # reached once the axis has turned
                        [-1.0, 0.0, 0.05],  # behind +X, beyond square to +Z: still touched
                        [-0.6, 0.0, -0.8],  # behind every axis used
                        [-0.3, 0.0, -0.95]])  # underneath
    assert faces_away(motion, normals).tolist() == [False, False, False, True, True]


def test_a_fixed_axis_is_judged_exactly_as_before():
    motion = _motion(np.tile([0.0, 0.0, 1.0], (5, 1)))
    normals = np.array([[0.0, 1.0, 1e-6], [0.0, 1.0, -1e-6]])
    assert faces_away(motion, normals).tolist() == [False, True]


def test_a_five_axis_line_leaves_the_plane_beside_it_unreachable(ball6):
    # one 5-axis line across a plane (B swinging 40 deg): the band beside it no pass covers
    machine = load_machine("head-table-bc")
    report = verify_program(five_axis_line(machine, ball6, 400), PLANE, machine, ball6,
                            options=OPTIONS)
    assert report.faces_away_area_mm2 == 0.0  # the plane faces every axis used
    assert report.design_area_mm2 == pytest.approx(26.0 * 6.0, rel=0.02)
    assert report.unreachable_area_mm2 == pytest.approx(report.stats.uncut_area_mm2)
    fraction = report.to_dict()["unreachable_fraction"]
    assert 0.2 < fraction < 0.9


def test_the_bin_scan_agrees_with_every_product():
    # the scan that tries the last best bin first against max over the full products table
    rng = np.random.default_rng(27)
    tilt = np.radians(rng.uniform(0.0, 40.0, 4000))
    turn = np.radians(rng.uniform(-30.0, 90.0, 4000))
    axes = np.column_stack((np.sin(tilt) * np.cos(turn), np.sin(tilt) * np.sin(turn),
                            np.cos(tilt)))
    normals = rng.normal(size=(30, 40, 3))
    normals /= np.linalg.norm(normals, axis=-1, keepdims=True)
    bins = np.unique(np.round(axes / AXIS_BIN).astype(np.int64), axis=0) * AXIS_BIN
    bins /= np.linalg.norm(bins, axis=1, keepdims=True)
    full = (normals.reshape(-1, 3) @ bins.T).max(axis=1) < -AXIS_BIN
    away = faces_away(_motion(axes), normals)
    assert away.shape == (30, 40)
    assert 0.1 < away.mean() < 0.9
    assert away.ravel().tolist() == full.tolist()
