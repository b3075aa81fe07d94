"""The uncut area's grid: nodes tried first with the piece the contacts place at them.

:meth:`~toolpath.planning.uncut_area.UncutArea.on_grid` with the chord measurement's
contacts tries each node's piece first (the shortcut) and searches the others; without them
every node is searched (the full method). Both must find the same uncut nodes.
"""

import dataclasses

import numpy as np
import pytest
from measured_plans import planned

from toolpath.path import MoveKind
from toolpath.planning import SpherePatch
from toolpath.planning.chord_measure import measure_chord
from toolpath.planning.uncut_area import UncutArea

CAP = SpherePatch(radius_mm=50.0, longitude_deg=(-20.0, 20.0), colatitude_deg=(15.0, 40.0))


def _without_passes(path, passes):
    """The toolpath with the moves along ``passes`` made rapids: those strips stay uncut."""
    kinds = path.kinds.copy()
    kinds[np.isin(path.pass_index, passes)] = MoveKind.RAPID
    return dataclasses.replace(path, kinds=kinds)


@pytest.mark.parametrize("scramble", [False, True])
def test_the_contacts_pieces_find_the_uncut_area_the_full_search_finds(scramble):
    measured = planned(CAP, "ball:6", scallop_mm=0.02, chord_tol_mm=0.02, axis_mode="3")
    middle = int(measured.path.pass_index.max()) // 2
    path = _without_passes(measured.path, np.arange(middle - 3, middle + 4))
    chord = measure_chord(path, CAP, measured.cutter, measured.samples)
    measured = dataclasses.replace(measured, path=path, chord=chord)
    volume = measured.volume()
    contacts = (chord.contact_t, chord.contact_s)
    assert np.isfinite(contacts[0]).sum() > 200
    if scramble:  # pieces placed at nodes far from them: the search must take over
        rng = np.random.default_rng(3)
        contacts = tuple(rng.permutation(c) for c in contacts)
    width_mm = 2.0 * np.sqrt(0.02 * (2.0 * 3.0 - 0.02))
    fast = UncutArea.on_grid(CAP, volume, width_mm, contacts)
    full = UncutArea.on_grid(CAP, volume, width_mm)
    assert full.uncut.any() and (~full.uncut).any()
    assert np.array_equal(fast.uncut, full.uncut)
    assert fast.fraction == full.fraction
    assert np.array_equal(fast.reach, full.reach)
