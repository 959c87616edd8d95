"""The calibration report: the paper's Fig. 8 (data, initial and fitted model), residuals, the
parameter table and the warnings, as PNG figures and a markdown summary."""

from __future__ import annotations

import math
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from magcilia._atomic import save_figure, staged_directory, write_json, write_text
from magcilia.calibration import CalibrationResult
from magcilia.io.setup_files import save_setup
from magcilia.report.figures import new_figure
from magcilia.report.units import output_units

if TYPE_CHECKING:
    from matplotlib.axes import Axes


def plot_fit(result: CalibrationResult, ax: Axes) -> Axes:
    """Fig. 8: measured means (error bars: 1 standard error), initial and fitted model (mV).

    The initial model is drawn with the fitted bias so that shapes can be compared."""
    data = result.data
    dense = np.radians(np.linspace(data.angles_deg.min(), data.angles_deg.max(), 300))
    ax.errorbar(data.angles_deg, data.volts * 1e3, yerr=data.sem * 1e3, fmt="o", ms=4,
                capsize=2, label="measured (mean ± s.e.)", color="k")
    offset = result.values["offset"]
    ax.plot(np.degrees(dense), (result.initial.replace(offset=offset).output(dense)) * 1e3,
            "--", label="initial model", color="tab:orange")
    fitted = result.setup.output(dense)
    coef = result.bias_coefficients
    if coef.size > 1:  # polynomial bias beyond the constant
        fitted = fitted + np.polynomial.polynomial.polyval(dense, np.r_[0.0, coef[1:]])
    ax.plot(np.degrees(dense), fitted * 1e3, "-", label="fitted model", color="tab:blue")
    ax.set_xlabel("tilt angle θ (deg)")
    ax.set_ylabel("sensor output (mV)")
    ax.set_title(f"cost {result.cost:.3g} V², RMS {result.rms * 1e3:.3g} mV")
    ax.grid(alpha=0.3)
    ax.legend(fontsize="small")
    return ax


def plot_residuals(result: CalibrationResult, ax: Axes) -> Axes:
    """Residuals (measured − fitted, µV) with the measurement standard errors."""
    data = result.data
    ax.errorbar(data.angles_deg, result.residuals * 1e6, yerr=data.sem * 1e6, fmt="o", ms=4,
                capsize=2, color="k")
    ax.axhline(0.0, color="0.5", lw=0.8)
    ax.set_xlabel("tilt angle θ (deg)")
    ax.set_ylabel("residual (µV)")
    ax.grid(alpha=0.3)
    return ax


def markdown_summary(result: CalibrationResult, figures: dict[str, str]) -> str:
    """The report as markdown (figure paths relative to the report)."""
    lines = [
        "# magcilia calibration report",
        "",
        f"Data: `{result.data.source}`, {len(result.data)} angles"
        + (" (set/reset readings)" if result.data.set_reset else "") + ".",
        "",
        f"- cost (sum of squared residuals): **{result.cost:.6g} V²**",
        f"- RMS residual: {result.rms * 1e3:.4g} mV",
        f"- bias model: {result.bias}",
        f"- model evaluations: {result.evaluations}, time {result.elapsed:.2f} s",
        f"- restarts' final costs: {', '.join(f'{c:.4g}' for c in result.restart_costs)} V²",
        "",
        "| parameter | unit | initial | fitted | standard error |"
        + (" truth |" if result.truth is not None else ""),
        "|---|---|---|---|---|" + ("---|" if result.truth is not None else ""),
    ]
    for r in result.table():
        se = r["stderr"]
        se_text = ("fixed" if r.get("fixed") else f"{se:.4g}" if math.isfinite(se)
                   else "undetermined" if se == math.inf else "–")
        lines.append(f"| {r['parameter']} | {r['unit']} | {r['initial']:.6g} | {r['fitted']:.6g} "
                     f"| {se_text} |" + (f" {r['truth']:.6g} |" if "truth" in r else ""))
    lines += ["", "## Warnings", ""]
    lines += [f"- {w}" for w in result.warnings] or ["- none"]
    comparison = result.truth_comparison()
    if comparison:
        known = "The recording is synthetic: its true parameters are known."
        lines += ["", "## Fit versus truth", "", known, "", *comparison[1:]]
    lines += ["", "## Figures", ""]
    lines += [f"![{name}]({path})" for name, path in figures.items()]
    lines.append("")
    return "\n".join(lines)


