"""The read-out just beyond a span's ends: how far the model is continued there (the edge
tolerance) and the small tables that continue it."""

from __future__ import annotations

import numpy as np

from magcilia._errors import MagciliaError
from magcilia.device.actuation import Actuation
from magcilia.device.setup import Setup
from magcilia.mechanics import Flow
from magcilia.readout.forward import model_output
from magcilia.readout.table import InverseTable

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

