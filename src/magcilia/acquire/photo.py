"""Tilt angles from photos of the cilium holder (the paper's camera measurement, automated).

The paper measured each tilt angle "manually from the camera images": a macro photo of the holder,
which carries a reflective tape along its length. :func:`measure_tilt` finds that tape — a bright,
long, straight stripe — and measures its angle from the image vertical (the sensor's z axis), or
from the normal of the sensor case's top edge, or from a reference line given by two points.

How the tape is found: on a block-averaged copy of at most ~1000 px a side, a white top-hat keeps
narrow bright things (not the background's light gradient); Otsu's threshold (three times, each
above the last) and connected components give candidates, ranked by length and elongation (a
round flash reflection is not elongated). Each is refined on the full-resolution pixels: across
the stripe at up to 512 stations along it, the centre of the part above half its height
(sub-pixel), and a straight line through those centres, trimmed of outliers (a reflection or a
gap on the tape). The first candidate whose centres lie within a tenth of its width of the line
is the tape. The case's top edge: Canny edges and a Hough transform over lines within 25 degrees
of horizontal, refined in the same way on the derivative across the edge.

Image coordinates are pixels of the upright (EXIF-oriented) image: x to the right, y down; the
pixel in row i, column j has its centre at (x, y) = (j, i). Angles are in rad, measured from the
image vertical (or the reference), positive when the top of the holder leans to the right.
"""

from __future__ import annotations

import math
import os
import re
import sys
import warnings
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from magcilia import _validate as v
from magcilia._display import Display, Item, number
from magcilia._errors import MagciliaError
from magcilia.acquire.stripes import (
    Point,
    Segment,
    downsample,
    fit_edge,
    fit_tape,
    photo_module,
    tilt_of,
    upward,
    wrap,
)

F64 = NDArray[np.float64]

#: references measure_tilt accepts, and those a result can carry
REFERENCES = ("vertical", "detect")
RESULT_REFERENCES = ("vertical", "detected", "given")
METHODS = ("auto", "manual")
ARRAY_PATH = "<array>"  # the path recorded for a photo given as an array



# -- reading ---------------------------------------------------------------------------------------
#: most pixels of a photo: above every camera's single frame (151 MP: Phase One IQ4); a larger
#: image (a stitched panorama, a decompression bomb) is refused before it is decoded
MAX_PIXELS = 160_000_000
#: longest side, px, of the image a photo is measured on: a larger photo is decoded downscaled
#: by a whole factor (JPEG in the decoder, other formats by block means right after decoding),
#: so that the measurement costs about the same at any size (~0.13 GB as float64); the tape still
#: spans hundreds of pixels, and the angle, the same in every uniformly scaled copy of the photo,
#: keeps its accuracy (tests/acquire/test_photo.py; benchmarks/bench_photo.py)
DECODE_SIDE = 4096
#: EXIF orientation -> the PIL.Image.Transpose that shows the photo upright (as ImageOps'
#: exif_transpose)
_UPRIGHT = {2: "FLIP_LEFT_RIGHT", 3: "ROTATE_180", 4: "FLIP_TOP_BOTTOM", 5: "TRANSPOSE",
            6: "ROTATE_270", 7: "TRANSVERSE", 8: "ROTATE_90"}
_WIDE = ("I", "I;16", "I;16B", "I;16L", "I;16N")  # 16/32-bit integer grey levels


@dataclass(frozen=True)
class Photo:
    """A photo decoded for measuring (:func:`load_photo`), possibly downscaled.

    Attributes
    ----------
    image : ndarray, shape (h, w)
        Grey levels in [0, 1], upright (row 0 at the top).
    scale : int
        Pixels of the upright photo per pixel of ``image``, along each axis (1: full size); the
        pixel (i, j) of ``image`` has its centre at ``((j + 0.5) scale − 0.5, (i + 0.5) scale −
        0.5)`` px of the photo.
    size : (int, int)
        Width and height of the upright photo, px.
    path : str
        The file.
    """

    image: F64
    scale: int
    size: tuple[int, int]
    path: str

    def to_photo(self, points: ArrayLike) -> F64:
        """Points (…, 2) in px of ``image`` as px of the photo."""
        return (np.asarray(points, dtype=np.float64) + 0.5) * self.scale - 0.5


