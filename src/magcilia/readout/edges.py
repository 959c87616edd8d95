"""The read-out just beyond a span's ends: how far the model is continued there (the edge
tolerance) and the small tables that continue it."""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from magcilia._errors import MagciliaError
from magcilia.device.actuation import Actuation
from magcilia.device.setup import Setup
from magcilia.mechanics import Flow
from magcilia.readout.forward import model_output
from magcilia.readout.protocol import FLAG_DTYPE, Flag
from magcilia.readout.table import InverseTable

F64 = NDArray[np.float64]

#: how readings beyond the span's ends (within the edge tolerance) are read
EDGES = ("extrapolate", "clip", "blank")
#: default edge tolerance: at least this fraction of the span's width …
EDGE_TOLERANCE = 0.05
#: … and at least as far as the output moves by this many σ of the sensor's noise (over
#: DEFAULT_BANDWIDTH) from the span's end, up to the span's width
EDGE_SIGMAS = 5.0


def noise_reach(setup: Setup, quantity: str, flow: Flow, end: float, sign: float,
                 end_volts: float, start: float, cap: float, volts: float,
                 actuation: Actuation | None = None) -> float:
    """How far (SI, from ``start`` doubling up to ``cap``) beyond a span's ``end`` in the
    direction ``sign`` the model's output moves by ``volts`` (V) from ``end_volts``; where the
    model cannot be solved, the reach reached so far."""
    reach = start
    while reach < cap:
        try:
            out = model_output(setup, quantity, np.array([end + sign * reach]), flow,
                               actuation)[0]
        except MagciliaError:
            return reach
        if abs(out - end_volts) >= volts:
            return reach
        reach = min(2.0 * reach, cap)
    return reach


def edge_table(setup: Setup, quantity: str, flow: Flow, end: float, reach: float, points: int,
                end_volts: float, actuation: Actuation | None = None) -> InverseTable | None:
    """The model continued from a span's ``end`` (SI) by ``reach`` (signed, SI) over ``points``
    directly solved points, as a table whose output at ``end`` is ``end_volts`` (V, the span
    table's, so that no reading falls between the two); it ends where the output turns. None
    where the model cannot be solved there or its output does not change."""
    grid = end + np.linspace(0.0, reach, points)
    try:
        volts = model_output(setup, quantity, grid, flow, actuation)
        volts[0] = end_volts
        return InverseTable.build(grid, volts, f"{quantity} beyond {end:.6g}")
    except MagciliaError:
        return None


def read_beyond(table: InverseTable,
                edge_tables: tuple[InverseTable | None, InverseTable | None], edge: str,
                x: F64) -> tuple[F64, F64, F64, NDArray[np.uint16]]:
    """Readings ``x`` (V, (b,)) outside ``table``'s output range (or NaN) of a read-out whose
    span is continued by ``edge_tables`` as ``edge`` says: estimates, the
    slope |dquantity/dV| for σ, the clipping distance (SI) and the flags (OUTSIDE_SPAN and
    BELOW/ABOVE_SPAN beyond the reach; EXTRAPOLATED or CLIPPED within it), all (b,)."""
    value = np.full(x.size, np.nan)
    slope = np.full(x.size, np.nan)
    bias = np.zeros(x.size)
    flags = np.full(x.size, FLAG_DTYPE(Flag.OUTSIDE_SPAN))
    low_at_bottom = bool(table.output[0] == table.volts[0])  # output rises with the quantity
    for bottom in (True, False):
        low_end = bottom == low_at_bottom
        if not low_end and table.fold is not None:
            continue  # beyond the turn at the fold: no direction, no estimate
        side = np.flatnonzero(x < table.volts[0] if bottom else x > table.volts[-1])
        direction = FLAG_DTYPE(Flag.BELOW_SPAN if low_end else Flag.ABOVE_SPAN)
        flags[side] |= direction
        ext = edge_tables[0 if low_end else 1]
        if ext is None or not side.size:
            continue
        side = side[ext.inside(x[side])]
        if not side.size:
            continue
        est, est_slope = ext.value_and_slope(x[side])
        if edge == "clip":
            end = table.quantity[0 if low_end else -1]
            value[side] = end
            bias[side] = np.abs(est - end)
            slope[side] = abs(float(table.slope[0 if bottom else -1]))
            flags[side] = direction | FLAG_DTYPE(Flag.CLIPPED)
        else:
            value[side] = est
            slope[side] = est_slope
            flags[side] = direction | FLAG_DTYPE(Flag.EXTRAPOLATED)
    return value, slope, bias, flags


def outside_text(quantity: str, span: tuple[float, float], unit: str, table: InverseTable,
                 edge_tables: tuple[InverseTable | None, InverseTable | None], edge: str) -> str:
    """What a reading outside a read-out's reach should be, for its one-line error: within the
    span's output range (the span, a fold), or up to how far beyond its ends it is continued."""
    lo, hi = span
    what = f"{quantity} {lo:.4g}…{hi:.4g} {unit}"
    if table.fold is not None:
        what += f", folding at {table.fold:.4g} {unit}"
    text = (f"within the span's output range {min(table.output_range):.6g}…"
            f"{max(table.output_range):.6g} V ({what})")
    low, high = (0.0 if t is None else abs(float(t.quantity[-1] - t.quantity[0]))
                 for t in edge_tables)
    if not (low or high):
        return text
    ends = [t.volts[[0, -1]] for t in edge_tables if t is not None]
    a = min(table.volts[0], *(e[0] for e in ends))
    b = max(table.volts[-1], *(e[1] for e in ends))
    reach = f"{low:.4g} {unit} below" if low else ""
    reach += (" and " if low and high else "") + (f"{high:.4g} {unit} above" if high else "")
    return f"{text}, or up to {reach} it ({a:.6g}…{b:.6g} V, edge={edge!r})"
