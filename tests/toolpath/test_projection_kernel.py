"""The projection's Newton step and seam rule against numpy twins written from their docs."""

import numpy as np

from toolpath.projection_kernel import (
    DEGENERATE_SHARE,
    STEP_CLIP,
    halve_rows,
    newton_step_rows,
    no_farther,
    seam_corner,
    seam_lerp_rows,
    wrap_t,
)
from toolpath.tolerances import TINY


def _numpy_step(fr, p, t, s, closed):
    """The damped Newton step of the module docstring, on rows, in numpy (the oracle)."""
    x, xt, xs, xtt, xts, xss = fr
    d = x - p
    dot = lambda a, b: np.einsum("ij,ij->i", a, b)  # noqa: E731
    e, f, g = dot(xt, xt), dot(xt, xs), dot(xs, xs)
    h11, h12, h22 = e + dot(d, xtt), f + dot(d, xts), g + dot(d, xss)
    bad = (h11 * h22 - h12 * h12 <= DEGENERATE_SHARE * (e * g + TINY)) | (h11 <= 0.0)
    h11, h12, h22 = np.where(bad, e, h11), np.where(bad, f, h12), np.where(bad, g, h22)
    det = np.maximum(h11 * h22 - h12 * h12, TINY)
    g1, g2 = dot(d, xt), dot(d, xs)
    step_t = np.clip((h22 * g1 - h12 * g2) / det, -STEP_CLIP, STEP_CLIP)
    step_s = np.clip((h11 * g2 - h12 * g1) / det, -STEP_CLIP, STEP_CLIP)
    new_t = np.mod(t - step_t, 1.0) if closed else np.clip(t - step_t, 0.0, 1.0)
    return step_t, step_s, dot(d, d), new_t, np.clip(s - step_s, 0.0, 1.0)


def test_newton_step_is_the_documented_step():
    rng = np.random.default_rng(0)
    n = 2000
    fr = rng.normal(size=(6, n, 3))
    fr[3:] *= rng.choice([0.01, 1.0, 30.0], size=(1, n, 1))  # convex, mild, indefinite
    fr[1, :7] = 0.0  # degenerate tangents: the Gauss-Newton matrix, a finite step
    p = rng.normal(size=(n, 3))
    t, s = rng.random(n), rng.random(n)
    for closed in (False, True):
        got = tuple(np.empty(n) for _ in range(5))
        newton_step_rows(fr, p, t, s, closed, *got)
        want = _numpy_step(fr, p, t, s, closed)
        for a, b in zip(got, want, strict=True):
            np.testing.assert_allclose(a, b, rtol=1e-9, atol=1e-12)
        assert np.isfinite(got[0]).all() and (np.abs(got[0]) <= STEP_CLIP).all()
        assert (np.abs(got[0]) == STEP_CLIP).any()  # some steps were clipped
        assert got[3].min() >= 0.0 and got[3].max() <= 1.0


def test_halving_keeps_the_trial_in_the_domain():
    t, s = np.array([0.1, 0.95, 0.5]), np.array([0.0, 1.0, 0.5])
    step_t, step_s = np.array([0.2, -0.2, 0.1]), np.array([0.1, -0.1, 0.1])
    new_t, new_s = np.zeros(3), np.zeros(3)
    halve_rows(np.array([0, 1]), t, s, True, step_t, step_s, new_t, new_s)
    np.testing.assert_allclose(new_t[:2], [0.0, 0.05], atol=1e-12)  # 0.95 + 0.1 wraps
    np.testing.assert_allclose(new_s[:2], [0.0, 1.0])  # clipped
    assert new_t[2] == 0.0 and step_t[2] == 0.1  # row 2 not halved


def test_no_farther_allows_round_off_only():
    assert no_farther(1.0 + 1e-13, 1.0)
    assert not no_farther(1.0 + 1e-9, 1.0)
    np.testing.assert_array_equal(no_farther(np.array([0.5, 2.0]), np.array([1.0, 1.0])),
                                  [True, False])


def test_seam_rule_goes_the_short_way_round():
    ta, tb = np.array([0.95, 0.05, 0.2]), np.array([0.05, 0.95, 0.6])
    u = np.array([[0.25, 0.75], [0.25, 0.6], [0.5, 1.0]])
    closed = seam_lerp_rows(ta, tb, u, True)
    np.testing.assert_allclose(closed, [[0.975, 0.025], [0.025, 0.99], [0.4, 0.6]], atol=1e-12)
    open_ = seam_lerp_rows(ta, tb, u, False)
    np.testing.assert_allclose(open_, ta[:, None] * (1.0 - u) + tb[:, None] * u)
    np.testing.assert_allclose([wrap_t(t, True) for t in (-0.25, 1.25, 0.5)], [0.75, 0.25, 0.5])
    np.testing.assert_allclose([wrap_t(t, False) for t in (-0.25, 1.25, 0.5)], [0.0, 1.0, 0.5])


def test_seam_lerp_rows_in_numpy_are_the_compiled_rule_bit_for_bit():
    # seam_lerp_rows runs seam_lerp's own source on arrays; the kernels compile it: the
    # same numbers, across the seam, at differences of exactly 0.5 and where the fold
    # reads 1 (a tiny negative t)
    import numba

    from toolpath.projection_kernel import seam_lerp

    @numba.njit
    def compiled_rows(ta, tb, u, closed):
        out = np.empty(u.shape)
        for j in range(u.shape[0]):
            for q in range(u.shape[1]):
                out[j, q] = seam_lerp(ta[j], tb[j], u[j, q], closed)
        return out

    rng = np.random.default_rng(3)
    ta, tb = rng.random(4000), rng.random(4000)
    ta[:3], tb[:3] = [0.25, 0.75, 0.0], [0.75, 0.25, 1.0 - 1e-17]
    ta[3], tb[3] = 1e-17, 0.9  # (t just below 0 near u = 1/9: folds to 1.0 - 1e-17)
    u = rng.random((4000, 3))
    for closed in (True, False):
        np.testing.assert_array_equal(seam_lerp_rows(ta, tb, u, closed),
                                      compiled_rows(ta, tb, u, closed))


def test_seam_corner_takes_the_corner_where_no_farther_signed_by_both_normals():
    # a knife edge at the origin: the part |y| < -x, outward normals 90 deg apart
    n_before, n_after = np.array([1.0, 1.0, 0.0]) / 2**0.5, np.array([1.0, -1.0, 0.0]) / 2**0.5
    corner = np.zeros(3)
    beside = np.array([-0.01, 0.01, 0.0])  # a stalled foot on the upper face
    outside = np.array([2.0, 0.3, 0.0])  # in the normals' cone: outside, the corner nearest
    assert seam_corner(outside, beside, corner, n_before, n_after) == (
        True, np.linalg.norm(outside))
    inside = np.array([-0.5, 0.0, 0.0])  # between the faces: inside
    taken, signed = seam_corner(inside, np.array([-0.25, 0.25, 0.0]), corner, n_before, n_after)
    assert not taken  # the foot on a face is nearer (0.35 < 0.5)
    taken, signed = seam_corner(inside, np.array([-0.5, 0.5, 0.0]), corner, n_before, n_after)
    assert taken and signed == -0.5  # a worse foot: the corner, inside
