"""The checks of a recording's raw samples as pure NumPy over plain arrays: robust outliers per
condition, spikes in a time series, duplicated blocks of rows, garbled values
(:mod:`magcilia.io.quality` says what each means and reports them).

Each costs a few vectorised passes over the samples, and none sorts them in the common case, so
that the checks cost little beside reading a file (``benchmarks/bench_recordings.py``):

- **Conditions as runs of rows.** A recording keeps each condition's samples together, so a
  condition is a few runs of rows (start, length); the per-condition work is done on slices of
  them. A recording that interleaves its conditions (more runs than :func:`_many_runs` allows) is
  sorted by condition once (stable) and handled the same way.
- **Outliers.** The median and the median absolute deviation (MAD) of a condition (and polarity,
  and column) are those of its samples when it holds at most :data:`OUTLIER_SUBSAMPLE`, else of
  that many evenly spaced ones among them (their median is then known to 0.02σ and the scale to
  about 2 %, which moves the 8σ threshold by about 0.15σ: odds of a Gaussian sample beyond it
  stay below 1e-13). The smallest and largest sample of each run then tell whether
  any lies beyond the threshold (``|x − median| > threshold`` is monotone in x, also in floating
  point); only a run that holds one is gone through sample by sample.
- **Duplicated blocks.** A column that strictly increases or decreases (time stamps, a sample
  counter) makes every row distinct from every other: no row repeats an earlier one, and nothing
  needs hashing. Otherwise 64-bit hashes of the rows, and of windows of rows (built by doubling,
  2·log2(length) passes), are sorted once; repeats are confirmed bit for bit.
- **Garbled values.** A double with 0 < |x| < ``TINY`` is told by its bits (twice the bits
  without the sign, minus 2, below a constant: one comparison), in pieces that stay in cache.
"""

from __future__ import annotations

import math
from collections.abc import Iterator

import numpy as np
from numpy.typing import NDArray

from magcilia.io.moments import runs

F64 = NDArray[np.float64]
I64 = NDArray[np.int64]
Mask = NDArray[np.bool_]

#: the robust standard deviation of Gaussian noise per median absolute deviation
MAD_SIGMA = 1.482602218505602
#: most samples of a condition (per polarity) whose median and MAD are computed; above it, from
#: this many evenly spaced ones (standard errors of 0.02σ and about 2 % of σ)
OUTLIER_SUBSAMPLE = 1 << 12
#: rows handled at a time where a pass needs temporaries (a few MB: they stay in cache)
PIECE = 1 << 16


def _many_runs(runs: int, samples: int) -> bool:
    """Whether the runs are too many to go through one by one in Python (sorting the samples by
    condition once is then cheaper)."""
    return runs > 64 + samples // 256


def _pieces(start: int, stop: int, size: int = PIECE) -> Iterator[tuple[int, int]]:
    for a in range(start, stop, size):
        yield a, min(a + size, stop)


# -- outliers ------------------------------------------------------------------------------------
class _Group:
    """One condition's rows (runs of the samples) on one polarity side (None: all rows)."""

    def __init__(self, starts: I64, lengths: I64, sign: Mask | None, side: bool | None):
        self.runs = list(zip(starts.tolist(), (starts + lengths).tolist(), strict=True))
        self.sign, self.side = sign, side
        self.counts = [b - a if sign is None else int(np.count_nonzero(sign[a:b] == side))
                       for a, b in self.runs]
        self.size = sum(self.counts)

    def mask(self, a: int, b: int) -> Mask | None:
        return None if self.sign is None else np.asarray(self.sign[a:b] == self.side)

    def evenly_spaced(self, most: int) -> I64:
        """Rows of the group (increasing): all of them, or every k-th to keep at most ``most``."""
        step = max(1, math.ceil(self.size / most))
        picks: list[I64] = []
        seen = 0  # rows of the group before the current piece
        for (a, b), count in zip(self.runs, self.counts, strict=True):
            if self.sign is None:
                picks.append(np.arange(a + (-seen) % step, b, step))
                seen += count
                continue
            for p, q in _pieces(a, b):
                rows = np.flatnonzero(self.sign[p:q] == self.side)
                picks.append(p + rows[(-seen) % step::step])
                seen += rows.size
        return np.concatenate(picks) if picks else np.zeros(0, np.int64)

    def values(self, column: F64, a: int, b: int) -> F64:
        m = self.mask(a, b)
        return column[a:b] if m is None else column[a:b][m]


