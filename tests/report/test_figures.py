"""Every figure the CLI writes, rendered and checked the way a reviewer looks at it.

Each command runs in-process (``main([...])``) into ``tmp_path``, in both styles. Every
``Figure.savefig`` call is intercepted: the figure is drawn with matplotlib's Agg renderer, in
the same style context, and checked:

(a) every visible text (titles, axis labels, drawn tick labels, legend texts, annotations,
    colorbar labels, offset texts) lies inside the canvas;
(b) drawn tick labels of one axis do not overlap each other;
(c) every legend lies inside its axes, and each entry has a label and stands for an artist
    drawn with data inside the frame (not a line beyond the limits, not a band thinner than a
    pixel, not a line hidden on the frame);
(d) no title, label, legend or annotation writes a number's minus as a hyphen (``-0.5``,
    ``1e-05``): the figures use the real minus sign (mathtext ``$...$`` is exempt: it renders
    one);
(e) measured data drawn with error bars span at least a quarter of their axes' height (a model
    curve must not set the scale);
and the files written are what their suffix says (PNG, PDF, SVG), complete and not empty.

Missing glyphs fail too (the suite turns matplotlib's warning into an error).
"""

from __future__ import annotations

import math
import re
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from matplotlib.axes import Axes
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.collections import Collection
from matplotlib.container import BarContainer, Container, ErrorbarContainer
from matplotlib.figure import Figure
from matplotlib.image import AxesImage
from matplotlib.lines import Line2D
from matplotlib.patches import Patch
from matplotlib.text import Text
from matplotlib.transforms import Bbox

import magcilia as mc
from magcilia.acquire.synthetic import synthetic_field_recording
from magcilia.cli import main
from magcilia.io.recordings import example_path

_TOL = 1.0  # px


# --- the checks --------------------------------------------------------------------------------


def _all_axes(fig: Figure) -> list[Axes]:
    """The figure's axes with their children (secondary axes, insets), depth first."""
    out: list[Axes] = []

    def add(ax: Axes) -> None:
        if ax not in out:
            out.append(ax)
            for child in ax.child_axes:
                add(child)

    for ax in fig.axes:
        add(ax)
    return out


def _drawn_tick_labels(ax: Axes) -> Iterator[tuple[str, list[Text]]]:
    """Per axis and side, the tick labels the last draw drew."""
    for name, axis in (("x", ax.xaxis), ("y", ax.yaxis)):
        if not axis.get_visible():
            continue
        ticks = axis._update_ticks()  # the ticks a draw draws (inside the view)
        for side in ("label1", "label2"):
            yield f"{name}{side[-1]}", [getattr(t, side) for t in ticks
                                       if getattr(t, side).get_visible()
                                       and getattr(t, side).get_text().strip()]


def _inside(inner: Bbox, outer: Bbox, tol: float = _TOL) -> bool:
    return (inner.x0 >= outer.x0 - tol and inner.x1 <= outer.x1 + tol
            and inner.y0 >= outer.y0 - tol and inner.y1 <= outer.y1 + tol)


def _overlap(a: Bbox, b: Bbox, tol: float = 0.5) -> bool:
    return (min(a.x1, b.x1) - max(a.x0, b.x0) > tol) and (min(a.y1, b.y1) - max(a.y0, b.y0) > tol)


def _describe(t: Text) -> str:
    return repr(t.get_text()[:60])


