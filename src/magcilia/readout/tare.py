"""Tare: the unloaded baseline of a read-out, one class for every read-out: :meth:`Readout.tare
<magcilia.Readout.tare>`, the force vector's and the array's ``tare``, the ``--tare`` option of
``magcilia readout`` and the live read-out (:mod:`magcilia.live.zero`).

A tare takes the mean of readings taken with the cilium unloaded (upright, no force, no flow) as
the sensor's zero: from then on every reading gets the correction ``rest − mean`` added, where
``rest`` is the model's reading at rest (angle 0, force 0, flow 0). The earth's and the lab's
fields, the bridge offset and the amplifier's offset cancel, as a force gauge's or a magnetic
skin's *zero* does. The spread of the baseline is the measured noise of one reading (sensor,
amplifier and ADC together), and the uncertainty of its mean (the standard error, spread / √n for
independent readings; larger with 1/f noise or drift over the baseline) is an error shared by all
readings of the tared read-out.

One channel (a single output, V) holds floats; several channels (a 3-axis sensor's or an array's
field readings, T) hold arrays of shape (c,), one entry per channel.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from magcilia import _validate as v
from magcilia._display import Display, Item, scaled, si
from magcilia._errors import MagciliaError

F64 = NDArray[np.float64]


@dataclass(frozen=True, eq=False, repr=False)
class Tare(Display):
    """A zero-load baseline (immutable; SI).

    Attributes
    ----------
    rest : float or ndarray, shape (c,)
        The model's reading at rest (quantity 0), per channel, in ``unit``.
    mean : float or ndarray, shape (c,)
        Mean of the baseline's finite readings, ``unit``.
    noise : float or ndarray, shape (c,)
        Their standard deviation (``ddof=1``): the noise RMS of one reading, ``unit``.
    count : int or ndarray of int, shape (c,)
        Finite readings in the baseline (≥ 2 per channel).
    unit : str
        ``"V"`` (a sensor output) or ``"T"`` (field channels).
    names : tuple of str
        The channels' names (() for one channel).

    Examples
    --------
    >>> t = Tare.from_readings([1.0e-3, 1.2e-3, 1.1e-3, 0.9e-3], rest=1.0e-3)
    >>> round(t.correction * 1e6, 6), t.count
    (-50.0, 4)
    >>> t3 = Tare.from_readings([[1e-5, 0.0], [3e-5, 2e-6]], rest=[2e-5, 0.0], unit="T")
    >>> t3.correction.tolist(), t3.count.tolist()
    ([0.0, -1e-06], [2, 2])
    """

    rest: Any
    mean: Any
    noise: Any
    count: Any
    unit: str = "V"
    names: tuple[str, ...] = ()

    @classmethod
    def from_readings(cls, readings: ArrayLike, rest: ArrayLike, *, unit: str = "V",
                      names: tuple[str, ...] = ()) -> Tare:
        """The tare of unloaded ``readings`` for a model whose reading at rest is ``rest``.

        Parameters
        ----------
        readings : array-like
            One channel (``rest`` a number): readings of any shape, all of that channel. Several
            channels (``rest`` of shape (c,)): shape (..., c). NaN readings are skipped.
        rest : float or array-like, shape (c,)
            The model's reading at rest per channel, ``unit``.
        unit : str
            The readings' unit (``"V"`` or ``"T"``).
        names : tuple of str
            Channel names for messages and reports (default ``channel 0`` …).

        Raises
        ------
        MagciliaError
            If a channel has fewer than two finite readings, or (several channels) a channel's
            readings do not vary (noise 0: quantised below the LSB).
        """
        if np.ndim(rest) == 0:
            x = np.asarray(readings, dtype=np.float64).reshape(-1)
            good = x[np.isfinite(x)]
            if good.size < 2:
                raise MagciliaError(f"tare needs at least 2 finite readings; got {good.size}")
            return cls(rest=v.real("rest", rest, unit), mean=float(good.mean()),
                       noise=float(good.std(ddof=1)), count=int(good.size), unit=unit,
                       names=names)
        r = np.asarray(rest, dtype=np.float64).reshape(-1)
        given = np.asarray(readings, dtype=np.float64)
        if given.ndim < 1 or given.shape[-1] != r.size:
            raise MagciliaError(f"tare readings must have shape (..., {r.size}), one column per "
                                f"channel; got shape {given.shape}")
        table = given.reshape(-1, r.size)
        label = names or tuple(f"channel {i}" for i in range(r.size))
        good = np.isfinite(table)
        count = good.sum(axis=0)
        if np.any(count < 2):
            ch = int(np.argmax(count < 2))
            raise MagciliaError(f"tare needs at least 2 finite readings per channel; got "
                                f"{int(count[ch])} for {label[ch]}")
        mean = np.where(good, table, 0.0).sum(axis=0) / count
        noise = np.sqrt((np.where(good, table - mean, 0.0) ** 2).sum(axis=0) / (count - 1))
        if np.any(noise <= 0.0):
            ch = int(np.argmax(noise <= 0.0))
            raise MagciliaError(f"tare needs readings that vary (noise > 0) on every channel; "
                                f"{label[ch]} is constant: quantised below its LSB?")
        return cls(rest=r, mean=mean, noise=noise, count=count.astype(np.int64), unit=unit,
                   names=names)

    @property
    def channels(self) -> int:
        """Number of channels (1 for a single output)."""
        return int(np.size(self.rest))

    @property
    def correction(self) -> Any:
        """What is added to every reading, ``unit`` (float, or (c,)): ``rest − mean``."""
        return self.rest - self.mean

    @property
    def standard_error(self) -> Any:
        """Uncertainty of each baseline mean, ``unit`` (float, or (c,)): ``noise / √count``, an
        error shared by all readings."""
        if np.ndim(self.rest) == 0:
            return self.noise / math.sqrt(self.count)
        return np.asarray(self.noise / np.sqrt(self.count))

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready content (SI)."""
        def plain(a: Any) -> Any:
            return np.asarray(a).tolist()
        out = {"rest": plain(self.rest), "mean": plain(self.mean), "noise": plain(self.noise),
               "count": plain(self.count), "correction": plain(self.correction),
               "standard_error": plain(self.standard_error), "unit": self.unit, "units": "SI"}
        if self.names:
            out["names"] = list(self.names)
        return out

    def _text(self, value: float) -> str:
        if self.unit == "T":
            return scaled(value, 1e-4, "G", 4)
        return si(value, self.unit, 4)

    def report(self) -> str:
        """One line: the zero, its correction and uncertainty, the noise of one reading."""
        if np.ndim(self.rest) == 0:
            return (f"tare: zero at {self.mean * 1e3:.6g} mV from {self.count} readings "
                    f"(correction {self.correction * 1e3:+.4g} mV ± "
                    f"{self.standard_error * 1e6:.3g} µV; noise {self.noise * 1e6:.3g} µV per "
                    f"reading)") if self.unit == "V" else (
                    f"tare: zero at {self._text(self.mean)} from {self.count} readings "
                    f"(correction {self._text(self.correction)} ± "
                    f"{self._text(self.standard_error)}; noise {self._text(self.noise)} per "
                    f"reading)")
        corr = ", ".join(self._text(c) for c in self.correction)
        noise = ", ".join(self._text(n) for n in self.noise)
        return (f"tare: {int(np.min(self.count))}+ readings per channel; corrections {corr}; "
                f"noise {noise} per reading")

    # -- display --------------------------------------------------------------------------------
    def _display_items(self) -> list[Item]:
        if np.ndim(self.rest) == 0:
            return [("readings", str(self.count)), ("correction", si(self.correction, self.unit)),
                    ("± s.e.", si(self.standard_error, self.unit)),
                    ("noise", si(self.noise, self.unit))]
        return [("channels", str(self.channels)), ("readings", str(int(np.min(self.count)))),
                ("max |correction|", self._text(float(np.max(np.abs(self.correction)))))]


ChannelTare = Tare
"""The per-channel tare's former name: one class now, :class:`Tare` holding arrays."""
