"""The calibration report: the paper's Fig. 8 (data, initial and fitted model), residuals, the
parameter table and the warnings, as PNG figures and a markdown summary."""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping, Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import NDArray

from magcilia._atomic import save_figure, staged_directory, write_json, write_text
from magcilia._errors import MagciliaError
from magcilia.calibration import CalibrationResult
from magcilia.calibration.temperature import temperature_doc, temperature_lines
from magcilia.constants import GAUSS
from magcilia.device.parameters import PARAMETERS as REGISTRY
from magcilia.io.measurement import Measurement
from magcilia.io.setup_files import save_setup
from magcilia.io.temperature_table import TEMPERATURE_TABLE, fitted_temperature_table
from magcilia.report.recording_notes import data_doc, data_markdown
from magcilia.report.units import output_units

if TYPE_CHECKING:
    from matplotlib.axes import Axes
    from matplotlib.figure import Figure

    from magcilia.report.figure_process import FigureWriter


def _bias(result: CalibrationResult, angles: NDArray[np.float64]) -> NDArray[np.float64]:
    """The fitted bias at ``angles`` (rad), V (the constant offset and any angle terms)."""
    coef = result.bias_coefficients
    if coef.size == 0:
        return np.zeros_like(angles)
    return np.asarray(np.polynomial.polynomial.polyval(angles, coef), dtype=np.float64)


def measured_field(result: CalibrationResult) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """The measurement in field units: ``B_x = (V − bias(θ)) / S`` with the fitted setup's sensor
    scale ``S`` and the fitted bias, and its standard error ``sem / |S|``; both T, shape (a,)."""
    scale = result.setup.sensor.scale
    data = result.path
    return (data.volts - _bias(result, data.angles)) / scale, data.sem / abs(scale)


def _volts_axis(ax: Axes, scale: float, offset: float, label: str, factor: float) -> Any:
    """A secondary y axis of ``ax`` (in units of ``factor`` × gauss) showing the output
    ``S·B + offset`` in mV or µV (``label``)."""
    unit = 1e3 if "mV" in label else 1e6

    def to_volts(g: Any) -> Any:
        return (np.asarray(g) / factor * GAUSS * scale + offset) * unit

    def to_field(v: Any) -> Any:
        return (np.asarray(v) / unit - offset) / scale / GAUSS * factor

    sec = ax.secondary_yaxis("right", functions=(to_volts, to_field))
    sec.set_ylabel(label)
    return sec


def plot_fit(result: CalibrationResult, ax: Axes | None = None) -> Axes:
    """The paper's Fig. 8: the measured field with 1 s.e. error bars and the fitted model's
    ``B_x`` (gauss) vs tilt (deg), the sensor output (mV) on the right-hand axis.

    The measurement is shown as field, ``B_x = (V − bias(θ)) / S`` (:func:`measured_field`),
    the right-hand axis reads ``V = S·B_x + offset`` with the fitted offset (with a bias
    polynomial in the angle, the output less its angle terms).

    Parameters
    ----------
    result : CalibrationResult
    ax : matplotlib Axes, optional
        Where to draw; a new figure when None.

    Returns
    -------
    matplotlib Axes
    """
    from magcilia.report.figures import axes_or_new

    ax = axes_or_new(ax)
    data = result.path
    b, sem = measured_field(result)
    dense = np.radians(np.linspace(data.angles_deg.min(), data.angles_deg.max(), 300))
    ax.plot(np.degrees(dense), result.setup.field(dense)[:, 0] / GAUSS, "-", color="C0",
            label="fitted model", zorder=2)
    spread = float(np.ptp(b)) or 1.0
    hidden = 2.0 * float(sem.max()) < 0.015 * spread  # bars shorter than the symbols
    ax.errorbar(data.angles_deg, b / GAUSS, yerr=sem / GAUSS, fmt="o", mfc="white", mew=0.9,
                elinewidth=0.9, color="k", zorder=3,
                label="measured (mean ± 1 s.e." + (", bars within symbols)" if hidden else ")"))
    ax.set_xlabel("tilt angle θ (deg)")
    ax.set_ylabel("$B_x$ at the sensing element (gauss)")
    ax.margins(x=0.02, y=0.08)
    ax.grid(alpha=0.3)
    ax.legend(loc="best")
    coef = result.bias_coefficients
    _volts_axis(ax, result.setup.sensor.scale, float(coef[0]) if coef.size else 0.0,
                "output (mV)" if coef.size <= 1 else "output less bias(θ) terms (mV)", 1.0)
    return ax


