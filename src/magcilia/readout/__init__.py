"""Read-out: from sensor output back to angle, force and flow, and what a design can resolve.

* :mod:`.inverse`: :class:`Readout`, the inverse tables with 1-σ uncertainties and flags, and
  the read-out just beyond the span's ends;
* :mod:`.tare`: :class:`Tare`, a zero-load baseline (:meth:`Readout.tare`, the live tare);
* :mod:`.design`: :func:`design_metrics`, sensitivity, minimum detectable signal and range.
"""

from __future__ import annotations

from magcilia.readout.design import DesignMetrics, Metric, design_metrics
from magcilia.readout.inverse import QUANTITIES, Readout, ReadoutFlag, ReadoutResult
from magcilia.readout.tare import Tare

__all__ = [
    "QUANTITIES",
    "DesignMetrics",
    "Metric",
    "Readout",
    "ReadoutFlag",
    "ReadoutResult",
    "Tare",
    "design_metrics",
]
