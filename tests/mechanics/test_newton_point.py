"""The fused Newton loop of a point force alone (``elastica._newton_point``, what every planar
point-force bend runs) against the reference iteration (``Problem.newton_step`` in the generic
loop), and the bend's caches: a first call in a process (every cache empty) gives what later
calls give, and the closed-form Chebyshev references match NumPy's polynomial module."""

from __future__ import annotations

import dataclasses
import math
import subprocess
import sys
import warnings

import numpy as np
import pytest
from numpy.polynomial import chebyshev as cheb

import magcilia as mc
from magcilia.mechanics import chebyshev_tables, elastica, planar, sections
from magcilia.mechanics.planar import _Case
from magcilia.mechanics.shape import BentShape

E = 2.0e6
L = 3.0e-3


class _Reference:
    """A :class:`elastica.Problem` seen only through the Steppable protocol: :func:`newton`
    runs its generic loop on ``Problem.newton_step`` (the reference) instead of the fused one."""

    def __init__(self, problem: elastica.Problem) -> None:
        self.problem = problem

    def residual(self, theta: np.ndarray, scale: float) -> np.ndarray:
        return self.problem.residual(theta, scale)

    def newton_step(self, theta: np.ndarray, scale: float, tol: float
                    ) -> tuple[float, np.ndarray | None]:
        return self.problem.newton_step(theta, scale, tol)


def _setup(taper: float) -> mc.Setup:
    return mc.Setup.paper(height=L, base_radius=2e-4, tip_radius=2e-4 * taper,
                          youngs_modulus=E)


CASES = [  # (taper, P L² / (E I₀), direction, at / L)
    (0.25, 1.0, 0.5 * math.pi, 1.0),  # the benchmark's
    (0.25, 0.01, 0.5 * math.pi, 1.0),
    (0.25, 30.0, 0.5 * math.pi, 1.0),
    (0.25, 10.0, 0.3, 1.0),  # pulling: F_z ≠ 0
    (0.25, 10.0, 2.5, 1.0),  # pushing
    (0.25, 3.0, -1.0, 1.0),  # toward −x
    (1.0, 3.0, 0.5 * math.pi, 0.6),  # a cylinder loaded below the tip (two pieces)
    (0.5, 2.0, 4.0, 1.0),
]


@pytest.mark.parametrize(("taper", "alpha", "direction", "at"), CASES)
def test_fused_newton_matches_the_reference_iteration(taper: float, alpha: float,
                                                      direction: float, at: float) -> None:
    setup = _setup(taper)
    force = alpha * E * math.pi * (2e-4) ** 4 / 4.0 / L**2
    case = _Case(setup, at * L, direction, True, None, None)
    problem = case.problem(force, 0.0)
    assert problem.point_only and problem.point is not None
    guess = case.guess(force, 0.0)
    fused = elastica.newton(problem, 1.0, guess)
    reference = elastica.newton(_Reference(problem), 1.0, guess)  # type: ignore[arg-type]
    assert fused is not None and reference is not None
    # both converge to residuals below 1e-12 rad: they agree to what that allows
    np.testing.assert_allclose(fused.theta, reference.theta, rtol=0, atol=1e-12)
    assert fused.residual < 1e-12 and reference.residual < 1e-12
    assert fused.iterations == reference.iterations  # the chord step costs no iteration


@pytest.mark.parametrize(("taper", "alpha", "direction", "at"), CASES)
def test_the_chord_step_costs_no_iteration(monkeypatch: pytest.MonkeyPatch, taper: float,
                                           alpha: float, direction: float, at: float) -> None:
    setup = _setup(taper)
    force = alpha * E * math.pi * (2e-4) ** 4 / 4.0 / L**2
    chord = mc.bend(setup, force=force, direction=direction, at=at * L)
    monkeypatch.setattr(elastica, "CHORD_RESIDUAL", 0.0)  # every step a full Newton step
    full = mc.bend(setup, force=force, direction=direction, at=at * L)
    assert chord.iterations == full.iterations
    np.testing.assert_allclose(chord.points, full.points, rtol=0, atol=1e-12 * L)


def test_a_non_finite_problem_is_refused() -> None:
    case = _Case(_setup(0.25), L, 0.5 * math.pi, True, None, None)
    problem = case.problem(float("nan"), 0.0)
    assert elastica.newton(problem, 1.0, np.zeros(case.grid.s.size)) is None
    guess = np.zeros(case.grid.s.size)
    guess[-1] = np.nan  # one bad node: idamax passes NaNs over, the loop must not
    assert elastica.newton(case.problem(1e-4, 0.0), 1.0, guess) is None


def _clear_caches() -> None:
    for cached in (chebyshev_tables.read, planar._static, sections.sections, elastica._grid,
                   elastica._reference, elastica._coefficients, elastica._uniform_reference):
        cached.cache_clear()


def test_a_first_call_gives_what_later_calls_give() -> None:
    setup = _setup(0.25)
    force = E * math.pi * (2e-4) ** 4 / 4.0 / L**2
    try:
        _clear_caches()
        first = mc.bend(setup, force=force)  # grids, references and maps built here
        later = mc.bend(setup, force=force)  # all from the caches
        swept = mc.bend_sweep(setup, forces=[force])
    finally:
        _clear_caches()
    np.testing.assert_array_equal(first.points, later.points)
    np.testing.assert_array_equal(first.angles, later.angles)
    assert (first.residual, first.iterations, first.nodes) == (
        later.residual, later.iterations, later.nodes)
    np.testing.assert_allclose(swept.points[0], first.points[0], rtol=0, atol=1e-12 * L)