def write_report(result: CalibrationResult, directory: str | Path) -> dict[str, Path]:
    """Write ``fit.png``, ``residuals.png`` and ``report.md`` into ``directory`` (atomically)."""
    out = Path(directory)
    out.mkdir(parents=True, exist_ok=True)
    paths = {"fit": out / "fit.png", "residuals": out / "residuals.png"}
    fig, axes = new_figure()
    plot_fit(result, axes[0, 0])
    save_figure(fig, paths["fit"], dpi=130)
    fig, axes = new_figure(size=(6.4, 3.0))
    plot_residuals(result, axes[0, 0])
    save_figure(fig, paths["residuals"], dpi=130)
    paths["report"] = out / "report.md"
    write_text(paths["report"], markdown_summary(
        result, {"data and models (Fig. 8)": "fit.png", "residuals": "residuals.png"}))
    return paths


def calibration_json(result: CalibrationResult, si: bool = False) -> dict[str, Any]:
    """``calibrate --json``: :meth:`CalibrationResult.to_dict` in the console table's display
    units (SI with ``si``), every dimensional key suffixed with its unit: parameter values,
    standard errors, bounds, held and true values keyed ``height_mm``, …; the covariance with a
    unit per row; the bias coefficients with theirs; costs in V^2 in both systems."""
    units = output_units(si)
    raw = result.to_dict()
    doc: dict[str, Any] = units.convert(  # type: ignore[assignment]
        {k: v for k, v in raw.items()
         if k not in ("values", "stderr", "bounds", "fixed", "truth", "table", "covariance",
                      "bias_coefficients")})
    for key in ("values", "stderr", "bounds", "fixed"):
        doc[key] = units.named(raw[key])
    if result.truth is not None:
        doc["truth"] = units.named(dict(result.truth))
    covariance = raw.get("covariance")
    if covariance and covariance.get("matrix") is not None:
        names = list(covariance["names"])
        f = [units.factor(n) for n in names]
        doc["covariance"] = {
            "names": names, "units": [units.unit(n) for n in names],
            "matrix": [[None if c is None else c / (f[i] * f[j]) for j, c in enumerate(row)]
                       for i, row in enumerate(covariance["matrix"])]}
    volt, angle = units.factor("voltage"), units.factor("angle")
    v, a = units.unit("voltage"), units.unit("angle")
    coefficients = raw["bias_coefficients"]
    doc["bias_coefficients"] = [c * angle ** k / volt for k, c in enumerate(coefficients)]
    doc["bias_coefficient_units"] = [v if k == 0 else f"{v}/{a}" if k == 1 else f"{v}/{a}^{k}"
                                     for k in range(len(coefficients))]
    doc["table"] = result.table(si)
    return {"units": units.system, **doc}


#: the files ``magcilia calibrate --out`` (and ``demo``) writes into its folder
CALIBRATION_FILES = ("fitted_setup.toml", "result.json", "report.md", "fit.png", "residuals.png")


def write_calibration_files(result: CalibrationResult, directory: str | Path) -> None:
    """Write :data:`CALIBRATION_FILES` into the existing folder ``directory`` (each file atomic,
    the folder not: use :func:`write_calibration`, or a ``staged_directory`` of your own)."""
    folder = Path(directory)
    save_setup(result.setup, folder / "fitted_setup.toml")
    doc = result.to_dict()
    doc.setdefault("units", "SI")  # a format magcilia reads back: SI, whatever the CLI shows
    write_json(folder / "result.json", doc)
    write_report(result, folder)


def write_calibration(result: CalibrationResult, directory: str | Path, *,
                      force: bool = False) -> None:
    """Write everything ``magcilia calibrate --out`` gives into the new folder ``directory``: the
    fitted setup (``fitted_setup.toml``), ``result.json`` (SI), ``report.md``, ``fit.png`` and
    ``residuals.png``.

    The folder is filled under a staging name and renamed in one step: a failure or a crash
    leaves nothing behind. An existing ``directory`` (an earlier output) is replaced only with
    ``force=True``.
    """
    with staged_directory(directory, force=force, names=CALIBRATION_FILES) as tmp:
        write_calibration_files(result, tmp)
