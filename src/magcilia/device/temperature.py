"""Temperature: how the sensor's output and the cilium change with it, and a temperature over time.

The output of the single-axis setup is ``V = offset + S·V_b·g · B_x(pose)`` (:mod:`magcilia.device.
sensor`), with ``B_x`` proportional to the cilium's magnetization and the pose under a load set by
the load over the bending stiffness E·I. Four things in it move with the temperature T (relative
to :attr:`TemperatureModel.reference`, ΔT = T − T_ref; every coefficient linear in ΔT, with its
1 σ):

* **AMR sensitivity** S. Honeywell HMC1001/1002/1021/1022 datasheet: the HMC1001/1002 table
  states a sensitivity tempco of −0.32 / −0.30 / −0.28 %/°C (min/typ/max; T_A = −40…125 °C) at
  V_bridge = 8 V and −0.06 %/°C at I_bridge = 5 mA (read in a stored copy of the datasheet); the
  HMC1021/1022 table's row, −2700 / −3000 / −3300 ppm/°C at V_bridge = 5 V and −600 ppm/°C at
  5 mA, is as this module's authors know it (the stored copies end before that row: unverified
  here, consistent with the HMC1001/1002 row and with the HMC1053's −2700 ppm/°C typical, the
  same AMR process). Default −3000 ppm/K with σ 300 ppm/K (the min–max half-width). The output's
  change with temperature pivots at zero applied field (M. J. Caruso, "Applications of
  magnetoresistive sensors in navigation systems", Honeywell, SAE 1997, Fig. 5): the scale
  changes about the zero-field level, which is how :meth:`TemperatureModel.output` applies it.
* **Bridge resistance** R_b. HMC1021/1022 table (unverified here, as above): bridge resistance
  tempco 2100 / 2500 / 2900 ppm/°C.
  It leaves a voltage-driven bridge's output alone; a current-driven bridge's voltage follows
  R_b, so its sensitivity tempco is the sum (−3000 + 2500 ≈ −500 ppm/K, beside the datasheet's
  −600 ppm/°C at a current drive): ``drive="current"`` applies it. :meth:`TemperatureModel.
  temperature_from_resistance` reads the temperature off the bridge's own resistance.
* **Bridge offset.** HMC1021/1022 table: bridge offset −10 / ±2.5 / +11.25 mV at V_bridge = 5 V
  (read in a stored copy); its tempco ±500 ppm/°C without set/reset, ±10 ppm/°C with it
  (unverified here, as above). Caruso (1997) adds that parts' offset drifts are uncorrelated
  ("may in fact drift in opposite directions") and that set/reset switching cancels them, down
  to below 0.01 %/°C overall. The sign being unknown per part, the default drift is 0 with
  σ = 500 ppm/K × 2.25 mV/V over the 1 mV/V/gauss sensitivity, field-referred: 1.125e-7 T/K
  (1.1 mG/K; with set/reset pulsing, 2.25e-9 T/K).
* **The elastomer's modulus** E. Well above its glass transition a rubber's modulus is entropic,
  E = 3·n·k_B·T (L. R. G. Treloar, The Physics of Rubber Elasticity, 3rd ed., Oxford 1975,
  ch. 2–4: the retractive force at fixed extension is proportional to the absolute temperature),
  so d ln E / dT = 1/T_ref ≈ +3.4e-3 /K at 20 °C. Kraton D SIS is a physically cross-linked
  triblock: its polyisoprene mid-block is far above its T_g (about −60 °C) at room temperature,
  while its polystyrene domains (T_g about 95–100 °C) that act as the cross-links soften as they
  are approached, which works the other way. No figure for the slope of D1163P's small-strain
  modulus near room temperature could be verified here (Kraton's data sheets give 23 °C values
  only), so the default is the entropic 1/T_ref with a σ of the same size (100 %): measure it
  (a ring-down at two temperatures, :func:`magcilia.ringdown`) and override it.
* **The cobalt's magnetization** M. Bulk cobalt's saturation magnetization is 162.5 emu/g at 0 K
  and 161 emu/g at 20 °C (B. D. Cullity and C. D. Graham, Introduction to Magnetic Materials,
  2nd ed., Wiley 2009, table 4.2; Curie point 1388 K). Bloch's T^{3/2} law through the two gives
  d ln M_s / dT = −1.5 · (ΔM/M₀) / T_ref ≈ −47 ppm/K at 20 °C. The particles' *remanent*
  magnetization, which the model uses, may fall faster (the coercivity of a particle ensemble
  falls with T and thermal relaxation lowers the remanence); no figure for the paper's powder
  could be verified here, so σ is 100 ppm/K, twice the bulk slope: measure it for your powder.

The model's output at a temperature (:meth:`TemperatureModel.output`) and its inverse
(:meth:`TemperatureModel.to_reference`, with the σ of every coefficient) act on the output at
the reference temperature; the modulus acts on the load (a tip force's pose depends on F/E
only: the force at T is ``F_ref · E(T)/E_ref``, :meth:`TemperatureModel.load_factor`).
Compensation in the read-out: :mod:`magcilia.readout.thermal`; a temperature over time for the
simulated source: :class:`TemperatureProfile`.

Examples
--------
>>> m = TemperatureModel()
>>> round(float(m.sensitivity_factor(313.15)), 4)  # 20 K above the reference, −3000 ppm/K
0.94
>>> TemperatureModel.zero().to_reference([1.0, 2.0], 330.0, offset=0.0)[0].tolist()
[1.0, 2.0]
"""