def _drawn_with_data(artist: Any, frame: Bbox, renderer: Any) -> bool:
    """Whether ``artist`` shows something inside ``frame`` (display px)."""
    if isinstance(artist, ErrorbarContainer):
        parts = [artist.lines[0]] if artist.lines[0] is not None else list(artist.lines[2])
        return any(_drawn_with_data(p, frame, renderer) for p in parts)
    if isinstance(artist, BarContainer):
        return any(_drawn_with_data(p, frame, renderer) for p in artist.patches)
    if isinstance(artist, Container):
        return any(_drawn_with_data(p, frame, renderer) for p in artist.get_children())
    if not artist.get_visible():
        return False
    if isinstance(artist, Line2D):
        xy = artist.get_transform().transform(artist.get_xydata())
        xy = xy[np.isfinite(xy).all(axis=1)]
        inner = frame.padded(-_TOL)  # a line on the frame itself is hidden by it
        if len(xy) == 0:
            return False
        if artist.get_linestyle() in ("None", "", " ") or len(xy) == 1:
            return bool(((xy[:, 0] >= inner.x0) & (xy[:, 0] <= inner.x1)
                         & (xy[:, 1] >= inner.y0) & (xy[:, 1] <= inner.y1)).any())
        seg = Bbox.from_extents(xy[:, 0].min(), xy[:, 1].min(), xy[:, 0].max(), xy[:, 1].max())
        return (min(seg.x1, inner.x1) >= max(seg.x0, inner.x0)
                and min(seg.y1, inner.y1) >= max(seg.y0, inner.y0))
    box = artist.get_window_extent(renderer)
    cut = Bbox.intersection(box, frame)
    if cut is None:
        return False
    if isinstance(artist, (Patch, Collection, AxesImage)):
        return cut.width >= 1.0 and cut.height >= 1.0  # a band thinner than a pixel is not seen
    return True


_HYPHEN_MINUS = re.compile(r"(^|[\s(\[=:,/±~≈])-(\d|\.\d)|\de-\d")


def problems(fig: Figure) -> list[str]:
    """What a reviewer would object to in ``fig`` (empty when it is fine)."""
    canvas = FigureCanvasAgg(fig)
    canvas.draw()
    renderer = canvas.get_renderer()
    found: list[str] = []
    page = fig.bbox
    axes = _all_axes(fig)
    tick_label_ids: set[int] = set()
    for ax in axes:
        for axis in (ax.xaxis, ax.yaxis):
            for tick in [*axis.majorTicks, *axis.minorTicks]:
                tick_label_ids |= {id(tick.label1), id(tick.label2)}
    # (a), (b): tick labels
    for ax in axes:
        for side, labels in _drawn_tick_labels(ax):
            boxes = [t.get_window_extent(renderer) for t in labels]
            for t, box in zip(labels, boxes, strict=True):
                if not _inside(box, page):
                    found.append(f"(a) tick label {_describe(t)} lies outside the canvas")
            for i in range(len(boxes)):
                for j in range(i + 1, len(boxes)):
                    if _overlap(boxes[i], boxes[j]):
                        found.append(f"(b) {side} tick labels {_describe(labels[i])} and "
                                     f"{_describe(labels[j])} overlap")
    # (a), (d): every other visible text
    for t in fig.findobj(Text):
        if id(t) in tick_label_ids or not t.get_text().strip() or not t.get_visible():
            continue
        if not all(a.get_visible() for a in _ancestors(t, fig)):
            continue
        if not _inside(t.get_window_extent(renderer), page):
            found.append(f"(a) text {_describe(t)} lies outside the canvas")
        plain = re.sub(r"\$[^$]*\$", "", t.get_text())
        if _HYPHEN_MINUS.search(plain):
            found.append(f"(d) text {_describe(t)} writes a minus as a hyphen")
    # (e): measured data (error bars) fill the frame, not a sliver of it
    for ax in axes:
        for c in ax.containers:
            if isinstance(c, ErrorbarContainer) and c.lines[0] is not None:
                xy = c.lines[0].get_transform().transform(c.lines[0].get_xydata())
                ys = xy[np.isfinite(xy).all(axis=1), 1]
                if len(ys) >= 5 and np.ptp(ys) < 0.25 * ax.bbox.height:
                    found.append(f"(e) the data of {_name(ax)} fill "
                                 f"{np.ptp(ys) / ax.bbox.height:.0%} of its height")
    # (c): legends
    for ax in axes:
        legend = ax.get_legend()
        if legend is None or not legend.get_visible():
            continue
        if not _inside(legend.get_window_extent(renderer), ax.bbox):
            found.append(f"(c) the legend of {_name(ax)} spills outside its axes")
        twins = [a for a in axes if np.allclose(a.bbox.bounds, ax.bbox.bounds)]
        for text in legend.get_texts():
            label = text.get_text()
            if not label.strip():
                found.append(f"(c) a legend entry of {_name(ax)} has no label")
                continue
            artists = [a for tw in twins for a in (*tw.containers, *tw.lines, *tw.collections,
                                                    *tw.patches, *tw.images)
                       if a.get_label() == label]
            if not any(_drawn_with_data(a, ax.bbox, renderer) for a in artists):
                found.append(f"(c) legend entry {label!r} of {_name(ax)} stands for nothing "
                             "drawn inside the frame")
    return found


