"""A measured profile of any point count bends at a bounded cost (magcilia.mechanics.sections):
few points keep the exact knot grid (bit for bit as before), many are resampled onto at most
MAX_NODES nodes with each node's cell means of 1/I, r and r², and agree with the exact small-load
compliance and with the exact grid where that can still be solved."""

from __future__ import annotations

import importlib
import tracemalloc
from collections.abc import Callable

import numpy as np
import pytest

import magcilia as mc
from magcilia.device.cilium import MAX_PROFILE_POINTS
from magcilia.mechanics.sections import MAX_NODES, RESAMPLED_NODES, sections

bend_module = importlib.import_module("magcilia.mechanics.bend")  # the package shadows it
planar_module = importlib.import_module("magcilia.mechanics.planar")  # where _static lives

L, RB, E = 3e-3, 2e-4, 2e6


def measured(points: int, *, noise: float = 0.01, tip: float = 0.25, seed: int = 0) -> mc.Setup:
    """A tapered cilium measured at ``points`` radii: a cone with a 5 % waviness and ``noise``
    (relative) measurement noise on every radius."""
    rng = np.random.default_rng(seed)
    s = np.linspace(0.0, L, points)
    r = RB * (1 - (1 - tip) * s / L) * (1 + 0.05 * np.sin(6 * s / L))
    r *= 1 + noise * rng.standard_normal(points)
    r[0] = RB
    return mc.Setup.paper(cilium=mc.Cilium.from_profile(s, r, youngs_modulus=E))


def test_few_points_keep_the_exact_grid() -> None:
    setup = measured(12)
    sec = sections(setup.cilium, L, True, None)
    assert not sec.resampled
    knots = np.asarray(setup.cilium.profile[0]) * L
    assert np.allclose(sec.grid.bounds, knots, rtol=0, atol=1e-15)
    assert np.array_equal(sec.second_moment, setup.cilium.second_moment(sec.grid.s))


@pytest.mark.parametrize("points", [200, 1000, MAX_PROFILE_POINTS])
def test_many_points_are_resampled_within_max_nodes(points: int) -> None:
    setup = measured(points)
    sec = sections(setup.cilium, L, True, None)
    assert sec.resampled and sec.grid.s.size <= MAX_NODES
    assert set(sec.grid.sizes) == {RESAMPLED_NODES}
    # each node's compliance is its cell's mean: the quadrature of 1/I is exact
    assert np.sum(sec.grid.w / sec.second_moment) == pytest.approx(
        _integral(setup, np.ones_like), rel=1e-12)


def _integral(setup: mc.Setup, weight: Callable[[np.ndarray], np.ndarray]) -> float:
    """∫ weight(s) / I(s) ds over the cilium, by Gauss–Legendre on each knot interval."""
    c = setup.cilium
    knots = np.asarray(c.profile[0]) * c.height
    x, wq = np.polynomial.legendre.leggauss(12)
    a, b = knots[:-1, None], knots[1:, None]
    s = 0.5 * (a + b) + 0.5 * (b - a) * x
    return float(np.sum(0.5 * (b - a) * wq * weight(s) / c.second_moment(s)))


@pytest.mark.parametrize("points", [1000, MAX_PROFILE_POINTS])
def test_a_small_load_matches_the_exact_compliance(points: int) -> None:
    setup = measured(points)
    force = 1e-9
    tip = bend_module.bend(setup, force=force).tip[0]
    assert tip / force == pytest.approx(bend_module.tip_compliance(setup), rel=1e-4)


def test_a_large_load_matches_the_exact_grid() -> None:
    """60 points: the exact knot grid (1416 nodes) is still solvable; the resampled one agrees."""
    setup = measured(60)
    resampled = bend_module.bend(setup, force=3e-4)
    assert sections(setup.cilium, L, True, None).resampled
    big = MAX_NODES * 4
    try:
        planar_module.sections.cache_clear()
        planar_module._static.cache_clear()
        with pytest.MonkeyPatch.context() as mp:
            mp.setattr("magcilia.mechanics.sections.MAX_NODES", big)
            exact = bend_module.bend(setup, force=3e-4)
            assert not sections(setup.cilium, L, True, None).resampled
    finally:
        planar_module.sections.cache_clear()
        planar_module._static.cache_clear()
    assert resampled.nodes <= MAX_NODES < exact.nodes
    assert np.linalg.norm(resampled.tip - exact.tip) <= 2e-5 * np.linalg.norm(exact.tip)


def test_sharp_tip_and_point_load_below_it() -> None:
    rng = np.random.default_rng(1)
    s = np.linspace(0.0, L, 500)
    r = RB * (1 - s / L) * (1 + 0.005 * rng.standard_normal(500))
    r[0], r[-1] = RB, 0.0
    setup = mc.Setup.paper(cilium=mc.Cilium.from_profile(s, r, youngs_modulus=E))
    sec = sections(setup.cilium, 0.6 * L, True, None)
    assert sec.resampled and np.all(np.isfinite(sec.second_moment))
    assert np.any(np.isclose(sec.grid.bounds, 0.6 * L, rtol=0, atol=1e-15))
    shape = bend_module.bend(setup, force=1e-4, at=0.6 * L)
    assert np.all(np.isfinite(shape.points)) and shape.nodes <= MAX_NODES


def test_bend_at_the_point_limit_costs_what_a_shorter_profile_does() -> None:
    """The documented limit (MAX_PROFILE_POINTS) in counted work (nodes) and memory (the
    tracemalloc peak of the bend, NumPy's arrays included): as for 200 points."""

    def cost(points: int) -> tuple[int, int]:
        setup = measured(points)
        planar_module._static.cache_clear()
        planar_module.sections.cache_clear()
        tracemalloc.start()
        try:
            shape = bend_module.bend(setup, force=3e-4)
            return shape.nodes, tracemalloc.get_traced_memory()[1]
        finally:
            tracemalloc.stop()

    nodes, memory = cost(MAX_PROFILE_POINTS)
    few_nodes, few_memory = cost(200)
    assert nodes == few_nodes <= MAX_NODES
    assert memory < 40e6  # bytes (the (24·N)² matrix of every knot would be ~460 GB)
    assert memory < 1.5 * few_memory


def test_nodes_per_piece_are_bounded() -> None:
    setup = mc.Setup.paper(tip_radius=5e-5, youngs_modulus=E)
    with pytest.raises(mc.MagciliaError, match="nodes must be at most 400"):
        bend_module.bend(setup, force=1e-4, nodes=401)
    with pytest.raises(mc.MagciliaError, match="nodes must be at most 400"):
        bend_module.bend_sweep(setup, forces=[1e-4], nodes=10**6)