from __future__ import annotations

import math
from dataclasses import dataclass, fields, replace
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from magcilia import _validate as v
from magcilia._display import Display, Item

F64 = NDArray[np.float64]

#: 0 °C in kelvin
ZERO_CELSIUS = 273.15
#: the default reference temperature, K (20 °C)
REFERENCE_TEMPERATURE = 293.15
#: the name of a temperature channel (K): a source's, a recording's column, a read-out's input
TEMPERATURE_CHANNEL = "temperature_K"
#: how a bridge is driven: its sensitivity tempco differs (see the module docstring)
DRIVES = ("voltage", "current")

#: the temperature coefficients a model holds: name -> (SI unit, default, default 1 σ, what)
COEFFICIENTS: dict[str, tuple[str, float, float, str]] = {
    "sensitivity_tempco": ("1/K", -3000e-6, 300e-6, "AMR sensitivity at a fixed bridge voltage"),
    "bridge_resistance_tempco": ("1/K", 2500e-6, 400e-6, "AMR bridge resistance"),
    "offset_tempco": ("T/K", 0.0, 500e-6 * 2.25e-3 / 10.0, "bridge offset, field-referred"),
    "modulus_tempco": ("1/K", 1.0 / REFERENCE_TEMPERATURE, 1.0 / REFERENCE_TEMPERATURE,
                       "Young's modulus (entropic rubber elasticity)"),
    "magnetization_tempco": ("1/K", -1.5 * (162.5 - 161.0) / 162.5 / REFERENCE_TEMPERATURE,
                             100e-6, "remanent magnetization of the cobalt"),
}