def _ancestors(t: Text, fig: Figure) -> list[Any]:
    """The legend, axes or figure chain above a text (each must be visible for it to show)."""
    chain: list[Any] = []
    for legend in [*(ax.get_legend() for ax in _all_axes(fig)), *fig.legends]:
        if legend is not None and t in legend.get_texts():
            chain.append(legend)
    if t.axes is not None:
        chain.append(t.axes)
    return chain


def _name(ax: Axes) -> str:
    return repr(ax.get_title() or ax.get_ylabel() or ax.get_xlabel() or "an axes")


# --- running the CLI with every savefig checked ------------------------------------------------


@pytest.fixture
def checked(monkeypatch: pytest.MonkeyPatch) -> list[tuple[str, list[str]]]:
    """Record, for every figure saved, its file name and its problems (in the style in use)."""
    seen: list[tuple[str, list[str]]] = []
    original = Figure.savefig

    def savefig(self: Figure, fname: Any, *args: Any, **kwargs: Any) -> None:
        original(self, fname, *args, **kwargs)
        name = getattr(fname, "name", fname)
        seen.append((Path(str(name)).name if isinstance(name, (str, Path)) else "memory",
                     problems(self)))

    monkeypatch.setattr(Figure, "savefig", savefig)
    return seen


def photo(path: Path, angle_deg: float = -18.0) -> Path:
    """A grey photo of a bright tape on a dark holder, tilted by ``angle_deg`` (PNG)."""
    from PIL import Image
    from scipy import ndimage

    h, w = 360, 480
    y, x = np.mgrid[0:h, 0:w].astype(np.float64)
    th = math.radians(angle_deg)
    u = (x - w / 2) * math.sin(th) - (y - 0.85 * h) * math.cos(th)
    v = (x - w / 2) * math.cos(th) + (y - 0.85 * h) * math.sin(th)
    img = 0.5 + 0.05 * np.sin(x / 17.0) * np.cos(y / 23.0)
    holder = (np.abs(v) < 16) & (u > -5) & (u < 260)
    tape = (np.abs(v) < 5) & (u > 10) & (u < 245)
    img = np.where(holder, 0.12, img)
    img = np.where(tape, 0.9, img)
    img = ndimage.gaussian_filter(img, 1.2)
    Image.fromarray(np.asarray(img * 255, dtype=np.uint8)).save(path)
    return path


def field_recordings(tmp: Path) -> list[str]:
    """Two synthetic 3-axis recordings of the paper's cilium (converged layout), tilted toward
    azimuths 0 and 90 deg."""
    truth = mc.Setup.paper(ring="rms", n_loops=64, dipoles_per_loop=5)
    angles = np.radians(np.linspace(0.0, 80.0, 9))
    paths = []
    for i, phi in enumerate((0.0, np.pi / 2)):
        rec = synthetic_field_recording(truth, angles, (phi,), samples_per_angle=20, noise=1e-6,
                                        background=(20e-6, -5e-6, 40e-6), rng=i)
        paths.append(tmp / f"az{i}.csv")
        rec.write_csv(paths[-1])
    return [str(p) for p in paths]


