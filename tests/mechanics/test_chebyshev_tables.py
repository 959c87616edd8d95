"""The shipped Chebyshev references (:mod:`magcilia.mechanics.chebyshev_tables`) are the closed
forms' (recomputed here; ``test_newton_point`` checks both against NumPy's polynomial module), a
missing or damaged file falls back to the closed forms, and a bend is the same either way."""

from __future__ import annotations

import math
from collections.abc import Iterator
from pathlib import Path

import numpy as np
import pytest

import magcilia as mc
from magcilia.mechanics import chebyshev_tables as tables
from magcilia.mechanics import elastica, planar, sections

L = 3.0e-3


def _clear() -> None:
    for cached in (tables.read, planar._static, sections.sections, elastica._grid,
                   elastica._reference, elastica._coefficients, elastica._uniform_reference):
        cached.cache_clear()


@pytest.fixture
def fresh_caches() -> Iterator[None]:
    _clear()
    yield
    _clear()


@pytest.mark.parametrize("n", sorted(tables.SHIPPED))
def test_shipped_tables_are_the_closed_forms(n: int) -> None:
    m = tables.SHIPPED[n]
    shipped = tables.read(n)
    assert shipped is not None, f"{tables.path(n, m)} missing: run scripts/chebyshev_tables.py"
    closed = (*elastica._closed_reference(n), elastica._closed_uniform_reference(n, m))
    for got, want in zip(shipped, closed, strict=True):
        assert got.shape == want.shape
        assert not got.flags.writeable
        np.testing.assert_allclose(got, want, rtol=0, atol=2e-15)
    assert np.all(np.diff(shipped[0]) > 0.0)  # ascending nodes
    assert math.isclose(float(np.sum(shipped[2])), 2.0, rel_tol=1e-14)  # ∫_{-1}^{1} 1


def test_counts_not_shipped_are_computed() -> None:
    assert tables.read(33) is None
    nodes, at_nodes, weights = elastica._reference(33)
    assert nodes.shape == weights.shape == (33,) and at_nodes.shape == (33, 33)


@pytest.mark.parametrize("damage", ["missing", "short", "long"])
def test_a_missing_or_damaged_file_falls_back_to_the_closed_forms(
        damage: str, tmp_path: Path, monkeypatch: pytest.MonkeyPatch,
        fresh_caches: None) -> None:
    n = min(tables.SHIPPED)
    good = Path(tables.path(n, tables.SHIPPED[n]))
    if damage != "missing":
        data = good.read_bytes()
        (tmp_path / good.name).write_bytes(data[:-8] if damage == "short" else data + data[:8])
    monkeypatch.setattr(tables, "FOLDER", str(tmp_path))
    assert tables.read(n) is None
    np.testing.assert_array_equal(elastica._reference(n)[1], elastica._closed_reference(n)[1])


def test_a_bend_is_the_same_from_the_shipped_tables_and_the_closed_forms(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch, fresh_caches: None) -> None:
    setup = mc.Setup.paper(height=L, base_radius=2e-4, tip_radius=5e-5, youngs_modulus=2e6)
    force = 2e6 * math.pi * (2e-4) ** 4 / 4.0 / L**2
    shipped = mc.bend(setup, force=force)
    assert shipped.nodes in tables.SHIPPED  # the cilium: a shipped count
    _clear()
    monkeypatch.setattr(tables, "FOLDER", str(tmp_path))  # nothing there: the closed forms
    closed = mc.bend(setup, force=force)
    np.testing.assert_allclose(shipped.points, closed.points, rtol=0, atol=1e-13 * L)
    np.testing.assert_allclose(shipped.angles, closed.angles, rtol=0, atol=1e-12)
