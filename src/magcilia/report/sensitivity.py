"""Figures and files of a sensitivity study: figs. 9–12 equivalents, the x–y map, Sobol bars.

Plot functions take and return matplotlib axes (imported lazily); display units (mm, deg, mV) only
here. :func:`write_sensitivity_report` writes the figures, ``sensitivity.json`` and a markdown
summary into a directory (each file atomically).
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from magcilia._atomic import jsonable, save_figure, write_json, write_text
from magcilia.analysis import OATResult, PlacementMap, SensitivityStudy, SobolResult
from magcilia.analysis.tolerance import PlacementTolerance
from magcilia.device.parameters import PARAMETERS, STUDIED
from magcilia.report.units import output_units
from magcilia.units import OutputUnits, ascii_unit

if TYPE_CHECKING:
    from matplotlib.axes import Axes

def display(parameter: str) -> tuple[str, str, float]:
    """Label, unit and factor from SI of a parameter in these figures: the registry's label and
    display unit, the same quantity as the CLI, JSON and API name (the base radius is the
    radius, ``base_radius``, not the paper's fig. 12 diameter)."""
    p = PARAMETERS[parameter]
    return p.label, p.display, 1.0 / p.display_factor


#: figure file of each of the paper's sensitivity figures
FIGURE_FILES = {9: "fig09_xy.png", 10: "fig10_z.png", 11: "fig11_nk.png",
                12: "fig12_geometry.png"}
#: every figure file ``write_sensitivity_report`` may write (PDFs in the paper style)
FIGURE_NAMES = tuple(f"{Path(name).stem}{ext}"
                     for name in (*FIGURE_FILES.values(), "xy_map.png", "sobol.png")
                     for ext in (".png", ".pdf"))
#: figure file name -> the sweeps it shows (the registry's figure numbers)
FIGURES = {name: tuple(n for n in STUDIED if PARAMETERS[n].figure == number)
           for number, name in FIGURE_FILES.items()}


def _label(parameter: str) -> str:
    name, unit, _ = display(parameter)
    return f"{name} ({unit})" if unit else name


def plot_sweep_curves(result: OATResult, ax: Axes | None = None, max_curves: int = 9) -> Axes:
    """Output (mV) vs tilt (deg) for up to ``max_curves`` values of a one-at-a-time sweep,
    coloured by the swept value (colour bar; every value of a whole-number sweep up to 12), the
    reference curve dashed; returns ``ax`` (a new figure when None)."""
    from matplotlib import colormaps
    from matplotlib.cm import ScalarMappable
    from matplotlib.colors import BoundaryNorm, Normalize

    from magcilia.report.figures import axes_or_new

    ax = axes_or_new(ax)
    deg = np.degrees(result.angles)
    integer = PARAMETERS[result.parameter].domain == "integer"
    shown = result.values.size if integer and result.values.size <= 12 else max_curves
    idx = np.unique(np.linspace(0, result.values.size - 1, min(shown, result.values.size))
                    .round().astype(int))
    values = result.values * display(result.parameter)[2]
    cmap = colormaps["viridis"].resampled(256)
    if integer:  # one colour per whole number shown
        edges = np.r_[values[idx] - 0.5, values[idx][-1] + 0.5]
        norm: Normalize = BoundaryNorm(edges, cmap.N)
    else:
        norm = Normalize(float(values.min()), float(values.max()))
    for i in idx:
        ax.plot(deg, result.curves[i] * 1e3, color=cmap(norm(values[i])), lw=1.2)
    ax.plot(deg, result.reference * 1e3, color="k", ls=(0, (4, 3)), lw=1.2, label="reference")
    bar = ax.figure.colorbar(ScalarMappable(norm, cmap), ax=ax, location="top", aspect=35,
                             pad=0.02, label=_label(result.parameter),
                             ticks=values[idx] if integer and idx.size <= 10 else None)
    bar.ax.axvline(result.nominal * display(result.parameter)[2], color="k", lw=1.5)
    ax.set_xlabel("tilt angle θ (deg)")
    ax.set_ylabel("sensor output (mV)")
    ax.grid(alpha=0.3)
    ax.legend(loc="best")
    return ax


def plot_sweep_measure(result: OATResult, ax: Axes | None = None) -> Axes:
    """RMS output change (mV) vs the swept value, and the calibration cost (V², log) on a twin
    axis when the study had measurements; returns ``ax`` (a new figure when None)."""
    from magcilia.report.figures import axes_or_new

    ax = axes_or_new(ax)
    _, _, factor = display(result.parameter)
    x = result.values * factor
    marker = "o" if PARAMETERS[result.parameter].domain == "integer" else ""
    ax.plot(x, result.rms_change * 1e3, marker=marker, ms=3, color="C0", label="RMS change")
    ax.plot(x, result.shape_change * 1e3, marker=marker, ms=3, color="C0", ls="--",
            label="offset-free")
    ax.axvline(result.nominal * factor, color="k", ls=":", lw=1)
    ax.set_xlabel(_label(result.parameter))
    ax.set_ylabel("RMS output change (mV)", color="C0")
    ax.grid(alpha=0.3)
    handles, labels = ax.get_legend_handles_labels()
    top = float(np.nanmax(np.r_[result.rms_change, result.shape_change])) * 1e3
    ax.set_ylim(-0.04 * top, 1.3 * top)  # the legend's row above the curves
    target = ax
    if result.cost is not None:
        twin = ax.twinx()
        twin.plot(x, result.cost, marker=marker, ms=3, color="C3", label="cost")
        twin.set_ylabel("calibration cost (V²)", color="C3")
        twin.set_yscale("log")
        cost = result.cost[np.isfinite(result.cost) & (result.cost > 0)]
        if cost.size:
            lo, hi = float(cost.min()), float(cost.max())
            decades = math.log10(hi / lo) if hi > lo else 1.0
            twin.set_ylim(lo / 10 ** (0.04 * decades), hi * 10 ** (0.3 * decades))
        more = twin.get_legend_handles_labels()
        handles, labels = handles + more[0], labels + more[1]
        target = twin  # drawn above the twin's line
    target.legend(handles, labels, loc="upper center", ncols=len(labels), handlelength=1.4,
                  columnspacing=0.8)
    return ax


def plot_xy_map(xy: PlacementMap, ax: Axes | None = None, quantity: str = "rms") -> Axes:
    """Map of the RMS change (mV) or the cost (V², log) over x, y (mm); the reference marked;
    returns ``ax`` (a new figure when None)."""
    from matplotlib.colors import LogNorm

    from magcilia.report.figures import axes_or_new

    ax = axes_or_new(ax, size=(6.0, 4.8))
    z = xy.cost if quantity == "cost" and xy.cost is not None else xy.rms_change * 1e3
    extent = (xy.x[0] * 1e3, xy.x[-1] * 1e3, xy.y[0] * 1e3, xy.y[-1] * 1e3)
    if quantity == "cost" and xy.cost is not None:
        pos = z[np.isfinite(z) & (z > 0)]
        norm = LogNorm(vmin=float(pos.min()), vmax=float(pos.max())) if pos.size else None
        label = "calibration cost (V²)"
    else:
        norm, label = None, "RMS output change (mV)"
    im = ax.imshow(z, origin="lower", extent=extent, aspect="auto", cmap="magma", norm=norm)
    if np.isfinite(z).sum() > 4 and norm is None:
        ax.contour(xy.x * 1e3, xy.y * 1e3, z, colors="w", linewidths=0.6, levels=6)
    ax.plot(xy.nominal[0] * 1e3, xy.nominal[1] * 1e3, "+", color="c", ms=10, mew=2,
            label="reference")
    ax.figure.colorbar(im, ax=ax, label=label)
    ax.set_xlabel("x (mm)")
    ax.set_ylabel("y (mm)")
    ax.legend(loc="upper right")
    return ax


def plot_sobol(result: SobolResult, ax: Axes | None = None) -> Axes:
    """Horizontal bars of first-order and total Sobol indices with their confidence intervals;
    returns ``ax`` (a new figure when None)."""
    from magcilia.report.figures import axes_or_new

    ax = axes_or_new(ax)
    names = [display(n)[0] if n in PARAMETERS else n for n in result.names]
    pos = np.arange(len(names))
    bars: dict[str, Any] = {"capsize": 2, "error_kw": {"elinewidth": 0.8}}
    ax.barh(pos - 0.2, result.S1, 0.4, xerr=result.S1_conf, color="C0",
            label="first order $S_1$", **bars)
    ax.barh(pos + 0.2, result.ST, 0.4, xerr=result.ST_conf, color="C1", label="total $S_T$",
            **bars)
    ax.axvline(0.0, color="0.4", lw=0.8)
    ax.set_yticks(pos, names)
    ax.invert_yaxis()  # the registry's order, top down
    ax.set_xlabel("Sobol index")
    ax.set_title(f"global sensitivity ({result.measure}, {result.n_evaluations} evaluations)")
    ax.grid(alpha=0.3, axis="x")
    ax.legend(loc="best")
    return ax


def sweep_figure(study: SensitivityStudy, parameters: tuple[str, ...]) -> Any:
    """One figure: for each parameter, its curves (top, the swept value on a colour bar above,
    the reference marked on it) and measure (bottom)."""
    from magcilia.report.figures import new_figure

    fig, axes = new_figure(ncols=len(parameters), nrows=2, size=(5.5, 3.8))
    for j, name in enumerate(parameters):
        plot_sweep_curves(study.sweeps[name], axes[0, j])
        plot_sweep_measure(study.sweeps[name], axes[1, j])
    return fig


def sensitivity_figures(study: SensitivityStudy,
                        sobol: SobolResult | None = None) -> dict[str, Any]:
    """The figures of ``magcilia sensitivity --out`` by file name (figs. 9–12 equivalents, the
    x–y map and, with ``sobol``, the Sobol bars), built in the style in use."""
    from magcilia.report.figures import new_figure

    figures = {fname: sweep_figure(study, params) for fname, params in FIGURES.items()}
    ncols = 2 if study.xy_map.cost is not None else 1
    fig, axes = new_figure(ncols=ncols, size=(6.0, 4.8))
    plot_xy_map(study.xy_map, axes[0, 0])
    if ncols == 2:
        plot_xy_map(study.xy_map, axes[0, 1], quantity="cost")
    figures["xy_map.png"] = fig
    if sobol is not None:
        fig, axes = new_figure()
        plot_sobol(sobol, axes[0, 0])
        figures["sobol.png"] = fig
    return figures


def markdown_summary(study: SensitivityStudy, sobol: SobolResult | None = None,
                     tolerance: PlacementTolerance | None = None,
                     figures: dict[str, str] | None = None,
                     units: OutputUnits | None = None) -> str:
    """Short markdown summary: the sweep table, notes, Sobol and tolerance tables, figure links;
    in ``units`` (default: display units, as the figures; SI with ``output_units(si=True)``)."""
    u = units if units is not None else output_units()
    volt = u.unit("voltage")
    lines = ["# Sensitivity of the cilium model", ""]
    if study.data_source:
        lines += [(f"Measurements: `{study.data_source}` (cost = sum of squared residuals, offset "
                  "solved in closed form)."), ""]
    lines += [("Changes are RMS over the tilt angles vs the reference curve; *offset-free* "
               "removes the mean difference (what a fitted output offset absorbs)."), "",
              f"| parameter | span | max RMS change ({volt}) | max offset-free change ({volt}) |"
              + (" min cost (V²) |" if study.data_source else ""),
              "|---|---|---|---|" + ("---|" if study.data_source else "")]
    for r in study.table():
        name, unit, f = display(r["parameter"])
        if u.si:  # SI: m, rad, ...
            unit, f = u.unit(r["parameter"]), f * PARAMETERS[r["parameter"]].display_factor
        span = f"{r['span'][0] * f:.4g}..{r['span'][1] * f:.4g} {unit}".strip()
        change = u.factor("voltage")
        row = (f"| {name} | {span} | {r['max_rms_change_V'] / change:.4g} | "
               f"{r['max_shape_change_V'] / change:.4g} |")
        if "min_cost_V2" in r:
            row += f" {r['min_cost_V2']:.4g} |"
        lines.append(row)
    if study.notes:
        lines += ["", *[f"- note: {n}" for n in study.notes]]
    if sobol is not None:
        lines += ["", (f"## Sobol indices ({sobol.measure}, N = {sobol.n_base}, "
                  f"{sobol.n_evaluations} evaluations)"), "", "| parameter | S1 | ST |",
                  "|---|---|---|"]
        lines += [f"| {r['parameter']} | {r['S1']:.3f} ± {r['S1_conf']:.3f} | "
                  f"{r['ST']:.3f} ± {r['ST_conf']:.3f} |" for r in sobol.table()]
    if tolerance is not None:
        doc = u.convert(dict(jsonable(tolerance.to_dict())))
        assert isinstance(doc, dict)
        lines += ["", "## Placement tolerance", "", "```", tolerance_text(doc, u), "```"]
    if figures:
        lines += ["", "## Figures", ""]
        lines += [f"![{k}]({p})" for k, p in figures.items()]
    return "\n".join(lines) + "\n"


def report_dict(study: SensitivityStudy, sobol: SobolResult | None = None,
                tolerance: PlacementTolerance | None = None,
                units: OutputUnits | None = None) -> dict[str, Any]:
    """The content of ``sensitivity.json`` in ``units`` (default: SI; ``magcilia sensitivity``
    passes display units unless ``--si``): every number's key carries its unit (``x_mm``,
    ``nominal_mm``, ``rms_change_mV``, ``angles_deg``); NaN/inf as null."""
    u = units if units is not None else output_units(si=True)
    doc = study.to_dict()
    doc["setup"] = u.named(doc["setup"])
    doc["spans"] = u.named(doc["spans"])
    for row in doc.get("summary", []):
        name = row["parameter"]
        for key in ("nominal", "span"):
            if key in row:
                row[u.key(key, name)] = u.value(row.pop(key), name)
    for name, sweep in doc.get("sweeps", {}).items():
        for key in ("nominal", "values"):
            if key in sweep:
                sweep[u.key(key, name)] = u.value(sweep.pop(key), name)
    doc["sobol"] = None if sobol is None else sobol.to_dict()
    if doc["sobol"] is not None:
        sob = doc["sobol"]
        sob["bounds"] = u.named(sob["bounds"])
        unit = "V2" if sob.get("measure") == "cost" else "V"
        for key in ("output_mean", "output_std"):
            if key in sob:
                sob[f"{key}_{unit}"] = sob.pop(key)
    doc["tolerance"] = None if tolerance is None else tolerance.to_dict()
    return dict(jsonable({"units": u.system, **u.convert(doc)}))  # type: ignore[dict-item]


def tolerance_text(doc: dict[str, Any], units: OutputUnits) -> str:
    """The placement tolerance (the ``tolerance`` entry of :func:`report_dict`, made with the
    same ``units``) as the lines ``magcilia sensitivity`` prints."""
    deg, mm, volt = units.unit("angle"), units.unit("length"), units.unit("voltage")
    a, m, v = (ascii_unit(x) for x in (deg, mm, volt))
    lines = [f"placement tolerance for {doc[f'angle_accuracy_{a}']:.3g} {deg} angle accuracy",
             (f"noise {doc[f'noise_rms_{v}']:.3g} {volt} rms over {doc['bandwidth_Hz'][0]:g}.."
              f"{doc['bandwidth_Hz'][1]:g} Hz -> noise-limited angle resolution "
              f"{doc[f'noise_angle_{a}']:.3g} {deg} (1 sigma, worst angle)")]
    for name, tol, worst, tol_n in zip(doc["coordinates"], doc[f"tolerance_{m}"],
                                       doc[f"worst_angle_{a}"],
                                       doc[f"tolerance_with_noise_{m}"], strict=True):
        if tol is None:  # inf: no first-order effect
            lines.append(f"{name}: no first-order effect on the angle")
            continue
        lines.append(f"{name} must be known to ±{tol:.3g} {mm} (worst at {worst:.3g} {deg}; "
                     f"±{tol_n:.3g} {mm} once the noise is spent)")
    return "\n".join(lines)


def write_sensitivity_report(study: SensitivityStudy, directory: str | Path,
                             sobol: SobolResult | None = None,
                             tolerance: PlacementTolerance | None = None,
                             units: OutputUnits | None = None,
                             style: str = "screen") -> dict[str, Path]:
    """Write figs. 9–12 equivalents, the x–y map, Sobol bars, ``sensitivity.json`` (in
    ``units``, default SI; see :func:`report_dict`) and ``summary.md`` into ``directory``; with
    ``style="paper"`` a vector PDF beside each PNG (the summary links the PNGs). Returns the
    written paths by name."""
    from magcilia.report import style as st

    out = Path(directory)
    out.mkdir(parents=True, exist_ok=True)
    written: dict[str, Path] = {}
    with st.use(style):
        for fname, fig in sensitivity_figures(study, sobol).items():
            save_figure(fig, out / fname, dpi=st.dpi())
            written[fname] = out / fname
            if style == "paper":
                pdf = Path(fname).with_suffix(".pdf").name
                save_figure(fig, out / pdf)
                written[pdf] = out / pdf
    write_json(out / "sensitivity.json", report_dict(study, sobol, tolerance, units))
    written["sensitivity.json"] = out / "sensitivity.json"
    figs = {k: k for k in written if k.endswith(".png")}
    write_text(out / "summary.md", markdown_summary(study, sobol, tolerance, figs,
                                                    units or output_units(si=False)))
    written["summary.md"] = out / "summary.md"
    return written
