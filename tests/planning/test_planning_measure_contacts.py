"""The chord measurement's ball contacts, seeded along runs, against the full method.

``measure_chord`` searches a ball's contact from the nearest surface sample at every
``contact_stride``-th location along a run of cutting moves and seeds the locations
between from those contacts; ``contact_stride=1`` seeds every location from its own
nearest sample (the full method, the oracle here). Both must find the same feet: the same
gaps, the same cusp seeds.
"""

import numpy as np
import pytest
from measured_plans import planned

import toolpath.planning.measure as measure
from toolpath.planning import EllipticBladeSurface, SpherePatch

#: Feet found from either seed agree to within the Newton search's convergence (its last
#: step moves a foot by under a micrometre; the next by far less): mm and parameter.
SAME_GAP_MM = 1e-9
SAME_PARAMETER = 1e-7


def _chord_inputs(surface, cutter, **options):
    """What the plan's measure stage gives ``measure_chord`` (:mod:`measured_plans`)."""
    measured = planned(surface, cutter, **options)
    args = (measured.path, measured.surface, measured.cutter, measured.samples)
    return args, {"machine": measured.machine}


def _same_contacts(args, kwargs):
    fast = measure.measure_chord(*args, **kwargs)
    full = measure.measure_chord(*args, **kwargs, contact_stride=1)
    assert full.n_moves == fast.n_moves > 100
    for name in ("max_mm", "overcut_mm", "undercut_mm", "contact_mm"):
        assert getattr(fast, name) == pytest.approx(getattr(full, name), abs=SAME_GAP_MM)
    assert np.array_equal(fast.seeds_pass, full.seeds_pass)
    assert np.abs(fast.seeds_t - full.seeds_t).max() < SAME_PARAMETER
    assert np.abs(fast.seeds_s - full.seeds_s).max() < SAME_PARAMETER
    assert full.max_mm > 0.0


@pytest.mark.parametrize("axis", [{"axis_mode": "3"},
                                  {"axis_mode": "lead-tilt", "lead_deg": 10.0}])
def test_sphere_cap_contacts_match_the_full_method(axis):
    cap = SpherePatch(radius_mm=50.0, longitude_deg=(-20.0, 20.0), colatitude_deg=(15.0, 40.0))
    _same_contacts(*_chord_inputs(cap, "ball:6", scallop_mm=0.02,
                                  chord_tol_mm=0.01, **axis))


def test_closed_blade_spiral_across_the_seam():
    # one spiral round closed sections: runs cross the seam, where t wraps
    blade = EllipticBladeSurface()
    assert blade.closed_t
    _same_contacts(*_chord_inputs(blade, "ball:6", scallop_mm=0.05,
                                  chord_tol_mm=0.02, axis_mode="lead-tilt", lead_deg=10.0,
                                  linking="spiral"))


def test_flat_and_bull_nose_contacts_keep_their_own_seeds():
    # a guard of the policy, not of a computation: only a ball's contacts are seeded from
    # the anchors' (a flat or bull-nose cutter's disc search and re-seed check keep a
    # sample of their own for every location)
    cap = SpherePatch(radius_mm=50.0, longitude_deg=(-10.0, 10.0), colatitude_deg=(20.0, 30.0))
    args, kwargs = _chord_inputs(cap, "bull:8:1", scallop_mm=0.05,
                                 chord_tol_mm=0.02)
    fast = measure.measure_chord(*args, **kwargs)
    full = measure.measure_chord(*args, **kwargs, contact_stride=1)
    for name in ("max_mm", "overcut_mm", "undercut_mm", "contact_mm", "worst_point"):
        assert getattr(fast, name) == getattr(full, name)
    for name in ("seeds_t", "seeds_s", "seeds_pass"):
        assert np.array_equal(getattr(fast, name), getattr(full, name))
