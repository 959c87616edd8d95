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

**Rest check.** A tare is only as good as the rest it was taken at: a window that holds a load
step or a load being applied has more spread and a trend. :func:`rest_check` (and every
:meth:`Tare.from_readings`, as :attr:`Tare.check`) compares each channel's window with the rest:

* *noise*: the spread of the readings (``std``) against the rest noise — the larger of the
  expected noise (the sensor model's over the window's bandwidth, or the previous tare's) and the
  window's own white noise (:func:`difference_noise`, unmoved by a step or a slow signal): not at
  rest beyond :data:`NOISE_RATIO` times it (or beyond 5 of the spread's own standard errors,
  ``1/√(2(n−1))``, for short windows). A step of height h in the window raises the spread to
  about h/2: a step of 3 noise σ is caught, and the load step of the simulation (24× the noise)
  by far;
* *trend*: the change over the window of a straight line fitted to the readings (slope × window
  length) against its standard error (``√12 σ/√n`` for white noise σ, i.e. 3.5 standard errors
  of the mean): not at rest beyond :data:`TREND_SIGMAS` of them.

The thresholds leave a window of white noise at rest refused about once in a million and a
window of the simulated bench (white and 1/f noise, drift) about never
(``tests/readout/test_tare_rest.py``); what to do with a tare that is not at rest (refuse it, or
keep it and flag ``TARE_UNDER_LOAD``) is the caller's choice: :attr:`Tare.at_rest` says which.
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

#: a tare window is not at rest when its spread exceeds the rest noise by this factor
NOISE_RATIO = 1.5
#: … or when a line fitted to it changes by more than this many of its standard errors
TREND_SIGMAS = 5.0
#: … or (short windows) when its spread exceeds the rest noise by this many standard errors of
#: a spread, 1/√(2(n−1)) of it
SPREAD_SIGMAS = 5.0


def difference_noise(readings: ArrayLike) -> Any:
    """Noise RMS of one reading from the spread of successive differences, in the readings'
    unit (NaN with fewer than 3 finite readings); readings (t, c) of several channels give one
    per channel, an array (c,).

    ``1.4826 · MAD(diff(readings)) / √2``: for white noise the standard deviation, unmoved by a
    slowly changing signal and by the few differences that straddle a step. What it misses is
    noise slower than the readings' spacing (1/f), which the sensor model's noise includes.

    Parameters
    ----------
    readings : array-like, shape (t,) or (t, c)
        Consecutive readings (V, T, …).
    """
    if np.ndim(readings) == 2:
        return np.array([difference_noise(col) for col in np.asarray(readings).T])
    x = np.asarray(readings, dtype=np.float64).reshape(-1)
    d = np.diff(x[np.isfinite(x)])
    if d.size < 2:
        return math.nan
    return float(1.4826 * np.median(np.abs(d - np.median(d))) / math.sqrt(2.0))


def _plain(a: Any) -> Any:
    """A float or an array as JSON-ready Python (a number or nested lists)."""
    return np.asarray(a).tolist()


@dataclass(frozen=True, eq=False, repr=False)
class RestCheck(Display):
    """Whether a tare's window was at rest, per channel (immutable; see the module docstring).

    Attributes
    ----------
    noise : float or ndarray, shape (c,)
        Spread (``std``, ddof=1) of the window's readings, ``unit``.
    reference : float or ndarray, shape (c,)
        The rest noise it is compared with: the larger of the expected noise and the window's
        white noise (:func:`difference_noise`), ``unit``.
    trend : float or ndarray, shape (c,)
        Change over the window of a straight line fitted to it, ``unit``.
    trend_sigma : float or ndarray, shape (c,)
        Standard error of ``trend`` (from the residuals' spread), ``unit``.
    count : int
        Readings in the window (the fewest finite of a channel).
    unit : str
        ``"V"`` or ``"T"``.
    noise_limit : float
        The largest ``noise / reference`` at rest (:data:`NOISE_RATIO`, more for short windows).
    names : tuple of str
        The channels' names (() for one channel).
    """

    noise: Any
    reference: Any
    trend: Any
    trend_sigma: Any
    count: int
    unit: str = "V"
    noise_limit: float = NOISE_RATIO
    names: tuple[str, ...] = ()

    @property
    def noisy(self) -> NDArray[np.bool_]:
        """Per channel: spread beyond the rest noise, shape (c,) ((1,) for one channel)."""
        return np.atleast_1d(np.asarray(self.noise) > self.noise_limit
                             * np.asarray(self.reference))

    @property
    def trending(self) -> NDArray[np.bool_]:
        """Per channel: a trend beyond :data:`TREND_SIGMAS` of its standard errors."""
        return np.atleast_1d(np.abs(np.asarray(self.trend)) > TREND_SIGMAS
                             * np.asarray(self.trend_sigma))

    @property
    def at_rest(self) -> bool:
        """Whether every channel's window was at rest."""
        return not bool(np.any(self.noisy) or np.any(self.trending))

    @property
    def reason(self) -> str:
        """Why the window was not at rest, one line ("" when it was)."""
        if self.at_rest:
            return ""
        noise = np.atleast_1d(np.asarray(self.noise, dtype=np.float64))
        ref = np.atleast_1d(np.asarray(self.reference, dtype=np.float64))
        trend = np.atleast_1d(np.asarray(self.trend, dtype=np.float64))
        label = self.names or (("",) if noise.size == 1 else
                               tuple(f"channel {i}" for i in range(noise.size)))
        noisy, trending = self.noisy, self.trending
        ratio = np.where(ref > 0, noise / np.where(ref > 0, ref, 1.0), np.inf)
        i = int(np.argmax(np.where(noisy | trending, ratio, -np.inf)))
        where = f" on {label[i]}" if label[i] else ""
        parts = []
        if noisy[i]:
            parts.append(f"noise {self._text(noise[i])} per reading, {ratio[i]:.3g}× the rest "
                         f"noise {self._text(ref[i])}")
        if trending[i]:
            parts.append(f"a trend of {self._text(trend[i])} over the window")
        more = int(np.count_nonzero(noisy | trending)) - 1
        return ("the window was not at rest" + where + " (" + "; ".join(parts) + ")"
                + (f" and on {more} more channel{'s' if more > 1 else ''}" if more > 0 else ""))

    def _text(self, value: float) -> str:
        return scaled(value, 1e-4, "G", 3) if self.unit == "T" else si(value, self.unit, 3)

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready content (SI)."""
        return {"at_rest": self.at_rest, "noise": _plain(self.noise),
                "reference": _plain(self.reference), "trend": _plain(self.trend),
                "trend_sigma": _plain(self.trend_sigma), "count": self.count, "unit": self.unit,
                "noise_limit": self.noise_limit, "trend_sigmas": TREND_SIGMAS,
                "reason": self.reason, "units": "SI"}

    def report(self) -> str:
        """One line: at rest, or why not."""
        if self.at_rest:
            return (f"tare window at rest ({self.count} readings: spread within "
                    f"{self.noise_limit:.3g}× the rest noise, no trend beyond {TREND_SIGMAS:g} σ)")
        return f"tare window not at rest: {self.reason}"

    # -- display --------------------------------------------------------------------------------
    def _display_items(self) -> list[Item]:
        with np.errstate(divide="ignore", invalid="ignore"):
            ratio = float(np.max(np.asarray(self.noise) / np.asarray(self.reference)))
        items = [("", "at rest" if self.at_rest else "not at rest"),
                 ("readings", str(self.count)), ("max noise ratio", f"{ratio:.3g}")]
        if not self.at_rest:
            items.append(("why", self.reason))
        return items


def rest_check(readings: ArrayLike, expected_noise: ArrayLike | None = None, *, unit: str = "V",
               names: tuple[str, ...] = ()) -> RestCheck:
    """Whether a tare's window was at rest (see the module docstring).

    Parameters
    ----------
    readings : array-like, shape (t,) or (t, c)
        The window's readings in time order, evenly spaced (one channel, or c channels).
    expected_noise : float or array-like, shape (c,), optional
        The noise RMS of one reading at rest, ``unit``: the sensor model's over the window's
        bandwidth, or the previous tare's. Default: the window's own white noise only.
    unit : str
        The readings' unit (``"V"`` or ``"T"``).
    names : tuple of str
        Channel names for the reason.

    Examples
    --------
    >>> rng = np.random.default_rng(0)
    >>> quiet = rng.normal(0.0, 1e-5, 500)
    >>> rest_check(quiet, 1e-5).at_rest
    True
    >>> step = quiet + np.where(np.arange(500) < 250, 0.0, 2e-4)  # a load step in the window
    >>> c = rest_check(step, 1e-5)
    >>> c.at_rest, c.reason.startswith("the window was not at rest (noise 100 µV")
    (False, True)
    """
    x = np.asarray(readings, dtype=np.float64)
    one = x.ndim <= 1
    table = x.reshape(-1, 1) if one else x.reshape(-1, x.shape[-1])
    c = table.shape[1]
    expected = (np.zeros(c) if expected_noise is None else
                np.broadcast_to(np.asarray(expected_noise, dtype=np.float64).reshape(-1), (c,)))
    noise, ref, trend, trend_sigma = (np.full(c, math.nan) for _ in range(4))
    counts = np.zeros(c, dtype=np.int64)
    for j in range(c):
        col = table[:, j]
        good = np.isfinite(col)
        y, t = col[good], np.arange(col.size, dtype=np.float64)[good]
        counts[j] = y.size
        if y.size < 3:
            continue
        noise[j] = float(y.std(ddof=1))
        white = difference_noise(y)
        ref[j] = max(float(expected[j]), white if math.isfinite(white) else 0.0)
        tc = t - t.mean()
        sxx = float(tc @ tc)
        slope = float(tc @ (y - y.mean())) / sxx
        resid = y - y.mean() - slope * tc
        length = float(t[-1] - t[0])
        trend[j] = slope * length
        trend_sigma[j] = float(np.sqrt(resid @ resid / max(y.size - 2, 1) / sxx)) * length
    n = int(counts.min()) if counts.size else 0
    limit = max(NOISE_RATIO, 1.0 + SPREAD_SIGMAS / math.sqrt(2.0 * max(n - 1, 1)))

    def shaped(a: F64) -> Any:
        return float(a[0]) if one else a
    return RestCheck(noise=shaped(noise), reference=shaped(ref), trend=shaped(trend),
                     trend_sigma=shaped(trend_sigma), count=n, unit=unit, noise_limit=limit,
                     names=names)


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
    check : RestCheck or None
        Whether the baseline's window was at rest (:func:`rest_check`; None: not checked).

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
    check: RestCheck | None = None

    @classmethod
    def from_readings(cls, readings: ArrayLike, rest: ArrayLike, *, unit: str = "V",
                      names: tuple[str, ...] = (),
                      expected_noise: ArrayLike | None = None) -> Tare:
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
        expected_noise : float or array-like, shape (c,), optional
            Noise RMS of one reading at rest, ``unit`` (the sensor model's over the readings'
            bandwidth, or the previous tare's): what the rest check (:attr:`check`) compares
            the spread with, beside the readings' own white noise.

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
                       names=names, check=rest_check(x, expected_noise, unit=unit, names=names))
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
                   names=names, check=rest_check(table, expected_noise, unit=unit, names=label))

    @property
    def at_rest(self) -> bool:
        """Whether the baseline's window was at rest (True when it was not checked)."""
        return self.check is None or self.check.at_rest

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
        out = {"rest": _plain(self.rest), "mean": _plain(self.mean), "noise": _plain(self.noise),
               "count": _plain(self.count), "correction": _plain(self.correction),
               "standard_error": _plain(self.standard_error), "unit": self.unit, "units": "SI"}
        if self.names:
            out["names"] = list(self.names)
        if self.check is not None:
            out["at_rest"] = self.check.at_rest
            out["rest_check"] = self.check.to_dict()
        return out

    def _text(self, value: float) -> str:
        if self.unit == "T":
            return scaled(value, 1e-4, "G", 4)
        return si(value, self.unit, 4)

    def report(self) -> str:
        """One line: the zero, its correction and uncertainty, the noise of one reading."""
        if np.ndim(self.rest) == 0:
            if self.unit == "V":
                zero, corr, error, noise = (f"{self.mean * 1e3:.6g} mV",
                                            f"{self.correction * 1e3:+.4g} mV",
                                            f"{self.standard_error * 1e6:.3g} µV",
                                            f"{self.noise * 1e6:.3g} µV")
            else:
                zero, corr, error, noise = (self._text(x) for x in (
                    self.mean, self.correction, self.standard_error, self.noise))
            return (f"tare: zero at {zero} from {self.count} readings (correction {corr} ± "
                    f"{error}; noise {noise} per reading){self._rest_note()}")
        corr = ", ".join(self._text(c) for c in self.correction)
        noise = ", ".join(self._text(n) for n in self.noise)
        return (f"tare: {int(np.min(self.count))}+ readings per channel; corrections {corr}; "
                f"noise {noise} per reading{self._rest_note()}")

    def _rest_note(self) -> str:
        return "" if self.at_rest or self.check is None else f"; NOT AT REST: {self.check.reason}"

    # -- display --------------------------------------------------------------------------------
    def _display_items(self) -> list[Item]:
        if np.ndim(self.rest) == 0:
            return [("readings", str(self.count)), ("correction", si(self.correction, self.unit)),
                    ("± s.e.", si(self.standard_error, self.unit)),
                    ("noise", si(self.noise, self.unit))] + (
                        [] if self.at_rest else [("", "NOT AT REST")])
        return [("channels", str(self.channels)), ("readings", str(int(np.min(self.count)))),
                ("max |correction|", self._text(float(np.max(np.abs(self.correction)))))]


ChannelTare = Tare
"""The per-channel tare's former name: one class now, :class:`Tare` holding arrays."""
