"""Read-out: from sensor output back to angle, force and flow.

* :mod:`.inverse`: :class:`Readout`, one output read back as angle, force or flow, with 1-σ
  uncertainties and flags; its parts: :mod:`.table` (the inverse table), :mod:`.edges` (the
  read-out just beyond the span's ends), :mod:`.forward` (the model it inverts, with or without
  an actuation), :mod:`.calibration_sigma` (the calibration's share of σ), :mod:`.result`
  (:class:`ReadoutResult`);
* :mod:`.biaxial`: :class:`BiaxialReadout`, the horizontal force vector (Fx, Fy) from several
  field channels (:class:`Channel`, :mod:`.channel`; a 3-axis
  :class:`~magcilia.device.magnetometer.Magnetometer` gives three), with covariance and
  :class:`Flag` bits (:class:`ForceVectorResult`, :mod:`.force_vector`); its polar table
  (:mod:`.polar_table`) and model readings (:mod:`.vector_model`);
* :mod:`.actuated`: sensing while actuating: :class:`ActuatedReadout` (a varying actuation,
  compensated per reading), :func:`measure_coupling` (the direct coupling, cilium clamped);
  ``Readout(..., actuation=)`` for a constant one;
* :mod:`.dynamic`: :class:`DynamicReadout`, the load from the hair's dynamic state (a Kalman
  filter on its modal model) around a :class:`Readout`, so that steps read within about a period
  instead of ringing;
* :mod:`.protocol`: what every read-out offers (:class:`SensorReadout`: ``inputs``, ``rest``,
  ``read``, ``tare``), the one :class:`Flag` set and the result's shape (:class:`ReadoutValues`);
* :mod:`.tare`: :class:`Tare`, the one zero-load baseline (one channel or several) of every
  read-out and of the live tare;
* :mod:`.array`: arrays of cilia under loads: :class:`ArrayReadout` (:mod:`.array_readout`:
  crosstalk, the inverse of all force vectors at once, n samples at once:
  :class:`ArrayEstimates`), :func:`field_for_loads` (:mod:`.array_model`), :func:`array_metrics`
  (against pitch); results in :mod:`.array_results`, checks in :mod:`.array_checks`;
* :mod:`.recalibration`: in-use re-calibration: :class:`Recalibrator` re-estimates offset,
  sensitivity, magnetization and stiffness from coil pulses (:class:`PulseWindow`), the strap
  (:class:`StrapWindow`) and unloaded moments (:class:`RestWindow`) into a
  :class:`Recalibration` (the windows in :mod:`.recalibration_windows`);
  :mod:`.recalibration_stream` finds the pulses in a stream
  (:class:`PulseTracker`, :func:`pulse_windows`);
* :mod:`.branch`: :func:`~.branch.first_turn`, where a sweep's signal first turns back (a fold).

What a design can resolve (``design_metrics``, ``DesignMetrics``, ``Metric``) and design
optimisation moved to :mod:`magcilia.design` (a room above this one); import them from there or
from ``magcilia``. ``magcilia.readout.design_metrics`` and its two classes still work in this
release, with a ``DeprecationWarning`` (the architecture test allows this one forward).
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

from magcilia._lazy import attach

if TYPE_CHECKING:
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
    from magcilia.readout.dynamic import DynamicReadout
    from magcilia.readout.inverse import QUANTITIES, Readout, ReadoutFlag, ReadoutResult
    from magcilia.readout.protocol import (
        FLAG_DTYPE,
        Flag,
        ReadoutValues,
        SensorReadout,
        flag_names,
    )
    from magcilia.readout.recalibration import Recalibration, Recalibrator
    from magcilia.readout.recalibration_stream import PulseTracker, pulse_windows
    from magcilia.readout.recalibration_windows import PulseWindow, RestWindow, StrapWindow
    from magcilia.readout.tare import ChannelTare, Tare
    from magcilia.readout.thermal import ThermalReadout, ThermalResult

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
    "DynamicReadout",
    "Flag",
    "ForceFlag",
    "ForceVectorResult",
    "PulseTracker",
    "PulseWindow",
    "Readout",
    "ReadoutFlag",
    "ReadoutResult",
    "ReadoutValues",
    "Recalibration",
    "Recalibrator",
    "RestWindow",
    "SensorReadout",
    "StrapWindow",
    "Tare",
    "ThermalReadout",
    "ThermalResult",
    "array_metrics",
    "field_for_loads",
    "flag_names",
    "loaded_poses",
    "measure_coupling",
    "pulse_windows",
]

#: names that moved up to :mod:`magcilia.design` in this release: still reachable here, deprecated
_MOVED_TO_DESIGN = frozenset({"design_metrics", "DesignMetrics", "Metric"})


def _moved(name: str) -> Any:
    """The names that moved to :mod:`magcilia.design`, with a ``DeprecationWarning`` (removed in
    the next release)."""
    if name in _MOVED_TO_DESIGN:
        import warnings

        from magcilia import design

        # stacklevel 3: the user's line, past magcilia._lazy's __getattr__
        warnings.warn(f"magcilia.readout.{name} moved to magcilia.design (also magcilia.{name}); "
                      "this alias goes in the next release", DeprecationWarning, stacklevel=3)
        return getattr(design, name)
    raise AttributeError(f"module 'magcilia.readout' has no attribute {name!r}")


__getattr__, __dir__ = attach(__name__, fallback=_moved)
