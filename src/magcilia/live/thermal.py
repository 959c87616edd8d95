"""The temperature compensation of the live read-out: a :class:`~magcilia.ThermalReadout` read
block by block from a source with a temperature channel (``temperature_K``, K).

:class:`~magcilia.live.pipeline.LiveReadout` reads one output through its window averager, its
zero (tare and tracking, :mod:`magcilia.live.zero`) and the read-out. With a thermal read-out
(:class:`LiveThermal`, the view :func:`~magcilia.live.readouts.live_sensor` makes of it):

1. each sample is brought to the reference temperature first (:meth:`LiveThermal.compensate`,
   :meth:`TemperatureModel.to_reference <magcilia.TemperatureModel.to_reference>` about the
   zero-field level the zero implies, the sensor's offset less the zero's correction), so that
   the averager, set/reset demodulation, the tare and zero tracking all see an output that no
   longer moves with the temperature (a zero that tracked the temperature's drift would also
   take the scale's change for an offset);
2. each reading of the wrapped :class:`~magcilia.Readout` is finished as
   :meth:`ThermalReadout.read_at <magcilia.ThermalReadout.read_at>` finishes it
   (:meth:`ThermalReadout.finish <magcilia.ThermalReadout.finish>`: the modulus's change, the
   temperature part of σ, TEMPERATURE_OUTSIDE), at the mean temperature of its window;
3. a tare widens the calibrated range to the temperatures of its readings, as
   :meth:`ThermalReadout.tare <magcilia.ThermalReadout.tare>` does.

The recording of a live run keeps the source's raw output and its ``temperature_K`` column (a
replay compensates again, from the raw samples).
"""

from __future__ import annotations

from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from magcilia._errors import MagciliaError
from magcilia.device.temperature import TEMPERATURE_CHANNEL
from magcilia.readout.inverse import Readout
from magcilia.readout.protocol import FLAG_DTYPE, Flag
from magcilia.readout.thermal import ThermalReadout, ThermalResult

F64 = NDArray[np.float64]

#: window temperatures kept for a tare's range (a 0.5 s tare at 1 kHz holds 500)
KEPT_WINDOWS = 1 << 16
#: flags that warn but keep a single output's value in the live views: TEMPERATURE_OUTSIDE (the
#: coefficients extrapolated; the value stands, flagged, as ``magcilia readout`` writes it)
WARNING_FLAGS = FLAG_DTYPE(Flag.TEMPERATURE_OUTSIDE)


class LiveThermal:
    """The live read-out's view of a :class:`~magcilia.ThermalReadout` (see the module
    docstring): :meth:`compensate` a block's samples, then :meth:`read` their readings.

    Parameters
    ----------
    thermal : ThermalReadout
        The read-out; its wrapped :class:`~magcilia.Readout` reads the compensated outputs
        (untared: the live zero tares them).

    Attributes
    ----------
    thermal : ThermalReadout
        The read-out, its calibrated range widened by each tare's temperatures.
    temperature : float
        The mean temperature of the last reading's window, K (NaN before the first).
    """

    def __init__(self, thermal: ThermalReadout) -> None:
        self.thermal = thermal
        self.temperature = float("nan")
        self._temps = np.zeros(0)  # the last block's sample temperatures, K
        self._sigma = np.zeros(0)  # and their outputs' σ from the coefficients, V
        self._windows = np.zeros(0)  # the last KEPT_WINDOWS readings' temperatures, K
        self._zero: Any = None
        self._tared_at: float | None = None

    @property
    def readout(self) -> Readout:
        """The wrapped read-out (at the reference temperature)."""
        return self.thermal.readout

    @property
    def inputs(self) -> tuple[str, ...]:
        """The channels read: the output and ``temperature_K``."""
        return self.thermal.inputs

    @property
    def rest(self) -> F64:
        """The model's output at rest (V), (1,): the zero's level."""
        return np.asarray(self.readout.rest, dtype=np.float64)

    def compensate(self, block: Any, volts: F64, zero: Any) -> F64:
        """The samples ``volts`` (V, (n,)) of a source's ``block`` brought to the reference
        temperature at its ``temperature_K`` channel, about the level the live ``zero``
        implies (the sensor's offset less its correction)."""
        names = [c.name for c in getattr(block, "channels", ())]
        if names and TEMPERATURE_CHANNEL not in names:
            raise MagciliaError(f"the source has no {TEMPERATURE_CHANNEL} channel (it has "
                                f"{', '.join(names)}); a temperature-compensated read-out "
                                "needs one")
        temps = np.asarray(block[TEMPERATURE_CHANNEL], dtype=np.float64).reshape(-1)
        sensor = self.readout.setup.sensor
        level = sensor.offset - float(np.asarray(zero.correction).reshape(-1)[0])
        ref, sigma = self.thermal.model.to_reference(volts, temps, level, sensor.scale)
        self._temps, self._sigma, self._zero = temps, np.asarray(sigma), zero
        return np.asarray(ref, dtype=np.float64)

    def read(self, readings: ArrayLike, /, *, noise: ArrayLike | None = None) -> ThermalResult:
        """The compensated estimates of ``readings`` (V, (m,): the compensated outputs of the
        last block's windows, with the zero's correction), each at its window's mean
        temperature."""
        x = np.asarray(readings, dtype=np.float64).reshape(-1)
        m = x.size
        if not m or self._temps.size % m:
            raise MagciliaError(f"{m} readings of a block of {self._temps.size} samples: "
                                "compensate the block first, in whole windows")
        with np.errstate(invalid="ignore"):
            temps = np.nanmean(self._temps.reshape(m, -1), axis=1)
        sigma = self._sigma.reshape(m, -1).mean(axis=1)
        self._windows = np.concatenate([self._windows, temps])[-KEPT_WINDOWS:]
        self._widen_to_tare()
        inner = self.readout.read(x, noise=noise)
        result = self.thermal.finish(inner, x, sigma, temps, noise=noise)
        finite = temps[np.isfinite(temps)]
        self.temperature = float(finite[-1]) if finite.size else float("nan")
        return result

    def _widen_to_tare(self) -> None:
        """A new tare's readings (the last ones the zero took) widen the calibrated range."""
        zero = self._zero
        if zero is None or zero.tared_at is None or zero.tared_at == self._tared_at:
            return
        self._tared_at = zero.tared_at
        count = int(np.max(zero.baseline.count)) if zero.baseline is not None else 0
        seen = self._windows[-count:] if count else np.zeros(0)
        seen = seen[np.isfinite(seen)]
        if seen.size:
            self.thermal = self.thermal.widened(float(seen.min()), float(seen.max()))

    def text(self) -> str:
        """The status's few words: the temperature and the calibrated range."""
        lo, hi = self.thermal.calibrated_range
        t = self.temperature
        where = ("" if not np.isfinite(t) else " — OUTSIDE the calibrated range" if not
                 lo <= t <= hi else "")
        shown = f"{t:.2f} K" if np.isfinite(t) else "—"
        return f"{shown} (calibrated {lo:.2f}…{hi:.2f} K, compensated){where}"


__all__ = ["KEPT_WINDOWS", "WARNING_FLAGS", "LiveThermal"]
