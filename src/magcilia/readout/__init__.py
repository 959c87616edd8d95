"""Read-out: from sensor output back to angle, force and flow, and what a design can resolve.

* :mod:`.inverse`: :class:`Readout`, the inverse tables with 1-σ uncertainties and flags, and
  the read-out just beyond the span's ends;
* :mod:`.biaxial`: :class:`BiaxialReadout`, the horizontal force vector (Fx, Fy) from several
  field channels (:class:`Channel`, :mod:`.channel`; a 3-axis
  :class:`~magcilia.device.magnetometer.Magnetometer` gives three), with covariance and
  :class:`Flag` bits (:class:`ForceVectorResult`, :mod:`.force_vector`); its polar table
  (:mod:`.polar_table`) and model readings (:mod:`.vector_model`);
* :mod:`.actuated`: sensing while actuating: :class:`ActuatedReadout` (a varying actuation,
  compensated per reading), :func:`measure_coupling` (the direct coupling, cilium clamped);
  ``Readout(..., actuation=)`` for a constant one;
* :mod:`.protocol`: what every read-out offers (:class:`SensorReadout`: ``inputs``, ``rest``,
  ``read``, ``tare``), the one :class:`Flag` set and the result's shape (:class:`ReadoutValues`);
* :mod:`.tare`: :class:`Tare`, the one zero-load baseline (one channel or several) of every
  read-out and of the live tare;
* :mod:`.design`: :func:`design_metrics`, sensitivity, minimum detectable signal and range;
* :mod:`.array`: arrays of cilia under loads: :class:`ArrayReadout` (:mod:`.array_readout`:
  crosstalk, the inverse of all force vectors at once, n samples at once:
  :class:`ArrayEstimates`), :func:`field_for_loads` (:mod:`.array_model`), :func:`array_metrics`
  (against pitch); results in :mod:`.array_results`, checks in :mod:`.array_checks`.
"""

from __future__ import annotations

from magcilia.readout.actuated import ActuatedReadout, Coupling, measure_coupling
from magcilia.readout.array import (
    ArrayEstimate,
    ArrayEstimates,
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
    ForceFlag,
    ForceVectorResult,
)
from magcilia.readout.design import DesignMetrics, Metric, design_metrics
from magcilia.readout.inverse import QUANTITIES, Readout, ReadoutFlag, ReadoutResult
from magcilia.readout.protocol import (
    FLAG_DTYPE,
    Flag,
    ReadoutValues,
    SensorReadout,
    flag_names,
)
from magcilia.readout.tare import ChannelTare, Tare

__all__ = [
    "FLAG_DTYPE",
    "QUANTITIES",
    "ActuatedReadout",
    "ArrayEstimate",
    "ArrayEstimates",
    "ArrayFlag",
    "ArrayMetrics",
    "ArrayReadout",
    "BiaxialReadout",
    "Channel",
    "ChannelTare",
    "Coupling",
    "Crosstalk",
    "DesignMetrics",
    "Flag",
    "ForceFlag",
    "ForceVectorResult",
    "Metric",
    "Readout",
    "ReadoutFlag",
    "ReadoutResult",
    "ReadoutValues",
    "SensorReadout",
    "Tare",
    "array_metrics",
    "design_metrics",
    "field_for_loads",
    "flag_names",
    "loaded_poses",
    "measure_coupling",
]
