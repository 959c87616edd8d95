"""``fit.png`` of a physical-model (joint) calibration in the style of the paper's Fig. 8: one
column per experiment, its data with 1 s.e. error bars and the fitted model above, the residuals
(measured − fitted) with the same error bars below, on a shared x axis.

Each experiment is shown in the units a lab reads it in (the edge: deg, mN, m/s, mV, gauss):

* a tilt path: the output less its fitted offset (mV), or the three field components less theirs
  (gauss; each on a panel of its own scale, its label in its colour), vs tilt angle (deg), one
  series (marker) per azimuth;
* a load experiment: the same vs tip force (mN) or flow speed (m/s);
* a coil experiment: the cilium's own part of each reading (the reading less the offsets and
  the applied field as the sensor sees it, relative to the fitted value at the weakest applied
  field: the cilium at rest), per applied field, the fields ordered by their B_x, B_y, B_z.

The data are in mV (output) or gauss (field), the residuals in µV or mG, as in the paper-mode
figure (:func:`~magcilia.report.calibration.plot_residuals`), each stepping down (µV, nV; mG,
µG, nG) where its values would read below 0.1 (:func:`panel_unit`: a 3-axis part's nT-level
noise). The residuals are ``measured − fitted`` of the
:class:`~magcilia.calibration.experiment_fit.ExperimentFit`, exactly. The error bars are the
recording's standard errors (before the fit's floors); where they are shorter than the markers
the legend says so.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import NDArray

from magcilia.constants import GAUSS

if TYPE_CHECKING:
    from matplotlib.axes import Axes
    from matplotlib.figure import Figure

    from magcilia.calibration import CalibrationResult
    from magcilia.calibration.experiment_fit import ExperimentFit

F64 = NDArray[np.float64]

#: experiments side by side in one band of the figure (more wrap into further bands): on screen,
#: and on paper (two journal columns wide)
COLUMNS = {"screen": 3, "paper": 2}
#: markers of the azimuths of one experiment (the tilt directions)
MARKERS = ("o", "s", "^", "D", "v", "P")
#: the units a panel steps down through (name, SI per unit), largest first: an output's and a
#: field's
LADDERS = {"output": (("mV", 1e-3), ("µV", 1e-6), ("nV", 1e-9)),
           "field": (("gauss", GAUSS), ("mG", 1e-3 * GAUSS), ("µG", 1e-6 * GAUSS),
                     ("nG", 1e-9 * GAUSS))}
#: a panel whose largest value is below this many units is shown in the next smaller unit
SMALL = 0.1


@dataclass(frozen=True)
class Panel:
    """What one experiment's column shows, in display units.

    Attributes
    ----------
    title : str
        The experiment and its file.
    x : ndarray, shape (a,)
        The condition of each value (deg, mN, m/s, or the coil field's rank).
    xlabel : str
    data, model, sem : ndarray, shape (a, c)
        The measured values, the fitted model and the standard errors (c = 1 output, 3 field),
        in the data panel's unit.
    residual, residual_sem : ndarray, shape (a, c)
        measured − fitted and the standard errors in the residual panel's unit.
    ylabels : list of str, length c
        The data panel's label per component (a field's components each get a panel).
    residual_label : str
    names : list of str, length c
        The components' names.
    series : ndarray of int, shape (a,)
        Which series (azimuth) each value belongs to; ``series_names`` names them.
    series_names : list of str
    joined : bool
        Whether a series' model values are joined by a line (not for the coil's conditions,
        which are no path).
    known_sem : bool
        Whether the standard errors are known (a result read back from a ``result.json``
        written before they were kept has none: no bars).
    measured_label : str
        The data's legend entry (what was taken off them).
    """

    title: str
    x: F64
    xlabel: str
    data: F64
    model: F64
    sem: F64
    residual: F64
    residual_sem: F64
    ylabels: list[str]
    residual_label: str
    names: list[str]
    series: NDArray[np.intp]
    series_names: list[str]
    joined: bool = True
    known_sem: bool = True
    measured_label: str = "measured"


def panel_unit(values: F64, observable: str, start: int = 0) -> tuple[str, float]:
    """The unit (name, SI per unit) of :data:`LADDERS` ``[observable]`` in which the largest of
    ``values`` (SI) reads at least :data:`SMALL`, from the ladder's entry ``start`` down (the
    smallest where even that is too large: zeros keep ``start``'s)."""
    ladder = LADDERS[observable][start:]
    finite = np.abs(np.asarray(values, dtype=np.float64))
    top = float(np.max(finite[np.isfinite(finite)], initial=0.0))
    if top == 0.0:
        return ladder[0]
    return next((u for u in ladder if top / u[1] >= SMALL), ladder[-1])


