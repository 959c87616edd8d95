"""Figure of the design metrics: output vs force, flow speed and tilt, with the sensor's limits."""

from __future__ import annotations

import math
import textwrap
from typing import TYPE_CHECKING, Any

import numpy as np

from magcilia.constants import GAUSS
from magcilia.design import DesignMetrics, Metric
from magcilia.device.parameters import MEASURANDS

if TYPE_CHECKING:
    from matplotlib.axes import Axes
    from matplotlib.figure import Figure


def _plot_metric(metrics: DesignMetrics, m: Metric, ax: Axes) -> Axes:
    """One panel: output change (mV) vs the measurand in its display unit."""
    from magcilia.report.style import number

    measurand = MEASURANDS[m.quantity]
    unit, factor = measurand.display, 1.0 / measurand.display_factor
    ax.set_xlabel(f"{measurand.label} ({unit})")
    ax.set_ylabel("output change ΔV (mV)")
    ax.grid(alpha=0.3)
    if m.curve.shape[0] == 0:
        reason = m.limited_by.split(": ", 1)[-1]  # "WHAT: WHY; FIX" -> WHAT and FIX
        parts = [reason.split(": ", 1)[0], *reason.rsplit("; ", 1)[1:]]
        why = "\n".join(textwrap.fill(p, width=30) for p in parts)
        ax.text(0.5, 0.5, f"not available:\n{why}", ha="center", va="center",
                fontsize="small", transform=ax.transAxes)
        ax.set_title(m.quantity)
        ax.set_xticks([])
        ax.set_yticks([])
        return ax
    sensor = metrics.setup.sensor
    q, volts = m.curve[:, 0] * factor, m.curve[:, 1]
    dv = (volts - volts[0]) * 1e3
    shown = q > 0 if m.quantity == "flow" else np.ones(q.shape, dtype=bool)
    if m.quantity == "flow":  # drag grows as U²: a log axis shows the small flows
        ax.set_xscale("log")
    ax.plot(q[shown], dv[shown], color="C0", label="model")
    lo, hi = float(dv.min()), float(dv.max())
    span = max(hi - lo, 1e-9)
    limits = [(sign * sensor.field_range * sensor.scale + sensor.offset - volts[0]) * 1e3
              for sign in (-1.0, 1.0)]
    near = [v for v in limits if lo - 1.5 * span <= v <= hi + 1.5 * span]
    for i, v in enumerate(near):
        ax.axhline(v, color="C3", ls="--", lw=0.9,
                   label=f"±{number(sensor.field_range / GAUSS)} gauss" if i == 0 else None)
    lo, hi = min([lo, *near]), max([hi, *near])
    pad = 0.08 * max(hi - lo, 1e-9)
    ax.set_ylim(lo - pad, hi + pad)
    noise = metrics.noise * 1e3
    if 2 * noise >= 0.015 * (hi - lo + 2 * pad):  # a band thinner than that is not seen
        ax.axhspan(-noise, noise, color="0.8", label="noise (±1 RMS)", zorder=0)
    x_lo, x_hi = float(q[shown].min()), float(q[shown].max())
    if m.quantity != "flow":
        ax.set_xlim(x_lo - 0.03 * (x_hi - x_lo), x_hi + 0.03 * (x_hi - x_lo))
    elif math.isfinite(m.minimum) and m.minimum * factor / 30 > x_lo:  # from below the minimum
        x_lo = m.minimum * factor / 30
        ax.set_xlim(x_lo, x_hi * 1.3)
    fraction = ((math.log(m.minimum / x_lo) / math.log(x_hi / x_lo)) if m.quantity == "flow"
                and m.minimum > x_lo else (m.minimum * factor - x_lo) / (x_hi - x_lo))
    if math.isfinite(m.minimum) and 0.02 < fraction < 0.98:
        ax.axvline(m.minimum * factor, color="C1", ls="-.", lw=1.0, label="min. detectable")
    if math.isfinite(m.range) and m.range * factor < 0.98 * x_hi:
        ax.axvline(m.range * factor, color="C2", ls=":", lw=1.2, label=f"range ({m.limited_by})")
    ax.set_title(f"{number(m.sensitivity / factor * 1e3)} mV/{unit} at zero load\n"
                 f"min. {number(m.minimum * factor)} {unit}, range "
                 f"{number(m.range * factor)} {unit}", fontsize="medium")
    if len(ax.get_legend_handles_labels()[1]) > 1:
        ax.legend(loc="best")
    return ax


def plot_design(metrics: DesignMetrics, axes: Any = None) -> Any:
    """Three panels (force in mN, flow speed in m/s on a log axis, tilt in deg) of the output
    change (mV) from zero load, with the ±field_range limit and the noise band where they fall
    near the curve, and the minimum detectable value and the range where they are not at the
    curve's ends (each panel's title gives the sensitivity, minimum and range).

    Parameters
    ----------
    metrics : DesignMetrics
        The result of :func:`magcilia.design_metrics`.
    axes : sequence of three matplotlib Axes, optional
        Where to draw (force, flow, angle); a new figure (:func:`design_figure`) when None.

    Returns
    -------
    ndarray of matplotlib Axes, shape (3,)
    """
    if axes is None:
        return np.asarray(design_figure(metrics).axes)
    axes = np.asarray(axes, dtype=object).ravel()
    for ax, m in zip(axes, metrics.metrics, strict=True):
        _plot_metric(metrics, m, ax)
    return axes


def design_figure(metrics: DesignMetrics) -> Figure:
    """The figure of ``magcilia design --plot`` (:func:`plot_design` in a new figure)."""
    from magcilia.report.figures import new_figure
    from magcilia.report.style import current, number

    fig, axes = new_figure(ncols=3, size=(4.2, 3.6))
    plot_design(metrics, axes[0])
    if current() == "screen":
        fig.suptitle(f"Design metrics (noise {number(metrics.noise * 1e6)} µV RMS, "
                     f"{metrics.bandwidth[0]:g}–{metrics.bandwidth[1]:g} Hz; flow in "
                     f"{metrics.fluid.name})")
    return fig
