"""The compiled streamline kernels against independent evaluations and the numpy search."""

import math

import numpy as np
import pytest
import scipy.interpolate

import toolpath
from toolpath import fit_streamline_surface
from toolpath.compiled import MOVES_CHUNK, ORDERS
from toolpath.paper_examples import bundled_data_path
from toolpath.planning.local import project_to_surface, signed_distance_near
from toolpath.planning.setup import PlacedSurface, rotation_from_spec
from toolpath.surface import ParametricSurface


@pytest.fixture(scope="module")
def blade():
    sections = toolpath.read_sections(bundled_data_path("dev_blade_15x142.csv"))
    return fit_streamline_surface(sections, tol=0.01)


def _eq25_partials(surface, t, s):
    """Eq. 25 and its partials from scipy's B-splines (module docstring of the surface)."""
    coef = surface.tensor.coef
    g = {o: scipy.interpolate.NdBSpline((surface.knots_t, surface.knots_s), coef, 3)(
        np.c_[t, s], nu=o) for o in ORDERS}
    x0 = scipy.interpolate.BSpline(surface.knots_s, surface.row_coef[:, -3:], 3)
    z0 = (x0(s) + surface.c) @ surface.T.T
    z1, z2 = x0(s, 1) @ surface.T.T, x0(s, 2) @ surface.T.T
    e = np.exp(g[0, 0])
    w = z0 * e
    w_s = e * (z1 + z0 * g[0, 1])
    ws = {(0, 0): w, (1, 0): w * g[1, 0], (0, 1): w_s, (2, 0): w * (g[2, 0] + g[1, 0] ** 2),
          (1, 1): w_s * g[1, 0] + w * g[1, 1],
          (0, 2): e * (z2 + 2.0 * z1 * g[0, 1] + z0 * (g[0, 2] + g[0, 1] ** 2))}
    t_inv = np.linalg.inv(surface.T)
    return {o: v @ t_inv.T - (surface.c if o == (0, 0) else 0.0) for o, v in ws.items()}


@pytest.mark.parametrize("closed", [False, True])
def test_compiled_partials_equal_eq25_from_scipy(blade, closed_sections, closed):
    surface = fit_streamline_surface(closed_sections, tol=0.01) if closed else blade
    rng = np.random.default_rng(3)
    t, s = np.r_[rng.random(500), 0.0, 1.0, 1.0], np.r_[rng.random(500), 0.0, 1.0, 0.0]
    got = surface.kernel().partials(t, s, ORDERS)
    want = _eq25_partials(surface, t, s)
    for order in ORDERS:
        # round-off: near the leading edge X_ts is a difference of terms ~G_t large
        scale = np.abs(want[order]).max()
        assert np.abs(got[order] - want[order]).max() <= 1e-10 * scale, order


def test_placed_kernel_is_the_rotated_and_shifted_surface(blade):
    rotation = rotation_from_spec("y:-90,z:30")
    placed = PlacedSurface(PlacedSurface(blade, rotation, (1.0, 2.0, 3.0)),
                           rotation_from_spec("x:90"), (0.0, -5.0, 7.0))
    rng = np.random.default_rng(4)
    t, s = rng.random(200), rng.random(200)
    outer = rotation_from_spec("x:90")
    x = blade(t, s) @ rotation.T + [1.0, 2.0, 3.0]
    want = x @ outer.T + [0.0, -5.0, 7.0]
    assert np.allclose(placed(t, s), want, rtol=0, atol=1e-10)
    want_t = blade.derivative(t, s, dt=1) @ rotation.T @ outer.T
    assert np.allclose(placed.derivative(t, s, dt=1), want_t, rtol=0, atol=1e-10)


class _NumpyOnly(ParametricSurface):
    """The same surface with its kernel hidden, for the numpy Newton search.

    Its points still come from the base surface's own (compiled) partials.
    """

    def __init__(self, base):
        self.base, self.closed_t, self.orientation = base, base.closed_t, base.orientation

    def _partials(self, t, s, dt, ds):
        return self.base._partials(t, s, dt, ds)


