"""The result of a ring-down (:func:`magcilia.analysis.ringdown.ringdown`): frequency, decay,
damping ratio and modulus with σ, and the modulus as a calibration prior."""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

from magcilia._display import Display, Item, number, si
from magcilia._errors import MagciliaError
from magcilia.calibration.experiments import Prior
from magcilia.device.parameters import PARAMETERS


@dataclass(frozen=True, eq=False, repr=False)
class RingdownResult(Display):
    """A ring-down: the free oscillation's frequency and decay, and the modulus they give.

    Attributes
    ----------
    frequency, frequency_sigma : float
        Damped frequency ``f_d`` and its 1 σ, Hz.
    decay_rate, decay_rate_sigma : float
        Decay rate ``γ`` of the envelope ``e^(−γt)`` and its 1 σ, 1/s.
    natural_frequency, natural_frequency_sigma : float
        ``f_n = √(f_d² + (γ/2π)²)`` (the undamped frequency, added mass included), Hz.
    damping_ratio, damping_ratio_sigma : float
        ``ζ = γ / (2π f_n)`` and its 1 σ (whatever damps it: the fluid and the material).
    amplitude, offset, noise : float
        The oscillation's amplitude at the segment's start, the rest level and the residuals'
        rms, in ``unit``.
    unit : str
        ``"V"`` (the output) or ``"T"`` (a field channel).
    rate : float
        Sample rate, Hz.
    start, duration : float
        The segment fitted: its start (from the record's first sample) and length, s.
    samples : int
        Samples fitted.
    youngs_modulus, youngs_modulus_sigma : float
        Pa (NaN without a setup).
    modulus_terms : dict of str to float
        1 σ contributions to ``youngs_modulus_sigma`` by source (``"frequency"``, ``"height"``,
        ``"base_radius"``, ``"tip_radius"``), Pa; they add in quadrature.
    fluid : str
        The fluid of the modal model (``"vacuum"`` without one).
    model_damping_ratio : float
        The first mode's damping ratio that the fluid alone gives at the fitted modulus (NaN
        without a setup or in vacuum): the measured ζ minus it is the material's share.
    second_frequency, second_decay_rate : float
        A second mode's damped frequency (Hz) and decay rate (1/s), where one was fitted (NaN).
    source : str
        The recording (file name) or ``"samples"``.
    """

    frequency: float
    frequency_sigma: float
    decay_rate: float
    decay_rate_sigma: float
    natural_frequency: float
    natural_frequency_sigma: float
    damping_ratio: float
    damping_ratio_sigma: float
    amplitude: float
    offset: float
    noise: float
    unit: str
    rate: float
    start: float
    duration: float
    samples: int
    youngs_modulus: float = math.nan
    youngs_modulus_sigma: float = math.nan
    modulus_terms: dict[str, float] = field(default_factory=dict)
    fluid: str = "vacuum"
    model_damping_ratio: float = math.nan
    second_frequency: float = math.nan
    second_decay_rate: float = math.nan
    source: str = "samples"

    @property
    def periods(self) -> float:
        """Periods of free oscillation fitted."""
        return self.duration * self.frequency

    @property
    def has_modulus(self) -> bool:
        """Whether a setup turned the frequency into a modulus."""
        return math.isfinite(self.youngs_modulus)

    @property
    def dominant(self) -> str:
        """The largest contribution to the modulus's σ (``"frequency"``, ``"height"``, …;
        ``""`` without a modulus)."""
        if not self.modulus_terms:
            return ""
        return max(self.modulus_terms, key=lambda k: self.modulus_terms[k])

    def prior(self) -> Prior:
        """The modulus as a Gaussian prior of the physical calibration
        (``calibrate(..., priors={p.name: (p.value, p.sigma)})`` or ``experiments + prior``).

        Raises
        ------
        MagciliaError
            Without a modulus (a ring-down read without a setup).
        """
        if not self.has_modulus:
            raise MagciliaError("this ring-down has no modulus (read without a setup); give the "
                                "setup (its size) to turn the frequency into a modulus")
        return Prior("youngs_modulus", self.youngs_modulus, self.youngs_modulus_sigma)

    def prior_option(self) -> str:
        """The ``magcilia calibrate`` option that carries :meth:`prior` (MPa):
        ``"--prior youngs_modulus=0.512:0.021"``."""
        p = self.prior()
        mpa = PARAMETERS["youngs_modulus"].display_factor
        return f"--prior youngs_modulus={p.value / mpa:.6g}:{p.sigma / mpa:.6g}"

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready content (SI); with a modulus also ``prior`` (name, value, sigma) and the
        ``calibrate`` option."""
        doc: dict[str, Any] = {
            "kind": "ringdown", "units": "SI", "source": self.source,
            "frequency_Hz": self.frequency, "frequency_sigma_Hz": self.frequency_sigma,
            "decay_rate_per_s": self.decay_rate, "decay_rate_sigma_per_s": self.decay_rate_sigma,
            "natural_frequency_Hz": self.natural_frequency,
            "natural_frequency_sigma_Hz": self.natural_frequency_sigma,
            "damping_ratio": self.damping_ratio, "damping_ratio_sigma": self.damping_ratio_sigma,
            "amplitude": self.amplitude, "offset": self.offset, "noise": self.noise,
            "unit": self.unit, "rate_Hz": self.rate, "start_s": self.start,
            "duration_s": self.duration, "samples": self.samples, "periods": self.periods,
            "fluid": self.fluid, "youngs_modulus_Pa": self.youngs_modulus,
            "youngs_modulus_sigma_Pa": self.youngs_modulus_sigma,
            "modulus_terms_Pa": dict(self.modulus_terms), "dominant": self.dominant,
            "model_damping_ratio": self.model_damping_ratio,
            "second_frequency_Hz": self.second_frequency,
            "second_decay_rate_per_s": self.second_decay_rate,
        }
        if self.has_modulus:
            p = self.prior()
            doc["prior"] = {"name": p.name, "value": p.value, "sigma": p.sigma}
            doc["calibrate_option"] = self.prior_option()
        return doc

    def report(self) -> str:
        """The ring-down for people: frequency, decay, damping ratio and modulus with σ (MPa)."""
        e = PARAMETERS["youngs_modulus"]
        lines = [
            (f"ring-down of {self.source}: {self.periods:.1f} periods over "
             f"{si(self.duration, 's')} from t = {si(self.start, 's')} ({self.samples} samples "
             f"at {self.rate:g} Hz; noise {si(self.noise, self.unit)})"),
            f"  damped frequency   {_pm(self.frequency, self.frequency_sigma)} Hz",
            f"  decay rate         {_pm(self.decay_rate, self.decay_rate_sigma)} 1/s",
            f"  natural frequency  {_pm(self.natural_frequency, self.natural_frequency_sigma)} Hz",
            f"  damping ratio      {_pm(self.damping_ratio, self.damping_ratio_sigma)}",
        ]
        if math.isfinite(self.second_frequency):
            lines.append(f"  second mode        {number(self.second_frequency, 4)} Hz, decay "
                         f"{number(self.second_decay_rate, 3)} 1/s")
        if self.has_modulus:
            f = e.display_factor
            modulus = _pm(self.youngs_modulus / f, self.youngs_modulus_sigma / f)
            lines.append(f"  Young's modulus    {modulus} {e.display} "
                         f"({self.youngs_modulus:.6g} Pa; {self.fluid})")
            terms = ", ".join(f"{k} {number(100 * s / self.youngs_modulus, 2)} %"
                              for k, s in sorted(self.modulus_terms.items(),
                                                 key=lambda kv: -kv[1]))
            lines.append(f"  σ of the modulus   {terms} (dominant: {self.dominant})")
            if math.isfinite(self.model_damping_ratio):
                lines.append(f"  the {self.fluid} alone damps ζ = "
                             f"{number(self.model_damping_ratio, 3)} at this modulus")
            lines.append(f"  as a calibration prior: {self.prior_option()}")
        else:
            lines.append("  Young's modulus    - (give the setup: its size turns the frequency "
                         "into a modulus)")
        return "\n".join(lines)

    def _display_items(self) -> list[Item]:
        items = [("f_d", f"{number(self.frequency, 4)} Hz"),
                 ("zeta", _pm(self.damping_ratio, self.damping_ratio_sigma))]
        if self.has_modulus:
            items.insert(0, ("E", PARAMETERS["youngs_modulus"].text(self.youngs_modulus)
                             + " ± " + PARAMETERS["youngs_modulus"].text(self.youngs_modulus_sigma,
                                                                          2)))
        return [*items, ("periods", number(self.periods, 3)), ("source", self.source)]


def _pm(value: float, sigma: float) -> str:
    """``value ± sigma`` with the value's digits following the σ's (two significant)."""
    if not (math.isfinite(sigma) and sigma > 0 and math.isfinite(value)):
        return number(value, 4)
    digits = max(0, 1 - math.floor(math.log10(sigma)))
    return f"{value:.{digits}f} ± {sigma:.{digits}f}"