def plot_initial(result: CalibrationResult, ax: Axes | None = None) -> Axes:
    """The start of the fit: the measured field (as :func:`plot_fit`) and the initial model's
    ``B_x`` (gauss) vs tilt (deg), on their own scale.

    Parameters
    ----------
    result : CalibrationResult
    ax : matplotlib Axes, optional
        Where to draw; a new figure when None.

    Returns
    -------
    matplotlib Axes
    """
    from magcilia.report.figures import axes_or_new

    ax = axes_or_new(ax)
    data = result.path
    b, _ = measured_field(result)
    dense = np.radians(np.linspace(data.angles_deg.min(), data.angles_deg.max(), 300))
    ax.plot(np.degrees(dense), result.initial.field(dense)[:, 0] / GAUSS, "--", color="C1",
            label="initial model")
    ax.plot(data.angles_deg, b / GAUSS, "o", ms=2.5, color="k", label="measured")
    ax.set_xlabel("tilt angle θ (deg)")
    ax.set_ylabel("$B_x$ (gauss)")
    ax.grid(alpha=0.3)
    ax.legend(loc="best")
    return ax


def plot_residuals(result: CalibrationResult, ax: Axes | None = None) -> Axes:
    """Residuals (measured − fitted) as field, mG (10⁻³ gauss), with 1 s.e. error bars, vs tilt
    (deg); µV on the right-hand axis.

    Parameters
    ----------
    result : CalibrationResult
    ax : matplotlib Axes, optional
        Where to draw; a new figure when None.

    Returns
    -------
    matplotlib Axes
    """
    from magcilia.report.figures import axes_or_new

    ax = axes_or_new(ax, size=(6.4, 3.0))
    data = result.path
    scale = result.setup.sensor.scale
    mg = 1e3 / GAUSS / scale
    ax.errorbar(data.angles_deg, result.residuals * mg, yerr=data.sem * abs(mg), fmt="o",
                mfc="white", mew=0.9, elinewidth=0.9, color="k")
    ax.axhline(0.0, color="0.5", lw=0.8)
    ax.set_xlabel("tilt angle θ (deg)")
    ax.set_ylabel("residual of $B_x$ (mG)")
    ax.margins(x=0.02)
    ax.grid(alpha=0.3)
    _volts_axis(ax, scale, 0.0, "residual (µV)", 1e3)
    return ax


def fit_figure(result: CalibrationResult) -> Figure:
    """``fit.png``: Fig. 8 (:func:`plot_fit`), the residuals with their error bars
    (:func:`plot_residuals`) and the initial model on its own panel (:func:`plot_initial`), one
    above the other on a shared angle axis; of a physical fit :func:`joint_fit_figure` (one
    column per experiment)."""
    from magcilia.report.figures import new_figure

    if result.model != "paper":
        return joint_fit_figure(result)
    from magcilia.report.style import current, number

    fig, axes = new_figure(nrows=3, size=(6.4, 2.3), sharex=True, height_ratios=(2.4, 1.0, 1.1))
    plot_fit(result, axes[0, 0])
    plot_residuals(result, axes[1, 0])
    plot_initial(result, axes[2, 0])
    axes[1, 0].set_ylabel("residual (mG)")
    for ax in axes[:2, 0]:
        ax.set_xlabel("")
    if current() == "screen":
        axes[0, 0].set_title(f"fit: RMS residual {number(result.rms * 1e6)} µV, cost "
                             f"{number(result.cost)} V²")
    fig.align_ylabels(axes[:, 0])
    return fig


def residuals_figure(result: CalibrationResult) -> Figure:
    """``residuals.png``: :func:`plot_residuals` alone."""
    from magcilia.report.figures import new_figure

    fig, axes = new_figure(size=(6.4, 3.0))
    plot_residuals(result, axes[0, 0])
    return fig


