"""Single-axis AMR sensor (Honeywell HMC1021Z preset): field ↔ voltage, range, noise.

Sensitive axis +x at the origin (the README's "Coordinate frame"). Output ``V = S · B_x + offset``
with ``S = sensitivity · bridge_voltage · gain`` (V/T).

Datasheet facts (Honeywell HMC1001/1002/1021/1022, rev. E): sensitivity 1.0 mV/V/gauss typical
(0.8–1.25 spread); linear range ±6 gauss; noise density 48 nV/√Hz at 1 kHz with a 5 V bridge
(≈ 9.6 µgauss/√Hz ≈ 0.96 nT/√Hz field-referred); resolution 85 µgauss in a 10 Hz band, consistent
with a 1/f corner near 10 Hz.

The sensor's limits beyond B_x (:meth:`Sensor.check`, :class:`SensorFlag`, :class:`SensorCheck`):

* **Cross-axis effect.** An AMR element's sensitivity depends on the field along its easy axis
  (in the element's plane, across the sensitive axis: +y here, the die lying in the board's x–y
  plane). The standard model (Honeywell application note AN-205, "Magnetic sensor cross-axis
  effect"; Včelák, Ripka et al., Sens. Actuators A 2006, for the HMC1001/1002) is
  ``B_x,read = B_x · H₀ / (H₀ + p·B_y)`` with the field-scale constant H₀ (anisotropy plus
  demagnetizing field, :attr:`Sensor.anisotropy_field`) and p = +1 after a set pulse, −1 after a
  reset. The datasheet gives the effect as ±0.3 %FS for a 1 gauss cross field at ±1 gauss applied
  (HMC1021/1022 table, "Cross-Axis Effect"), which fixes H₀ = 1 G · 1 G / (0.003 · 6 G) ≈ 56 G.
  :meth:`Sensor.output_with_cross_axis` is the output with this term; ``Setup.output`` leaves it
  out (the paper's model), so every existing result is unchanged.
* **Flipping.** A field beyond the "disturbing field" (HMC1021/1022 table: 20 gauss, "sensitivity
  starts to degrade; use S/R pulse to restore sensitivity") can flip the element's magnetization;
  a set/reset pulse restores it. Honeywell's magnetic-sensor FAQ likewise says parts are "permed"
  by fields over 20 gauss and that set/reset pulses restore them.
* **Range.** The ±6 gauss range is stated for the *total applied field*.

The cross-axis (±0.3 %FS) and disturbing-field (20 gauss) figures are the rev. E table's as this
module's authors know them; the stored copies of the datasheet available when they were written
end before those rows, so check them against your copy and override ``cross_axis`` and
``flip_field`` (setup files: ``[sensor] cross_axis``, ``flip_field``) for your part.
"""

from __future__ import annotations

import enum
import math
from dataclasses import dataclass, fields, replace
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from magcilia import _validate as v
from magcilia._display import Display, Item, count, number, scaled
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
    "cross_axis": 0.003,  # ±0.3 %FS at a 1 gauss cross field, ±1 gauss applied
    "flip_field": 20.0 * GAUSS,  # the datasheet's "disturbing field"
}

#: the datasheet's cross-axis test: cross field and applied field on the sensitive axis, T
CROSS_AXIS_TEST = (1.0 * GAUSS, 1.0 * GAUSS)

#: default noise band of a read-out, Hz: one raw sample at the paper's 1 kHz DAQ rate
DEFAULT_BANDWIDTH = (0.5, 500.0)


