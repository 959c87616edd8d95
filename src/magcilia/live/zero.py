"""Tare and zero tracking: the unloaded baseline of a live read-out, per channel.

**Tare** captures the unloaded reading (the mean of a few tenths of a second of readings) and
from then on adds the correction ``rest − baseline`` to every reading, where ``rest`` is the
model's reading with the cilium at rest (upright, no force, no flow): the earth's and the lab's
fields, the bridge offset and the amplifier's offset all cancel, as a force gauge's or a magnetic
skin's *zero* does. The spread of the tare readings is the measured noise of one reading (all of
it: sensor, amplifier, ADC), which the read-out then uses for σ instead of the sensor's datasheet
noise. One channel (a single output, V) holds floats; several (a 3-axis sensor's or an array's
field channels, T) hold arrays of shape (c,).

**A tare under load** (the cilium pushed while the window was taken) is found by the rest check
of :class:`~magcilia.readout.tare.Tare` (noise beyond the rest noise, or a trend: see
:func:`~magcilia.readout.tare.rest_check`). What happens then:

* with a good tare in use, the new one is **refused**: the good one stays (zero tracking has kept
  it current, so nothing is lost by keeping it), and :attr:`Zero.notice` says why — one line the
  views show as the status message;
* without one (the first tare, e.g. at start while the simulation or a hand already pushes), it is
  **kept and flagged**: every estimate carries ``Flag.TARE_UNDER_LOAD`` until a tare at rest,
  since an untared read-out would be off by the whole bias and say nothing.

**Zero tracking** (load cells' *automatic zero tracking*, made to follow a ramp): after a tare,
each batch of readings whose mean lies within ``band`` standard errors of the *predicted* zero
(the noise of one reading over √batch, and the prediction's own σ) counts as rest. A straight
line, zero + drift rate × time, is fitted per channel by least squares to the rest readings, the
older ones forgotten with time constant ``tau`` (exponential weights, updated in place: no
history is kept). At rest the correction follows the line's value now, so a steady drift (the
simulation's 0.2 µV/s; a temperature ramp) is followed without lag; while the cilium is loaded
the correction holds its last rest value (what the zero did meanwhile is not seen: σ says how
much it may have moved, below), and the rest band is drawn around the line's prediction, so rest
is recognised again after a long load. A load that stands out of the noise is never
tracked away; one applied more slowly than ``tau`` and within the band would be (as in any zero
tracking); ``tau=None`` switches tracking off.

**σ of the zero** (:attr:`Zero.sigma`): the fit's standard error of the zero now (from the noise
of one reading, through the weights: grows while no rest comes, through the rate's uncertainty),
and the drift not yet tracked, ``|rate| × (time since the last rest)``, in quadrature. The
read-out adds it to each reading's noise (:meth:`Zero.total_noise`). When it exceeds
``drift_limit`` times the noise of one reading (the load never returns to rest, or the drift is
too fast or too irregular to follow) the estimates are flagged ``Flag.ZERO_DRIFT``
(:attr:`Zero.flags`).
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from magcilia import _validate as v
from magcilia._errors import MagciliaError
from magcilia.readout.protocol import Flag
from magcilia.readout.tare import Tare, difference_noise

F64 = NDArray[np.float64]

# difference_noise lives in readout.tare; it stays importable from here for earlier code
__all__ = ["Zero", "difference_noise"]

#: the running sums of the fit, per channel: weights, Σw·τ, Σw·τ², Σw·y, Σw·τ·y, and the
#: sandwich's Σw²/n, Σw²/n·τ, Σw²/n·τ² (τ: time before the last update, y: reading − y0)
_SUMS = ("w", "wt", "wtt", "wy", "wty", "u", "ut", "utt")


class Zero:
    """The baseline state of a live read-out (see the module docstring).

    Parameters
    ----------
    rest : float or array-like, shape (c,)
        The model's reading at rest per channel, ``unit``.
    tau : float or None
        Zero-tracking memory, s: the time constant with which older rest readings are forgotten
        (None: no tracking).
    band : float
        Tracking band, in standard errors of a batch mean.
    drift_limit : float
        ``Flag.ZERO_DRIFT`` when the zero's σ exceeds this many noise σ of one reading.
    unit : str
        ``"V"`` (one output) or ``"T"`` (field channels).
    names : tuple of str
        Channel names for messages.

    Attributes
    ----------
    correction : float or ndarray, shape (c,)
        What is added to each reading, ``unit`` (0 before the first tare).
    noise : float or ndarray or None
        Measured noise RMS of one reading at the tare in use, ``unit`` (None before one).
    drift : float or ndarray
        Change of the correction by zero tracking since that tare, ``unit``.
    tared_at : float or None
        Time of that tare, s (the read-out's clock).
    baseline : Tare or None
        That tare.
    under_load : bool
        Whether that tare's window was not at rest (its estimates flagged TARE_UNDER_LOAD).
    notice : str
        What the last tare request came to, one line ("" for a good tare).

    Examples
    --------
    >>> rng = np.random.default_rng(0)
    >>> zero = Zero(rest=0.0, tau=10.0)
    >>> zero.tare(rng.normal(0.0, 1e-5, 500), at=0.5, dt=1e-3)
    True
    >>> t = 0.5
    >>> for _ in range(200):   # 20 s of rest readings drifting at 1 µV/s
    ...     t += 0.1
    ...     zero.track(1e-6 * t + rng.normal(0.0, 1e-5, 100), 1e-3, at=t)
    >>> abs(zero.correction + 1e-6 * t) < 3 * zero.sigma, round(zero.rate * 1e6, 1)
    (True, 1.0)
    """

    def __init__(self, rest: ArrayLike, tau: float | None = 30.0, band: float = 3.0,
                 drift_limit: float = 1.0, unit: str = "V", names: tuple[str, ...] = ()) -> None:
        self.scalar = np.ndim(rest) == 0
        self._rest = (np.array([v.real("rest", rest, unit)]) if self.scalar else
                      np.asarray(rest, dtype=np.float64).reshape(-1).copy())
        if not np.isfinite(self._rest).all():
            raise v.fail("rest", rest, f"finite readings at rest, {unit}")
        self.tau = None if tau is None else v.positive("tau", tau, "s", "time constant")
        self.band = v.positive("band", band, "σ", "band")
        self.drift_limit = v.positive("drift_limit", drift_limit, "σ", "limit")
        self.unit, self.names = unit, tuple(names)
        c = self._rest.size
        self._correction = np.zeros(c)
        self._tare_correction = np.zeros(c)
        self._noise: F64 | None = None
        self.tared_at: float | None = None
        self.baseline: Tare | None = None
        self.under_load = False
        self.notice = ""
        self._now = 0.0
        self._y0 = np.zeros(c)
        self._sums = {k: np.zeros(c) for k in _SUMS}
        self._rested_at = np.zeros(c)
        self._cached: tuple[F64, F64, F64, F64, F64] | None = None

    # -- what the read-out uses -----------------------------------------------------------------
    def _out(self, a: F64) -> Any:
        return float(a[0]) if self.scalar else a.copy()

    @property
    def rest(self) -> Any:
        """The model's reading at rest, ``unit`` (float, or (c,))."""
        return self._out(self._rest)

    @property
    def channels(self) -> int:
        """Number of channels."""
        return int(self._rest.size)

    @property
    def correction(self) -> Any:
        """What is added to each reading now, ``unit`` (float, or (c,))."""
        return self._out(self._correction)

    @property
    def noise(self) -> Any:
        """Noise RMS of one reading measured at the tare in use (None before one)."""
        return None if self._noise is None else self._out(self._noise)

    @property
    def drift(self) -> Any:
        """Change of the correction by zero tracking since the tare in use, ``unit``."""
        return self._out(self._correction - self._tare_correction)

    def _fit(self) -> tuple[F64, F64, F64, F64]:
        """Per channel: the zero now (relative to y0), the drift rate, and their variances per
        unit noise variance (the sandwich of the exponentially weighted fit); kept until the
        sums change."""
        if self._cached is None:
            self._cached = self._solve()
        a, b, var_a, var_b, _ = self._cached
        return a, b, var_a, var_b

    def _solve(self) -> tuple[F64, F64, F64, F64, F64]:
        w, wt, wtt, wy, wty, u, ut, utt = (self._sums[k] for k in _SUMS)
        det = w * wtt - wt * wt
        ok = det > 1e-12 * (w * wtt)
        with np.errstate(divide="ignore", invalid="ignore"):
            inv = np.where(ok, 1.0 / np.where(ok, det, 1.0), 0.0)
            a = (wtt * wy - wt * wty) * inv
            b = (w * wty - wt * wy) * inv
            # Cov / σ² = A⁻¹ U A⁻¹, A = [[w, wt], [wt, wtt]], A⁻¹ = [[wtt, −wt], [−wt, w]] / det
            i00, i01, i11 = wtt * inv, -wt * inv, w * inv
            var_a = i00 * i00 * u + 2.0 * i00 * i01 * ut + i01 * i01 * utt
            var_b = i01 * i01 * u + 2.0 * i01 * i11 * ut + i11 * i11 * utt
            cov = i00 * i01 * u + (i00 * i11 + i01 * i01) * ut + i01 * i11 * utt
            if not ok.all():  # one time only (the tare's readings at one instant): no rate
                safe = np.where(w > 0, w, 1.0)
                a = np.where(ok, a, wy / safe)
                var_a = np.where(ok, var_a, u / safe ** 2)
        return a, b, var_a, var_b, cov

    @property
    def rate(self) -> Any:
        """The fitted drift rate of the zero reading, ``unit``/s (0 before a tare or without
        tracking)."""
        if self.tau is None or self._noise is None:
            return self._out(np.zeros(self.channels))
        return self._out(self._fit()[1])

    def _sigma(self) -> F64:
        if self._noise is None:
            return np.zeros(self.channels)
        if self.tau is None:
            return np.asarray(self.baseline.standard_error if self.baseline is not None
                              else np.zeros(self.channels), dtype=np.float64).reshape(-1)
        _, b, var_a, _ = self._fit()
        untracked = b * (self._now - self._rested_at)
        return np.sqrt(np.maximum(var_a, 0.0) * self._noise ** 2 + untracked ** 2)

    @property
    def sigma(self) -> Any:
        """1-σ of the zero now, ``unit``: the fit's standard error and the drift not yet tracked
        (``|rate| ×`` time since the last rest), in quadrature; the tare's standard error
        without tracking; 0 before a tare."""
        return self._out(self._sigma())

    def total_noise(self, noise: ArrayLike) -> Any:
        """A reading's noise RMS ``noise`` (``unit``) with the zero's σ added in quadrature: what
        σ of an estimate is made of."""
        return self._out(np.hypot(np.asarray(noise, dtype=np.float64).reshape(-1)
                                  * np.ones(self.channels), self._sigma()))

    @property
    def channel_flags(self) -> NDArray[np.uint16]:
        """:class:`~magcilia.readout.protocol.Flag` bits per channel, shape (c,):
        TARE_UNDER_LOAD while the tare in use was not at rest, ZERO_DRIFT while the zero's σ
        exceeds ``drift_limit`` noise σ of one reading."""
        out = np.zeros(self.channels, dtype=np.uint16)
        if self.under_load:
            out |= np.uint16(Flag.TARE_UNDER_LOAD)
        if self._noise is not None and self.tau is not None:
            drifting = (self._sigma() > self.drift_limit * self._noise) & (self._noise > 0)
            out[drifting] |= np.uint16(Flag.ZERO_DRIFT)
        return out

    @property
    def flags(self) -> int:
        """The channels' flags together (``|``): what every estimate gets now."""
        return int(np.bitwise_or.reduce(self.channel_flags)) if self.channels else 0

    # -- tare -----------------------------------------------------------------------------------
    def _table(self, readings: ArrayLike) -> F64:
        x = np.asarray(readings, dtype=np.float64)
        if self.scalar:
            return x.reshape(-1, 1)
        if x.ndim != 2 or x.shape[1] != self.channels:
            raise v.fail("readings", f"shape {x.shape}", f"shape (m, {self.channels}), one "
                         "column per channel")
        return x

    def tare(self, readings: ArrayLike, at: float, dt: float | None = None,
             expected_noise: ArrayLike | None = None) -> bool:
        """Take the mean of unloaded ``readings`` as the new zero, unless they were not at rest
        while a good tare is in use (see the module docstring). Returns whether it was taken;
        :attr:`notice` says what happened.

        Parameters
        ----------
        readings : array-like, shape (t,) or (t, c)
            Consecutive readings, oldest first, ``unit`` (t ≥ 2 finite per channel).
        at : float
            Time of the last reading, s.
        dt : float, optional
            Spacing of the readings, s (default: all at ``at``): the fit of the zero's drift
            starts from them.
        expected_noise : float or array-like, shape (c,), optional
            The noise of one reading at rest, for the rest check (default: the tare in use's
            noise, else the readings' own white noise only).

        Raises
        ------
        MagciliaError
            If a channel has fewer than two finite readings.
        """
        table = self._table(readings)
        expected = self._noise if expected_noise is None else expected_noise
        tare = Tare.from_readings(table[:, 0] if self.scalar else table, self.rest,
                                  unit=self.unit, names=self.names,
                                  expected_noise=expected)
        if not tare.at_rest and self.baseline is not None and not self.under_load:
            reason = tare.check.reason if tare.check is not None else ""
            self.notice = (f"tare refused: {reason}; the previous tare stays — tare again with "
                           "the cilium unloaded")
            return False
        self.under_load = not tare.at_rest
        self.notice = "" if tare.at_rest else (
            f"tare taken under load: {tare.check.reason if tare.check else ''}; estimates are "
            "flagged TARE_UNDER_LOAD until a tare at rest (unload the cilium and tare again)")
        self.baseline = tare
        mean = np.asarray(tare.mean, dtype=np.float64).reshape(-1)
        self._noise = np.asarray(tare.noise, dtype=np.float64).reshape(-1)
        self._y0 = mean.copy()
        self._now = float(at)
        self._sums = {k: np.zeros(self.channels) for k in _SUMS}
        self._cached = None
        m = table.shape[0]
        tau = np.zeros(m) if dt is None else -(m - 1 - np.arange(m)) * float(dt)
        self._add(table, tau)
        self._rested_at = np.full(self.channels, float(at))
        self._correction = self._rest - mean
        self._tare_correction = self._correction.copy()
        self.tared_at = float(at)
        return True

    def _add(self, table: F64, tau: F64) -> None:
        """Add readings (m, c) at times ``tau`` (s before now) to the fit, weight 1 each."""
        self._cached = None
        good = np.isfinite(table)
        y = np.where(good, table - self._y0, 0.0)
        g = good.astype(np.float64)
        t = tau[:, None]
        s = self._sums
        n = g.sum(axis=0)
        tt, ttt = (g * t).sum(axis=0), (g * t * t).sum(axis=0)
        s["w"] += n
        s["wt"] += tt
        s["wtt"] += ttt
        s["wy"] += y.sum(axis=0)
        s["wty"] += (y * t).sum(axis=0)
        s["u"] += n
        s["ut"] += tt
        s["utt"] += ttt

    # -- tracking -------------------------------------------------------------------------------
    def _advance(self, now: float) -> None:
        """Move the fit's time origin to ``now`` and forget by ``exp(−Δt/tau)``."""
        step = now - self._now
        if step <= 0.0 or self.tau is None:
            return
        if self._cached is not None:  # the line seen from the new origin: a' = a + b·Δt
            a, b, var_a, var_b, cov = self._cached
            self._cached = (a + b * step, b, var_a + step * (2.0 * cov + step * var_b), var_b,
                            cov + step * var_b)  # (uniform forgetting leaves Cov / σ² as is)
        s = self._sums
        d = math.exp(-step / self.tau)
        w, wt, wy = s["w"], s["wt"], s["wy"]
        s["wtt"] = (s["wtt"] - 2 * step * wt + step * step * w) * d
        s["wty"] = (s["wty"] - step * wy) * d
        s["wt"] = (wt - step * w) * d
        s["w"] = w * d
        s["wy"] = wy * d
        u, ut = s["u"], s["ut"]
        s["utt"] = (s["utt"] - 2 * step * ut + step * step * u) * d * d
        s["ut"] = (ut - step * u) * d * d
        s["u"] = u * d * d
        self._now = now

    def track(self, readings: ArrayLike, dt: float, at: float | None = None) -> None:
        """Let the zero follow a batch of readings (``unit``, uncorrected, shape (m,) or (m, c),
        spaced ``dt`` s) on the channels where its mean lies within the band around the
        predicted zero (the others hold their correction); nothing before a tare or without
        tracking.

        Parameters
        ----------
        readings : array-like, shape (m,) or (m, c)
            The batch, oldest first.
        dt : float
            Spacing of the readings, s.
        at : float, optional
            Time of the last reading, s (default: the batch follows the previous one directly).
        """
        if self.tau is None or self._noise is None:
            return
        table = self._table(readings)
        m = table.shape[0]
        if m == 0:
            return
        self._advance(self._now + m * dt if at is None else float(at))
        good = np.isfinite(table)
        count = good.sum(axis=0)
        mean = np.where(good, table - self._y0, 0.0).sum(axis=0) / np.maximum(count, 1)
        centre = -(m - 1) / 2.0 * dt
        a, b, var_a, var_b = self._fit()
        predicted = a + b * centre
        var_pred = (var_a + centre * centre * var_b) * self._noise ** 2  # (cov ignored: tiny)
        limit = self.band * np.sqrt(self._noise ** 2 / np.maximum(count, 1) + var_pred)
        rest = (count > 0) & (np.abs(mean - predicted) <= limit)
        if rest.any():
            tau = -(m - 1 - np.arange(m)) * float(dt)
            self._add(np.where(rest[None, :], table, np.nan), tau)
            self._rested_at[rest] = self._now
            now = self._rest - (self._y0 + self._fit()[0])
            self._correction = np.where(rest, now, self._correction)

    # -- for recordings -------------------------------------------------------------------------
    def state(self) -> dict[str, Any]:
        """The whole state, JSON-ready (a recording stores it, a replay restores it)."""
        def plain(a: Any) -> Any:
            return None if a is None else np.asarray(a, dtype=np.float64).tolist()
        return {"rest": plain(self._rest), "scalar": self.scalar, "tau": self.tau,
                "band": self.band, "drift_limit": self.drift_limit, "unit": self.unit,
                "names": list(self.names), "correction": plain(self._correction),
                "tare_correction": plain(self._tare_correction), "noise": plain(self._noise),
                "tared_at": self.tared_at,
                "baseline": None if self.baseline is None else self.baseline.to_dict(),
                "under_load": self.under_load, "notice": self.notice, "now": self._now,
                "y0": plain(self._y0), "rested_at": plain(self._rested_at),
                "sums": {k: plain(x) for k, x in self._sums.items()}}

    @classmethod
    def from_state(cls, doc: dict[str, Any]) -> Zero:
        """The zero that :meth:`state` described (its tare kept as numbers: ``baseline`` is
        rebuilt without its rest check)."""
        try:
            rest = doc["rest"][0] if doc["scalar"] else doc["rest"]
            zero = cls(rest, doc["tau"], doc["band"], doc["drift_limit"], doc["unit"],
                       tuple(doc["names"]))

            def arr(key: str) -> F64:
                return np.asarray(doc[key], dtype=np.float64).reshape(-1)
            zero._correction, zero._tare_correction = arr("correction"), arr("tare_correction")
            zero._noise = None if doc["noise"] is None else arr("noise")
            zero.tared_at = doc["tared_at"]
            zero.under_load, zero.notice = bool(doc["under_load"]), str(doc["notice"])
            zero._now, zero._y0, zero._rested_at = float(doc["now"]), arr("y0"), arr("rested_at")
            zero._sums = {k: np.asarray(doc["sums"][k], dtype=np.float64) for k in _SUMS}
            zero._cached = None
            b = doc["baseline"]
            if b is not None:
                one = zero.scalar
                zero.baseline = Tare(rest=b["rest"] if one else np.asarray(b["rest"]),
                                     mean=b["mean"] if one else np.asarray(b["mean"]),
                                     noise=b["noise"] if one else np.asarray(b["noise"]),
                                     count=b["count"] if one else np.asarray(b["count"]),
                                     unit=b["unit"], names=tuple(b.get("names", ())))
        except (KeyError, TypeError, ValueError, IndexError) as exc:
            raise MagciliaError(f"zero-tracking state: not a state this version wrote ({exc})"
                                ) from None
        return zero
