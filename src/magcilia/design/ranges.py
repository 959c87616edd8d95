"""Where a design's read range ends: the sensor's rated range or a fold of what it reads.

One rule for every sweep, one sweep or many at once (:func:`range_end`): from the first load, the
range ends at the first of

* the sensor leaving its rated range: the largest of |reading_i| / full_scale_i over its read
  axes and of |B| / the rated total field passes 1 (:func:`rated_ratio`; the HMC1021Z's ±6 gauss
  hold for the sensitive axis and, by its datasheet, for the total applied field), interpolated
  between sweep points;
* a fold: the read-out's signal (an output, or a weighted 3-axis reading) turns back
  (:func:`magcilia.readout.branch.first_turn`, the rule the inverse tables end by), so readings
  become ambiguous.

When the sweep ends first, the range has not been reached: its value is the sweep's end, a
lower bound (:attr:`RangeEnd.END`). :func:`magcilia.design_metrics` and
:func:`magcilia.optimise_design` (its exact metrics and its vectorised screen) all end their
ranges here.

Examples
--------
>>> q = np.array([0.0, 1.0, 2.0, 3.0])
>>> value, kind, last = range_end(q, np.array([0.2, 0.6, 1.4, 2.0]), q)
>>> float(value), RangeEnd(int(kind)).name, int(last)
(1.5, 'SATURATED', 1)
>>> value, kind, last = range_end(q, np.zeros(4), np.array([0.0, 2.0, 3.0, 1.0]))
>>> float(value), RangeEnd(int(kind)).name, int(last)
(2.0, 'FOLD', 2)
"""

from __future__ import annotations

import enum
import math

import numpy as np
from numpy.typing import NDArray

from magcilia._display import number
from magcilia.constants import GAUSS
from magcilia.readout.branch import first_true, first_turn

F64 = NDArray[np.float64]
I64 = NDArray[np.int64]

#: the note of a range that ends in a fold of the output
FOLD_NOTE = "fold (output turns back)"
#: the note of a range that ends at zero load (saturated there already)
SATURATED_AT_ZERO = "sensor range (beyond its rated range at zero load)"
#: the prefix of a range that the sweep did not reach (the value is a lower bound)
NOT_REACHED = "not reached: "


class RangeEnd(enum.IntEnum):
    """What ends a read range (:func:`range_end`)."""

    #: the first load is beyond the rated range already: the range is 0
    ZERO = 0
    #: the sensor leaves its rated range (interpolated between sweep points)
    SATURATED = 1
    #: the read-out's signal turns back
    FOLD = 2
    #: the sweep ended first: the range is not reached, its value a lower bound
    END = 3


def range_end(q: F64, ratio: F64, signal: F64, end: F64 | float | None = None
              ) -> tuple[F64, I64, I64]:
    """Where each sweep's range ends, from q[..., 0]: the first load whose reading leaves the
    sensor's range (interpolated where ``ratio`` crosses 1) or the first fold of ``signal``,
    whichever comes first, else the sweep's end.

    Parameters
    ----------
    q : ndarray, shape (..., c)
        The loads, increasing along the last axis.
    ratio : ndarray, shape (..., c)
        The reading over its full scale (the largest over a sensor's axes, :func:`rated_ratio`);
        beyond 1: saturated.
    signal : ndarray, shape (..., c)
        What the read-out inverts (an output, or a weighted 3-axis reading): its first turn is
        the fold.
    end : float or ndarray, shape (...), optional
        The value of a range the sweep did not reach (default the last load, ``q[..., -1]``).

    Returns
    -------
    value : ndarray, shape (...)
        The range's end (the unit of ``q``; 0 for :attr:`RangeEnd.ZERO`).
    kind : ndarray of int, shape (...)
        What ends it, a :class:`RangeEnd`.
    last : ndarray of int, shape (...)
        The last sweep index within the range.
    """
    q = np.asarray(q, dtype=np.float64)
    ratio = np.asarray(ratio, dtype=np.float64)
    c = q.shape[-1]
    stop = q[..., -1] if end is None else np.asarray(end, dtype=np.float64)
    i_sat = first_true(ratio > 1.0)
    i_fold = first_turn(signal)
    sat = (i_sat < c) & (i_sat <= i_fold)
    zero = sat & (i_sat == 0)
    fold = ~sat & (i_fold < c - 1)
    lo = np.maximum(i_sat - 1, 0)[..., None]
    hi = np.minimum(i_sat, c - 1)[..., None]
    r0 = np.take_along_axis(ratio, lo, axis=-1)[..., 0]
    r1 = np.take_along_axis(ratio, hi, axis=-1)[..., 0]
    q0 = np.take_along_axis(q, lo, axis=-1)[..., 0]
    q1 = np.take_along_axis(q, hi, axis=-1)[..., 0]
    with np.errstate(divide="ignore", invalid="ignore"):
        t = np.where(r1 > r0, (1.0 - r0) / (r1 - r0), 0.0)
    at_fold = np.take_along_axis(q, np.minimum(i_fold, c - 1)[..., None], axis=-1)[..., 0]
    value = np.where(sat, np.where(zero, 0.0, q0 + t * (q1 - q0)), np.where(fold, at_fold, stop))
    kind = np.select([zero, sat, fold], [RangeEnd.ZERO, RangeEnd.SATURATED, RangeEnd.FOLD],
                     RangeEnd.END).astype(np.int64)
    last = np.where(sat, lo[..., 0], np.where(fold, i_fold, c - 1)).astype(np.int64)
    return value, kind, last


