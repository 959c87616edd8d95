"""Figure of the design metrics: output vs force, flow speed and tilt, with the sensor's limits."""

from __future__ import annotations

import math
import textwrap
from typing import Any

import numpy as np

from magcilia.constants import GAUSS
from magcilia.device.parameters import MEASURANDS
from magcilia.readout.design import DesignMetrics


def plot_design(metrics: DesignMetrics) -> Any:
    """Three panels (force in mN, flow speed in m/s, tilt in deg) of the output change (mV) from
    zero load, with the ±field_range limit, the noise floor, the minimum detectable value and the
    range marked. Returns the matplotlib Figure (not tied to pyplot)."""
    from magcilia.report.figures import new_figure

    fig, axes = new_figure(ncols=3, size=(4.2, 3.6))
    sensor = metrics.setup.sensor
    for ax, m in zip(axes[0], metrics.metrics, strict=True):
        measurand = MEASURANDS[m.quantity]
        unit, factor = measurand.display, 1.0 / measurand.display_factor
        ax.set_xlabel(f"{m.quantity} ({unit})")
        ax.set_ylabel("output change from zero load (mV)")
        ax.grid(alpha=0.3)
        if m.curve.shape[0] == 0:
            why = textwrap.fill(m.limited_by.split(": ", 1)[-1], width=34)
            ax.text(0.5, 0.5, f"not available:\n{why}", ha="center", va="center",
                    fontsize="small", transform=ax.transAxes)
            continue
        q, volts = m.curve[:, 0] * factor, m.curve[:, 1]
        ax.plot(q, (volts - volts[0]) * 1e3, color="C0", label="model")
        for sign in (-1.0, 1.0):
            limit = (sign * sensor.field_range * sensor.scale + sensor.offset - volts[0]) * 1e3
            ax.axhline(limit, color="C3", ls="--", lw=0.8,
                       label=f"±{sensor.field_range / GAUSS:g} gauss" if sign > 0 else None)
        ax.axhspan(-metrics.noise * 1e3, metrics.noise * 1e3, color="0.8", label="noise RMS")
        if math.isfinite(m.range):
            ax.axvline(m.range * factor, color="C2", ls=":", label=f"range ({m.limited_by})")
        if math.isfinite(m.minimum):
            ax.axvline(m.minimum * factor, color="C1", ls=":", label="min. detectable")
        span = np.ptp((volts - volts[0]) * 1e3)
        ax.set_ylim(*(np.array([-1.2, 1.2]) * max(span, 1e-6)))
        if m.quantity == "flow":
            ax.set_xscale("symlog", linthresh=max(m.minimum * factor, 1e-6)
                          if math.isfinite(m.minimum) and m.minimum > 0 else 1e-3)
            ax.set_xlim(left=0.0)
        ax.set_title(f"{m.quantity}: {abs(m.sensitivity) / factor:.3g} V/{unit} at zero load"
                     if math.isfinite(m.sensitivity) else m.quantity, fontsize="small")
        ax.legend(fontsize="x-small")
    fig.suptitle(f"Design metrics (noise {metrics.noise * 1e6:.3g} µV RMS, "
                 f"{metrics.bandwidth[0]:g}–{metrics.bandwidth[1]:g} Hz; flow in "
                 f"{metrics.fluid.name})")
    return fig
