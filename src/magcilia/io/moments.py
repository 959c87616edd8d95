"""Statistics of a recording's samples grouped by angle: counts, means and squared deviations,
accurate for samples on a large common offset and mergeable block by block (Chan, Golub &
LeVeque 1983). Pure NumPy over arrays; :mod:`magcilia.io.recordings` builds readings from them."""

from __future__ import annotations

from typing import Any, NamedTuple

import numpy as np
from numpy.typing import NDArray

F64 = NDArray[np.float64]


def runs(*keys: NDArray[Any]) -> tuple[NDArray[np.intp], NDArray[np.intp]]:
    """Start and length of each run of rows over which every key (shape (s,)) is constant,
    shapes (r,). NaN differs from itself: each NaN row is a run of its own."""
    first, n = keys[0], keys[0].size
    change = np.ones(n, dtype=bool)
    np.not_equal(first[1:], first[:-1], out=change[1:])
    for key in keys[1:]:
        change[1:] |= key[1:] != key[:-1]
    starts = np.flatnonzero(change)
    return starts, np.diff(starts, append=n)


def by_value(values: NDArray[Any]) -> tuple[NDArray[Any], NDArray[np.intp]]:
    """The distinct values (increasing; complex values by real, then imaginary part) and the
    index of each value among them.

    A recording keeps each angle's samples together: the runs of equal values are found first
    and only the runs are sorted (``np.unique`` of every sample would sort them all).
    """
    starts, lengths = runs(values)
    distinct, run = np.unique(values[starts], return_inverse=True)
    return distinct, np.repeat(run, lengths)


class Moments(NamedTuple):
    """Statistics of groups of samples, arrays of one shape: count, mean (V) held as ``hi + lo``
    and the sum of squared deviations from the mean (V²). ``hi`` is the mean of the first samples
    seen, ``lo`` (small) what the later ones moved it: means of samples on a large offset are then
    compared and merged without losing their last digits in the offset."""

    n: NDArray[np.int64]
    hi: F64
    lo: F64
    m2: F64

    def reshape(self, *shape: int) -> Moments:
        return Moments(self.n.reshape(shape), self.hi.reshape(shape), self.lo.reshape(shape),
                        self.m2.reshape(shape))


def group_moments(key: NDArray[np.intp], values: F64, size: int) -> tuple[Moments, F64]:
    """Statistics of the samples of each key 0 … size − 1 and their largest |value|, shapes
    (size,) (zeros for a key without samples).

    Two passes: the means, then the deviations from them in the corrected two-pass form of Chan,
    Golub & LeVeque (1983), ``M2 = Σd² − (Σd)²/n`` and ``lo = Σd/n``, accurate for samples on a
    large common offset. Each sum is taken over the runs of equal keys (``np.add.reduceat``) and
    gathered per key (``np.bincount``).
    """
    zero = np.zeros(size)
    if key.size == 0:
        return Moments(np.zeros(size, np.int64), zero, zero, zero), zero
    starts, lengths = runs(key)
    run = key[starts]
    n = np.bincount(run, lengths, size).astype(np.int64)
    peak = np.zeros(size)
    np.maximum.at(peak, run, np.maximum.reduceat(np.abs(values), starts))
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):  # overflow: checked later
        hi = np.bincount(run, np.add.reduceat(values, starts), size) / np.maximum(n, 1)
        dev = values - np.repeat(hi[run], lengths)
        lo = np.bincount(run, np.add.reduceat(dev, starts), size) / np.maximum(n, 1)
        square = np.bincount(run, np.add.reduceat(dev * dev, starts), size)
        return Moments(n, hi, lo, square - lo * lo * n), peak


def summarize(stats: Moments) -> tuple[F64, F64, NDArray[np.int64]]:
    """Readings from per-angle statistics of shape (a, k) (k = 1, or 2: reset and set samples):
    mean (V), standard error (V; sample std / sqrt(count), 0 for a single sample), samples used;
    with set/reset samples the offset-free ``(mean(V_set) − mean(V_reset)) / 2``."""
    n, hi, lo, m2 = stats
    with np.errstate(invalid="ignore", over="ignore"):  # overflow: checked by the callers
        var = np.divide(m2, (n - 1) * n, out=np.zeros(n.shape), where=n > 1)  # of each mean
        if n.shape[1] == 1:
            return hi[:, 0] + lo[:, 0], np.sqrt(var[:, 0]), n[:, 0]
        return (((hi[:, 1] - hi[:, 0]) + (lo[:, 1] - lo[:, 0])) / 2.0,
                np.sqrt(var.sum(axis=1)) / 2.0, n.sum(axis=1))


def grow_rows(arr: NDArray[Any], at: NDArray[np.intp], size: int) -> NDArray[Any]:
    """Zeros with ``size`` rows, ``arr``'s rows at rows ``at``."""
    grown = np.zeros((size, *arr.shape[1:]), arr.dtype)
    grown[at] = arr
    return grown
