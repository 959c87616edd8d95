"""Fast read-out approximations of the output-vs-tilt curve (the paper's Sec. V).

Once calibrated, the model's output V(θ) is smooth and nearly linear; the paper suggests replacing it
at read-out by a piecewise-linear function with two corner points, or by a line over a reduced
range. This module makes that a fit with known error:

* :func:`piecewise_linear` — continuous least-squares fit of a continuous piecewise-linear function
  with ``corners`` interior corner points on a dense angle grid. For fixed corners the node values
  are a linear least-squares problem in the hat-function basis; the corner positions are optimised
  (bounded and ordered) by a coarse exhaustive search followed by Nelder–Mead refinement over a
  log-gap parametrisation that keeps them ordered and inside the range.
* :func:`lookup_table` — a uniform table with linear interpolation, either V→θ (``"inverse"``,
  what firmware needs) or θ→V (``"output"``), with the classic interpolation error bound
  ``h² / 8 · max|g''|`` from the tabulated function's curvature.

Both results extrapolate linearly beyond their range (the end segments continued). SI units:
angles in rad, outputs in V. :mod:`magcilia.firmware` exports them as C.
"""

from __future__ import annotations

import dataclasses
import itertools
import math
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy.optimize import minimize

from magcilia import _validate as v
from magcilia._errors import MagciliaError
from magcilia.setup import Setup

F64 = NDArray[np.float64]
Curve = Setup | Callable[[F64], ArrayLike]

#: the default angle range of the paper's experiment, rad
DEFAULT_RANGE = (0.0, math.radians(85.0))
QUANTITIES = ("inverse", "output")


# -- shared helpers ------------------------------------------------------------------------------
def _check_range(angle_range: tuple[float, float] | ArrayLike) -> tuple[float, float]:
    try:
        lo, hi = (float(x) for x in np.asarray(angle_range, dtype=np.float64).ravel())
    except (TypeError, ValueError):
        raise v.fail("angle_range", angle_range, "a (start, stop) pair of angles in rad") from None
    if not (math.isfinite(lo) and math.isfinite(hi)):
        raise v.fail("angle_range", (lo, hi), "a finite (start, stop) pair of angles in rad")
    if hi <= lo:
        raise v.fail("angle_range", (lo, hi), "a non-empty range with stop > start (rad)")
    return lo, hi


def _evaluate(curve: Curve, angles: F64) -> F64:
    """The curve's output at ``angles`` (rad), V, checked finite."""
    if isinstance(curve, Setup):
        return curve.output(angles)
    if not callable(curve):
        raise v.fail("curve", type(curve).__name__, "a magcilia Setup or a callable f(tilt) -> V")
    out = np.asarray(curve(angles), dtype=np.float64)
    if out.shape != angles.shape:
        raise v.fail("curve output", f"shape {out.shape}", f"shape {angles.shape} (one V per angle)")
    if not np.isfinite(out).all():
        raise v.fail("curve output", "non-finite values", "finite volts over the whole range")
    return out


def _interp_extrap(x: F64, xp: F64, fp: F64) -> F64:
    """Linear interpolation through increasing nodes ``xp`` with linear extrapolation at both ends."""
    i = np.clip(np.searchsorted(xp, x, side="right") - 1, 0, xp.size - 2)
    x0, x1 = xp[i], xp[i + 1]
    return np.asarray(fp[i] + (fp[i + 1] - fp[i]) * (x - x0) / (x1 - x0), dtype=np.float64)


def _folds(angles: F64, values: F64) -> tuple[float, ...]:
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


def _fold_error(what: str, lo: float, hi: float, folds: tuple[float, ...]) -> MagciliaError:
    marks = ", ".join(f"{math.degrees(f):.4g}" for f in folds)
    return MagciliaError(
        f"{what} needs a strictly monotonic curve, but the output over "
        f"{math.degrees(lo):.4g}..{math.degrees(hi):.4g} deg folds (turns or is flat) at {marks} deg; "
        "restrict the angle range to one side of it"
    )


