"""Figures of the biaxial read-out: estimated force vectors against the truth.

:func:`force_vector_figure` draws, in the force plane (Fx, Fy in mN; µN for µN-scale loads), the
true loads, the estimates with their 2σ error ellipses (from each reading's noise covariance),
and beside it the pulls (estimate − truth)/σ of magnitude and direction against the true
direction, where an honest σ keeps ~95 % of them within ±2. Readings without an estimate or a
direction (flags) are left out of the pulls and counted in the title.

The ellipses and pulls use the noise's σ (:attr:`ForceVectorResult.covariance_noise`): the force
scale's σ (the Young's modulus's uncertainty) is systematic, one error shared by every reading of
the cilium, which readings against a truth made with the same modulus cannot show; the title says
where the force scale comes from.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
from numpy.typing import ArrayLike

from magcilia import _validate as v
from magcilia.readout.biaxial import ForceVectorResult, polar_sigmas
from magcilia.report.readout import flag_names
from magcilia.report.units import output_units, unit_for
from magcilia.units import UNITS

#: the ellipses' radius in σ (2σ: ~86 % of a 2-D normal's draws lie inside)
ELLIPSE_SIGMAS = 2.0


def noise_sigmas(result: ForceVectorResult) -> tuple[np.ndarray, np.ndarray]:
    """The noise's 1 σ of the magnitude (N) and of the direction (rad) of each reading, flat:
    :attr:`ForceVectorResult.covariance_noise` along and across the estimate
    (:func:`~magcilia.readout.biaxial.polar_sigmas`; NaN without an estimate, inf without a
    direction, as the result's own)."""
    s_mag, s_dir = polar_sigmas(result.covariance_noise.reshape(-1, 2, 2),
                                result.magnitude.reshape(-1),
                                np.arctan2(result.fy, result.fx).reshape(-1))
    s_dir = np.where(np.isinf(result.sigma_direction.reshape(-1)), np.inf, s_dir)
    return s_mag, s_dir


def _truth(truth: ArrayLike, result: ForceVectorResult) -> np.ndarray:
    t = v.finite_array("truth", truth, unit="N")
    if t.shape != (*result.fx.shape, 2):
        raise v.fail("truth", f"an array of shape {t.shape}",
                     f"shape {(*result.fx.shape, 2)}: the true (Fx, Fy) of each reading, N")
    return t.reshape(-1, 2)


def plot_force_vectors(truth: ArrayLike, result: ForceVectorResult, ax: Any = None,
                       ellipse_scale: float = 1.0, legend: bool = True) -> Any:
    """Draw true loads (rings), estimates (dots) and their 2σ error ellipses (the noise's, see
    the module docstring) in the force plane.

    Parameters
    ----------
    truth : array-like, shape (..., 2)
        The true (Fx, Fy) of each reading, N (the readings' shape).
    result : ForceVectorResult
        The read-out's estimates.
    ax : matplotlib Axes, optional
        Where to draw; a new figure when None.
    ellipse_scale : float
        Enlarge the ellipses by this factor (said in the legend) where σ is too small to see.
    legend : bool
        Draw a legend in the axes (:func:`force_vector_figure` draws one for the figure).

    Returns
    -------
    matplotlib Axes
    """
    from matplotlib.patches import Ellipse
    from matplotlib.ticker import MaxNLocator

    from magcilia.report.figures import axes_or_new
    from magcilia.report.style import number

    ax = axes_or_new(ax, size=(4.4, 4.4))
    si_truth = _truth(truth, result)
    # the unit of the loads' magnitude (µN for a µN-scale span; report.units' one rule)
    unit = unit_for(output_units(), "force",
                    max(float(np.max(np.abs(si_truth), initial=0.0)), float(result.span)))
    to_unit = 1.0 / UNITS["force"][unit]
    t = si_truth * to_unit
    est = result.vector.reshape(-1, 2) * to_unit
    cov = result.covariance_noise.reshape(-1, 2, 2) * to_unit**2
    good = result.estimated.reshape(-1)
    scale = v.positive("ellipse_scale", ellipse_scale, "", "factor")
    ax.plot(t[:, 0], t[:, 1], "o", mfc="none", color="0.45", label="true load")
    for i, j in zip(t[good], est[good], strict=True):
        ax.plot([i[0], j[0]], [i[1], j[1]], color="0.7", lw=0.6)
    if good.any():
        vals, vecs = np.linalg.eigh(cov[good])
        width = 2.0 * ELLIPSE_SIGMAS * scale * np.sqrt(np.clip(vals[:, 1], 0.0, None))
        height = 2.0 * ELLIPSE_SIGMAS * scale * np.sqrt(np.clip(vals[:, 0], 0.0, None))
        angle = np.degrees(np.arctan2(vecs[:, 1, 1], vecs[:, 0, 1]))
        label = f"{number(ELLIPSE_SIGMAS, 2)}σ ellipse" + (
            f" (×{number(scale, 3)})" if scale != 1.0 else "")
        for k, (xy, wd, ht, an) in enumerate(zip(est[good], width, height, angle,
                                                  strict=True)):
            ax.add_patch(Ellipse(tuple(xy), wd, ht, angle=an, fill=False, edgecolor="C0",
                                 lw=0.8, label=label if k == 0 else None))
        ax.plot(est[good, 0], est[good, 1], ".", color="C1", label="estimate")
    reach = max(float(np.max(np.abs(t))), result.span * to_unit) * 1.12
    ax.set_xlim(-reach, reach)
    ax.set_ylim(-reach, reach)
    ax.set_aspect("equal")
    ax.axhline(0.0, color="0.85", lw=0.6, zorder=0)
    ax.axvline(0.0, color="0.85", lw=0.6, zorder=0)
    circle = np.linspace(0.0, 2.0 * math.pi, 361)
    ax.plot(result.span * to_unit * np.cos(circle), result.span * to_unit * np.sin(circle), ls=":",
            color="0.6", lw=0.8, label="span")
    ax.xaxis.set_major_locator(MaxNLocator(5, symmetric=True))
    ax.yaxis.set_major_locator(MaxNLocator(5, symmetric=True))
    ax.set_xlabel(f"$F_x$ ({unit})")
    ax.set_ylabel(f"$F_y$ ({unit})")
    if legend:
        ax.legend(loc="upper left", ncols=2, fontsize="small")
    return ax


def plot_pulls(truth: ArrayLike, result: ForceVectorResult, ax: Any = None,
               legend: bool = True) -> Any:
    """Pulls (estimate − truth)/σ of the magnitude and the direction against the true
    direction (deg), with the ±2 band an honest σ keeps ~95 % of them in (σ: the noise's,
    :func:`noise_sigmas`).

    Parameters
    ----------
    truth : array-like, shape (..., 2)
        The true (Fx, Fy), N.
    result : ForceVectorResult
        The estimates.
    ax : matplotlib Axes, optional
        Where to draw; a new figure when None.
    legend : bool
        Draw a legend in the axes.

    Returns
    -------
    matplotlib Axes
    """
    from magcilia.report.figures import axes_or_new

    ax = axes_or_new(ax, size=(4.4, 4.4))
    t = _truth(truth, result)
    true_mag = np.hypot(t[:, 0], t[:, 1])
    true_dir = np.arctan2(t[:, 1], t[:, 0])
    mag = result.magnitude.reshape(-1)
    direction = result.direction.reshape(-1)
    s_mag, s_dir = noise_sigmas(result)
    with np.errstate(invalid="ignore", divide="ignore"):
        p_mag = (mag - true_mag) / s_mag
        p_dir = (np.remainder(direction - true_dir + math.pi, 2 * math.pi) - math.pi) / s_dir
    x = np.degrees(true_dir) % 360.0
    ax.axhspan(-2.0, 2.0, color="0.92", zorder=0, label="±2σ")
    shown = np.isfinite(p_mag)
    ax.plot(x[shown], p_mag[shown], "o", ms=3.0, mfc="none", color="C0", label="magnitude pull")
    shown = np.isfinite(p_dir)
    ax.plot(x[shown], p_dir[shown], "s", ms=2.5, mfc="none", color="C3", label="direction pull")
    ax.set_xlim(-10.0, 370.0)
    ax.set_xticks(np.arange(0.0, 361.0, 90.0))
    lim = max(4.0, float(np.nanmax(np.abs(np.concatenate([p_mag, p_dir])[
        np.isfinite(np.concatenate([p_mag, p_dir]))]), initial=0.0)) * 1.15)
    ax.set_ylim(-lim, (1.3 if legend else 1.0) * lim)
    ax.set_xlabel("true direction (deg)")
    ax.set_ylabel("(estimate − truth) / σ")
    if legend:
        ax.legend(loc="upper right", ncols=3, fontsize="small")
    return ax


def force_vector_figure(truth: ArrayLike, result: ForceVectorResult,
                        ellipse_scale: float = 1.0, title: str | None = None) -> Any:
    """The read-out vs truth: the force plane with 2σ ellipses (left) and the pulls (right).

    Parameters
    ----------
    truth : array-like, shape (..., 2)
        The true (Fx, Fy) of each reading, N.
    result : ForceVectorResult
        The estimates (:meth:`magcilia.BiaxialReadout.read`).
    ellipse_scale : float
        Enlarge the ellipses by this factor where σ is too small to see (said in the legend).
    title : str, optional
        Figure title; default a count of the readings and of the flagged ones, and where the
        force scale comes from (its σ, systematic, is not in the ellipses and pulls).

    Returns
    -------
    matplotlib Figure
    """
    from magcilia.report.figures import new_figure

    fig, axes = new_figure(2, 1, size=(4.4, 4.4))
    plot_force_vectors(truth, result, axes[0, 0], ellipse_scale, legend=False)
    plot_pulls(truth, result, axes[0, 1], legend=False)
    handles, labels = [], []
    for ax in axes[0]:
        h, lab = ax.get_legend_handles_labels()
        handles += h
        labels += lab
    fig.legend(handles, labels, loc="outside lower center", ncols=4)
    c = result.counts()
    no_dir = c["readings"] - int(np.isfinite(result.direction).sum())
    default = (f"{c['estimated']}/{c['readings']} force vectors estimated"
               + (f", {no_dir} without a direction" if no_dir else "")
               + ("; σ: the noise's" if result.scale_note else "")
               + (f"\n{result.scale_note} (systematic, not drawn)"
                  if result.covariance_scale.any() else ""))
    fig.suptitle(title if title is not None else default)
    return fig


# -- the CSV of ``magcilia readout --biaxial`` -------------------------------------------------

#: the CSV's estimate columns: (name, attribute of ForceVectorResult, dimension)
VECTOR_COLUMNS = (("fx", "fx", "force"), ("fy", "fy", "force"),
                  ("magnitude", "magnitude", "force"), ("direction", "direction", "angle"),
                  ("sigma_fx", "sigma_fx", "force"), ("sigma_fy", "sigma_fy", "force"),
                  ("sigma_magnitude", "sigma_magnitude", "force"),
                  ("sigma_direction", "sigma_direction", "angle"))


def vector_flag_names(flags: int) -> str:
    """The names of a force-vector reading's flags, ``|``-separated (empty for a good one):
    :func:`magcilia.report.readout.flag_names` (one flag set for every read-out)."""
    return flag_names(flags)


def vector_csv(result: ForceVectorResult, times: Any = None, si: bool = False) -> str:
    """CSV text, one row per reading: [time_s,] fx, fy, magnitude, direction and their 1-σ in
    display units (``fx_mN``, ``direction_deg``; SI with ``si``: ``fx_N``, ``direction_rad``),
    χ², the flag bits and their names; empty fields where there is no value (NaN; an undefined
    direction's σ, inf, is written ``inf``)."""
    from magcilia.report import csvtext

    force_unit, force_factor = ("N", 1.0) if si else ("mN", 1e-3)
    angle_unit, angle_factor = ("rad", 1.0) if si else ("deg", math.pi / 180.0)
    head = [] if times is None else ["time_s"]
    cols = [] if times is None else [csvtext.shortest(np.asarray(times, dtype=np.float64)
                                                      .reshape(-1))]
    for name, attr, dim in VECTOR_COLUMNS:
        unit, factor = (force_unit, force_factor) if dim == "force" else (angle_unit,
                                                                          angle_factor)
        head.append(f"{name}_{unit}")
        cols.append(csvtext.significant(np.asarray(getattr(result, attr)).reshape(-1) / factor,
                                        10 if not name.startswith("sigma") else 4))
    flags = np.asarray(result.flags).reshape(-1)
    codes, inverse = np.unique(flags, return_inverse=True)
    head += ["chi2", "flags", "flag_names"]
    cols += [csvtext.significant(np.asarray(result.chi2).reshape(-1), 6),
             csvtext.table(inverse.reshape(-1), [str(int(c)) for c in codes]),
             csvtext.table(inverse.reshape(-1), [vector_flag_names(int(c)) for c in codes])]
    return ",".join(head) + "\n" + csvtext.rows(cols).decode("ascii")
