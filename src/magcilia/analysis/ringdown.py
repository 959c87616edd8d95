"""Ring-down identification: the damped frequency and decay of a flicked cilium, and from them
its Young's modulus and damping ratio, with σ.

A flick or a coil pulse makes the hair ring; the output (V) or a field channel (T) then holds a
damped sinusoid. :func:`ringdown` finds it (:mod:`magcilia.analysis.ringdown_fit`: the segment
after the flick's peak down to the noise floor, a spectral first guess, one least-squares fit
of ``c + e^(−γt)(a cos ω_d t + b sin ω_d t)`` on :func:`magcilia.fitting.fit_batch`) and
returns a :class:`RingdownResult`: the damped frequency ``f_d`` (Hz) and decay rate ``γ``
(1/s) with σ from the Jacobian and the residual noise, the natural frequency
``f_n = √(f_d² + (γ/2π)²)`` and the damping ratio ``ζ = γ/(2π f_n)``.

Given a setup (its size), the modulus is the one at which the modal model
(:func:`magcilia.mechanics.modes`, fluid loading included) puts the first mode's undamped
frequency at the measured ``f_n``: in vacuum ``f ∝ √E`` exactly, in a fluid the added mass
depends on the frequency, so ``E`` is found by the fixed-point iteration
``E ← E (f_n / f(E))²`` (a few modal solves). Its σ combines the frequency's (from the fit) and
the size's (σ of height, base and tip radius, each propagated by a difference through the same
solve); the result says which dominates. The density of the composite is taken as exact.

:meth:`RingdownResult.prior` hands the modulus to the physical calibration as a
:class:`~magcilia.calibration.experiments.Prior` (``calibrate(..., priors=)``; the CLI's
``magcilia calibrate --prior-from ringdown.json`` reads the JSON of ``magcilia ringdown --json``
through :func:`ringdown_prior`).
"""

from __future__ import annotations

import json
import math
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from magcilia import _validate as v
from magcilia._errors import MagciliaError
from magcilia.analysis import ringdown_fit as rf
from magcilia.analysis.ringdown_result import RingdownResult
from magcilia.device.setup import Setup
from magcilia.mechanics.drag import FLUIDS, Fluid
from magcilia.mechanics.modal import modes

F64 = NDArray[np.float64]

#: the channels a ring-down is read from: name → the recording's column key, and its unit
CHANNELS = {"voltage": ("voltage_V", "V"), "field_x": ("field_x_T", "T"),
            "field_y": ("field_y_T", "T"), "field_z": ("field_z_T", "T")}
#: the size parameters whose σ is propagated into the modulus
SIZE = ("height", "base_radius", "tip_radius")
#: relative step of the differences of the modulus by the frequency and the size
STEP = 1e-4
#: the fixed-point iteration stops when the modal frequency matches to this fraction (the
#: eigensolver's own rounding is ~1e-9 of a frequency)
FREQUENCY_TOLERANCE = 1e-8
#: the fitted decay rate must stand this many σ above zero (else: no decay)
DECAY_SIGMAS = 3.0
#: the second mode is sought above this multiple of the first's frequency
SECOND_MODE_ABOVE = 1.5
#: modulus used for the first modal solve where the setup has none, Pa
START_MODULUS = 1e6


# -- the modal model: frequency ↔ modulus ---------------------------------------------------------

def _fluid(fluid: Fluid | str | None) -> Fluid | None:
    """A fluid by name (:data:`magcilia.mechanics.drag.FLUIDS`, or ``"vacuum"``), a
    :class:`Fluid`, or None (vacuum)."""
    if fluid is None or isinstance(fluid, Fluid):
        return fluid
    if isinstance(fluid, str) and fluid.lower() in ("vacuum", "none"):
        return None
    if isinstance(fluid, str) and fluid.lower() in FLUIDS:
        return FLUIDS[fluid.lower()]
    raise v.fail("fluid", fluid, "None (vacuum), a Fluid, or one of " + ", ".join(FLUIDS))


def _first_mode(setup: Setup, modulus: float, fluid: Fluid | None,
                gravity: bool) -> tuple[float, float, bool]:
    """The first mode at ``modulus`` (Pa): undamped frequency (Hz, added mass included), damping
    ratio, overdamped."""
    m = modes(setup.replace(youngs_modulus=modulus), fluid, gravity, count=1)
    return (float(m.frequencies[0]), float(m.damping_ratios[0]), bool(m.overdamped[0]))


