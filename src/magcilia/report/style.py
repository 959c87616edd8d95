"""The two looks of every magcilia figure: ``screen`` (the default: sans serif, sized for a
monitor and a markdown report) and ``paper`` (serif, one journal column wide, print-sized fonts,
vector output).

Use :func:`use` around the code that builds *and* saves a figure (matplotlib reads most settings
when an artist is made, a few when the file is written)::

    with style.use("paper"):
        fig = calibration_figure(result)
        save_figure(fig, "fig8.pdf", dpi=style.dpi())

:func:`new_figure` (in :mod:`magcilia.report.figures`) sizes figures by the style in use: on
paper a one-panel figure is :data:`COLUMN` wide, a figure of several panels side by side
:data:`DOUBLE_COLUMN`. Numbers in titles and legends go through :func:`number`, which writes a
real minus sign and powers of ten the way a journal prints them.
"""

from __future__ import annotations

import contextlib
import contextvars
import math
from collections.abc import Iterator
from typing import Any

from magcilia._validate import fail

#: the style names ``--style`` accepts
STYLES = ("screen", "paper")
#: one journal column, inches (8.9 cm)
COLUMN = 3.5
#: two journal columns, inches (18.3 cm)
DOUBLE_COLUMN = 7.2

_BASE: dict[str, Any] = {
    "axes.unicode_minus": True,
    "axes.grid": False,
    "legend.framealpha": 0.85,
    "legend.edgecolor": "0.8",
    "errorbar.capsize": 2.0,
    "savefig.bbox": None,  # the figure is laid out (constrained) at its own size: keep it
}

#: matplotlib settings of each style
RC: dict[str, dict[str, Any]] = {
    "screen": {
        **_BASE,
        "font.family": "sans-serif",
        "font.size": 10.0,
        "axes.titlesize": 10.0,
        "axes.labelsize": 10.0,
        "legend.fontsize": 8.5,
        "xtick.labelsize": 9.0,
        "ytick.labelsize": 9.0,
        "figure.titlesize": 11.0,
        "lines.linewidth": 1.5,
        "lines.markersize": 5.0,
        "mathtext.fontset": "dejavusans",
    },
    "paper": {
        **_BASE,
        "font.family": "serif",
        "font.serif": ["STIXGeneral", "DejaVu Serif"],
        "mathtext.fontset": "stix",
        "font.size": 8.0,
        "axes.titlesize": 8.0,
        "axes.labelsize": 8.0,
        "legend.fontsize": 7.0,
        "xtick.labelsize": 7.0,
        "ytick.labelsize": 7.0,
        "figure.titlesize": 8.5,
        "axes.linewidth": 0.6,
        "grid.linewidth": 0.4,
        "lines.linewidth": 1.0,
        "lines.markersize": 3.0,
        "errorbar.capsize": 1.5,
        "xtick.major.width": 0.6,
        "ytick.major.width": 0.6,
        "xtick.major.size": 3.0,
        "ytick.major.size": 3.0,
        "xtick.direction": "in",
        "ytick.direction": "in",
        "legend.handlelength": 1.6,
        "legend.borderpad": 0.3,
        "legend.labelspacing": 0.25,
        "pdf.fonttype": 42,  # TrueType in the PDF, as journals ask (not Type 3)
        "ps.fonttype": 42,
        "svg.fonttype": "path",
    },
}

#: raster resolution of each style (PNG files), dots per inch
DPI = {"screen": 150, "paper": 300}

_CURRENT: contextvars.ContextVar[str] = contextvars.ContextVar("magcilia_style", default="screen")


def check(style: str) -> str:
    """``style`` if it is one of :data:`STYLES`, else a one-line error."""
    if style not in STYLES:
        raise fail("style", style, "one of " + ", ".join(STYLES))
    return style


def current() -> str:
    """The style in use (``screen`` outside :func:`use`)."""
    return _CURRENT.get()


def dpi(style: str | None = None) -> int:
    """Raster resolution (dots per inch) of ``style`` (default: the style in use)."""
    return DPI[check(style or current())]


@contextlib.contextmanager
def use(style: str = "screen") -> Iterator[str]:
    """Build and save figures in ``style`` (``screen`` or ``paper``) inside the block.

    The matplotlib settings of :data:`RC` apply in the block only (``matplotlib.rc_context``),
    and :func:`current` tells :func:`~magcilia.report.figures.new_figure` which size to use.
    """
    import matplotlib as mpl

    token = _CURRENT.set(check(style))
    try:
        with mpl.rc_context(RC[style]):  # type: ignore[arg-type]
            yield style
    finally:
        _CURRENT.reset(token)


def figure_size(ncols: int, nrows: int, panel: tuple[float, float],
                style: str | None = None) -> tuple[float, float]:
    """Figure size in inches for ``nrows`` × ``ncols`` panels of ``panel`` (w, h) inches on
    screen. On paper the width is :data:`COLUMN` for one panel a row and :data:`DOUBLE_COLUMN`
    for more, each panel keeping its screen aspect ratio (height at most 9 in)."""
    w, h = panel
    if (style or current()) == "screen":
        return w * ncols, h * nrows
    width = COLUMN if ncols == 1 else DOUBLE_COLUMN
    return width, min(9.0, width / ncols * h / w * nrows)


def number(value: float, digits: int = 3, *, sign: bool = False) -> str:
    r"""``value`` to ``digits`` significant digits for a title or legend: a real minus sign (−),
    powers of ten in mathtext (``2.29×10⁻⁵`` on the figure; outside 1e-4..1e``digits``), ``+``
    in front with ``sign``.

    >>> number(-2.2876e-5)
    '−2.29$\\times10^{-5}$'
    >>> number(0.0125, sign=True)
    '+0.0125'
    """
    if not math.isfinite(value):
        return {math.inf: "∞", -math.inf: "−∞"}.get(value, "n/a")
    text = f"{value:.{digits}g}"
    mantissa, _, exponent = text.partition("e")
    if exponent:
        power = f"10^{{{int(exponent)}}}"
        text = (f"${power}$" if mantissa == "1" else f"−${power}$" if mantissa == "-1"
                else f"{mantissa}$\\times{power}$")
    if sign and value > 0:
        text = "+" + text
    head, dollar, tail = text.partition("$")
    return head.replace("-", "−") + dollar + tail