def _commands(tmp: Path, style: str) -> dict[str, tuple[list[str], list[Path]]]:
    """Per case: the argv and the figure files it must write."""
    ext = ".png" if style == "screen" else ".pdf"
    data = str(example_path())
    pdf = style == "paper"

    def folder(name: str, files: list[str]) -> list[Path]:
        names = [*files, *[f.replace(".png", ".pdf") for f in files]] if pdf else files
        return [tmp / name / f for f in names]

    return {
        "demo": (["demo", "--out", str(tmp / "demo"), "--quiet"],
                 folder("demo", ["fit.png", "residuals.png"])),
        "calibrate": (["calibrate", data, "--out", str(tmp / "cal"), "--starts", "64", "--quiet",
                       "--bias", "polynomial", "--bias-degree", "1"],
                      folder("cal", ["fit.png", "residuals.png"])),
        "field": (["field", "paper", "paper-initial", "--angles", "0:85:5", "--plot",
                   str(tmp / f"field{ext}")], [tmp / f"field{ext}"]),
        "field-svg": (["field", "paper", "--angles", "0:85:5", "--plot", str(tmp / "field.svg")],
                      [tmp / "field.svg"]),
        "bend-force": (["bend", "force-sensor", "--force", "0.2mN", "--plot",
                        str(tmp / f"bend{ext}")], [tmp / f"bend{ext}"]),
        "bend-flow": (["bend", "force-sensor", "--flow", "0.1m/s", "--plot",
                       str(tmp / f"flow{ext}")], [tmp / f"flow{ext}"]),
        "bend-spatial": (["bend", "force-sensor", "--force-vector", "0.1,-0.08,0",
                          "--actuation-field", "2,-1,0", "--plot", str(tmp / f"spatial{ext}")],
                         [tmp / f"spatial{ext}"]),
        "bend-azimuth": (["bend", "force-sensor", "--force", "0.2mN", "--azimuth", "120deg",
                          "--plot", str(tmp / f"azimuth{ext}")], [tmp / f"azimuth{ext}"]),
        "design": (["design", "force-sensor", "--plot", str(tmp / f"design{ext}")],
                   [tmp / f"design{ext}"]),
        "design-cone": (["design", "paper", "--plot", str(tmp / f"cone{ext}")],
                        [tmp / f"cone{ext}"]),
        "sensitivity": (["sensitivity", "paper", "--data", data, "--out", str(tmp / "sens"),
                         "--points", "5", "--map-points", "9", "--sobol-base", "64", "--quiet"],
                        folder("sens", ["fig09_xy.png", "fig10_z.png", "fig11_nk.png",
                                        "fig12_geometry.png", "xy_map.png", "sobol.png"])),
        "angle": (["angle", str(photo(tmp / "holder.png")), "--annotate", str(tmp / "ann")],
                  [tmp / "ann" / "holder_angle.png"]),
        "optimise": (["optimise", "force-sensor", "--designs", "128", "--refine", "12",
                      "--workers", "1", "--sensor", "HMC1021Z,MMC5983MA", "--quiet", "--plot",
                      str(tmp / f"pareto{ext}")], [tmp / f"pareto{ext}"]),
        "calibrate-physical": (["calibrate", *field_recordings(tmp), "--model", "physical",
                                "--setup", "paper", "--prior", "height=3.3:0.15", "--posterior",
                                "--out", str(tmp / "joint"), "--quiet"],
                               folder("joint", ["fit.png", "pairs.png"])),
    }


CASES = ("demo", "calibrate", "field", "field-svg", "bend-force", "bend-flow", "design",
         "design-cone", "sensitivity", "angle", "calibrate-physical", "optimise")
CASES += ("bend-spatial", "bend-azimuth")  # issue 15: bending in any direction, actuation
MAGIC = {".png": b"\x89PNG\r\n\x1a\n", ".pdf": b"%PDF-", ".svg": b"<?xml"}


@pytest.mark.parametrize("style", ["screen", "paper"])
@pytest.mark.parametrize("case", CASES)
def test_every_cli_figure_passes_the_checks(case: str, style: str, tmp_path: Path,
                                            checked: list[tuple[str, list[str]]],
                                            capsys: pytest.CaptureFixture[str]) -> None:
    argv, files = _commands(tmp_path, style)[case]
    assert main([*argv, "--style", style]) == 0, capsys.readouterr().err
    assert checked, "no figure was saved"
    bad = [f"{name}: {p}" for name, probs in checked for p in probs]
    assert not bad, "\n".join(bad)
    for f in files:
        data = f.read_bytes()
        assert data.startswith(MAGIC[f.suffix]), f
        assert len(data) > 2000, f
        if f.suffix == ".svg":
            assert b"<svg" in data[:2000]
        if f.suffix == ".pdf":
            assert data.rstrip().endswith(b"%%EOF")
