"""Figures of the field model (matplotlib, imported lazily; every function takes and returns axes).

Degrees, gauss and millivolts appear only here, at the edge.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import NDArray

from magcilia.constants import GAUSS

if TYPE_CHECKING:
    from matplotlib.axes import Axes
    from matplotlib.figure import Figure


def new_figure(
    ncols: int = 1, nrows: int = 1, size: tuple[float, float] = (6.4, 4.0)
) -> tuple[Figure, Any]:
    """A figure not tied to pyplot's global state (safe in threads and tests)."""
    from matplotlib.figure import Figure

    fig = Figure(figsize=(size[0] * ncols, size[1] * nrows), layout="constrained")
    axes = fig.subplots(nrows, ncols, squeeze=False)
    return fig, axes


def plot_field_vs_tilt(
    angles: NDArray[np.float64],
    fields: Sequence[NDArray[np.float64]],
    labels: Sequence[str],
    ax: Axes,
) -> Axes:
    """Plot B components (gauss) vs tilt angle (deg) for several setups; fields are (a, 3) in T."""
    deg = np.degrees(angles)
    for b, label in zip(fields, labels, strict=True):
        line = ax.plot(deg, b[:, 0] / GAUSS, label=f"{label}: $B_x$")[0]
        ax.plot(deg, b[:, 1] / GAUSS, ls="--", color=line.get_color(), label=f"{label}: $B_y$")
        ax.plot(deg, b[:, 2] / GAUSS, ls=":", color=line.get_color(), label=f"{label}: $B_z$")
    ax.set_xlabel("tilt angle θ (deg)")
    ax.set_ylabel("field at the sensing element (gauss)")
    ax.grid(alpha=0.3)
    ax.legend(fontsize="small")
    return ax


def plot_output_vs_tilt(
    angles: NDArray[np.float64],
    outputs: Sequence[NDArray[np.float64]],
    labels: Sequence[str],
    ax: Axes,
    in_range: Sequence[NDArray[np.bool_]] | None = None,
) -> Axes:
    """Plot sensor output (mV) vs tilt (deg); points outside the sensor's linear range (where
    ``in_range`` is False) are marked with red crosses."""
    deg = np.degrees(angles)
    for i, (v, label) in enumerate(zip(outputs, labels, strict=True)):
        ax.plot(deg, v * 1e3, marker=".", label=label)
        if in_range is not None and not in_range[i].all():
            bad = ~in_range[i]
            ax.plot(deg[bad], v[bad] * 1e3, "x", color="red", label=f"{label}: beyond ±range")
    ax.set_xlabel("tilt angle θ (deg)")
    ax.set_ylabel("sensor output (mV)")
    ax.grid(alpha=0.3)
    ax.legend(fontsize="small")
    return ax