# -- piecewise-linear fit ------------------------------------------------------------------------
@dataclass(frozen=True, eq=False)
class PiecewiseLinear:
    """A continuous piecewise-linear approximation of the output-vs-tilt curve (immutable).

    Call it with tilt angles (rad, shape (a,)) to get outputs (V, shape (a,)); beyond the fitted
    range the end segments are continued linearly.

    Attributes
    ----------
    knots : ndarray, shape (corners + 2,)
        All nodes, rad, increasing: the range start, the corners, the range end.
    values : ndarray, shape (corners + 2,)
        Output at the nodes, V.
    max_error, rms_error : float
        Largest and RMS |approximation − curve| over the dense fitting grid, V.
    max_angle_error : float
        Largest angle error, rad, over the dense grid: with a monotonic approximation the exact
        read-out error ``inverse(curve(θ)) − θ``; otherwise the local estimate
        ``|error(θ)| / |dV/dθ|`` (infinite where the curve is flat).
    folds : tuple of float
        Angles (rad) where the *curve* turns or is flat over the range (empty when it is strictly
        monotonic); an inverse is only offered without folds.
    grid : int
        Points of the dense uniform fitting grid.
    """

    knots: F64
    values: F64
    max_error: float
    rms_error: float
    max_angle_error: float
    folds: tuple[float, ...] = ()
    grid: int = 0

    def __post_init__(self) -> None:
        for name in ("knots", "values"):
            arr = np.array(getattr(self, name), dtype=np.float64)
            arr.setflags(write=False)
            object.__setattr__(self, name, arr)
        if self.knots.ndim != 1 or self.knots.size < 2 or self.values.shape != self.knots.shape:
            raise v.fail("knots/values", f"shapes {self.knots.shape}, {self.values.shape}",
                         "two equal 1-D arrays with at least 2 nodes")
        if not (np.isfinite(self.knots).all() and np.isfinite(self.values).all()):
            raise v.fail("knots/values", "non-finite entries", "finite numbers")
        if np.any(np.diff(self.knots) <= 0):
            raise v.fail("knots", self.knots.tolist(), "strictly increasing angles in rad")

    # -- evaluation ------------------------------------------------------------------------------
    def __call__(self, tilt: ArrayLike) -> F64:
        """Approximate output, V, same shape as ``tilt`` (rad)."""
        t = v.finite_array("tilt", tilt, unit="rad")
        return _interp_extrap(t.ravel(), self.knots, self.values).reshape(t.shape)

    @property
    def corners(self) -> int:
        """Number of interior corner points."""
        return int(self.knots.size - 2)

    @property
    def breakpoints(self) -> F64:
        """Interior corner angles, rad, shape (corners,)."""
        return self.knots[1:-1]

    @property
    def angle_range(self) -> tuple[float, float]:
        """The fitted range (start, stop), rad."""
        return float(self.knots[0]), float(self.knots[-1])

    @property
    def slopes(self) -> F64:
        """Segment slopes, V/rad, shape (corners + 1,)."""
        return np.diff(self.values) / np.diff(self.knots)

    @property
    def invertible(self) -> bool:
        """True if the curve has no folds and the node values are strictly monotonic."""
        d = np.diff(self.values)
        return not self.folds and bool(np.all(d > 0) or np.all(d < 0))

    def inverse(self, volts: ArrayLike) -> F64:
        """Tilt angle, rad, from output ``volts`` (V, any shape): the approximation inverted,
        with linear extrapolation beyond the end nodes.

        Raises
        ------
        MagciliaError
            If the curve is not strictly monotonic over the range (naming where it folds).
        """
        if not self.invertible:
            lo, hi = self.angle_range
            folds = self.folds or tuple(
                float(k) for k, d in zip(self.knots[1:], np.diff(self.values), strict=True) if d == 0
            ) or (lo,)
            raise _fold_error("inverse", lo, hi, folds)
        y = v.finite_array("volts", volts, unit="V")
        vals, knots = self.values, self.knots
        if vals[-1] < vals[0]:
            vals, knots = vals[::-1], knots[::-1]
        return _interp_extrap(y.ravel(), vals, knots).reshape(y.shape)

    # -- export ----------------------------------------------------------------------------------
    def to_dict(self) -> dict[str, Any]:
        """JSON-ready description (SI, plus degrees and millivolts for reading)."""
        return {
            "kind": "piecewise_linear", "corners": self.corners,
            "angle_range_rad": list(self.angle_range),
            "knots_rad": self.knots.tolist(), "values_V": self.values.tolist(),
            "breakpoints_rad": self.breakpoints.tolist(),
            "knots_deg": np.degrees(self.knots).tolist(),
            "slopes_V_per_rad": self.slopes.tolist(),
            "max_error_V": self.max_error, "rms_error_V": self.rms_error,
            "max_angle_error_rad": self.max_angle_error,
            "max_angle_error_deg": math.degrees(self.max_angle_error),
            "folds_rad": list(self.folds), "invertible": self.invertible, "grid": self.grid,
        }

    @classmethod
    def from_dict(cls, data: Mapping[str, Any]) -> PiecewiseLinear:
        """Rebuild from :meth:`to_dict` output."""
        try:
            return cls(
                knots=np.asarray(data["knots_rad"], dtype=np.float64),
                values=np.asarray(data["values_V"], dtype=np.float64),
                max_error=float(data["max_error_V"]), rms_error=float(data["rms_error_V"]),
                max_angle_error=float(data.get("max_angle_error_rad", math.nan) or math.nan),
                folds=tuple(float(f) for f in data.get("folds_rad", ())),
                grid=int(data.get("grid", 0)),
            )
        except (KeyError, TypeError, ValueError) as exc:
            raise v.fail("approximation data", f"missing or bad {exc}",
                         "a dict from PiecewiseLinear.to_dict()") from None

    def table(self) -> list[dict[str, float]]:
        """Rows per node: angle (deg), output (mV), slope of the following segment (mV/deg)."""
        slopes = np.append(self.slopes, math.nan)
        return [
            {"angle_deg": math.degrees(k), "output_mV": val * 1e3,
             "slope_mV_per_deg": s * 1e3 * math.pi / 180.0}
            for k, val, s in zip(self.knots, self.values, slopes, strict=True)
        ]


