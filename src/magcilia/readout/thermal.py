"""Temperature compensation of the single-output read-out: readings taken at temperature T read as
the reference temperature would have given them, with the coefficients' σ in the force's σ.

:class:`ThermalReadout` follows the read-out protocol (:mod:`magcilia.readout.protocol`) with two
inputs per sample, ``("output", "temperature_K")`` (V, K). For each sample it

1. brings the output to the reference temperature (:meth:`magcilia.TemperatureModel.to_reference`:
   the offset's drift removed and the scale's change undone, sensitivity and magnetization,
   about the zero-field level: the sensor's offset, or the level its tare found);
2. reads that with the :class:`~magcilia.Readout` it wraps (its table, tare, calibration σ,
   flags);
3. scales a force by the modulus's change, ``F = F_ref · E(T)/E_ref`` (exact for a tip force: the
   elastica depends on F/(E·I) only; for a flow speed the drag is taken as proportional to the
   speed, the low-Reynolds limit, so ``U = U_ref · E(T)/E_ref`` is a first-order correction; a
   tilt angle does not depend on E);
4. adds the temperature part of σ (``sigma_temperature``: the output's σ through the table's slope,
   and the modulus's, from the coefficients' σ and the thermometer's) in quadrature;
5. flags TEMPERATURE_OUTSIDE where T lies outside the calibrated range (the range of the
   temperatures seen at calibration and tare, :attr:`ThermalReadout.calibrated_range`): there
   the coefficients are extrapolated. A NaN temperature leaves the reading without an estimate
   (MISSING).

The tare (:meth:`ThermalReadout.tare`) takes unloaded samples at their temperatures: it finds the
zero-field level that makes them the model's rest output after compensation, and widens the
calibrated range to their temperatures.
"""

from __future__ import annotations

import copy
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from magcilia import _validate as v
from magcilia._display import Display, Item
from magcilia._errors import MagciliaError
from magcilia.device.parameters import MEASURANDS
from magcilia.device.sensor import DEFAULT_BANDWIDTH
from magcilia.device.temperature import TEMPERATURE_CHANNEL, TemperatureModel
from magcilia.readout.inverse import Readout
from magcilia.readout.protocol import FLAG_DTYPE, OUTPUT, Flag
from magcilia.readout.result import NO_ESTIMATE, ReadoutResult
from magcilia.readout.tare import Tare

F64 = NDArray[np.float64]

#: the second input of a temperature-compensated read-out, K (a source's temperature channel)
TEMPERATURE = TEMPERATURE_CHANNEL


def temperature_range(temperature: ArrayLike, name: str = "temperature") -> tuple[float, float]:
    """The (lowest, highest) finite temperature of ``temperature`` (K, any shape)."""
    t = np.asarray(temperature, dtype=np.float64).reshape(-1)
    good = t[np.isfinite(t)]
    if not good.size:
        raise MagciliaError(f"{name} has no finite value (K)")
    if good.min() <= 0.0:
        raise v.fail(name, f"{float(good.min()):.6g} K", "absolute temperatures above 0 K")
    return float(good.min()), float(good.max())


