"""Lookup tables of the output-vs-tilt curve: a uniform table with linear interpolation, either
V→θ (``"inverse"``, what firmware needs) or θ→V (``"output"``), with the classic interpolation
error bound ``h² / 8 · max|g''|`` from the tabulated function's curvature. Linear extrapolation
beyond the table. SI units: angles in rad, outputs in V."""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from magcilia import _validate as v
from magcilia._display import Display, Item, Table, dataframe, rows_table, si
from magcilia.approximation.curve import (
    DEFAULT_RANGE,
    Curve,
    check_grid,
    check_range,
    evaluate,
    fold_error,
    folds_of,
    interp_extrap,
)

F64 = NDArray[np.float64]
QUANTITIES = ("inverse", "output")
#: most entries of a lookup table (4 MB of float32 in firmware; interpolation error falls as
#: 1/size², so a million entries are far below any sensor's noise)
MAX_TABLE_SIZE = 1_000_000


# -- lookup table --------------------------------------------------------------------------------
@dataclass(frozen=True, eq=False, repr=False)
class LookupTable(Display):
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
        return interp_extrap(q.ravel(), self.x, self.y).reshape(q.shape)

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

    @classmethod
    def from_dict(cls, data: Mapping[str, Any]) -> LookupTable:
        """Rebuild from :meth:`to_dict` output."""
        with v.rebuilding("lookup table data", "LookupTable"):
            size = int(data["size"])
            x = float(data["x_start"]) + float(data["x_step"]) * np.arange(size, dtype=np.float64)
            lo, hi = (float(a) for a in data["angle_range_rad"])
            return cls(quantity=v.choice("quantity", data["quantity"], QUANTITIES), x=x,
                       y=np.asarray(data["y"], dtype=np.float64),
                       error_bound=float(data["error_bound"]), angle_range=(lo, hi))

    def report(self) -> str:
        """One line: direction, size and error bound (deg or mV)."""
        if self.quantity == "inverse":
            return (f"lookup table V->angle, {self.size} entries: error bound "
                    f"{math.degrees(self.error_bound):.4g} deg")
        return (f"lookup table angle->V, {self.size} entries: error bound "
                f"{self.error_bound * 1e3:.4g} mV")

    # -- display --------------------------------------------------------------------------------
    def _names(self) -> tuple[str, str]:
        names = ("output_V", "angle_rad")
        return names if self.quantity == "inverse" else (names[1], names[0])

    def _display_items(self) -> list[Item]:
        lo, hi = (math.degrees(a) for a in self.angle_range)
        bound = (f"{math.degrees(self.error_bound):.3g} deg" if self.quantity == "inverse"
                 else si(self.error_bound, "V"))
        return [("", self.quantity), ("size", str(self.size)),
                ("angles", f"{lo:.3g}…{hi:.3g} deg"), ("error bound", bound)]

    def _display_table(self) -> Table | None:
        return rows_table(self.to_dataframe().to_dict("records"))

    def to_dataframe(self) -> Any:
        """The table as a ``pandas.DataFrame``, SI, one row per entry: ``output_V`` then
        ``angle_rad`` for an ``"inverse"`` table, ``angle_rad`` then ``output_V`` for an
        ``"output"`` table (input column first)."""
        x, y = self._names()
        return dataframe({x: self.x, y: self.y})


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
        Table entries (2 … :data:`MAX_TABLE_SIZE`).
    angle_range : (float, float)
        Tilt range, rad.
    quantity : {"inverse", "output"}
        ``"inverse"`` (default): tilt (rad) as a function of output (V), uniform in V over the
        curve's output span — needs a strictly monotonic curve. ``"output"``: V of tilt.
    grid : int
        Dense grid used to invert the curve and to bound its curvature (at most
        :data:`~magcilia.approximation.curve.MAX_GRID`).

    Returns
    -------
    LookupTable
        With ``error_bound = h²/8 · max|g''|`` (rad for ``"inverse"``, V for ``"output"``).
    """
    lo, hi = check_range(angle_range)
    size = v.integer("size", size, 2)
    if size > MAX_TABLE_SIZE:
        raise v.fail("size", size, f"at most {MAX_TABLE_SIZE} entries (MAX_TABLE_SIZE)")
    v.choice("quantity", quantity, QUANTITIES)
    grid = check_grid(grid, 5)
    t = np.linspace(lo, hi, grid)
    y = evaluate(curve, t)
    d1 = np.gradient(y, t, edge_order=2)
    d2 = np.gradient(d1, t, edge_order=2)
    if quantity == "output":
        x = np.linspace(lo, hi, size)
        h = (hi - lo) / (size - 1)
        return LookupTable(quantity, x, evaluate(curve, x), h * h / 8.0 * float(np.abs(d2).max()),
                           (lo, hi))
    folds = folds_of(t, y)
    if folds:
        raise fold_error("an inverse lookup table", lo, hi, folds)
    # g(V) = θ(V): g'' = −f'' / f'³
    g2 = np.abs(d2 / d1**3)
    vmin, vmax = float(y.min()), float(y.max())
    x = np.linspace(vmin, vmax, size)
    order = np.argsort(y)
    theta = np.interp(x, y[order], t[order])
    # refine the inverse by Newton steps on the model itself (the dense grid is only a start)
    for _ in range(3):
        f = evaluate(curve, theta)
        slope = np.interp(theta, t, d1)
        theta = np.clip(theta - (f - x) / slope, lo, hi)
    h = (vmax - vmin) / (size - 1)
    return LookupTable(quantity, x, theta, h * h / 8.0 * float(g2.max()), (lo, hi))