def hat_basis(x: F64, knots: F64) -> F64:
    """Hat-function basis of continuous piecewise-linear functions, shape (g, m).

    Parameters
    ----------
    x : ndarray, shape (g,)
        Evaluation points (inside ``[knots[0], knots[-1]]``).
    knots : ndarray, shape (m,)
        Strictly increasing nodes.
    """
    m = knots.size
    i = np.clip(np.searchsorted(knots, x, side="right") - 1, 0, m - 2)
    w = (x - knots[i]) / (knots[i + 1] - knots[i])
    basis = np.zeros((x.size, m))
    rows = np.arange(x.size)
    basis[rows, i] = 1.0 - w
    basis[rows, i + 1] += w
    return basis


def _node_values(x: F64, y: F64, knots: F64) -> tuple[F64, float]:
    """Least-squares node values for fixed knots, and the sum of squared residuals."""
    basis = hat_basis(x, knots)
    coef, *_ = np.linalg.lstsq(basis, y, rcond=None)
    r = y - basis @ coef
    return np.asarray(coef), float(r @ r)


def _knots_from_gaps(z: F64, lo: float, hi: float) -> F64:
    """Ordered knots from c free log-gaps (the last of the c+1 gaps is fixed to exp(0))."""
    g = np.exp(np.clip(np.append(z, 0.0), -30.0, 30.0))
    inner = lo + (hi - lo) * np.cumsum(g)[:-1] / g.sum()
    return np.concatenate([[lo], inner, [hi]])


def _gaps_from_knots(inner: F64, lo: float, hi: float) -> F64:
    edges = np.concatenate([[lo], inner, [hi]])
    g = np.maximum(np.diff(edges), 1e-9 * (hi - lo))
    return np.asarray(np.log(g[:-1] / g[-1]))


def _coarse_starts(x: F64, y: F64, corners: int, lo: float, hi: float, keep: int) -> list[F64]:
    """Candidate interior corners: exhaustive on a coarse grid for few corners, else
    curvature-equidistributed; the ``keep`` best by squared error."""
    cands: list[F64] = []
    if corners <= 3:
        m = {1: 64, 2: 32, 3: 14}[corners]
        pts = lo + (hi - lo) * np.arange(1, m) / m
        cands = [np.array(c) for c in itertools.combinations(pts, corners)]
    # equidistribute |y''|^(2/5), the L2-optimal knot density of linear interpolation
    d2 = np.abs(np.gradient(np.gradient(y, x), x)) ** 0.4 + 1e-12
    cdf = np.concatenate([[0.0], np.cumsum(0.5 * (d2[1:] + d2[:-1]) * np.diff(x))])
    cdf /= cdf[-1]
    targets = np.arange(1, corners + 1) / (corners + 1)
    cands.append(np.interp(targets, cdf, x))
    cands.append(lo + (hi - lo) * targets)  # uniform
    scored = sorted(((_node_values(x, y, np.concatenate([[lo], c, [hi]]))[1], i)
                     for i, c in enumerate(cands)), key=lambda t: t[0])
    return [cands[i] for _, i in scored[:keep]]


