"""Figures of arrays of cilia: the map (cilia, sensors, field and loads) and the crosstalk matrix.

Millimetres, gauss and millinewtons appear only here. Every function takes and returns axes
(``ax=None``: a new figure, :func:`magcilia.report.figures.new_figure`, sized by the style in use).
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import ArrayLike

from magcilia.constants import GAUSS
from magcilia.device.array import CiliaArray
from magcilia.readout.array import ArrayEstimate, ArrayMetrics, Crosstalk
from magcilia.report.figures import axes_or_new, new_figure
from magcilia.report.style import number
from magcilia.report.units import show

if TYPE_CHECKING:
    from matplotlib.axes import Axes
    from matplotlib.figure import Figure


def plot_array_map(array: CiliaArray, field: ArrayLike | None = None,
                   forces: ArrayLike | None = None, ax: Axes | None = None,
                   names: bool | None = None) -> Axes:
    """Top view of an array (x, y in mm): the cilia's bases (circles of their base radius), the
    sensors (squares), the in-plane field at each sensor (arrows, gauss) and the loads on the
    cilia (arrows from their bases, mN).

    Parameters
    ----------
    array : CiliaArray
    field : array-like, shape (S, 3), optional
        A board-frame field at the sensors, T (e.g. its change from rest under the loads); its
        (x, y) part is drawn, the largest arrow half a pitch long.
    forces : array-like, shape (C, 2) or (C, 3), optional
        Horizontal loads on the cilia, N; the largest arrow half a pitch long.
    ax : Axes, optional
    names : bool, optional
        Write the cilia's names (default: for up to 25 cilia).
    """
    from matplotlib.patches import Circle

    ax = axes_or_new(ax, size=(5.6, 5.0))
    b = np.asarray(array.bases) * 1e3
    s = np.asarray(array.sensor_positions) * 1e3
    pts = np.concatenate([b[:, :2], s[:, :2]])
    extent = float(np.ptp(pts, axis=0).max()) if len(pts) > 1 else 1.0
    if len(b) > 1:
        d = np.hypot(*(b[:, None, :2] - b[None, :, :2]).transpose(2, 0, 1))
        pitch = float(np.min(d[d > 0]))
    else:
        pitch = max(extent, 2.0)
    radius = [c.cilium.base_radius * 1e3 for c in array.cilia]
    for (x, y, _), r in zip(b, radius, strict=True):
        ax.add_patch(Circle((x, y), r, facecolor="0.75", edgecolor="0.3", linewidth=0.6))
    ax.scatter([], [], s=40, marker="o", facecolor="0.75", edgecolor="0.3", label="cilium base")
    ax.scatter(s[:, 0], s[:, 1], s=22, marker="s", facecolor="none", edgecolor="C0",
               linewidths=0.8, label="sensor", zorder=3)
    if field is not None:
        f = np.asarray(field, dtype=np.float64)[:, :2] / GAUSS
        big = float(np.abs(np.hypot(f[:, 0], f[:, 1])).max())
        if big > 0.0:
            k = 0.5 * pitch / big
            ax.quiver(s[:, 0], s[:, 1], f[:, 0] * k, f[:, 1] * k, angles="xy", scale_units="xy",
                      scale=1.0, color="C0", width=0.004, zorder=4,
                      label=f"field (x, y), longest {number(big, 3)} G")
    if forces is not None:
        fo = np.asarray(forces, dtype=np.float64)[:, :2] * 1e3
        big = float(np.hypot(fo[:, 0], fo[:, 1]).max())
        if big > 0.0:
            k = 0.5 * pitch / big
            ax.quiver(b[:, 0], b[:, 1], fo[:, 0] * k, fo[:, 1] * k, angles="xy",
                      scale_units="xy", scale=1.0, color="C3", width=0.006, zorder=5,
                      label=f"load, longest {show(big * 1e-3, 'force', digits=3)}")
    if names if names is not None else len(array) <= 25:
        for (x, y, _), name in zip(b, array.names, strict=True):
            ax.annotate(name, (x, y), xytext=(0, -9), textcoords="offset points",
                        ha="center", va="top", fontsize="x-small", color="0.3")
    lo, hi = pts.min(axis=0) - 0.75 * pitch, pts.max(axis=0) + 0.75 * pitch
    ax.set_xlim(lo[0], hi[0])
    ax.set_ylim(lo[1], hi[1] + 0.35 * pitch)
    ax.set_aspect("equal")
    ax.set_xlabel("x (mm)")
    ax.set_ylabel("y (mm)")
    ax.set_title(f"{len(array)} cilia over {array.n_sensors} sensors")
    ax.legend(loc="upper left", ncols=2, fontsize="x-small")
    return ax


def plot_crosstalk(crosstalk: Crosstalk, ax: Axes | None = None, full: bool = False) -> Axes:
    """The crosstalk as an image, gauss per mN on a log scale (at most three decades).

    By default each sensor's response to each cilium (rows: sensors, columns: cilia; the
    spectral norm of the 3 × 2 block, :attr:`Crosstalk.response`), each cilium's site outlined;
    with ``full`` the whole matrix, |response| of each sensor axis (x, y, z) to a unit load on
    each cilium along x and y (:attr:`Crosstalk.matrix`)."""
    from matplotlib.colors import LogNorm
    from matplotlib.patches import Rectangle

    ax = axes_or_new(ax, size=(5.6, 5.0))
    m = np.abs(crosstalk.matrix if full else crosstalk.response) / GAUSS * 1e-3  # G/mN
    top = float(m.max()) if m.size and m.max() > 0 else 1.0
    low = max(float(m[m > 0].min()) if np.any(m > 0) else top, top * 1e-3)  # ≤ three decades
    image = ax.imshow(np.clip(m, low, None), norm=LogNorm(vmin=min(low, 0.5 * top), vmax=top),
                      cmap="viridis", aspect="auto", interpolation="nearest")
    fig = ax.get_figure()
    if fig is not None:
        fig.colorbar(image, ax=ax, label="response (G/mN)")
    c_n, s_n = len(crosstalk.names), len(crosstalk.sensor_names)
    per_c, per_s = (2, 3) if full else (1, 1)
    step_c, step_s = max(1, -(-c_n // 8)), max(1, -(-s_n // 8))
    ax.set_xticks([per_c * c + 0.5 * (per_c - 1) for c in range(0, c_n, step_c)],
                  [crosstalk.names[c] for c in range(0, c_n, step_c)], fontsize="x-small",
                  rotation=90 if c_n > 8 else 0)
    ax.set_yticks([per_s * s + 0.5 * (per_s - 1) for s in range(0, s_n, step_s)],
                  [f"S{s + 1}" for s in range(0, s_n, step_s)], fontsize="x-small")
    if not full:
        for c, s in enumerate(crosstalk.site.tolist()):
            ax.add_patch(Rectangle((c - 0.5, s - 0.5), 1.0, 1.0, fill=False, edgecolor="C3",
                                   linewidth=0.8))
    ax.set_xlabel("load on cilium" + (" (x, y)" if full else ""))
    ax.set_ylabel("sensor" + (" axis (x, y, z)" if full else " (site outlined)"))
    ax.set_title(f"crosstalk: ratio median {number(float(np.median(crosstalk.ratio)), 3)}, "
                 f"largest {number(float(crosstalk.ratio.max()), 3)}")
    return ax


def array_figure(array: CiliaArray, crosstalk: Crosstalk, field: ArrayLike | None = None,
                 forces: ArrayLike | None = None) -> Figure:
    """Two panels: the array map (:func:`plot_array_map`) and its crosstalk matrix
    (:func:`plot_crosstalk`)."""
    fig, axes = new_figure(2, 1, size=(5.2, 4.8))
    plot_array_map(array, field, forces, ax=axes[0, 0])
    plot_crosstalk(crosstalk, ax=axes[0, 1])
    return fig


# -- display records of `magcilia array` (SI rows with unit-suffixed keys; OutputUnits.convert
# turns them into display units) ---------------------------------------------------------------

def field_rows(array: CiliaArray, field: ArrayLike, readings: ArrayLike | None = None,
               load_set: int | None = None) -> list[dict[str, Any]]:
    """One row per sensor (SI): its position, the board-frame field (T) and, if given, its
    reading on its own axes (T) and whether an axis saturated.

    Parameters
    ----------
    array : CiliaArray
    field : array-like, shape (S, 3)
        Board-frame field at the sensors, T.
    readings : array-like, shape (S, 3), optional
        The sensors' readings on their axes, T (:meth:`CiliaArray.readings`).
    load_set : int, optional
        A ``set`` column (the load set's number).
    """
    b = np.asarray(field, dtype=np.float64)
    r = None if readings is None else np.asarray(readings, dtype=np.float64)
    sat = None if r is None else np.asarray(array.saturated(r).any(axis=1))
    rows = []
    for s, sensor in enumerate(array.sensors):
        row: dict[str, Any] = {} if load_set is None else {"set": load_set}
        row.update({"sensor": sensor.name, "x_m": sensor.position[0],
                    "y_m": sensor.position[1], "z_m": sensor.position[2],
                    "Bx_T": float(b[s, 0]), "By_T": float(b[s, 1]), "Bz_T": float(b[s, 2])})
        if r is not None and sat is not None:
            row.update({"reading_x_T": float(r[s, 0]), "reading_y_T": float(r[s, 1]),
                        "reading_z_T": float(r[s, 2]), "saturated": bool(sat[s])})
        rows.append(row)
    return rows


def readout_rows(estimate: ArrayEstimate, truth: ArrayLike,
                 load_set: int | None = None) -> list[dict[str, Any]]:
    """One row per cilium (SI): the true load, the estimate with its σ and flags, and the error
    (``error_N`` = |F̂ − F|; ``error_per_sigma`` = the larger of |F̂x − Fx|/σx, |F̂y − Fy|/σy
    with the noise's σ, :attr:`ArrayEstimate.sigma_noise`: a truth simulated through the model
    shares its modulus, so only the noise can show in the error; ``sigma_*`` hold the force
    scale too).

    Parameters
    ----------
    estimate : ArrayEstimate
    truth : array-like, shape (C, 2)
        The true horizontal loads, N.
    load_set : int, optional
        A ``set`` column.
    """
    f = np.asarray(truth, dtype=np.float64)[:, :2]
    rows = []
    for c, r in enumerate(estimate.table()):
        err = np.asarray(estimate.force[c]) - f[c]
        with np.errstate(divide="ignore", invalid="ignore"):
            z = float(np.max(np.abs(err) / np.asarray(estimate.sigma_noise[c])))
        row: dict[str, Any] = {} if load_set is None else {"set": load_set}
        row.update({"cilium": r["cilium"], "true_Fx_N": float(f[c, 0]),
                    "true_Fy_N": float(f[c, 1]), "true_force_N": float(np.hypot(*f[c])),
                    "true_direction_rad": float(np.arctan2(f[c, 1], f[c, 0])),
                    "Fx_N": r["Fx_N"], "Fy_N": r["Fy_N"], "force_N": r["force_N"],
                    "direction_rad": r["direction_rad"], "sigma_Fx_N": r["sigma_Fx_N"],
                    "sigma_Fy_N": r["sigma_Fy_N"], "sigma_force_N": r["sigma_force_N"],
                    "sigma_direction_rad": r["sigma_direction_rad"],
                    "error_N": float(np.hypot(*err)), "error_per_sigma": z,
                    "flags": r["flag_names"]})
        rows.append(row)
    return rows


def crosstalk_rows(crosstalk: Crosstalk) -> list[dict[str, Any]]:
    """:meth:`Crosstalk.table` (SI; the response in T/N)."""
    return crosstalk.table()


def metrics_rows(metrics: ArrayMetrics) -> list[dict[str, Any]]:
    """:meth:`ArrayMetrics.table` (SI: pitch in m, forces in N)."""
    return metrics.table()


def rows_text(rows: list[dict[str, Any]], columns: list[str] | None = None,
              digits: int = 4) -> str:
    """A fixed-width text table of display rows: one column per key (the key, with its unit
    suffix, as the header), numbers with ``digits`` significant digits."""
    if not rows:
        return "(none)"
    keys = columns or list(rows[0])

    def cell(x: Any) -> str:
        if isinstance(x, bool):
            return "yes" if x else ""
        if isinstance(x, float):
            return "inf" if x == float("inf") else f"{x:.{digits}g}"
        return str(x)

    cells = [[cell(r.get(k, "")) for k in keys] for r in rows]
    widths = [max(len(k), *(len(c[i]) for c in cells)) for i, k in enumerate(keys)]
    numeric = [all(isinstance(r.get(k), int | float) and not isinstance(r.get(k), bool)
                   for r in rows) for k in keys]

    def line(values: list[str]) -> str:
        return "  ".join(x.rjust(w) if n else x.ljust(w)
                         for x, w, n in zip(values, widths, numeric, strict=True)).rstrip()

    return "\n".join([line(keys), *(line(c) for c in cells)])


__all__ = ["array_figure", "crosstalk_rows", "field_rows", "metrics_rows", "plot_array_map",
           "plot_crosstalk", "readout_rows", "rows_text"]


