"""fit_batch's options for the read-outs: a feasible set within the box (project=), an absolute
tolerance on the cost (atol=), a caller's JᵀJ with a cached Jacobian, and 2 × 2 systems."""

from __future__ import annotations

import numpy as np
import pytest

from magcilia.fitting import fit_batch
from magcilia.fitting.levenberg_marquardt import _solve


def _disc(x: np.ndarray, _which: np.ndarray) -> np.ndarray:
    r = np.hypot(x[:, 0], x[:, 1])
    return x * np.where(r > 1.0, 1.0 / np.maximum(r, 1e-300), 1.0)[:, None]


def test_project_keeps_the_fit_in_a_disc_and_ends_on_its_edge() -> None:
    targets = np.array([[3.0, 4.0], [0.3, -0.2], [-2.0, 0.0]])  # two outside the unit disc

    def residuals(x: np.ndarray, which: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        return x - targets[which], np.broadcast_to(np.eye(2), (len(x), 2, 2))

    seen: list[np.ndarray] = []

    def project(x: np.ndarray, which: np.ndarray) -> np.ndarray:
        out = _disc(x, which)
        seen.append(out)
        return out

    fit = fit_batch(residuals, np.zeros((3, 2)), [-5.0, -5.0], [5.0, 5.0], jacobian=True,
                    project=project)
    np.testing.assert_allclose(fit.x, [[0.6, 0.8], [0.3, -0.2], [-1.0, 0.0]], atol=1e-9)
    assert fit.converged.all()
    assert all(np.all(np.hypot(*s.T) <= 1.0 + 1e-12) for s in seen)  # never left the disc


def test_atol_stops_on_a_small_change_of_the_cost_either_way() -> None:
    t = np.linspace(0.0, 1.0, 30)
    data = 2.0 * np.exp(-3.0 * t) + 0.01 * np.random.default_rng(0).standard_normal(30)

    def residuals(x: np.ndarray, which: np.ndarray) -> np.ndarray:
        return x[:, :1] * np.exp(-x[:, 1:] * t) - data

    tight = fit_batch(residuals, [[1.0, 1.0]], [0.0, 0.0], [10.0, 10.0])
    loose = fit_batch(residuals, [[1.0, 1.0]], [0.0, 0.0], [10.0, 10.0], ftol=0.0, xtol=0.0,
                      atol=1e-6)
    assert loose.converged.all() and loose.iterations[0] <= tight.iterations[0]
    assert loose.cost[0] - tight.cost[0] < 1e-5  # within a few atol of the minimum
    np.testing.assert_allclose(loose.x, tight.x, rtol=1e-2)


def test_a_cached_gram_matrix_gives_the_same_fit() -> None:
    t = np.linspace(0.0, 1.0, 20)
    data = np.array([[2.0], [1.0]]) * np.exp(-np.array([[3.0], [0.5]]) * t)

    def residuals(x: np.ndarray, which: np.ndarray) -> np.ndarray:
        return x[:, :1] * np.exp(-x[:, 1:] * t) - data[which]

    def jacobian(x: np.ndarray, which: np.ndarray) -> np.ndarray:
        e = np.exp(-x[:, 1:] * t)
        return np.stack([e, -x[:, :1] * t * e], axis=-1)

    def with_gram(x: np.ndarray, which: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        j = jacobian(x, which)
        return j, np.einsum("sap,saq->spq", j, j)

    plain = fit_batch(residuals, [[1.0, 1.0]] * 2, [0.0, 0.0], [10.0, 10.0], jacobian=jacobian)
    cached = fit_batch(residuals, [[1.0, 1.0]] * 2, [0.0, 0.0], [10.0, 10.0],
                       jacobian=with_gram)
    np.testing.assert_allclose(cached.x, plain.x, rtol=1e-12)
    np.testing.assert_allclose(cached.x, [[2.0, 3.0], [1.0, 0.5]], rtol=1e-8)


@pytest.mark.parametrize("size", [2, 3])
def test_small_systems_match_lapack_and_singular_ones_give_zero(size: int) -> None:
    rng = np.random.default_rng(size)
    a = rng.standard_normal((50, size, size)) + 3.0 * np.eye(size)
    b = rng.standard_normal((50, size))
    np.testing.assert_allclose(_solve(a, b), np.linalg.solve(a, b[:, :, None])[:, :, 0],
                               rtol=1e-10, atol=1e-12)
    a[7] = 0.0
    assert np.all(_solve(a, b)[7] == 0.0)
