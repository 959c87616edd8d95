"""Read-out: from sensor output back to angle, force and flow.

* :mod:`.inverse`: :class:`Readout`, the inverse tables with 1-σ uncertainties and flags, and
  the read-out just beyond the span's ends;
* :mod:`.biaxial`: :class:`BiaxialReadout`, the horizontal force vector (Fx, Fy) from several
  field channels (:class:`Channel`; a 3-axis :class:`~magcilia.device.magnetometer.Magnetometer`
  gives three), with covariance and :class:`ForceFlag` flags (:class:`ForceVectorResult`);
* :mod:`.actuated`: sensing while actuating: :class:`ActuatedReadout` (a varying actuation,
  compensated per reading), :func:`measure_coupling` (the direct coupling, cilium clamped);
  ``Readout(..., actuation=)`` for a constant one;
* :mod:`.tare`: :class:`Tare`, a zero-load baseline (:meth:`Readout.tare`, the live tare);
* :mod:`.array`: arrays of cilia under loads: :class:`ArrayReadout` (crosstalk, the inverse of
  all force vectors at once), :func:`field_for_loads`, :func:`array_metrics` (against pitch);
* :mod:`.branch`: :func:`~.branch.first_turn`, where a sweep's signal first turns back (a fold).

What a design can resolve (``design_metrics``, ``DesignMetrics``, ``Metric``) and design
optimisation moved to :mod:`magcilia.design` (a room above this one); they are importable from
there and from ``magcilia``, no longer from ``magcilia.readout``.
"""

from __future__ import annotations

from magcilia.readout.actuated import ActuatedReadout, Coupling, measure_coupling
from magcilia.readout.array import (
    ArrayEstimate,
    ArrayFlag,
    ArrayMetrics,
    ArrayReadout,
    Crosstalk,
    array_metrics,
    field_for_loads,
    loaded_poses,
)
from magcilia.readout.biaxial import (
    BiaxialReadout,
    Channel,
    ChannelTare,
    ForceFlag,
    ForceVectorResult,
)
from magcilia.readout.inverse import QUANTITIES, Readout, ReadoutFlag, ReadoutResult
from magcilia.readout.tare import Tare

__all__ = [
    "QUANTITIES",
    "ActuatedReadout",
    "ArrayEstimate",
    "ArrayFlag",
    "ArrayMetrics",
    "ArrayReadout",
    "BiaxialReadout",
    "Channel",
    "ChannelTare",
    "Coupling",
    "Crosstalk",
    "ForceFlag",
    "ForceVectorResult",
    "Readout",
    "ReadoutFlag",
    "ReadoutResult",
    "Tare",
    "array_metrics",
    "field_for_loads",
    "loaded_poses",
    "measure_coupling",
]
