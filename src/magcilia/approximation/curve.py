"""The output-vs-tilt curve that approximations are fitted to, and the helpers they share: range
checks, evaluation of a setup or a callable, linear interpolation with extrapolation and fold
detection. SI: angles in rad, outputs in V."""

from __future__ import annotations

import itertools
import math
from collections.abc import Callable

import numpy as np
from numpy.typing import ArrayLike, NDArray

from magcilia import _validate as v
from magcilia._errors import MagciliaError
from magcilia.device.setup import Setup

F64 = NDArray[np.float64]
Curve = Setup | Callable[[F64], ArrayLike]

#: the default angle range of the paper's experiment, rad
DEFAULT_RANGE = (0.0, math.radians(85.0))
#: most points of a dense fitting grid (``grid`` of :func:`~magcilia.piecewise_linear` and
#: :func:`~magcilia.lookup_table`): the corner search solves a least-squares problem on the whole
#: grid some thousand times, ~20 s at 10^5 points on two cores; 10^4 points (0.01 deg over
#: 85 deg) already resolve any curve the model gives
MAX_GRID = 100_000


def check_grid(grid: object, minimum: int) -> int:
    """A dense grid size: an integer from ``minimum`` to :data:`MAX_GRID`."""
    size = v.integer("grid", grid, minimum)
    if size > MAX_GRID:
        raise v.fail("grid", size, f"at most {MAX_GRID} points (MAX_GRID); a finer grid does not "
                                   "change the fit")
    return size


#: the widest tilt range, rad: one turn either way (the output is periodic in the tilt)
MAX_TILT = 2.0 * math.pi
#: the narrowest tilt range, rad (a finer one leaves the dense grid's spacing to underflow)
MIN_SPAN = 1e-9


def check_range(angle_range: tuple[float, float] | ArrayLike) -> tuple[float, float]:
    """A (start, stop) tilt range in rad: finite, within ±:data:`MAX_TILT`, at least
    :data:`MIN_SPAN` wide."""
    try:
        lo, hi = (float(x) for x in np.asarray(angle_range, dtype=np.float64).ravel())
    except (TypeError, ValueError):
        raise v.fail("angle_range", angle_range, "a (start, stop) pair of angles in rad") from None
    if not (math.isfinite(lo) and math.isfinite(hi)):
        raise v.fail("angle_range", (lo, hi), "a finite (start, stop) pair of angles in rad")
    if hi <= lo:
        raise v.fail("angle_range", (lo, hi), "a non-empty range with stop > start (rad)")
    if max(abs(lo), abs(hi)) > MAX_TILT or hi - lo < MIN_SPAN:
        raise v.fail("angle_range", (lo, hi), f"a range within ±{MAX_TILT:.6g} rad (±360 deg) "
                                              f"at least {MIN_SPAN:g} rad wide")
    return lo, hi


def evaluate(curve: Curve, angles: F64) -> F64:
    """The curve's output at ``angles`` (rad), V, checked finite."""
    if isinstance(curve, Setup):
        return curve.output(angles)
    if not callable(curve):
        raise v.fail("curve", type(curve).__name__, "a magcilia Setup or a callable f(tilt) -> V")
    out = np.asarray(curve(angles), dtype=np.float64)
    if out.shape != angles.shape:
        raise v.fail("curve output", f"shape {out.shape}",
                     f"shape {angles.shape} (one V per angle)")
    if not np.isfinite(out).all():
        raise v.fail("curve output", "non-finite values", "finite volts over the whole range")
    return out


def interp_extrap(x: F64, xp: F64, fp: F64) -> F64:
    """Linear interpolation through increasing nodes ``xp`` with linear extrapolation at both
    ends."""
    i = np.clip(np.searchsorted(xp, x, side="right") - 1, 0, xp.size - 2)
    x0, x1 = xp[i], xp[i + 1]
    return np.asarray(fp[i] + (fp[i + 1] - fp[i]) * (x - x0) / (x1 - x0), dtype=np.float64)


def folds_of(angles: F64, values: F64) -> tuple[float, ...]:
    """Angles (rad) where a sampled curve turns (its slope changes sign or vanishes)."""
    d = np.diff(values)
    sign = np.sign(d)
    if np.all(sign > 0) or np.all(sign < 0):
        return ()
    nz = np.nonzero(sign)[0]
    if nz.size == 0:
        return (float(angles[0]),)
    out = []
    if nz[0] > 0:  # flat start
        out.append(float(angles[nz[0]]))
    for a, b in itertools.pairwise(nz):
        if sign[a] != sign[b] or b > a + 1:
            out.append(float(angles[b]))
    if nz[-1] < d.size - 1:  # flat end
        out.append(float(angles[nz[-1] + 1]))
    return tuple(out)


def fold_error(what: str, lo: float, hi: float, folds: tuple[float, ...]) -> MagciliaError:
    marks = ", ".join(f"{math.degrees(f):.4g}" for f in folds)
    return MagciliaError(
        f"{what} needs a strictly monotonic curve, but the output over "
        f"{math.degrees(lo):.4g}..{math.degrees(hi):.4g} deg folds (turns or is flat) "
        f"at {marks} deg; "
        "restrict the angle range to one side of it"
    )