def _grey(img: Any) -> F64:
    """A decoded Pillow image as grey levels in [0, 1] (float64; ITU-R 601 luma for colour)."""
    if img.mode in _WIDE:
        return np.asarray(img, dtype=np.float64) / 65535.0
    if img.mode == "F":
        return np.asarray(img, dtype=np.float64)
    return np.asarray(img.convert("L"), dtype=np.float64) / 255.0


def _reduced(img: Any, factor: int) -> Any:
    """``img`` (loaded) reduced ``factor`` times by block means (grey first where Pillow cannot
    average the mode, e.g. a palette)."""
    if factor == 1:
        return img
    if img.mode not in ("L", "RGB", "RGBA", "F", *_WIDE):
        img = img.convert("L")
    if img.mode in _WIDE:  # reduce works on 32-bit integers
        img = img.convert("I")
    return img.reduce(factor)


def load_photo(path: str | os.PathLike[str], max_side: int | None = DECODE_SIDE) -> Photo:
    """A photo as a grey image for measuring: JPEG, PNG or TIFF through Pillow, EXIF orientation
    applied, decoded downscaled by a whole factor when its longest side exceeds ``max_side`` px.

    Parameters
    ----------
    path : str or path-like
        The image file (at most :data:`MAX_PIXELS` pixels).
    max_side : int or None
        Longest side of the decoded image, px (default :data:`DECODE_SIDE`); None: full size.

    Returns
    -------
    Photo
        The grey image (h, w) in [0, 1] and its scale to the photo's pixels.

    Raises
    ------
    MagciliaError
        If the file is missing, is not an image Pillow can read, is truncated, or has more than
        :data:`MAX_PIXELS` pixels.
    """
    image_mod = photo_module("PIL.Image", "pillow", "reading photos")
    ops = photo_module("PIL.ImageOps", "pillow", "reading photos")
    name = str(path)
    if not Path(name).is_file():
        raise MagciliaError(f"photo {name!r} does not exist (or is not a file); check the path")

    def too_big(count: str) -> MagciliaError:
        return MagciliaError(f"photo {name!r} has {count} pixels, more than the {MAX_PIXELS:,} "
                             "that magcilia measures (MAX_PIXELS, above any camera's frame); "
                             "scale it down or crop it to the holder")

    try:
        with warnings.catch_warnings():  # Pillow's own limit is below ours: MAX_PIXELS decides
            warnings.simplefilter("ignore", image_mod.DecompressionBombWarning)
            opened = image_mod.open(name)
        with opened as img:
            w, h = img.size
            if w * h > MAX_PIXELS:
                raise too_big(f"{w} x {h} = {w * h:,}")
            factor = 1 if max_side is None else math.ceil(max(w, h) / max_side)
            if factor == 1:  # full size: as ever
                img.load()
                upright = ops.exif_transpose(img)
            else:
                orientation = img.getexif().get(0x0112, 1)
                drafted = img.draft("L", (math.ceil(w / factor), math.ceil(h / factor)))
                first = 1 if drafted is None else round(w / drafted[1][2])  # JPEG: 1, 2, 4, 8
                img.load()
                rest = math.ceil(max(img.size) / max_side)
                upright = _reduced(img, rest)
                factor = first * rest
                if orientation in _UPRIGHT:
                    upright = upright.transpose(getattr(image_mod.Transpose,
                                                        _UPRIGHT[orientation]))
                    if orientation >= 5:
                        w, h = h, w
            out = _grey(upright)
    except MagciliaError:
        raise
    except image_mod.DecompressionBombError as exc:  # beyond Pillow's limit, found on opening
        found = re.search(r"\((\d+) pixels\)", str(exc))
        raise too_big(f"{int(found.group(1)):,}" if found else "too many") from None
    except image_mod.UnidentifiedImageError:
        raise MagciliaError(f"photo {name!r} is not an image Pillow can read; give a JPEG, PNG "
                            "or TIFF file") from None
    except (OSError, SyntaxError, ValueError) as exc:
        why = " ".join(str(exc).split()) or type(exc).__name__
        raise MagciliaError(f"photo {name!r} is truncated or damaged ({why}); copy it from the "
                            "camera again") from None
    if factor == 1:
        w, h = out.shape[1], out.shape[0]
    return Photo(np.clip(out, 0.0, 1.0), factor, (w, h), name)