def rated_ratio(reading: F64, full_scale: F64, magnitude: F64, total: float
                ) -> tuple[F64, I64]:
    """How far into its rated range a sensor is, per sweep point: the largest of |reading_i| /
    full_scale_i over its read axes and of |B| / ``total`` (a rated range of the total applied
    field, as the HMC1021Z's datasheet states; inf: none), shape (..., c); beyond 1 the read-out
    has ended (:func:`range_end`). Also which term is largest (..., c): 0, 1, 2 for an axis, 3
    for |B|.

    Parameters
    ----------
    reading : ndarray, shape (..., c, 3)
        The field on the sensor's axes, T (a single-axis element: the board's, only x read).
    full_scale : ndarray, shape (3,)
        Range per axis, T (inf: the axis is not read).
    magnitude : ndarray, shape (..., c)
        |B| at the sensing point, T.
    total : float
        Rated range of |B|, T (inf for none).
    """
    terms = np.concatenate([np.abs(reading) / full_scale, (magnitude / total)[..., None]],
                           axis=-1)
    return np.max(terms, axis=-1), np.argmax(terms, axis=-1)


def range_text(kind: RangeEnd, which: int, full_scale: F64, total: float, axes: int,
               end_note: str) -> str:
    """What ends a range (:func:`range_end`'s ``kind``; ``which``: :func:`rated_ratio`'s term at
    the crossing), for reports: the rated range (an axis or the total field), a fold, or for a
    range not reached what ended the sweep (``end_note``)."""
    if kind is RangeEnd.ZERO:
        return SATURATED_AT_ZERO
    if kind is RangeEnd.FOLD:
        return FOLD_NOTE
    if kind is RangeEnd.END:
        return NOT_REACHED + end_note
    if which == 3:
        return f"sensor range (|B| {number(total / GAUSS)} gauss, the rated total field)"
    axis = f" on {'xyz'[which]}" if axes == 3 else f" on B_{'xyz'[which]}"
    return f"sensor range (±{number(full_scale[which] / GAUSS)} gauss{axis})"


def read_range(q: F64, reading: F64, b: F64, full_scale: F64, total: float, signal: F64,
               axes: int, end_note: str) -> tuple[float, str, int, bool]:
    """The range of one sweep from q[0] (:func:`range_end` of :func:`rated_ratio`): where the
    sensor leaves its rated range or the read-out ``signal`` (c,) folds, else the sweep's end
    (not reached). ``reading``, ``b``, ``full_scale`` and ``total`` as :func:`rated_ratio`;
    ``axes`` the sensor's read axes (1 or 3) and ``end_note`` what ended the sweep, for
    :func:`range_text`. Returns the value (the unit of ``q``), what ends it, the last sweep index
    within it and whether it was reached."""
    ratio, which = rated_ratio(reading, full_scale, np.linalg.norm(b, axis=-1), total)
    value, kind, last = range_end(q, ratio, signal)
    end = RangeEnd(int(kind))
    term = int(which[min(int(last) + 1, which.size - 1)])
    return (float(value), range_text(end, term, full_scale, total, axes, end_note), int(last),
            end is not RangeEnd.END)


def single_axis_range(q: F64, b: F64, field_range: float, voltage: F64, end_note: str
                      ) -> tuple[float, str, bool]:
    """:func:`read_range` of a single-axis element (B_x and |B| within ±``field_range``, T; the
    output ``voltage`` (c,) as the signal) for the fields ``b`` (c, 3): the value, what ends it
    and whether it was reached."""
    value, why, _, reached = read_range(
        q, b, b, np.array([field_range, math.inf, math.inf]), field_range, voltage, 1, end_note)
    return value, why, reached
