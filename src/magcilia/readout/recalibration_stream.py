"""Coil pulses found in a stream of samples: their windows, their samples masked, drifts updated.

:class:`PulseTracker` takes consecutive chunks of samples (time, output, the applied field of each
sample, the set/reset polarity) as a live read-out reads them, finds each coil pulse (the applied
field differs from its level outside the pulses), makes its :class:`PulseWindow` from its samples
after ``settle`` s against the mean of the quiet levels ``before`` s before and after it (a pulse
whose two levels differ — the load moved — is left out), and a :class:`StrapWindow` from the
samples before it where they hold both polarities; each pulse updates the state
(:meth:`Recalibrator.update` with a random walk: a Kalman filter's step). It returns, per chunk,
the samples with the pulse's samples (and ``after`` s of the hair's return) replaced by the
latest quiet level, and the mask of those samples: the read-out flags them and never shows them
as a force. :func:`pulse_windows` does the same on a whole recording at once.
"""

from __future__ import annotations

import math
from collections import deque
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from magcilia import _validate as v
from magcilia.readout.recalibration import WALK, Recalibration, Recalibrator
from magcilia.readout.recalibration_windows import PulseWindow, RestWindow, StrapWindow, Window

F64 = NDArray[np.float64]

#: a field step smaller than this is no pulse, T
_FIELD_TOLERANCE = 1e-9


def _step(before: F64, during: F64, pb: NDArray[Any] | None, pd: NDArray[Any] | None
          ) -> tuple[float, float, float, float] | None:
    """(before, σ, during, σ) of the field part: per polarity present on both sides, p·(x − ·)
    averaged (an offset-free step with set/reset); None without enough samples."""
    if pb is None or pd is None:
        if before.size < 2 or during.size < 2:
            return None
        return (float(before.mean()), float(before.std(ddof=1) / math.sqrt(before.size)),
                float(during.mean()), float(during.std(ddof=1) / math.sqrt(during.size)))
    parts = []
    for p in (1, -1):
        xb, xd = before[pb == p], during[pd == p]
        if xb.size >= 2 and xd.size >= 2:
            parts.append((p * xb.mean(), xb.std(ddof=1) / math.sqrt(xb.size),
                          p * xd.mean(), xd.std(ddof=1) / math.sqrt(xd.size)))
    if not parts:
        return None
    n = len(parts)
    mb = sum(x[0] for x in parts) / n
    md = sum(x[2] for x in parts) / n
    sb = math.sqrt(sum(x[1] ** 2 for x in parts)) / n
    sd = math.sqrt(sum(x[3] ** 2 for x in parts)) / n
    return float(mb), float(sb), float(md), float(sd)


def _strap(volts: F64, polarity: NDArray[Any] | None, at: float) -> StrapWindow | None:
    if polarity is None or (polarity > 0).sum() < 2 or (polarity < 0).sum() < 2:
        return None
    return StrapWindow.of(volts, polarity, at)


