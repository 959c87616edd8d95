"""Read-out: from sensor output back to angle, force and flow, and what a design can resolve.

* :mod:`.inverse`: :class:`Readout`, the inverse tables with 1-σ uncertainties and flags;
* :mod:`.design`: :func:`design_metrics`, sensitivity, minimum detectable signal and range.
"""

from __future__ import annotations

from magcilia.readout.design import DesignMetrics, Metric, design_metrics
from magcilia.readout.inverse import QUANTITIES, Readout, ReadoutFlag, ReadoutResult

__all__ = [
    "QUANTITIES",
    "DesignMetrics",
    "Metric",
    "Readout",
    "ReadoutFlag",
    "ReadoutResult",
    "design_metrics",
]
