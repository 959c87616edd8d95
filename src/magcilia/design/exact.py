"""The optimiser's exact metrics of one design (run as tasks through the execution layer): the
large-deflection sweep and the full field model, the minimum detectable value from the reading's
slope over the sensor's noise, and the read range (:mod:`magcilia.design.ranges`).

The *minimum detectable* value is the field noise of one reading over the field's slope,
combined over the sensor's axes as ``1 / sqrt(Σ (s_i / σ_i)²)`` (s: dB/dF or dB/dU on axis i,
σ_i its RMS noise; one axis for the HMC1021Z: ``σ / |s|``, as :func:`magcilia.design_metrics`).
The range ends at the sensor's rated range or a fold of the reading ``Σ w_i B_i`` with the
zero-load weights ``w_i = s_i / σ_i²`` (the best linear read-out; for one axis the output itself).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from magcilia.design.measurands import Measurand
from magcilia.design.ranges import read_range
from magcilia.design.robust import RobustSpec, calibration_free_error
from magcilia.design.sensors import SensorChoice
from magcilia.device.setup import Setup
from magcilia.mechanics import Fluid
from magcilia.mechanics.response import response_figures

F64 = NDArray[np.float64]


@dataclass(frozen=True)
class ExactTask:
    """What one exact evaluation needs (picklable): the design, its sensor, the measurand, the
    speed whose slope counts (m/s, flow), the noise band (Hz), the fluid, the sweep's points,
    the rated range of |B| in force (T), whether to measure the dynamics (the response's
    bandwidth and settling time: :func:`dynamics`) and, for the ``"robust"`` objective, how to
    estimate the calibration-free error (:mod:`magcilia.design.robust`)."""

    setup: Setup
    choice: SensorChoice
    measurand: Measurand
    speed: float
    bandwidth: tuple[float, float]
    fluid: Fluid
    points: int
    total: float = math.inf
    dynamics: bool = True
    robust: RobustSpec | None = None


def information(slope: F64, sigma: F64) -> float:
    """Σ (s_i / σ_i)² over the read axes (1/unit²)."""
    return float(np.sum((slope / sigma) ** 2))


def evaluate(task: ExactTask) -> dict[str, Any]:
    """The exact metrics of one design (a top-level function: runs in worker processes), its
    layout by the layout rule at the sensing element: ``sensitivity`` (T per unit), ``minimum``,
    ``range`` (SI), ``limited_by``, ``peak_field`` (T), ``reached`` and, when the task asks,
    the dynamics: ``bandwidth`` (−3 dB, Hz) and ``settling_time`` (2 %, s); NaN otherwise;
    with ``task.robust``, the calibration-free error over the range (``error``: RMS,
    ``error_p95``; fractions of the range; NaN without a range)."""
    setup, choice = task.setup.resolve_layout(), task.choice
    sigma = choice.sigma(task.bandwidth)
    sweep = task.measurand.sweep(setup, task.fluid, task.points)
    slope = task.measurand.field_slope(setup, choice, sweep, task.speed)
    q, b = sweep.values, sweep.fields
    info = information(slope, sigma)
    minimum = 1.0 / math.sqrt(info) if info > 0.0 else math.inf
    sensitivity = float(np.linalg.norm(slope[np.isfinite(sigma)]))
    if q.size < 2:
        return {"sensitivity": sensitivity, "minimum": minimum, "range": 0.0,
                "limited_by": sweep.end,
                "peak_field": math.nan, "reached": False}
    weights = np.nan_to_num(slope / sigma**2, nan=0.0, posinf=0.0, neginf=0.0)
    if not np.any(weights):  # no slope at the operating point: read the largest axis
        weights = np.eye(3)[int(np.argmax(np.abs(choice.reading(b[-1]) - choice.reading(b[0]))
                                          / np.where(np.isfinite(sigma), sigma, np.inf)))]
    reading = choice.reading(b)
    signal = reading @ np.where(np.isfinite(weights), weights, 0.0)
    rng, why, last, reached = read_range(q, reading, b, choice.full_scale, task.total, signal,
                                         choice.axes, sweep.end)
    peak = float(np.max(np.linalg.norm(b[:last + 1], axis=1)))
    band, settle = dynamics(task) if task.dynamics else (math.nan, math.nan)
    out = {"sensitivity": sensitivity, "minimum": minimum, "range": rng, "limited_by": why,
           "peak_field": peak, "reached": reached, "bandwidth": band, "settling_time": settle}
    if task.robust is not None and rng > 0.0:
        err = calibration_free_error(setup, rng, task.robust)
        out.update(error=err.rms, error_p95=err.p95)
    return out


def dynamics(task: ExactTask) -> tuple[float, float]:
    """The −3 dB bandwidth (Hz) and 2 % settling time (s) of the design's response to its
    measurand (a tip force about rest, a flow about the task's speed) in the task's fluid
    (:func:`magcilia.frequency_response`; NaN where the model refuses the design)."""
    return response_figures(task.setup, task.fluid, task.measurand.name, task.speed)


def evaluate_many(tasks: Sequence[ExactTask]) -> list[dict[str, Any]]:
    """:func:`evaluate` of a chunk of designs (one task of the execution layer); a design the
    model refuses is infeasible (its ``limited_by`` starts "model error"), not the end of the
    search."""
    out = []
    for task in tasks:
        try:
            out.append(evaluate(task))
        except (ValueError, ArithmeticError) as exc:  # MagciliaError, a singular solve
            out.append({"sensitivity": math.nan, "minimum": math.inf, "range": 0.0,
                        "limited_by": f"model error ({exc})", "peak_field": math.nan,
                        "reached": False})
    return out