@pytest.mark.parametrize("n", [4, 5, 24, 32, 34, 96])
def test_closed_form_references_match_numpy_polynomial(n: int) -> None:
    # the construction they replace: Chebyshev–Vandermonde inverse and chebint
    t = np.cos(np.pi * (2.0 * np.arange(n) + 1.0) / (2.0 * n))[::-1]
    vinv = np.linalg.inv(cheb.chebvander(t, n - 1))
    kv = cheb.chebint(np.eye(n), lbnd=-1.0, axis=0) @ vinv
    nodes, at_nodes, weights = elastica._reference(n)
    np.testing.assert_allclose(nodes, t, rtol=0, atol=1e-15)
    np.testing.assert_allclose(elastica._coefficients(n), vinv, rtol=0, atol=1e-14)
    np.testing.assert_allclose(at_nodes, cheb.chebvander(t, n) @ kv, rtol=0, atol=1e-14)
    np.testing.assert_allclose(weights, (cheb.chebvander(np.ones(1), n) @ kv)[0], rtol=0,
                               atol=1e-14)
    x = np.linspace(-1.0, 1.0, 129)
    np.testing.assert_allclose(elastica._uniform_reference(n, 129), cheb.chebvander(x, n) @ kv,
                               rtol=0, atol=1e-14)
    np.testing.assert_allclose(elastica._cumulative(n, x), cheb.chebvander(x, n) @ kv, rtol=0,
                               atol=1e-14)
    assert np.all(elastica._uniform_reference(n, 129)[0] == 0.0)  # ∫ from −1 to −1


def test_a_solved_shape_is_the_checked_constructor_s() -> None:
    shape = mc.bend(_setup(0.25), force=1e-4)
    checked = BentShape(shape.s, shape.angles, shape.points, load=shape.load,
                        residual=shape.residual, iterations=shape.iterations, nodes=shape.nodes)
    for f in dataclasses.fields(BentShape):
        mine, theirs = getattr(shape, f.name), getattr(checked, f.name)
        if isinstance(mine, np.ndarray):
            np.testing.assert_array_equal(mine, theirs)
            assert mine.dtype == np.float64 and not mine.flags.writeable
        else:
            assert mine == theirs
    assert repr(shape) == repr(checked) and shape.to_dict() == checked.to_dict()


def test_dense_solve_solves_and_refuses_a_singular_matrix() -> None:
    """The Newton steps' solver (NumPy's LAPACK): its answer satisfies the system to rounding,
    and it gives None, without a warning, for a singular matrix or a non-finite right-hand
    side (Newton then gives up on that start)."""
    rng = np.random.default_rng(3)
    a = rng.standard_normal((34, 34)) + 34.0 * np.eye(34)
    b = rng.standard_normal(34)
    got = elastica.dense_solve(a, b)
    assert got is not None
    np.testing.assert_allclose(a @ got, b, rtol=0.0, atol=1e-12)
    singular = a.copy()
    singular[:, 5] = 0.0  # exactly singular: a zero pivot
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        assert elastica.dense_solve(np.zeros((3, 3)), np.ones(3)) is None
        assert elastica.dense_solve(singular, b) is None
        assert elastica.dense_solve(a, np.full(34, np.nan)) is None


def test_a_first_bend_imports_no_scipy_linalg() -> None:
    """A planar bend in a fresh process solves its Newton steps with NumPy's LAPACK: importing
    scipy.linalg (~0.1 s) would be most of a first bend's time (issue 27 item 6)."""
    code = ("import sys, magcilia as mc\n"
            "s = mc.Setup.paper(height=3e-3, base_radius=2e-4, tip_radius=5e-5, "
            "youngs_modulus=2e6)\n"
            "tip = mc.bend(s, force=1e-4).tip\n"
            "print('scipy.linalg' in sys.modules, float(tip[0]))\n")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         check=True, timeout=120).stdout.split()
    assert out[0] == "False"
    assert float(out[1]) > 0.0


def test_a_force_along_an_axis_has_no_component_across_it() -> None:
    # cos(π/2) is 6e-17 in floating point: the default horizontal force must not carry it (the
    # fused loop's horizontal case), nor a vertical force sin(π)'s 1e-16
    assert planar.direction_unit(0.5 * math.pi) == (1.0, 0.0)
    assert planar.direction_unit(math.pi) == (0.0, -1.0)
    assert planar.direction_unit(-0.5 * math.pi) == (-1.0, 0.0)
    assert planar.direction_unit(0.3) == (math.sin(0.3), math.cos(0.3))
    case = _Case(_setup(0.25), L, 0.5 * math.pi, True, None, None)
    assert case.problem(1e-4, 0.0).force.tolist() == [1e-4, 0.0]
    tilted = mc.bend(_setup(0.25), force=1e-4, direction=0.5 * math.pi + 1e-9)
    level = mc.bend(_setup(0.25), force=1e-4)
    np.testing.assert_allclose(level.points, tilted.points, rtol=0, atol=1e-8 * L)
