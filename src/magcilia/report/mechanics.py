"""Bent shapes for people: figures of centrelines and the record of one bend in display units
(mm, deg, mN, mV, gauss) or SI that ``magcilia bend`` prints and writes."""

from __future__ import annotations

import math
import re
from typing import Any

import numpy as np

from magcilia.device.setup import Setup
from magcilia.mechanics import BentShape, SpatialBentShape, bend
from magcilia.model.centreline import SpatialCentreline
from magcilia.readout.scale import per_ln_modulus
from magcilia.report.units import exact_zeros, in_unit, output_units, show, unit_for
from magcilia.units import OutputUnits


def load_label(shape: BentShape) -> str:
    """The load of a shape in words: ``0.2 mN``, a flow's description, both or ``no load``."""
    load = shape.load
    parts = [show(load.force, "force")] if load.force else []  # µN for a µN-scale force
    if load.flow is not None:
        parts.append(load.flow.describe())
    return ", ".join(parts) or "no load"


def bend_scale(setup: Setup, shape: BentShape | SpatialBentShape) -> dict[str, Any]:
    """The force scale of one bend (SI): the modulus's note, and the 1 σ of the tip position (m,
    (3,)) and of the output (V) that the Young's modulus's uncertainty gives under the same
    load (central differences in ln E, :func:`~magcilia.readout.scale.per_ln_modulus`; zeros
    without a load or for a modulus taken as exact)."""
    load, rel = shape.load, setup.youngs_modulus_uncertainty
    out = {"scale_note": setup.modulus.note(), "sigma_tip_m": [0.0, 0.0, 0.0],
           "sigma_output_V": 0.0}
    if not rel or (not load.force and load.flow is None and load.actuation is None):
        return out

    def tip_and_output(s: Setup) -> np.ndarray:
        """The tip's position (m, (3,)) and the output (V) of the bend under ``s``'s modulus."""
        bent = bend(s, force=load.force, at=load.at if load.force else None,
                    direction=load.direction, azimuth=load.azimuth, flow=load.flow,
                    actuation=load.actuation)
        return np.append(bent.points[0, -1], setup.output(bent)[0])

    rate = np.abs(per_ln_modulus(tip_and_output, setup)) * rel
    out["sigma_tip_m"] = exact_zeros(rate[:3]).tolist()
    out["sigma_output_V"] = float(rate[3])
    return out


def _scale_line(record: dict[str, Any], u: OutputUnits, axes: str) -> str:
    """The force scale's line of a bend's text: the note and the tip's and output's 1 σ."""
    mm, volt = u.unit("length"), u.unit("voltage")
    sig = record[u.key("sigma_tip", "length")]
    if not any(sig):
        return str(record["scale_note"])
    tip = ", ".join(f"{a} ±{sig['xyz'.index(a)]:.2g}" for a in axes)
    return (f"{record['scale_note']}: under this load tip {tip} {mm}, output "
            f"±{record[u.key('sigma_output', 'voltage')]:.2g} {volt}")


def bend_record(setup: Setup, shape: BentShape, label: str,
                units: OutputUnits | None = None) -> dict[str, Any]:
    """One bend as the ``magcilia bend`` JSON: load, tip position, tip angle, output, B_x, range
    flag, solver figures, the force scale (:func:`bend_scale`) and the centreline, in ``units``
    (default: display units, mm, deg, mN, mV, gauss; every key carries its unit, e.g.
    ``tip_mm``); ``label`` names the setup."""
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
        **bend_scale(setup, shape),
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
    lines.append(_scale_line(record, u, "xz"))
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


# -- bending in any direction, actuation (issue 15) -------------------------------------------


def spatial_load_label(shape: BentShape | SpatialBentShape) -> str:
    """The load of any bent shape in words: the force vector (mN), the flow, the actuation."""
    load = shape.load
    vec = load.vector
    vec = np.where(np.abs(vec) > 1e-9 * float(np.abs(vec).max(initial=0.0)), vec, 0.0)
    parts = []
    if np.any(vec != 0.0):
        unit = unit_for(output_units(), "force", float(np.abs(vec).max()))  # one unit, by |F|
        parts.append("F = (" + ", ".join(f"{in_unit(c, unit, 'force'):.3g}" for c in vec)
                     + f") {unit}")
    if load.flow is not None:
        parts.append(load.flow.describe()
                     + (f" toward {math.degrees(load.flow.azimuth):.4g} deg"
                        if load.flow.azimuth else ""))
    if load.actuation is not None:
        parts.append(load.actuation.describe())
    return ", ".join(parts) or "no load"