def markdown_summary(result: CalibrationResult, figures: dict[str, str]) -> str:
    """The report as markdown (figure paths relative to the report)."""
    lines = [
        "# magcilia calibration report",
        "",
        f"Data: `{result.path.source}`, {len(result.path)} angles"
        + (" (set/reset readings)" if result.path.set_reset else "") + ".",
        "",
        f"- cost (sum of squared residuals): **{result.cost:.6g} V²**",
        f"- RMS residual: {result.rms * 1e3:.4g} mV",
        f"- bias model: {result.bias}",
        f"- model evaluations: {result.evaluations}, time {result.elapsed:.2f} s",
        f"- restarts' final costs: {', '.join(f'{c:.4g}' for c in result.restart_costs)} V²",
        *(f"- {line}" for line in temperature_lines(result)),
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
                     f"| {se_text} |" + ((f" {r['truth']:.6g} |" if math.isfinite(r["truth"])
                                          else " – |") if "truth" in r else ""))
    lines += ["", "## Warnings", ""]
    lines += [f"- {w}" for w in result.warnings] or ["- none"]
    lines += ["", *data_markdown([result.path])]
    comparison = result.truth_comparison()
    if comparison:
        known = "The recording is synthetic: its true parameters are known."
        lines += ["", "## Fit versus truth", "", known, "", *comparison[1:]]
    lines += ["", "## Figures", ""]
    lines += [f"![{name}]({path})" for name, path in figures.items()]
    lines.append("")
    return "\n".join(lines)


def write_report(result: CalibrationResult, directory: str | Path,
                 style: str = "screen", writer: FigureWriter | None = None) -> dict[str, Path]:
    """Write ``fit.png``, ``residuals.png`` and ``report.md`` into ``directory`` (atomically);
    with ``style="paper"`` also ``fit.pdf`` and ``residuals.pdf`` (vector, one column wide; the
    report links the PNGs). ``writer`` (:func:`~magcilia.report.figure_process.figure_writer`)
    may draw the figures in a helper process: they are then written when its ``wait()``
    returns."""
    out = Path(directory)
    out.mkdir(parents=True, exist_ok=True)
    paths = {"fit": out / "fit.png", "residuals": out / "residuals.png"}
    for name, build in (("fit", fit_figure), ("residuals", residuals_figure)):
        targets = [paths[name]]
        if style == "paper":
            paths[f"{name}_pdf"] = out / f"{name}.pdf"
            targets.append(paths[f"{name}_pdf"])
        if writer is None:
            draw_figure(build, result, targets, style)
        else:
            writer.submit(draw_figure, build, result, targets, style)
    paths["report"] = out / "report.md"
    write_text(paths["report"], markdown_summary(
        result, {"data and models (Fig. 8)": "fit.png", "residuals": "residuals.png"}))
    return paths


def draw_figure(build: Callable[[CalibrationResult], Figure], result: CalibrationResult,
                paths: Sequence[Path], style: str) -> None:
    """Build one figure of ``result`` in ``style`` and save it to each of ``paths`` (PNG at the
    style's resolution; PDF)."""
    from magcilia.report import style as st

    with st.use(style):
        fig = build(result)
        for path in paths:
            if path.suffix == ".pdf":
                save_figure(fig, path)
            else:
                save_figure(fig, path, dpi=st.dpi())


def calibration_json(result: CalibrationResult, si: bool = False,
                     data: Sequence[Measurement] | None = None) -> dict[str, Any]:
    """``calibrate --json``: a paper fit's :meth:`CalibrationResult.to_dict` in the console
    table's display units (SI with ``si``), every dimensional key suffixed with its unit:
    parameter values, standard errors, bounds, held and true values keyed ``height_mm``, …; the
    covariance with a unit per row; the bias coefficients with theirs; costs in V^2 in both
    systems. A physical fit's: :func:`joint_calibration_json`. ``data``: the measurements
    fitted (default a paper fit's tilt path)."""
    if result.model != "paper":
        return joint_calibration_json(result, si, () if data is None else data)
    units = output_units(si)
    raw = result.to_dict()
    doc: dict[str, Any] = units.convert(  # type: ignore[assignment]
        {k: v for k, v in raw.items()
         if k not in ("values", "stderr", "bounds", "fixed", "truth", "table", "covariance",
                      "propagation_covariance", "bias_coefficients", "parameters", "setup",
                      "initial", "measurement", "model")})
    for key in ("values", "stderr", "bounds", "fixed"):
        doc[key] = units.named(raw[key])
    if result.truth is not None:
        doc["truth"] = units.named(dict(result.truth))
    for key in ("covariance", "propagation_covariance"):  # null rows: undetermined parameters
        covariance = raw.get(key)
        if not covariance or covariance.get("matrix") is None:
            continue
        names = list(covariance["names"])
        f = [units.factor(n) for n in names]
        doc[key] = {**covariance, "units": [units.unit(n) for n in names], "matrix": [
            [None if c is None or not math.isfinite(c) else c / (f[i] * f[j])
             for j, c in enumerate(row)] for i, row in enumerate(covariance["matrix"])]}
    volt, angle = units.factor("voltage"), units.factor("angle")
    v, a = units.unit("voltage"), units.unit("angle")
    coefficients = raw["bias_coefficients"]
    doc["bias_coefficients"] = [c * angle ** k / volt for k, c in enumerate(coefficients)]
    doc["bias_coefficient_units"] = [v if k == 0 else f"{v}/{a}" if k == 1 else f"{v}/{a}^{k}"
                                     for k in range(len(coefficients))]
    doc["table"] = result.table(si)
    doc["data"] = data_doc([result.path] if data is None else data)
    return {"units": units.system, **doc}


