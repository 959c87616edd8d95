"""Averaging windows: raw samples in, one reading per window out (set/reset demodulated).

A live read-out averages ``factor`` consecutive samples into one reading (a boxcar: the noise
bandwidth of the readings is half the output rate). With set/reset samples each window's reading
is the offset-free ``(mean(V_set) − mean(V_reset)) / 2`` plus the model's offset (the bridge flips
with the strap's pulses, the bias does not: see :func:`magcilia.io.recordings.reading`); a window
holding only one polarity pairs it with the last mean of the other (carried across calls).

Several channels (a 3-axis sensor's or an array's field readings) are averaged alike, column by
column: samples (n, c) give readings (w, c).

Shape letters: ``n`` samples (a multiple of the factor), ``w = n / factor`` windows, ``c``
channels.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from magcilia import _validate as v

F64 = NDArray[np.float64]


@dataclass(frozen=True, eq=False)
class Windows:
    """Readings of consecutive windows (immutable).

    Attributes
    ----------
    time : ndarray, shape (w,)
        Centre time of each window, s (the samples' own clock).
    volts : ndarray, shape (w,) or (w, c)
        Mean output of each window, V (demodulated with set/reset samples; NaN while one
        polarity has not been seen yet); per channel for several (their unit).
    beyond : ndarray of bool, shape (w,)
        Whether any raw sample of the window lies beyond the sensor's linear range.
    """

    time: F64
    volts: F64
    beyond: NDArray[np.bool_]


class Averager:
    """Turns blocks of samples into window readings (see the module docstring).

    Parameters
    ----------
    factor : int
        Samples per window (the source's rate over the output rate).
    offset : float or ndarray, shape (c,)
        The model's output offset, V, added to demodulated readings so that they compare with the
        read-out table (``setup.sensor.offset``); one per channel for several.
    """

    def __init__(self, factor: int, offset: ArrayLike = 0.0) -> None:
        self.factor = v.integer("factor", factor, 1)
        self.offset: Any = v.real("offset", offset, "V") if np.ndim(offset) == 0 else \
            v.finite_array("offset", offset, ndim=1)
        self.reset()

    def reset(self) -> None:
        """Forget the carried set/reset means (after a reconnection)."""
        self._last = np.full((2, *np.shape(self.offset)), np.nan)  # last set, last reset mean

    def push(self, time: F64, volts: F64, beyond: NDArray[np.bool_],
             setreset: NDArray[np.int8] | None = None) -> Windows:
        """Readings of the windows of these samples.

        Parameters
        ----------
        time : ndarray, shape (n,)
            Sample times, s; ``n`` a multiple of ``factor``.
        volts : ndarray, shape (n,) or (n, c)
            Outputs, V (or each channel's reading).
        beyond : ndarray of bool, shape (n,)
            Samples beyond the sensor's range.
        setreset : ndarray of int8, shape (n,), optional
            +1 after a set pulse, −1 after a reset pulse (None: plain averages).
        """
        f = self.factor
        n = time.size
        if n % f:
            raise v.fail("samples", n, f"a multiple of the window ({f} samples)")
        w = n // f
        rest = volts.shape[1:]
        t = time.reshape(w, f).mean(axis=1)
        out_of_range = np.asarray(beyond.reshape(w, f).any(axis=1))
        x = volts.reshape(w, f, *rest)
        if setreset is None:
            return Windows(t, x.mean(axis=1), out_of_range)
        means = np.empty((2, w, *rest))
        for row, mask in enumerate((setreset > 0, setreset < 0)):
            m = mask.reshape(w, f, *(1 for _ in rest))
            count = m.sum(axis=1)
            total = np.where(m, x, 0.0).sum(axis=1)
            with np.errstate(invalid="ignore", divide="ignore"):
                means[row] = total / count
            means[row] = _hold(means[row], count > 0, self._last[row])
        self._last = means[:, -1].copy()
        return Windows(t, (means[0] - means[1]) / 2.0 + self.offset, out_of_range)


def _hold(values: F64, valid: NDArray[np.bool_], before: Any) -> F64:
    """``values`` (w, ...) with each invalid window replaced by the last valid one (``before``
    at first); ``valid`` (w, 1...) or (w,)."""
    ok = valid.reshape(valid.shape[0])
    index = np.where(ok, np.arange(values.shape[0]), -1)
    np.maximum.accumulate(index, out=index)
    held = values[np.maximum(index, 0)]
    first = (index < 0).reshape(-1, *(1 for _ in values.shape[1:]))
    return np.asarray(np.where(first, before, held))
