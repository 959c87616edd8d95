"""Bent shapes for people: figures of centrelines and the record of one bend in display units
(mm, deg, mN, mV, gauss) or SI that ``magcilia bend`` prints and writes."""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from magcilia.device.setup import Setup
from magcilia.mechanics import BentShape
from magcilia.units import OutputUnits


def load_label(shape: BentShape) -> str:
    """The load of a shape in words: ``0.2 mN``, a flow's description, both or ``no load``."""
    load = shape.load
    parts = [f"{load.force * 1e3:.4g} mN"] if load.force else []
    if load.flow is not None:
        parts.append(load.flow.describe())
    return ", ".join(parts) or "no load"


def bend_record(setup: Setup, shape: BentShape, label: str,
                units: OutputUnits | None = None) -> dict[str, Any]:
    """One bend as the ``magcilia bend`` JSON: load, tip position, tip angle, output, B_x, range
    flag, solver figures and the centreline, in ``units`` (default: display units, mm, deg, mN,
    mV, gauss; every key carries its unit, e.g. ``tip_mm``); ``label`` names the setup."""
    bx = float(setup.field(shape)[0, 0])
    load = shape.load
    points = shape.points[0]
    record = {
        "setup": label,
        "load": {"force_N": load.force, "at_m": load.at, "direction_rad": load.direction,
                 "flow": None if load.flow is None else load.flow.describe()},
        "tip_m": shape.tip.tolist(), "tip_angle_rad": shape.tip_angle,
        "output_V": float(setup.sensor.voltage(bx)), "Bx_T": bx,
        "in_range": bool(setup.sensor.in_range(bx)),
        "iterations": shape.iterations, "residual_rad": shape.residual,
        "centreline_m": {"s": shape.s.tolist(), "x": points[:, 0].tolist(),
                         "z": points[:, 2].tolist()},
    }
    u = units if units is not None else OutputUnits(False, _DISPLAY)
    return {"units": u.system, **u.convert(record)}  # type: ignore[dict-item]


#: the display units of :func:`bend_record` without an OutputUnits (the CLI passes its own)
_DISPLAY = {"length": "mm", "angle": "deg", "force": "mN", "voltage": "mV", "field": "gauss"}


def bend_text(record: dict[str, Any], units: OutputUnits | None = None) -> str:
    """The record of :func:`bend_record` (made with the same ``units``) as the lines
    ``magcilia bend`` prints."""
    u = units if units is not None else OutputUnits(False, _DISPLAY)
    mm, deg, volt, gauss = (u.unit("length"), u.unit("angle"), u.unit("voltage"),
                            u.unit("field"))
    x, _, z = record[u.key("tip", "length")]
    flag = "" if record["in_range"] else "  (beyond the sensor's linear range)"
    lines = [f"tip position  x {x:.6g} {mm}, z {z:.6g} {mm} (from the base centre)",
             f"tip angle     {record[u.key('tip_angle', 'angle')]:.6g} {deg}",
             (f"output        {record[u.key('output', 'voltage')]:.9g} {volt} "
              f"(Bx {record[u.key('Bx', 'field')]:.6g} {gauss}){flag}")]
    residual = record[u.key("residual", "angle")]
    if np.isfinite(residual) and record["iterations"]:
        lines.append(f"solver        {record['iterations']} Newton iterations, residual "
                     f"{residual:.2g} {deg}")
    return "\n".join(lines)


def shape_figure(setup: Setup, shape: BentShape) -> Any:
    """The figure of ``magcilia bend --plot``: one bent shape beside the unloaded cilium, titled
    with its load, tip angle and output (mV)."""
    from magcilia.report.figures import new_figure
    from magcilia.report.style import number

    fig, axes = new_figure(size=(3.6, 4.4))
    plot_shapes(shape, axes[0, 0], labels=["loaded"])
    volts = float(setup.output(shape)[0])
    tip = number(math.degrees(shape.tip_angle))
    axes[0, 0].set_title(f"load: {load_label(shape)}\ntip angle {tip} deg, output "
                         f"{number(volts * 1e3, 5)} mV", fontsize="medium")
    return fig


def plot_shapes(shapes: Any, ax: Any = None, labels: Any = None) -> Any:
    """Plot centrelines in the x–z plane, mm, with the straight cilium dashed.

    Parameters
    ----------
    shapes : Centreline
        One or more centrelines (a :class:`~magcilia.BentShape`, a ``bend_sweep`` result).
    ax : matplotlib Axes, optional
        Where to draw; a new figure when None.
    labels : sequence of str, optional
        A legend label for each shape (no legend without).

    Returns
    -------
    matplotlib Axes
    """
    import matplotlib as mpl

    from magcilia.report.figures import axes_or_new

    ax = axes_or_new(ax, size=(3.6, 4.4))
    length = shapes.length * 1e3
    ax.plot([0.0, 0.0], [0.0, length], color="0.6", ls="--", label="unloaded")
    for i in range(len(shapes)):
        pts = shapes.points[i] * 1e3
        label = labels[i] if labels is not None else None
        ax.plot(pts[:, 0], pts[:, 2], lw=1.4 * mpl.rcParams["lines.linewidth"], color=f"C{i}",
                label=label)
        ax.plot(pts[-1, 0], pts[-1, 2], "o", color="k", ms=3)
    x = shapes.points[..., 0] * 1e3
    half = max(0.5 * length, float(np.abs(x).max()) * 1.15)  # keep the panel readable
    ax.set_xlim(-half if x.min() < -0.05 * half else -0.25 * half, half)
    ax.set_ylim(-0.04 * length, 1.08 * max(length, float((shapes.points[..., 2] * 1e3).max())))
    ax.set_aspect("equal")
    ax.set_xlabel("x (mm), along the sensitive axis")
    ax.set_ylabel("z (mm), from the base")
    ax.grid(alpha=0.3)
    if labels is not None:
        ax.legend(loc="lower right" if x[..., -1].mean() >= 0 else "lower left")  # below the bend
    return ax
