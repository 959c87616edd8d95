"""fit_batch's compiled step for small problems (fitting/small_step.py, ``compiled=True``) held to
its NumPy path: the same minima, costs, convergence and (to rounding) iteration counts on
exponential decays of 1–4 parameters, with bounds that hold parameters, per-problem and infinite
bounds, a disc projection, and problems whose residuals are never finite; and SciPy's
least_squares as the independent reference for the minima."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.optimize import least_squares

from magcilia._jit import compile_kernel
from magcilia.fitting import fit_batch, small_step

F = np.ndarray
T = np.linspace(0.0, 3.0, 12)

pytestmark = pytest.mark.skipif(compile_kernel(small_step.accept_kernel) is None,
                                reason="numba missing: no compiled step to compare")


def decay(p: int, data: F):
    """Residuals and Jacobian of a sum of decays a0 e^(−a1 t) + a2 + a3 t (first p terms)."""

    def model(x: F, which: F) -> tuple[F, F]:
        cols, jac = [], []
        e = np.exp(-x[:, 1:2] * T) if p > 1 else np.exp(-T)[None] * np.ones((x.shape[0], 1))
        value = x[:, :1] * e
        jac.append(e)
        if p > 1:
            jac.append(-x[:, :1] * T * e)
        if p > 2:
            value = value + x[:, 2:3]
            jac.append(np.ones_like(e))
        if p > 3:
            value = value + x[:, 3:4] * T
            jac.append(np.ones_like(e) * T)
        cols = np.stack(jac, -1)
        return value - data[which], cols

    return model


def _problems(p: int, n: int, seed: int) -> tuple[F, F]:
    rng = np.random.default_rng(seed)
    truth = np.column_stack([rng.uniform(1, 3, n), rng.uniform(0.3, 2, n),
                             rng.uniform(-0.5, 0.5, n), rng.uniform(-0.2, 0.2, n)])[:, :p]
    full = np.column_stack([truth, np.zeros((n, 4 - p))])
    data = (full[:, :1] * np.exp(-(full[:, 1:2] if p > 1 else 1.0) * T) + full[:, 2:3]
            + full[:, 3:4] * T + rng.normal(0, 0.01, (n, T.size)))
    start = truth * rng.uniform(0.5, 1.5, truth.shape) + 0.1
    return data, start


def _both(residuals, start, lower, upper, **kw):
    fast = fit_batch(residuals, start, lower, upper, jacobian=True, compiled=True, **kw)
    slow = fit_batch(residuals, start, lower, upper, jacobian=True, **kw)
    return fast, slow


def _same(fast, slow) -> None:
    """The same fits: minima to what the stopping rule resolves (a flat valley of a 3- or
    4-term decay moves x by ~1e-6 for a cost change below ftol), costs closer still; with
    p ≤ 2 (the same closed-form solve) the same iteration counts nearly everywhere, with
    Gaussian elimination against LAPACK's the path itself may differ by rounding."""
    np.testing.assert_array_equal(fast.converged, slow.converged)
    ok = np.isfinite(slow.cost)
    np.testing.assert_array_equal(np.isfinite(fast.cost), ok)
    np.testing.assert_allclose(fast.x[ok], slow.x[ok], rtol=1e-5, atol=1e-8)
    np.testing.assert_allclose(fast.cost[ok], slow.cost[ok], rtol=1e-8, atol=1e-14)
    np.testing.assert_allclose(fast.jtj[ok], slow.jtj[ok], rtol=1e-4, atol=1e-9)
    if fast.x.shape[1] <= 2:
        assert np.mean(fast.iterations == slow.iterations) > 0.95  # rounding may cost one


@pytest.mark.parametrize("p", [1, 2, 3, 4])
def test_the_compiled_step_matches_numpy_and_scipy(p: int) -> None:
    data, start = _problems(p, 60, p)
    lower, upper = np.full(p, -10.0), np.full(p, 10.0)
    fast, slow = _both(decay(p, data), start, lower, upper, maxiter=300)
    _same(fast, slow)
    assert fast.converged.all()
    for i in range(3):  # SciPy's least_squares: the same minimum
        ref = least_squares(lambda x, i=i: decay(p, data)(x[None], np.array([i]))[0][0],
                            start[i], xtol=1e-15, ftol=1e-15, gtol=1e-15)
        np.testing.assert_allclose(fast.x[i], ref.x, rtol=1e-6, atol=1e-8)


def test_held_parameters_per_problem_and_infinite_bounds() -> None:
    data, start = _problems(3, 40, 7)
    lower = np.tile([-np.inf, 0.0, 0.05], (40, 1))  # the offset often pinned at its bound
    upper = np.tile([np.inf, 1.2, np.inf], (40, 1))
    upper[::2, 1] = 0.5  # per problem: the rate held on its upper bound for some
    start = np.clip(start, lower, upper)
    fast, slow = _both(decay(3, data), start, lower, upper, maxiter=80)
    _same(fast, slow)
    assert (fast.x[:, 2] == 0.05).any() and (fast.x[::2, 1] == 0.5).any()


def test_a_projection_and_problems_never_finite() -> None:
    data, start = _problems(2, 30, 9)
    data[3] = np.nan  # never finite: never runs, not converged

    def disc(x: F, which: F) -> F:
        mag = np.hypot(x[:, 0], x[:, 1])
        shrink = np.where(mag > 2.0, 2.0 / np.maximum(mag, 1e-300), 1.0)
        return x * shrink[:, None]

    fast, slow = _both(decay(2, data), start, [-5.0, -5.0], [5.0, 5.0], maxiter=50,
                       project=disc)
    _same(fast, slow)
    assert not fast.converged[3] and np.hypot(*fast.x.T).max() <= 2.0 + 1e-12
    assert fast.converged.sum() > 15  # the rest crawl along the edge to maxiter
