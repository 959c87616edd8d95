"""One condition's reading from its raw samples, and the sensor's range on raw outputs: the rules
the reduction (:mod:`magcilia.io.reduction`) applies per sample and per condition.

With set/reset samples the offset-free reading of a condition is
``(mean(V_set) − mean(V_reset))/2`` (the bridge flips polarity, the offset does not; HMC1021
datasheet).
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray

from magcilia._errors import MagciliaError
from magcilia.device.sensor import Sensor
from magcilia.device.sensor import beyond_range as saturated
from magcilia.io.moments import group_moments, summarize


def beyond_range(volts: ArrayLike, sensor: Sensor) -> NDArray[np.bool_]:
    """True where an output (V, any shape) lies beyond the sensor's linear range (the one
    saturation rule, :func:`magcilia.device.sensor.beyond_range`, of the field it stands for). The
    bias is not known at this point: the field is judged relative to the sensor's offset."""
    field = np.array(volts, dtype=np.float64)  # a copy, worked on in place
    with np.errstate(over="ignore", invalid="ignore"):  # huge outputs are beyond the range
        field -= sensor.offset
        field /= abs(sensor.scale)
        return saturated(field, sensor.field_range)


def _polarity_error(where: str, n: NDArray[np.int64]) -> MagciliaError:
    """The error for samples (``n``: reset and set counts) lacking one polarity."""
    return MagciliaError(f"{where} has {n[1]} set and {n[0]} reset samples; set/reset readings "
                         "need both at every angle")


def reading(volts: ArrayLike, setreset: ArrayLike | None = None,
            where: str = "samples") -> tuple[float, float, int]:
    """One angle's reading from its samples: mean (V), standard error (V), samples used.

    Parameters
    ----------
    volts : array-like, shape (s,)
        Samples, V (at least one).
    setreset : array-like, shape (s,), optional
        +1 after a set pulse, −1 after a reset pulse (samples marked otherwise are left out): the
        reading is then the offset-free ``(mean(V_set) − mean(V_reset)) / 2`` (the bridge flips,
        its offset does not).
    where : str
        Names the samples in the error when set/reset samples lack one polarity.
    """
    values = np.asarray(volts, dtype=np.float64).ravel()
    if setreset is None:
        key, k = np.zeros(values.size, np.intp), 1
    else:
        sr = np.asarray(setreset, dtype=np.float64).ravel()
        marked = (sr > 0) | (sr < 0)
        values, key, k = values[marked], (sr[marked] > 0).astype(np.intp), 2
    stats, _ = group_moments(key, values, k)
    if stats.n.min() == 0 and k == 2:
        raise _polarity_error(where, stats.n)
    mean, sem, count = summarize(stats.reshape(1, k))
    return float(mean[0]), float(sem[0]), int(count[0])
