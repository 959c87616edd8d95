"""Design: what a sensor design can resolve, and the search for a better one.

* :mod:`.metrics`: :func:`design_metrics` (:class:`DesignMetrics`, one :class:`Metric` per
  measurand): sensitivity, minimum detectable signal and range of a setup;
* :mod:`.optimise`: :func:`optimise_design` (:class:`DesignOptimum` of :class:`Candidate`
  designs): the cilium's geometry, material, placement and sensor searched for an objective
  (:data:`OBJECTIVES`), the Pareto front of range against resolution (:func:`pareto_ranks`);
* :mod:`.robust`: :func:`calibration_free_error` (:class:`CalibrationFreeError`): the read-out
  error of a design without per-device calibration under :class:`Tolerances`, by Monte Carlo
  through the exact model (the ``"robust"`` objective's metric, :data:`ROBUST`); with a
  start-up coil self-test instead (:mod:`.self_test`, :class:`CoilSelfTest`);
* what they share: :mod:`.ranges` (where a read range ends: the rated range or a fold,
  :func:`range_end`), :mod:`.sweeps` (how far a sweep goes, the fields along it),
  :mod:`.measurands` (:data:`FORCE`, :data:`FLOW`: what each objective measures),
  :mod:`.sensors` (:class:`SensorChoice`: the single-axis element or a 3-axis magnetometer);
  the optimiser's screen (:mod:`.proxy`, :mod:`.screen`) and exact metrics (:mod:`.exact`).

These moved here from ``magcilia.readout`` (the read-out stays there); ``magcilia`` exports
the public names as before.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from magcilia._lazy import attach

if TYPE_CHECKING:
    from magcilia.design.measurands import FLOW, FORCE, ROBUST, Measurand
    from magcilia.design.metrics import DesignMetrics, Metric, design_metrics
    from magcilia.design.optimise import (
        DEFAULT_BOUNDS,
        OBJECTIVES,
        VARIABLES,
        optimise_design,
    )
    from magcilia.design.pareto import pareto_ranks
    from magcilia.design.ranges import RangeEnd, range_end
    from magcilia.design.results import Candidate, DesignOptimum
    from magcilia.design.robust import (
        TOLERANCES,
        CalibrationFreeError,
        RobustSpec,
        Tolerances,
        calibration_free_error,
        tolerance_shares,
    )
    from magcilia.design.self_test import CoilSelfTest
    from magcilia.design.sensors import SINGLE_AXIS, SensorChoice, sensor_choices

__all__ = [
    "DEFAULT_BOUNDS",
    "FLOW",
    "FORCE",
    "OBJECTIVES",
    "ROBUST",
    "SINGLE_AXIS",
    "TOLERANCES",
    "VARIABLES",
    "CalibrationFreeError",
    "Candidate",
    "CoilSelfTest",
    "DesignMetrics",
    "DesignOptimum",
    "Measurand",
    "Metric",
    "RangeEnd",
    "RobustSpec",
    "SensorChoice",
    "Tolerances",
    "calibration_free_error",
    "design_metrics",
    "optimise_design",
    "pareto_ranks",
    "range_end",
    "sensor_choices",
    "tolerance_shares",
]

__getattr__, __dir__ = attach(__name__)
