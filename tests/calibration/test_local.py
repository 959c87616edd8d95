"""The batched Levenberg–Marquardt of the calibration against SciPy's least_squares."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.optimize import least_squares

from magcilia.calibration.local import levenberg_marquardt
from magcilia.calibration.multistart import latin_hypercube

T = np.linspace(0.0, 3.0, 25)


def _model(x: np.ndarray) -> np.ndarray:
    """a · exp(−b t) + c for rows x = (a, b, c): shape (m, 25)."""
    return x[:, 0:1] * np.exp(-x[:, 1:2] * T) + x[:, 2:3]


def test_independent_problems_solved_as_least_squares_does() -> None:
    rng = np.random.default_rng(0)
    truths = rng.uniform([0.5, 0.2, -1.0], [2.0, 3.0, 1.0], (12, 3))
    data = _model(truths) + 0.01 * rng.standard_normal((12, T.size))
    lower, upper = np.array([0.0, 0.0, -5.0]), np.array([10.0, 10.0, 5.0])
    fits = levenberg_marquardt(lambda x, which: _model(x) - data[which],
                               np.tile([1.0, 1.0, 0.0], (12, 1)), lower, upper)
    for i in range(12):
        ref = least_squares(lambda p, i=i: _model(p[None])[0] - data[i], [1.0, 1.0, 0.0],
                            bounds=(lower, upper), xtol=1e-14, ftol=1e-14, gtol=1e-14)
        assert fits.cost[i] == pytest.approx(2 * ref.cost, rel=1e-8)
        np.testing.assert_allclose(fits.x[i], ref.x, rtol=1e-5, atol=1e-8)


def test_a_bound_holds_and_the_rest_still_converges() -> None:
    # the unconstrained optimum has b = 2; with b <= 1 the fit ends on that bound, and a, c take
    # the constrained optimum (least_squares' answer)
    data = _model(np.array([[1.5, 2.0, 0.3]]))
    lower, upper = np.array([0.0, 0.0, -5.0]), np.array([10.0, 1.0, 5.0])
    fits = levenberg_marquardt(lambda x, which: _model(x) - data[which],
                               np.array([[1.0, 0.5, 0.0]]), lower, upper)
    ref = least_squares(lambda p: _model(p[None])[0] - data[0], [1.0, 0.5, 0.0],
                        bounds=(lower, upper), xtol=1e-14, ftol=1e-14, gtol=1e-14)
    assert fits.x[0, 1] == 1.0
    assert fits.cost[0] == pytest.approx(2 * ref.cost, rel=1e-7)


def test_non_finite_points_are_never_accepted() -> None:
    # residuals are NaN for b > 1.2: the fit stays in the finite region, and a problem that
    # starts there (no finite residual) is left alone with an infinite cost
    data = _model(np.array([[1.0, 2.0, 0.0]]))[0]

    def resid(x: np.ndarray, which: np.ndarray) -> np.ndarray:
        r = _model(x) - data
        r[x[:, 1] > 1.2] = np.nan
        return r

    fits = levenberg_marquardt(resid, np.array([[1.0, 0.5, 0.0], [1.0, 1.5, 0.0]]),
                               np.zeros(3), np.full(3, 5.0))
    assert np.isfinite(fits.cost[0]) and fits.x[0, 1] <= 1.2
    assert fits.cost[1] == np.inf
    np.testing.assert_array_equal(fits.x[1], [1.0, 1.5, 0.0])


def test_latin_hypercube_is_stratified() -> None:
    pts = latin_hypercube(50, np.array([0.0, -1.0]), np.array([1.0, 1.0]), np.random.default_rng(3))
    assert pts.shape == (50, 2)
    for j, (lo, hi) in enumerate([(0.0, 1.0), (-1.0, 1.0)]):
        slabs = np.floor((pts[:, j] - lo) / (hi - lo) * 50).astype(int)
        np.testing.assert_array_equal(np.sort(slabs), np.arange(50))
