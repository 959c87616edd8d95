"""Figure of a design optimisation: the Pareto front of range against resolution."""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

import numpy as np

from magcilia.device.parameters import MEASURANDS
from magcilia.readout.optimise import DesignOptimum

if TYPE_CHECKING:
    from matplotlib.axes import Axes
    from matplotlib.figure import Figure

#: marker per sensor choice, in order of appearance
_MARKERS = ("o", "s", "D", "^", "v")


def plot_pareto(result: DesignOptimum, ax: Axes | None = None) -> Axes:
    """Range against minimum detectable value (both in the measurand's display unit, log axes)
    of every refined design: the infeasible ones as grey crosses, the feasible ones as light
    markers (one shape per sensor), the Pareto front joined by a line, the reference (the given
    setup) as a star, the chosen design ringed, and the resolution constraint (``min_force``)
    as a dashed line. Better designs lie up and to the left.

    Parameters
    ----------
    result : DesignOptimum
        The result of :func:`magcilia.optimise_design`.
    ax : matplotlib Axes, optional
        Where to draw; a new figure (:func:`pareto_figure`) when None.

    Returns
    -------
    matplotlib Axes
    """
    if ax is None:
        fig = pareto_figure(result)
        axes: Axes = fig.axes[0]
        return axes
    q = MEASURANDS[result.quantity]
    unit = q.display
    k = 1.0 / q.display_factor
    sensors = list(dict.fromkeys([d.sensor for d in result.designs]))
    marker = {s: _MARKERS[i % len(_MARKERS)] for i, s in enumerate(sensors)}
    bad = [d for d in result.designs if not d.feasible and d.range > 0.0
           and math.isfinite(d.minimum) and d.minimum > 0.0]
    if bad:
        ax.scatter([d.minimum * k for d in bad], [d.range * k for d in bad], marker="x",
                   color="0.65", s=18, lw=0.8, label="refined, infeasible", zorder=1)
    for s in sensors:
        ok = [d for d in result.designs if d.feasible and d.rank != 0 and d.sensor == s]
        if ok:
            ax.scatter([d.minimum * k for d in ok], [d.range * k for d in ok],
                       marker=marker[s], color="C0", alpha=0.35, s=16, lw=0,
                       label=f"refined, feasible ({s})" if len(sensors) > 1
                       else "refined, feasible", zorder=2)
    front = result.front
    xs = np.array([d.minimum * k for d in front])
    ys = np.array([d.range * k for d in front])
    ax.step(xs, ys, where="post", color="C1", lw=1.2, zorder=3)
    for s in sensors:
        on = [d for d in front if d.sensor == s]
        if on:
            ax.scatter([d.minimum * k for d in on], [d.range * k for d in on],
                       marker=marker[s], color="C1", s=30, zorder=4,
                       label=f"Pareto front ({s})" if len(sensors) > 1 else "Pareto front")
    ref = result.reference
    ax.scatter([ref.minimum * k], [ref.range * k], marker="*", s=140, color="C3", zorder=5,
               label="given setup")
    best = result.best
    ax.scatter([best.minimum * k], [best.range * k], marker="o", s=160, facecolors="none",
               edgecolors="C2", lw=1.8, zorder=6, label="chosen design")
    ax.set_xscale("log")
    ax.set_yscale("log")
    limit = result.fixed.get("min_force") if result.quantity == "force" else None
    if limit is not None:
        ax.axvline(limit * k, color="C3", ls="--", lw=0.9, zorder=0,
                   label="resolution limit (min_force)")
    if result.quantity == "flow":
        ax.axhline(result.fixed["speed"] * k, color="C3", ls="--", lw=0.9, zorder=0,
                   label="speed (range must reach it)")
    what = "force" if result.quantity == "force" else "speed change"
    ax.set_xlabel(f"minimum detectable {what} ({unit})")
    ax.set_ylabel(f"{q.label} range ({unit})")
    ax.grid(alpha=0.3, which="both", lw=0.5)
    ax.legend(loc="lower right", fontsize="small")
    return ax


def pareto_figure(result: DesignOptimum) -> Figure:
    """The figure of ``magcilia optimise --plot`` (:func:`plot_pareto` in a new figure)."""
    from magcilia.report.figures import new_figure
    from magcilia.report.style import current, number

    fig, axes = new_figure(size=(6.4, 4.6))
    plot_pareto(result, axes[0, 0])
    if current() == "screen":
        q = MEASURANDS[result.quantity]
        fig.suptitle(f"Design optimisation ({result.objective}): {result.screened} designs "
                     f"screened, {len(result.designs)} refined\nchosen: range "
                     f"{number(result.best.range / q.display_factor)} {q.display}, minimum "
                     f"{number(result.best.minimum / q.display_factor)} {q.display}")
    return fig

