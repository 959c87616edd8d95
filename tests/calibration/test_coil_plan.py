"""Coil calibration plans and identifiability from the Fisher information (issue 29, item 1)."""

from __future__ import annotations

import subprocess
import sys

import numpy as np
import pytest

import magcilia as mc
from magcilia.calibration.coil_plan import plan_coil
from magcilia.calibration.coil_rows import (
    LENGTHS,
    calibration_rows,
    coil_jacobian,
    coil_totals,
    parameters_for,
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


NAMES = parameters_for("field")


def test_coil_only_has_the_scale_symmetry_and_a_size_prior_removes_it(setup, rows):
    info = experiment_information(rows, 1e-9)
    alone = identify(info, NAMES, setup)
    assert alone.rank == len(NAMES) - 1
    assert alone.undetermined[0].startswith("all lengths together")
    assert "size measurement" in alone.remedies[0]
    d = alone.directions[0]
    lengths = [NAMES.index(n) for n in LENGTHS]
    np.testing.assert_allclose(np.abs(d[lengths]), 1 / np.sqrt(5), rtol=0.05)
    assert all(not np.isfinite(alone.stderr[i]) for i in lengths)
    sized = identify(info, NAMES, setup, {"height": 0.15e-3})
    assert sized.rank == len(NAMES) and not sized.undetermined
    assert np.all(np.isfinite(sized.stderr))
    assert sized.stderr[0] <= 0.15e-3 * (1 + 1e-6)  # the size is the prior's: no more


def test_the_scale_symmetry_is_exact_in_the_forward_model(setup):
    """Every length × 1.1 (z as the element-to-base distance, the tip with the base) leaves the
    coil readings unchanged: the null direction is the model's, not the differences'."""
    lam = 1.1
    p = setup.params()
    depth = setup.sensor.depth
    scaled = setup.replace(height=lam * p["height"], base_radius=lam * p["base_radius"],
                           tip_radius=lam * p["tip_radius"], x=lam * p["x"], y=lam * p["y"],
                           z=lam * (p["z"] + depth) - depth)
    a = coil_totals(setup, FIELDS[:3])
    b = coil_totals(scaled, FIELDS[:3])
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


def test_coil_rows_match_a_loop_of_bend_and_setup_field(setup):
    """The rows come from the Problem's coil model; an independent reference: central
    differences of mc.bend(..., actuation=) + Setup.field, one field at a time."""
    b = FIELDS[:4]
    rows = coil_jacobian(setup, b, measure="field", parameters=("x", "magnetization_scale"))

    def loop(s: mc.Setup) -> np.ndarray:
        return np.array([s.field(mc.bend(s, actuation=mc.Actuation.uniform(x)))[0] + x
                         for x in b])

    h = 1e-7
    p = setup.params()
    dx = (loop(setup.replace(x=p["x"] + h)) - loop(setup.replace(x=p["x"] - h))) / (2 * h)
    dm = (loop(setup.replace(magnetization_scale=1 + 1e-4))
          - loop(setup.replace(magnetization_scale=1 - 1e-4))) / 2e-4
    np.testing.assert_allclose(rows[:, :, 0], dx, rtol=1e-4, atol=1e-6 * np.abs(dx).max())
    np.testing.assert_allclose(rows[:, :, 1], dm, rtol=1e-4, atol=1e-6 * np.abs(dm).max())


def test_tilt_rows_have_no_modulus_and_scale_with_the_sensitivity(setup):
    angles = np.radians([0.0, 30.0, 60.0])
    coil, tilt = calibration_rows(setup, fields=FIELDS[:2], angles=angles, measure="output")
    names = parameters_for("output")
    assert coil is not None and tilt is not None
    assert np.all(tilt[:, :, names.index("youngs_modulus")] == 0.0)
    s = setup.sensor.sensitivity
    np.testing.assert_allclose(tilt[:, 0, names.index("sensitivity")] * s,
                               setup.output(angles) - setup.sensor.offset, rtol=1e-6)
    assert np.all(coil[:, :, names.index("youngs_modulus")] != 0.0)


def test_fisher_sigma_matches_the_scatter_of_real_fits(setup):
    """Seeded synthetic coil data (3-axis, placement and magnetization fitted, the size known)
    fitted by least squares through the Problem: the scatter of the fits agrees with the Fisher
    σ (six seeds: the sample σ is within ±0.32 of σ at 1 σ; the noise is low enough for the
    linearisation to hold; at 20 nT the four parameters correlate at 0.999, the fits are
    non-linear and scatter ~1.7 σ)."""
    from scipy.optimize import least_squares

    from magcilia.calibration.experiments import CoilExperiment
    from magcilia.calibration.problem import Problem
    from magcilia.io.recordings import Measurement

    names = ("x", "y", "z", "magnetization_scale")
    noise = 5e-10
    J = coil_jacobian(setup, FIELDS, measure="field", parameters=names)
    sigma = identify(experiment_information(J, noise), names, setup).stderr
    truth = np.array([setup.params()[n] for n in names])
    clean = coil_totals(setup, FIELDS) + np.array([1e-5, -2e-5, 3e-5])
    a = FIELDS.shape[0]
    z = np.zeros(a)
    ints = (np.ones(a, np.int64), np.zeros(a, np.int64), np.zeros(a, np.int64))
    bounds = dict.fromkeys(names, (-np.inf, np.inf))
    fits = []
    for seed in range(6):
        y = clean + noise * np.random.default_rng(seed).standard_normal(clean.shape)
        m = Measurement(z, np.full(a, np.nan), np.full(a, np.nan), *ints, azimuths=z, fields=y,
                        field_sem=np.full((a, 3), noise), actuation=FIELDS)
        problem = Problem([CoilExperiment(m)], setup, names, bounds)
        res = least_squares(lambda u, problem=problem: problem.residuals(u * truth)[0],
                            np.ones(len(names)), diff_step=1e-6)
        fits.append(res.x * truth)
    scatter = np.std(np.array(fits), axis=0, ddof=1)
    ratio = scatter / sigma
    assert np.all((ratio > 0.45) & (ratio < 1.8)), dict(zip(names, ratio, strict=True))


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