def modulus_from_frequency(setup: Setup, natural_frequency: float,
                           fluid: Fluid | str | None = None, gravity: bool = False, *,
                           start: float | None = None) -> float:
    """The Young's modulus (Pa) at which the first mode's undamped frequency (added mass
    included) is ``natural_frequency`` (Hz): ``E ← E (f_n / f(E))²`` from ``start`` (the setup's
    modulus, or :data:`START_MODULUS`), exact after one step in vacuum, a few in a fluid.

    Examples
    --------
    >>> setup = Setup.paper(youngs_modulus=5e5)
    >>> f1 = float(modes(setup).frequencies[0])
    >>> round(modulus_from_frequency(setup, 2.0 * f1) / 5e5, 6)  # vacuum: f ∝ √E
    4.0
    """
    f_target = v.positive("natural_frequency", natural_frequency, "Hz", "frequency")
    flu = _fluid(fluid)
    e = start if start is not None else (setup.cilium.youngs_modulus or START_MODULUS)
    for _ in range(50):
        f, _, _ = _first_mode(setup, e, flu, gravity)
        if not (math.isfinite(f) and f > 0):
            raise MagciliaError(f"the modal model gives no first mode at E = {e:.4g} Pa in "
                                f"{_fluid_name(flu)}; check the setup's size and density")
        if abs(f / f_target - 1.0) < FREQUENCY_TOLERANCE:
            return float(e)
        e *= (f_target / f) ** 2
    raise MagciliaError(f"the modulus for a first mode at {f_target:.6g} Hz in "
                        f"{_fluid_name(flu)} did not converge; the modal model's frequency does "
                        "not rise with the modulus there")


def _fluid_name(fluid: Fluid | None) -> str:
    return "vacuum" if fluid is None else fluid.name


def _modulus_with_sigma(setup: Setup, fit: _Fitted, fluid: Fluid | None, gravity: bool,
                        size_sigma: Mapping[str, float]) -> tuple[float, float, dict[str, float],
                                                                  float]:
    """E (Pa), its σ, the σ terms by source, and the fluid's damping ratio at E."""
    e = modulus_from_frequency(setup, fit.natural, fluid, gravity)
    up = modulus_from_frequency(setup, fit.natural * (1 + STEP), fluid, gravity, start=e)
    terms = {"frequency": abs((up - e) / (fit.natural * STEP)) * fit.natural_sigma}
    for name in SIZE:
        sigma = float(size_sigma.get(name, 0.0))
        if sigma <= 0.0:
            continue
        value = float(setup.value(name))
        h = STEP * max(value, setup.cilium.base_radius)
        moved = setup.replace(**{name: value + h})
        terms[name] = abs(modulus_from_frequency(moved, fit.natural, fluid, gravity, start=e)
                          - e) / h * sigma
    _, zeta, _ = _first_mode(setup, e, fluid, gravity)
    total = math.sqrt(sum(s * s for s in terms.values()))
    return e, total, terms, (zeta if fluid is not None else math.nan)


# -- the recording --------------------------------------------------------------------------------

def _series(recording: Any, rate: float | None, channel: str | None,
            reading: dict[str, Any]) -> tuple[F64, float, str, str, str]:
    """The time series, its rate (Hz), its unit, its channel key and its source name."""
    if isinstance(recording, (str, Path)):
        from magcilia.io.recordings import read_samples

        cols = read_samples(recording, ("observable",), **reading)  # notes logged as warnings
        if channel is None:
            channel = "voltage" if "voltage_V" in cols else "field_x"
        key, unit = CHANNELS[v.choice("channel", channel, tuple(CHANNELS))]
        if key not in cols:
            raise MagciliaError(f"{recording}: no {key} column (it has "
                                f"{', '.join(cols) or 'none'}); choose the channel with "
                                "channel= (--channel: voltage, field_x, field_y, field_z)")
        y = cols[key]
        times = cols.get("time_s")
        if times is not None and times.size >= 2:
            steps = np.diff(times)
            if not np.all(steps > 0):
                raise MagciliaError(f"{recording}: time_s does not rise at every sample; a "
                                    "ring-down needs one stream of evenly spaced samples")
            dt = float(np.median(steps))
            if np.any(np.abs(steps - dt) > 0.01 * dt):
                raise MagciliaError(f"{recording}: samples are not evenly spaced (steps "
                                    f"{steps.min():.4g} to {steps.max():.4g} s); a ring-down "
                                    "needs one stream at a fixed rate")
            if rate is not None and abs(rate * dt - 1.0) > 0.01:
                raise MagciliaError(f"{recording}: the rate given ({rate:g} Hz) is not the "
                                    f"file's ({1.0 / dt:g} Hz from time_s); leave the rate out")
            rate = 1.0 / dt
        elif rate is None:
            raise MagciliaError(f"{recording}: no time_s column to take the sample rate "
                                "from; give the rate (rate=, --source-rate) in Hz")
        name = Path(recording).name
    else:
        key, unit = CHANNELS[v.choice("channel", channel or "voltage", tuple(CHANNELS))]
        y = np.asarray(recording, dtype=np.float64)
        if y.ndim != 1:
            raise v.fail("samples", f"an array of shape {y.shape}", "one time series (n,)")
        if rate is None:
            raise v.fail("rate", rate, "the sample rate in Hz for an array of samples")
        name = "samples"
    rate = v.positive("rate", rate, "Hz", "rate")
    if not np.all(np.isfinite(y)):
        raise MagciliaError(f"{name}: {int(np.sum(~np.isfinite(y)))} samples are not finite; "
                            "a ring-down needs a clean stream (cut the record)")
    return y, rate, unit, key, name