@dataclass(frozen=True, eq=False, repr=False)
class ThermalReadout(Display):
    """A :class:`~magcilia.Readout` whose readings are compensated for temperature (see the module
    docstring; immutable).

    Parameters
    ----------
    readout : Readout
        The read-out at the reference temperature (its setup's parameters are the
        calibration's, at ``model.reference``).
    model : TemperatureModel, optional
        The coefficients (default: :class:`~magcilia.TemperatureModel`'s, the HMC1021Z and the
        paper's cilium).
    calibrated_range : (float, float), optional
        Temperatures seen at calibration, K (default: the model's
        :attr:`~magcilia.TemperatureModel.calibrated_range`, else the reference alone; a tare
        widens it).

    Attributes
    ----------
    offset : float
        The zero-field output at the reference, V, about which the scale's change acts: the
        sensor's offset, or the one the tare found.
    """

    readout: Readout
    model: TemperatureModel
    calibrated_range: tuple[float, float]
    offset: float

    def __init__(self, readout: Readout, model: TemperatureModel | None = None,
                 calibrated_range: tuple[float, float] | None = None) -> None:
        if not isinstance(readout, Readout):
            raise v.fail("readout", type(readout).__name__, "a magcilia.Readout")
        if readout.actuation is not None:
            raise v.fail("readout", "a read-out under an actuation", "one without: the "
                         "magnetization's change with temperature also changes the actuation's "
                         "bending, which the compensation does not model")
        model = TemperatureModel() if model is None else model
        if not isinstance(model, TemperatureModel):
            raise v.fail("model", type(model).__name__, "a magcilia.TemperatureModel")
        if calibrated_range is None:
            calibrated_range = model.calibrated_range or (model.reference, model.reference)
        span = temperature_range(calibrated_range, "calibrated_range")
        for name, value in (("readout", readout), ("model", model), ("calibrated_range", span),
                            ("offset", float(readout.setup.sensor.offset))):
            object.__setattr__(self, name, value)

    # -- the protocol -----------------------------------------------------------------------------
    @property
    def inputs(self) -> tuple[str, ...]:
        """What one sample holds: ``("output", "temperature_K")`` (V, K)."""
        return (OUTPUT, TEMPERATURE)

    @property
    def rest(self) -> F64:
        """The model's reading at rest at the reference: (output V, reference K)."""
        return np.array([float(self.readout.rest[0]), self.model.reference])

    @property
    def baseline(self) -> Tare | None:
        """The tare of the wrapped read-out (of the compensated outputs), or None."""
        return self.readout.baseline

    @property
    def quantity(self) -> str:
        """The wrapped read-out's quantity."""
        return self.readout.quantity

    def _split(self, samples: ArrayLike) -> tuple[F64, F64]:
        x = np.asarray(samples, dtype=np.float64)
        if x.ndim != 2 or x.shape[1] != 2:
            raise v.fail("samples", f"an array of shape {x.shape}",
                         "shape (n, 2): the output in V and the temperature in K per sample")
        return x[:, 0], x[:, 1]

    def tare(self, baseline: ArrayLike, /) -> ThermalReadout:
        """A copy tared on unloaded samples ``baseline`` ((n, 2): output V, temperature K).

        The zero-field level is the one that brings the baseline, compensated, to the model's
        rest output on average; the wrapped read-out is then tared on the compensated baseline
        (its noise and standard error as :meth:`Readout.tare`'s), and the calibrated range
        widened to the baseline's temperatures."""
        volts, temps = self._split(baseline)
        good = np.isfinite(volts) & np.isfinite(temps)
        if np.count_nonzero(good) < 2:
            raise MagciliaError("tare needs at least 2 samples with a finite output and "
                                f"temperature; got {int(np.count_nonzero(good))}")
        lo, hi = temperature_range(temps[good], "baseline temperature")
        m, sensor = self.model, self.readout.setup.sensor
        signal = float(self.readout.rest[0]) - sensor.offset  # the model's rest signal at T_ref
        gain = m.sensitivity_factor(temps[good]) * m.magnetization_factor(temps[good])
        level = volts[good] - gain * signal - sensor.scale * m.offset_tempco * m.delta(temps[good])
        new = self.widened(lo, hi)
        object.__setattr__(new, "offset", float(level.mean()))
        ref, _ = m.to_reference(volts, temps, new.offset, sensor.scale)
        object.__setattr__(new, "readout", self.readout.tare(ref[good]))
        return new

    def widened(self, low: float, high: float) -> ThermalReadout:
        """A copy whose calibrated range also covers ``low``…``high`` (K): the temperatures of a
        tare (:meth:`tare`; the live read-out's, :mod:`magcilia.live.thermal`)."""
        new = copy.copy(self)
        c_lo, c_hi = self.calibrated_range
        object.__setattr__(new, "calibrated_range", (min(c_lo, float(low)),
                                                     max(c_hi, float(high))))
        return new

    def read(self, samples: ArrayLike, /, *, noise: ArrayLike | None = None,
             bandwidth: tuple[float, float] = DEFAULT_BANDWIDTH) -> ThermalResult:
        """Compensated estimates of ``samples`` ((n, 2): output V, temperature K), with 1 σ and
        flags (:class:`ThermalResult`); ``noise`` and ``bandwidth`` as :meth:`Readout.read`'s."""
        volts, temps = self._split(samples)
        return self.read_at(volts, temps, noise=noise, bandwidth=bandwidth)

    def read_at(self, volts: ArrayLike, temperature: ArrayLike, *,
                noise: ArrayLike | None = None,
                bandwidth: tuple[float, float] = DEFAULT_BANDWIDTH) -> ThermalResult:
        """:meth:`read` of outputs ``volts`` (V, (n,)) at temperatures ``temperature`` (K, (n,)
        or one for all)."""
        x = np.asarray(volts, dtype=np.float64).reshape(-1)
        t = np.broadcast_to(np.asarray(temperature, dtype=np.float64), np.shape(volts))
        t = np.asarray(t, dtype=np.float64).reshape(-1)
        ref, sigma_ref = self.model.to_reference(x, t, self.offset, self.readout.setup.sensor.scale)
        inner = self.readout.read(ref, bandwidth=bandwidth, noise=noise)
        return self.finish(inner, ref, sigma_ref, t, noise=noise, bandwidth=bandwidth)

    def finish(self, inner: ReadoutResult, ref: ArrayLike, sigma_ref: ArrayLike,
               temperature: ArrayLike, *, noise: ArrayLike | None = None,
               bandwidth: tuple[float, float] = DEFAULT_BANDWIDTH) -> ThermalResult:
        """Steps 3–5 of the compensation (the module docstring) for ``inner``, the wrapped
        read-out's reading of the outputs ``ref`` (V, (n,)) already brought to the reference
        (:meth:`TemperatureModel.to_reference`, whose σ ``sigma_ref`` (V, (n,)) they carry) at
        temperatures ``temperature`` (K, (n,)): the modulus's change, the temperature part of σ,
        TEMPERATURE_OUTSIDE and MISSING. :meth:`read_at` is ``to_reference``, the wrapped
        read-out's ``read`` and this; the live read-out (:mod:`magcilia.live.thermal`) brings
        its samples to the reference before its zero and calls ``finish`` on their readings."""
        m, r = self.model, self.readout
        ref = np.asarray(ref, dtype=np.float64).reshape(-1)
        sigma_ref = np.asarray(sigma_ref, dtype=np.float64).reshape(-1)
        t = np.asarray(temperature, dtype=np.float64).reshape(-1)
        slope = _slope(r, inner, ref, noise, bandwidth)
        factor = (np.ones_like(t) if r.quantity == "angle" else m.load_factor(t))
        rel = np.zeros_like(t) if r.quantity == "angle" else m.load_sigma(t)
        with np.errstate(invalid="ignore"):
            value = inner.value * factor
            s_temp = np.hypot(slope * sigma_ref * np.abs(factor), np.abs(inner.value) * rel)
            sigma = np.hypot(inner.sigma * np.abs(factor), s_temp)
        flags = np.array(inner.flags, dtype=FLAG_DTYPE)
        lo, hi = self.calibrated_range
        outside = ~((t >= lo) & (t <= hi)) & np.isfinite(t)
        flags[outside] |= FLAG_DTYPE(Flag.TEMPERATURE_OUTSIDE)
        missing = ~np.isfinite(t)
        flags[missing] |= FLAG_DTYPE(Flag.MISSING)
        blank = missing | ((flags & FLAG_DTYPE(NO_ESTIMATE)) != 0)
        for arr in (value, sigma, s_temp):
            arr[blank] = np.nan
        return ThermalResult(quantity=r.quantity, unit=r.unit, value=value, sigma=sigma,
                             sigma_temperature=s_temp, flags=flags, temperature=t,
                             reference=inner, load_factor=np.asarray(factor, dtype=np.float64),
                             calibrated_range=self.calibrated_range)

    def outside_note(self, temperature: ArrayLike) -> str:
        """One line when ``temperature`` (K) leaves the calibrated range ("" when it does not)."""
        lo, hi = temperature_range(temperature)
        c_lo, c_hi = self.calibrated_range
        if lo >= c_lo and hi <= c_hi:
            return ""
        return (f"temperature {lo:.2f}…{hi:.2f} K leaves the calibrated range {c_lo:.2f}…"
                f"{c_hi:.2f} K: its coefficients are extrapolated there (TEMPERATURE_OUTSIDE); "
                "tare or calibrate over the temperatures you measure at")

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready content (SI)."""
        return {"readout": self.readout.to_dict(), "temperature_model": self.model.to_dict(),
                "calibrated_range_K": list(self.calibrated_range), "offset_V": self.offset}

    def report(self) -> str:
        """The wrapped read-out's line, then the compensation's."""
        lo, hi = self.calibrated_range
        return (f"{self.readout.report()}\ntemperature-compensated about {self.model.reference:.2f}"
                f" K (calibrated {lo:.2f}…{hi:.2f} K)\n{self.model.report()}")

    def _display_items(self) -> list[Item]:
        lo, hi = self.calibrated_range
        return [("", self.readout.quantity), ("reference", f"{self.model.reference:.2f} K"),
                ("calibrated", f"{lo:.2f}…{hi:.2f} K")]


def _slope(readout: Readout, inner: ReadoutResult, volts: F64, noise: ArrayLike | None,
           bandwidth: tuple[float, float]) -> F64:
    """|dq/dV| of each reading: the noise part over the reading noise (exact, the read-out's own
    slope), or the table's where the noise is 0."""
    noise_v = readout.reading_noise(noise, bandwidth)
    if noise_v > 0.0:
        return np.asarray(inner.sigma_noise / noise_v)
    correction = 0.0 if readout.baseline is None else readout.baseline.correction
    ends = readout.table.volts[[0, -1]]
    x = np.fmin(np.fmax(volts + correction, ends[0]), ends[1])
    return np.asarray(np.abs(readout.table.value_and_slope(x)[1]))