def read_photo(path: str | os.PathLike[str]) -> F64:
    """A photo as a grey image at full size: JPEG, PNG or TIFF through Pillow, EXIF orientation
    applied (:func:`load_photo` without downscaling; at most :data:`MAX_PIXELS` pixels).

    Parameters
    ----------
    path : str or path-like
        The image file.

    Returns
    -------
    ndarray, shape (h, w)
        Grey levels (ITU-R 601 luma) in [0, 1], float64, upright as the camera's orientation tag
        says (row 0 at the top).

    Raises
    ------
    MagciliaError
        If the file is missing, is not an image Pillow can read, is truncated, or is too large.
    """
    return load_photo(path, max_side=None).image


# -- the result ------------------------------------------------------------------------------------
def _segment(value: Any) -> Segment:
    (x0, y0), (x1, y1) = value
    return (float(x0), float(y0)), (float(x1), float(y1))


@dataclass(frozen=True, repr=False)
class TiltMeasurement(Display):
    """The tilt of the holder measured in one photo (immutable).

    Attributes
    ----------
    path : str
        The photo (``"<array>"`` when it was given as an array).
    angle : float
        Tilt, rad: the tape's angle from the reference direction, positive when the top of the
        holder leans toward the image's right; in [−π/2, π/2).
    reference : str
        ``"vertical"`` (the image vertical, the sensor's z axis), ``"detected"`` (the normal of the
        sensor case's top edge, found in the photo) or ``"given"`` (a line given by two points).
    reference_angle : float
        The reference direction's angle from the image vertical, rad, same sign convention
        (0 for ``"vertical"``). ``angle`` + ``reference_angle`` is the tape's angle in the image.
    line : ((x0, y0), (x1, y1))
        End points of the measured tape line, px of the upright image: lower end, then upper end.
    method : str
        ``"auto"`` (found and fitted) or ``"manual"`` (two points given).
    length : float
        Length of the measured line, px.
    residual_rms : float
        RMS distance of the tape's centre points from the fitted line, px (NaN when manual).
    reference_line : ((x0, y0), (x1, y1)) or None
        End points of the reference line (the case edge, left to right, or the given points),
        px; None for ``"vertical"``.
    image_size : (int, int)
        Width and height of the upright image, px.
    """

    path: str
    angle: float
    reference: str
    reference_angle: float
    line: Segment
    method: str
    length: float
    residual_rms: float
    reference_line: Segment | None = None
    image_size: tuple[int, int] = (0, 0)

    def __post_init__(self) -> None:
        v.choice("reference", self.reference, RESULT_REFERENCES)
        v.choice("method", self.method, METHODS)
        object.__setattr__(self, "line", _segment(self.line))
        if self.reference_line is not None:
            object.__setattr__(self, "reference_line", _segment(self.reference_line))
        w, h = self.image_size
        object.__setattr__(self, "image_size", (int(w), int(h)))

    @property
    def angle_deg(self) -> float:
        """The tilt in degrees (for display)."""
        return math.degrees(self.angle)

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready description: angles in rad (and degrees for reading), points in px."""
        return {
            "kind": "tilt_measurement", "path": self.path,
            "angle_rad": self.angle, "angle_deg": self.angle_deg,
            "reference": self.reference, "reference_angle_rad": self.reference_angle,
            "reference_angle_deg": math.degrees(self.reference_angle),
            "line_px": [list(p) for p in self.line], "method": self.method,
            "length_px": self.length, "residual_rms_px": self.residual_rms,
            "reference_line_px": (None if self.reference_line is None
                                  else [list(p) for p in self.reference_line]),
            "image_size_px": list(self.image_size),
        }

    @classmethod
    def from_dict(cls, data: Mapping[str, Any]) -> TiltMeasurement:
        """Rebuild from :meth:`to_dict` output."""
        with v.rebuilding("tilt measurement data", "TiltMeasurement"):
            ref = data.get("reference_line_px")
            rms = data.get("residual_rms_px")
            return cls(
                path=str(data["path"]), angle=float(data["angle_rad"]),
                reference=str(data["reference"]),
                reference_angle=float(data["reference_angle_rad"]),
                line=_segment(data["line_px"]), method=str(data["method"]),
                length=float(data["length_px"]),
                residual_rms=math.nan if rms is None else float(rms),
                reference_line=None if ref is None else _segment(ref),
                image_size=tuple(data.get("image_size_px", (0, 0))),
            )

    def report(self) -> str:
        """One line: the photo, the tilt in degrees and what it is measured from."""
        if self.reference == "vertical":
            ref = "the image vertical"
        else:
            what = "case edge normal" if self.reference == "detected" else "given reference"
            ref = f"the {what} (at {math.degrees(self.reference_angle):+.2f} deg)"
        fit = ("" if math.isnan(self.residual_rms)
               else f", rms {self.residual_rms:.2g} px")
        return (f"{self.path}: tilt {self.angle_deg:+.3f} deg from {ref} ({self.method}, "
                f"line {self.length:.0f} px{fit})")

    # -- display --------------------------------------------------------------------------------
    def _display_items(self) -> list[Item]:
        return [("angle", f"{math.degrees(self.angle):.4g} deg"), ("reference", self.reference),
                ("method", self.method), ("length", f"{self.length:.0f} px"),
                ("residual", f"{number(self.residual_rms)} px"), ("path", self.path)]


# -- the image -------------------------------------------------------------------------------------
def _as_image(photo: str | os.PathLike[str] | Photo | ArrayLike) -> Photo:
    """The photo to measure: a file decoded by :func:`load_photo`, or an array at scale 1."""
    if isinstance(photo, str | os.PathLike):
        return load_photo(photo)
    if isinstance(photo, Photo):
        return photo
    try:
        img = np.asarray(photo, dtype=np.float64)
    except (TypeError, ValueError):
        raise v.fail("photo", type(photo).__name__, "a path or a 2-D grey array") from None
    if img.ndim != 2 or min(img.shape) < 16:
        raise v.fail("photo", f"an array of shape {img.shape}",
                     "a path or a 2-D grey array of at least 16 x 16 pixels")
    return Photo(img, 1, (img.shape[1], img.shape[0]), ARRAY_PATH)


def _points(name: str, value: ArrayLike, shape: tuple[int, int]) -> F64:
    pts = v.finite_array(name, value, unit="px")
    h, w = shape
    if pts.shape != (2, 2) or float(np.hypot(*(pts[1] - pts[0]))) < 1.0:
        raise v.fail(name, f"an array of shape {pts.shape}" if pts.shape != (2, 2)
                     else pts.tolist(), "two distinct (x, y) points in px, ((x0, y0), (x1, y1))")
    if not (np.all(pts >= -0.5) and np.all(pts[:, 0] <= w - 0.5) and np.all(pts[:, 1] <= h - 0.5)):
        raise v.fail(name, pts.tolist(), f"points inside the {w} x {h} px image")
    return pts


def measure_tilt(
    photo: str | os.PathLike[str] | Photo | ArrayLike,
    *,
    reference: str = "vertical",
    line_points: ArrayLike | None = None,
    reference_points: ArrayLike | None = None,
) -> TiltMeasurement:
    """Measure the holder's tilt in a photo from the reflective tape along it.

    Parameters
    ----------
    photo : str, path-like, Photo or array-like, shape (h, w)
        A photo file (decoded with :func:`load_photo`: EXIF orientation applied, downscaled
        beyond :data:`DECODE_SIDE` px), a decoded :class:`Photo`, or a grey image, rows top to
        bottom. Points and the result are in px of the (upright) photo at full size.
    reference : {"vertical", "detect"}
        Measure from the image vertical (the sensor's z axis), or detect the sensor case's top
        edge (the strongest long straight edge within 25 degrees of horizontal) and measure from
        its normal.
    line_points : array-like, shape (2, 2), optional
        Manual mode: two (x, y) points on the tape, px of the upright image; no search.
    reference_points : array-like, shape (2, 2), optional
        Two (x, y) points, px, on a reference line that should be vertical (with
        ``reference="vertical"`` only).

    Returns
    -------
    TiltMeasurement
        The angle, rad, positive when the top of the holder leans toward the image's right.

    Raises
    ------
    MagciliaError
        If the photo cannot be read, no tape line (or, with ``"detect"``, no case edge) is found,
        or the points are not two distinct points inside the image.
    """
    ref = v.choice("reference", reference, REFERENCES)
    if ref == "detect" and reference_points is not None:
        raise v.fail("reference", ref, "'vertical' when reference_points are given")
    decoded = _as_image(photo)
    img, path = decoded.image, decoded.path
    full = (decoded.size[1], decoded.size[0])  # h, w of the photo: points are in its px
    where = "the image" if path == ARRAY_PATH else repr(path)
    small, f = downsample(img)
    if line_points is None:
        fit = fit_tape(img, small, f, where)
        lo, hi = (decoded.to_photo(p) for p in fit.ends())
        method, rms = "auto", fit.rms * decoded.scale
    else:
        pts = _points("line_points", line_points, full)
        lo, hi = pts[0], pts[1]
        method, rms = "manual", math.nan
    line = upward(lo, hi)
    tape_angle = tilt_of(np.subtract(line[1], line[0]))
    ref_line: Segment | None = None
    ref_angle, kind = 0.0, "vertical"
    if ref == "detect":
        edge = fit_edge(img, small, f, where)
        a, b = (decoded.to_photo(p) for p in edge.ends())
        ref_line = ((float(a[0]), float(a[1])), (float(b[0]), float(b[1])))
        if a[0] > b[0]:
            ref_line = (ref_line[1], ref_line[0])
        ex, ey = np.subtract(ref_line[1], ref_line[0])
        ref_angle, kind = math.atan2(ey, ex), "detected"
    elif reference_points is not None:
        rp = _points("reference_points", reference_points, full)
        ref_line = upward(rp[0], rp[1])
        ref_angle, kind = tilt_of(np.subtract(ref_line[1], ref_line[0])), "given"
    length = math.hypot(line[1][0] - line[0][0], line[1][1] - line[0][1])
    return TiltMeasurement(path=path, angle=wrap(tape_angle - ref_angle), reference=kind,
                           reference_angle=ref_angle, line=line, method=method, length=length,
                           residual_rms=rms, reference_line=ref_line, image_size=decoded.size)


# -- manual picking --------------------------------------------------------------------------------
_BATCH_BACKENDS = {"agg", "cairo", "pdf", "pgf", "ps", "svg", "template"}


def pick_points(image: ArrayLike, n: int, prompt: str) -> list[Point]:
    """Show ``image`` in a window and collect ``n`` mouse clicks (the interactive manual mode).

    Parameters
    ----------
    image : array-like, shape (h, w)
        Grey image, rows top to bottom.
    n : int
        Number of points to collect.
    prompt : str
        What to click, shown as the window's title.

    Returns
    -------
    list of (x, y)
        The clicked points, px of the image (x to the right, y down).

    Raises
    ------
    MagciliaError
        Without a display (a non-interactive matplotlib backend, or no X/Wayland display), or
        if the window is closed before ``n`` points are clicked.
    """
    count = v.integer("n", n, 1)
    img = v.finite_array("image", image, ndim=2)
    import matplotlib as mpl

    backend = mpl.get_backend().lower()
    headless = sys.platform.startswith("linux") and not (
        os.environ.get("DISPLAY") or os.environ.get("WAYLAND_DISPLAY"))
    if backend in _BATCH_BACKENDS or backend.startswith("module://") or headless:
        raise MagciliaError(f"picking points needs a display (matplotlib backend {backend!r}); "
                            "give the points instead: --line X0,Y0,X1,Y1 (px)")
    import matplotlib.pyplot as plt

    fig = plt.figure(figsize=(9, 7))
    try:
        ax = fig.add_subplot()
        ax.imshow(img, cmap="gray")
        ax.set_title(f"{prompt} ({count} clicks; right click removes the last)")
        points = fig.ginput(count, timeout=0)
    finally:
        plt.close(fig)
    if len(points) < count:
        raise MagciliaError(f"picking stopped after {len(points)} of {count} points; "
                            "click all points before closing the window")
    return [(float(x), float(y)) for x, y in points]
