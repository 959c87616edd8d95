"""Coil calibration plans and identifiability from the Fisher information (issue 29, item 1)."""

from __future__ import annotations

import subprocess
import sys

import numpy as np
import pytest

import magcilia as mc
from magcilia.calibration.coil_plan import plan_coil
from magcilia.calibration.coil_rows import (
    COIL_PARAMETERS,
    LENGTHS,
    coil_fields,
    coil_jacobian,
    readings,
)
from magcilia.calibration.identifiability import experiment_information, identify

FIELDS = 4e-4 * np.array([[1, 0, 0], [0, 1, 0], [0, 0, 1], [-1, 0, 0], [0, -1, 0],
                          [0.6, 0.6, 0.5], [-0.6, 0.5, -0.6], [0.5, -0.6, 0.6],
                          [0, 0, -1], [0.7, -0.7, 0]])


@pytest.fixture(scope="module")
def setup() -> mc.Setup:
    return mc.load_setup("examples/force-sensor.toml")


@pytest.fixture(scope="module")
def rows(setup: mc.Setup) -> np.ndarray:
    return coil_jacobian(setup, FIELDS, measure="field")


def test_coil_only_has_the_scale_symmetry_and_a_size_prior_removes_it(setup, rows):
    info = experiment_information(rows, 1e-9)
    alone = identify(info, COIL_PARAMETERS, setup)
    assert alone.rank == len(COIL_PARAMETERS) - 1
    assert alone.undetermined[0].startswith("all lengths together")
    assert "size measurement" in alone.remedies[0]
    d = alone.directions[0]
    lengths = [COIL_PARAMETERS.index(n) for n in LENGTHS]
    np.testing.assert_allclose(np.abs(d[lengths]), 1 / np.sqrt(5), rtol=0.05)
    assert all(not np.isfinite(alone.stderr[i]) for i in lengths)
    sized = identify(info, COIL_PARAMETERS, setup, {"height": 0.15e-3})
    assert sized.rank == len(COIL_PARAMETERS) and not sized.undetermined
    assert np.all(np.isfinite(sized.stderr))
    assert sized.stderr[0] < 0.15e-3  # the data add to the prior, never lose it


def test_the_scale_symmetry_is_exact_in_the_forward_model(setup):
    """Every length × 1.1 (z as the element-to-base distance, the tip with the base) leaves the
    coil readings unchanged: the null direction is the model's, not the differences'."""
    lam = 1.1
    p = setup.params()
    depth = setup.sensor.depth
    scaled = setup.replace(height=lam * p["height"], base_radius=lam * p["base_radius"],
                           tip_radius=lam * p["tip_radius"], x=lam * p["x"], y=lam * p["y"],
                           z=lam * (p["z"] + depth) - depth)
    a = readings(setup, coil_fields(setup, FIELDS[:3]), "field")
    b = readings(scaled, coil_fields(scaled, FIELDS[:3]), "field")
    np.testing.assert_allclose(a, b, rtol=0, atol=1e-6 * np.max(np.abs(a)))


def test_d_optimal_sequence_beats_the_naive_sweep(setup):
    plan = plan_coil(setup, 10, measure="field", prior_sd={"height": 0.15e-3},
                     magnitudes=[4e-4])
    assert plan.design.rank == len(plan.design.interest)
    assert plan.design.log_det > plan.naive.log_det
    assert plan.design.budget == 10 and sum(n for _, n in plan.conditions()) == 10
    assert "planned fields (G" in plan.report()
    assert plan.to_dict()["stimulus"] == "coil"


def test_plan_refuses_what_no_sequence_determines(setup):
    with pytest.raises(mc.MagciliaError, match=r"all lengths together.*size measurement"):
        plan_coil(setup, 10, measure="field", magnitudes=[4e-4])
    with pytest.raises(mc.MagciliaError, match="budget"):
        plan_coil(setup, 3, measure="field", prior_sd={"height": 0.15e-3})


@pytest.mark.slow
def test_fisher_sigma_matches_the_scatter_of_real_fits(setup):
    """Seeded synthetic coil data (3-axis, placement, magnetization and gain fitted, the size
    known), fitted by least squares: the scatter of the fits agrees with the Fisher σ."""
    from scipy.optimize import least_squares

    from magcilia.calibration.coil_rows import nominal, with_value

    names = ("x", "y", "z", "magnetization_scale", "gain")
    noise = 2e-8
    J = coil_jacobian(setup, FIELDS, measure="field", parameters=names)
    info = experiment_information(J, noise)
    sigma = identify(info, names, setup).stderr
    truth = np.array([nominal(setup, n) for n in names])

    def model(p: np.ndarray) -> np.ndarray:
        s = setup
        for n, val in zip(names, p[:5], strict=True):
            s = with_value(s, n, float(val))
        return readings(s, coil_fields(s, FIELDS), "field") + p[5:]

    clean = model(np.concatenate([truth, np.zeros(3)]))
    fits = []
    for seed in range(6):
        y = clean + noise * np.random.default_rng(seed).standard_normal(clean.shape)
        scale = np.concatenate([np.abs(truth), [1e-6] * 3])
        res = least_squares(lambda u, y=y, scale=scale: ((model(u * scale) - y) / noise).ravel(),
                            np.concatenate([truth, np.zeros(3)]) / scale, x_scale=1.0,
                            diff_step=1e-6)
        fits.append(res.x[:5] * scale[:5])
    scatter = np.std(np.array(fits), axis=0, ddof=1)
    ratio = scatter / sigma
    assert np.all((ratio > 0.3) & (ratio < 2.5)), dict(zip(names, ratio, strict=True))


def _cli(*args: str) -> subprocess.CompletedProcess[str]:
    return subprocess.run([sys.executable, "-m", "magcilia", "plan", *args],
                          capture_output=True, text=True, timeout=300, check=False)


def test_cli_bad_coil_input_exits_2():
    low = _cli("--setup", "examples/force-sensor.toml", "--stimulus", "coil", "--budget", "3")
    assert low.returncode == 2 and "--budget" in low.stderr and "Traceback" not in low.stderr
    sharp = _cli("--setup", "examples/paper.toml", "--stimulus", "coil", "--budget", "20",
                 "--prior", "height=3.26:0.15")
    assert sharp.returncode == 2 and "tip radius" in sharp.stderr
    fit = _cli("--setup", "examples/force-sensor.toml", "--budget", "20", "--fit", "x")
    assert fit.returncode == 2 and "--stimulus coil" in fit.stderr


@pytest.mark.slow
def test_cli_coil_without_size_names_the_combination():
    out = _cli("--setup", "examples/force-sensor.toml", "--stimulus", "coil", "--budget", "20",
               "--quiet")
    assert out.returncode == 2
    assert "all lengths together" in out.stderr and "size measurement" in out.stderr
