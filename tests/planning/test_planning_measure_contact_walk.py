"""A contact pose's walk that had not stayed walks on (bull-nose, 5 axes).

Round the standing dev blade's leading edge a bull-nose with a lead turns round its
contact: the target the walk seeks (:func:`~toolpath.planning.cusp_estimates._contact_poses`)
moves with the axis of the piece it stands on, and after
:data:`~toolpath.planning.cusp_estimates.CONTACT_WALKS` windows some walks had not stayed:
their foot lay beyond their piece's end, no pose was found and the seed was ray cast. Those
walk on (:data:`~toolpath.planning.cusp_estimates.CONTACT_WALKS_ON`). The measure skips the
ray cast of a seed whose estimate stands below the largest cusp cast, so the estimates this
brings must not read below the ray cast (the full method, the oracle here), and the poses
must be where the walk stays.
"""

import numpy as np
import pytest
from measured_plans import standing_blade_job

import toolpath.planning.cusp_estimates as cusp_estimates
from toolpath.planning.cusp_search import CuspSearch, SearchSeeds

#: The ray cast's own tolerance: the estimates walking on brings read 1.030 times the cast
#: and up (84 of the 36,335 seeds' here; pose-section bounds).
LEAST_SHARE = 0.995


def _estimates(measured, walks_on):
    """The blade's estimates and the contact poses sought, walking on so far."""
    volume = measured.volume()
    seeds, others = SearchSeeds.of(measured.surface, measured.chord)
    sought = []
    contact_poses = cusp_estimates._contact_poses

    def spy(*args):
        sought.append((args, contact_poses(*args)))
        return sought[-1][1]

    with pytest.MonkeyPatch.context() as patch:
        patch.setattr(cusp_estimates, "CONTACT_WALKS_ON", walks_on)
        patch.setattr(cusp_estimates, "_contact_poses", spy)
        guess = cusp_estimates.torus_cusp_estimates(volume, measured.surface, seeds)
    return volume, seeds, others, guess, sought


@pytest.fixture(scope="module")
def walked():
    """The plan, and its estimates walking on and stopped (one plan for both tests)."""
    measured = standing_blade_job("bull:8:1", 0.03, 0.03)  # (the pose sections' job too)
    return (measured, _estimates(measured, cusp_estimates.CONTACT_WALKS_ON),
            _estimates(measured, cusp_estimates.CONTACT_WALKS))


def test_walking_on_brings_estimates_that_never_read_below_the_ray_cast(walked):
    measured, (volume, seeds, others, guess, _), (*_, stopped, _) = walked
    # walking on only finds poses the first windows left unfound: no other estimate moves
    before = np.isfinite(stopped)
    np.testing.assert_array_equal(guess[before], stopped[before])
    new = np.isnan(stopped) & np.isfinite(guess)
    assert new.sum() >= 40  # (84 here)
    search = CuspSearch(volume, measured.surface, seeds, others, 1.0, 20_000)
    search.run(new)
    h = search.height[new]
    assert not np.isinf(h).any()  # (no seed above the horizon read as a cusp)
    cusp = np.isfinite(h) & (h > 0.0)
    assert cusp.any()
    ratio = guess[new][cusp] / h[cusp]
    assert ratio.min() >= LEAST_SHARE, np.sort(ratio)[:5]


def test_the_poses_walking_on_finds_are_where_the_walk_stays(walked, monkeypatch):
    _, (volume, _, _, _, sought), _ = walked
    assert sought
    late = 0
    for (_, piece, corner, normal), (_, _, best, found) in sought:
        with monkeypatch.context() as patch:
            patch.setattr(cusp_estimates, "CONTACT_WALKS_ON", cusp_estimates.CONTACT_WALKS)
            *_, found_stopped = cusp_estimates._contact_poses(volume, piece, corner, normal)
        rows = np.flatnonzero(found & ~found_stopped)
        late += rows.size
        # one more window about the piece found, with its own axis's target: it stays
        edge = np.zeros(len(piece), dtype=bool)
        moved = cusp_estimates._walk_to_contact(volume, best.copy(), edge, rows, corner,
                                                normal, 1)
        assert not moved.size, moved
        # and each foot lies across its piece (not beyond a pass's end or bend)
        *_, across = cusp_estimates._pose_at_contact(volume, best[rows], corner[rows],
                                                     normal[rows])
        assert across.all(), rows[~across]
    assert late >= 40
