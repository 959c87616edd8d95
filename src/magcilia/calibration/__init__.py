"""Calibration: fit the model's parameters to a field-vs-tilt recording (the paper's Sec. III.B).

* experiments as residual objects that add (:mod:`.experiments`: :class:`TiltPath`,
  :class:`FieldPath`, :class:`LoadExperiment`, :class:`CoilExperiment`, :class:`Prior`;
  ``a + b``), and the one
  least-squares :class:`Problem` over their sum (:mod:`.problem`: the search vector, bounds, the
  one non-finite penalty, batched residuals with the linear parameters solved in closed form);
* :func:`calibrate` (:mod:`.search`): the paper's model (one tilt path, n and k searched): global
  search (:mod:`.multistart`, many local fits at once by the batched Levenberg–Marquardt of
  :mod:`magcilia.fitting`) + polish;
* ``calibrate(model="physical")`` (:mod:`.joint`): several experiments (any tilt azimuth,
  output or 3-axis field, loads) in one fit of the physical model (n, k at a converged layout,
  :mod:`.layout`), with priors;
* one result for both, :class:`CalibrationResult` (:mod:`.result`; ``JointCalibrationResult``
  is the same class), with :class:`ParameterCovariance` (:mod:`.covariance`), an
  :class:`ExperimentFit` per experiment (:mod:`.experiment_fit`) and its parameters as objects
  (:class:`FitParameter` named by a :class:`ParameterKey`, :mod:`.parameters`); earlier
  ``result.json`` files read back (:mod:`.reload`);
* :class:`CalibrationWarning` and the thresholds of the warnings (:mod:`.diagnostics`);
* the Jacobian-based uncertainty with its warnings (:mod:`.uncertainty`);
* :func:`sample_posterior` and :class:`Posterior` (:mod:`.posterior`): the posterior sampled
  (emcee, extra ``posterior``), modes weighted by their Laplace evidence;
* :func:`d_optimal`, :func:`plan_calibration` (:mod:`.plan`): which conditions to measure.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from magcilia._lazy import attach

if TYPE_CHECKING:
    from magcilia.calibration.covariance import ParameterCovariance
    from magcilia.calibration.diagnostics import WARNING_KINDS, CalibrationWarning
    from magcilia.calibration.experiment_fit import ExperimentFit
    from magcilia.calibration.experiments import (
        CoilExperiment,
        Experiment,
        Experiments,
        FieldPath,
        LoadExperiment,
        Prior,
        TiltPath,
        experiment,
    )
    from magcilia.calibration.joint import (
        JointProblem as JointProblem,  # an earlier name, re-exported
    )
    from magcilia.calibration.joint import calibrate_joint
    from magcilia.calibration.layout import PhysicalLayout, converged_layout
    from magcilia.calibration.parameters import FitParameter, ParameterKey
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
    from magcilia.calibration.problem import (
        BIASES,
        CONTINUOUS,
        DEFAULT_BOUNDS,
        INTEGER,
        NONFINITE_COST,
        PARAMETERS,
        Problem,
    )
    from magcilia.calibration.result import CalibrationResult
    from magcilia.calibration.result import (  # an earlier name, re-exported
        JointCalibrationResult as JointCalibrationResult,
    )
    from magcilia.calibration.search import calibrate

# the earlier names JointCalibrationResult (the one CalibrationResult) and JointProblem (it builds
# the one Problem) stay importable from here, undocumented: they are not names of their own
__all__ = [
    "BIASES",
    "CONTINUOUS",
    "DEFAULT_BOUNDS",
    "INTEGER",
    "NONFINITE_COST",
    "PARAMETERS",
    "WARNING_KINDS",
    "CalibrationPlan",
    "CalibrationResult",
    "CalibrationWarning",
    "CoilExperiment",
    "Design",
    "Experiment",
    "ExperimentFit",
    "Experiments",
    "FieldPath",
    "FitParameter",
    "LoadExperiment",
    "ParameterCovariance",
    "ParameterKey",
    "PhysicalLayout",
    "Posterior",
    "Prior",
    "Problem",
    "SamplingWarning",
    "TiltPath",
    "calibrate",
    "calibrate_joint",
    "converged_layout",
    "d_optimal",
    "evaluate_design",
    "experiment",
    "least_squares_log_prob",
    "plan_calibration",
    "sample_posterior",
    "sample_problem",
]

__getattr__, __dir__ = attach(__name__)
