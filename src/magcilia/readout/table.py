"""The inverse table of a single-output read-out: the monotone branch of the output against a
quantity, resampled on a uniform output grid (a reading's cell by arithmetic, no search)."""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from magcilia import _validate as v
from magcilia.readout.branch import first_turn

F64 = NDArray[np.float64]


@dataclass(frozen=True, eq=False)
class InverseTable:
    """The monotone branch of the output vs a quantity, ready to invert (immutable).

    Built by :meth:`build` from a dense sweep: the branch that contains the sweep's start, every
    other point of it as the table, the skipped points to measure the interpolation error, and
    the table resampled on a uniform output grid so that a reading's cell is found by arithmetic
    instead of a search.

    Attributes
    ----------
    quantity, output : ndarray, shape (t,)
        The table: quantity (SI) and output (V), in sweep order.
    error : float
        Largest interpolation error at the skipped points, in the quantity's unit.
    fold : float or None
        Quantity at which the output folds back inside the sweep (None if monotone).
    ambiguous : (float, float) or None
        Output range (V) that also occurs beyond the fold.
    volts, values, slope : ndarray, shape (t,)
        The table sorted by increasing output, and dquantity/dV there.
    cell_start, cell_step : ndarray, shape (c,)
        The quantity at the start of each of ``c`` uniform output cells from ``volts[0]`` to
        ``volts[-1]``, and its change over the cell.
    cells_per_volt : float
        Cells per volt of output.
    cell_knot : ndarray of intp, shape (c,)
        For each cell, a table interval (index into ``volts``) at or below its readings; at most
        ``knot_steps`` knots lie between it and any reading of the cell.
    knot_steps : int
        Forward steps that find a reading's table interval from ``cell_knot``.
    """

    quantity: F64
    output: F64
    error: float
    fold: float | None
    ambiguous: tuple[float, float] | None
    volts: F64
    values: F64
    slope: F64
    cell_start: F64
    cell_step: F64
    cells_per_volt: float
    cell_knot: NDArray[np.intp]
    knot_steps: int

    @classmethod
    def build(cls, grid: F64, volts: F64, where: str) -> InverseTable:
        """The table of a sweep ``grid`` (quantity, increasing) with outputs ``volts`` (V);
        ``where`` names the sweep in errors."""
        dv = np.diff(volts)
        nonzero = np.nonzero(dv != 0.0)[0]
        if nonzero.size == 0:
            raise v.fail("span", where, "a span over which the output changes")
        sign = float(np.sign(dv[nonzero[0]]))
        end = int(first_turn(volts, flat=True))  # last index of the (strictly monotone) branch
        folds = end < grid.size - 1
        if end < 2:
            raise v.fail("span", where, f"a span whose output is monotone near its start (it "
                         f"folds at {grid[end]:.6g})")
        beyond = volts[end:]
        even = np.arange(0, end + 1, 2)
        if even[-1] != end:
            even = np.append(even, end)
        order = slice(None) if sign > 0 else slice(None, None, -1)
        xp = np.ascontiguousarray(volts[even][order])  # increasing outputs
        fp = np.ascontiguousarray(grid[even][order])
        n_cells = 16 * (xp.size - 1)
        cells = np.interp(np.linspace(xp[0], xp[-1], n_cells + 1), xp, fp)
        per_volt = n_cells / float(xp[-1] - xp[0])
        # the intervals at half a cell below and above each cell (a margin for rounding)
        first, last = np.clip(np.searchsorted(
            xp, xp[0] + (np.arange(n_cells) + np.array([[-0.5], [1.5]])) / per_volt,
            side="right") - 1, 0, xp.size - 1)
        table = cls(
            quantity=grid[even], output=volts[even], error=0.0,
            fold=float(grid[end]) if folds else None,
            ambiguous=(float(beyond.min()), float(beyond.max())) if folds else None,
            volts=xp, values=fp, slope=np.gradient(fp, xp), cell_start=cells[:-1].copy(),
            cell_step=np.diff(cells), cells_per_volt=per_volt,
            cell_knot=first.astype(np.intp), knot_steps=int(np.max(last - first)),
        )
        odd = np.arange(1, end, 2)
        if odd.size:
            error = float(np.max(np.abs(table.lookup(volts[odd]) - grid[odd])))
            table = dataclasses.replace(table, error=error)
        return table

    @property
    def output_range(self) -> tuple[float, float]:
        """Outputs (V) at the start and the end of the branch."""
        return float(self.output[0]), float(self.output[-1])

    def inside(self, x: F64) -> NDArray[np.bool_]:
        """Whether readings (V) lie within the table's output range (False for NaN)."""
        return np.asarray((x >= self.volts[0]) & (x <= self.volts[-1]))

    def lookup(self, x: F64) -> F64:
        """Uniform-grid linear interpolation of readings (V, any shape) assumed inside the
        table (readings outside get the end cells' lines)."""
        return self._cells(x)[0]

    def _cells(self, x: F64) -> tuple[F64, NDArray[np.intp]]:
        """:meth:`lookup` and each reading's cell index (same shape as ``x``)."""
        u = np.subtract(x, self.volts[0], out=np.empty(np.shape(x)))
        u *= self.cells_per_volt
        i = np.minimum(u, self.cell_start.size - 1).astype(np.intp)  # u ≥ 0 inside
        u -= i
        value = self.cell_step[i]
        value *= u
        value += self.cell_start[i]
        return value, i

    def value_and_slope(self, x: F64) -> tuple[F64, F64]:
        """Estimates (as :meth:`lookup`) and |dquantity/dV| (the table's slope interpolated
        linearly in output, as ``np.interp`` over ``volts``), same shape as ``x``; readings
        outside the table are taken at its nearest end (NaN at the start)."""
        xc = np.fmax(x, self.volts[0])  # NaN -> the start
        np.fmin(xc, self.volts[-1], out=xc)
        value, i = self._cells(xc)
        return value, np.abs(_interp(xc, self.cell_knot[i], self.knot_steps, self.volts,
                                     self.slope))


def _interp(x: F64, j: NDArray[np.intp], steps: int, xp: F64, fp: F64) -> F64:
    """``np.interp(x, xp, fp)`` for ``x`` within [xp[0], xp[-1]] (same shape as ``j``), given
    intervals ``j`` at or below each x with at most ``steps`` knots in between; the same
    arithmetic as NumPy's, so the same numbers (``j`` is updated in place)."""
    ahead = np.append(xp[1:], math.inf)
    for _ in range(steps):
        j += x >= ahead[j]
    rate = np.append(np.diff(fp) / np.diff(xp), 0.0)
    out = np.subtract(x, xp[j])
    out *= rate[j]
    out += fp[j]
    return out