def centre_and_scale(values: F64) -> tuple[float, float]:
    """Median and robust standard deviation (1.4826 × MAD) of samples (shape (n,), n ≥ 1)."""
    med = float(np.median(values))
    return med, MAD_SIGMA * float(np.median(np.abs(values - med)))


def _floor(group: _Group, column: F64, med: float) -> float:
    """The smallest non-zero deviation from ``med`` in the group (the quantum of quantised data;
    inf when every sample equals it): the scale's floor."""
    least = math.inf
    for a, b in group.runs:
        for p, q in _pieces(a, b):
            dev = np.abs(group.values(column, p, q) - med)
            dev = dev[dev > 0.0]
            if dev.size:
                least = min(least, float(dev.min()))
    return least


def _group_outliers(group: _Group, columns: list[F64], sigmas: float, out: Mask) -> None:
    """Mark in ``out`` the group's samples beyond ``sigmas`` robust SDs of its median in any
    column."""
    picks = group.evenly_spaced(OUTLIER_SUBSAMPLE)
    for column in columns:
        med, scale = centre_and_scale(column[picks])
        if scale == 0.0:  # quantised: most samples equal
            scale = _floor(group, column, med)
        limit = sigmas * scale
        if not limit < math.inf:
            continue
        for a, b in group.runs:
            part = group.values(column, a, b)
            if part.size == 0 or not (part.max() - med > limit or med - part.min() > limit):
                continue  # no sample of the run beyond the threshold (or NaN: not judged)
            beyond = np.abs(column[a:b] - med) > limit
            m = group.mask(a, b)
            out[a:b] |= beyond if m is None else beyond & m


def outliers_in_runs(columns: list[F64], starts: I64, lengths: I64, run_group: I64,
                     groups: int, sign: Mask | None = None, *, sigmas: float,
                     min_samples: int, skip: Mask | None = None) -> tuple[Mask, I64]:
    """Samples beyond ``sigmas`` robust standard deviations (1.4826 × MAD, floored at the
    smallest non-zero deviation) from the median of their group (and polarity), in groups of at
    least ``min_samples``; any column counts.

    Parameters
    ----------
    columns : list of ndarray, each shape (s,)
        The samples (any unit), finite.
    starts, lengths, run_group : ndarray of int, shape (r,)
        The runs of rows and the group of each (0 … groups − 1).
    groups : int
        Number of groups.
    sign : ndarray of bool, shape (s,), optional
        The polarity (True: set): each polarity of a group is judged on its own.
    skip : ndarray of bool, shape (groups,), optional
        Groups not judged.

    Returns
    -------
    outlier : ndarray of bool, shape (s,)
    per_group : ndarray of int, shape (groups,)
        Outliers in each group.
    """
    s = columns[0].size if columns else 0
    out = np.zeros(s, dtype=bool)
    per = np.zeros(groups, np.int64)
    if s == 0:
        return out, per
    if _many_runs(starts.size, s):  # interleaved conditions: sorted by condition once
        label = np.repeat(run_group, lengths)
        order = np.argsort(label, kind="stable")
        label = label[order]
        st, ln = runs(label)
        inner, per = _outliers_by_group(
            [c[order] for c in columns], st, ln, label[st], groups,
            None if sign is None else sign[order], sigmas, min_samples, skip)
        out[order] = inner
        return out, per
    return _outliers_by_group(columns, starts, lengths, run_group, groups, sign, sigmas,
                              min_samples, skip)


