"""The normal equations of small dense problems, formed entry by entry (fitting/_normal)."""

from __future__ import annotations

import numpy as np
import pytest

from magcilia.fitting import levenberg_marquardt as lm


@pytest.mark.parametrize("dims", [1, 2, 3, 4, 5])
def test_small_and_batched_matmul_paths_agree(dims: int, monkeypatch: pytest.MonkeyPatch) -> None:
    rng = np.random.default_rng(dims)
    jac = rng.normal(size=(50, 7, dims))
    r = rng.normal(size=(50, 7))
    jtj, jtr = lm._normal(jac, r)
    np.testing.assert_allclose(jtj, np.einsum("sai,saj->sij", jac, jac), rtol=1e-13, atol=1e-13)
    np.testing.assert_allclose(jtr, np.einsum("sai,sa->si", jac, r), rtol=1e-13, atol=1e-13)
    monkeypatch.setattr(lm, "SMALL_GRAM", 0)  # every size through the batched matmul
    big = lm._normal(jac, r)
    np.testing.assert_allclose(jtj, big[0], rtol=1e-13, atol=1e-13)
    np.testing.assert_allclose(jtr, big[1], rtol=1e-13, atol=1e-13)
    # a Gram matrix kept by the caller is returned as given, Jᵀr computed
    kept = np.ones((50, dims, dims))
    got = lm._normal((jac, kept), r)
    np.testing.assert_array_equal(got[0], kept)
    np.testing.assert_allclose(got[1], jtr, rtol=1e-13, atol=1e-13)


@pytest.mark.parametrize("width", [1, 2, 5, 16, 17])
def test_row_reductions_column_by_column_match_numpys(width: int) -> None:
    rng = np.random.default_rng(width)
    a = rng.normal(size=(40, width))
    a[3, 0] = np.nan  # NaN propagates as in ndarray.max
    a[5, -1] = np.inf
    np.testing.assert_array_equal(lm._row_max(a), a.max(axis=1))
    b = rng.uniform(size=(40, width)) < 0.7
    b[0], b[1] = True, False
    np.testing.assert_array_equal(lm._row_all(b), b.all(axis=1))
    np.testing.assert_array_equal(lm._row_any(b), b.any(axis=1))
