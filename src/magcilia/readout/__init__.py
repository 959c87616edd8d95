"""Read-out: from sensor output back to angle, force and flow, and what a design can resolve.

* :mod:`.inverse`: :class:`Readout`, the inverse tables with 1-σ uncertainties and flags, and
  the read-out just beyond the span's ends;
* :mod:`.biaxial`: :class:`BiaxialReadout`, the horizontal force vector (Fx, Fy) from several
  field channels (:class:`Channel`; a 3-axis :class:`~magcilia.device.magnetometer.Magnetometer`
  gives three), with covariance and :class:`ForceFlag` flags (:class:`ForceVectorResult`);
* :mod:`.tare`: :class:`Tare`, a zero-load baseline (:meth:`Readout.tare`, the live tare);
* :mod:`.design`: :func:`design_metrics`, sensitivity, minimum detectable signal and range.
"""

from __future__ import annotations

from magcilia.readout.biaxial import (
    BiaxialReadout,
    Channel,
    ChannelTare,
    ForceFlag,
    ForceVectorResult,
)
from magcilia.readout.design import DesignMetrics, Metric, design_metrics
from magcilia.readout.inverse import QUANTITIES, Readout, ReadoutFlag, ReadoutResult
from magcilia.readout.tare import Tare

__all__ = [
    "QUANTITIES",
    "BiaxialReadout",
    "Channel",
    "ChannelTare",
    "DesignMetrics",
    "ForceFlag",
    "ForceVectorResult",
    "Metric",
    "Readout",
    "ReadoutFlag",
    "ReadoutResult",
    "Tare",
    "design_metrics",
]
