"""Averaging windows: raw samples in, one reading per window out (set/reset demodulated).

A live read-out averages ``factor`` consecutive samples into one reading (a boxcar: the noise
bandwidth of the readings is half the output rate). With set/reset samples each window's reading
is the offset-free ``(mean(V_set) − mean(V_reset)) / 2`` plus the model's offset (the bridge flips
with the strap's pulses, the bias does not: see :func:`magcilia.io.recordings.reading`); a window
holding only one polarity pairs it with the last mean of the other (carried across calls).

Shape letters: ``n`` samples (a multiple of the factor), ``w = n / factor`` windows.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from magcilia import _validate as v

F64 = NDArray[np.float64]


@dataclass(frozen=True, eq=False)
class Windows:
    """Readings of consecutive windows (immutable).

    Attributes
    ----------
    time : ndarray, shape (w,)
        Centre time of each window, s (the samples' own clock).
    volts : ndarray, shape (w,)
        Mean output of each window, V (demodulated with set/reset samples; NaN while one
        polarity has not been seen yet).
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
    offset : float
        The model's output offset, V, added to demodulated readings so that they compare with the
        read-out table (``setup.sensor.offset``).
    """

    def __init__(self, factor: int, offset: float = 0.0) -> None:
        self.factor = v.integer("factor", factor, 1)
        self.offset = v.real("offset", offset, "V")
        self._last = np.array([np.nan, np.nan])  # last set mean, last reset mean

    def reset(self) -> None:
        """Forget the carried set/reset means (after a reconnection)."""
        self._last = np.array([np.nan, np.nan])

    def push(self, time: F64, volts: F64, beyond: NDArray[np.bool_],
             setreset: NDArray[np.int8] | None = None) -> Windows:
        """Readings of the windows of these samples.

        Parameters
        ----------
        time, volts : ndarray, shape (n,)
            Sample times, s, and outputs, V; ``n`` a multiple of ``factor``.
        beyond : ndarray of bool, shape (n,)
            Samples beyond the sensor's range.
        setreset : ndarray of int8, shape (n,), optional
            +1 after a set pulse, −1 after a reset pulse (None: plain averages).
        """
        f = self.factor
        if volts.size % f:
            raise v.fail("samples", volts.size, f"a multiple of the window ({f} samples)")
        w = volts.size // f
        t = time.reshape(w, f).mean(axis=1)
        out_of_range = np.asarray(beyond.reshape(w, f).any(axis=1))
        if setreset is None:
            return Windows(t, volts.reshape(w, f).mean(axis=1), out_of_range)
        means = np.empty((2, w))
        for row, mask in enumerate((setreset > 0, setreset < 0)):
            m = mask.reshape(w, f)
            count = m.sum(axis=1)
            total = np.where(m, volts.reshape(w, f), 0.0).sum(axis=1)
            with np.errstate(invalid="ignore", divide="ignore"):
                means[row] = total / count
            means[row] = _hold(means[row], count > 0, self._last[row])
        self._last = means[:, -1].copy()
        return Windows(t, (means[0] - means[1]) / 2.0 + self.offset, out_of_range)


def _hold(values: F64, valid: NDArray[np.bool_], before: float) -> F64:
    """``values`` with each invalid entry replaced by the last valid one (``before`` at first)."""
    index = np.where(valid, np.arange(values.size), -1)
    np.maximum.accumulate(index, out=index)
    return np.where(index >= 0, values[np.maximum(index, 0)], before)
