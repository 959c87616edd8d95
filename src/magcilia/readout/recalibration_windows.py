"""The windows an in-use re-calibration fits (:mod:`magcilia.readout.recalibration`).

* :class:`PulseWindow`: a coil pulse's field step and the output's levels before and during it;
* :class:`StrapWindow`: the AMR strap's set and reset levels (their mean is the offset);
* :class:`RestWindow`: the level at a moment the cilium is known to be unloaded (∝ M).

Standard errors come from the samples' spread, and for strap and rest windows with four or more
set/reset periods from the periods' own levels (batch means), whichever is larger: the noise's
low frequencies, which the samples' spread misses, are counted.
"""

from __future__ import annotations

import itertools
import math
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from magcilia import _validate as v
from magcilia._display import Display, Item

F64 = NDArray[np.float64]


def _mean_sem(volts: ArrayLike, what: str) -> tuple[float, float]:
    x = v.finite_array(what, volts, ndim=1, unit="V")
    if x.size < 2:
        raise v.fail(what, f"{x.size} samples", "at least 2 samples")
    return float(x.mean()), float(x.std(ddof=1) / math.sqrt(x.size))


@dataclass(frozen=True, repr=False)
class PulseWindow(Display):
    """A coil pulse: the field step ``field`` (3,), T, and the output's mean ± s.e. before and
    during it, V, at time ``time``, s; ``offset_free`` when the levels are the set/reset
    demodulated field part (no offset). The level before tells the load the hair carries (the
    model's g is taken there). Build it from samples with :meth:`of`."""

    field: tuple[float, float, float]
    before: float
    before_sem: float
    during: float
    during_sem: float
    time: float = 0.0
    offset_free: bool = False

    @classmethod
    def of(cls, field: ArrayLike, before: ArrayLike, during: ArrayLike,
           time: float = 0.0) -> PulseWindow:
        """From the samples before (n,) and during (n,) the pulse, V, and the pulse's field (3,),
        T (the samples during it after the hair settled)."""
        b = v.vector3("field", field, "T")
        m0, s0 = _mean_sem(before, "samples before the pulse")
        m1, s1 = _mean_sem(during, "samples during the pulse")
        return cls((float(b[0]), float(b[1]), float(b[2])), m0, s0, m1, s1, float(time))

    @property
    def step(self) -> tuple[float, float]:
        """The output's step and its σ, V."""
        return self.during - self.before, math.hypot(self.before_sem, self.during_sem)

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready content (SI)."""
        return {"field_T": list(self.field), "before_V": self.before,
                "before_sem_V": self.before_sem, "during_V": self.during,
                "during_sem_V": self.during_sem, "time_s": self.time,
                "offset_free": self.offset_free}

    def report(self) -> str:
        """One line: the field (G) and the step (mV)."""
        step, sigma = self.step
        b = ", ".join(f"{x * 1e4:+.3g}" for x in self.field)
        return f"pulse ({b}) G at {self.time:.3f} s: step {step * 1e3:+.5f} ± {sigma * 1e3:.5f} mV"

    def _display_items(self) -> list[Item]:
        return [("", self.report())]


@dataclass(frozen=True)
class StrapWindow:
    """Set and reset levels (mean ± s.e., V) of the AMR strap at ``time`` (s): the offset is
    their mean (the strap flips the bridge's field response, not its offset)."""

    set_level: float
    set_sem: float
    reset_level: float
    reset_sem: float
    time: float = 0.0

    @classmethod
    def of(cls, volts: ArrayLike, setreset: ArrayLike, time: float = 0.0) -> StrapWindow:
        """From samples (n,), V, and their polarity (n,) (+1 set, −1 reset). With four or more
        set/reset periods the s.e. is that of the periods' offsets (batch means: the noise's
        low frequencies, which the samples' spread misses, are counted), else the samples'."""
        x = v.finite_array("samples", volts, ndim=1, unit="V")
        p = np.asarray(setreset).ravel()
        if p.shape != x.shape:
            raise v.fail("setreset", p.shape, f"one polarity per sample ({x.size})")
        a, sa = _mean_sem(x[p > 0], "set samples")
        b, sb = _mean_sem(x[p < 0], "reset samples")
        sem = _batch_sem([0.5 * (u + w) for u, w in _periods(x, p)], 0.5 * math.hypot(sa, sb))
        scale = sem / (0.5 * math.hypot(sa, sb))
        return cls(a, sa * scale, b, sb * scale, float(time))


@dataclass(frozen=True)
class RestWindow:
    """The output's level (mean ± s.e., V) at a moment the cilium is known to be unloaded, at
    ``time`` (s): o + S·s·m·B₀ₓ, proportional to the magnetization (S·s·m·B₀ₓ with
    ``offset_free``, the set/reset demodulated level). Build it from samples with :meth:`of`."""

    level: float
    sem: float
    time: float = 0.0
    offset_free: bool = False

    @classmethod
    def of(cls, volts: ArrayLike, setreset: ArrayLike | None = None,
           time: float = 0.0) -> RestWindow:
        """From unloaded samples (n,), V, and their polarity (n,) or None: with it, the
        offset-free level (half the set − reset difference, its s.e. from the periods' levels)."""
        x = v.finite_array("samples", volts, ndim=1, unit="V")
        if setreset is None:
            return cls(*_mean_sem(x, "rest samples"), float(time))
        p = np.asarray(setreset).ravel()
        if p.shape != x.shape:
            raise v.fail("setreset", p.shape, f"one polarity per sample ({x.size})")
        a, sa = _mean_sem(x[p > 0], "set samples")
        b, sb = _mean_sem(x[p < 0], "reset samples")
        sem = _batch_sem([0.5 * (u - w) for u, w in _periods(x, p)], 0.5 * math.hypot(sa, sb))
        return cls(0.5 * (a - b), sem, float(time), offset_free=True)


Window = PulseWindow | StrapWindow | RestWindow


def _periods(x: F64, p: NDArray[Any]) -> list[tuple[float, float]]:
    """(set level, reset level) of each set/reset period of the samples, in order."""
    pieces = [i for i in np.split(np.arange(x.size), np.flatnonzero(np.diff(p) != 0) + 1)
              if i.size]
    runs = [(int(np.sign(p[i[0]])), float(x[i].mean())) for i in pieces]
    out = []
    for (pa, a), (pb, b) in itertools.pairwise(runs):
        if pa > 0 > pb:
            out.append((a, b))
    return out


def _batch_sem(levels: list[float], samples_sem: float) -> float:
    """The s.e. of a level from four or more periods' levels (batch means: the noise's low
    frequencies, which the samples' spread misses, are counted), never below the samples'."""
    if len(levels) < 4:
        return samples_sem
    return max(samples_sem, float(np.std(levels, ddof=1) / math.sqrt(len(levels))))
