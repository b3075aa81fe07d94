"""Issue 27: a shank piece meeting the cutter end it starts at is no collision.

A shank piece starts at the ball centre, so at its instance it holds the ball that the
merged ball pieces approximate from inside (by up to the replay and merge tolerances). On
a bowl the ball-centre chords stand above the path, and the collision search's shank ends
find a little less material than the near search: within those tolerances the same
contact, whose neighbourhood need not be searched again. The full method (every such
sample taken as a miss, its neighbourhood searched again with every piece) must give the
same map to within those tolerances, the same scallop and gouge.
"""

import numpy as np
import pytest
from verify_programs import five_axis_cap

import verification.verify as verify_module
from machines import load_machine
from toolpath.planning.analytic import SpherePatch
from verification import VerifyOptions, verify_program
from verification.search import Dexels


class _EveryMiss(Dexels):
    """The searches with no tolerance: any shank piece lower than the near search is a miss."""

    def __init__(self, *args, **kwargs):
        kwargs["model_tol_mm"] = 0.0
        super().__init__(*args, **kwargs)


def test_shank_ends_on_a_bowl_match_the_full_collision_search(monkeypatch, ball6):
    radius = 30.0
    bowl = SpherePatch(radius_mm=radius, longitude_deg=(-20.0, 20.0),
                       colatitude_deg=(145.0, 155.0), inside=True)
    machine = load_machine("trunnion-ac")
    program = five_axis_cap(machine, ball6, radius, inside=True,
                            colatitudes_deg=np.arange(143.0, 157.0, np.degrees(0.4 / radius)))
    options = VerifyOptions(scallop_mm=0.005, collision_spacing_mm=0.5)
    fast = verify_program(program, bowl, machine, ball6, options=options)
    with monkeypatch.context() as m:
        m.setattr(verify_module, "Dexels", _EveryMiss)
        full = verify_program(program, bowl, machine, ball6, options=options)
    assert fast.pairs < full.pairs / 2  # the shank ends were taken as the near contact
    tol = options.replay_tol_mm + options.merge_tol_mm
    a, b = fast.deviation_map.deviation_mm, full.deviation_map.deviation_mm
    assert np.array_equal(np.isfinite(a), np.isfinite(b))
    finite = np.isfinite(a)
    assert np.abs(a[finite] - b[finite]).max() <= tol
    assert (fast.deviation_map.block_index == full.deviation_map.block_index).mean() > 0.99
    assert fast.max_scallop_mm == pytest.approx(full.max_scallop_mm, abs=tol)
    assert fast.max_gouge_mm == pytest.approx(full.max_gouge_mm, abs=tol)