def _outliers_by_group(columns: list[F64], starts: I64, lengths: I64, run_group: I64,
                       groups: int, sign: Mask | None, sigmas: float, min_samples: int,
                       skip: Mask | None) -> tuple[Mask, I64]:
    out = np.zeros(columns[0].size, dtype=bool)
    per = np.zeros(groups, np.int64)
    sizes = np.bincount(run_group, lengths, minlength=groups)
    order = np.argsort(run_group, kind="stable")  # the runs of each group, in file order
    bounds = np.searchsorted(run_group[order], np.arange(groups + 1))
    for g in np.flatnonzero(sizes >= min_samples).tolist():
        if skip is not None and skip[g]:
            continue
        mine = order[bounds[g]:bounds[g + 1]]
        marked = False
        for side in ((None,) if sign is None else (True, False)):
            group = _Group(starts[mine], lengths[mine], sign, side)
            if group.size >= min_samples:
                _group_outliers(group, columns, sigmas, out)
                marked = True
        if marked:
            per[g] = sum(int(np.count_nonzero(out[a:a + n]))
                         for a, n in zip(starts[mine].tolist(), lengths[mine].tolist(),
                                         strict=True))
    return out, per


# -- spikes --------------------------------------------------------------------------------------
def spikes_in_series(y: F64, sigmas: float) -> I64:
    """Indices of the samples of a series (shape (n,), in time order) that stand out from both
    neighbours in the same direction by more than ``sigmas`` robust SDs of the sample-to-sample
    differences (1.4826 × median |Δ| / √2; that median from at most :data:`OUTLIER_SUBSAMPLE`
    evenly spaced differences)."""
    n = y.size
    if n < 3:
        return np.zeros(0, np.int64)
    at = np.arange(0, n - 1, max(1, math.ceil((n - 1) / OUTLIER_SUBSAMPLE)))
    with np.errstate(invalid="ignore", over="ignore"):
        scale = MAD_SIGMA * float(np.median(np.abs(y[at + 1] - y[at]))) / math.sqrt(2.0)
        if not scale > 0.0:
            return np.zeros(0, np.int64)
        limit = sigmas * scale
        big: list[I64] = []  # differences d_i = y_(i+1) - y_i beyond the limit
        for a, b in _pieces(0, n - 1, 1 << 20):
            big.append(a + np.flatnonzero(np.abs(y[a + 1:b + 1] - y[a:b]) > limit))
        c = np.concatenate(big)
        pair = np.flatnonzero(c[1:] == c[:-1] + 1)  # y_j beyond both neighbours: d_(j-1), d_j
        j = c[pair] + 1
        left, right = y[j] - y[j - 1], y[j] - y[j + 1]
        return j[np.signbit(left) == np.signbit(right)]


# -- duplicated blocks ---------------------------------------------------------------------------
_MIX = (np.uint64(0x9E3779B97F4A7C15), np.uint64(0xBF58476D1CE4E5B9), np.uint64(31))
_BASE = 0x100000001B3


def strictly_monotone(column: F64) -> bool:
    """Whether a column strictly increases or strictly decreases (every value distinct)."""
    if column.size < 2:
        return True
    head = min(column.size, 1025)
    with np.errstate(invalid="ignore"):
        if column[-1] > column[0]:  # (the first values first: most columns fail at once)
            return bool((column[1:head] > column[:head - 1]).all()
                        and (column[1:] > column[:-1]).all())
        if column[-1] < column[0]:
            return bool((column[1:head] < column[:head - 1]).all()
                        and (column[1:] < column[:-1]).all())
    return False


def row_hashes(columns: list[F64]) -> NDArray[np.uint64]:
    """A 64-bit hash of each row's bits (columns of shape (s,) in, (s,) out)."""
    h = np.full(columns[0].size, _MIX[0], dtype=np.uint64)
    for column in columns:
        h ^= column.view(np.uint64)
        h *= _MIX[1]
        h ^= h >> _MIX[2]
    return h


def window_hashes(h: NDArray[np.uint64], length: int) -> NDArray[np.uint64]:
    """A polynomial hash of each window of ``length`` consecutive row hashes (shape
    (s − length + 1,)), built by doubling: a window of a + b rows is the one of a rows times
    B^b plus the one of b rows a rows on."""
    power, width, span = h, 1, length  # windows of `width` rows; `span` rows still to cover
    result: NDArray[np.uint64] | None = None
    done = 0
    while span:
        if span & 1:
            if result is None:
                result, done = power, width
            else:
                m = h.size - done - width + 1
                result = result[:m] * np.uint64(pow(_BASE, width, 1 << 64)) + power[done:done + m]
                done += width
        span >>= 1
        if span:
            m = power.size - width
            power = power[:m] * np.uint64(pow(_BASE, width, 1 << 64)) + power[width:]
            width *= 2
    assert result is not None
    return result[:h.size - length + 1]