@pytest.mark.parametrize("iterations", [0, 1, 3])
def test_compiled_projection_takes_the_numpy_steps(blade, iterations):
    placed = PlacedSurface(blade, rotation_from_spec("y:-90"), (0.0, 0.0, 20.0))
    rng = np.random.default_rng(5)
    n = 3000
    t, s = rng.random(n), rng.random(n)
    height = rng.uniform(0.0, 1.5, n)  # outward along the normal: the foot is (t, s)
    points = placed(t, s) + height[:, None] * placed.normal(t, s)
    t0, s0 = np.clip(t + rng.normal(scale=0.003, size=n), 0, 1), np.clip(s + 0.02, 0, 1)
    got = project_to_surface(placed, points, t0, s0, iterations=iterations)
    want = project_to_surface(_NumpyOnly(placed), points, t0, s0, iterations=iterations)
    assert np.allclose(got[0], want[0], rtol=0, atol=1e-7)
    assert np.allclose(got[1], want[1], rtol=0, atol=1e-7)
    assert np.allclose(got[2], want[2], rtol=0, atol=1e-8)
    # signed along the outward normal at the foot, from the fused kernel as from numpy
    signed = signed_distance_near(placed, points, t0, s0, iterations=iterations)
    numpy_signed = signed_distance_near(_NumpyOnly(placed), points, t0, s0,
                                        iterations=iterations)
    assert np.allclose(signed[0], numpy_signed[0], rtol=0, atol=1e-8)
    assert np.allclose(signed[1:], numpy_signed[1:], rtol=0, atol=1e-7)
    # from (almost) the foot the last step is too small to check: its signed distance
    # comes from the partials at the start (second order), as exact as an evaluation
    near_t, near_s = np.clip(t + 5e-7, 0, 1), s
    fast = signed_distance_near(placed, points, near_t, near_s, iterations=max(iterations, 1))
    slow = signed_distance_near(_NumpyOnly(placed), points, near_t, near_s,
                                iterations=max(iterations, 1))
    assert np.allclose(fast[0], slow[0], rtol=0, atol=1e-9)
    if iterations == 3:  # and it did find the closest points: the offset comes back
        assert np.quantile(np.abs(got[2] - height), 0.99) < 1e-6
        assert np.quantile(np.abs(signed[0] - height), 0.99) < 1e-6
        inside = signed_distance_near(placed, placed(t, s) - 0.01 * placed.normal(t, s),
                                      t, s, iterations=iterations)[0]
        assert np.allclose(inside, -0.01, rtol=0, atol=1e-6)


@pytest.mark.parametrize("closed", [False, True])
def test_ball_move_gaps_in_one_compiled_pass_equal_the_gathered_moves(blade, closed_sections,
                                                                      closed):
    # the chord check's compiled path (the moves' points made in a kernel, projected by the
    # points' search) gives the very numbers of move_gaps on the gathered ends, across a
    # closed seam too
    from toolpath.planning.cutters import parse_cutter
    from toolpath.planning.sampling import MoveEnds, move_gaps, point_move_gaps

    surface = fit_streamline_surface(closed_sections, tol=0.01) if closed else blade
    placed = PlacedSurface(surface, rotation_from_spec("y:-90"), (0.0, 0.0, 20.0))
    cutter = parse_cutter("ball:6")
    rng = np.random.default_rng(8)
    n = 400
    t = np.sort(rng.random(n))
    if closed:
        t[1] = 0.999  # moves across the seam, both ways
    s = np.full(n, 0.4) + 0.01 * rng.random(n)
    normal = placed.normal(t, s)
    axes = normal + rng.normal(scale=0.1, size=(n, 3))
    axes /= np.linalg.norm(axes, axis=1, keepdims=True)
    tips = placed(t, s) + 3.0 * normal - 3.0 * axes + rng.normal(scale=0.01, size=(n, 3))
    first = np.arange(n - 1)
    fractions = np.array([0.25, 0.5, 0.75])
    fused = point_move_gaps(placed, cutter, tips, axes, t, s, first, fractions, newton=1)
    ends = MoveEnds(tips[first], tips[first + 1], axes[first], axes[first + 1], t[first],
                    t[first + 1], s[first], s[first + 1])
    gathered = move_gaps(placed, cutter, ends, fractions, newton=1)
    for got, want in zip(fused, gathered, strict=True):
        np.testing.assert_array_equal(got, want)
    # the moves' own fractions (one each), the default Newton steps
    own = rng.random((n - 1, 1))
    fused = point_move_gaps(placed, cutter, tips, axes, t, s, first, own)
    gathered = move_gaps(placed, cutter, ends, own)
    np.testing.assert_array_equal(fused[0], gathered[0])
    # more moves than one batch of points holds: every batch the same numbers
    many = np.resize(first, MOVES_CHUNK + 5)
    batched = point_move_gaps(placed, cutter, tips, axes, t, s, many, fractions, newton=1)
    once = point_move_gaps(placed, cutter, tips, axes, t, s, first, fractions, newton=1)
    for got, want in zip(batched, once, strict=True):
        np.testing.assert_array_equal(got, np.resize(want, (len(many), len(fractions))))


