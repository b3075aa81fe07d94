import numpy as np
import pytest
import scipy.linalg

from toolpath import fit_linear_system
from toolpath.paper_examples import example1, example2

# Paper Tables 1 and 2 (chord-length parameters in [0, 1]); targets: within 15%.
TABLE1 = {"P1-1": 0.0058, "P1-2": 0.0029, "P2": 0.0018}
TABLE2 = {"P1-1": 0.1760, "P1-2": 0.0031}


@pytest.mark.parametrize("model,paper", TABLE1.items())
def test_table1_reproduced_within_15_percent(model, paper):
    points, _, _ = example1()
    assert fit_linear_system(points, model=model).max_error == pytest.approx(paper, rel=0.15)


@pytest.mark.parametrize("model,paper", TABLE2.items())
def test_table2_reproduced_within_15_percent(model, paper):
    points, _, _ = example2()
    assert fit_linear_system(points, model=model).max_error == pytest.approx(paper, rel=0.15)


@pytest.mark.parametrize("example", [example1, example2])
def test_p0_recovers_a_exactly_with_true_time(example):
    points, t, A = example()
    curve = fit_linear_system(points, model="P0", params=t)
    np.testing.assert_allclose(curve.A, A, atol=1e-9)
    assert curve.max_error < 1e-10


def test_p2_recovers_a_with_second_order_convergence():
    errs = []
    for n in (50, 100, 200):
        points, t, A = example1(n=n)
        errs.append(np.abs(fit_linear_system(points, model="P2", params=t).A - A).max())
    assert errs[-1] < 1e-5
    # trapezoid rule: halving the step quarters the error
    assert 3.0 < errs[0] / errs[1] < 5.0 and 3.0 < errs[1] / errs[2] < 5.0


def test_evaluation_is_batched_expm_and_derivative_is_a_x():
    points, t, A = example1()
    curve = fit_linear_system(points, model="P0", params=t)
    ts = np.linspace(0, 1, 7)
    expected = np.stack([scipy.linalg.expm(A * s) @ points[0] for s in ts])
    np.testing.assert_allclose(curve(ts), expected, atol=1e-9)
    np.testing.assert_allclose(curve.derivative(ts), expected @ A.T, atol=1e-8)
    np.testing.assert_allclose(curve.derivative(ts, order=2), expected @ (A @ A).T, atol=1e-8)
    assert curve(0.5).shape == (3,)


def test_p12_normal_equations_match_dense_lstsq_of_eq10():
    points, _, _ = example2(n=30)
    curve = fit_linear_system(points, model="P1-2")
    t = curve.params
    rows, rhs = [], []
    for i in range(1, len(points) - 1):
        h0, h1 = t[i] - t[i - 1], t[i + 1] - t[i]
        a, b, g, d = h0**2, h1**2 - h0**2, -(h1**2), h0 * h1 * (h0 + h1)
        rhs.append(a * points[i + 1] + b * points[i] + g * points[i - 1])
        rows.append(d * np.kron(np.eye(3), points[i][None, :]))
    ref = np.linalg.lstsq(np.vstack(rows), np.concatenate(rhs), rcond=None)[0].reshape(3, 3)
    np.testing.assert_allclose(curve.A, ref, atol=1e-9)


def test_p0_stops_within_its_budget_and_warns():
    """Issue 26 (fuzz): points far from any dX/dt = A X (four blade sections read as one
    curve) ran P0's Levenberg-Marquardt for scipy's 9000 evaluations, over ten minutes."""
    from toolpath.errors import ConvergenceWarning
    from toolpath.linear_system import _fit_p0

    t = np.linspace(0.0, 1.0, 30)
    zigzag = np.c_[40 * t, 3 * (-1.0) ** np.arange(30), 5 + t**2]
    with pytest.warns(ConvergenceWarning, match=r"P0 stopped after \d+ evaluations"):
        a = _fit_p0(zigzag, t, evaluations_per_unknown=1)  # a budget of 10 evaluations
    assert a.shape == (3, 3) and np.isfinite(a).all()
