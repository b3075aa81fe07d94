"""The ray cast's shortcuts against the full method, seed by seed.

The cusp search (:class:`~toolpath.planning.cusp_search.CuspSearch`) seeks each bracket's
pieces within its own reach, brackets of like reach together
(:func:`~toolpath.planning.cusp_search._reach_groups`): the same cusps as one search of
every bracket within the longest one's reach, where the passes end (brackets of the
default gap, longer than the others) and elsewhere.
"""

import numpy as np
import pytest
from measured_plans import planned

from toolpath import fit_streamline_surface
from toolpath.paper_examples import bundled_data_path
from toolpath.planning import cusp_search
from toolpath.planning.cusp_search import CuspSearch, SearchSeeds
from toolpath.planning.setup import centred_on_table, rotation_from_spec


@pytest.fixture(scope="module")
def lying():
    rows = np.loadtxt(bundled_data_path("dev_blade_15x142.csv"), delimiter=",", skiprows=1)
    sections = rows[:, 1:].reshape(15, 142, 3)[::2]  # every other section: a shorter fit
    blade = fit_streamline_surface(sections, tol=0.01, closed=False)
    return centred_on_table(blade, rotation_from_spec("x:90"), base_height_mm=0.0)


def _cast_all(measured, spread):
    """Every seed ray cast, brackets sought in groups of reach within ``spread``."""
    volume = measured.volume()
    seeds, others = SearchSeeds.of(measured.surface, measured.chord)
    search = CuspSearch(volume, measured.surface, seeds, others, 1.0, 20_000)
    keep = cusp_search.REACH_SPREAD
    cusp_search.REACH_SPREAD = spread
    try:
        search.run(np.ones(len(seeds.t), dtype=bool))
    finally:
        cusp_search.REACH_SPREAD = keep
    return search


@pytest.mark.parametrize(("cutter", "scallop_mm"), [("ball:6", 0.01), ("bull:8:1", 0.03)])
def test_brackets_sought_by_their_own_reach_find_the_cusps_of_the_longest_reach(
        lying, cutter, scallop_mm):
    # 3 axes on the lying blade: passes end at the lowest reachable point, where a seed's
    # bracket runs over the default gap (1 mm here) rather than 2.5 times the spacing
    measured = planned(lying, cutter, scallop_mm=scallop_mm, chord_tol_mm=0.02,
                       axis_mode="3")
    grouped = _cast_all(measured, cusp_search.REACH_SPREAD)
    one = _cast_all(measured, np.inf)  # (one group: every bracket within the longest reach)
    reach = one.bracket_s - one.seeds.s  # (in s: the brackets' lengths differ several fold)
    assert np.nanmax(reach) > 2.0 * np.nanmedian(reach)
    found = np.isfinite(one.height)
    assert found.sum() > 500
    np.testing.assert_array_equal(grouped.height, one.height)
    np.testing.assert_array_equal(grouped.s, one.s)