def _sharp_te_sections(thickness=0.12):
    """Closed NACA-like sections whose sharp TE is point 0 (at 12 % thick normals 109 deg apart)."""
    n = 80
    beta = np.linspace(0.0, 2 * np.pi, n, endpoint=False)
    x = 0.5 * (1.0 + np.cos(beta))  # 1 at the TE (point 0), 0 at the LE
    half = 2.5 * thickness * (2.969 * np.sqrt(x) - 1.26 * x - 3.516 * x**2 + 2.843 * x**3
                              - 1.036 * x**4)
    y = np.where(beta < np.pi, 1.0, -1.0) * half
    out = []
    for j, h in enumerate(np.linspace(0.0, 1.0, 5)):
        chord, twist = 40.0 - 8.0 * h, 0.3 * h
        c, s = np.cos(twist), np.sin(twist)
        out.append(np.c_[chord * (c * x - s * y), chord * (s * x + c * y), np.full(n, 15.0 * j)])
    return np.stack(out)


def test_signed_distance_beside_a_sharp_seam_corner_is_its_distance():
    """A ball resting on a sharp TE at the seam stands clear, searched from either side.

    With the normal of one side only, ``(p - X) . n`` read it as cut into the part (a
    prop blade's plan measured a 6 mm chord error there).
    """
    surface = fit_streamline_surface(toolpath.as_sections(_sharp_te_sections(), closed=True),
                                     tol=0.01)
    s = np.array([0.2, 0.5, 0.8])
    x, n_after = surface.points_and_normals(np.zeros(3), s)
    n_before = surface.points_and_normals(np.full(3, 1.0 - 1e-12), s)[1]
    assert (np.einsum("ij,ij->i", n_before, n_after) < 0.0).all()  # a corner, > 90 deg
    bisector = (n_before + n_after) / np.linalg.norm(n_before + n_after, axis=1)[:, None]
    for t0 in (0.0, 1.0 - 1e-9, 0.999, 0.001):
        seeds = np.full(3, t0)
        for surf in (surface, _NumpyOnly(surface)):
            outside = signed_distance_near(surf, x + 3.0 * bisector, seeds, s, iterations=6)
            assert np.allclose(outside[0], 3.0, rtol=0, atol=1e-3)  # (s stalls by ~1e-4)
            inside = signed_distance_near(surf, x - 0.05 * bisector, seeds, s, iterations=6)
            assert (inside[0] < 0.0).all()


def _brute_signed(surface, p, s_hint):
    """Signed distance of ``p`` by brute force: the nearest of a dense sampling, zoomed in.

    Each face beside the seam (``t`` up to 0.15 either side of it, never across) is sampled
    on a 41 x 41 grid, then on finer grids round its best sample, five times; the nearer
    face's best sample is the foot. Inside or outside by the winding number of ``p`` round
    the dense section through the foot (``s`` there; these sections lie in planes
    ``z = const``: in ``x, y``).
    """
    best = (np.inf, 0.0)
    for lo, hi in ((0.0, 0.15), (0.85, 1.0 - 1e-12)):
        t_lo, t_hi, s_lo, s_hi = lo, hi, max(s_hint - 0.05, 0.0), min(s_hint + 0.05, 1.0)
        for _ in range(6):
            tt, ss = np.meshgrid(np.linspace(t_lo, t_hi, 41), np.linspace(s_lo, s_hi, 41))
            d = np.linalg.norm(surface(tt.ravel(), ss.ravel()) - p, axis=1)
            k = int(np.argmin(d))
            dt, ds = (t_hi - t_lo) / 8, (s_hi - s_lo) / 8
            t_lo, t_hi = max(tt.flat[k] - dt, lo), min(tt.flat[k] + dt, hi)
            s_lo, s_hi = max(ss.flat[k] - ds, 0.0), min(ss.flat[k] + ds, 1.0)
        if d[k] < best[0]:
            best = (d[k], ss.flat[k])
    dist, s_foot = best
    ring = surface(np.linspace(0.0, 1.0, 20001)[:-1], np.full(20000, s_foot))[:, :2] - p[:2]
    nxt = np.roll(ring, -1, axis=0)
    turn = np.arctan2(ring[:, 0] * nxt[:, 1] - ring[:, 1] * nxt[:, 0],
                      np.einsum("ij,ij->i", ring, nxt)).sum()
    return -dist if abs(turn) > np.pi else dist


