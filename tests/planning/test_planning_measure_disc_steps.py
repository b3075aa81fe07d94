"""Issue 27: a flat or bull-nose cutter's contacts measured with fewer fixed Newton steps.

``measure_chord`` searches each disc point of a flat or bull-nose cutter's contact from the
nearest surface sample with ``DISC_CONTACT_NEWTON`` fixed steps, then more while a step
still moves the foot (``CONVERGED_MM``). The full method is six fixed steps: every
location's gap (to 0.1 nm), foot (to 1 um) and the chord figures must be the same.
"""

import numpy as np
import pytest
from measured_plans import planned, standing_blade_job

from toolpath.planning import EllipticBladeSurface
from toolpath.planning.chord_measure import (
    DISC_CONTACT_NEWTON,
    _cutting_moves,
    _end_contacts,
    measure_chord,
)

FULL_NEWTON = 6


@pytest.fixture(scope="module", params=["standing bull:8:1", "elliptic flat:6"])
def measured(request):
    if request.param == "standing bull:8:1":  # 5-axis under joint interpolation
        return standing_blade_job("bull:8:1", 0.03, 0.03)
    # round the thin edges of an elliptic blade, tip-linear (no machine)
    return planned(EllipticBladeSurface(), "flat:6", scallop_mm=0.05, chord_tol_mm=0.05,
                   axis_mode="lead-tilt", lead_deg=10.0)


def test_fewer_steps_than_the_full_method():
    assert DISC_CONTACT_NEWTON < FULL_NEWTON


def test_every_contact_same_as_the_full_search(measured):
    path, surface, cutter = measured.path, measured.surface, measured.cutter
    move = _cutting_moves(path)
    found = {n: _end_contacts(path, surface, cutter, measured.samples, move, 100_000, 4,
                              disc_newton=n) for n in (DISC_CONTACT_NEWTON, FULL_NEWTON)}
    fast, full = found[DISC_CONTACT_NEWTON], found[FULL_NEWTON]
    assert fast.gap.size > 500
    # (a foot within the convergence test of the full search's: gaps within 0.1 nm)
    np.testing.assert_allclose(fast.gap, full.gap, rtol=0.0, atol=1e-7)
    # (where the disc's lowest point is flat along its rim the foot may stand anywhere
    # along a stretch over which the gap changes by under 0.1 nm: feet within 1 um)
    np.testing.assert_allclose(fast.point, full.point, rtol=0.0, atol=1e-3)


def test_chord_same_as_the_full_search(measured):
    args = (measured.path, measured.surface, measured.cutter, measured.samples)
    fast = measured.chord  # (measured as plan_finishing does: the default steps)
    full = measure_chord(*args, machine=measured.machine, disc_newton=FULL_NEWTON)
    assert fast.n_moves == full.n_moves > 500
    for key in ("max_mm", "overcut_mm", "undercut_mm", "contact_mm"):
        assert getattr(fast, key) == pytest.approx(getattr(full, key), abs=1e-9), key
    assert fast.worst_point == full.worst_point
    np.testing.assert_allclose(fast.seeds_s, full.seeds_s, rtol=0.0, atol=1e-5)
