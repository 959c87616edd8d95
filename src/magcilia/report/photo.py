"""What a tilt measurement in a photo measured, as a figure: the photo, the fitted tape line, the
reference and the angle in degrees (matplotlib imported lazily)."""

from __future__ import annotations

import math
import os
from pathlib import Path
from typing import Any

from numpy.typing import ArrayLike

from magcilia import _validate as v
from magcilia._atomic import save_figure
from magcilia.acquire.photo import TiltMeasurement

_SHOWN = 1600  # the image is shown with at most about this many pixels a side


def annotate_figure(measurement: TiltMeasurement, image: ArrayLike) -> Any:
    """A figure of ``measurement`` drawn over ``image``: the photo, the fitted tape line, the
    reference and the angle in degrees (arguments as :func:`annotate`)."""
    from magcilia.report.figures import new_figure

    img = v.finite_array("image", image, ndim=2)
    h, w = img.shape
    fig, axes = new_figure(size=(6.0, 6.0 * h / w + 0.5))
    plot_measurement(measurement, img, axes[0, 0])
    return fig


def plot_measurement(measurement: TiltMeasurement, image: ArrayLike, ax: Any = None) -> Any:
    """Draw ``measurement`` over ``image`` on ``ax`` (a new figure when None); returns ``ax``.

    Parameters
    ----------
    measurement : TiltMeasurement
        The result of :func:`magcilia.acquire.photo.measure_tilt` on ``image``.
    image : array-like, shape (h, w)
        The upright grey photo the measurement was made on, at full size or downscaled
        (:class:`~magcilia.acquire.photo.Photo`): shown over the measurement's ``image_size``.
    ax : matplotlib Axes, optional

    Returns
    -------
    matplotlib Axes
    """
    from magcilia.report.figures import axes_or_new

    img = v.finite_array("image", image, ndim=2)
    h, w = img.shape
    if all(measurement.image_size):  # a downscaled image is shown over the photo's pixels
        w, h = measurement.image_size
    ax = axes_or_new(ax, size=(6.0, 6.0 * h / w + 0.5))
    step = max(1, math.ceil(max(img.shape) / _SHOWN))
    ax.imshow(img[::step, ::step], cmap="gray", vmin=0.0, vmax=max(float(img.max()), 1e-12),
              extent=(-0.5, w - 0.5, h - 0.5, -0.5))
    (x0, y0), (x1, y1) = measurement.line
    ax.plot([x0, x1], [y0, y1], color="tab:red", lw=1.5, label=f"tape ({measurement.method})")
    if measurement.reference_line is not None:
        (a0, b0), (a1, b1) = measurement.reference_line
        what = "case edge" if measurement.reference == "detected" else "given reference"
        ax.plot([a0, a1], [b0, b1], color="tab:cyan", lw=1.2, label=what)
    # the reference direction through the tape's lower end, as long as the tape
    ref = measurement.reference_angle
    length = measurement.length
    ax.plot([x0, x0 + length * math.sin(ref)], [y0, y0 - length * math.cos(ref)],
            color="tab:cyan", lw=1.0, ls="--", label="reference direction")
    ax.set_xlim(-0.5, w - 0.5)
    ax.set_ylim(h - 0.5, -0.5)
    ax.set_xlabel("x (px)")
    ax.set_ylabel("y (px)")
    ref_text = {"vertical": "the image vertical", "detected": "the case edge normal",
                "given": "the given reference"}[measurement.reference]
    angle = f"{measurement.angle_deg:+.2f}".replace("-", "−")  # the real minus sign
    ax.set_title(f"{Path(measurement.path).name}: tilt {angle}° from {ref_text}",
                 fontsize="medium")
    ax.legend(loc="upper right")
    return ax


def annotate(measurement: TiltMeasurement, image: ArrayLike,
             path: str | os.PathLike[str], style: str = "screen") -> Path:
    """Save a figure of ``measurement`` drawn over ``image`` (atomically; format from the suffix);
    with ``style="paper"`` a vector PDF beside a PNG ``path``.

    Parameters
    ----------
    measurement : TiltMeasurement
        The result of :func:`magcilia.acquire.photo.measure_tilt` on ``image``.
    image : array-like, shape (h, w)
        The upright grey photo the measurement was made on (px coordinates of the measurement).
    path : str or path-like
        Output file, e.g. ``angle.png``.
    style : {"screen", "paper"}
        The figure style (:mod:`magcilia.report.style`).

    Returns
    -------
    Path
        The file written.
    """
    from magcilia.report import style as st

    out = Path(path)
    with st.use(style):
        fig = annotate_figure(measurement, image)
        save_figure(fig, out, dpi=st.dpi())
        if style == "paper" and out.suffix.lower() == ".png":
            save_figure(fig, out.with_suffix(".pdf"))
    return out
