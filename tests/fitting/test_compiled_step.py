"""fit_batch's one compiled step (``magcilia.fitting.compiled``: ``propose_kernel``,
``accept_kernel``) held to its NumPy reference: the same damped steps (p = 1…6, bounds that hold
parameters, shared and per-problem bounds, singular and non-finite systems; the normal equations
from cached Jacobians or given), and the same fits — minima, costs, JᵀJ, convergence and (p ≤ 2)
iteration counts — for every Jacobian source, with per-problem and infinite bounds, a disc
projection and problems never finite; SciPy's least_squares the independent reference for the
minima."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.optimize import least_squares

from magcilia.fitting import compiled, fit_batch
from magcilia.fitting.levenberg_marquardt import _damped_steps

F = np.ndarray
T = np.linspace(0.0, 3.0, 16)
TERMS = 6

pytestmark = pytest.mark.skipif(compiled.kernels() is None,
                                reason="numba missing: no compiled step to compare")


def test_numba_is_available_here() -> None:
    assert compiled.kernels() is not None


def _systems(seed: int, size: int, dims: int) -> tuple[F, ...]:
    rng = np.random.default_rng(seed)
    jac = rng.standard_normal((size, 12, dims)) * rng.uniform(0.1, 10.0, (size, 1, dims))
    r = rng.standard_normal((size, 12))
    lam = 10.0 ** rng.uniform(-6, 2, size)
    x = rng.uniform(-1.0, 1.0, (size, dims))
    x[::3, 0], x[1::3, dims - 1] = -1.0, 1.0  # on a bound: some steps point outward, held
    jac[5] = 0.0  # a singular system: zero step
    jac[6, :, 0] = 0.0  # a parameter without effect: the floored diagonal keeps it regular
    r[7, 3] = np.nan  # a non-finite one: not ok, zero step
    return jac, r, lam, x


def _propose(x: F, lam: F, lo: F, hi: F, jac: F, r: F, jtj: F, jtr: F) -> tuple[F, F]:
    fast = compiled.kernels()
    assert fast is not None
    idx = np.arange(x.shape[0])
    trial, ok = np.empty_like(x), np.empty(x.shape[0], dtype=bool)
    fast.propose(idx, x, lam, lo, hi, jac, r, jtj, jtr, trial, ok)
    return trial, ok


@pytest.mark.parametrize("dims", [1, 2, 3, 4, 5, 6])
def test_the_compiled_step_is_the_numpy_step(dims: int) -> None:
    size = 40
    jac, r, lam, x = _systems(dims, size, dims)
    with np.errstate(invalid="ignore"):
        jtj = np.einsum("sap,saq->spq", jac, jac)
        jtr = np.einsum("sap,sa->sp", jac, r)
    lo, hi = np.full(dims, -1.0), np.full(dims, 1.0)
    delta, ok_ref = _damped_steps(jtj, jtr, lam, x, lo, hi)
    ref = np.clip(x + delta, lo, hi)
    assert not ok_ref[7] and ok_ref[5] and not delta[5].any() and not delta[7].any()
    if dims > 1:  # held on its bound: the second solve left it there
        assert (ref[::3, 0] == -1.0).any() and (ref[1::3, dims - 1] == 1.0).any()
    tol = 1e-10 * (np.abs(delta).max(axis=1, keepdims=True) + 1e-300)
    none3, none2 = np.zeros((0, 0, 0)), np.zeros((0, 0))
    given, ok = _propose(x, lam, lo[None], hi[None], none3, r, jtj, jtr)  # JᵀJ, Jᵀr given
    np.testing.assert_array_equal(ok, ok_ref)
    assert (np.abs(given - ref) <= tol).all()
    cached, ok = _propose(x, lam, lo[None], hi[None], jac, r, none3, none2)  # from cached J
    np.testing.assert_array_equal(ok, ok_ref)
    assert (np.abs(cached - ref) <= tol).all()
    # per-problem bounds: the same steps; narrower ones for half of the problems
    per_lo, per_hi = np.tile(lo, (size, 1)), np.tile(hi, (size, 1))
    same, _ = _propose(x, lam, per_lo, per_hi, jac, r, none3, none2)
    np.testing.assert_array_equal(same, cached)
    per_hi[::2] = np.maximum(x[::2], 0.2)
    d2, _ = _damped_steps(jtj, jtr, lam, x, per_lo, per_hi)
    narrow, _ = _propose(x, lam, per_lo, per_hi, jac, r, none3, none2)
    assert (np.abs(narrow - np.clip(x + d2, per_lo, per_hi)) <= tol).all()
    assert (narrow <= per_hi).all()


def decay(p: int, data: F):
    """Residuals and Jacobian of a0 e^(−a1 t) + a2 + a3 t + a4 sin 3t + a5 cos 3t (the first p
    terms)."""

    def model(x: F, which: F) -> tuple[F, F]:
        e = np.exp(-x[:, 1:2] * T) if p > 1 else np.exp(-T)[None] * np.ones((x.shape[0], 1))
        value = x[:, :1] * e
        jac = [e] + ([-x[:, :1] * T * e] if p > 1 else [])
        bases = [np.ones_like(T), T, np.sin(3 * T), np.cos(3 * T)][:max(p - 2, 0)]
        for j, basis in enumerate(bases):
            value = value + x[:, 2 + j:3 + j] * basis
            jac.append(np.broadcast_to(basis, e.shape))
        return value - data[which], np.stack(jac, -1)

    return model


def _problems(p: int, n: int, seed: int) -> tuple[F, F]:
    rng = np.random.default_rng(seed)
    truth = np.column_stack([rng.uniform(1, 3, n), rng.uniform(0.3, 2, n),
                             rng.uniform(-0.5, 0.5, n), rng.uniform(-0.2, 0.2, n),
                             rng.uniform(-0.3, 0.3, n), rng.uniform(-0.3, 0.3, n)])[:, :p]
    full = np.column_stack([truth, np.zeros((n, TERMS - p))])
    data = (full[:, :1] * np.exp(-(full[:, 1:2] if p > 1 else 1.0) * T) + full[:, 2:3]
            + full[:, 3:4] * T + full[:, 4:5] * np.sin(3 * T) + full[:, 5:6] * np.cos(3 * T)
            + rng.normal(0, 0.01, (n, T.size)))
    start = truth * rng.uniform(0.5, 1.5, truth.shape) + 0.1
    return data, start


def _both(monkeypatch: pytest.MonkeyPatch, residuals, start, lower, upper, **kw):
    fast = fit_batch(residuals, start, lower, upper, **kw)
    with monkeypatch.context() as m:
        m.setattr(compiled, "ENABLED", False)
        slow = fit_batch(residuals, start, lower, upper, **kw)
    return fast, slow


def _same(fast, slow, iterations: bool = True) -> None:
    """The same fits: minima to what the stopping rule resolves (a flat valley moves x by ~1e-6
    for a cost change below ftol), costs closer still; with p ≤ 2 (the same closed-form solve)
    the same iteration counts nearly everywhere; LU against LAPACK's may differ by rounding."""
    np.testing.assert_array_equal(fast.converged, slow.converged)
    ok = np.isfinite(slow.cost)
    np.testing.assert_array_equal(np.isfinite(fast.cost), ok)
    np.testing.assert_allclose(fast.x[ok], slow.x[ok], rtol=1e-5, atol=1e-8)
    np.testing.assert_allclose(fast.cost[ok], slow.cost[ok], rtol=1e-8, atol=1e-14)
    np.testing.assert_allclose(fast.jtj[ok], slow.jtj[ok], rtol=1e-4, atol=1e-9)
    if iterations and fast.x.shape[1] <= 2:
        assert np.mean(fast.iterations == slow.iterations) > 0.95  # rounding may cost one


