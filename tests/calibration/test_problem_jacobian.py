"""The calibration problem's analytic Jacobian (issue 27, item 2): the residuals' derivatives
through the variable projection (bias, fitted scale), the azimuth turn and the priors, against
central differences of ``Problem.residuals``; the fitter's residuals are the problem's."""

from __future__ import annotations

import numpy as np
import pytest

import magcilia as mc
from magcilia.calibration import FieldPath, Prior, Problem, TiltPath
from magcilia.calibration.problem import GEOMETRY, PARAMETERS, named
from magcilia.io import Measurement, example_path

TRUTH = mc.Setup.paper(n_loops=8, dipoles_per_loop=5, ring="rms")
ANGLES = np.radians(np.arange(0.0, 81.0, 5.0))


def _output(azimuth: float, seed: int) -> Measurement:
    rng = np.random.default_rng(seed)
    a = ANGLES.size
    volts = TRUTH.output(ANGLES, azimuth=azimuth) + 3e-3 + rng.normal(0.0, 2e-6, a)
    return Measurement(angles=ANGLES.copy(), volts=volts, sem=np.full(a, 2e-6),
                       counts=np.full(a, 100), saturated=np.zeros(a, np.int64),
                       nonfinite=np.zeros(a, np.int64), azimuths=np.full(a, azimuth),
                       source=f"output {azimuth:g}")


def _field(azimuth: float, seed: int) -> Measurement:
    rng = np.random.default_rng(seed)
    a = ANGLES.size
    b = TRUTH.field(ANGLES, azimuth=azimuth) + [2e-6, -1e-6, 4e-6] + rng.normal(0, 2e-8, (a, 3))
    return Measurement(angles=ANGLES.copy(), volts=np.zeros(a), sem=np.zeros(a),
                       counts=np.full(a, 100), saturated=np.zeros(a, np.int64),
                       nonfinite=np.zeros(a, np.int64), azimuths=np.full(a, azimuth),
                       fields=b, field_sem=np.full((a, 3), 2e-8), source=f"field {azimuth:g}")


def _differences(problem: Problem, p: np.ndarray, free: np.ndarray) -> np.ndarray:
    """Central differences of the residuals (m, p), relative steps 1e-6 (zero columns for the
    integers)."""
    out = np.zeros((problem.size, p.size))
    for i in np.nonzero(free)[0]:
        h = 1e-6 * abs(p[i])
        e = np.zeros(p.size)
        e[i] = h
        out[:, i] = (problem.residuals(p + e)[0] - problem.residuals(p - e)[0]) / (2 * h)
    return out


def _assert_close(jac: np.ndarray, ref: np.ndarray) -> None:
    scale = np.abs(ref).max(axis=0)
    err = np.abs(jac - ref).max(axis=0)
    assert (err <= 1e-5 * scale + 1e-12 * scale.max()).all(), (err / np.maximum(scale, 1e-300))


@pytest.mark.parametrize(("bias", "degree", "fit_scale"),
                         [("offset", 0, False), ("polynomial", 2, False), ("offset", 0, True),
                          ("none", 0, True)])
def test_paper_problem_jacobian_matches_differences(bias: str, degree: int,
                                                    fit_scale: bool) -> None:
    data = mc.read_measurements(example_path())
    problem = Problem.paper(data, mc.Setup.paper_initial(), bias, degree, fit_scale)
    assert problem.analytic
    p = np.array([3.1e-3, 2.1e-4, 1.2e-3, 0.4e-3, 0.3e-3, 4.0, 3.0])
    r, jac = problem.residuals_jacobian(p[None])
    np.testing.assert_allclose(r[0], problem.residuals(p)[0], rtol=0,
                               atol=1e-10 * np.abs(r).max())
    free = np.array([n not in ("n_loops", "dipoles_per_loop") for n in PARAMETERS])
    _assert_close(jac[0], _differences(problem, p, free))
    assert not jac[0][:, ~free].any()
    np.testing.assert_allclose(problem.jacobian(p), jac[0])


def test_joint_problem_jacobian_matches_differences() -> None:
    # a tilt toward another azimuth, a 3-axis field and a prior: the turn and the prior rows
    terms = (TiltPath(_output(0.0, 1)) + TiltPath(_output(1.1, 2)) + FieldPath(_field(0.5, 3))
             + Prior("height", 3.0e-3, 2e-4))
    bounds = {n: mc.calibration.DEFAULT_BOUNDS[n] for n in GEOMETRY}
    for fit_scale in (False, True):
        problem = Problem(terms, TRUTH, GEOMETRY, bounds, fit_scale=fit_scale)
        p = np.array([TRUTH.params()[n] for n in GEOMETRY]) * [1.02, 0.97, 1.05, 1.0, 1.1]
        p[3] = 0.2e-3
        r, jac = problem.residuals_jacobian(p[None])
        np.testing.assert_allclose(r[0], problem.residuals(p)[0], rtol=0,
                                   atol=1e-10 * np.abs(r).max())
        _assert_close(jac[0], _differences(problem, p, np.ones(p.size, dtype=bool)))


def test_fitter_residuals_are_the_problems() -> None:
    data = mc.read_measurements(example_path())
    problem = Problem.paper(data, mc.Setup.paper_initial())
    rows = np.array([[3.1e-3, 2.1e-4, 1.2e-3, 0.4e-3, 0.3e-3, 4.0, 3.0],
                     [2.5e-3, 1.1e-4, -1.2e-3, 0.0, 0.5e-3, 1.0, 7.0]])
    r, jac = problem.data_residuals_jacobian(named(rows.T))
    np.testing.assert_allclose(r, problem.linear(problem.model(named(rows.T)))[0], rtol=0,
                               atol=1e-10 * np.abs(r).max())
    assert jac.shape == (2, len(data), len(PARAMETERS))
