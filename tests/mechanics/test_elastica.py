"""The static elastica solver against exact solutions: the uniform cantilever in elliptic
integrals (Bisshopp & Drucker), the tapered rod's small-load compliance, the moment balance of
the returned shape, symmetries and bad input."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.integrate import quad

import magcilia as mc
from magcilia.mechanics import cantilever_tip, elastica, tip_compliance
from magcilia.mechanics.planar import _Case

E = 2.0e6
L = 3.0e-3


def cylinder(radius: float = 1e-4, length: float = L, modulus: float = E) -> mc.Setup:
    return mc.Setup.paper(height=length, base_radius=radius, tip_radius=radius,
                          youngs_modulus=modulus, position=(1.5e-3, 2e-3, 0.4e-3))


def stiffness(setup: mc.Setup) -> float:
    return setup.youngs_modulus * float(setup.cilium.second_moment(0.0))


@pytest.mark.parametrize("alpha", [0.1, 1.0, 10.0])
def test_exact_reference_matches_direct_quadrature(alpha: float) -> None:
    # the elliptic-integral reference against a direct quadrature of the first integral
    # θ'² = 2α (sin θ0 − sin θ) (L = 1): x = ∫ sin θ / θ' dθ, 1 = ∫ dθ / θ'
    x, z, theta0 = cantilever_tip(alpha)

    def w(t: float) -> float:
        return 1.0 / math.sqrt(2.0 * alpha * (math.sin(theta0) - math.sin(t)))

    length = quad(w, 0.0, theta0, limit=200)[0]
    x_q = quad(lambda t: math.sin(t) * w(t), 0.0, theta0, limit=200)[0]
    z_q = quad(lambda t: math.cos(t) * w(t), 0.0, theta0, limit=200)[0]
    assert length == pytest.approx(1.0, rel=1e-7)
    assert x == pytest.approx(x_q, rel=1e-6)
    assert z == pytest.approx(z_q, rel=1e-6)


def test_exact_reference_limits_and_literature() -> None:
    assert cantilever_tip(0.0) == (0.0, 1.0, 0.0)
    x, _, theta0 = cantilever_tip(1e-4)
    assert x == pytest.approx(1e-4 / 3.0, rel=1e-6)  # linear theory
    assert theta0 == pytest.approx(0.5e-4, rel=1e-6)
    # Bisshopp & Drucker's table: alpha = 1 -> deflection 0.302 L, tip angle 26.4 deg
    x1, _, t1 = cantilever_tip(1.0)
    assert x1 == pytest.approx(0.302, abs=5e-4)
    assert math.degrees(t1) == pytest.approx(26.43, abs=0.01)


@pytest.mark.parametrize("alpha", [0.1, 0.3, 1.0, 3.0, 10.0])
def test_uniform_rod_matches_exact_elastica(alpha: float) -> None:
    setup = cylinder()
    force = alpha * stiffness(setup) / L**2
    shape = mc.bend(setup, force=force)
    x, z, theta0 = cantilever_tip(alpha)
    # issue target 1e-4 relative; the spectral solver does far better
    np.testing.assert_allclose(shape.tip, [x * L, 0.0, z * L], rtol=1e-8, atol=1e-12 * L)
    assert shape.tip_angle == pytest.approx(theta0, rel=1e-8)
    assert shape.residual < 1e-11


@pytest.mark.parametrize("taper", [0.25, 0.5, 1.0])
def test_tapered_small_load_compliance(taper: float) -> None:
    setup = mc.Setup.paper(height=L, base_radius=2e-4, tip_radius=2e-4 * taper, youngs_modulus=E)
    i0 = math.pi * (2e-4) ** 4 / 4.0
    expected = L**3 / (3.0 * E * i0 * taper)
    assert tip_compliance(setup) == pytest.approx(expected, rel=1e-12)
    force = 1e-5 * L / expected  # deflection 1e-5 L: nonlinear terms ~1e-10
    assert mc.bend(setup, force=force).deflection / force == pytest.approx(expected, rel=1e-7)


def test_zero_load_is_straight() -> None:
    shape = mc.bend(cylinder(), force=0.0)
    assert np.all(shape.angles == 0.0)
    np.testing.assert_array_equal(shape.points[0, :, 2], shape.s)
    np.testing.assert_array_equal(shape.tip, [0.0, 0.0, L])
    assert shape.tip_angle == 0.0


def test_shape_satisfies_moment_balance() -> None:
    # independent check of the returned shape: EI θ'(s) = F (z_tip − z(s)) for a +x tip force
    setup = mc.Setup.paper(height=L, base_radius=2e-4, tip_radius=5e-5, youngs_modulus=E)
    force = 1e-4
    shape = mc.bend(setup, force=force)
    s, th, pts = shape.s, shape.angles[0], shape.points[0]
    curvature = np.gradient(th, s, edge_order=2)
    ei = E * setup.cilium.second_moment(s)
    moment = force * (pts[-1, 2] - pts[:, 2])
    inner = slice(5, -5)
    np.testing.assert_allclose(ei[inner] * curvature[inner], moment[inner],
                               rtol=2e-3, atol=1e-4 * moment.max())
    # positions consistent with the angles: |dr/ds| = 1 (inextensible)
    ds = np.linalg.norm(np.diff(pts, axis=0), axis=1)
    np.testing.assert_allclose(ds, np.diff(s), rtol=1e-4)


def test_load_below_the_tip_leaves_the_rest_straight() -> None:
    setup = cylinder()
    a = 0.6 * L
    alpha = 2.0  # on the loaded length a
    force = alpha * stiffness(setup) / a**2
    shape = mc.bend(setup, force=force, at=a)
    x, z, theta0 = cantilever_tip(alpha)
    beyond = shape.s > a
    np.testing.assert_allclose(shape.angles[0, beyond], theta0, rtol=1e-8)
    tip_expected = np.array([x * a + (L - a) * math.sin(theta0), 0.0,
                             z * a + (L - a) * math.cos(theta0)])
    np.testing.assert_allclose(shape.tip, tip_expected, rtol=1e-8)


def test_symmetries_of_the_load() -> None:
    setup = cylinder()
    force = stiffness(setup) / L**2
    plus = mc.bend(setup, force=force)
    minus = mc.bend(setup, force=-force)
    np.testing.assert_allclose(minus.tip, plus.tip * [-1, 1, 1], rtol=1e-12)
    # a tensile load along the axis leaves the inextensible rod straight
    axial = mc.bend(setup, force=force, direction=0.0)
    np.testing.assert_allclose(axial.tip, [0.0, 0.0, L], atol=1e-15)
    # same alpha, other length and modulus: same normalised shape
    other = cylinder(length=2 * L, modulus=3 * E)
    scaled = mc.bend(other, force=force * 3 / 4)
    np.testing.assert_allclose(scaled.tip / (2 * L), plus.tip / L, rtol=1e-10)


def test_continuation_failure_reports_the_largest_converged_load(
        monkeypatch: pytest.MonkeyPatch) -> None:
    setup = cylinder()
    limit = 3.0 * stiffness(setup) / L**2  # pretend Newton fails above this load
    real = elastica.newton

    def failing(problem: elastica.Problem, scale: float, guess: np.ndarray,
                **kw: float) -> elastica.Solution | None:
        if np.linalg.norm(problem.force * scale) > limit:
            return None
        return real(problem, scale, guess, **kw)

    monkeypatch.setattr(elastica, "newton", failing)
    with pytest.raises(mc.MagciliaError, match=r"did not converge beyond F = ") as info:
        mc.bend(setup, force=2 * limit)
    reached = float(str(info.value).split("F = ")[1].split(" N")[0])
    assert 0.99 * limit <= reached <= limit * (1 + 1e-5)  # 6 significant digits
    assert "\n" not in str(info.value)


@pytest.mark.parametrize(
    ("make", "match"),
    [
        (lambda: mc.bend(mc.Setup.paper(), force=1e-4), "tip compliance is infinite"),
        (lambda: mc.bend(cylinder(), force=1e-4, at=2 * L), "at must be an arc length"),
        (lambda: mc.bend(cylinder(), force=float("nan")), "force must be a finite number"),
        (lambda: mc.Setup.paper(youngs_modulus=-2e6), "youngs_modulus must be a positive"),
        (lambda: mc.bend("paper", force=1e-4), "setup must be a magcilia.Setup"),  # type: ignore[arg-type]
    ],
    ids=["cone-tip-load", "at-beyond-tip", "nan-force", "negative-modulus", "not-a-setup"],
)
def test_bad_input(make: object, match: str) -> None:
    with pytest.raises(mc.MagciliaError, match=match):
        make()  # type: ignore[operator]


def test_cone_accepts_a_load_below_the_tip() -> None:
    cone = mc.Setup.paper(youngs_modulus=E)
    shape = mc.bend(cone, force=2e-5, at=0.8 * cone.cilium.height)
    assert shape.tip[0] > 0.0 and np.isfinite(shape.points).all()


def _tapered() -> mc.Setup:
    return mc.Setup.paper(height=L, base_radius=2e-4, tip_radius=5e-5, youngs_modulus=E)


def _path_followed(setup: mc.Setup, force: float, direction: float, steps: int = 200
                   ) -> mc.Centreline:
    """The load ramped up slowly (each solve continued from the last): the quasi-static path."""
    return mc.bend_sweep(setup, forces=np.linspace(0.0, force, steps), direction=direction)


@pytest.mark.parametrize(
    ("alpha", "direction"),
    [(0.01, 0.5 * math.pi), (1.0, 0.5 * math.pi), (30.0, 0.5 * math.pi), (10.0, 0.3),
     (10.0, -1.0), (10.0, 2.5), (30.0, 4.0)],
    ids=["small", "benchmark", "large", "pull", "negative", "push", "push-beyond-pi"],
)
def test_warm_start_gives_the_path_followed_solution(alpha: float, direction: float) -> None:
    # a single bend starts Newton from the saturated linear-beam guess; it must land on the
    # equilibrium that slow loading reaches (pushing loads have others that Newton from the
    # straight rod found before the warm start: tip on the wrong side of the load)
    setup = _tapered()
    force = alpha * E * math.pi * (2e-4) ** 4 / 4.0 / L**2
    warm = mc.bend(setup, force=force, direction=direction)
    slow = _path_followed(setup, force, direction)
    np.testing.assert_allclose(warm.points[0], slow.points[-1], rtol=0, atol=1e-10 * L)
    assert warm.residual < 1e-12
    assert warm.iterations <= 4


@pytest.mark.parametrize("direction", [0.5 * math.pi, 2.5], ids=["perpendicular", "push"])
def test_warm_and_cold_newton_agree(direction: float) -> None:
    # the same continuation from the straight rod with the guess (warm) and without it (cold)
    setup = _tapered()
    case = _Case(setup, L, direction, True, None, None)
    force = E * math.pi * (2e-4) ** 4 / 4.0 / L**2

    def at(lam: float) -> tuple[elastica.Problem, float]:
        return case.problem(force, 0.0), lam

    zero = np.zeros(case.grid.s.size)
    warm, _ = elastica.solve(at, 0.0, 1.0, zero, case.guess(force, 0.0))
    cold, _ = elastica.solve(at, 0.0, 1.0, zero)
    np.testing.assert_allclose(warm.theta, cold.theta, rtol=0, atol=1e-10)
    assert warm.iterations < cold.iterations  # 4 against 5


def test_sweep_predicts_each_load_from_its_neighbours(monkeypatch: pytest.MonkeyPatch) -> None:
    setup = _tapered()
    real = elastica.newton
    iterations: list[int] = []

    def counting(problem: elastica.Problem, scale: float, guess: np.ndarray,
                 **kw: float) -> elastica.Solution | None:
        sol = real(problem, scale, guess, **kw)
        iterations.append(-1 if sol is None else sol.iterations)
        return sol

    monkeypatch.setattr(elastica, "newton", counting)
    mc.bend_sweep(setup, forces=np.linspace(0.0, 2e-4, 513))  # a read-out table's sweep
    assert -1 not in iterations and len(iterations) == 512
    # one Newton step per load from the parabola through the last three solutions (two each
    # when each started from its neighbour's solution)
    assert max(iterations[3:]) == 1


def test_sweep_of_unordered_and_repeated_loads_matches_single_bends() -> None:
    setup = _tapered()
    f1 = E * math.pi * (2e-4) ** 4 / 4.0 / L**2
    forces = [1e-3 * f1, 1e-2 * f1, 10 * f1, f1, -f1, f1, f1, 0.0, 3 * f1]
    batch = mc.bend_sweep(setup, forces=forces)
    for i, f in enumerate(forces):
        np.testing.assert_allclose(batch.points[i], mc.bend(setup, force=f).points[0],
                                   rtol=0, atol=1e-10 * L)


def test_a_misleading_prediction_is_retried_from_the_last_solution(
        monkeypatch: pytest.MonkeyPatch) -> None:
    setup = cylinder()
    force = stiffness(setup) / L**2
    expected = mc.bend(setup, force=force).tip
    real = elastica.newton

    def refusing_guesses(problem: elastica.Problem, scale: float, guess: np.ndarray,
                         **kw: float) -> elastica.Solution | None:
        return None if np.any(guess != 0.0) else real(problem, scale, guess, **kw)

    monkeypatch.setattr(elastica, "newton", refusing_guesses)
    np.testing.assert_allclose(mc.bend(setup, force=force).tip, expected, rtol=1e-10)
