"""Firmware-ready approximations of the output-vs-tilt curve (the paper's Sec. V).

* :mod:`.piecewise`: a continuous piecewise-linear fit with optimised corners and its inverse;
* :mod:`.lookup`: uniform lookup tables (V→θ or θ→V) with an interpolation error bound;
* :mod:`.curve`: what both are fitted to (a setup or a callable) and the helpers they share.

:mod:`magcilia.io.firmware` exports them as C headers.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from magcilia._lazy import attach

if TYPE_CHECKING:
    from magcilia.approximation.curve import DEFAULT_RANGE
    from magcilia.approximation.lookup import QUANTITIES, LookupTable, lookup_table
    from magcilia.approximation.piecewise import (
        PiecewiseLinear,
        fit_piecewise_linear,
        hat_basis,
        piecewise_linear,
    )

__all__ = [
    "DEFAULT_RANGE",
    "QUANTITIES",
    "LookupTable",
    "PiecewiseLinear",
    "fit_piecewise_linear",
    "hat_basis",
    "lookup_table",
    "piecewise_linear",
]

__getattr__, __dir__ = attach(__name__)
