"""Tare: the unloaded baseline of a read-out, shared by :meth:`magcilia.Readout.tare`, the
``--tare`` option of ``magcilia readout`` and the live read-out (:mod:`magcilia.live.zero`).

A tare takes the mean of readings taken with the cilium unloaded (upright, no force, no flow) as
the sensor's zero: from then on every reading gets the correction ``V_rest − mean`` added, where
``V_rest`` is the model's output at rest (angle 0, force 0, flow 0). The earth's and the lab's
fields, the bridge offset and the amplifier's offset cancel, as a force gauge's or a magnetic
skin's *zero* does. The spread of the baseline is the measured noise of one reading (sensor,
amplifier and ADC together), and the uncertainty of its mean (the standard error, spread / √n for
independent readings; larger with 1/f noise or drift over the baseline) is an error shared by all
readings of the tared read-out.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import ArrayLike

from magcilia import _validate as v
from magcilia._display import Display, Item, si
from magcilia._errors import MagciliaError


@dataclass(frozen=True, repr=False)
class Tare(Display):
    """A zero-load baseline (immutable; SI).

    Attributes
    ----------
    rest : float
        The model's output at rest (quantity 0), V.
    mean : float
        Mean of the baseline's finite readings, V.
    noise : float
        Their standard deviation (``ddof=1``): the noise RMS of one reading, V.
    count : int
        Finite readings in the baseline (≥ 2).

    Examples
    --------
    >>> t = Tare.from_readings([1.0e-3, 1.2e-3, 1.1e-3, 0.9e-3], rest=1.0e-3)
    >>> round(t.correction * 1e6, 6), t.count
    (-50.0, 4)
    """

    rest: float
    mean: float
    noise: float
    count: int

    @classmethod
    def from_readings(cls, volts: ArrayLike, rest: float) -> Tare:
        """The tare of unloaded readings ``volts`` (V, any shape; NaN readings are skipped) for a
        model whose output at rest is ``rest`` (V).

        Raises
        ------
        MagciliaError
            If fewer than two finite readings were given.
        """
        x = np.asarray(volts, dtype=np.float64).reshape(-1)
        good = x[np.isfinite(x)]
        if good.size < 2:
            raise MagciliaError(f"tare needs at least 2 finite readings; got {good.size}")
        return cls(rest=v.real("rest", rest, "V"), mean=float(good.mean()),
                   noise=float(good.std(ddof=1)), count=int(good.size))

    @property
    def correction(self) -> float:
        """What is added to every reading, V: ``rest − mean``."""
        return self.rest - self.mean

    @property
    def standard_error(self) -> float:
        """Uncertainty of the baseline mean, V: ``noise / √count``."""
        return self.noise / math.sqrt(self.count)

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready content (SI: volts)."""
        return {"rest": self.rest, "mean": self.mean, "noise": self.noise, "count": self.count,
                "correction": self.correction, "standard_error": self.standard_error,
                "units": "SI"}

    def report(self) -> str:
        """One line: the zero, its correction and uncertainty, the noise of one reading."""
        return (f"tare: zero at {self.mean * 1e3:.6g} mV from {self.count} readings (correction "
                f"{self.correction * 1e3:+.4g} mV ± {self.standard_error * 1e6:.3g} µV; noise "
                f"{self.noise * 1e6:.3g} µV per reading)")

    # -- display --------------------------------------------------------------------------------
    def _display_items(self) -> list[Item]:
        return [("readings", str(self.count)), ("correction", si(self.correction, "V")),
                ("± s.e.", si(self.standard_error, "V")), ("noise", si(self.noise, "V"))]
