"""Piecewise-linear approximation of the output-vs-tilt curve (the paper's Sec. V).

Once calibrated, the model's output V(θ) is smooth and nearly linear; the paper suggests replacing
it at read-out by a piecewise-linear function with two corner points, or by a line over a reduced
range. :func:`piecewise_linear` makes that a fit with known error: a continuous least-squares fit
of a continuous piecewise-linear function with ``corners`` interior corner points on a dense angle
grid. For fixed corners the node values are a linear least-squares problem in the hat-function
basis; the corner positions are optimised (bounded and ordered) by a coarse exhaustive search
followed by Nelder–Mead refinement over a log-gap parametrisation that keeps them ordered and
inside the range. The result extrapolates linearly beyond its range (the end segments continued).
SI units: angles in rad, outputs in V. :mod:`magcilia.io.firmware` exports it as C.
"""

from __future__ import annotations

import dataclasses
import itertools
import math
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from magcilia import _validate as v
from magcilia._display import Display, Item, Table, count, dataframe, rows_table, si
from magcilia.approximation.curve import (
    DEFAULT_RANGE,
    MAX_GRID,
    Curve,
    check_grid,
    check_range,
    evaluate,
    fold_error,
    folds_of,
    interp_extrap,
)

F64 = NDArray[np.float64]

#: most interior corners: the corner search is a Nelder–Mead over the corners, whose cost grows
#: steeply (16 corners take ~7 s on a 1001-point grid, 32 over a minute); for a finer read-out use
#: a lookup table (:func:`magcilia.lookup_table`)
MAX_CORNERS = 16


def _check_corners(corners: object, grid: int) -> int:
    count = v.integer("corners", corners, 0)
    if count > MAX_CORNERS:
        raise v.fail("corners", count, f"at most {MAX_CORNERS} (MAX_CORNERS); for a finer "
                                       "read-out use a lookup table")
    if count > grid - 2:
        raise v.fail("corners", count, f"at most {grid - 2} for a grid of {grid} points "
                     "(use a finer grid or fewer corners)")
    return count


# -- piecewise-linear fit ------------------------------------------------------------------------
@dataclass(frozen=True, eq=False, repr=False)
class PiecewiseLinear(Display):
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
        return interp_extrap(t.ravel(), self.knots, self.values).reshape(t.shape)

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
                float(k)
                for k, d in zip(self.knots[1:], np.diff(self.values), strict=True)
                if d == 0
            ) or (lo,)
            raise fold_error("inverse", lo, hi, folds)
        y = v.finite_array("volts", volts, unit="V")
        vals, knots = self.values, self.knots
        if vals[-1] < vals[0]:
            vals, knots = vals[::-1], knots[::-1]
        return interp_extrap(y.ravel(), vals, knots).reshape(y.shape)

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
        with v.rebuilding("approximation data", "PiecewiseLinear"):
            return cls(
                knots=np.asarray(data["knots_rad"], dtype=np.float64),
                values=np.asarray(data["values_V"], dtype=np.float64),
                max_error=float(data["max_error_V"]), rms_error=float(data["rms_error_V"]),
                max_angle_error=float(data.get("max_angle_error_rad", math.nan) or math.nan),
                folds=tuple(float(f) for f in data.get("folds_rad", ())),
                grid=int(data.get("grid", 0)),
            )

    def table(self) -> list[dict[str, float]]:
        """Rows per node: angle (deg), output (mV), slope of the following segment (mV/deg)."""
        slopes = np.append(self.slopes, math.nan)
        return [
            {"angle_deg": math.degrees(k), "output_mV": val * 1e3,
             "slope_mV_per_deg": s * 1e3 * math.pi / 180.0}
            for k, val, s in zip(self.knots, self.values, slopes, strict=True)
        ]

    def report(self) -> str:
        """Plain text: the nodes (deg, mV, mV/deg), the errors and whether it can be inverted."""
        lo, hi = self.angle_range
        lines = [(f"piecewise-linear approximation, {self.corners} corner(s) over "
                  f"{math.degrees(lo):.4g}..{math.degrees(hi):.4g} deg"),
                 f"{'node':>4} {'angle/deg':>10} {'output/mV':>12} {'slope/(mV/deg)':>15}"]
        for i, row in enumerate(self.table()):
            slope = ("" if math.isnan(row["slope_mV_per_deg"])
                     else f"{row['slope_mV_per_deg']:15.6g}")
            lines.append(f"{i:>4} {row['angle_deg']:10.4f} {row['output_mV']:12.6f} {slope}")
        lines.append(f"max error {self.max_error * 1e3:.4g} mV, RMS {self.rms_error * 1e3:.4g} mV, "
                     f"max angle error {math.degrees(self.max_angle_error):.4g} deg")
        if not self.invertible:
            folds = ", ".join(f"{math.degrees(f):.4g}" for f in self.folds)
            lines.append(f"note: the output is not monotonic over the range (folds at {folds} "
                         "deg): no inverse")
        return "\n".join(lines)

    # -- display --------------------------------------------------------------------------------
    def _display_items(self) -> list[Item]:
        lo, hi = (math.degrees(a) for a in self.angle_range)
        return [("", count(self.corners, "corner")), ("range", f"{lo:.3g}…{hi:.3g} deg"),
                ("max error", si(self.max_error, "V")), ("rms", si(self.rms_error, "V")),
                ("max angle error", f"{math.degrees(self.max_angle_error):.3g} deg"),
                ("invertible", "yes" if self.invertible else "no")]

    def _display_table(self) -> Table | None:
        return rows_table(self.table())

    def to_dataframe(self) -> Any:
        """The knots as a ``pandas.DataFrame``, SI: ``angle_rad``, ``output_V`` and
        ``slope_V_per_rad`` (of the segment that starts there; NaN at the last knot)."""
        return dataframe({"angle_rad": self.knots, "output_V": self.values,
                          "slope_V_per_rad": np.append(self.slopes, math.nan)})


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
    if x.size > MAX_GRID:
        raise v.fail("angles", f"{x.size} samples", f"at most {MAX_GRID} (MAX_GRID)")
    corners = _check_corners(corners, x.size)
    lo, hi = float(x[0]), float(x[-1])
    if corners == 0:
        knots = np.array([lo, hi])
        return knots, _node_values(x, y, knots)[0]
    scale = float(y @ y) / y.size or 1.0

    from scipy.optimize import minimize
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
        Interior corner points, at most :data:`MAX_CORNERS`; the paper suggests 2; 0 gives the
        best straight line.
    angle_range : (float, float)
        Fitted range (start, stop), rad; default 0..85°.
    grid : int
        Points of the dense uniform grid on which the continuous least-squares error is
        approximated (≥ corners + 2, at most :data:`~magcilia.approximation.curve.MAX_GRID`).
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
    lo, hi = check_range(angle_range)
    grid = check_grid(grid, 3)
    corners = _check_corners(corners, grid)
    x = np.linspace(lo, hi, grid)
    y = evaluate(curve, x)
    knots, values = fit_piecewise_linear(x, y, corners, starts=starts)
    return _finish(knots, values, x, y, grid)


def _finish(knots: F64, values: F64, x: F64, y: F64, grid: int) -> PiecewiseLinear:
    err = interp_extrap(x, knots, values) - y
    folds = folds_of(x, y)
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
