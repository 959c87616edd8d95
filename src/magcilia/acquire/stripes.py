"""Straight bright stripes and straight edges in grey images: how :mod:`.photo` finds the
holder's tape and the sensor case's top edge (see its docstring for the method).

Image coordinates are pixels: x to the right, y down; angles in rad from the image vertical,
positive leaning right.
"""

from __future__ import annotations

import math
from typing import Any, NamedTuple

import numpy as np
from numpy.typing import NDArray

from magcilia import _validate as v
from magcilia._errors import MagciliaError, require

F64 = NDArray[np.float64]
Bools = NDArray[np.bool_]
Point = tuple[float, float]
Segment = tuple[Point, Point]

WORK_SIZE = 1000  # longest side of the image the tape and the case edge are searched on, px
MANUAL_HINT = ("give two points on the tape instead (line_points=..., or magcilia angle "
               "--manual / --line X0,Y0,X1,Y1)")


def photo_module(name: str, package: str, purpose: str) -> Any:
    """A package of the ``photo`` extra (part of the core install), or a one-line error naming
    the extra."""
    return require(name, package=package, extra="photo", purpose=purpose)


# -- geometry --------------------------------------------------------------------------------------
def tilt_of(direction: F64) -> float:
    """Angle of a line from the image vertical, rad in [−π/2, π/2), positive leaning right."""
    dx, dy = float(direction[0]), float(direction[1])
    if dy > 0 or (dy == 0 and dx < 0):
        dx, dy = -dx, -dy
    return wrap(math.atan2(dx, -dy))


def wrap(angle: float) -> float:
    """An undirected line's angle wrapped into [−π/2, π/2)."""
    return (angle + math.pi / 2) % math.pi - math.pi / 2


def upward(a: F64, b: F64) -> Segment:
    """The segment a–b ordered lower end first (larger y), as plain floats."""
    lo, hi = (a, b) if a[1] >= b[1] else (b, a)
    return (float(lo[0]), float(lo[1])), (float(hi[0]), float(hi[1]))


class Line(NamedTuple):
    """A fitted line: a point, a unit direction, the extent along it and fit figures (px)."""

    centre: F64
    direction: F64
    t0: float
    t1: float
    rms: float
    width: float

    def ends(self) -> tuple[F64, F64]:
        return self.centre + self.t0 * self.direction, self.centre + self.t1 * self.direction


