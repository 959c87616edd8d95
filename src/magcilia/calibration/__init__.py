"""Calibration: fit the model's parameters to a field-vs-tilt recording (the paper's Sec. III.B).

* :func:`calibrate` (:mod:`.search`): global search (:mod:`.multistart`, many local fits at
  once by the batched Levenberg–Marquardt of :mod:`.local`) + polish;
* ``calibrate(model="physical")`` (:mod:`.joint`): several experiments (any tilt azimuth,
  output or 3-axis field) in one fit of the physical model (n, k converged), with priors;
  :class:`JointProblem` is its vectorised objective, :class:`JointCalibrationResult` its result;
* :class:`CalibrationResult`, :class:`ParameterCovariance` (:mod:`.result`);
* :class:`CalibrationWarning` and the thresholds of the warnings (:mod:`.diagnostics`);
* the least-squares problem with its linear parameters solved in closed form (:mod:`.problem`)
  and the Jacobian-based uncertainty with its warnings (:mod:`.uncertainty`).
"""

from __future__ import annotations

from magcilia.calibration.diagnostics import WARNING_KINDS, CalibrationWarning
from magcilia.calibration.joint import (
    JointProblem,
    PhysicalLayout,
    calibrate_joint,
    converged_layout,
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
    "CalibrationResult",
    "CalibrationWarning",
    "ExperimentFit",
    "JointCalibrationResult",
    "JointProblem",
    "ParameterCovariance",
    "PhysicalLayout",
    "calibrate",
    "calibrate_joint",
    "converged_layout",
]
