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
    ncols: int = 1, nrows: int = 1, size: tuple[float, float] = (6.4, 4.0), **grid: Any
) -> tuple[Figure, Any]:
    """A figure not tied to pyplot's global state (safe in threads and tests), with an
    ``(nrows, ncols)`` array of axes.

    ``size`` is one panel's (width, height) in inches on screen; in the ``paper`` style
    (:func:`magcilia.report.style.use`) the figure is one column wide (one panel a row) or two
    (several), panels keeping their aspect ratio (:func:`~magcilia.report.style.figure_size`).
    ``grid`` goes to ``Figure.subplots`` (``sharex``, ``height_ratios``, ...).
    """
    from matplotlib.figure import Figure

    from magcilia.report.style import figure_size

    fig = Figure(figsize=figure_size(ncols, nrows, size), layout="constrained")
    axes = fig.subplots(nrows, ncols, squeeze=False, **grid)
    return fig, axes


def axes_or_new(ax: Axes | None, size: tuple[float, float] = (6.4, 4.0)) -> Axes:
    """``ax``, or the axes of a new one-panel figure (:func:`new_figure`) when None."""
    if ax is not None:
        return ax
    axes: Axes = new_figure(size=size)[1][0, 0]
    return axes


_COMPONENTS = {"x": 0, "y": 1, "z": 2}


def plot_field_vs_tilt(
    angles: NDArray[np.float64],
    fields: Sequence[NDArray[np.float64]],
    labels: Sequence[str],
    ax: Axes | None = None,
    components: str = "xyz",
) -> Axes:
    """Plot field components (gauss) at the sensing element vs tilt angle (deg) for several
    setups.

    Parameters
    ----------
    angles : ndarray, shape (a,)
        Tilt angles, rad.
    fields : sequence of ndarray, shape (a, 3)
        The field of each setup at ``angles``, T.
    labels : sequence of str
        A name for each setup.
    ax : matplotlib Axes, optional
        Where to draw; a new figure when None.
    components : str
        Which of ``x``, ``y``, ``z`` to draw (solid, dashed, dotted; one component solid, the
        y label naming it and the legend listing the setups only).

    Returns
    -------
    matplotlib Axes
    """
    ax = axes_or_new(ax)
    deg = np.degrees(angles)
    styles = {"x": "-", "y": "--", "z": ":"}
    for i, (b, label) in enumerate(zip(fields, labels, strict=True)):
        for c in components:
            name = label if len(components) == 1 else f"{label}: $B_{c}$"
            ax.plot(deg, b[:, _COMPONENTS[c]] / GAUSS, ls=styles[c] if len(components) > 1
                    else "-", color=f"C{i}", label=name)
    ax.set_xlabel("tilt angle θ (deg)")
    ax.set_ylabel(f"$B_{components}$ (gauss)" if len(components) == 1
                  else "field at the sensing element (gauss)")
    ax.grid(alpha=0.3)
    if len(components) > 1 or len(labels) > 1:
        ax.legend(loc="best")
    return ax


def plot_output_vs_tilt(
    angles: NDArray[np.float64],
    outputs: Sequence[NDArray[np.float64]],
    labels: Sequence[str],
    ax: Axes | None = None,
    in_range: Sequence[NDArray[np.bool_]] | None = None,
) -> Axes:
    """Plot sensor output (mV) vs tilt (deg) for several setups.

    Parameters
    ----------
    angles : ndarray, shape (a,)
        Tilt angles, rad.
    outputs : sequence of ndarray, shape (a,)
        Each setup's output, V.
    labels : sequence of str
        A name for each setup.
    ax : matplotlib Axes, optional
        Where to draw; a new figure when None.
    in_range : sequence of ndarray of bool, shape (a,), optional
        False where the field is beyond the sensor's linear range: those points are marked
        with red crosses.

    Returns
    -------
    matplotlib Axes
    """
    ax = axes_or_new(ax)
    deg = np.degrees(angles)
    flagged = False
    for i, (v, label) in enumerate(zip(outputs, labels, strict=True)):
        ax.plot(deg, v * 1e3, marker=".", color=f"C{i}", label=label)
        if in_range is not None and not in_range[i].all():
            bad = ~in_range[i]
            ax.plot(deg[bad], v[bad] * 1e3, "x", color="C3", ms=6, mew=1.2,
                    label=None if flagged else "beyond the linear range")
            flagged = True
    ax.set_xlabel("tilt angle θ (deg)")
    ax.set_ylabel("sensor output (mV)")
    ax.grid(alpha=0.3)
    if len(labels) > 1 or flagged:
        ax.legend(loc="best")
    return ax


def field_figure(
    angles: NDArray[np.float64],
    fields: Sequence[NDArray[np.float64]],
    outputs: Sequence[NDArray[np.float64]],
    labels: Sequence[str],
    in_range: Sequence[NDArray[np.bool_]] | None = None,
) -> Figure:
    """The figure of ``magcilia field --plot``: B_x, B_y, B_z (gauss) and the output (mV) vs
    tilt, one panel each so that every component has its own scale (arguments as
    :func:`plot_field_vs_tilt` and :func:`plot_output_vs_tilt`)."""
    fig, axes = new_figure(ncols=2, nrows=2, size=(4.6, 3.0))
    for ax, c in zip(axes.flat, "xyz", strict=False):
        plot_field_vs_tilt(angles, fields, labels, ax, components=c)
        if ax.get_legend() is not None:  # the output panel's legend names the setups
            ax.get_legend().remove()
    plot_output_vs_tilt(angles, outputs, labels, axes[1, 1], in_range=in_range)
    for ax in axes[0]:
        ax.set_xlabel("")
    from magcilia.report.style import current

    if current() == "screen":
        fig.suptitle("Field at the sensing element and sensor output vs tilt "
                     "(distributed-dipole model)")
    return fig