#: the files ``magcilia calibrate --out`` (and ``demo``) writes into its folder
CALIBRATION_FILES = ("fitted_setup.toml", "result.json", "report.md", "fit.png", "residuals.png")
#: every file it may write: :data:`CALIBRATION_FILES` and, in the paper style, the PDF figures
CALIBRATION_NAMES = (*CALIBRATION_FILES, "fit.pdf", "residuals.pdf", "pairs.png", "pairs.pdf")


def calibration_files(result: CalibrationResult) -> tuple[str, ...]:
    """The files :func:`write_calibration_files` writes for ``result`` (screen style): a paper
    fit's :data:`CALIBRATION_FILES`; a physical fit's setup, result, report, ``fit.png`` and,
    with a posterior, ``pairs.png``."""
    if result.model == "paper":
        return CALIBRATION_FILES
    return (*CALIBRATION_FILES[:4], *(("pairs.png",) if result.posterior is not None else ()))


def write_calibration_files(result: CalibrationResult, directory: str | Path,
                            style: str = "screen", *, figures: bool = True,
                            comparison: str | None = None,
                            data: Sequence[Measurement] | None = None,
                            writer: FigureWriter | None = None,
                            temperature: Mapping[str, Any] | None = None) -> None:
    """Write :func:`calibration_files` into the existing folder ``directory`` (each file atomic,
    the folder not: use :func:`write_calibration`, or a ``staged_directory`` of your own); the
    PDF figures only with ``style="paper"``; with ``figures=False`` the same files less the
    figures (``report.md`` then links none). ``data``: the measurements fitted (what the
    readers said of them goes into ``result.json`` and ``report.md``; default a paper fit's
    tilt path); ``comparison``: the paper's model beside a physical fit
    (:func:`model_comparison`); ``writer``: the figures drawn by it (see :func:`write_report`;
    call its ``wait()`` before publishing the folder); ``temperature``: the initial setup file's
    ``[temperature]`` table, written into ``fitted_setup.toml`` with the temperatures the
    calibration saw (:func:`fitted_setup_tables`)."""
    if result.model != "paper":
        _write_joint_files(result, directory, style, comparison, () if data is None else data,
                           figures, writer, temperature)
        return
    folder = Path(directory)
    save_setup(result.setup, folder / "fitted_setup.toml",
               tables=fitted_setup_tables(result, temperature))
    doc = result.to_dict()
    doc.setdefault("units", "SI")  # a format magcilia reads back: SI, whatever the CLI shows
    doc["data"] = data_doc([result.path] if data is None else data)
    write_json(folder / "result.json", doc)
    if figures:
        write_report(result, folder, style, writer)
    else:
        write_text(folder / "report.md", markdown_summary(result, {}))


def fitted_setup_tables(result: CalibrationResult, temperature: Mapping[str, Any] | None = None
                        ) -> dict[str, dict[str, Any]]:
    """The tables ``fitted_setup.toml`` holds beside the setup: ``[temperature]`` (the initial
    setup file's ``temperature`` table with ``reference`` and ``calibrated_range`` the
    temperatures the calibration saw, :func:`~magcilia.io.temperature_table.
    fitted_temperature_table`), where there is one."""
    table = fitted_temperature_table(temperature, result.temperature_range,
                                     result.temperature_mean)
    return {} if table is None else {TEMPERATURE_TABLE: table}