@dataclass(frozen=True, eq=False, repr=False)
class ThermalResult(Display):
    """Estimates of :meth:`ThermalReadout.read` (arrays of shape (n,); SI).

    Attributes
    ----------
    quantity, unit : str
        As the wrapped read-out's.
    value : ndarray
        Compensated estimates; NaN where there is none.
    sigma : ndarray
        1 σ: the reference read-out's σ (scaled with the modulus) and ``sigma_temperature`` in
        quadrature.
    sigma_temperature : ndarray
        The compensation's part: the coefficients' and the thermometer's σ.
    flags : ndarray of uint16
        :class:`~magcilia.readout.protocol.Flag` bits, TEMPERATURE_OUTSIDE among them.
    temperature : ndarray
        The temperature of each reading, K.
    reference : ReadoutResult
        The reading of the compensated outputs at the reference (before the modulus's change).
    load_factor : ndarray
        E(T)/E_ref of each reading (1 for a tilt angle): ``value = reference.value ·
        load_factor``.
    calibrated_range : (float, float)
        The temperatures seen at calibration and tare, K.
    """

    quantity: str
    unit: str
    value: F64
    sigma: F64
    sigma_temperature: F64
    flags: NDArray[np.uint16]
    temperature: F64
    reference: ReadoutResult
    load_factor: F64
    calibrated_range: tuple[float, float]

    def as_readout_result(self) -> ReadoutResult:
        """The estimates as a :class:`~magcilia.readout.result.ReadoutResult` (for the writers of
        :meth:`Readout.read`'s results): the reference reading's σ parts scaled with the modulus,
        the temperature part joining ``sigma_calibration`` (an error shared by the readings,
        as the calibration's), so that ``sigma`` stays their quadrature sum."""
        ref, factor = self.reference, np.abs(self.load_factor)
        with np.errstate(invalid="ignore"):
            parts = (self.value, self.sigma, ref.sigma_noise * factor,
                     np.hypot(ref.sigma_calibration * factor, self.sigma_temperature),
                     ref.sigma_edge * factor, ref.sigma_scale * factor, self.flags)
        return ReadoutResult.of(self.quantity, self.unit, parts, ref.table_error, ref.scale_note)

    def to_xarray(self, time_s: Any = None) -> Any:
        """The estimates as an ``xarray.Dataset`` (:meth:`ReadoutResult.to_xarray` of
        :meth:`as_readout_result`, ``time_s`` its coordinate where given) with
        ``sigma_temperature_*``, ``temperature_K`` and ``load_factor`` beside them and the
        calibrated range (K) as an attribute. Needs xarray (the ``export`` extra)."""
        from magcilia._display import column

        ds = self.as_readout_result().to_xarray(time_s)
        dim = ds[column(self.quantity, self.unit)].dims
        ds[column("sigma_temperature", self.unit)] = (dim, self.sigma_temperature,
                                                      {"units": self.unit})
        ds["temperature_K"] = (dim, self.temperature, {"units": "K"})
        ds["load_factor"] = (dim, self.load_factor, {"units": "1"})
        ds.attrs["calibrated_range_K"] = list(self.calibrated_range)
        return ds

    @property
    def outside(self) -> int:
        """How many readings lie outside the calibrated range."""
        return int(np.count_nonzero(self.flags & FLAG_DTYPE(Flag.TEMPERATURE_OUTSIDE)))

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready content (SI; NaN written as null by the JSON writers)."""
        return {"quantity": self.quantity, "unit": self.unit, "value": self.value.tolist(),
                "sigma": self.sigma.tolist(),
                "sigma_temperature": self.sigma_temperature.tolist(),
                "flags": self.flags.tolist(), "temperature_K": self.temperature.tolist(),
                "calibrated_range_K": list(self.calibrated_range)}

    def report(self) -> str:
        """The reference reading's line and, where some readings lie outside the calibrated
        range, how many."""
        q = MEASURANDS[self.quantity]
        good = np.isfinite(self.value)
        text = f"{int(good.sum())}/{self.value.size} readings estimated"
        if good.any():
            vals = self.value[good] / q.display_factor
            text += (f"; {self.quantity} {vals.min():.4g}…{vals.max():.4g} {q.display}, median "
                     f"1-σ {np.median(self.sigma[good]) / q.display_factor:.3g} {q.display} "
                     f"(temperature part "
                     f"{np.median(self.sigma_temperature[good]) / q.display_factor:.3g})")
        finite = self.temperature[np.isfinite(self.temperature)]
        if finite.size:
            text += f"; temperature {finite.min():.2f}…{finite.max():.2f} K"
        if self.outside:
            lo, hi = self.calibrated_range
            text += (f"; {self.outside} outside the calibrated {lo:.2f}…{hi:.2f} K "
                     "(TEMPERATURE_OUTSIDE)")
        return text

    def _display_items(self) -> list[Item]:
        good = np.isfinite(self.value)
        return [("", self.quantity), ("estimated", f"{int(good.sum())}/{self.value.size}"),
                ("outside range", str(self.outside)),
                ("median σ", "n/a" if not good.any() else
                 f"{float(np.median(self.sigma[good])):.3g} {self.unit}")]


__all__ = ["TEMPERATURE", "ThermalReadout", "ThermalResult", "temperature_range"]
