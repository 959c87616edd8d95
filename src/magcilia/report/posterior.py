"""Pair plots of a sampled posterior (corner-plot style), in display units.

Written with matplotlib alone (no ``corner`` dependency): the diagonal shows each parameter's
marginal histogram with its 68 % credible interval, the panels below it the 2-D histograms of
each pair with the contours that enclose 68 % and 95 % of the samples; the panels above the
diagonal are hidden. Only the left column and the bottom row carry tick labels.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

import numpy as np

from magcilia.calibration.posterior_result import Posterior, display_unit

if TYPE_CHECKING:
    from matplotlib.axes import Axes

#: bins of the histograms
BINS = 30
#: credible levels of the 2-D contours
CONTOURS = (0.68, 0.95)


def _label(name: str) -> str:
    unit = display_unit(name)[1]
    return f"{name.replace('_', ' ')} ({unit})" if unit else name.replace("_", " ")


def _levels(h: Any, masses: tuple[float, ...]) -> list[float]:
    """Density levels of a 2-D histogram ``h`` that enclose each of ``masses`` (increasing)."""
    flat = np.sort(h.ravel())[::-1]
    cum = np.cumsum(flat) / max(float(flat.sum()), 1e-300)
    levels = sorted({float(flat[min(int(np.searchsorted(cum, m)), flat.size - 1)])
                     for m in masses})
    return [lv for lv in levels if lv > 0]


def _smooth(h: Any) -> Any:
    """A 2-D histogram smoothed by a [1, 2, 1]/4 kernel along each axis (smoother contours)."""
    for axis in (0, 1):
        padded = np.concatenate([np.take(h, [0], axis=axis), h, np.take(h, [-1], axis=axis)],
                                axis=axis)
        n = h.shape[axis]
        h = (np.take(padded, range(n), axis=axis) + 2.0 * np.take(padded, range(1, n + 1),
                                                                      axis=axis)
             + np.take(padded, range(2, n + 2), axis=axis)) / 4.0
    return h


def plot_pairs(posterior: Posterior, axes: Any = None) -> Any:
    """A corner plot of ``posterior``: marginal histograms on the diagonal, 2-D histograms with
    68 % and 95 % contours below it, display units (mm, mV) where a name is a registry parameter.

    Parameters
    ----------
    posterior : Posterior
        The result of :func:`magcilia.calibration.posterior.sample_posterior`.
    axes : array of matplotlib Axes, shape (p, p), optional
        Where to draw; a new figure (p × p panels) when None.

    Returns
    -------
    ndarray of matplotlib Axes, shape (p, p)
        The axes (those above the diagonal hidden).
    """
    from matplotlib.ticker import MaxNLocator

    if not isinstance(posterior, Posterior):
        from magcilia._validate import fail

        raise fail("posterior", type(posterior).__name__, "a magcilia Posterior")
    p = len(posterior.names)
    if axes is None:
        from magcilia.report.figures import new_figure

        fig, axes = new_figure(ncols=p, nrows=p, size=(1.7, 1.7))
        engine: Any = fig.get_layout_engine()
        engine.set(w_pad=0.02, h_pad=0.02, wspace=0.0, hspace=0.0)
    axes = np.asarray(axes, dtype=object).reshape(p, p)
    factors = np.array([display_unit(n)[0] for n in posterior.names])
    S = posterior.samples / factors
    lo = np.percentile(S, 0.5, axis=0)
    hi = np.percentile(S, 99.5, axis=0)
    hi = np.where(hi > lo, hi, lo + 1.0)
    for i in range(p):
        for j in range(p):
            ax: Axes = axes[i, j]
            if j > i:
                ax.xaxis.set_visible(False)
                ax.yaxis.set_visible(False)
                ax.set_visible(False)
                continue
            if i == j:
                ax.hist(S[:, i], bins=BINS, range=(lo[i], hi[i]), color="0.45",
                        histtype="stepfilled", alpha=0.8)
                a, b = posterior.intervals[0.68][i] / factors[i]
                for x in (a, b):
                    ax.axvline(x, color="C0", lw=0.8, ls="--")
                ax.set_yticks([])
                ax.set_xlim(lo[i], hi[i])
            else:
                h, xe, ye = np.histogram2d(S[:, j], S[:, i], bins=BINS,
                                           range=[[lo[j], hi[j]], [lo[i], hi[i]]])
                ax.pcolormesh(xe, ye, h.T, cmap="Greys", shading="flat", rasterized=True)
                h = _smooth(h)
                levels = _levels(h, CONTOURS)
                if len(levels) >= 1 and h.max() > 0:
                    xc, yc = 0.5 * (xe[1:] + xe[:-1]), 0.5 * (ye[1:] + ye[:-1])
                    ax.contour(xc, yc, h.T, levels=levels, colors="C0", linewidths=0.8)
                ax.set_xlim(lo[j], hi[j])
                ax.set_ylim(lo[i], hi[i])
            ax.xaxis.set_major_locator(MaxNLocator(3, prune="both"))
            if i != j:
                ax.yaxis.set_major_locator(MaxNLocator(3, prune="both"))
            if i == p - 1:
                ax.set_xlabel(_label(posterior.names[j]))
                ax.tick_params(axis="x", labelrotation=45)
            else:
                ax.tick_params(axis="x", labelbottom=False)
            if j == 0 and i > 0:
                ax.set_ylabel(_label(posterior.names[i]))
            else:
                ax.tick_params(axis="y", labelleft=False)
    return axes
