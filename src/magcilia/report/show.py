"""The 3-D view of a setup or an array, written to a file (``magcilia show``).

The scene (:func:`magcilia.device.scene.scene`: the cilia as exact bodies, the sensors with their
sensitive axes, the field on a slice) is drawn by magpylib's display backends: matplotlib for a
static figure (``.png``, ``.pdf``, ``.svg``), plotly for an interactive page (``.html``,
self-contained: it opens offline). The file is written atomically.
"""

from __future__ import annotations

import os
from collections.abc import Sequence
from pathlib import Path
from typing import TYPE_CHECKING

from magcilia._atomic import atomic_path
from magcilia._errors import MagciliaError, require

if TYPE_CHECKING:
    from magcilia.device.array import CiliaArray
    from magcilia.device.setup import Setup
    from magcilia.model.pose import Pose

#: file suffix -> magpylib backend
BACKENDS = {".png": "matplotlib", ".pdf": "matplotlib", ".svg": "matplotlib", ".html": "plotly"}
#: the static figure's size (inches) and resolution (dots per inch)
FIGSIZE = (6.4, 6.0)
DPI = 120
#: the static figure's key (magpylib's own legend lists every field pixel)
CAPTION = ("blue: the cilium (exact body) · at the origin: the sensor, its arrow the sensitive "
           "axis x\narrows: B on the x–z slice, coloured by |B|")


def backend_of(path: str | os.PathLike[str], option: str = "--out") -> str:
    """The magpylib backend that writes ``path`` (by its suffix), or a :class:`MagciliaError`
    naming ``option`` and the suffixes it takes."""
    suffix = Path(path).suffix.lower()
    if suffix not in BACKENDS:
        raise MagciliaError(f"{option} must end in {', '.join(BACKENDS)} (a figure, or an "
                            f"interactive page); got {os.fspath(path)}")
    return BACKENDS[suffix]


def write_show(target: Setup | CiliaArray, path: str | os.PathLike[str],
               pose: Pose | Sequence[Pose] | None = None, *, field: bool = True,
               title: str | None = None) -> Path:
    """Draw ``target`` in 3-D into ``path`` (its suffix picks the backend: :data:`BACKENDS`).

    Parameters
    ----------
    target : Setup or CiliaArray
        What to draw (see :func:`magcilia.device.scene.scene`, which also takes ``pose``).
    path : path
        The file: ``.png``/``.pdf``/``.svg`` (matplotlib) or ``.html`` (plotly, the ``show``
        extra); replaced atomically.
    pose : pose or sequence of poses, optional
        The cilium's pose (a tilt angle in rad, a centreline), or one per cilium of an array.
    field : bool
        Draw the field slice.
    title : str, optional
        The figure's title.

    Returns
    -------
    Path
        ``path``.
    """
    from magcilia.device.scene import scene

    backend = backend_of(path)
    if backend == "plotly":
        require("plotly", package="plotly", extra="show", purpose="an interactive 3-D view (.html)")
    import magpylib as magpy

    collection = scene(target, pose, field=field)
    out = Path(path)
    if backend == "plotly":
        fig = magpy.show(*collection.children, backend="plotly", return_fig=True)
        if title:
            fig.update_layout(title=title)
        with atomic_path(out) as tmp:
            fig.write_html(tmp, include_plotlyjs=True, full_html=True)
        return out
    import matplotlib.pyplot as plt

    fig = plt.figure(figsize=FIGSIZE)
    try:
        ax = fig.add_subplot(projection="3d")
        magpy.show(*collection.children, canvas=ax, backend="matplotlib")
        ax.set(xlabel="x (mm)", ylabel="y (mm)", zlabel="z (mm)")  # magpylib draws in mm
        legend = ax.get_legend()
        if legend is not None:  # one entry per field pixel: a caption says it instead
            legend.remove()
        fig.text(0.5, 0.02, CAPTION if field else CAPTION.split("\n", maxsplit=1)[0],
                 ha="center", fontsize="small")
        if title:
            ax.set_title(title)
        with atomic_path(out) as tmp:
            fig.savefig(tmp, dpi=DPI, format=out.suffix.lstrip(".").lower())
    finally:
        plt.close(fig)
    return out

