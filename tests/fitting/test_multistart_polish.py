"""The multistart (Latin hypercube, successive halving) and the one ``least_squares`` polish."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.optimize import least_squares

from magcilia import MagciliaError
from magcilia.fitting import fit_batch, halving, latin_hypercube, multistart, polish

F = np.ndarray
T = np.linspace(0.0, 3.0, 25)


def decay(x: F) -> F:
    return x[:, 0:1] * np.exp(-x[:, 1:2] * T) + x[:, 2:3]


# -- a problem with many basins: r = (sin(3 x) + 0.3 x, y − 1); global minimum near x = −0.43 --
def wavy(x: F, which: F) -> F:
    return np.stack([np.sin(3.0 * x[:, 0]) + 0.3 * x[:, 0] + 0.9, x[:, 1] - 1.0], axis=1)


def _global_wavy() -> float:
    grid = np.linspace(-4.0, 4.0, 200_001)
    return float(np.min((np.sin(3.0 * grid) + 0.3 * grid + 0.9) ** 2))


def test_latin_hypercube_is_stratified() -> None:
    pts = latin_hypercube(50, np.array([0.0, -1.0]), np.array([1.0, 1.0]),
                          np.random.default_rng(3))
    assert pts.shape == (50, 2)
    for j, (lo, hi) in enumerate([(0.0, 1.0), (-1.0, 1.0)]):
        slabs = np.floor((pts[:, j] - lo) / (hi - lo) * 50).astype(int)
        np.testing.assert_array_equal(np.sort(slabs), np.arange(50))


def test_multistart_finds_the_global_minimum_that_one_start_misses() -> None:
    lower, upper = [-4.0, -4.0], [4.0, 4.0]
    one = fit_batch(wavy, [[3.5, 0.0]], lower, upper)
    found = multistart(wavy, lower, upper, starts=64, rng=0)
    best = _global_wavy()
    assert one.cost[0] > best + 0.1  # a local minimum
    assert found.cost[0] == pytest.approx(best, abs=1e-9)
    assert np.all(np.diff(found.cost) >= 0)  # best first
    assert found.x[0, 1] == pytest.approx(1.0)
    again = multistart(wavy, lower, upper, starts=64, rng=0)
    np.testing.assert_array_equal(again.x, found.x)  # the rng makes it repeat


def test_multistart_keeps_the_given_starts() -> None:
    # one start given at the global minimum's basin and a single survivor: it is kept
    found = multistart(wavy, [-4.0, -4.0], [4.0, 4.0], starts=4, rng=1,
                       x0=[-0.45, 0.9], survivors=4, round_iterations=1)
    assert found.cost[0] == pytest.approx(_global_wavy(), abs=1e-9)


def test_halving_keeps_each_row_its_own_problem() -> None:
    # row i of the starts fits to its own target: the survivors report their rows
    rng = np.random.default_rng(4)
    targets = rng.uniform(-1.0, 1.0, (40, 2))
    x0 = rng.uniform(-2.0, 2.0, (40, 2))
    seen: set[int] = set()

    def residuals(x: F, which: F) -> F:
        seen.update(int(w) for w in which)
        return np.c_[x - targets[which], 0.1 * (np.abs(x0[which]).sum(axis=1))]

    fits, rows = halving(residuals, x0, [-3.0, -3.0], [3.0, 3.0], survivors=5)
    assert rows.size == 5 and seen == set(range(40))
    np.testing.assert_allclose(fits.x, targets[rows], atol=1e-8)
    # the survivors are the starts whose constant residual (their |x0|) is smallest
    kept = np.sort(np.argsort(np.abs(x0).sum(axis=1))[:5])
    np.testing.assert_array_equal(np.sort(rows), kept)


def test_bad_multistart_input_is_a_one_line_error() -> None:
    with pytest.raises(MagciliaError, match="starts"):
        multistart(wavy, [-1.0, -1.0], [1.0, 1.0], starts=0)
    with pytest.raises(MagciliaError, match="finite bounds"):
        multistart(wavy, [-1.0, -np.inf], [1.0, 1.0], starts=4)


# -- polish ----------------------------------------------------------------------------------
LOWER, UPPER = np.array([0.0, 0.0, -5.0]), np.array([10.0, 10.0, 5.0])


def _data(seed: int) -> F:
    rng = np.random.default_rng(seed)
    return decay(np.array([[1.3, 1.7, 0.2]])) + 0.01 * rng.standard_normal((1, T.size))


def test_polish_is_scipy_least_squares() -> None:
    data = _data(0)
    start = np.array([1.1, 1.5, 0.1])
    fit = polish(lambda x, w: decay(x) - data[w], start, LOWER, UPPER)
    ref = least_squares(lambda p: decay(p[None])[0] - data[0], start, bounds=(LOWER, UPPER),
                        x_scale=UPPER - LOWER, method="trf", xtol=1e-12, ftol=1e-14, gtol=1e-12,
                        max_nfev=200)
    np.testing.assert_allclose(fit.x[0], ref.x, rtol=1e-10)
    assert fit.cost[0] == pytest.approx(2 * ref.cost, rel=1e-10)
    assert fit.converged[0] and fit.evaluations[0] >= ref.nfev
    np.testing.assert_allclose(fit.jtj[0], ref.jac.T @ ref.jac, rtol=1e-10)


@pytest.mark.parametrize("mode", ["callable", "with residuals"])
def test_polish_takes_analytic_jacobians(mode: str) -> None:
    data = _data(1)

    def jac(x: F, which: F) -> F:
        e = np.exp(-x[:, 1:2] * T)
        return np.stack([e, -x[:, 0:1] * T * e, np.ones_like(e)], axis=-1)

    res = (lambda x, w: decay(x) - data[w]) if mode == "callable" else (
        lambda x, w: (decay(x) - data[w], jac(x, w)))
    fit = polish(res, [1.0, 1.0, 0.0], LOWER, UPPER, jacobian=jac if mode == "callable" else True)
    plain = polish(lambda x, w: decay(x) - data[w], [1.0, 1.0, 0.0], LOWER, UPPER)
    np.testing.assert_allclose(fit.x, plain.x, rtol=1e-6)
    assert fit.converged[0]


def test_polish_holds_parameters_with_equal_bounds_and_polishes_rows_apart() -> None:
    data = np.concatenate([_data(2), _data(3)])
    lower = np.array([[0.0, 0.0, 0.2], [0.0, 1.7, -5.0]])
    upper = np.array([[10.0, 10.0, 0.2], [10.0, 1.7, 5.0]])
    fit = polish(lambda x, w: decay(x) - data[w], [[1.0, 1.0, 0.2], [1.0, 1.7, 0.0]],
                 lower, upper)
    assert fit.x[0, 2] == 0.2 and fit.x[1, 1] == 1.7
    ref = least_squares(lambda p: decay(np.r_[p, 0.2][None])[0] - data[0], [1.0, 1.0],
                        bounds=([0.0, 0.0], [10.0, 10.0]), xtol=1e-14, ftol=1e-15, gtol=1e-15)
    np.testing.assert_allclose(fit.x[0, :2], ref.x, rtol=1e-6)
    assert np.all(fit.jtj[0, 2] == 0.0)  # the held parameter's row


def test_polish_survives_non_finite_residuals_and_never_worsens() -> None:
    data = _data(4)

    def residuals(x: F, which: F) -> F:
        r = decay(x) - data[which]
        r[x[:, 1] > 1.5] = np.nan  # the optimum (b = 1.7) lies in the bad region
        return r

    start = np.array([1.0, 1.0, 0.0])
    fit = polish(residuals, start, LOWER, UPPER)
    start_cost = float(np.sum(residuals(start[None], np.array([0])) ** 2))
    assert np.isfinite(fit.cost[0]) and fit.cost[0] <= start_cost and fit.x[0, 1] <= 1.5
    # a start where nothing is finite: kept, with an infinite cost
    bad = polish(residuals, [1.0, 2.0, 0.0], LOWER, UPPER)
    assert bad.cost[0] == np.inf