def write_calibration(result: CalibrationResult, directory: str | Path, *,
                      force: bool = False, style: str = "screen") -> None:
    """Write everything ``magcilia calibrate --out`` gives into the new folder ``directory``: the
    fitted setup (``fitted_setup.toml``), ``result.json`` (SI), ``report.md``, ``fit.png`` and
    ``residuals.png`` (and their PDFs with ``style="paper"``).

    The folder is filled under a staging name and renamed in one step: a failure or a crash
    leaves nothing behind. An existing ``directory`` (an earlier output) is replaced only with
    ``force=True``.
    """
    with staged_directory(directory, force=force, names=CALIBRATION_NAMES) as tmp:
        write_calibration_files(result, tmp, style)


# --- joint calibration (model="physical", several experiments) -----------------------------------
def joint_fit_figure(result: CalibrationResult) -> Figure:
    """``fit.png`` of a joint calibration:
    :func:`~magcilia.report.calibration_physical.physical_fit_figure` (one column per experiment,
    data ± 1 s.e., the fitted model and the residuals)."""
    from magcilia.report.calibration_physical import physical_fit_figure

    return physical_fit_figure(result)


def pairs_figure(result: CalibrationResult) -> Figure:
    """``pairs.png``: the posterior's corner plot (:func:`~magcilia.report.posterior.plot_pairs`)
    of a physical fit sampled with ``posterior=True``."""
    from magcilia.report.posterior import plot_pairs

    if result.posterior is None:
        raise MagciliaError("this calibration has no posterior: fit with posterior=True")
    fig: Figure = plot_pairs(result.posterior)[0, 0].get_figure()
    return fig


def model_comparison(paper: CalibrationResult, physical: CalibrationResult) -> str:
    """The paper's model and the physical model fitted to the same recording, side by side
    (display units): each one's geometry ± standard error, its layout and how well it fits."""
    n, k = int(paper.values["n_loops"]), int(paper.values["dipoles_per_loop"])
    heads = (f"paper (n={n}, k={k} searched)",
             f"physical (n={physical.n_loops}, k={physical.dipoles_per_loop})")
    lines = ["the two models on the same data (geometry ± standard error):",
             f"{'parameter':<12} {'unit':<4} {heads[0]:>30} {heads[1]:>30}"]
    for name in ("height", "base_radius", "x", "y", "z"):
        p = REGISTRY[name]
        cells = []
        for fit in (paper, physical):
            value, se = fit.values[name], fit.stderr.get(name, math.nan)
            text = (f"{p.to_display(value):.4g} ± {p.to_display(se):.2g}" if math.isfinite(se)
                    else f"{p.to_display(value):.4g} (undetermined)" if se == math.inf
                    else f"{p.to_display(value):.4g}")
            cells.append(text)
        lines.append(f"{name:<12} {p.display:<4} {cells[0]:>30} {cells[1]:>30}")
    same = next((e for e in physical.experiments
                 if e.source == paper.path.source and e.observable == "output"), None)
    lines.append(f"{'RMS':<12} {'mV':<4} {paper.rms * 1e3:>30.4g} "
                 f"{format(same.rms * 1e3, '.4g') if same else '-':>30}")
    lines.append("The paper's model trades its coarse layout against the geometry: its height and "
                 "base radius are model parameters; the physical model's are the hair's (to the "
                 "layout's stated accuracy).")
    return "\n".join(lines)


def joint_markdown_summary(result: CalibrationResult, comparison: str | None = None,
                           data: Sequence[Measurement] = ()) -> str:
    """The joint calibration's report as markdown: the plain-text report, the figures (the
    posterior's pair plot when it was sampled), with ``comparison`` the paper's model on the
    same data (:func:`model_comparison`), and with ``data`` (the measurements fitted) what the
    readers said of them."""
    pairs = ("" if result.posterior is None
             else "![posterior: marginals and 68 %, 95 % contours](pairs.png)\n")
    both = "" if comparison is None else f"\n## Both models\n\n```\n{comparison}\n```\n"
    notes = "\n" + "\n".join(data_markdown(data)) if data else ""
    return (f"# magcilia joint calibration report\n\n```\n{result.report()}\n```\n\n"
            "![data and fitted model per experiment](fit.png)\n" + pairs + both + notes)