def _points_beside_the_seam(surface, s):
    """Points about a sharp seam at ``s``: beyond the edge, on its bisector, beside its faces.

    Beyond: 0.01-3 mm out along and across the normals' cone; inside on the bisector
    0.002-0.2 mm deep; beside either face at 0.2-4 % of the section from the seam and at
    5.5-7.5 % (just beyond ``SEAM_SEARCH_T``, where a search from the other face settles at
    the mirror outside the window too), 1-10 um inside and outside.
    """
    x, n_after = surface.points_and_normals(np.zeros(1), np.array([s]))
    n_before = surface.points_and_normals(np.full(1, 1.0 - 1e-12), np.array([s]))[1]
    x, n_after, n_before = x[0], n_after[0], n_before[0]
    bisector = (n_after + n_before) / np.linalg.norm(n_after + n_before)
    across = (n_after - n_before) / 2.0
    out = [x + r * (bisector + w * across) / np.linalg.norm(bisector + w * across)
           for r in (0.01, 0.3, 3.0) for w in (-0.8, 0.0, 0.8)]
    out += [x - r * bisector for r in (0.002, 0.02, 0.2)]
    t_face = np.repeat([0.002, 0.01, 0.04, 0.055, 0.065, 0.075,
                        0.925, 0.935, 0.945, 0.96, 0.99, 0.998], 4)
    depth = np.tile([-0.01, -0.001, 0.001, 0.01], 12)
    xf, nf = surface.points_and_normals(t_face, np.full(t_face.size, s))
    return np.r_[np.array(out), xf + depth[:, None] * nf]


@pytest.mark.parametrize(("thickness", "stall_share"), [(0.12, 2e-3), (0.03, 5e-3)])
def test_signed_distance_beside_a_sharp_seam_agrees_with_brute_force(thickness, stall_share):
    """Points about a knife edge at the seam, searched from either face, vs brute force.

    A search started on the face across the seam settles there, at the mirror of the true
    foot, and that face's normal read a point 1 um outside the other face as 0.1-0.4 mm
    inside the part (main: 48 of 288 here). Now the other face is searched too
    (projection_kernel SEAM_SEARCH_T), and beyond that window a foot reading its point
    deeper than the point lies from the foot's mirror (``mirror_nearer``): no point inside
    by more than 1 um reads outside (a hidden gouge), none outside by more reads inside, and
    the distances agree with the brute force's. Fails with ``other_face_nearer`` returning
    False (the far foot kept), ``SEAM_SEARCH_T = 1e-3`` (the window main had), or
    ``mirror_nearer`` returning False (flatseam 2fba654 on the 3 % section: points 1-10 um
    outside a face 5.5-7.5 % from the seam, its faces nearly parallel there, settled at the
    mirror just outside the window and read 1.4-1.8 mm deep, 20 of 384).
    """
    surface = fit_streamline_surface(
        toolpath.as_sections(_sharp_te_sections(thickness), closed=True), tol=0.01)
    for s in (0.3, 0.6):
        points = _points_beside_the_seam(surface, s)
        truth = np.array([_brute_signed(surface, p, s) for p in points])
        for t0 in (0.99, 0.01):
            seeds, at = np.full(len(points), t0), np.full(len(points), s)
            for surf in (surface, _NumpyOnly(surface)):
                got = signed_distance_near(surf, points, seeds, at, iterations=6)[0]
                assert not (got[truth < -1e-3] > 0.0).any()  # a gouge hidden
                assert not (got[truth > 1e-3] < 0.0).any()  # a false gouge
                # (beyond the edge the corner point's s stalls, ~1e-4: at 12 % up to 6 um at
                # 3 mm; round the thinner edge 2 um at 0.3 mm, 8 um at 3 mm, as before)
                assert (np.abs(got - truth) <= 1e-3 + stall_share * np.abs(truth)).all()


def _squared(v):
    """``|v|^2`` summed as the kernels sum it (a dot product may sum otherwise)."""
    return float(v[0]) * float(v[0]) + float(v[1]) * float(v[1]) + float(v[2]) * float(v[2])


def _in_python(compiled):
    """A compiled kernel function's own source run in Python, its compiled callees likewise.

    (Those compiled without a Python wrapper cannot be called from Python at all.)
    """
    import types

    f = compiled.py_func
    names = {name: _in_python(value) for name, value in f.__globals__.items()
             if name in f.__code__.co_names and hasattr(value, "py_func")}
    return types.FunctionType(f.__code__, {**f.__globals__, **names})


