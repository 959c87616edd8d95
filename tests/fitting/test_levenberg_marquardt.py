"""The batched Levenberg–Marquardt against SciPy's ``least_squares`` on problems with known
minima: Rosenbrock, a noisy exponential decay, a minimum on a bound, batches that mix easy and
impossible problems, analytic against finite-difference Jacobians, many problems against one at
a time."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.optimize import least_squares

from magcilia import MagciliaError
from magcilia.fitting import BatchFit, fit_batch

F = np.ndarray
TIGHT = {"xtol": 1e-15, "ftol": 1e-15, "gtol": 1e-15}


# -- Rosenbrock: r = (10 (y − x²), 1 − x), minimum 0 at (1, 1) -------------------------------
def rosenbrock(x: F, which: F) -> F:
    return np.stack([10.0 * (x[:, 1] - x[:, 0] ** 2), 1.0 - x[:, 0]], axis=1)


def rosenbrock_jacobian(x: F, which: F) -> F:
    jac = np.zeros((x.shape[0], 2, 2))
    jac[:, 0, 0], jac[:, 0, 1], jac[:, 1, 0] = -20.0 * x[:, 0], 10.0, -1.0
    return jac


ROSENBROCK_STARTS = np.array([[-1.2, 1.0], [2.0, -1.0], [0.0, 0.0], [-3.0, 4.0], [1.0, 1.0]])


def test_rosenbrock_reaches_its_minimum_from_every_start() -> None:
    fit = fit_batch(rosenbrock, ROSENBROCK_STARTS, [-5.0, -5.0], [5.0, 5.0], maxiter=200)
    np.testing.assert_allclose(fit.x, 1.0, atol=1e-6)
    assert np.all(fit.cost < 1e-12) and fit.converged.all()
    for start in ROSENBROCK_STARTS:  # SciPy from the same starts: the same point
        ref = least_squares(lambda p: rosenbrock(p[None], None)[0], start, **TIGHT)
        np.testing.assert_allclose(ref.x, 1.0, atol=1e-6)


@pytest.mark.parametrize("mode", ["callable", "with residuals"])
def test_rosenbrock_with_analytic_jacobian_and_no_bounds(mode: str) -> None:
    if mode == "callable":
        fit = fit_batch(rosenbrock, ROSENBROCK_STARTS, [-np.inf] * 2, [np.inf] * 2,
                        jacobian=rosenbrock_jacobian, maxiter=200)
    else:
        fit = fit_batch(lambda x, w: (rosenbrock(x, w), rosenbrock_jacobian(x, w)),
                        ROSENBROCK_STARTS, [-np.inf] * 2, [np.inf] * 2, jacobian=True,
                        maxiter=200)
    np.testing.assert_allclose(fit.x, 1.0, atol=1e-6)
    assert fit.converged.all()
    # with analytic Jacobians only the trial points cost evaluations: one per iteration
    np.testing.assert_array_equal(fit.evaluations, fit.iterations + 1)


# -- a · exp(−b t) + c with seeded noise ---------------------------------------------------------
T = np.linspace(0.0, 3.0, 25)
LOWER, UPPER = np.array([0.0, 0.0, -5.0]), np.array([10.0, 10.0, 5.0])


def decay(x: F) -> F:
    return x[:, 0:1] * np.exp(-x[:, 1:2] * T) + x[:, 2:3]


def decay_jacobian(x: F) -> F:
    e = np.exp(-x[:, 1:2] * T)
    return np.stack([e, -x[:, 0:1] * T * e, np.ones_like(e)], axis=-1)


def noisy_decays(count: int, seed: int = 0) -> tuple[F, F]:
    rng = np.random.default_rng(seed)
    truths = rng.uniform([0.5, 0.2, -1.0], [2.0, 3.0, 1.0], (count, 3))
    return truths, decay(truths) + 0.01 * rng.standard_normal((count, T.size))


def test_noisy_decays_fit_as_least_squares_does() -> None:
    truths, data = noisy_decays(12)
    fit = fit_batch(lambda x, w: decay(x) - data[w], np.tile([1.0, 1.0, 0.0], (12, 1)),
                    LOWER, UPPER)
    assert fit.converged.all()
    for i in range(12):
        ref = least_squares(lambda p, i=i: decay(p[None])[0] - data[i], [1.0, 1.0, 0.0],
                            bounds=(LOWER, UPPER), **TIGHT)
        assert fit.cost[i] == pytest.approx(2 * ref.cost, rel=1e-8)
        np.testing.assert_allclose(fit.x[i], ref.x, rtol=1e-5, atol=1e-8)
        np.testing.assert_allclose(fit.residuals[i], ref.fun, atol=1e-6)
        # and the noise is small: the truth within 10 %
        np.testing.assert_allclose(fit.x[i], truths[i], rtol=0.1, atol=0.05)


def test_covariance_from_jtj_matches_scipy_jacobian() -> None:
    _, data = noisy_decays(3, seed=4)
    fit = fit_batch(lambda x, w: decay(x) - data[w], np.tile([1.0, 1.0, 0.0], (3, 1)),
                    LOWER, UPPER, final_jacobian=True)
    exact = fit_batch(lambda x, w: decay(x) - data[w], np.tile([1.0, 1.0, 0.0], (3, 1)),
                      LOWER, UPPER, jacobian=lambda x, w: decay_jacobian(x), final_jacobian=True)
    for i in range(3):
        jac = decay_jacobian(fit.x[i][None])[0]
        np.testing.assert_allclose(fit.jtj[i], jac.T @ jac, rtol=1e-5)
        np.testing.assert_allclose(exact.jtj[i], jac.T @ jac, rtol=1e-6)
        cov = np.linalg.inv(fit.jtj[i])  # finite: the problem is well determined
        assert np.all(np.diag(cov) > 0)


# -- a minimum on a bound ------------------------------------------------------------------------
def test_a_minimum_on_a_bound_is_least_squares_constrained_one() -> None:
    # unconstrained optimum b = 2; with b ≤ 1 the fit ends on that bound and a, c take the
    # constrained optimum (SciPy's answer); a lower bound too: c ≥ 0.5 with true c = 0.3
    data = decay(np.array([[1.5, 2.0, 0.3]]))
    lower, upper = np.array([0.0, 0.0, 0.5]), np.array([10.0, 1.0, 5.0])
    fit = fit_batch(lambda x, w: decay(x) - data[w], [[1.0, 0.5, 1.0]], lower, upper)
    ref = least_squares(lambda p: decay(p[None])[0] - data[0], [1.0, 0.5, 1.0],
                        bounds=(lower, upper), **TIGHT)
    assert fit.x[0, 1] == 1.0 and fit.x[0, 2] == 0.5  # exactly on the bounds
    assert fit.converged[0]
    assert fit.cost[0] == pytest.approx(2 * ref.cost, rel=1e-7)
    np.testing.assert_allclose(fit.x[0], ref.x, rtol=1e-5)
    # KKT: the cost rises into the box from each active bound
    grad = decay_jacobian(fit.x)[0].T @ fit.residuals[0]
    assert grad[1] < 0 and grad[2] > 0 and abs(grad[0]) < 1e-6 * np.abs(grad).max()


def test_per_problem_bounds_equal_shared_bounds_one_at_a_time() -> None:
    _, data = noisy_decays(4, seed=2)
    lower = np.array([[0.0, 0.0, -5.0], [0.0, 0.0, 0.5], [0.0, 0.0, -5.0], [1.8, 0.0, -5.0]])
    upper = np.array([[10.0, 1.0, 5.0], [10.0, 10.0, 5.0], [10.0, 10.0, 5.0], [10.0, 10.0, 5.0]])
    x0 = np.clip(np.tile([1.0, 1.0, 0.0], (4, 1)), lower, upper)
    both = fit_batch(lambda x, w: decay(x) - data[w], x0, lower, upper)
    for i in range(4):
        one = fit_batch(lambda x, w, i=i: decay(x) - data[i], x0[i], lower[i], upper[i])
        np.testing.assert_allclose(both.x[i], one.x[0], rtol=1e-9, atol=1e-12)
        assert np.all(both.x[i] >= lower[i]) and np.all(both.x[i] <= upper[i])


# -- easy and impossible problems in one batch -----------------------------------------------
def test_a_batch_mixing_easy_and_impossible_problems() -> None:
    _, data = noisy_decays(1, seed=7)
    target = data[0]

    def residuals(x: F, which: F) -> F:
        r = decay(x) - target
        r[which == 1] = np.nan  # never finite
        r[(which == 2) & (x[:, 1] > 1.2)] = np.nan  # finite only for b ≤ 1.2
        r[which == 3] = 0.0 * r[which == 3] + 1.0  # no parameter has any effect
        return r

    x0 = np.array([[1.0, 1.0, 0.0], [1.0, 1.0, 0.0], [1.0, 0.5, 0.0], [1.0, 1.0, 0.0]])
    fit = fit_batch(residuals, x0, LOWER, UPPER)
    alone = fit_batch(lambda x, w: decay(x) - target, x0[0], LOWER, UPPER)
    np.testing.assert_allclose(fit.x[0], alone.x[0], rtol=1e-9)  # untouched by the others
    assert fit.converged[0]
    # never finite: left alone, infinite cost, no iteration
    assert fit.cost[1] == np.inf and not fit.converged[1] and fit.iterations[1] == 0
    np.testing.assert_array_equal(fit.x[1], x0[1])
    assert np.isnan(fit.jtj[1]).all()
    # partly finite: stays where it is finite
    assert np.isfinite(fit.cost[2]) and fit.x[2, 1] <= 1.2
    # zero columns: the system stays regular and nothing moves
    np.testing.assert_array_equal(fit.x[3], x0[3])
    assert fit.cost[3] == T.size and fit.converged[3]
    assert np.isfinite(fit.x).all()


def test_a_zero_column_among_live_ones_stays_put() -> None:
    # the third parameter has no effect (as d/dy at y = 0 of B_x, even in y): it keeps its
    # start, the other two fit as without it
    _, data = noisy_decays(1, seed=3)

    def residuals(x: F, which: F) -> F:
        return decay(np.c_[x[:, :2], np.zeros(x.shape[0])]) - data[0] + 0.0 * x[:, 2:3]

    fit = fit_batch(residuals, [[1.0, 1.0, 0.7]], LOWER, UPPER)
    ref = least_squares(lambda p: decay(np.r_[p, 0.0][None])[0] - data[0], [1.0, 1.0],
                        bounds=(LOWER[:2], UPPER[:2]), **TIGHT)
    assert fit.x[0, 2] == 0.7
    np.testing.assert_allclose(fit.x[0, :2], ref.x, rtol=1e-5)


def test_a_held_parameter_stays_put() -> None:
    _, data = noisy_decays(1, seed=5)
    fit = fit_batch(lambda x, w: decay(x) - data[0], [[1.0, 1.0, 0.25]],
                    [0.0, 0.0, 0.25], [10.0, 10.0, 0.25])
    ref = least_squares(lambda p: decay(np.r_[p, 0.25][None])[0] - data[0], [1.0, 1.0],
                        bounds=([0.0, 0.0], [10.0, 10.0]), **TIGHT)
    assert fit.x[0, 2] == 0.25
    np.testing.assert_allclose(fit.x[0, :2], ref.x, rtol=1e-5)


# -- Jacobians and batching ------------------------------------------------------------------------
def test_analytic_and_finite_difference_jacobians_agree() -> None:
    _, data = noisy_decays(6, seed=1)
    x0 = np.tile([1.0, 1.0, 0.0], (6, 1))
    fd = fit_batch(lambda x, w: decay(x) - data[w], x0, LOWER, UPPER)
    an = fit_batch(lambda x, w: decay(x) - data[w], x0, LOWER, UPPER,
                   jacobian=lambda x, w: decay_jacobian(x))
    both = fit_batch(lambda x, w: (decay(x) - data[w], decay_jacobian(x)), x0, LOWER, UPPER,
                     jacobian=True)
    for fit in (an, both):
        np.testing.assert_allclose(fit.x, fd.x, rtol=1e-5, atol=1e-8)
        np.testing.assert_allclose(fit.cost, fd.cost, rtol=1e-8)
        assert fit.converged.all()
    # finite differences cost p more evaluations per iteration
    np.testing.assert_array_equal(fd.evaluations, 1 + 4 * fd.iterations)


def test_many_problems_at_once_equal_one_at_a_time() -> None:
    _, data = noisy_decays(10, seed=9)
    x0 = np.random.default_rng(9).uniform([0.2, 0.2, -1.0], [3.0, 3.0, 1.0], (10, 3))
    batch = fit_batch(lambda x, w: decay(x) - data[w], x0, LOWER, UPPER)
    for i in range(10):
        one = fit_batch(lambda x, w, i=i: decay(x) - data[i], x0[i], LOWER, UPPER)
        np.testing.assert_allclose(batch.x[i], one.x[0], rtol=1e-9, atol=1e-12)
        assert batch.cost[i] == pytest.approx(one.cost[0], rel=1e-9)
        assert batch.iterations[i] == pytest.approx(one.iterations[0], abs=2)


def test_iteration_limit_is_not_convergence() -> None:
    fit = fit_batch(rosenbrock, [[-1.2, 1.0]], [-5.0, -5.0], [5.0, 5.0], maxiter=2)
    assert fit.iterations[0] == 2 and not fit.converged[0]
    assert fit.cost[0] < 24.2  # it did lower the cost (24.2 at the start)


# -- the result and the checks -----------------------------------------------------------------
def test_the_result_is_frozen_and_reports() -> None:
    fit = fit_batch(rosenbrock, ROSENBROCK_STARTS[:2], [-5.0, -5.0], [5.0, 5.0], maxiter=200)
    assert isinstance(fit, BatchFit) and fit.best in (0, 1)
    with pytest.raises(AttributeError):
        fit.x = fit.x  # type: ignore[misc]
    doc = fit.to_dict()
    assert doc["problems"] == 2 and len(doc["x"]) == 2 and doc["converged"] == [True, True]
    assert "2 converged" in fit.report() and "best: problem" in fit.report()
    assert repr(fit).startswith("BatchFit(problems=2")
    np.testing.assert_array_equal(fit.take(np.array([1])).x, fit.x[1:])


@pytest.mark.parametrize(("lower", "upper", "match"), [
    ([0.0], [1.0, 1.0], "lower"),
    ([0.0, 2.0], [1.0, 1.0], "lower <= upper"),
    ([0.0, np.nan], [1.0, 1.0], "lower"),
    ([0.0, -np.inf], [1.0, 1.0], "finite bounds"),
])
def test_bad_bounds_are_one_line_errors(lower: list[float], upper: list[float],
                                        match: str) -> None:
    with pytest.raises(MagciliaError, match=match):
        fit_batch(rosenbrock, [[0.5, 0.5]], lower, upper)


def test_the_callers_arrays_are_never_written() -> None:
    # residuals and Jacobians handed back from a cache (read-only here) are copied, not updated
    _, data = noisy_decays(2, seed=6)

    def residuals(x: F, which: F) -> tuple[F, F]:
        r, jac = decay(x) - data[which], decay_jacobian(x)
        r.setflags(write=False)
        jac.setflags(write=False)
        return r, jac

    fit = fit_batch(residuals, np.tile([1.0, 1.0, 0.0], (2, 1)), LOWER, UPPER, jacobian=True)
    assert fit.converged.all()