def _load_doc(shape: BentShape | SpatialBentShape) -> dict[str, Any]:
    """The load's document, its force vector's zeros exact (cos 90° is 6e-17, not 0)."""
    doc = shape.load.describe()
    for key, value in doc.items():
        if key.startswith("force") and isinstance(value, list) and value:
            doc[key] = exact_zeros(value).tolist()
    return doc


def spatial_record(setup: Setup, shape: BentShape | SpatialBentShape, label: str,
                   units: OutputUnits | None = None) -> dict[str, Any]:
    """One bend in any direction (or under an actuation) as the ``magcilia bend`` JSON: the load
    (force vector, flow, actuation), the tip (x, y, z), tip angle, tip azimuth and horizontal
    deflection, the field at the element (the cilium's plus the actuation's direct field, each
    component), the output, the sensor's flags (:meth:`Sensor.check`), solver figures and the
    centreline (x, y, z), in ``units`` (default display units; every key carries its unit)."""
    from magcilia.device.sensor import flag_names

    spatial = shape if isinstance(shape, SpatialBentShape) else \
        SpatialCentreline.from_planar(shape)
    pts = exact_zeros(spatial.points[0])  # what is zero by symmetry prints as 0
    tip = pts[-1]
    t = spatial.tangents[0, -1]
    act = shape.load.actuation
    cilium = exact_zeros(setup.field(shape)[0])
    direct = np.asarray(act.field(np.zeros(3))) if act is not None else np.zeros(3)
    total = exact_zeros(cilium + direct)
    flags = int(setup.sensor.check(total))
    deflection = float(math.hypot(tip[0], tip[1]))
    record = {
        "setup": label,
        "load": _load_doc(shape),
        "tip_m": tip.tolist(),
        "tip_angle_rad": float(math.atan2(math.hypot(t[0], t[1]), t[2])),
        "tip_azimuth_rad": float(math.atan2(tip[1], tip[0])) if deflection > 0.0 else 0.0,
        "deflection_m": deflection,
        "output_V": float(setup.sensor.voltage(total[0])),
        "B_T": total.tolist(), "B_cilium_T": cilium.tolist(),
        "direct_field_T": direct.tolist() if act is not None else None,
        "in_range": bool(setup.sensor.in_range(total[0])),
        "sensor_flags": flags, "sensor_flag_names": flag_names(flags),
        "solver": "3-D rod" if isinstance(shape, SpatialBentShape) and shape.plane is None
        else "planar",
        "iterations": shape.iterations, "residual_rad": shape.residual,
        **bend_scale(setup, shape),
        "centreline_m": {"s": spatial.s.tolist(), "x": pts[:, 0].tolist(),
                         "y": pts[:, 1].tolist(), "z": pts[:, 2].tolist()},
    }
    u = units if units is not None else OutputUnits(False, _DISPLAY)
    return {"units": u.system, **u.convert(record)}  # type: ignore[dict-item]


def spatial_text(record: dict[str, Any], units: OutputUnits | None = None) -> str:
    """The record of :func:`spatial_record` (made with the same ``units``) as the lines
    ``magcilia bend`` prints."""
    u = units if units is not None else OutputUnits(False, _DISPLAY)
    mm, deg, volt, gauss = (u.unit("length"), u.unit("angle"), u.unit("voltage"),
                            u.unit("field"))
    x, y, z = record[u.key("tip", "length")]
    b = record[u.key("B", "field")]
    flags = record["sensor_flag_names"]
    note = "" if flags == "ok" else f"  (sensor: {flags})"
    lines = [(f"tip position  x {x:.6g} {mm}, y {y:.6g} {mm}, z {z:.6g} {mm} (from the base "
             "centre)"),
             (f"deflection    {record[u.key('deflection', 'length')]:.6g} {mm} toward azimuth "
             f"{record[u.key('tip_azimuth', 'angle')]:.6g} {deg}"),
             f"tip angle     {record[u.key('tip_angle', 'angle')]:.6g} {deg}",
             (f"output        {record[u.key('output', 'voltage')]:.9g} {volt} (B = ("
              + ", ".join(f"{c:.6g}" for c in b) + f") {gauss} at the element){note}")]
    direct = record.get(u.key("direct_field", "field"))
    act = record["load"].get("actuation")
    if act is not None and direct is not None:
        lines.append("actuation     " + act["kind"] + ": direct field ("
                     + ", ".join(f"{c:.6g}" for c in direct) + f") {gauss} at the element")
    residual = record[u.key("residual", "angle")]
    if np.isfinite(residual) and record["iterations"]:
        lines.append(f"solver        {record['solver']}, {record['iterations']} Newton "
                     f"iterations, residual {residual:.2g} {deg}")
    lines.append(_scale_line(record, u, "xyz"))
    return "\n".join(lines)