@dataclass(frozen=True)
class _Fitted:
    """What the fit gives, in the result's terms."""

    frequency: float
    frequency_sigma: float
    decay: float
    decay_sigma: float
    natural: float
    natural_sigma: float
    zeta: float
    zeta_sigma: float
    x: F64


def _fitted(x: F64, cov: F64) -> _Fitted:
    """Frequencies, decay and damping ratio with σ from the parameters and their covariance
    (first-order propagation through ``(γ, ω_d)``)."""
    g, w = float(x[2]), float(x[3])
    c = cov[np.ix_([2, 3], [2, 3])]
    wn = math.hypot(w, g)
    grad_n = np.array([g / wn, w / wn])
    grad_z = np.array([w * w / wn**3, -g * w / wn**3])
    two_pi = 2.0 * math.pi
    return _Fitted(w / two_pi, math.sqrt(c[1, 1]) / two_pi, g, math.sqrt(c[0, 0]),
                   wn / two_pi, math.sqrt(float(grad_n @ c @ grad_n)) / two_pi, g / wn,
                   math.sqrt(float(grad_z @ c @ grad_z)), x)


def ringdown(recording: str | Path | ArrayLike, rate: float | None = None, *,
             setup: Setup | None = None, fluid: Fluid | str | None = None,
             gravity: bool = False, channel: str | None = None, start: float | None = None,
             second_mode: bool = False, size_sigma: Mapping[str, float] | None = None,
             columns: Any = None, delimiter: str | None = None, decimal: str = ".",
             group: str | None = None) -> RingdownResult:
    """Identify a ring-down: damped frequency, decay, damping ratio and (with a setup) the
    Young's modulus, each with σ.

    Parameters
    ----------
    recording : str, Path or array-like, shape (n,)
        A recording file (CSV, TDMS of ``magcilia record`` or ``live --record``, .mat, HDF5:
        :func:`magcilia.io.read_samples`) with a time series of the output (``voltage_V``) or a
        field channel, or the samples themselves (V or T).
    rate : float, optional
        Sample rate, Hz (from the file's ``time_s`` by default; needed for an array).
    setup : Setup, optional
        The cilium (its size and density; :func:`magcilia.mechanics.modes`): turns the natural
        frequency into a modulus.
    fluid : {None, "air", "water"} or Fluid
        The fluid around the hair (added mass, viscous damping); None: vacuum.
    gravity : bool
        The modal model with the hair's own weight (an upright column).
    channel : {"voltage", "field_x", "field_y", "field_z"}, optional
        The channel of a file (default: the output, else ``field_x``).
    start : float, optional
        Where the free oscillation starts, s from the first sample (default: at the flick's
        largest deviation, after it where it is held).
    second_mode : bool
        Fit a second damped sinusoid beside the first (a second mode rung by the flick).
    size_sigma : mapping of str to float, optional
        1 σ of ``height``, ``base_radius``, ``tip_radius``, m: propagated into the modulus's σ.
    columns, delimiter, decimal, group : optional
        How to read the file (:func:`magcilia.io.read_samples`: its column names and units,
        CSV delimiter and decimal mark, HDF5/TDMS group).

    Returns
    -------
    RingdownResult

    Raises
    ------
    MagciliaError
        One line each: no free oscillation (no decay, or a growing one), clipped samples in the
        segment (runs at the record's extreme, or the output beyond the setup's sensor range),
        fewer than two periods, a sample rate below twice the frequency, a fluid in which the
        first mode is overdamped.
    """
    y, rate, unit, key, name = _series(recording, rate, channel, {
        "columns": columns, "delimiter": delimiter, "decimal": decimal, "group": group})
    flu = _fluid(fluid)
    sizes = dict(size_sigma or {})
    for k, s in sizes.items():
        if k not in SIZE:
            raise v.fail("size_sigma", k, "keys among " + ", ".join(SIZE))
        v.non_negative(f"size_sigma[{k!r}]", s, "m")
    if setup is not None:  # what the modal model expects at the setup's modulus
        e0 = setup.youngs_modulus
        f0, zeta0, over = _first_mode(setup, e0, flu, gravity)
        if over and flu is not None:
            raise MagciliaError(
                f"{name}: the first mode of this cilium is overdamped in {flu.name} (damping "
                f"ratio {zeta0:.3g} at E = {e0 / 1e6:.3g} MPa): it creeps back without "
                "ringing, so no ring-down exists; flick it in air, or use a stiffer or larger "
                "hair")
        if rate < 2.0 * f0 and setup.cilium.youngs_modulus is not None:
            raise MagciliaError(f"{name}: {rate:g} samples/s is below twice the first mode's "
                                f"{f0:.4g} Hz at the setup's modulus; sample at least five "
                                "times faster")
    first = None
    if start is not None:
        first = round(v.non_negative("start", start, "s", "time") * rate)
        if first >= y.size:
            raise v.fail("start", start, f"a time within the record's {y.size / rate:.4g} s")
    seg = rf.free_segment(y, rate, first, where=name)
    part = y[seg.start:seg.stop]
    after = (y.size - seg.start) / rate  # the record after the flick, s
    periods = after * seg.frequency
    clipped = rf.clipped_samples(part)
    if clipped == 0 and setup is not None and key == "voltage_V":
        from magcilia.io.readings import beyond_range

        clipped = int(np.sum(beyond_range(part, setup.sensor)))
    if clipped:
        raise MagciliaError(f"{name}: {clipped} samples of the free oscillation are clipped "
                            "(held at the record's extreme or beyond the sensor's range); "
                            "flick more gently or lower the gain")
    if periods < rf.MIN_PERIODS:
        raise _too_short(name, periods, after, seg.frequency)
    t = np.arange(part.size) / rate
    x0 = rf.first_guess(t, part[None, :], rate, np.array([seg.frequency]),
                        np.array([seg.noise]))
    if x0[0, 2] <= 0.0:
        raise MagciliaError(f"{name}: no free oscillation: the signal after the flick grows or "
                            f"holds (envelope decay rate {x0[0, 2]:.3g} 1/s); a ring-down "
                            "needs an oscillation that dies away")
    if second_mode:
        x0 = _with_second_mode(t, part, rate, x0)
    fit = rf.fit_damped(t, part[None, :], x0)
    x, cov = fit.x[0], fit.covariance[0]
    if not (x[2] > DECAY_SIGMAS * math.sqrt(max(cov[2, 2], 0.0))
            and math.isfinite(fit.noise[0])):
        raise MagciliaError(f"{name}: no free oscillation: the fitted decay rate is "
                            f"{x[2]:.3g} ± {math.sqrt(max(cov[2, 2], 0.0)):.2g} 1/s (growing, "
                            "or not decaying beyond its σ); a ring-down needs an oscillation "
                            "that dies away")
    f = _fitted(x, cov)
    if x.size == 9:
        _check_second_mode(name, x, cov)
    if f.frequency * after < rf.MIN_PERIODS:
        raise _too_short(name, f.frequency * after, after, f.frequency)
    extra: dict[str, Any] = {}
    if setup is not None:
        e, sigma, terms, zeta_model = _modulus_with_sigma(setup, f, flu, gravity, sizes)
        extra = {"youngs_modulus": e, "youngs_modulus_sigma": sigma, "modulus_terms": terms,
                 "model_damping_ratio": zeta_model}
    if x.size == 9:
        extra |= {"second_frequency": float(x[8]) / (2 * math.pi),
                  "second_decay_rate": float(x[7])}
    return RingdownResult(
        frequency=f.frequency, frequency_sigma=f.frequency_sigma, decay_rate=f.decay,
        decay_rate_sigma=f.decay_sigma, natural_frequency=f.natural,
        natural_frequency_sigma=f.natural_sigma, damping_ratio=f.zeta,
        damping_ratio_sigma=f.zeta_sigma, amplitude=float(math.hypot(x[0], x[1])),
        offset=float(x[4]), noise=float(fit.noise[0]), unit=unit, rate=rate,
        start=seg.start / rate, duration=(seg.stop - seg.start) / rate,
        samples=seg.stop - seg.start, fluid=_fluid_name(flu), source=name, **extra)


