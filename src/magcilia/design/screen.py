"""The optimiser's screen: proxy minimum and range of many designs at once (the cheap model of
:mod:`magcilia.design.proxy`, the measurand's curves, the one range rule of
:mod:`magcilia.design.ranges`), and the designs each constraint removes.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from magcilia.design.measurands import Measurand
from magcilia.design.proxy import SCREEN_U, SLOPE_TILT, compliance, mean_radius, moment_scale
from magcilia.design.ranges import range_end, rated_ratio
from magcilia.design.sensors import SensorChoice
from magcilia.device.setup import Setup
from magcilia.mechanics import Fluid
from magcilia.model.batch import TiltBatch

F64 = NDArray[np.float64]

#: why the screen drops a design, by code (0: it does not)
REASONS = ("", "tip_radius <= base_radius", "element outside the cilium",
           "sensor range at zero load", "flip field")
#: designs per screening chunk: ~30 MB of fields each; more chunks run as tasks through the
#: execution layer
SCREEN_CHUNK = 16384


@dataclass(frozen=True)
class Screen:
    """Proxy metrics of the screened designs (arrays over N); ``violated`` indexes
    :data:`REASONS` (0: none)."""

    minimum: F64
    range: F64
    violated: NDArray[np.int64]


def screen_chunk(arg: tuple[Any, ...]) -> Screen:
    """:func:`screen` of one chunk (a top-level function: runs in worker processes)."""
    return screen(*arg)


def screen(setup: Setup, values: dict[str, F64], sensor_index: NDArray[np.int64],
           choices: tuple[SensorChoice, ...], measurand: Measurand, speed: float,
           bandwidth: tuple[float, float], fluid: Fluid, field_limit: float | None = None
           ) -> Screen:
    """Proxy minimum and range of every design (:mod:`magcilia.design.optimise`'s docstring);
    the range ends where a read axis or |B| leaves the rated range (``field_limit``, T, for |B|;
    None: each sensor's own) or the weighted reading folds, and designs whose proxy |B| over
    the range passes 1.2 times the flip field (the proxy's margin) are marked.

    Parameters
    ----------
    setup : Setup
        The starting design (material, model, sensor, the variables not in ``values``).
    values : dict of str to ndarray, shape (N,)
        Every design variable, SI.
    sensor_index : ndarray of int, shape (N,)
        Each design's sensor, an index into ``choices``.
    measurand : Measurand
        What the objective measures.
    speed : float
        Flow: the speed whose slope counts, m/s.
    bandwidth : (float, float)
        Noise band of a single-axis sensor, Hz.
    """
    n = values["height"].size
    comp = compliance(setup, values)
    length = values["height"]
    minimum = np.full(n, math.inf)
    rng_ = np.zeros(n)
    peak = np.full(n, math.inf)
    flip = np.full(n, math.inf)
    angles = np.concatenate([[0.0, SLOPE_TILT], np.arctan(SCREEN_U[1:])])
    batch = TiltBatch(setup, angles)
    params = {k: values[k] for k in ("height", "base_radius", "tip_radius", "x", "y", "z")}
    params["magnetization_scale"] = moment_scale(setup, values)
    b_all = batch.field(params)  # (N, a, 3)
    finite = np.all(np.isfinite(b_all), axis=(1, 2))
    b_all = np.where(np.isfinite(b_all), b_all, 0.0)
    b_curve = np.concatenate([b_all[:, :1], b_all[:, 2:]], axis=1)  # at SCREEN_U
    for j, choice in enumerate(choices):
        sel = np.nonzero(sensor_index == j)[0]
        if sel.size == 0:
            continue
        sigma = choice.sigma(bandwidth)
        p = measurand.proxy(b_all[sel], choice.reading(b_curve[sel]), choice, comp[sel],
                            length[sel], mean_radius(values, sel), speed, fluid)
        info = np.sum((p.slope / sigma) ** 2, axis=1)
        with np.errstate(divide="ignore"):
            minimum[sel] = np.where(info > 0.0, 1.0 / np.sqrt(info), np.inf)
        weights = np.nan_to_num(p.slope / sigma**2, nan=0.0, posinf=0.0, neginf=0.0)
        ratio = rated_ratio(p.curve, choice.full_scale, p.magnitude,
                            choice.total_limit(field_limit))[0]
        signal = np.einsum("nak,nk->na", p.curve, weights)
        rng_[sel], _, last = range_end(p.q, ratio, signal, p.end)
        idx = np.arange(p.q.shape[1])[None, :]
        peak[sel] = np.max(np.where(idx <= last[:, None], p.magnitude, 0.0), axis=1)
        flip[sel] = choice.flip
    violated = np.select([~finite, rng_ <= 0.0, peak > 1.2 * flip],
                         [2, 3, 4], 0).astype(np.int64)
    return Screen(minimum, rng_, violated)
