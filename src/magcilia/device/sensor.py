"""Single-axis AMR sensor (Honeywell HMC1021Z preset): field ↔ voltage, range, noise.

Sensitive axis +x at the origin (the README's "Coordinate frame"). Output ``V = S · B_x + offset``
with ``S = sensitivity · bridge_voltage · gain`` (V/T).

Datasheet facts (Honeywell HMC1001/1002/1021/1022, rev. E): sensitivity 1.0 mV/V/gauss typical
(0.8–1.25 spread); linear range ±6 gauss; noise density 48 nV/√Hz at 1 kHz with a 5 V bridge
(≈ 9.6 µgauss/√Hz ≈ 0.96 nT/√Hz field-referred); resolution 85 µgauss in a 10 Hz band, consistent
with a 1/f corner near 10 Hz.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, fields, replace
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from magcilia import _validate as v
from magcilia._display import Display, Item, number
from magcilia.constants import GAUSS
from magcilia.device.parameters import PARAMETERS

_HMC1021Z: dict[str, Any] = {
    "name": "HMC1021Z",
    "sensitivity": 1.0e-3 / GAUSS,  # 1.0 mV/V/gauss = 10 V/V/T
    "bridge_voltage": 7.5,
    "gain": 1.0,
    "offset": 0.0,
    "depth": 0.71e-3,
    "field_range": 6.0 * GAUSS,
    "noise_density": 48e-9 / (5.0 * 1.0e-3 / GAUSS),  # 48 nV/√Hz at 5 V bridge -> T/√Hz
    "flicker_corner": 10.0,
}

#: default noise band of a read-out, Hz: one raw sample at the paper's 1 kHz DAQ rate
DEFAULT_BANDWIDTH = (0.5, 500.0)


@dataclass(frozen=True, repr=False)
class Sensor(Display):
    """A single-axis magnetoresistive bridge with an amplifier (all SI).

    Parameters
    ----------
    sensitivity : float
        Bridge sensitivity, V per V of bridge supply per T (1.0 mV/V/gauss = 10 V/V/T).
    bridge_voltage : float
        Bridge supply, V.
    gain : float
        Amplifier gain (dimensionless, non-zero; may be negative for an inverting stage).
    offset : float
        Output offset, V (bridge offset, ambient field, amplifier offset together).
    depth : float
        Depth of the sensing element below the case top, m (HMC1021Z: half the 1.42 mm case).
    field_range : float
        Linear range ±field_range on the sensitive axis, T (HMC1021Z: 6 gauss).
    noise_density : float
        White field-noise density, T/√Hz (field-referred).
    flicker_corner : float
        1/f corner frequency, Hz: the noise PSD is ``noise_density² (1 + corner/f)``.
    name : str
        Part name, for reports.
    """

    sensitivity: float = _HMC1021Z["sensitivity"]
    bridge_voltage: float = _HMC1021Z["bridge_voltage"]
    gain: float = _HMC1021Z["gain"]
    offset: float = _HMC1021Z["offset"]
    depth: float = _HMC1021Z["depth"]
    field_range: float = _HMC1021Z["field_range"]
    noise_density: float = _HMC1021Z["noise_density"]
    flicker_corner: float = _HMC1021Z["flicker_corner"]
    name: str = "HMC1021Z"

    def __post_init__(self) -> None:
        for f in fields(self):
            if f.name in PARAMETERS:  # all but the name
                object.__setattr__(self, f.name, PARAMETERS[f.name].check(getattr(self, f.name)))

    @classmethod
    def hmc1021z(cls, **overrides: Any) -> Sensor:
        """The HMC1021Z at the paper's settings (7.5 V bridge, gain 1, zero offset), overridable."""
        return replace(cls(), **overrides)

    @property
    def scale(self) -> float:
        """Output per field on the sensitive axis, V/T (75 for the paper's preset)."""
        return self.sensitivity * self.bridge_voltage * self.gain

    def voltage(self, bx: ArrayLike) -> NDArray[np.float64]:
        """Output voltage, V, for a field ``bx`` (T, any shape) along the sensitive axis."""
        return self.scale * np.asarray(bx, dtype=np.float64) + self.offset

    def field(self, volts: ArrayLike) -> NDArray[np.float64]:
        """Field along the sensitive axis, T, from output ``volts`` (V, any shape)."""
        return (np.asarray(volts, dtype=np.float64) - self.offset) / self.scale

    def in_range(self, bx: ArrayLike) -> NDArray[np.bool_]:
        """True where ``bx`` (T) lies within the linear range ±field_range."""
        return np.abs(np.asarray(bx, dtype=np.float64)) <= self.field_range

    def noise_rms(self, f_low: float, f_high: float) -> float:
        """RMS field noise in the band [f_low, f_high] Hz, T (white + 1/f, integrated PSD)."""
        f_low = v.positive("f_low", f_low, "Hz", "frequency")
        f_high = v.positive("f_high", f_high, "Hz", "frequency")
        if f_high <= f_low:
            raise v.fail("f_high", f_high, f"greater than f_low ({f_low:g} Hz)")
        var = self.noise_density**2 * (
            (f_high - f_low) + self.flicker_corner * math.log(f_high / f_low)
        )
        return math.sqrt(var)

    def output_noise_rms(self, f_low: float, f_high: float) -> float:
        """RMS output noise in the band [f_low, f_high] Hz, V (:meth:`noise_rms` times the
        scale)."""
        return abs(self.scale) * self.noise_rms(f_low, f_high)

    def noise(
        self,
        n_samples: int,
        rate: float,
        rng: int | np.random.Generator | None = None,
        size: int | None = None,
    ) -> NDArray[np.float64]:
        """Simulated output noise, V: white + 1/f, zero mean, sampled at ``rate`` Hz.

        The one-sided PSD is ``(scale · noise_density)² (1 + flicker_corner / f)`` for
        1/T ≤ f ≤ rate/2 (T = record length); synthesised by spectral shaping of Gaussian noise.

        Parameters
        ----------
        n_samples : int
            Samples per record.
        rate : float
            Sampling rate, Hz.
        rng : int, Generator or None
            Randomness source; None (default) draws fresh entropy, an int repeats the record.
        size : int or None
            Number of independent records; None returns shape (n_samples,), else (size, n_samples).
        """
        n = v.integer("n_samples", n_samples, 2)
        rate = v.positive("rate", rate, "Hz", "frequency")
        gen = np.random.default_rng(rng)
        shape = (1 if size is None else v.integer("size", size, 1), n)
        white = gen.standard_normal(shape)
        spec = np.fft.rfft(white, axis=-1)
        f = np.fft.rfftfreq(n, d=1.0 / rate)
        gain = np.zeros_like(f)
        gain[1:] = np.sqrt(1.0 + self.flicker_corner / f[1:])
        out = np.fft.irfft(spec * gain, n=n, axis=-1)
        # white part: variance density^2 * rate/2 per sample
        out *= abs(self.scale) * self.noise_density * math.sqrt(rate / 2.0)
        return out[0] if size is None else out

    def _display_items(self) -> list[Item]:
        names = ("sensitivity", "bridge_voltage", "gain", "offset", "depth", "field_range",
                 "noise_density", "flicker_corner")
        return [("", self.name), ("scale", f"{number(self.scale)} V/T"),
                *((n, PARAMETERS[n].text(getattr(self, n))) for n in names)]