def _check_second_mode(name: str, x: F64, cov: F64) -> None:
    """Refuse a second mode that the data do not hold: its amplitude within 3σ of zero, or a
    decay that is not positive."""
    amp = math.hypot(x[5], x[6])
    g = np.array([x[5], x[6]]) / max(amp, 1e-300)
    sigma = math.sqrt(max(float(g @ cov[5:7, 5:7] @ g), 0.0))
    if not (amp > DECAY_SIGMAS * sigma and x[7] > 0.0):
        raise MagciliaError(f"{name}: no second mode in the ring-down (its fitted amplitude "
                            f"{amp:.3g} ± {sigma:.2g}, decay rate {x[7]:.3g} 1/s); fit one mode")


def _too_short(name: str, periods: float, after: float, frequency: float) -> MagciliaError:
    """The error for a record that ends too soon after the flick."""
    return MagciliaError(f"{name}: the record holds {periods:.2g} periods after the flick "
                         f"({after:.3g} s at {frequency:.4g} Hz); a ring-down needs at least "
                         f"{rf.MIN_PERIODS:g}: record longer after the flick")


def _with_second_mode(t: F64, y: F64, rate: float, x0: F64) -> F64:
    """Starts for two modes: the first's, and the spectral peak of its fit's residuals above
    :data:`SECOND_MODE_ABOVE` × the first frequency (a clamped hair's second mode lies 3–6×
    above the first; below it the residuals hold the sensor's 1/f noise), its decay from the
    residuals' envelope (else the first's, scaled with the frequency)."""
    one = rf.fit_damped(t, y[None, :], x0)
    rest = (y - rf.damped_model(t, one.x)[0][0])[None, :]
    above = SECOND_MODE_ABOVE * one.x[0, 3] / (2.0 * math.pi)
    second = rf.first_guess(t, rest + one.x[0, 4], rate, rf.spectral_peak(rest, rate, above))[0]
    if not second[2] > 0.0:
        second[2] = one.x[0, 2] * second[3] / one.x[0, 3]
    return np.concatenate([one.x, second[None, :4]], axis=1)


