"""D-optimal calibration design: classical exact designs, the exchange never lowers the
criterion, nuisance offsets, standard errors against a direct inverse, and the tilt-table plan."""

from __future__ import annotations

import math

import numpy as np
import pytest

import magcilia as mc
from magcilia._errors import MagciliaError
from magcilia.calibration import d_optimal, evaluate_design, plan_calibration
from magcilia.calibration.doptimal import _criterion, _exchange, _setup_problem
from magcilia.calibration.plan import tilt_jacobian

X = np.linspace(-1.0, 1.0, 41)
QUADRATIC = np.stack([np.ones_like(X), X, X * X], axis=1)
LINEAR = QUADRATIC[:, :2]


def test_quadratic_regression_three_points_is_minus_one_zero_one() -> None:
    design = d_optimal(QUADRATIC, 3)
    assert X[design.chosen].tolist() == [-1.0, 0.0, 1.0]
    assert design.rank == 3 and math.isfinite(design.condition)
    # det of the 3-point design matrix [1 x x²] at −1, 0, 1 is 2: log det(JᵀJ) = 2 log 2
    assert design.log_det == pytest.approx(2.0 * math.log(2.0))


def test_quadratic_regression_six_points_replicates_each_twice() -> None:
    design = d_optimal(QUADRATIC, 6)
    assert X[design.chosen].tolist() == [-1.0, -1.0, 0.0, 0.0, 1.0, 1.0]
    assert design.log_det == pytest.approx(math.log(32.0))  # det(JᵀJ) = 2³ · 4
    # standard errors of (a, b, c) for 2 replicates at −1, 0, 1: (1/√2, 1/2, √3/2)
    np.testing.assert_allclose(design.stderr, [1 / math.sqrt(2), 0.5, math.sqrt(3) / 2])


def test_linear_regression_takes_the_two_ends() -> None:
    for n in (2, 4, 10):
        design = d_optimal(LINEAR, n)
        assert set(X[design.chosen].tolist()) == {-1.0, 1.0}
        assert np.sum(X[design.chosen] < 0) == n // 2


def test_exchange_never_lowers_the_criterion() -> None:
    gen = np.random.default_rng(0)
    J = gen.standard_normal((30, 2, 4))
    _, _, info, prior, _ = _setup_problem(J, None, None, None)
    nuis = np.array([], dtype=np.int_)
    for seed in range(10):
        start = np.bincount(np.random.default_rng(seed).integers(30, size=7), minlength=30)
        before = float(_criterion(prior + 1e-9 * np.eye(4)
                                  + np.einsum("c,cij->ij", start.astype(float), info), nuis))
        after, counts, _swaps = _exchange(start, info, prior + 1e-9 * np.eye(4), nuis)
        assert after >= before - 1e-12 and counts.sum() == 7
    best = d_optimal(J, 7)
    for seed in range(20):  # no random design beats the optimum
        chosen = np.random.default_rng(100 + seed).integers(30, size=7)
        assert evaluate_design(J, chosen).log_det <= best.log_det + 1e-9


def test_standard_errors_are_the_inverse_information() -> None:
    gen = np.random.default_rng(4)
    J = gen.standard_normal((12, 3)) * [1e-3, 1.0, 1e3]  # columns of very different units
    chosen = [0, 1, 2, 3, 3, 7]
    design = evaluate_design(J, chosen, prior_precision=[0.0, 4.0, 0.0])
    M = J[chosen].T @ J[chosen] + np.diag([0.0, 4.0, 0.0])
    np.testing.assert_allclose(design.stderr, np.sqrt(np.diag(np.linalg.inv(M))), rtol=1e-9)
    assert design.log_det == pytest.approx(np.linalg.slogdet(M)[1])


def test_a_null_direction_is_undetermined_not_a_small_error() -> None:
    J = np.stack([np.ones_like(X), 2.0 * np.ones_like(X), X], axis=1)  # columns 0 and 1 alias
    design = evaluate_design(J, range(41))
    assert design.rank == 2 and design.condition == math.inf
    assert math.isinf(design.stderr[0]) and math.isinf(design.stderr[1])
    assert math.isfinite(design.stderr[2])