class PulseTracker:
    """Finds coil pulses in a stream and keeps the re-calibration up to date (module docstring).

    Parameters
    ----------
    recalibrator : Recalibrator
        The model of the pulses.
    before : float
        Seconds of samples before each pulse that make its reference level.
    settle : float
        Seconds at the start of each pulse left out (the hair and the coil settling).
    after : float
        Seconds after each pulse still masked (the hair returning).
    memory : int
        Windows (pulses and strap levels) kept in :attr:`windows`.
    walk : dict, optional
        The drifts' random walk per √s of the tracking (default :data:`WALK`): each pulse's
        windows update the last state, a Kalman filter's step (:meth:`Recalibrator.update`).
    gate : float
        A pulse whose quiet levels before and after it (``before`` s each) differ by more than
        ``gate`` σ is left out and counted in :attr:`rejected` (the load moved meanwhile); the
        reference level of a pulse is the mean of the two (a linear drift cancels).
    """

    def __init__(self, recalibrator: Recalibrator, *, before: float = 0.05,
                 settle: float = 0.01, after: float = 0.02, memory: int = 12,
                 walk: dict[str, float] | None = None, gate: float = 3.0) -> None:
        if not isinstance(recalibrator, Recalibrator):
            raise v.fail("recalibrator", type(recalibrator).__name__, "a Recalibrator")
        self.recalibrator = recalibrator
        self.before = v.positive("before", before, "s", "duration")
        self.settle = v.non_negative("settle", settle, "s", "duration")
        self.after = v.non_negative("after", after, "s", "duration")
        self.memory = v.integer("memory", memory, 1)
        self.walk = dict(WALK if walk is None else walk)
        self.gate = v.positive("gate", gate, "", "σ")
        self.rejected = 0
        self.state: Recalibration = recalibrator.start()
        self.windows: deque[Window] = deque(maxlen=self.memory)
        self.updates = 0
        self._quiet: deque[tuple[float, float, int]] = deque()  # (t, V, polarity) not masked
        self._pulse: list[tuple[float, float, int]] = []  # the running pulse's samples
        self._before: list[tuple[float, float, int]] = []  # the quiet samples before it
        self._field: F64 | None = None
        self._start = math.nan
        self._pending: list[tuple[F64, float, list[Any], list[Any], float]] = []
        self._masked_until = -math.inf
        self._baseline: F64 | None = None

    def push(self, time: ArrayLike, volts: ArrayLike, applied: ArrayLike,
             setreset: ArrayLike | None = None) -> tuple[F64, NDArray[np.bool_]]:
        """Take a chunk: times (n,), s; outputs (n,), V; applied field (n, 3), T; polarity (n,)
        or None. Returns the outputs with the pulses' samples held at the level before them, and
        the mask of those samples (n,)."""
        t = np.asarray(time, dtype=np.float64).ravel()
        x = np.asarray(volts, dtype=np.float64).ravel()
        b = np.asarray(applied, dtype=np.float64).reshape(-1, 3)
        p = np.zeros(t.size, dtype=np.int8) if setreset is None else np.asarray(setreset).ravel()
        if not (t.size == x.size == b.shape[0] == p.size):
            raise v.fail("chunk", (t.size, x.size, b.shape, p.size),
                         "times, outputs, fields (n, 3) and polarities of the same n")
        if self._baseline is None and t.size:
            self._baseline = b[0].copy()
        base = self._baseline if self._baseline is not None else np.zeros(3)
        on = np.any(np.abs(b - base) > _FIELD_TOLERANCE, axis=1)
        out = x.copy()
        mask = np.zeros(t.size, dtype=bool)
        for i in range(t.size):
            sample = (float(t[i]), float(x[i]), int(p[i]))
            if on[i]:
                if self._field is None:  # a pulse begins: the level before it is kept
                    self._field = b[i] - base
                    self._start = sample[0]
                    self._before = [q for q in self._quiet if q[0] >= sample[0] - self.before]
                self._pulse.append(sample)
                mask[i] = True
                out[i] = self._held(sample[2])
                continue
            if self._field is not None:  # it ended with the previous sample
                self._pending.append((self._field, self._start, self._before, self._pulse,
                                      sample[0] + self.after))
                self._field, self._pulse, self._before = None, [], []
                self._masked_until = sample[0] + self.after
            if sample[0] < self._masked_until:
                mask[i] = True
                out[i] = self._held(sample[2])
                continue
            self._quiet.append(sample)
            while self._quiet and self._quiet[0][0] < sample[0] - self.before:
                self._quiet.popleft()
            if self._pending and sample[0] >= self._pending[0][4] + self.before:
                self._finish(*self._pending.pop(0)[:4])
        return out, mask

    def _held(self, pol: int) -> float:
        """The value a masked sample is replaced by: the latest quiet sample of its polarity."""
        for q in reversed(self._quiet):
            if q[2] == pol:
                return q[1]
        return self._quiet[-1][1] if self._quiet else math.nan

    def _finish(self, field: F64, start: float, before: list[tuple[float, float, int]],
                pulse: list[tuple[float, float, int]]) -> None:
        """Turn a pulse, bracketed by the quiet levels before and after it, into windows, and
        re-fit; a pulse whose levels before and after differ (the load moved) is left out."""
        after = [q for q in self._quiet if q[0] >= self._quiet[-1][0] - self.before]
        during = [q for q in pulse if q[0] >= start + self.settle]
        polar = any(q[2] != 0 for q in before)
        arrays = [(np.array([q[1] for q in w]), np.array([q[2] for q in w]) if polar else None)
                  for w in (before, during, after)]
        step = _step(arrays[0][0], arrays[1][0], arrays[0][1], arrays[1][1])
        back = _step(arrays[0][0], arrays[2][0], arrays[0][1], arrays[2][1])
        if step is None or back is None:
            return
        moved = back[2] - back[0]
        if abs(moved) > self.gate * math.hypot(back[1], back[3]):
            self.rejected += 1
            return
        level, level_sem = 0.5 * (back[0] + back[2]), 0.5 * math.hypot(back[1], back[3])
        new: list[Window] = [PulseWindow((float(field[0]), float(field[1]), float(field[2])),
                                         level, level_sem, step[2], step[3], start,
                                         offset_free=polar)]
        quiet = before + after  # both sides of the pulse: the offset from twice the samples
        strap = _strap(np.array([q[1] for q in quiet]), np.array([q[2] for q in quiet])
                       if polar else None, start)
        if strap is not None:
            new.append(strap)
        self.windows.extend(new)
        self.state = self.recalibrator.update(new, self.state, walk=self.walk)
        self.updates += 1


    def rest(self, time: ArrayLike, volts: ArrayLike, setreset: ArrayLike | None = None) -> None:
        """Samples the cilium is known to be unloaded at (times (n,), s; outputs (n,), V; the
        polarity or None), outside any pulse: a :class:`RestWindow` (the magnetization's level)
        that updates the state."""
        t = np.asarray(time, dtype=np.float64).ravel()
        window = RestWindow.of(volts, setreset, float(t.mean()))
        self.windows.append(window)
        self.state = self.recalibrator.update([window], self.state, walk=self.walk)
        self.updates += 1


def pulse_windows(recalibrator: Recalibrator, time: ArrayLike, volts: ArrayLike,
                  applied: ArrayLike, setreset: ArrayLike | None = None, *,
                  before: float = 0.05, settle: float = 0.01) -> list[Window]:
    """Every pulse window (and strap window) of a whole recording, in order: times (n,), s;
    outputs (n,), V; applied field (n, 3), T; polarity (n,) or None."""
    tracker = PulseTracker(recalibrator, before=before, settle=settle, memory=10**9)
    tracker.recalibrator = _NoFit(recalibrator)
    tracker.push(time, volts, applied, setreset)
    return list(tracker.windows)


class _NoFit(Recalibrator):
    """A recalibrator that collects without fitting (for :func:`pulse_windows`)."""

    def __init__(self, inner: Recalibrator) -> None:
        self.__dict__.update(inner.__dict__)

    def update(self, windows: Any, previous: Recalibration | None = None,  # noqa: ARG002
               *, walk: dict[str, float] | None = None) -> Recalibration:  # noqa: ARG002
        return previous if previous is not None else self.start()