def fit_piecewise_linear(
    angles: ArrayLike, volts: ArrayLike, corners: int = 2, *, starts: int = 3
) -> tuple[F64, F64]:
    """Least-squares continuous piecewise-linear fit of sampled data with optimised corners.

    Parameters
    ----------
    angles : array-like, shape (g,)
        Increasing sample angles, rad (the first and last are the range ends).
    volts : array-like, shape (g,)
        Samples, V.
    corners : int
        Interior corner points (0: a straight line).
    starts : int
        Local refinements from the best coarse candidates.

    Returns
    -------
    knots, values : ndarray, shape (corners + 2,)
        Nodes (rad) including the range ends, and the fitted values (V).
    """
    x = v.finite_array("angles", angles, ndim=1, unit="rad")
    y = v.finite_array("volts", volts, ndim=1, unit="V")
    if x.size != y.size or x.size < 2 or np.any(np.diff(x) <= 0):
        raise v.fail("angles", f"{x.size} angles for {y.size} values",
                     "strictly increasing angles, one per value (at least 2)")
    corners = v.integer("corners", corners, 0)
    if corners > x.size - 2:
        raise v.fail("corners", corners, f"at most {x.size - 2} for a grid of {x.size} points "
                     "(use a finer grid or fewer corners)")
    lo, hi = float(x[0]), float(x[-1])
    if corners == 0:
        knots = np.array([lo, hi])
        return knots, _node_values(x, y, knots)[0]
    scale = float(y @ y) / y.size or 1.0

    def objective(z: F64) -> float:
        return _node_values(x, y, _knots_from_gaps(z, lo, hi))[1] / scale

    best_z, best_f = None, math.inf
    for inner in _coarse_starts(x, y, corners, lo, hi, max(1, starts)):
        z0 = _gaps_from_knots(inner, lo, hi)
        res = minimize(objective, z0, method="Nelder-Mead",
                       options={"xatol": 1e-10, "fatol": 1e-16, "maxiter": 4000 * corners,
                                "adaptive": corners > 2})
        if res.fun < best_f:
            best_z, best_f = np.asarray(res.x), float(res.fun)
    assert best_z is not None
    knots = _knots_from_gaps(best_z, lo, hi)
    return knots, _node_values(x, y, knots)[0]


def piecewise_linear(
    curve: Curve,
    corners: int = 2,
    angle_range: tuple[float, float] = DEFAULT_RANGE,
    grid: int = 1001,
    *,
    starts: int = 3,
) -> PiecewiseLinear:
    """Fit a continuous piecewise-linear function to a setup's output-vs-tilt curve.

    Parameters
    ----------
    curve : Setup or callable
        The sensor (its ``output(tilt)``, offset included), or any ``f(tilt) -> V`` of an
        array (a,) in rad returning (a,) V.
    corners : int
        Interior corner points; the paper suggests 2; 0 gives the best straight line.
    angle_range : (float, float)
        Fitted range (start, stop), rad; default 0..85°.
    grid : int
        Points of the dense uniform grid on which the continuous least-squares error is
        approximated (≥ corners + 2).
    starts : int
        Local refinements of the corner positions, from the best coarse candidates.

    Returns
    -------
    PiecewiseLinear
        Callable approximation with its max/RMS error (V) and angle error (rad).

    Examples
    --------
    >>> import magcilia as mc, numpy as np
    >>> approx = mc.piecewise_linear(mc.Setup.paper(), corners=2)
    >>> approx.breakpoints.shape
    (2,)
    >>> bool(approx.max_error < 5e-5)
    True
    """
    lo, hi = _check_range(angle_range)
    grid = v.integer("grid", grid, 3)
    corners = v.integer("corners", corners, 0)
    if corners > grid - 2:
        raise v.fail("corners", corners, f"at most {grid - 2} for a grid of {grid} points "
                     "(increase grid or use fewer corners)")
    x = np.linspace(lo, hi, grid)
    y = _evaluate(curve, x)
    knots, values = fit_piecewise_linear(x, y, corners, starts=starts)
    return _finish(knots, values, x, y, grid)


def _finish(knots: F64, values: F64, x: F64, y: F64, grid: int) -> PiecewiseLinear:
    err = _interp_extrap(x, knots, values) - y
    folds = _folds(x, y)
    approx = PiecewiseLinear(knots=knots, values=values, max_error=float(np.abs(err).max()),
                             rms_error=float(np.sqrt(np.mean(err**2))), max_angle_error=math.nan,
                             folds=folds, grid=grid)
    if approx.invertible:
        angle_err = float(np.abs(approx.inverse(y) - x).max())
    else:
        slope = np.abs(np.gradient(y, x))
        with np.errstate(divide="ignore", invalid="ignore"):
            local = np.where(slope > 0, np.abs(err) / slope, np.inf)
        angle_err = float(local.max())
    return dataclasses.replace(approx, max_angle_error=angle_err)


