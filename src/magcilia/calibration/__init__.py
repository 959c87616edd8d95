"""Calibration: fit the model's parameters to a field-vs-tilt recording (the paper's Sec. III.B).

* :func:`calibrate` (:mod:`.search`): global search (:mod:`.multistart`, many local fits at
  once by the batched Levenberg–Marquardt of :mod:`magcilia.fitting`) + polish;
* ``calibrate(model="physical")`` (:mod:`.joint`): several experiments (any tilt azimuth,
  output or 3-axis field) in one fit of the physical model (n, k converged), with priors;
  :class:`JointProblem` is its vectorised objective, :class:`JointCalibrationResult` its result;
* :class:`CalibrationResult`, :class:`ParameterCovariance` (:mod:`.result`);
* :class:`CalibrationWarning` and the thresholds of the warnings (:mod:`.diagnostics`);
* the least-squares problem with its linear parameters solved in closed form (:mod:`.problem`)
  and the Jacobian-based uncertainty with its warnings (:mod:`.uncertainty`);
* :func:`sample_posterior` and :class:`Posterior` (:mod:`.posterior`): the posterior sampled
  (emcee, extra ``posterior``), modes weighted by their Laplace evidence;
* :func:`d_optimal`, :func:`plan_calibration` (:mod:`.plan`): which conditions to measure.
"""

from __future__ import annotations

from magcilia.calibration.diagnostics import WARNING_KINDS, CalibrationWarning
from magcilia.calibration.joint import (
    JointProblem,
    PhysicalLayout,
    calibrate_joint,
    converged_layout,
)
from magcilia.calibration.plan import (
    CalibrationPlan,
    Design,
    d_optimal,
    evaluate_design,
    plan_calibration,
)
from magcilia.calibration.posterior import (
    Posterior,
    SamplingWarning,
    least_squares_log_prob,
    sample_posterior,
    sample_problem,
)
from magcilia.calibration.problem import BIASES, CONTINUOUS, DEFAULT_BOUNDS, INTEGER, PARAMETERS
from magcilia.calibration.result import (
    CalibrationResult,
    ExperimentFit,
    JointCalibrationResult,
    ParameterCovariance,
)
from magcilia.calibration.search import calibrate

__all__ = [
    "BIASES",
    "CONTINUOUS",
    "DEFAULT_BOUNDS",
    "INTEGER",
    "PARAMETERS",
    "WARNING_KINDS",
    "CalibrationPlan",
    "CalibrationResult",
    "CalibrationWarning",
    "Design",
    "ExperimentFit",
    "JointCalibrationResult",
    "JointProblem",
    "ParameterCovariance",
    "PhysicalLayout",
    "Posterior",
    "SamplingWarning",
    "calibrate",
    "calibrate_joint",
    "converged_layout",
    "d_optimal",
    "evaluate_design",
    "least_squares_log_prob",
    "plan_calibration",
    "sample_posterior",
    "sample_problem",
]
