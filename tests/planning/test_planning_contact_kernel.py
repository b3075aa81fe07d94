"""The compiled window search picks the pieces the numpy search over the window picks.

:func:`toolpath.planning.contact_kernel.window_nearest` (the flat and bull-nose estimate's
contact poses) against the whole window in numpy: every candidate's foot on its segment,
candidates of another pass left out, the first of the nearest.
"""

import numpy as np

from toolpath.planning.contact_kernel import window_nearest


def _numpy_nearest(start, target, a, e, pass_of, window):
    shift = np.arange(-window, window + 1)
    cand = np.clip(start[:, None] + shift, 0, len(pass_of) - 1)
    near = target[:, None]
    f = np.clip(np.einsum("ijk,ijk->ij", near - a[cand], e[cand])
                / np.maximum(np.einsum("ijk,ijk->ij", e[cand], e[cand]), 1e-300), 0.0, 1.0)
    foot = a[cand] + f[..., None] * e[cand]
    dist = np.einsum("ijk,ijk->ij", near - foot, near - foot)
    dist[pass_of[cand] != pass_of[start, None]] = np.inf
    return np.take_along_axis(cand, np.argmin(dist, axis=1)[:, None], 1)[:, 0]


def test_window_nearest_equals_the_whole_window_in_numpy():
    rng = np.random.default_rng(30)
    # 40 passes of 30 pieces (some of no length), a wandering polyline each
    n_pass, per = 40, 30
    pass_of = np.repeat(np.arange(n_pass), per)
    steps = rng.normal(scale=0.3, size=(n_pass * per, 3))
    steps[rng.random(len(steps)) < 0.05] = 0.0
    a = np.cumsum(steps, axis=0)
    e = np.roll(a, -1, axis=0) - a
    e[(np.arange(len(a)) + 1) % per == 0] = 0.0
    m = 3000
    start = rng.integers(0, len(a), m)
    target = a[start] + rng.normal(scale=2.0, size=(m, 3))
    for window in (1, 4, 24):
        got = window_nearest(start, target, a, e, pass_of, window)
        np.testing.assert_array_equal(got, _numpy_nearest(start, target, a, e, pass_of,
                                                          window))
        assert (pass_of[got] == pass_of[start]).all()
        assert (got != start).mean() > 0.3  # (most rows move: the window is searched)