@pytest.mark.parametrize("p", [1, 2, 3, 4, 5, 6])
def test_the_compiled_fit_matches_numpy_and_scipy(p: int,
                                                  monkeypatch: pytest.MonkeyPatch) -> None:
    data, start = _problems(p, 60, p)
    lower, upper = np.full(p, -10.0), np.full(p, 10.0)
    fast, slow = _both(monkeypatch, decay(p, data), start, lower, upper, jacobian=True,
                       maxiter=300)
    _same(fast, slow)
    # p ≥ 5: an exponential beside a line and a sinusoid may crawl along a flat valley
    assert fast.converged.all() if p <= 4 else fast.converged.mean() >= 0.95
    for i in range(3):  # SciPy's least_squares: the same minimum
        ref = least_squares(lambda x, i=i: decay(p, data)(x[None], np.array([i]))[0][0],
                            start[i], xtol=1e-15, ftol=1e-15, gtol=1e-15)
        np.testing.assert_allclose(fast.x[i], ref.x, rtol=1e-6, atol=1e-8)


@pytest.mark.parametrize("source", ["callable", "differences"])
@pytest.mark.parametrize("p", [2, 5])
def test_every_jacobian_source_takes_the_compiled_step(p: int, source: str,
                                                       monkeypatch: pytest.MonkeyPatch) -> None:
    data, start = _problems(p, 30, 20 + p)
    model = decay(p, data)
    lower, upper = np.full(p, -10.0), np.full(p, 10.0)
    upper[-1] = {2: 1.0, 5: 0.0}[p]  # the last parameter often held on its upper bound

    def residuals(x: F, which: F) -> F:
        return model(x, which)[0]

    kw = ({"jacobian": lambda x, which: model(x, which)[1]} if source == "callable" else {})
    fast, slow = _both(monkeypatch, residuals, np.clip(start, lower, upper), lower, upper,
                       maxiter=200, final_jacobian=True, **kw)
    _same(fast, slow, iterations=False)  # JᵀJ's rounding (einsum, loops) may cost one
    assert fast.converged.mean() >= 0.8 and (fast.x[:, -1] == upper[-1]).any()