def beyond_range(values: ArrayLike, field_range: ArrayLike,
                 resolution: ArrayLike = 0.0) -> NDArray[np.bool_]:
    """The one saturation rule: True where a field or a reading on a sensor's axes lies beyond
    its linear range, shape of ``values`` (broadcast with the others).

    An analog output (``resolution`` 0, the HMC1021Z's) is beyond when |value| > field_range. A
    digital part clips its output at ±field_range and rounds it to its LSB (``resolution``), so
    a reading within half an LSB of the range, or beyond, is saturated: it may be a clipped one.

    Parameters
    ----------
    values : array-like
        Fields or readings, T (any shape; per axis).
    field_range, resolution : array-like
        Range ±field_range and LSB, T (broadcast with ``values``: one per axis, e.g. (3,)).

    Examples
    --------
    >>> beyond_range([5e-4, 6e-4, 7e-4], 6e-4).tolist()
    [False, False, True]
    >>> beyond_range([7.9995e-4, 7.99e-4], 8e-4, 1e-6).tolist()  # within half an LSB: clipped
    [True, False]
    """
    a = np.abs(np.asarray(values, dtype=np.float64))
    if np.ndim(resolution) == 0 and not resolution:  # analog: the read-out's per-sample path
        return np.asarray(a > field_range)
    limit = np.asarray(field_range, dtype=np.float64)
    half = 0.5 * np.asarray(resolution, dtype=np.float64)
    with np.errstate(invalid="ignore"):
        return np.asarray(np.where(half > 0.0, a >= limit - half, a > limit), dtype=bool)


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
    cross_axis : float
        Cross-axis effect as a fraction of full scale (the datasheet's %FS / 100) at the
        datasheet's test, :data:`CROSS_AXIS_TEST` (1 gauss cross field, ±1 gauss applied);
        HMC1021Z: 0.003. 0 turns the effect off. See :attr:`anisotropy_field`.
    flip_field : float
        Field magnitude, T, beyond which the element's magnetization may flip and a set/reset
        pulse is needed (the datasheet's "disturbing field"; HMC1021Z: 20 gauss).
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
    cross_axis: float = _HMC1021Z["cross_axis"]
    flip_field: float = _HMC1021Z["flip_field"]

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
        """True where ``bx`` (T) lies within the linear range ±field_range: the complement of
        :func:`beyond_range` for this analog output (|B_x| ≤ field_range), NaN neither (one
        comparison: the read-out's per-sample path)."""
        return np.abs(np.asarray(bx, dtype=np.float64)) <= self.field_range

    @property
    def anisotropy_field(self) -> float:
        """The AMR field-scale constant H₀, T (anisotropy plus demagnetizing field), implied by
        :attr:`cross_axis`: the cross-axis test's cross field times applied field over the
        error it produces, ``b_c · b_a / (cross_axis · field_range)`` (≈ 5.6 mT = 56 gauss for
        the HMC1021Z); infinite when ``cross_axis`` is 0."""
        if self.cross_axis == 0.0:
            return math.inf
        cross, applied = CROSS_AXIS_TEST
        return cross * applied / (self.cross_axis * self.field_range)

    def field_with_cross_axis(self, b: ArrayLike, polarity: int = 1) -> NDArray[np.float64]:
        """What the element reads on its sensitive axis, T, shape (...), for a field ``b``
        (..., 3), T, in the sensor frame (x sensitive, y the easy axis, z out of the die):
        ``B_x · H₀ / (H₀ + p·B_y)`` (module docstring), with p = ``polarity`` (+1 after a set
        pulse, −1 after a reset). NaN where ``p·B_y ≤ −H₀``: there the cross field has reversed
        the magnetization and the model no longer holds (:meth:`check` flags FLIPPED_RISK long
        before, at :attr:`flip_field`)."""
        arr = _field3("b", b)
        p = _polarity(polarity)
        h0 = self.anisotropy_field
        bx, by = arr[..., 0], arr[..., 1]
        if math.isinf(h0):
            return np.array(bx, dtype=np.float64)
        denom = 1.0 + p * by / h0
        with np.errstate(divide="ignore", invalid="ignore"):
            return np.asarray(np.where(denom > 0.0, bx / denom, np.nan), dtype=np.float64)

    def cross_axis_error(self, b: ArrayLike, polarity: int = 1) -> NDArray[np.float64]:
        """The cross-axis term alone, T, shape (...): :meth:`field_with_cross_axis` − B_x."""
        arr = _field3("b", b)
        return self.field_with_cross_axis(arr, polarity) - arr[..., 0]

    def output_with_cross_axis(self, b: ArrayLike, polarity: int = 1) -> NDArray[np.float64]:
        """Output voltage, V, shape (...), for a 3-axis field ``b`` (..., 3), T, including the
        cross-axis effect: ``scale · field_with_cross_axis(b) + offset``. An explicit extra:
        :meth:`voltage` and ``Setup.output`` stay the paper's ``scale · B_x + offset``."""
        return self.scale * self.field_with_cross_axis(b, polarity) + self.offset

    def check(self, b: ArrayLike, bandwidth: tuple[float, float] = DEFAULT_BANDWIDTH,
              polarity: int = 1) -> NDArray[np.uint8]:
        """:class:`SensorFlag` bits of each field ``b`` (..., 3), T, at the element, shape (...)
        (0: a good reading).

        BEYOND_RANGE: |B_x| > field_range. TOTAL_BEYOND_RANGE: |B| > field_range (the
        datasheet states the range for the total applied field). CROSS_FIELD: the cross-axis
        error (:meth:`cross_axis_error`) exceeds the RMS field noise in ``bandwidth`` (Hz, as
        :meth:`noise_rms`; default one raw sample at the paper's 1 kHz), i.e. the term the
        paper's model leaves out is visible in one reading. FLIPPED_RISK: |B| > flip_field, a
        set/reset pulse is needed before the reading can be trusted.
        """
        arr = _field3("b", b)
        f_low, f_high = bandwidth
        floor = self.noise_rms(f_low, f_high)
        magnitude = np.linalg.norm(arr, axis=-1)
        error = self.cross_axis_error(arr, polarity)
        flags = np.zeros(arr.shape[:-1], dtype=np.uint8)
        flags[beyond_range(arr[..., 0], self.field_range)] |= np.uint8(SensorFlag.BEYOND_RANGE)
        flags[beyond_range(magnitude, self.field_range)] |= np.uint8(
            SensorFlag.TOTAL_BEYOND_RANGE)
        flags[~(np.abs(error) <= floor)] |= np.uint8(SensorFlag.CROSS_FIELD)
        flags[magnitude > self.flip_field] |= np.uint8(SensorFlag.FLIPPED_RISK)
        return flags

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
                 "noise_density", "flicker_corner", "cross_axis", "flip_field")
        return [("", self.name), ("scale", f"{number(self.scale)} V/T"),
                *((n, PARAMETERS[n].text(getattr(self, n))) for n in names)]


class SensorFlag(enum.IntFlag):
    """Bit flags of a field at the single-axis element (combine with ``|``; 0 is a good reading;
    see :meth:`Sensor.check`)."""

    OK = 0
    #: |B_x| beyond the linear range on the sensitive axis: the output saturates
    BEYOND_RANGE = 1
    #: the cross-axis error exceeds the noise of one reading (the paper's model leaves it out)
    CROSS_FIELD = 2
    #: |B| beyond the flip (disturbing) field: the magnetization may flip; pulse set/reset
    FLIPPED_RISK = 4
    #: |B| beyond the linear range (the datasheet's range is of the total applied field)
    TOTAL_BEYOND_RANGE = 8


def flag_names(flags: int) -> str:
    """The names of the set bits of a :class:`SensorFlag` value, ``"ok"`` for none."""
    names = [f.name for f in SensorFlag if f.value and int(flags) & f.value and f.name]
    return "|".join(n for n in names if n) or "ok"


def _field3(name: str, b: ArrayLike) -> NDArray[np.float64]:
    """A finite field, T, shape (..., 3)."""
    arr = v.finite_array(name, b, unit="T")
    if arr.ndim == 0 or arr.shape[-1] != 3:
        raise v.fail(name, f"an array of shape {arr.shape}",
                     "an array of shape (..., 3), T (Bx, By, Bz at the element)")
    return arr


def _polarity(polarity: object) -> int:
    if isinstance(polarity, bool) or polarity not in (1, -1):
        raise v.fail("polarity", polarity, "+1 (after a set pulse) or -1 (after a reset pulse)")
    return 1 if polarity == 1 else -1


@dataclass(frozen=True, eq=False, repr=False)
class SensorCheck(Display):
    """The single-axis element's field and flags for a batch of poses (all SI;
    ``Setup.check_sensor`` makes one).

    Attributes
    ----------
    sensor : Sensor
        The element checked.
    field : ndarray, shape (a, 3)
        Flux density at the element per pose, T.
    flags : ndarray of uint8, shape (a,)
        :class:`SensorFlag` bits per pose.
    cross_error : ndarray, shape (a,)
        Cross-axis error per pose, T (:meth:`Sensor.cross_axis_error`, after a set pulse).
    noise : float
        RMS field noise of one reading in ``bandwidth``, T (the CROSS_FIELD threshold).
    bandwidth : (float, float)
        The noise band, Hz.
    poses : ndarray, shape (a,)
        Tilt angles, rad, or NaN for centrelines (labels of the summaries).
    azimuth : float
        Direction of the tilt or bending, rad.
    """

    sensor: Sensor
    field: NDArray[np.float64]
    flags: NDArray[np.uint8]
    cross_error: NDArray[np.float64]
    noise: float
    bandwidth: tuple[float, float]
    poses: NDArray[np.float64]
    azimuth: float = 0.0

    @classmethod
    def of(cls, sensor: Sensor, field: ArrayLike, poses: ArrayLike | None = None,
           azimuth: float = 0.0, bandwidth: tuple[float, float] = DEFAULT_BANDWIDTH
           ) -> SensorCheck:
        """Check ``field`` (a, 3), T, at ``sensor``'s element; ``poses`` (a,) label the rows
        (tilt angles in rad; NaN for none)."""
        arr = _field3("field", field).reshape(-1, 3)
        labels = (np.full(len(arr), np.nan) if poses is None
                  else np.asarray(poses, dtype=np.float64).reshape(-1))
        if labels.shape != (len(arr),):
            raise v.fail("poses", f"{labels.size} labels", f"{len(arr)}, one per field")
        f_low, f_high = bandwidth
        return cls(sensor=sensor, field=arr, flags=sensor.check(arr, bandwidth),
                   cross_error=sensor.cross_axis_error(arr), noise=sensor.noise_rms(f_low, f_high),
                   bandwidth=(float(f_low), float(f_high)), poses=labels, azimuth=float(azimuth))

    @property
    def ok(self) -> bool:
        """True when no pose has a flag."""
        return not bool(np.any(self.flags))

    @property
    def magnitude(self) -> NDArray[np.float64]:
        """|B| at the element per pose, T, shape (a,)."""
        return np.asarray(np.linalg.norm(self.field, axis=-1), dtype=np.float64)

    def summaries(self) -> tuple[str, ...]:
        """One line per pose: the pose, B in gauss and what the flags mean."""
        return tuple(self._summary(i) for i in range(len(self.field)))

    def _summary(self, i: int) -> str:
        b = self.field[i]
        # components below 1e-9 of |B| are round-off of a symmetric placement: show them as 0
        bx, by, bz = np.where(np.abs(b) > 1e-9 * self.magnitude[i], b, 0.0) / GAUSS
        pose = ("" if math.isnan(self.poses[i])
                else f"{math.degrees(self.poses[i]):.4g} deg: ")
        text = (f"{pose}B = ({bx:.3g}, {by:.3g}, {bz:.3g}) G, |B| "
                f"{self.magnitude[i] / GAUSS:.3g} G")
        f = int(self.flags[i])
        s = self.sensor
        notes = []
        if f & SensorFlag.FLIPPED_RISK:
            notes.append(f"beyond the {s.flip_field / GAUSS:.3g} G flip field: pulse set/reset, "
                         "or move the cilium off the element")
        if f & SensorFlag.BEYOND_RANGE:
            notes.append(f"B_x beyond the ±{s.field_range / GAUSS:.3g} G range: the output "
                         "saturates")
        elif f & SensorFlag.TOTAL_BEYOND_RANGE:
            notes.append(f"|B| beyond the ±{s.field_range / GAUSS:.3g} G range of the total "
                         "field")
        if f & SensorFlag.CROSS_FIELD:
            notes.append(f"cross-axis error {scaled(self.cross_error[i], 1e-9, 'nT')} "
                         f"> noise {scaled(self.noise, 1e-9, 'nT')}")
        return f"{text}: " + ("; ".join(notes) if notes else "ok")

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready content (SI): per pose the field, |B|, the cross-axis error and the flags
        (bits and names), plus the sensor's limits."""
        s = self.sensor
        return {
            "sensor": s.name, "field_range_T": s.field_range, "flip_field_T": s.flip_field,
            "cross_axis": s.cross_axis, "anisotropy_field_T": s.anisotropy_field,
            "noise_T": self.noise, "bandwidth_Hz": list(self.bandwidth),
            "azimuth_rad": self.azimuth, "ok": self.ok,
            "poses": [{"angle_rad": None if math.isnan(p) else float(p),
                       "field_T": b.tolist(), "magnitude_T": float(m),
                       "cross_error_T": float(e), "flags": int(f), "flag_names": flag_names(f)}
                      for p, b, m, e, f in zip(self.poses, self.field, self.magnitude,
                                               self.cross_error, self.flags, strict=True)],
        }

    def report(self) -> str:
        """The verdict, then one line per pose (gauss, degrees)."""
        bad = int(np.count_nonzero(self.flags))
        head = (f"{self.sensor.name}: all {count(len(self.flags), 'pose')} ok" if not bad else
                f"{self.sensor.name}: {bad} of {count(len(self.flags), 'pose')} flagged")
        return "\n".join([head, *(f"  {line}" for line in self.summaries())])

    def _display_items(self) -> list[Item]:
        union = int(np.bitwise_or.reduce(self.flags)) if self.flags.size else 0
        return [("", self.sensor.name), ("poses", str(len(self.flags))),
                ("flagged", str(int(np.count_nonzero(self.flags)))),
                ("max |B|", f"{float(self.magnitude.max(initial=0.0)) / GAUSS:.3g} G"),
                ("flags", flag_names(union))]
