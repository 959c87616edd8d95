"""The compiled damped step of ``fit_batch`` (``magcilia.fitting.compiled``) against its NumPy
reference: the same steps (bounds held, singular and non-finite systems), the same fits."""

from __future__ import annotations

import numpy as np
import pytest

from magcilia.fitting import compiled, fit_batch
from magcilia.fitting.levenberg_marquardt import _damped_steps


def _systems(seed: int, size: int = 40, dims: int = 5) -> tuple[np.ndarray, ...]:
    rng = np.random.default_rng(seed)
    jac = rng.standard_normal((size, 12, dims)) * rng.uniform(0.1, 10.0, (size, 1, dims))
    r = rng.standard_normal((size, 12))
    jtj = np.einsum("sap,saq->spq", jac, jac)
    jtr = np.einsum("sap,sa->sp", jac, r)
    lam = 10.0 ** rng.uniform(-6, 2, size)
    x = rng.uniform(-1.0, 1.0, (size, dims))
    lo, hi = np.full(dims, -1.0), np.full(dims, 1.0)
    x[::3, 0], x[1::3, 2] = -1.0, 1.0  # on a bound: some steps point outward and are held
    return jac, r, jtj, jtr, lam, x, lo, hi


def test_numba_is_available_here() -> None:
    assert compiled.kernels() is not None


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_compiled_steps_match_the_numpy_reference(seed: int) -> None:
    jac, r, jtj, jtr, lam, x, lo, hi = _systems(seed)
    jtj[5] = 0.0  # a singular system: zero step, as the NumPy path
    jtj[7, 1, 1] = np.nan  # a non-finite one: not ok, zero step
    ref, ok_ref = _damped_steps(jtj, jtr, lam, x, lo, hi)
    fast = compiled.kernels()
    assert fast is not None
    delta, ok = np.empty_like(x), np.empty(x.shape[0], dtype=bool)
    fast.damped_steps(jtj, jtr, lam, x, lo[None], hi[None], delta, ok)
    np.testing.assert_array_equal(ok, ok_ref)
    assert not ok[7] and not delta[7].any() and not delta[5].any()
    scale = np.abs(ref).max(axis=1, keepdims=True) + 1e-300
    assert (np.abs(delta - ref) <= 1e-10 * scale).all()
    held = ((x <= lo) & (ref < 0.0)) | ((x >= hi) & (ref > 0.0))
    assert not held.any()  # the second solve left the held parameters at their bound
    # per-problem bounds, and the normal equations from cached Jacobians of some problems
    delta2 = np.empty_like(x)
    fast.damped_steps(jtj, jtr, lam, x, np.tile(lo, (x.shape[0], 1)),
                      np.tile(hi, (x.shape[0], 1)), delta2, ok)
    np.testing.assert_array_equal(delta2, delta)
    idx = np.array([3, 0, 9])
    g, b = np.empty((3, 5, 5)), np.empty((3, 5))
    fast.normal_rows(jac, r, idx, g, b)
    np.testing.assert_allclose(g, jtj[idx], rtol=1e-12)
    np.testing.assert_allclose(b, jtr[idx], rtol=1e-12, atol=1e-12 * np.abs(jtr).max())


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
    fast = fit_batch(residuals, x0, [0.0, 0.0, 0.0], [1.5, 3.0, 3.0], jacobian=True)
    monkeypatch.setattr(compiled, "ENABLED", False)
    ref = fit_batch(residuals, x0, [0.0, 0.0, 0.0], [1.5, 3.0, 3.0], jacobian=True)
    np.testing.assert_allclose(fast.x, ref.x, rtol=1e-8, atol=1e-10)
    np.testing.assert_array_equal(fast.converged, ref.converged)
    assert (fast.x[:, 0] <= 1.5).all() and np.isclose(fast.x[:, 0], 1.5).any()  # a bound held