@dataclass(frozen=True, repr=False)
class TemperatureModel(Display):
    """Linear temperature coefficients of the sensor and the cilium, each with its 1 σ (all SI;
    the figures and their sources are in the module docstring).

    Parameters
    ----------
    reference : float
        Reference temperature T_ref, K: the temperature of the calibration's parameters.
    sensitivity_tempco, sensitivity_tempco_sigma : float
        Relative change of the AMR sensitivity per kelvin at a fixed bridge voltage, 1/K.
    bridge_resistance_tempco, bridge_resistance_tempco_sigma : float
        Relative change of the bridge resistance per kelvin, 1/K.
    offset_tempco, offset_tempco_sigma : float
        Drift of the bridge offset per kelvin, field-referred, T/K (the output moves by
        ``scale · offset_tempco`` V/K).
    modulus_tempco, modulus_tempco_sigma : float
        Relative change of the cilium's Young's modulus per kelvin, 1/K.
    magnetization_tempco, magnetization_tempco_sigma : float
        Relative change of the cilium's magnetization per kelvin, 1/K.
    drive : {"voltage", "current"}
        How the bridge is driven: a current drive adds the bridge resistance's tempco to the
        sensitivity's.
    temperature_sigma : float
        1 σ of a temperature reading, K (the thermometer's accuracy; 0: exact).
    calibrated_range : (float, float) or None
        The temperatures, K, the setup's parameters were calibrated over (None: the reference
        alone); a read-out flags readings outside it (:mod:`magcilia.readout.thermal`).
    """

    reference: float = REFERENCE_TEMPERATURE
    sensitivity_tempco: float = COEFFICIENTS["sensitivity_tempco"][1]
    sensitivity_tempco_sigma: float = COEFFICIENTS["sensitivity_tempco"][2]
    bridge_resistance_tempco: float = COEFFICIENTS["bridge_resistance_tempco"][1]
    bridge_resistance_tempco_sigma: float = COEFFICIENTS["bridge_resistance_tempco"][2]
    offset_tempco: float = COEFFICIENTS["offset_tempco"][1]
    offset_tempco_sigma: float = COEFFICIENTS["offset_tempco"][2]
    modulus_tempco: float = COEFFICIENTS["modulus_tempco"][1]
    modulus_tempco_sigma: float = COEFFICIENTS["modulus_tempco"][2]
    magnetization_tempco: float = COEFFICIENTS["magnetization_tempco"][1]
    magnetization_tempco_sigma: float = COEFFICIENTS["magnetization_tempco"][2]
    drive: str = "voltage"
    temperature_sigma: float = 0.0
    calibrated_range: tuple[float, float] | None = None

    def __post_init__(self) -> None:
        object.__setattr__(self, "reference",
                           v.positive("reference", self.reference, "K", "temperature"))
        object.__setattr__(self, "drive", v.choice("drive", self.drive, DRIVES))
        if self.calibrated_range is not None:
            lo, hi = (v.positive("calibrated_range", t, "K", "temperature")
                      for t in _pair(self.calibrated_range))
            if hi < lo:
                raise v.fail("calibrated_range", (lo, hi), "(low, high) in K with high ≥ low")
            object.__setattr__(self, "calibrated_range", (lo, hi))
        for f in fields(self):
            if f.name.endswith("_tempco"):
                unit = COEFFICIENTS[f.name][0]
                object.__setattr__(self, f.name, v.real(f.name, getattr(self, f.name), unit))
            elif f.name.endswith("_sigma"):
                unit = "K" if f.name == "temperature_sigma" else COEFFICIENTS[f.name[:-6]][0]
                object.__setattr__(self, f.name, v.non_negative(
                    f.name, getattr(self, f.name), unit, "uncertainty"))

    @classmethod
    def zero(cls, reference: float = REFERENCE_TEMPERATURE) -> TemperatureModel:
        """A model with every coefficient and σ 0: nothing changes with temperature."""
        zeros: dict[str, Any] = {f.name: 0.0 for f in fields(cls)
                                 if f.name.endswith(("_tempco", "_sigma"))}
        return cls(reference=reference, **zeros)

    def replace(self, **changes: Any) -> TemperatureModel:
        """A copy with ``changes`` (SI)."""
        return replace(self, **changes)

    # -- the factors ------------------------------------------------------------------------------
    def delta(self, temperature: ArrayLike) -> F64:
        """ΔT = T − T_ref, K, shape of ``temperature`` (K)."""
        return np.asarray(temperature, dtype=np.float64) - self.reference

    @property
    def scale_tempco(self) -> tuple[float, float]:
        """The output scale's relative tempco and its σ, 1/K: the sensitivity's, plus the bridge
        resistance's for a current drive."""
        if self.drive == "voltage":
            return self.sensitivity_tempco, self.sensitivity_tempco_sigma
        return (self.sensitivity_tempco + self.bridge_resistance_tempco,
                math.hypot(self.sensitivity_tempco_sigma, self.bridge_resistance_tempco_sigma))

    def sensitivity_factor(self, temperature: ArrayLike) -> Any:
        """S(T)/S(T_ref) of the output scale (drive included), shape of ``temperature``."""
        d = self.delta(temperature)
        if self.drive == "voltage":
            return 1.0 + self.sensitivity_tempco * d
        return (1.0 + self.sensitivity_tempco * d) * (1.0 + self.bridge_resistance_tempco * d)

    def magnetization_factor(self, temperature: ArrayLike) -> Any:
        """M(T)/M(T_ref), shape of ``temperature``."""
        return 1.0 + self.magnetization_tempco * self.delta(temperature)

    def load_factor(self, temperature: ArrayLike) -> Any:
        """E(T)/E(T_ref), shape of ``temperature``: a tip force F at T bends the cilium as
        ``F / load_factor`` does at the reference."""
        return 1.0 + self.modulus_tempco * self.delta(temperature)

    def resistance(self, resistance_ref: float, temperature: ArrayLike) -> Any:
        """The bridge resistance, Ω, at ``temperature`` (K) of a bridge of ``resistance_ref`` Ω
        at the reference."""
        return resistance_ref * (1.0 + self.bridge_resistance_tempco * self.delta(temperature))

    def temperature_from_resistance(self, resistance: ArrayLike, resistance_ref: float) -> F64:
        """The temperature, K, at which the bridge has ``resistance`` (Ω, any shape), given its
        ``resistance_ref`` at the reference: the bridge as its own thermometer."""
        if self.bridge_resistance_tempco == 0.0:
            raise v.fail("bridge_resistance_tempco", 0.0, "non-zero to read a temperature")
        ratio = np.asarray(resistance, dtype=np.float64) / resistance_ref - 1.0
        return np.asarray(self.reference + ratio / self.bridge_resistance_tempco)

    # -- the output -------------------------------------------------------------------------------
    def output(self, volts_ref: ArrayLike, temperature: ArrayLike, offset: float,
               scale: float) -> F64:
        """The output, V, at ``temperature`` (K) of a sensor whose output at the reference is
        ``volts_ref`` (V, the pose already at the temperature's load; broadcast together):
        ``offset + scale·offset_tempco·ΔT + S(T)·M(T) · (volts_ref − offset)``, where ``offset``
        (V) and ``scale`` (V/T) are the sensor's at the reference."""
        d = self.delta(temperature)
        gain = self.sensitivity_factor(temperature) * self.magnetization_factor(temperature)
        return np.asarray(offset + scale * self.offset_tempco * d
                          + gain * (np.asarray(volts_ref, dtype=np.float64) - offset))

    def to_reference(self, volts: ArrayLike, temperature: ArrayLike, offset: float,
                     scale: float = 1.0) -> tuple[F64, F64]:
        """The inverse of :meth:`output`: readings ``volts`` (V) taken at ``temperature`` (K) as
        the reference temperature would have given them, and the 1 σ of that, V (the
        coefficients' σ and the temperature's, first order), both of the broadcast shape.

        ``offset`` (V) is the output's zero-field level at the reference (the pivot of the
        scale's change; a tare finds it), ``scale`` (V/T) the sensor's output scale."""
        x = np.asarray(volts, dtype=np.float64)
        d = self.delta(temperature)
        s = self.sensitivity_factor(temperature)
        m = self.magnetization_factor(temperature)
        drift = scale * self.offset_tempco
        ref = offset + (x - offset - drift * d) / (s * m)
        signal = ref - offset
        a_s, sig_s = self.scale_tempco
        s_lin = 1.0 + a_s * d  # the scale's linearised factor (the σ's first order)
        var = ((signal * d * sig_s / s_lin) ** 2
               + (signal * d * self.magnetization_tempco_sigma / m) ** 2
               + (scale * self.offset_tempco_sigma * d / (s * m)) ** 2)
        if self.temperature_sigma:
            slope = -(drift + signal * (a_s * m + self.magnetization_tempco * s_lin)) / (s * m)
            var = var + (slope * self.temperature_sigma) ** 2
        return np.asarray(ref), np.asarray(np.sqrt(var))

    def load_sigma(self, temperature: ArrayLike) -> F64:
        """1 σ of :meth:`load_factor` (relative), shape of ``temperature``: the modulus tempco's
        σ and the temperature's."""
        d = self.delta(temperature)
        return np.asarray(np.hypot(d * self.modulus_tempco_sigma,
                                   self.modulus_tempco * self.temperature_sigma))

    @property
    def is_zero(self) -> bool:
        """True when nothing changes with temperature (every coefficient 0)."""
        return all(getattr(self, n) == 0.0 for n in COEFFICIENTS)

    # -- results protocol -----------------------------------------------------------------------
    def to_dict(self) -> dict[str, Any]:
        """JSON-ready content (SI; coefficient names with their unit)."""
        out = {key: getattr(self, name) for key, name in _dict_keys().items()}
        if self.calibrated_range is not None:
            out["calibrated_range_K"] = list(self.calibrated_range)
        return out

    @classmethod
    def from_dict(cls, doc: dict[str, Any]) -> TemperatureModel:
        """The model of :meth:`to_dict`'s content (SI)."""
        if not isinstance(doc, dict):
            raise v.fail("temperature model", type(doc).__name__, "a dict from to_dict()")
        known = _dict_keys()
        unknown = sorted(set(doc) - set(known))
        if unknown:
            raise v.fail("temperature model key", unknown[0], "one of " + ", ".join(known))
        args = {known[key]: value for key, value in doc.items()}
        if args.get("calibrated_range") is not None:
            args["calibrated_range"] = tuple(args["calibrated_range"])
        return cls(**args)

    def report(self) -> str:
        """One line per coefficient (ppm/K, nT/K)."""
        lines = [(f"temperature model: reference {self.reference:.2f} K "
                  f"({self.reference - ZERO_CELSIUS:.2f} °C), {self.drive} drive")]
        for name, (unit, *_rest, what) in COEFFICIENTS.items():
            value, sigma = getattr(self, name), getattr(self, f"{name}_sigma")
            if unit == "T/K":
                text = f"{value * 1e9:+.4g} ± {sigma * 1e9:.3g} nT/K"
            else:
                text = f"{value * 1e6:+.4g} ± {sigma * 1e6:.3g} ppm/K"
            lines.append(f"  {what}: {text}")
        if self.temperature_sigma:
            lines.append(f"  thermometer: ± {self.temperature_sigma:.3g} K")
        if self.calibrated_range is not None:
            lo, hi = self.calibrated_range
            lines.append(f"  calibrated over {lo:.2f}…{hi:.2f} K")
        return "\n".join(lines)

    def _display_items(self) -> list[Item]:
        a_s = self.scale_tempco[0]
        return [("reference", f"{self.reference:.2f} K"), ("drive", self.drive),
                ("scale", f"{a_s * 1e6:+.4g} ppm/K"),
                ("modulus", f"{self.modulus_tempco * 1e6:+.4g} ppm/K"),
                ("magnetization", f"{self.magnetization_tempco * 1e6:+.4g} ppm/K")]


