"""Figures of the cilium in time: the Bode plot of the sensor's frequency response
(:func:`bode_figure`; matplotlib imported lazily, no pyplot state)."""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Any

import numpy as np

from magcilia.mechanics.response import FrequencyResponse
from magcilia.report.figures import new_figure


def bode_figure(responses: Sequence[FrequencyResponse],
                labels: Sequence[str] | None = None) -> Any:
    """A two-panel Bode plot (|H| in dB relative to the static sensitivity; phase in degrees)
    of one or more :class:`~magcilia.FrequencyResponse` against frequency (Hz, log axis), each
    curve's −3 dB bandwidth marked; returns the matplotlib Figure.

    Parameters
    ----------
    responses : sequence of FrequencyResponse
        The curves (of one load: force or flow).
    labels : sequence of str, optional
        Legend labels (default: the fluid, its first mode's frequency and damping ratio).
    """
    fig, axes = new_figure(1, 2, size=(6.4, 2.6), sharex=True, height_ratios=(3, 2))
    mag, ph = axes[0, 0], axes[1, 0]
    for k, r in enumerate(responses):
        m = r.modes
        label = (labels[k] if labels is not None else
                 f"{'vacuum' if m.fluid is None else m.fluid.name}: f₁ {m.frequencies[0]:.4g} Hz, "
                 f"ζ₁ {m.damping_ratios[0]:.2g}")
        line, = mag.semilogx(r.frequencies, r.magnitude_db, label=label)
        ph.semilogx(r.frequencies, np.degrees(r.phase), color=line.get_color())
        if math.isfinite(r.bandwidth) and r.frequencies[0] <= r.bandwidth <= r.frequencies[-1]:
            mag.plot([r.bandwidth], [-3.0], "o", color=line.get_color(), ms=4)
    mag.axhline(-3.0, color="0.6", lw=0.8, ls="--")
    unit = responses[0].unit if responses else "V/N"
    mag.set_ylabel(f"|H| / |H(0)| (dB; H in {unit})")
    ph.set_ylabel("phase (deg)")
    ph.set_xlabel("frequency (Hz)")
    mag.legend(fontsize="small")
    mag.grid(True, which="both", alpha=0.3)
    ph.grid(True, which="both", alpha=0.3)
    return fig