def spatial_figure(setup: Setup, shape: BentShape | SpatialBentShape) -> Any:
    """The figure of ``magcilia bend --plot`` for a bend in any direction or under an
    actuation: the shape in three projections (side views x–z and y–z, top view x–y, mm from
    the base centre) beside the unloaded cilium, with the horizontal force and a uniform
    actuation field drawn as arrows in the top view; titled with the load, tip angle and
    azimuth and the output (mV, the actuation's direct field included)."""
    from magcilia.report.figures import new_figure
    from magcilia.report.style import number

    spatial = shape if isinstance(shape, SpatialBentShape) else \
        SpatialCentreline.from_planar(shape)
    record = spatial_record(setup, shape, "", OutputUnits(True, {}))
    fig, axes = new_figure(ncols=3, size=(2.6, 4.0))
    pts = spatial.points[0] * 1e3
    length = spatial.length * 1e3
    reach = max(0.45 * length, float(np.abs(pts[:, :2]).max()) * 1.2)
    views = (("x", "z", 0, 2), ("y", "z", 1, 2), ("x", "y", 0, 1))
    for ax, (h, vname, i, j) in zip(axes[0], views, strict=True):
        top = vname == "y"
        if not top:
            ax.plot([0.0, 0.0], [0.0, length], color="0.6", ls="--", label="unloaded")
        ax.plot(pts[:, i], pts[:, j], color="C0", lw=2.0, label="loaded")
        ax.plot(pts[-1, i], pts[-1, j], "o", color="k", ms=3)
        ax.set_xlim(-reach, reach)
        if top:
            ax.set_ylim(-reach, reach)
            ax.plot(0.0, 0.0, "s", color="0.6", ms=4)  # the base
        else:
            ax.set_ylim(-0.04 * length, 1.08 * max(length, float(pts[:, 2].max())))
        ax.set_aspect("equal")
        ax.set_xlabel(f"{h} (mm)")
        ax.set_ylabel(f"{vname} (mm)" + (", from the base" if not top else ""))
        ax.grid(alpha=0.3)
    top_ax = axes[0, 2]
    arrows = []
    vec = shape.load.vector
    fh = float(math.hypot(vec[0], vec[1]))
    if fh > 0.0:
        arrows.append(("force", vec[:2] / fh, "C3"))
    act = shape.load.actuation
    if act is not None and act.is_uniform:
        b = act.uniform_field
        bh = float(math.hypot(b[0], b[1]))
        if bh > 0.0:
            arrows.append(("field", b[:2] / bh, "C2"))
    for k, (name, d, color) in enumerate(arrows):
        side = (0.15 if k == 0 else -0.15) * reach  # parallel arrows side by side
        start = -0.85 * reach * d + side * np.array([-d[1], d[0]])
        end = start + 0.5 * reach * d
        top_ax.plot([start[0], end[0]], [start[1], end[1]], color=color, lw=1.5, label=name)
        top_ax.annotate("", xy=end, xytext=end - 0.05 * reach * d,
                        arrowprops={"arrowstyle": "-|>", "color": color, "lw": 1.5})
    top_ax.set_title("top view", fontsize="medium")
    axes[0, 0].set_title("side view (x–z)", fontsize="medium")
    axes[0, 1].set_title("side view (y–z)", fontsize="medium")
    axes[0, 0].legend(loc="lower left", fontsize="small")
    if arrows:
        top_ax.legend(loc="best", fontsize="small")
    volts = record["output_V"]
    label = re.sub(r"-(?=[0-9.])", "\u2212", spatial_load_label(shape))  # a real minus
    fig.suptitle(f"load: {label}\ntip angle "
                 f"{number(math.degrees(record['tip_angle_rad']))} deg toward "
                 f"{number(math.degrees(record['tip_azimuth_rad']))} deg, output "
                 f"{number(volts * 1e3, 5)} mV", fontsize="medium")
    return fig
