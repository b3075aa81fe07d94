"""The ray casts' candidate pieces met a run of rays at a time (memory), with the same casts.

On a 5-axis flat:6 job on the bundled propeller under trunnion-ac's joint interpolation a
chunk of 20,000 brackets met 104 million (ray, piece) candidates at once, 7.5 GB at the
peak: :func:`~toolpath.planning.cusp_search._bracket_pieces` now meets and filters them
:data:`~toolpath.planning.cusp_search.BRACKET_PAIRS_BATCH` at a time, and the search casts
fewer seeds at a time where their brackets keep many pieces
(:data:`~toolpath.planning.cusp_search.KEPT_PAIRS_CHUNK`; head-table-bc's job: 7.1 GB).
"""

import numpy as np
import pytest
from measured_plans import planned

import toolpath.planning.cusp_search as cusp_search
from machines import load_machine
from toolpath.planning import SpherePatch
from toolpath.planning.clearance_kernel import bin_samples, pair_batches, pairs_within
from toolpath.planning.cusp_search import CuspSearch, SearchSeeds
from toolpath.planning.cut_volume import CutVolume


@pytest.mark.parametrize("most_pairs", [1, 40, 1000, 10**9])
def test_pair_batches_are_pairs_within_a_run_of_queries_at_a_time(most_pairs):
    rng = np.random.default_rng(7)
    points = rng.uniform(-5.0, 5.0, size=(3000, 3))
    queries = rng.uniform(-6.0, 6.0, size=(300, 3))
    cells = bin_samples(points, 1.0)
    owner, item = pairs_within(cells, queries, 1.5)
    batches = list(pair_batches(cells, queries, 1.5, most_pairs))
    assert np.array_equal(np.concatenate([o for o, _ in batches]), owner)
    assert np.array_equal(np.concatenate([i for _, i in batches]), item)
    for o, _ in batches:  # runs of consecutive queries, at most most_pairs but one alone
        assert len(o) <= most_pairs or np.unique(o).size == 1
    counts = np.bincount(owner, minlength=len(queries))
    assert counts.max() > 40  # (40: some queries alone in their run)
    if most_pairs == 10**9:
        assert len(batches) == 1


@pytest.fixture(scope="module")
def flat_five_axis():
    cap = SpherePatch(radius_mm=50.0, longitude_deg=(-8.0, 8.0), colatitude_deg=(15.0, 25.0))
    return planned(cap, "flat:6", scallop_mm=0.01, chord_tol_mm=0.01, axis_mode="lead-tilt",
                   lead_deg=10.0, machine=load_machine("trunnion-ac"))


def _casts(measured) -> CuspSearch:
    """Every seed of the plan ray cast."""
    seeds, others = SearchSeeds.of(measured.surface, measured.chord)
    search = CuspSearch(measured.volume(), measured.surface, seeds, others, 1.0, 20_000)
    search.run(np.ones(len(seeds.t), dtype=bool))
    return search


def test_casts_in_small_pair_batches_read_as_in_one(flat_five_axis, monkeypatch):
    measured = flat_five_axis
    runs = []
    batches = CutVolume.pair_batches

    def counted(self, *args):
        for batch in batches(self, *args):
            runs.append(len(batch[0]))
            yield batch

    monkeypatch.setattr(CutVolume, "pair_batches", counted)
    whole = _casts(measured)
    assert len(runs) == 1
    runs.clear()
    monkeypatch.setattr(cusp_search, "BRACKET_PAIRS_BATCH", 4_000)
    batched = _casts(measured)
    assert len(runs) > 5 and max(runs) <= 4_000
    assert np.isfinite(whole.height).sum() > 100
    np.testing.assert_array_equal(batched.height, whole.height)
    np.testing.assert_array_equal(batched.s, whole.s)


def test_seeds_cast_fewer_at_a_time_where_their_brackets_meet_many_pieces(flat_five_axis,
                                                                         monkeypatch):
    measured = flat_five_axis
    sizes = []
    cusps = cusp_search._cusps

    def counted(volume, surface, t, *args):
        sizes.append(len(t))
        return cusps(volume, surface, t, *args)

    monkeypatch.setattr(cusp_search, "_cusps", counted)
    whole = _casts(measured)
    assert sizes[0] <= cusp_search.FIRST_CHUNK and len(sizes) <= 2  # (a few pieces a seed)
    cast = sum(sizes)
    sizes.clear()
    # about 15 seeds' pieces a batch after the first of 10 seeds (about 170 a seed)
    monkeypatch.setattr(cusp_search, "FIRST_CHUNK", 10)
    monkeypatch.setattr(cusp_search, "KEPT_PAIRS_CHUNK", 15 * 170)
    few = _casts(measured)
    assert len(sizes) > 10 and sizes[0] == 10 and len(set(sizes)) > 2 and sum(sizes) == cast
    np.testing.assert_array_equal(few.height, whole.height)
    np.testing.assert_array_equal(few.s, whole.s)
    np.testing.assert_array_equal(few.bracket_s, whole.bracket_s)
