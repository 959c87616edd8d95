"""The monotone branch of a sweep: where a read-out's signal first turns back (its fold).

A sweep's signal (an output, or a weighted 3-axis reading) can be read back only along its first
monotone branch: past the first turn a reading also occurs on the way back and becomes ambiguous.
:func:`first_turn` finds that turn for one sweep or many at once; the inverse tables
(:class:`magcilia.readout.inverse.InverseTable`) end there, and so does a design's read range
(:func:`magcilia.design.ranges.range_end`).

Examples
--------
>>> first_turn([0.0, 1.0, 2.0, 1.5, 3.0]).tolist()
2
>>> first_turn([[0.0, 1.0, 1.0, 2.0], [0.0, 1.0, 1.0, 2.0]], flat=True).tolist()
[1, 1]
>>> first_turn([3.0, 2.0, 1.0]).tolist()    # no turn: the last index
2
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray

I64 = NDArray[np.int64]


def first_true(mask: ArrayLike) -> I64:
    """Index of the first True along the last axis, or the axis's length where there is none;
    shape ``mask.shape[:-1]``."""
    m = np.asarray(mask, dtype=bool)
    return np.where(m.any(axis=-1), np.argmax(m, axis=-1), m.shape[-1]).astype(np.int64)


def first_turn(signal: ArrayLike, *, flat: bool = False) -> I64:
    """The last index of the monotone branch that starts at ``signal[..., 0]``, per sweep.

    The branch's direction is that of the first step that changes the signal; the branch ends
    before the first step against it (the index returned is the turning point: the extremum).

    Parameters
    ----------
    signal : array-like, shape (..., c)
        Sweeps along the last axis (c points each).
    flat : bool
        Whether a step that does not change the signal ends the branch too (an inverse table
        needs a strictly monotone one); default False: only a step back does.

    Returns
    -------
    ndarray of int, shape (...)
        The turning point's index, ``c - 1`` (the sweep's last) where the signal never turns; a
        signal that never changes has no direction: with ``flat`` its branch ends at 0.
    """
    x = np.asarray(signal, dtype=np.float64)
    c = x.shape[-1]
    if c < 2:
        return np.zeros(x.shape[:-1], dtype=np.int64)
    dp = np.diff(x, axis=-1)
    first = np.minimum(first_true(dp != 0.0), c - 2)
    sign = np.sign(np.take_along_axis(dp, first[..., None], axis=-1))
    against = np.sign(dp) * sign
    return first_true(against <= 0.0 if flat else against < 0.0)