def test_held_parameters_per_problem_and_infinite_bounds(monkeypatch: pytest.MonkeyPatch
                                                         ) -> None:
    data, start = _problems(3, 40, 7)
    lower = np.tile([-np.inf, 0.0, 0.05], (40, 1))  # the offset often pinned at its bound
    upper = np.tile([np.inf, 1.2, np.inf], (40, 1))
    upper[::2, 1] = 0.5  # per problem: the rate held on its upper bound for some
    start = np.clip(start, lower, upper)
    fast, slow = _both(monkeypatch, decay(3, data), start, lower, upper, jacobian=True,
                       maxiter=80)
    _same(fast, slow)
    assert (fast.x[:, 2] == 0.05).any() and (fast.x[::2, 1] == 0.5).any()


def test_a_projection_and_problems_never_finite(monkeypatch: pytest.MonkeyPatch) -> None:
    data, start = _problems(2, 30, 9)
    data[3] = np.nan  # never finite: never runs, not converged

    def disc(x: F, which: F) -> F:
        mag = np.hypot(x[:, 0], x[:, 1])
        shrink = np.where(mag > 2.0, 2.0 / np.maximum(mag, 1e-300), 1.0)
        return x * shrink[:, None]

    fast, slow = _both(monkeypatch, decay(2, data), start, [-5.0, -5.0], [5.0, 5.0],
                       jacobian=True, maxiter=50, project=disc)
    _same(fast, slow)
    assert not fast.converged[3] and np.hypot(*fast.x.T).max() <= 2.0 + 1e-12
    assert fast.converged.sum() > 15  # the rest crawl along the edge to maxiter


def test_singular_systems_stay_put(monkeypatch: pytest.MonkeyPatch) -> None:
    # problems whose residuals do not depend on the parameters: a zero JᵀJ, a zero step, ended
    data, start = _problems(4, 20, 11)
    model = decay(4, data)

    def residuals(x: F, which: F) -> tuple[F, F]:
        r, jac = model(x, which)
        flat = (which % 5 == 0)[:, None]
        return np.where(flat, 1.0, r), np.where(flat[:, :, None], 0.0, jac)

    fast, slow = _both(monkeypatch, residuals, start, np.full(4, -10.0), np.full(4, 10.0),
                       jacobian=True, maxiter=200)
    _same(fast, slow)
    np.testing.assert_array_equal(fast.x[::5], start[::5])
    assert (fast.iterations[::5] == 1).all() and fast.converged.all()


def test_fits_agree_with_and_without_the_compiled_step(monkeypatch: pytest.MonkeyPatch) -> None:
    t = np.linspace(0.0, 2.0, 25)
    rng = np.random.default_rng(4)
    truth = rng.uniform(0.5, 2.0, (30, 3))
    data = truth[:, :1] * np.exp(-truth[:, 1:2] * t) + truth[:, 2:]

    def residuals(x: np.ndarray, which: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        e = np.exp(-x[:, 1:2] * t)
        r = x[:, :1] * e + x[:, 2:] - data[which]
        return r, np.stack([e, -x[:, :1] * t * e, np.ones_like(e)], axis=-1)

    x0 = np.tile([1.0, 1.0, 1.0], (30, 1))
    fast, ref = _both(monkeypatch, residuals, x0, [0.0, 0.0, 0.0], [1.5, 3.0, 3.0],
                      jacobian=True)
    np.testing.assert_allclose(fast.x, ref.x, rtol=1e-8, atol=1e-10)
    np.testing.assert_array_equal(fast.converged, ref.converged)
    assert (fast.x[:, 0] <= 1.5).all() and np.isclose(fast.x[:, 0], 1.5).any()


def test_the_kernels_see_c_ordered_arrays_whatever_the_start(monkeypatch: pytest.MonkeyPatch
                                                             ) -> None:
    """A start in Fortran order (a transposed sample, say) is copied to C order: the kernels,
    typed by the arrays' layouts, then have one signature each, loaded from numba's cache once
    per process (a first CLI command paid a second load of each)."""
    from numba import typeof

    fast = compiled.kernels()
    assert fast is not None
    layouts: set[str] = set()

    def spy(kernel: object) -> object:
        def call(*args: object) -> object:
            layouts.update(typeof(a).layout for a in args if isinstance(a, np.ndarray))
            return kernel(*args)  # type: ignore[operator]
        return call

    monkeypatch.setattr(compiled, "kernels",
                        lambda: compiled.Kernels(spy(fast.propose), spy(fast.accept)))

    def residuals(x: F, which: F) -> F:
        return x[:, :1] * np.exp(-x[:, 1:] * T) - 2.0 * np.exp(-0.5 * T)

    start = np.asfortranarray(np.tile([1.0, 1.0], (8, 1)))
    assert not start.flags.c_contiguous
    fit = fit_batch(residuals, start, [0.0, 0.0], [10.0, 10.0])
    assert layouts == {"C"}
    np.testing.assert_allclose(fit.x, [[2.0, 0.5]] * 8, rtol=1e-6)