def _pair(value: object) -> tuple[Any, Any]:
    """A (low, high) pair, or the error naming it."""
    if not isinstance(value, (tuple, list)) or len(value) != 2:
        raise v.fail("calibrated_range", value, "a pair (low, high) in K")
    return value[0], value[1]


def _dict_keys() -> dict[str, str]:
    """:meth:`TemperatureModel.to_dict`'s keys (names with their SI unit) -> field names."""
    out = {"reference_K": "reference", "drive": "drive",
           "temperature_sigma_K": "temperature_sigma", "calibrated_range_K": "calibrated_range"}
    for name, (unit, *_rest) in COEFFICIENTS.items():
        tag = {"1/K": "per_K", "T/K": "T_per_K"}[unit]
        out[f"{name}_{tag}"] = name
        out[f"{name}_sigma_{tag}"] = f"{name}_sigma"
    return out


@dataclass(frozen=True)
class TemperatureProfile:
    """A temperature over time (K vs s) for the simulated source: ``start + rate·t``, held at
    ``stop`` once reached (a ramp), or forever (a drift; ``stop`` None).

    Build it with :meth:`constant`, :meth:`ramp` or :meth:`drift`.

    Examples
    --------
    >>> TemperatureProfile.ramp(293.0, 313.0, 10.0).values(np.array([0.0, 5.0, 20.0])).tolist()
    [293.0, 303.0, 313.0]
    """

    start: float
    rate: float = 0.0
    stop: float | None = None

    def __post_init__(self) -> None:
        object.__setattr__(self, "start", v.positive("start", self.start, "K", "temperature"))
        object.__setattr__(self, "rate", v.real("rate", self.rate, "K/s"))
        if self.stop is not None:
            object.__setattr__(self, "stop", v.positive("stop", self.stop, "K", "temperature"))

    @classmethod
    def constant(cls, temperature: float) -> TemperatureProfile:
        """The same temperature (K) all the time."""
        return cls(temperature)

    @classmethod
    def ramp(cls, start: float, end: float, duration: float) -> TemperatureProfile:
        """From ``start`` to ``end`` (K) linearly over ``duration`` (s), then held."""
        duration = v.positive("duration", duration, "s", "time")
        return cls(start, (v.real("end", end, "K") - start) / duration, end)

    @classmethod
    def drift(cls, start: float, rate: float) -> TemperatureProfile:
        """From ``start`` (K) at ``rate`` (K/s) for ever."""
        return cls(start, rate)

    def values(self, t: ArrayLike) -> F64:
        """The temperature, K, at times ``t`` (s), same shape."""
        out = self.start + self.rate * np.asarray(t, dtype=np.float64)
        if self.stop is not None:
            out = np.minimum(out, self.stop) if self.rate >= 0.0 else np.maximum(out, self.stop)
        return np.asarray(out, dtype=np.float64)

    def describe(self) -> str:
        """One line, K and K/s."""
        if self.rate == 0.0:
            return f"{self.start:.6g} K"
        text = f"{self.start:.6g} K at {self.rate:+.6g} K/s"
        return text if self.stop is None else f"{text} up to {self.stop:.6g} K"
