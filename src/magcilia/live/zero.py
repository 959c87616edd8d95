"""Tare and zero tracking: the unloaded baseline of a live read-out.

**Tare** captures the unloaded output (the mean of a few tenths of a second of readings) and from
then on adds the correction ``V_rest − baseline`` to every reading, where ``V_rest`` is the
model's output with the cilium at rest (upright, no force, no flow): the earth's and the lab's
fields, the bridge offset and the amplifier's offset all cancel, as a force gauge's or a magnetic
skin's *zero* does. The spread of the tare readings is the measured noise of one reading (all of
it: sensor, amplifier, ADC), which the read-out then uses for σ instead of the sensor's datasheet
noise.

**Zero tracking** (load cells' *automatic zero tracking*): after a tare, while the mean of a batch
of corrected readings stays within ``band`` standard errors of the rest output (the noise of one
reading over √batch), the correction follows it with time constant ``tau``: slow drift
(temperature, the 1/f noise of the bridge) is removed, a load that stands out of the noise is
never tracked away. A load applied more slowly than ``tau`` and within the band would be; set
``tau=None`` to switch tracking off.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
from numpy.typing import NDArray

from magcilia import _validate as v
from magcilia.readout.tare import Tare

F64 = NDArray[np.float64]


def difference_noise(volts: F64) -> Any:
    """Noise RMS of one reading from the spread of successive differences, V (NaN with fewer
    than 3 finite readings); readings (t, c) of several channels give one per channel, (c,).

    ``1.4826 · MAD(diff(volts)) / √2``: for white noise the standard deviation, unmoved by a
    slowly changing signal and by the few differences that straddle a step. What it misses is
    noise slower than the readings' spacing (1/f), which the sensor model's noise includes.

    Parameters
    ----------
    volts : ndarray, shape (t,) or (t, c)
        Consecutive readings, V (or a channel's unit).
    """
    if np.ndim(volts) == 2:
        return np.array([difference_noise(column) for column in np.asarray(volts).T])
    d = np.diff(volts[np.isfinite(volts)])
    if d.size < 2:
        return math.nan
    return float(1.4826 * np.median(np.abs(d - np.median(d))) / math.sqrt(2.0))


class Zero:
    """The baseline state of a live read-out (see the module docstring).

    Parameters
    ----------
    rest : float or ndarray, shape (c,)
        The model's output at rest, V (several channels: each one's reading at rest, their
        unit; then ``correction``, ``noise`` and ``drift`` are arrays (c,) too, and tracking
        follows only while every channel lies within its band).
    tau : float or None
        Zero-tracking time constant, s (None: no tracking).
    band : float
        Tracking band, in noise σ of one reading.

    Attributes
    ----------
    correction : float
        What is added to each reading, V (0 before the first tare).
    noise : float or None
        Measured noise RMS of one reading at the last tare, V (None before).
    drift : float
        Change of the correction by zero tracking since the last tare, V.
    tared_at : float or None
        Time of the last tare, s (the read-out's clock).
    """

    def __init__(self, rest: Any, tau: float | None = 30.0, band: float = 3.0) -> None:
        self.rest: Any = v.real("rest", rest, "V") if np.ndim(rest) == 0 else \
            v.finite_array("rest", rest, ndim=1)
        self.tau = None if tau is None else v.positive("tau", tau, "s", "time constant")
        self.band = v.positive("band", band, "σ", "band")
        self.correction: Any = 0.0 * self.rest
        self.noise: Any = None
        self.drift: Any = 0.0 * self.rest
        self.tared_at: float | None = None

    def tare(self, volts: F64, at: float) -> None:
        """Take the mean of unloaded readings ``volts`` (V, shape (t,), t ≥ 2) as the new zero.

        Raises
        ------
        MagciliaError
            If fewer than two finite readings were given.
        """
        tare = Tare.from_readings(volts, self.rest)  # the arithmetic of Readout.tare
        self.correction = tare.correction
        self.noise = tare.noise
        self.drift = 0.0 * self.rest
        self.tared_at = at

    def track(self, volts: F64, dt: float) -> None:
        """Let the correction follow a batch of readings ``volts`` (V, uncorrected, shape (w,),
        or (w, c) for several channels, spaced ``dt`` s) whose mean lies within the band around
        the rest output; nothing before a tare."""
        if np.ndim(self.rest):
            self._track_channels(np.asarray(volts).reshape(-1, np.size(self.rest)), dt)
            return
        good = volts[np.isfinite(volts)]
        if self.tau is None or self.noise is None or good.size == 0:
            return
        mean = float(good.mean())
        if abs(mean + self.correction - self.rest) > self.band * self.noise / math.sqrt(
                good.size):
            return
        target = self.rest - mean
        alpha = -math.expm1(-good.size * dt / self.tau)
        step = alpha * (target - self.correction)
        self.correction += step
        self.drift += step

    def _track_channels(self, readings: F64, dt: float) -> None:
        """:meth:`track` of several channels: all follow, or (one beyond its band) none."""
        rows = readings[np.isfinite(readings).all(axis=1)]
        if self.tau is None or self.noise is None or rows.shape[0] == 0:
            return
        mean = rows.mean(axis=0)
        n = rows.shape[0]
        if np.any(np.abs(mean + self.correction - self.rest) > self.band * self.noise
                  / math.sqrt(n)):
            return
        step = -math.expm1(-n * dt / self.tau) * (self.rest - mean - self.correction)
        self.correction = self.correction + step
        self.drift = self.drift + step