def ringdown_prior(path: str | Path) -> dict[str, tuple[float, float]]:
    """The modulus prior of a ring-down's JSON (``magcilia ringdown --json``, or
    ``RingdownResult.to_dict()`` written out): ``{"youngs_modulus": (E, σ)}``, Pa, as
    ``calibrate(..., priors=)`` takes them.

    Raises
    ------
    MagciliaError
        A file that is not such a JSON, or one without a modulus (read without a setup).
    """
    where = v.printable(str(path))
    try:
        text = Path(path).read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError) as exc:
        raise MagciliaError(f"{where}: cannot read the ring-down ({exc}); give the JSON that "
                            "magcilia ringdown --json printed") from None
    try:
        doc = json.loads(text)
    except json.JSONDecodeError as exc:
        raise MagciliaError(f"{where}: not JSON ({exc.msg} at line {exc.lineno}); give the "
                            "JSON that magcilia ringdown --json printed") from None
    if not isinstance(doc, dict) or doc.get("kind") != "ringdown":
        raise MagciliaError(f"{where}: not a ring-down result (no \"kind\": \"ringdown\"); "
                            "give the JSON that magcilia ringdown --json printed")
    prior = doc.get("prior")
    if not isinstance(prior, dict):
        raise MagciliaError(f"{where}: the ring-down has no modulus (it was read without "
                            "--setup); run magcilia ringdown again with the setup")
    numbers = [prior.get("value"), prior.get("sigma")]
    if prior.get("name") != "youngs_modulus" or not all(
            isinstance(x, int | float) and not isinstance(x, bool) and math.isfinite(x)
            and x > 0 for x in numbers):
        raise MagciliaError(f"{where}: the ring-down's prior must be youngs_modulus with a "
                            f"positive value and sigma in Pa; got {v.short(prior)}")
    value, sigma = (float(x) for x in numbers if isinstance(x, int | float))
    return {"youngs_modulus": (value, sigma)}