def _project_fresh(kernel, point, t, s, iterations, extra, converged_mm, orientation,
                   no_closer=None):
    """:func:`toolpath.compiled._project_one` as it was: every step's partials evaluated anew.

    The reference for the kernel's reuse of a taken trial point's partials (same steps,
    same numbers): scalars in Python through the kernel's own step functions. The steps
    whose every halving stayed farther (the last trial taken all the same) are counted in
    ``no_closer`` (a list, appended to).
    """
    from toolpath.compiled import SMALL_STEP_SHARE, _taylor_signed
    from toolpath.projection_kernel import HALVINGS, STEP_CLIP, newton_step, no_farther, trial

    taylor, step, trial, no_farther = (_in_python(f) for f in (_taylor_signed, newton_step,
                                                                trial, no_farther))
    p = np.asarray(point, dtype=float)[None, :]

    def frame(tt, ss, order):
        out = np.zeros((6, 1, 3))
        orders = ORDERS[:(order + 1) * (order + 2) // 2]
        got = kernel.partials(np.array([tt]), np.array([ss]), orders)
        for j, o in enumerate(ORDERS[:len(got)]):
            out[j, 0] = got[o][0]
        return out

    closed = bool(kernel.closed_t)
    moved, pt = np.inf, np.zeros((6, 1, 3))
    for k in range(iterations + extra):
        if k >= iterations and moved <= converged_mm:
            break
        fr = frame(t, s, 2)
        step_t, step_s, here = step(fr, 0, p, 0)
        new_t, new_s = trial(t, s, step_t, step_s, closed)
        lin = fr[1, 0] * (new_t - t) + fr[2, 0] * (new_s - s)
        if (orientation != 0.0 and k + 1 >= iterations and abs(new_t - t) < STEP_CLIP
                and _squared(lin) < (SMALL_STEP_SHARE * converged_mm) ** 2):
            return new_t, new_s, taylor(p, 0, fr, new_t - t, new_s - s, orientation)
        tangents = 1 if orientation != 0.0 and k + 1 >= iterations else 0
        for _ in range(HALVINGS):
            pt = frame(new_t, new_s, tangents)
            if no_farther(_squared(pt[0, 0] - p[0]), here):
                break
            step_t, step_s = 0.5 * step_t, 0.5 * step_s
            new_t, new_s = trial(t, s, step_t, step_s, closed)
        else:
            pt = frame(new_t, new_s, tangents)
            if no_closer is not None and k + 1 < iterations:
                no_closer.append(k)
        moved = math.sqrt(_squared(pt[0, 0] - fr[0, 0]))
        t, s = new_t, new_s
    if orientation == 0.0:
        return t, s, math.sqrt(_squared(frame(t, s, 0)[0, 0] - p[0]))
    return t, s, taylor(p, 0, frame(t, s, 1), 0.0, 0.0, orientation)


@pytest.mark.parametrize("seeds", ["near", "anywhere"])
@pytest.mark.parametrize("iterations", [1, 3, 7])
@pytest.mark.parametrize("orientation", [0.0, -1.0])
def test_projection_reusing_a_taken_points_partials_takes_the_fresh_steps(blade, iterations,
                                                                          orientation, seeds):
    # the kernel takes the next step's partials from its last trial point (evaluated to
    # the second order where another step surely follows): the same feet and distances,
    # to the bit, as evaluating them anew every step. Mutations caught: the copy of the
    # trial's partials into the next step's frame left out (stale second partials); the
    # trial taken after every halving stayed farther evaluated to the first order only
    # (``tangents`` for ``ahead``: seeds anywhere on the blade reach that branch).
    rng = np.random.default_rng(11)
    n = 60 if seeds == "near" else 150
    t, s = rng.random(n), rng.random(n)
    points = blade(t, s) + rng.uniform(0.2, 3.0, n)[:, None] * blade.normal(t, s)
    if seeds == "near":  # near ones converge; far ones take halvings and the extra steps
        t0 = np.clip(t + rng.normal(scale=0.05, size=n), 0, 1)
        s0 = np.clip(s + rng.normal(scale=0.05, size=n), 0, 1)
    else:
        t0, s0 = rng.random(n), rng.random(n)
    kernel = blade.kernel()
    got = kernel.project(points, t0, s0, iterations, 24, 1e-3, orientation=orientation)
    no_closer = []
    for i in range(n):
        want = _project_fresh(kernel, points[i], t0[i], s0[i], iterations, 24, 1e-3,
                              orientation, no_closer)
        assert (got[0][i], got[1][i], got[2][i]) == want, i
    if seeds == "anywhere" and iterations == 7:
        assert no_closer, "no step of these seeds kept a trial that stayed farther"