def downsample(img: F64) -> tuple[F64, int]:
    """Block means of f x f pixels so that the longest side is at most ~WORK_SIZE; checks that
    the image is finite (a NaN spreads into its block mean)."""
    f = max(1, math.ceil(max(img.shape) / WORK_SIZE))
    h, w = (img.shape[0] // f), (img.shape[1] // f)
    if f == 1:
        small = img
        rest_ok = True
    else:
        rows = img[: h * f].reshape(h, f, img.shape[1]).sum(axis=1)
        small = rows[:, : w * f].reshape(h, w, f).sum(axis=2) / (f * f)
        rest_ok = bool(np.isfinite(img[h * f:]).all() and np.isfinite(img[:, w * f:]).all())
    if not (rest_ok and np.isfinite(small).all()):
        raise v.fail("photo", "an image with NaN or inf pixels", "finite grey levels")
    lo, hi = np.percentile(small, [1.0, 99.0])
    return (small - lo) / max(hi - lo, 1e-12), f


def _to_full(p: F64, f: int) -> F64:
    """A point of the block-averaged image in full-resolution pixels."""
    return (p + 0.5) * f - 0.5


# -- coarse detection on the small image -----------------------------------------------------------
class _Bar(NamedTuple):
    """A bar-like region found in the small image: score, centre, unit direction, length and
    width (px of the small image)."""

    score: float
    centre: F64
    direction: F64
    length: float
    width: float


def _bars(mask: Bools, label: Any) -> list[_Bar]:
    """The bar-like connected regions of ``mask`` (long: at least 12 % of the short side, and
    at least 4 times longer than wide). Moments of all regions at once (bincount)."""
    labels = label(mask, connectivity=2)
    n = int(labels.max())
    if n == 0:
        return []
    ys, xs = np.nonzero(labels)
    lab = labels[ys, xs]
    count = np.bincount(lab, minlength=n + 1).astype(np.float64)
    count[0] = np.inf
    mx, my = (np.bincount(lab, c, n + 1) / count for c in (xs, ys))
    dx, dy = xs - mx[lab], ys - my[lab]
    sxx, syy, sxy = (np.bincount(lab, c, n + 1) / count for c in (dx * dx, dy * dy, dx * dy))
    half_tr, det = (sxx + syy) / 2, sxx * syy - sxy**2
    disc = np.sqrt(np.maximum(half_tr**2 - det, 0.0))
    length = 4 * np.sqrt(half_tr + disc) / 1.155  # a uniform bar's full length and width
    width = np.maximum(4 * np.sqrt(np.maximum(half_tr - disc, 0.0)) / 1.155, 1.0)
    elongation = length / width
    score = np.where((length >= 0.12 * min(mask.shape)) & (elongation >= 4),
                     length * np.minimum(elongation / 10, 1.0), 0.0)
    score[0] = 0.0
    out = []
    for i in np.flatnonzero(score > 0):
        angle = 0.5 * math.atan2(2 * sxy[i], sxx[i] - syy[i])
        out.append(_Bar(float(score[i]), np.array([mx[i], my[i]]),
                        np.array([math.cos(angle), math.sin(angle)]), float(length[i]),
                        float(width[i])))
    return out


def _find_tape(small: F64, keep: int = 6) -> list[_Bar]:
    """Candidates for the tape, the most bar-like first: bright narrow regions (a white top-hat
    removes the background's light) at three thresholds: Otsu's, then Otsu's again above it,
    twice (a bright tape stays whole where a textured background falls apart)."""
    measure = photo_module("skimage.measure", "scikit-image", "finding the tape in a photo")
    filters = photo_module("skimage.filters", "scikit-image", "finding the tape in a photo")
    from scipy import ndimage
    k = max(15, min(small.shape) // 6)
    top = small - ndimage.grey_opening(small, size=(k, k))
    found: list[_Bar] = []
    values = top.ravel()
    for _ in range(3):
        if values.size < 16 or not np.ptp(values) > 0:
            break
        level = float(filters.threshold_otsu(values))
        found += _bars(top > level, measure.label)
        values = values[values > level]
    return sorted(found, key=lambda bar: -bar.score)[:keep]


def _find_edge(small: F64) -> tuple[F64, F64] | None:
    """The strongest nearly horizontal straight edge (within 25 degrees): (point, unit direction
    pointing right) in px of ``small``, or None."""
    purpose = "finding the case edge in a photo"
    feature = photo_module("skimage.feature", "scikit-image", purpose)
    transform = photo_module("skimage.transform", "scikit-image", purpose)
    edges = feature.canny(small, sigma=2.0)
    if not edges.any():
        return None
    hspace, thetas, dists = transform.hough_line(edges, np.radians(np.linspace(65, 115, 251)))
    i, j = np.unravel_index(int(np.argmax(hspace)), hspace.shape)
    if hspace[i, j] < 0.25 * small.shape[1]:
        return None
    normal = np.array([math.cos(thetas[j]), math.sin(thetas[j])])
    direction = np.array([normal[1], -normal[0]])
    centre = np.array([(small.shape[1] - 1) / 2, (small.shape[0] - 1) / 2])
    point = centre + (float(dists[i]) - centre @ normal) * normal
    return point, direction


# -- refinement on the full image ------------------------------------------------------------------
def _profiles(img: F64, centre: F64, direction: F64, t: F64, s: F64) -> F64:
    """Grey levels across the line at stations ``t`` (px along it) and offsets ``s`` (px across,
    toward +normal), shape (t, s); NaN outside the image (linear interpolation)."""
    normal = np.array([-direction[1], direction[0]])
    x = centre[0] + t[:, None] * direction[0] + s[None, :] * normal[0]
    y = centre[1] + t[:, None] * direction[1] + s[None, :] * normal[1]
    from scipy import ndimage
    out = ndimage.map_coordinates(img, [y.ravel(), x.ravel()], order=1, mode="constant",
                                  cval=np.nan)
    return np.asarray(out, dtype=np.float64).reshape(x.shape)


def _peak_centres(p: F64, s: F64, core: float, outer: float) -> tuple[F64, F64, F64]:
    """Per row of ``p``: the centroid (in units of ``s``) of the part above half height of the
    peak found within |s| <= core (height over the higher of the two baselines |s| >= outer),
    its contrast and its width; NaN where the peak is not closed inside the window."""
    idx = np.arange(s.size)
    pk = np.argmax(np.where(np.abs(s) <= core, p, -np.inf), axis=1)
    peak = p[np.arange(p.shape[0]), pk]
    base = np.maximum(np.median(p[:, s <= -outer], axis=1), np.median(p[:, s >= outer], axis=1))
    half = (peak + base)[:, None] / 2
    below = p <= half
    left = np.max(np.where(below & (idx < pk[:, None]), idx, -1), axis=1)
    right = np.min(np.where(below & (idx > pk[:, None]), idx, s.size), axis=1)
    inside = (idx > left[:, None]) & (idx < right[:, None])
    weight = np.where(inside, p - half, 0.0)
    with np.errstate(invalid="ignore", divide="ignore"):
        centre = (weight * s).sum(axis=1) / weight.sum(axis=1)
    closed = (left >= 0) & (right < s.size)
    width = inside.sum(axis=1) * (s[1] - s[0])
    return np.where(closed, centre, np.nan), peak - base, width


def _largest_run(valid: Bools, gap: int) -> Bools:
    """``valid`` restricted to its largest run of stations (gaps up to ``gap`` allowed)."""
    idx = np.flatnonzero(valid)
    if idx.size == 0:
        return valid
    cuts = np.flatnonzero(np.diff(idx) > gap + 1) + 1
    runs = np.split(idx, cuts)
    best = max(runs, key=len)
    out = np.zeros_like(valid)
    out[best[0]: best[-1] + 1] = valid[best[0]: best[-1] + 1]
    return out


def _refine(img: F64, centre: F64, direction: F64, half_len: float, half_win: float,
            stations: int, kind: str) -> Line | None:
    """Fit the stripe (``kind="ridge"``) or the step edge (``"edge"``) near a line guess."""
    t = np.linspace(-half_len, half_len, stations)
    samples = 49 if kind == "ridge" else 65
    s = np.linspace(-half_win, half_win, samples)
    p = _profiles(img, centre, direction, t, s)
    rows: Bools = np.all(np.isfinite(p), axis=1)
    if rows.sum() < 8:
        return None
    p = np.where(rows[:, None], p, 0.0)
    if kind == "edge":
        # the derivative across the edge, smoothed over 1/16 of the window
        from scipy import ndimage
        g = ndimage.gaussian_filter1d(np.diff(p, axis=1), 4.0, axis=1)
        g *= 1.0 if np.sum(g[rows]) >= 0 else -1.0
        s = (s[1:] + s[:-1]) / 2
        c, contrast, width = _peak_centres(g, s, 0.6 * half_win, 0.8 * half_win)
    else:
        c, contrast, width = _peak_centres(p, s, 0.45 * half_win, 0.75 * half_win)
    valid: Bools = rows & np.isfinite(c)
    if valid.sum() < 8:
        return None
    valid &= contrast > 0.4 * np.median(contrast[valid])
    if kind == "ridge":
        valid = _largest_run(valid, max(2, stations // 10))
    keep = valid.copy()
    for _ in range(6):
        if keep.sum() < 8:
            return None
        b, a = np.polyfit(t[keep], c[keep], 1)
        r = c - (a + b * t)
        spread = max(3.0 * 1.4826 * float(np.median(np.abs(r[keep]))), 0.02 * half_win)
        new = valid & (np.abs(np.nan_to_num(r, nan=np.inf)) <= spread)
        if np.array_equal(new, keep):
            break
        keep = new
    if keep.sum() < max(8, 0.5 * valid.sum()):
        return None
    normal = np.array([-direction[1], direction[0]])
    slope = math.hypot(1.0, b)
    new_dir = (direction + b * normal) / slope
    new_centre = centre + a * normal
    tk = t[keep] * slope  # distances along the new line (projection of the stations)
    rms = float(np.sqrt(np.mean(r[keep] ** 2))) / slope
    return Line(new_centre, new_dir, float(tk.min()), float(tk.max()), rms,
                 float(np.median(width[keep])))


def _fit_bar(img: F64, bar: _Bar, f: int) -> Line | None:
    """The straight stripe along a candidate, or None if it is not one (too short, or its
    centres scatter by more than a tenth of its width)."""
    line = Line(_to_full(bar.centre, f), bar.direction, -bar.length * f / 2,
                 bar.length * f / 2, math.nan, bar.width * f)
    for _ in range(2):  # the second pass samples across the better line, over its found ends
        mid = line.centre + 0.5 * (line.t0 + line.t1) * line.direction
        half_len = 0.5 * (line.t1 - line.t0) * 1.15 + 2.0 * f
        stations = int(np.clip(2 * half_len / f, 64, 512))
        fit = _refine(img, mid, line.direction, half_len, max(1.25 * line.width, 3.0),
                      stations, "ridge")
        if (fit is None or fit.t1 - fit.t0 < 0.1 * min(img.shape)
                or fit.rms > max(0.1 * fit.width, 0.3)):
            return None
        line = fit
    return line


def fit_tape(img: F64, small: F64, f: int, where: str) -> Line:
    for bar in _find_tape(small):
        line = _fit_bar(img, bar, f)
        if line is not None:
            return line
    raise MagciliaError(f"no tape line found in {where} (no long, bright, straight stripe); "
                        + MANUAL_HINT)


def fit_edge(img: F64, small: F64, f: int, where: str) -> Line:
    found = _find_edge(small)
    line = None
    if found is not None:
        point, direction = found
        centre = _to_full(point, f)
        half_len = 0.5 * math.hypot(*img.shape)
        stations = int(np.clip(img.shape[1] / f, 64, 512))
        line = _refine(img, centre, direction, half_len, 8.0 * max(f, 1.5), stations, "edge")
        if line is not None:
            line = _refine(img, line.centre, line.direction, half_len, 6.0 * max(f, 1.5),
                           stations, "edge")
    if line is None or line.t1 - line.t0 < 0.25 * img.shape[1]:
        raise MagciliaError(f"no case edge found in {where} (no long, nearly horizontal "
                            "straight edge); measure from the vertical or give reference points")
    return line


# -- the measurement -------------------------------------------------------------------------------
