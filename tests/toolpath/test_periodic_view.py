"""Knots of a closed fit's cut-open view map back onto the loop without rounding past a sample."""

import numpy as np

from toolpath.periodic import view_knots_on_loop


def _cut_view(loop_t: np.ndarray, k: int) -> tuple[np.ndarray, np.ndarray, float]:
    """The view of samples ``loop_t`` (seam excluded) cut open at sample ``k``, as the
    closed-fit driver builds it: view parameters, each one's loop parameter, the cut."""
    n = loop_t.size
    cut_t = float(loop_t[k])
    view_t = np.r_[loop_t[k:n] - cut_t, loop_t[0:k] + 1.0 - cut_t, 1.0]
    return view_t, loop_t[np.r_[k:n, 0:k, k]], cut_t


def test_a_knot_on_a_view_sample_maps_to_that_samples_own_parameter():
    loop_t = np.linspace(0.0, 1.0, 41)[:-1]
    view_t, view_loop_t, cut_t = _cut_view(loop_t, 2)
    knots = view_t[1:-1]
    # the plain sum rounds: some samples come back past themselves (IEEE arithmetic, so on
    # every machine), which is what the mapping is there for
    plain = np.mod(knots + cut_t, 1.0)
    assert np.any(plain != view_loop_t[1:-1])
    mapped = view_knots_on_loop(knots, view_t, view_loop_t, cut_t)
    assert np.array_equal(mapped, view_loop_t[1:-1])


def test_a_knot_between_samples_maps_by_the_cut():
    loop_t = np.sort(np.random.default_rng(3).uniform(0.0, 1.0, 30))
    loop_t[0] = 0.0
    view_t, view_loop_t, cut_t = _cut_view(loop_t, 11)
    between = 0.5 * (view_t[:-1] + view_t[1:])
    mapped = view_knots_on_loop(between, view_t, view_loop_t, cut_t)
    assert np.array_equal(mapped, np.mod(between + cut_t, 1.0))
    # each stays strictly between the loop parameters of the samples either side
    lower, upper = view_loop_t[:-1], view_loop_t[1:]
    wraps = upper < lower  # the span across the loop's own seam
    inside = np.where(wraps, (mapped > lower) | (mapped < upper),
                      (mapped > lower) & (mapped < upper))
    assert inside.all()
