"""Figures and files of a sensitivity study: figs. 9–12 equivalents, the x–y map, Sobol bars.

Plot functions take and return matplotlib axes (imported lazily); display units (mm, deg, mV) only
here. :func:`write_sensitivity_report` writes the figures, ``sensitivity.json`` and a markdown
summary into a directory (each file atomically).
"""

from __future__ import annotations

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
    """Label, unit and factor from SI of a parameter in these figures: the registry's display
    unit, except that the base radius is shown as the base diameter, as the paper's fig. 12
    does."""
    p = PARAMETERS[parameter]
    if parameter == "base_radius":
        return "base diameter d", p.display, 2.0 / p.display_factor
    return p.label, p.display, 1.0 / p.display_factor


#: figure file of each of the paper's sensitivity figures
FIGURE_FILES = {9: "fig09_xy.png", 10: "fig10_z.png", 11: "fig11_nk.png",
                12: "fig12_geometry.png"}
#: figure file name -> the sweeps it shows (the registry's figure numbers)
FIGURES = {name: tuple(n for n in STUDIED if PARAMETERS[n].figure == number)
           for number, name in FIGURE_FILES.items()}


def _label(parameter: str) -> str:
    name, unit, _ = display(parameter)
    return f"{name} ({unit})" if unit else name


def plot_sweep_curves(result: OATResult, ax: Axes, max_curves: int = 7) -> Axes:
    """Output (mV) vs tilt (deg) for up to ``max_curves`` values of the sweep, reference dashed."""
    from matplotlib import colormaps

    name, unit, factor = display(result.parameter)
    deg = np.degrees(result.angles)
    idx = np.unique(np.linspace(0, result.values.size - 1, min(max_curves, result.values.size))
                    .round().astype(int))
    cmap = colormaps["viridis"]
    for j, i in enumerate(idx):
        color = cmap(j / max(1, idx.size - 1))
        val = result.values[i] * factor
        ax.plot(deg, result.curves[i] * 1e3, color=color,
                label=f"{name} = {val:.4g} {unit}".strip())
    ax.plot(deg, result.reference * 1e3, "k--", lw=1.5, label="reference")
    ax.set_xlabel("tilt angle θ (deg)")
    ax.set_ylabel("sensor output (mV)")
    ax.grid(alpha=0.3)
    ax.legend(fontsize="x-small")
    return ax


def plot_sweep_measure(result: OATResult, ax: Axes) -> Axes:
    """RMS output change (mV) vs the swept value, and the calibration cost on a twin axis."""
    _, _, factor = display(result.parameter)
    x = result.values * factor
    marker = "o" if PARAMETERS[result.parameter].domain == "integer" else ""
    ax.plot(x, result.rms_change * 1e3, marker=marker, color="C0", label="RMS change")
    ax.plot(x, result.shape_change * 1e3, marker=marker, color="C0", ls="--", label="offset-free")
    ax.legend(fontsize="x-small", loc="upper center")
    ax.axvline(result.nominal * factor, color="k", ls=":", lw=1)
    ax.set_xlabel(_label(result.parameter))
    ax.set_ylabel("RMS change of the output (mV)", color="C0")
    ax.grid(alpha=0.3)
    if result.cost is not None:
        twin = ax.twinx()
        twin.plot(x, result.cost, marker=marker, color="C3", label="cost")
        twin.set_ylabel("calibration cost (V²)", color="C3")
        twin.set_yscale("log")
    return ax


def plot_xy_map(xy: PlacementMap, ax: Axes, quantity: str = "rms") -> Axes:
    """Map of the RMS change (mV) or the cost (V², log) over x, y (mm); the reference marked."""
    from matplotlib.colors import LogNorm

    z = xy.cost if quantity == "cost" and xy.cost is not None else xy.rms_change * 1e3
    extent = (xy.x[0] * 1e3, xy.x[-1] * 1e3, xy.y[0] * 1e3, xy.y[-1] * 1e3)
    if quantity == "cost" and xy.cost is not None:
        pos = z[np.isfinite(z) & (z > 0)]
        norm = LogNorm(vmin=float(pos.min()), vmax=float(pos.max())) if pos.size else None
        label = "calibration cost (V²)"
    else:
        norm, label = None, "RMS change of the output (mV)"
    im = ax.imshow(z, origin="lower", extent=extent, aspect="auto", cmap="magma", norm=norm)
    if np.isfinite(z).sum() > 4 and norm is None:
        ax.contour(xy.x * 1e3, xy.y * 1e3, z, colors="w", linewidths=0.6, levels=6)
    ax.plot(xy.nominal[0] * 1e3, xy.nominal[1] * 1e3, "c+", ms=12, mew=2, label="reference")
    ax.figure.colorbar(im, ax=ax, label=label)
    ax.set_xlabel("x (mm)")
    ax.set_ylabel("y (mm)")
    ax.legend(fontsize="small")
    return ax


def plot_sobol(result: SobolResult, ax: Axes) -> Axes:
    """Bars of first-order and total Sobol indices with confidence intervals."""
    names = [display(n)[0] if n in PARAMETERS else n for n in result.names]
    pos = np.arange(len(names))
    ax.bar(pos - 0.2, result.S1, 0.4, yerr=result.S1_conf, capsize=3, label="first order S1")
    ax.bar(pos + 0.2, result.ST, 0.4, yerr=result.ST_conf, capsize=3, label="total ST")
    ax.set_xticks(pos, names, rotation=30, ha="right")
    ax.set_ylabel("Sobol index")
    ax.set_title(f"global sensitivity ({result.measure}, {result.n_evaluations} evaluations)")
    ax.grid(alpha=0.3, axis="y")
    ax.legend(fontsize="small")
    return ax


def sweep_figure(study: SensitivityStudy, parameters: tuple[str, ...]) -> Any:
    """One figure: for each parameter, its curves (top) and measure (bottom)."""
    from magcilia.report.figures import new_figure

    fig, axes = new_figure(ncols=len(parameters), nrows=2, size=(5.5, 3.8))
    for j, name in enumerate(parameters):
        plot_sweep_curves(study.sweeps[name], axes[0, j])
        plot_sweep_measure(study.sweeps[name], axes[1, j])
        axes[0, j].set_title(f"sensitivity to {display(name)[0]}")
    return fig


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
        if u.si:  # the base diameter in m; the rest in SI
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
                             units: OutputUnits | None = None) -> dict[str, Path]:
    """Write figs. 9–12 equivalents, the x–y map, Sobol bars, ``sensitivity.json`` (in
    ``units``, default SI; see :func:`report_dict`) and ``summary.md`` into ``directory``;
    returns the written paths by name."""
    from magcilia.report.figures import new_figure

    out = Path(directory)
    out.mkdir(parents=True, exist_ok=True)
    written: dict[str, Path] = {}
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
    for fname, fig in figures.items():
        save_figure(fig, out / fname, dpi=120)
        written[fname] = out / fname
    write_json(out / "sensitivity.json", report_dict(study, sobol, tolerance, units))
    written["sensitivity.json"] = out / "sensitivity.json"
    figs = {k: k for k in written if k.endswith(".png")}
    write_text(out / "summary.md", markdown_summary(study, sobol, tolerance, figs,
                                                    units or output_units(si=False)))
    written["summary.md"] = out / "summary.md"
    return written
