"""Figure of a design optimisation: the Pareto front of range against resolution."""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

import numpy as np

from magcilia.design import Candidate, DesignOptimum
from magcilia.device.parameters import MEASURANDS

if TYPE_CHECKING:
    from matplotlib.axes import Axes
    from matplotlib.figure import Figure

#: marker per sensor choice, in order of appearance
_MARKERS = ("o", "s", "D", "^", "v")


def axis_unit(values: list[float], quantity: str) -> tuple[str, float]:
    """The unit to draw ``values`` (SI) of a measurand in, and the SI value of one of it: the
    display unit, or µN for forces that are all below 0.1 mN (a minimum detectable force of
    0.4 µN reads better than 0.0004 mN)."""
    q = MEASURANDS[quantity]
    finite = [abs(x) for x in values if math.isfinite(x) and x != 0.0]
    if quantity == "force" and finite and max(finite) < 1e-4:
        return "µN", 1e-6
    return q.display, q.display_factor


def plot_pareto(result: DesignOptimum, ax: Axes | None = None) -> Axes:
    """Range against minimum detectable value (log axes; forces in mN, minima below 0.1 mN in
    µN: :func:`axis_unit`) of every refined design: the infeasible ones as grey crosses, the
    feasible ones as light markers (one shape per sensor), the Pareto front joined by a line,
    the reference (the given setup) as a star, the chosen design ringed, and the resolution
    constraint (``min_force``) as a dashed line. A range that the sweep did not reach (a lower
    bound: the read-out had not ended at the sweep's end) is drawn hollow. Better designs lie up
    and to the left.

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
    shown = [d for d in result.designs if d.range > 0.0 and math.isfinite(d.minimum)
             and d.minimum > 0.0]
    x_unit, x_si = axis_unit([d.minimum for d in shown] + [result.fixed.get("min_force", 0.0)],
                             result.quantity)
    y_unit, y_si = axis_unit([d.range for d in shown], result.quantity)
    kx, ky = 1.0 / x_si, 1.0 / y_si
    sensors = list(dict.fromkeys([d.sensor for d in result.designs]))
    marker = {s: _MARKERS[i % len(_MARKERS)] for i, s in enumerate(sensors)}

    from matplotlib.colors import to_rgba

    def face(designs: list[Candidate], color: str, alpha: float = 1.0
             ) -> list[tuple[float, ...]]:
        """Filled where the range was reached, hollow (transparent) where it is a lower bound
        (RGBA: an ``alpha`` keyword would also fill the hollow ones)."""
        return [to_rgba(color, alpha if d.reached else 0.0) for d in designs]

    bad = [d for d in shown if not d.feasible]
    if bad:
        ax.scatter([d.minimum * kx for d in bad], [d.range * ky for d in bad], marker="x",
                   color="0.65", s=18, lw=0.8, label="refined, infeasible", zorder=1)
    for s in sensors:
        ok = [d for d in result.designs if d.feasible and d.rank != 0 and d.sensor == s]
        if ok:
            ax.scatter([d.minimum * kx for d in ok], [d.range * ky for d in ok],
                       marker=marker[s], facecolors=face(ok, "C0", 0.45),
                       edgecolors=[to_rgba("C0", 0.45)] * len(ok), s=24, lw=0.9,
                       label=f"refined, feasible ({s})" if len(sensors) > 1
                       else "refined, feasible", zorder=2)
    front = result.front
    xs = np.array([d.minimum * kx for d in front])
    ys = np.array([d.range * ky for d in front])
    ax.step(xs, ys, where="post", color="C1", lw=1.2, zorder=3)
    for s in sensors:
        on = [d for d in front if d.sensor == s]
        if on:
            ax.scatter([d.minimum * kx for d in on], [d.range * ky for d in on],
                       marker=marker[s], facecolors=face(on, "C1"), edgecolors="C1", s=30,
                       lw=1.0, zorder=4,
                       label=f"Pareto front ({s})" if len(sensors) > 1 else "Pareto front")
    if any(not d.reached for d in shown):
        ax.scatter([], [], marker="o", facecolors="none", edgecolors="0.3", s=30, lw=1.0,
                   label="hollow: range not reached (≥)")
    ref = result.reference
    ax.scatter([ref.minimum * kx], [ref.range * ky], marker="*", s=140,
               facecolors="C3" if ref.reached else "none", edgecolors="C3", lw=1.2, zorder=5,
               label="given setup")
    best = result.best
    ax.scatter([best.minimum * kx], [best.range * ky], marker="o", s=160, facecolors="none",
               edgecolors="C2", lw=1.8, zorder=6, label="chosen design")
    ax.set_xscale("log")
    ax.set_yscale("log")
    limit = result.fixed.get("min_force") if result.quantity == "force" else None
    if limit is not None:
        ax.axvline(limit * kx, color="C3", ls="--", lw=0.9, zorder=0,
                   label="resolution limit (min_force)")
    if result.quantity == "flow":
        ax.axhline(result.fixed["speed"] * ky, color="C3", ls="--", lw=0.9, zorder=0,
                   label="speed (range must reach it)")
    what = "force" if result.quantity == "force" else "speed change"
    ax.set_xlabel(f"minimum detectable {what} ({x_unit})")
    ax.set_ylabel(f"{q.label} range ({y_unit})")
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
        best = result.best
        r_unit, r_si = axis_unit([best.range], result.quantity)
        m_unit, m_si = axis_unit([best.minimum], result.quantity)
        at_least = "" if best.reached else "≥ "
        fig.suptitle(f"Design optimisation ({result.objective}): {result.screened} designs "
                     f"screened, {len(result.designs)} refined\nchosen: range {at_least}"
                     f"{number(best.range / r_si)} {r_unit}, minimum "
                     f"{number(best.minimum / m_si)} {m_unit}")
    return fig