def _columns(values: F64) -> F64:
    """``values`` as (a, c): an output's (a,) becomes (a, 1)."""
    arr = np.asarray(values, dtype=np.float64)
    return arr[:, None] if arr.ndim == 1 else arr


def experiment_panel(e: ExperimentFit, scale: float) -> Panel:
    """The :class:`Panel` of one experiment; ``scale`` is the fitted sensor scale (V/T), with which
    a coil experiment's single-axis output sees the applied B_x."""
    output = e.observable == "output"
    names = ["output"] if output else ["$B_x$", "$B_y$", "$B_z$"]
    measured, fitted = _columns(e.measured), _columns(e.fitted)
    sem = (np.zeros_like(measured) if e.sem is None
           else np.where(np.isfinite(_columns(e.sem)), _columns(e.sem), 0.0))
    name = Path(e.source).name
    series = np.zeros(measured.shape[0], dtype=np.intp)
    series_names: list[str] = []
    if e.actuation is not None:
        applied = (scale * e.actuation[:, :1]) if output else e.actuation
        rest = int(np.argmin(np.linalg.norm(e.actuation, axis=1)))  # the weakest field
        base = fitted[rest] - applied[rest]
        order = np.lexsort(e.actuation.T[::-1])
        rank = np.empty(order.size)
        rank[order] = np.arange(order.size)
        top = float(np.max(np.linalg.norm(e.actuation, axis=1))) / GAUSS
        shown_measured, shown_fitted = measured - applied - base, fitted - applied - base
        x, joined = rank, False
        xlabel = "applied field, by $B_x$, $B_y$, $B_z$ (rank)"
        title = f"coil: {name}, {order.size} fields ≤ {top:.3g} G"
        labels = ["cilium's output"] if output else list(names)
        measured_label = "cilium's part"
    else:
        phi = np.round(np.degrees(np.mod(e.azimuths, 2 * np.pi)), 6)
        azimuths, series = np.unique(phi, return_inverse=True)
        series = series.astype(np.intp)
        series_names = [f"azimuth {a:.3g}°" for a in azimuths]
        offsets = e.offsets[:1] if output else e.offsets
        shown_measured, shown_fitted = measured - offsets, fitted - offsets
        joined = True
        if e.loads is None:
            x, xlabel, kind = np.degrees(e.angles), "tilt angle θ (deg)", "tilt path"
        elif e.load_kind == "force":
            x, xlabel, kind = e.loads * 1e3, "tip force (mN)", "tip forces"
        else:
            x, xlabel, kind = np.asarray(e.loads), "flow speed (m/s)", "flow"
        labels = ["output − offset"] if output else list(names)
        measured_label = "measured" if output else "measured − offsets"
        what = "output" if output else "3-axis field"
        title = f"{kind}: {name} ({what}, {', '.join(s.split()[1] for s in series_names)})"
    unit, si = panel_unit(np.concatenate([shown_measured, shown_fitted]), e.observable)
    # residuals: the paper-mode panel's µV or mG, smaller for a quieter sensor
    residual = measured - fitted
    res_unit, res_si = panel_unit(np.concatenate([residual, sem]), e.observable, start=1)
    return Panel(
        title=title, x=np.asarray(x, dtype=np.float64), xlabel=xlabel,
        data=shown_measured / si, model=shown_fitted / si, sem=sem / si,
        residual=residual / res_si, residual_sem=sem / res_si,
        ylabels=[f"{label} ({unit})" for label in labels],
        residual_label=f"residual ({res_unit})",
        names=names, series=series, series_names=series_names, joined=joined,
        known_sem=e.sem is not None, measured_label=measured_label)


def _hidden(values: F64, sem: F64, symbol: float) -> bool:
    """Whether every error bar is shorter than a marker, ``symbol`` of its component's spread
    (the paper-mode figure's 1.5 % on a full-height panel)."""
    for c in range(values.shape[1]):
        spread = float(np.ptp(values[:, c])) if values.shape[0] else 0.0
        if 2.0 * float(np.max(sem[:, c], initial=0.0)) >= symbol * (spread or 1.0):
            return False
    return True