# -- lookup table --------------------------------------------------------------------------------
@dataclass(frozen=True, eq=False)
class LookupTable:
    """A uniform lookup table with linear interpolation (immutable).

    Attributes
    ----------
    quantity : {"inverse", "output"}
        ``"inverse"``: input volts (V), output tilt (rad); ``"output"``: input tilt (rad), output V.
    x : ndarray, shape (size,)
        Uniform, increasing table inputs.
    y : ndarray, shape (size,)
        Table outputs.
    error_bound : float
        Bound on the interpolation error inside the table's span, in the output's unit:
        ``h² / 8 · max|g''|`` (h the spacing, g the tabulated function; g'' from the model on the
        dense grid, so the bound is as good as that grid resolves the curvature).
    angle_range : (float, float)
        The tilt range covered, rad.
    """

    quantity: str
    x: F64
    y: F64
    error_bound: float
    angle_range: tuple[float, float]

    def __post_init__(self) -> None:
        for name in ("x", "y"):
            arr = np.array(getattr(self, name), dtype=np.float64)
            arr.setflags(write=False)
            object.__setattr__(self, name, arr)

    def __call__(self, value: ArrayLike) -> F64:
        """Interpolate (linear extrapolation beyond the ends), same shape as ``value``."""
        q = v.finite_array("value", value)
        return _interp_extrap(q.ravel(), self.x, self.y).reshape(q.shape)

    @property
    def size(self) -> int:
        """Table entries."""
        return int(self.x.size)

    @property
    def step(self) -> float:
        """Spacing of the table inputs (V or rad)."""
        return float(self.x[1] - self.x[0])

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready description (SI)."""
        unit_in, unit_out = ("V", "rad") if self.quantity == "inverse" else ("rad", "V")
        return {
            "kind": "lookup_table", "quantity": self.quantity, "size": self.size,
            "x_start": float(self.x[0]), "x_step": self.step, "x_unit": unit_in,
            "y": self.y.tolist(), "y_unit": unit_out, "error_bound": self.error_bound,
            "angle_range_rad": list(self.angle_range),
        }


def lookup_table(
    curve: Curve,
    size: int,
    angle_range: tuple[float, float] = DEFAULT_RANGE,
    quantity: str = "inverse",
    grid: int = 4001,
) -> LookupTable:
    """Tabulate the curve (or its inverse) on a uniform grid of ``size`` entries.

    Parameters
    ----------
    curve : Setup or callable
        As in :func:`piecewise_linear`.
    size : int
        Table entries (≥ 2).
    angle_range : (float, float)
        Tilt range, rad.
    quantity : {"inverse", "output"}
        ``"inverse"`` (default): tilt (rad) as a function of output (V), uniform in V over the
        curve's output span — needs a strictly monotonic curve. ``"output"``: V of tilt.
    grid : int
        Dense grid used to invert the curve and to bound its curvature.

    Returns
    -------
    LookupTable
        With ``error_bound = h²/8 · max|g''|`` (rad for ``"inverse"``, V for ``"output"``).
    """
    lo, hi = _check_range(angle_range)
    size = v.integer("size", size, 2)
    v.choice("quantity", quantity, QUANTITIES)
    grid = v.integer("grid", grid, 5)
    t = np.linspace(lo, hi, grid)
    y = _evaluate(curve, t)
    d1 = np.gradient(y, t, edge_order=2)
    d2 = np.gradient(d1, t, edge_order=2)
    if quantity == "output":
        x = np.linspace(lo, hi, size)
        h = (hi - lo) / (size - 1)
        return LookupTable(quantity, x, _evaluate(curve, x), h * h / 8.0 * float(np.abs(d2).max()),
                           (lo, hi))
    folds = _folds(t, y)
    if folds:
        raise _fold_error("an inverse lookup table", lo, hi, folds)
    # g(V) = θ(V): g'' = −f'' / f'³
    g2 = np.abs(d2 / d1**3)
    vmin, vmax = float(y.min()), float(y.max())
    x = np.linspace(vmin, vmax, size)
    order = np.argsort(y)
    theta = np.interp(x, y[order], t[order])
    # refine the inverse by Newton steps on the model itself (the dense grid is only a start)
    for _ in range(3):
        f = _evaluate(curve, theta)
        slope = np.interp(theta, t, d1)
        theta = np.clip(theta - (f - x) / slope, lo, hi)
    h = (vmax - vmin) / (size - 1)
    return LookupTable(quantity, x, theta, h * h / 8.0 * float(g2.max()), (lo, hi))