def test_nuisance_offsets_are_profiled_out() -> None:
    """D_s: with an offset per experiment, the criterion is about the slope only."""
    J = np.stack([X, np.ones_like(X)], axis=1)
    design = d_optimal(J, 4, names=["slope", "offset"], interest=["slope"])
    assert set(X[design.chosen].tolist()) == {-1.0, 1.0}
    assert design.interest == ("slope",)
    # slope information with the offset profiled out: Σ (x − x̄)² = 4 for ±1 twice
    assert design.log_det == pytest.approx(math.log(4.0))


def test_budget_below_the_parameter_count_is_one_line() -> None:
    with pytest.raises(MagciliaError, match="budget must be at least 3 conditions") as err:
        d_optimal(QUADRATIC, 2)
    assert "\n" not in str(err.value)
    with pytest.raises(MagciliaError, match="budget"):
        plan_calibration(mc.Setup.paper(), 4)
    with pytest.raises(MagciliaError, match="jacobian"):
        d_optimal(np.full((3, 2), np.nan), 2)


SETUP = mc.Setup.paper()


def test_tilt_jacobian_matches_a_finite_difference_of_the_field() -> None:
    a = np.radians([0.0, 30.0, 60.0])
    J = tilt_jacobian(SETUP, a, np.full(3, math.pi / 2), sensor="field", parameters=("x",))
    h = 1e-6
    up = SETUP.replace(x=SETUP.params()["x"] + h).field(a, azimuth=math.pi / 2)
    down = SETUP.replace(x=SETUP.params()["x"] - h).field(a, azimuth=math.pi / 2)
    np.testing.assert_allclose(J[:, :, 0], (up - down) / (2 * h), rtol=1e-5, atol=1e-12)
    out = tilt_jacobian(SETUP, a, np.zeros(3), parameters=("height", "z"))
    assert out.shape == (3, 1, 2)


def test_the_field_of_one_point_cannot_see_a_similarity_scaling() -> None:
    """B ∝ M·V/r³: scaling the cilium and its placement about the sensing point leaves the field
    unchanged, so no tilt design determines the five lengths without a prior."""
    plan = plan_calibration(SETUP, 33, sensor="field")
    assert plan.design.rank == 4 and np.all(np.isinf(plan.design.stderr[:5]))
    lam = 1.001
    p = SETUP.params()
    scaled = SETUP.replace(height=lam * p["height"], base_radius=lam * p["base_radius"],
                           x=lam * p["x"], y=lam * p["y"],
                           z=lam * (p["z"] + SETUP.sensor.depth) - SETUP.sensor.depth)
    a = np.radians(np.arange(0.0, 86.0, 5.0))
    for phi in (0.0, 1.0):
        np.testing.assert_allclose(scaled.field(a, azimuth=phi), SETUP.field(a, azimuth=phi),
                                   rtol=1e-9, atol=1e-15)


def test_plan_beats_the_papers_single_path_with_a_height_prior() -> None:
    plan = plan_calibration(SETUP, 33, noise=5e-5, prior_sd={"height": 1e-4})
    d, r = plan.design, plan.reference
    assert d.rank == r.rank == 5
    assert d.log_det > r.log_det
    q = len(d.interest)
    assert np.all(d.stderr[1:q] < 0.5 * r.stderr[1:q])  # base radius, x, y, z: 2× or better
    assert d.stderr[0] == pytest.approx(1e-4, rel=1e-6) == r.stderr[0]  # the prior, either way
    assert {phi for _, phi, _ in plan.conditions()} == {0.0, math.pi / 2}
    assert sum(n for *_, n in plan.conditions()) == 33
    assert "paper (1 path)" in plan.report() and "σ x" in plan.report()
    np.testing.assert_allclose(np.degrees(plan.reference_angles), np.linspace(0, 85, 33))