def write_joint_calibration_files(result: CalibrationResult, directory: str | Path,
                                  style: str = "screen", comparison: str | None = None,
                                  data: Sequence[Measurement] = ()) -> None:
    """:func:`write_calibration_files` under its earlier name for a physical fit."""
    write_calibration_files(result, directory, style, comparison=comparison, data=data)


def _write_joint_files(result: CalibrationResult, directory: str | Path, style: str,
                       comparison: str | None, data: Sequence[Measurement],
                       figures: bool, writer: FigureWriter | None = None,
                       temperature: Mapping[str, Any] | None = None) -> None:
    """Write ``fitted_setup.toml``, ``result.json`` (SI), ``report.md``, ``fit.png`` and, with a
    posterior, ``pairs.png`` (and their PDFs with ``style="paper"``) of a physical fit into
    ``directory``; with ``data`` (the measurements fitted) what the readers said of them; the
    figures drawn by ``writer`` when given (:func:`write_report`)."""
    folder = Path(directory)
    save_setup(result.setup, folder / "fitted_setup.toml",
               tables=fitted_setup_tables(result, temperature))
    doc = result.to_dict()
    doc.setdefault("units", "SI")
    if data:
        doc["data"] = data_doc(data)
    write_json(folder / "result.json", doc)
    builds: dict[str, Callable[[CalibrationResult], Figure]] = (
        {"fit": joint_fit_figure} if figures else {})
    if figures and result.posterior is not None:
        builds["pairs"] = pairs_figure
    for name, build in builds.items():
        targets = [folder / f"{name}.png", *([folder / f"{name}.pdf"] if style == "paper"
                                             else [])]
        if writer is None:
            draw_figure(build, result, targets, style)
        else:
            writer.submit(draw_figure, build, result, targets, style)
    write_text(folder / "report.md", joint_markdown_summary(result, comparison, data))


def joint_calibration_json(result: CalibrationResult, si: bool = False,
                           data: Sequence[Measurement] = ()) -> dict[str, Any]:
    """``calibrate --model physical --json``: the parameters, standard errors and priors in the
    console's display units (mm; SI with ``si``), keys suffixed with their units, with each
    experiment's RMS and offsets (mV/µT; V/T with ``si``) and, with ``data`` (the measurements
    fitted), what the readers said of them."""
    units = output_units(si)
    names = ("height", "base_radius", "x", "y", "z", "youngs_modulus")
    geometry: dict[str, object] = {n: result.values[n] for n in names if n in result.values}
    out: dict[str, Any] = {
        "model": result.model, "n_loops": result.n_loops,
        "dipoles_per_loop": result.dipoles_per_loop, "chi2": result.chi2, "dof": result.dof,
        "values": units.named(geometry),
        "stderr": units.named({n: result.stderr.get(n, math.nan) for n in geometry}),
        "prior_values": units.named({k: float(p[0]) for k, p in result.priors.items()}),
        "prior_sigmas": units.named({k: float(p[1]) for k, p in result.priors.items()}),
        "warnings": list(result.warnings), "temperature_K": temperature_doc(result)}
    experiments = []
    for e in result.experiments:
        unit, factor = ((e.unit(), 1.0) if si else ("mV", 1e3) if e.observable == "output"
                        else ("uT", 1e6))
        experiments.append({"source": e.source, "observable": e.observable,
                            f"rms_{unit}": e.rms * factor, "chi2": e.chi2,
                            f"offsets_{unit}": (e.offsets * factor).tolist()})
    out["experiments"] = experiments
    if data:
        out["data"] = data_doc(data)
    post = result.posterior
    if post is not None:
        out["posterior"] = {
            "mean": units.named(dict(zip(post.names, post.mean.tolist(), strict=True))),
            "sd": units.named(dict(zip(post.names, post.sd.tolist(), strict=True))),
            **{f"interval_{round(100 * level)}": units.named(
                dict(zip(post.names, iv.tolist(), strict=True)))
               for level, iv in post.intervals.items()},
            "ess": dict(zip(post.names, post.ess.tolist(), strict=True)),
            "weights": post.weights.tolist(), "seconds": post.seconds,
            "converged": post.converged}
    return out
