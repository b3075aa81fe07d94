"""The power-form (per-patch polynomial) evaluation equals scipy's B-spline evaluation."""

import numpy as np
import pytest
import scipy.interpolate

from toolpath.tensor_spline import PiecewiseCubic, TensorSpline

ORDERS = ((0, 0), (1, 0), (0, 1), (2, 0), (1, 1), (0, 2), (3, 0), (2, 2))


def _clamped(rng, n_inner):
    inner = np.sort(rng.random(n_inner))
    return np.r_[[0.0] * 4, inner, [1.0] * 4]


@pytest.mark.parametrize("seed", [0, 1])
def test_partials_equal_scipy_tensor_evaluation(seed):
    rng = np.random.default_rng(seed)
    knots_t, knots_s = _clamped(rng, 9), _clamped(rng, 5)
    # a double interior knot too: a C1 joint
    knots_t = np.sort(np.r_[knots_t, knots_t[6]])
    coef = rng.normal(size=(len(knots_t) - 4, len(knots_s) - 4, 3))
    # random points, every knot, both ends and a little outside (clamped to the domain)
    t = np.r_[rng.random(300), knots_t, -0.1, 1.2]
    s = np.r_[rng.random(300), rng.permutation(np.resize(knots_s, len(knots_t))), 1.3, -0.2]
    spline = TensorSpline(knots_t, knots_s, coef)
    got = spline.partials(t, s, ORDERS)
    tc, sc = np.clip(t, 0.0, 1.0), np.clip(s, 0.0, 1.0)
    for dt, ds in ORDERS:
        along_s = scipy.interpolate.BSpline(knots_s, np.eye(coef.shape[1]), 3)(sc, nu=ds)
        along_t = scipy.interpolate.BSpline(knots_t, np.eye(coef.shape[0]), 3)(tc, nu=dt)
        want = np.einsum("ni,nj,ijk->nk", along_t, along_s, coef)
        scale = np.abs(want).max()
        assert np.abs(got[dt, ds] - want).max() <= 1e-12 * scale, (dt, ds)


def test_curve_derivatives_equal_scipy():
    rng = np.random.default_rng(3)
    knots = _clamped(rng, 7)
    coef = rng.normal(size=(len(knots) - 4, 2))
    x = np.r_[rng.random(200), knots]
    curve = PiecewiseCubic(knots, coef)
    for nu in range(4):
        want = scipy.interpolate.BSpline(knots, coef, 3)(x, nu=nu)
        assert np.allclose(curve(x, nu), want, rtol=0.0, atol=1e-10 * np.abs(want).max())


def test_evaluation_across_chunks_matches_separate_calls():
    """More points than one chunk: each point's value as if evaluated on its own call."""
    from toolpath.tensor_spline import CHUNK

    rng = np.random.default_rng(4)
    knots = _clamped(rng, 6)
    spline = TensorSpline(knots, knots, rng.normal(size=(len(knots) - 4,) * 2 + (3,)))
    n, cut = CHUNK + 1000, 1000  # one call crossing a chunk's end; two that do not
    t, s = rng.random(n), rng.random(n)
    whole = spline.partial(t, s, 1, 1)
    parts = [spline.partial(t[:cut], s[:cut], 1, 1), spline.partial(t[cut:], s[cut:], 1, 1)]
    assert np.array_equal(whole, np.concatenate(parts))