def duplicated_blocks(columns: list[F64], length: int) -> tuple[Mask, I64]:
    """Rows that repeat an earlier run of at least ``length`` consecutive rows bit for bit (each
    run of distinct rows), and the blocks: see :func:`magcilia.io.quality.duplicated_rows`.

    ``columns``: contiguous float64 columns of shape (s,), every column read.
    """
    s = columns[0].size if columns else 0
    none = (np.zeros(s, dtype=bool), np.zeros((0, 3), np.int64))
    if s < 2 * length or any(strictly_monotone(c) for c in columns):
        return none  # (a strictly monotone column: every row differs from every other)
    h = row_hashes(columns)
    window = window_hashes(h, length)
    m = window.size
    ordered = np.sort(window)  # the common case: no window repeats, one sort says so
    if not (ordered[1:] == ordered[:-1]).any():
        return none
    del ordered
    order = np.argsort(h, kind="stable")  # each row's previous equal row (-1: none)
    same = np.concatenate(([False], h[order][1:] == h[order][:-1]))
    prev = np.full(s, -1, np.int64)
    prev[order[same]] = order[np.flatnonzero(same) - 1]
    del order, same
    latest = np.full(m, -1, np.int64)  # the latest previous occurrence of a row in the window
    for k in range(length):
        np.maximum(latest, prev[k:k + m], out=latest)
    starts = np.arange(m)
    distinct = latest < starts
    del latest, prev
    window[~distinct] = 0
    _, first, inverse = np.unique(window, return_index=True, return_inverse=True)
    source = first[inverse.ravel()]
    candidate = np.flatnonzero(distinct & (source + length <= starts))
    if candidate.size == 0:
        return none
    src = source[candidate]
    same_rows = np.ones(candidate.size, dtype=bool)
    for k in range(length):  # confirmed bit for bit (hashes can collide)
        for column in columns:
            bits = column.view(np.uint64)
            same_rows &= bits[candidate + k] == bits[src + k]
    candidate, src = candidate[same_rows], src[same_rows]
    if candidate.size == 0:
        return none
    cover = np.zeros(s + 1, np.int64)  # rows covered by a confirmed window
    np.add.at(cover, candidate, 1)
    np.add.at(cover, candidate + length, -1)
    duplicate = np.cumsum(cover[:-1]) > 0
    new = np.concatenate(([True], (np.diff(candidate) != 1) | (np.diff(candidate - src) != 0)))
    firsts = np.flatnonzero(new)
    lasts = np.append(firsts[1:], candidate.size) - 1
    blocks = np.stack([candidate[firsts], candidate[lasts] - candidate[firsts] + length,
                       src[firsts]], axis=1).astype(np.int64)
    return duplicate, blocks


# -- garbled values ------------------------------------------------------------------------------
def garbled(column: F64, tiny: float) -> Mask | None:
    """Where ``0 < |x| < tiny`` in a column (shape (s,)), or None where nowhere (the common case:
    no array of the column's size is made). NaN and inf are not garbled."""
    # |x| < tiny and x != 0  <=>  2 <= (bits << 1) < (bits(tiny) << 1), the sign shifted out
    limit = (np.uint64(np.float64(tiny).view(np.uint64)) << np.uint64(1)) - np.uint64(2)
    work = np.empty(min(PIECE, column.size), np.uint64)
    found: list[I64] = []
    for a, b in _pieces(0, column.size):
        bits = np.ascontiguousarray(column[a:b]).view(np.uint64)
        w = work[:b - a]
        np.left_shift(bits, np.uint64(1), out=w)
        w -= np.uint64(2)  # (0 wraps round to the largest value)
        hit = w < limit
        if hit.any():
            found.append(a + np.flatnonzero(hit))
    if not found:
        return None
    out = np.zeros(column.size, dtype=bool)
    out[np.concatenate(found)] = True
    return out