def plot_panel(panel: Panel, data_axes: Sequence[Axes], residual_ax: Axes) -> None:
    """Draw ``panel``: data ± 1 s.e. and the fitted model (dark lines, or dashes at a coil's
    conditions) on ``data_axes`` (one, or one per component: a field's components each on their
    own scale, their labels in their colours), the residuals ± 1 s.e. on ``residual_ax``.
    Colours are the components (or the azimuths of an output on several), markers the
    azimuths; the legend (first data axes) names the azimuths and says what the bars are."""
    many = len(panel.series_names) > 1
    single = len(panel.names) == 1
    note = ("(s.e. not kept in this result)" if not panel.known_sem
            else "± 1 s.e." + (" (bars within symbols)"
                               if _hidden(panel.data, panel.sem, 0.015 * len(data_axes))
                               else ""))
    labelled: set[int] = set()
    for s in range(max(len(panel.series_names), 1)):
        rows = np.flatnonzero(panel.series == s)
        rows = rows[np.argsort(panel.x[rows], kind="stable")]
        for c in range(len(panel.names)):
            ax = data_axes[c if len(data_axes) > 1 else 0]
            k = s if single else c
            label = None
            if c == 0:
                label = panel.series_names[s] if many else f"{panel.measured_label} {note}"
            style = {"fmt": MARKERS[s % len(MARKERS)], "mfc": "white", "mew": 0.9,
                     "elinewidth": 0.9, "color": f"C{k}", "zorder": 3}
            ax.plot(panel.x[rows], panel.model[rows, c], "-" if panel.joined else "_",
                    color="0.15", lw=0.9, ms=8.0, zorder=4,
                    label=None if id(ax) in labelled else "fitted model")
            labelled.add(id(ax))
            ax.errorbar(panel.x[rows], panel.data[rows, c], yerr=panel.sem[rows, c],
                        label=label, **style)  # type: ignore[arg-type]
            residual_ax.errorbar(panel.x[rows], panel.residual[rows, c],
                                 yerr=panel.residual_sem[rows, c], **style)  # type: ignore[arg-type]
    first = data_axes[0]
    entries = 1 + (len(panel.series_names) if many else 1)
    # side by side where the entries are short (the azimuths), one a line where they are long
    ncols = 1 if entries == 1 or (single and not many) or not many else min(entries, 3)
    if not single and not many:
        ncols = 2 if len(panel.measured_label) + len(note) < 30 else 1
    first.legend(loc="best", ncols=ncols, fontsize="small", title_fontsize="small",
                 title=f"{panel.measured_label} {note}" if many else None)
    first.set_title(panel.title)
    for c, ax in enumerate(data_axes):
        ax.set_ylabel(panel.ylabels[c])
        if len(data_axes) > 1:
            ax.yaxis.label.set_color(f"C{c}")
        ax.margins(x=0.03, y=0.12)
        ax.grid(alpha=0.3)
        ax.tick_params(labelbottom=False)
    # room above the data for the legend (lines of it: a field's first panel is a third as tall)
    lines = -(-entries // ncols) + (1 if many else 0)
    low, high = first.get_ylim()
    first.set_ylim(low, high + (high - low) * lines * (0.09 if len(data_axes) == 1 else 0.45))
    residual_ax.axhline(0.0, color="0.5", lw=0.8, zorder=1)
    residual_ax.set_xlabel(panel.xlabel)
    residual_ax.set_ylabel(panel.residual_label)
    residual_ax.margins(x=0.03, y=0.15)
    residual_ax.grid(alpha=0.3)


def physical_fit_figure(result: CalibrationResult) -> Figure:
    """``fit.png`` of a physical-model calibration: per experiment (a column; more than
    :data:`COLUMNS` wrap into further bands) its data ± 1 s.e. and the fitted model (a field's
    three components each on a panel of their own), and the residuals ± 1 s.e. below, on a
    shared x axis (see the module docstring for the units and what each kind shows)."""
    from matplotlib.figure import Figure

    from magcilia.report.style import current, figure_size, number

    panels = [experiment_panel(e, result.setup.sensor.scale) for e in result.experiments]
    bands = -(-len(panels) // COLUMNS[current()])
    ncols = -(-len(panels) // bands)  # (four experiments: two bands of two)
    fig = Figure(figsize=figure_size(ncols, bands, (4.6, 5.0)), layout="constrained")
    grid = fig.add_gridspec(4 * bands, ncols, height_ratios=[1.0, 1.0, 1.0, 1.2] * bands)
    for i, panel in enumerate(panels):
        row, col = 4 * (i // ncols), i % ncols
        residual_ax = fig.add_subplot(grid[row + 3, col])
        if len(panel.names) == 1:
            data_axes = [fig.add_subplot(grid[row:row + 3, col], sharex=residual_ax)]
        else:
            data_axes = [fig.add_subplot(grid[row + c, col], sharex=residual_ax)
                         for c in range(3)]
        plot_panel(panel, data_axes, residual_ax)
    if current() == "screen":
        reduced = result.chi2 / result.dof if result.dof > 0 else float("nan")
        fig.suptitle(f"physical model: χ² {number(result.chi2)} for {result.dof} dof "
                     f"(reduced {number(reduced)})")
    return fig
