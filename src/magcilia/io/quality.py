"""Is a recording fit to be fitted? Checks of its raw samples before they are reduced, so that a
single bad value cannot move a fit without a word.

Four findings, each counted and named (:class:`RecordingQuality`):

- **sparse conditions**: a condition (tilt angle or load, at an azimuth) holding at most
  :data:`SPARSE_FRACTION` of the median number of samples of the recording's conditions: a
  dropped digit (39.8438 → 3.8438 deg) makes a new "angle" of one sample against 2,000 at the
  others, which a fit weighs like any other angle;
- **outliers**: samples more than :data:`OUTLIER_SIGMAS` robust standard deviations
  (1.4826 × the median absolute deviation; Rousseeuw & Croux 1993) from the median of their
  condition (and set/reset polarity, and field component), in conditions of at least
  :data:`OUTLIER_MIN_SAMPLES` samples. One sample ×10 stands out; the noise does not: a
  Gaussian sample beyond 8 σ has odds of 1e-15, and the scale estimated from 30 samples is good
  enough that seeded Gaussian noise flags a sample in 1e-4 of such groups. Data quantised so
  finely that most samples of a condition are equal take the quantum as the scale's floor. A
  recording without conditions (a read-out's time series) is checked for *spikes* instead:
  samples beyond :data:`OUTLIER_SIGMAS` robust standard deviations of the sample-to-sample
  differences from *both* neighbours, in the same direction (a step of the load moves from one
  neighbour only, and is kept);
- **duplicated blocks**: runs of at least :data:`DUPLICATE_ROWS` consecutive rows that repeat an
  earlier run bit for bit, in every column read (the time stamps too, where the file has them),
  each row of the run distinct from the others in it (so that a constant or periodic signal
  without time stamps is not mistaken for copies): an export or a copy gone wrong. The later
  copies are the duplicates;
- **garbled values**: a condition, azimuth or observable value that is not zero but smaller in
  magnitude than :data:`TINY` (1e-100 of its unit: no instrument resolves that; it is what a
  damaged exponent of a double looks like, as huge values are, which the range checks refuse).

The functions take plain arrays (pure, vectorised NumPy: per condition an O(n) selection after
one sort of the condition labels, which a recording keeps in runs; duplicates by 64-bit hashes of
the rows and of windows of rows, confirmed row by row); :func:`check_samples` runs all three.
What is done with the findings is the caller's policy (:data:`SUSPECT_POLICIES`: keep them and
say so, omit them and say so, or refuse the recording).
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from magcilia import _validate as v
from magcilia._display import Display, Item, count
from magcilia._errors import MagciliaError
from magcilia.io.columns import ANGLE_DECIMALS, FIELD_KEYS, LOAD_UNITS, scaled
from magcilia.io.moments import by_value, runs

F64 = NDArray[np.float64]
I64 = NDArray[np.int64]

#: a condition with at most this fraction of the median samples per condition is sparse
SPARSE_FRACTION = 0.25
#: a sample this many robust standard deviations from its condition's median is an outlier
OUTLIER_SIGMAS = 8.0
#: conditions (per polarity) with fewer samples are not checked for outliers (the median absolute
#: deviation of fewer is too uncertain: seeded Gaussian noise flags a sample in 1.1 % of groups
#: of 8, 0.04 % of groups of 20, 0.01 % of groups of 30, none of 20,000 groups of 50)
OUTLIER_MIN_SAMPLES = 30
#: the shortest run of rows that, repeating an earlier run, is a duplicated block
DUPLICATE_ROWS = 16
#: a value smaller than this in magnitude, but not zero, is garbled (a damaged exponent)
TINY = 1e-100
#: what a reader does with the samples flagged: keep them (and say so), omit them (and say so),
#: or refuse the recording
SUSPECT_POLICIES = ("keep", "omit", "raise")
#: the robust standard deviation of Gaussian noise per median absolute deviation
MAD_SIGMA = 1.482602218505602
#: the quantity a condition is a value of -> (unit in reports, factor from SI)
CONDITIONS = {"angle": ("deg", float(np.degrees(1.0))), "force": ("uN", 1e6),
              "flow": ("mm/s", 1e3), "time": ("", 1.0)}


def _table(values: ArrayLike) -> F64:
    """Values as a table of shape (s, w): a vector is one column."""
    x = np.asarray(values, dtype=np.float64)
    return x.reshape(-1, 1) if x.ndim <= 1 else x.reshape(x.shape[0], -1)


def sparse_conditions(counts: ArrayLike, fraction: float = SPARSE_FRACTION) -> NDArray[np.bool_]:
    """Which conditions hold far fewer samples than their peers: at most ``fraction`` of the
    median count (shape (c,) in, (c,) out; none with fewer than two conditions).

    >>> sparse_conditions([2000, 1999, 1, 2000]).tolist()
    [False, False, True, False]
    """
    n = np.asarray(counts, dtype=np.float64).ravel()
    if n.size < 2:
        return np.zeros(n.size, dtype=bool)
    return np.asarray(n <= fraction * float(np.median(n)))


def _group_rows(group: NDArray[np.intp]) -> list[slice] | list[NDArray[np.intp]]:
    """Each group's rows: slices when every group is one run of rows (a recording keeps each
    condition's samples together: no sort), else index arrays from one stable sort."""
    starts, lengths = runs(group)
    if np.unique(group[starts]).size == starts.size:
        return [slice(a, a + n) for a, n in zip(starts.tolist(), lengths.tolist(), strict=True)]
    order = np.argsort(group, kind="stable")
    ordered = group[order]
    cut = np.flatnonzero(ordered[1:] != ordered[:-1]) + 1
    return np.split(order, cut)


def _outliers(part: F64, sigmas: float) -> NDArray[np.bool_]:
    """Which rows of ``part`` (shape (n, w)) lie beyond ``sigmas`` robust SDs of its median."""
    med = np.median(part, axis=0)
    dev = np.abs(part - med)
    scale = MAD_SIGMA * np.median(dev, axis=0)
    for j in np.flatnonzero(scale == 0.0):  # quantised: the smallest non-zero deviation
        positive = dev[:, j][dev[:, j] > 0.0]
        scale[j] = positive.min() if positive.size else np.inf
    with np.errstate(invalid="ignore"):
        return np.asarray((dev > sigmas * scale).any(axis=1))


def robust_outliers(group: ArrayLike, values: ArrayLike, polarity: ArrayLike | None = None, *,
                    sigmas: float = OUTLIER_SIGMAS,
                    min_samples: int = OUTLIER_MIN_SAMPLES) -> NDArray[np.bool_]:
    """Which samples lie more than ``sigmas`` robust standard deviations (1.4826 × MAD, floored
    at the smallest non-zero deviation: the quantum of quantised data) from the median of their
    group (and polarity), in groups of at least ``min_samples``.

    Parameters
    ----------
    group : array-like of int, shape (s,)
        Each sample's group (a condition).
    values : array-like, shape (s,) or (s, w)
        The samples (any unit); with several columns, a sample is an outlier if any column is.
    polarity : array-like, shape (s,), optional
        +1/−1 set/reset marks: each polarity of a group is judged on its own.

    Returns
    -------
    ndarray of bool, shape (s,)

    Examples
    --------
    >>> x = np.r_[np.linspace(-1, 1, 40), 10.0]
    >>> np.flatnonzero(robust_outliers(np.zeros(41, int), x)).tolist()
    [40]
    """
    key = np.asarray(group, dtype=np.intp).ravel()
    x = _table(values)
    sign = None if polarity is None else np.asarray(polarity).ravel() > 0
    out = np.zeros(key.size, dtype=bool)
    if key.size == 0:
        return out
    for rows in _group_rows(key):
        part = x[rows]
        if sign is None:
            if part.shape[0] >= min_samples:
                out[rows] = _outliers(part, sigmas)
            continue
        index = np.arange(key.size)[rows]
        for side in (sign[rows], ~sign[rows]):
            if np.count_nonzero(side) >= min_samples:
                out[index[side]] = _outliers(part[side], sigmas)
    return out


def spikes(values: ArrayLike, polarity: ArrayLike | None = None, *,
           sigmas: float = OUTLIER_SIGMAS) -> NDArray[np.bool_]:
    """Which samples of a time series stand out from both neighbours in the same direction by
    more than ``sigmas`` robust standard deviations of the sample-to-sample differences (a
    single-sample spike; a step of the signal moves from one neighbour only).

    Parameters
    ----------
    values : array-like, shape (s,) or (s, w)
        The samples in time order (any unit); with several columns, any column.
    polarity : array-like, shape (s,), optional
        +1/−1 set/reset marks: each polarity's samples are a series of their own.

    Examples
    --------
    >>> x = np.sin(np.arange(50) / 5.0)
    >>> x[20] += 3.0
    >>> np.flatnonzero(spikes(x)).tolist()
    [20]
    """
    x = _table(values)
    out = np.zeros(x.shape[0], dtype=bool)
    series = ([np.arange(x.shape[0])] if polarity is None else
              [np.flatnonzero(np.asarray(polarity) == p) for p in (1.0, -1.0)])
    for rows in series:
        if rows.size < 3:
            continue
        y = x[rows]
        with np.errstate(invalid="ignore", over="ignore"):
            d = np.diff(y, axis=0)
            scale = MAD_SIGMA * np.median(np.abs(d), axis=0) / np.sqrt(2.0)
            left, right = d[:-1], -d[1:]  # y_i - y_(i-1) and y_i - y_(i+1)
            both = (np.sign(left) == np.sign(right)) & (
                np.minimum(np.abs(left), np.abs(right)) > sigmas * np.where(scale > 0, scale,
                                                                             np.inf))
        out[rows[1:-1]] |= both.any(axis=1)
    return out


def _row_hashes(columns: list[F64]) -> NDArray[np.uint64]:
    """A 64-bit hash of each row's bits (columns of shape (s,) in, (s,) out)."""
    h = np.full(columns[0].size, 0x9E3779B97F4A7C15, dtype=np.uint64)
    with np.errstate(over="ignore"):
        for column in columns:
            h ^= column.view(np.uint64)
            h *= np.uint64(0xBF58476D1CE4E5B9)
            h ^= h >> np.uint64(31)
    return h


def _columns(rows: ArrayLike | list[ArrayLike]) -> list[F64]:
    """Rows as contiguous float64 columns: a 2-D array's columns, or a list of 1-D columns."""
    if isinstance(rows, list | tuple):
        return [np.ascontiguousarray(np.asarray(c, dtype=np.float64).ravel()) for c in rows]
    x = _table(rows)
    return [np.ascontiguousarray(x[:, j]) for j in range(x.shape[1])]


def duplicated_rows(rows: ArrayLike | list[ArrayLike], length: int = DUPLICATE_ROWS
                    ) -> tuple[NDArray[np.bool_], I64]:
    """Rows that repeat an earlier run of at least ``length`` consecutive rows bit for bit (each
    run of distinct rows), and the duplicated blocks.

    Parameters
    ----------
    rows : array-like, shape (s, c), or a list of c arrays of shape (s,)
        Every column read, in file order.
    length : int
        The shortest run that counts.

    Returns
    -------
    duplicate : ndarray of bool, shape (s,)
        The later copies.
    blocks : ndarray of int, shape (b, 3)
        Each block: first row, rows, first row of the earlier run it repeats (0-based).

    Examples
    --------
    >>> t = np.arange(100.0)
    >>> data = np.column_stack([t, np.sin(t)])
    >>> doubled = np.concatenate([data[:60], data[40:60], data[60:]])
    >>> dup, blocks = duplicated_rows(doubled)
    >>> int(dup.sum()), blocks.tolist()
    (20, [[60, 20, 40]])
    """
    columns = _columns(rows)
    s = columns[0].size if columns else 0
    none = (np.zeros(s, dtype=bool), np.zeros((0, 3), np.int64))
    if s < 2 * length:
        return none
    h = _row_hashes(columns)
    m = s - length + 1
    window = np.zeros(m, dtype=np.uint64)
    with np.errstate(over="ignore"):
        for k in range(length):
            window *= np.uint64(0x100000001B3)
            window += h[k:k + m]
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


def _labels(values: F64, azimuths: F64, kind: str) -> list[str]:
    unit, factor = CONDITIONS[kind]
    text = [f"{x * factor:.6g} {unit}".rstrip() for x in values]
    if np.any(azimuths != 0.0):
        text = [f"{t} at azimuth {np.degrees(z):g} deg" for t, z in zip(text, azimuths,
                                                                        strict=True)]
    return text


def _listed(items: list[str], limit: int = 6) -> str:
    return ", ".join(items[:limit]) + (f", … ({len(items)} in all)" if len(items) > limit
                                       else "")


@dataclass(frozen=True, eq=False, repr=False)
class RecordingQuality(Display):
    """What the checks of a recording's samples found (see the module docstring), SI.

    Attributes
    ----------
    samples : int
        Samples checked.
    condition : str
        What a condition is a value of: ``"angle"`` (rad), ``"force"`` (N), ``"flow"`` (m/s), or
        ``"time"`` for a time series without conditions (outliers are then spikes).
    median_count : float
        The median number of samples per condition (0 for a time series).
    sparse_values, sparse_azimuths : ndarray, shape (k,)
        The sparse conditions: their value (SI, as ``condition``) and azimuth (rad).
    sparse_counts : ndarray of int, shape (k,)
        Their samples.
    outlier_values, outlier_azimuths : ndarray, shape (o,)
        The conditions holding outliers (a time series: none, the outliers are counted).
    outlier_counts : ndarray of int, shape (o,)
        Outliers in each.
    blocks : ndarray of int, shape (b, 3)
        Duplicated blocks: first row, rows, first row of the earlier run (0-based rows of the
        file's samples).
    flagged : ndarray of int, shape (f,)
        Every flagged row (0-based, increasing): the sparse conditions' samples, the outliers
        and the duplicates.
    outliers, duplicates, garbled : int
        Outlier samples, duplicated rows, samples with a garbled value.
    policy : str
        What is done with the flagged samples: ``"keep"`` (used, and said), ``"omit"`` (left
        out, and said) or ``"raise"`` (the recording refused).
    """

    samples: int
    condition: str = "angle"
    median_count: float = 0.0
    sparse_values: F64 = field(default_factory=lambda: np.zeros(0))
    sparse_azimuths: F64 = field(default_factory=lambda: np.zeros(0))
    sparse_counts: I64 = field(default_factory=lambda: np.zeros(0, np.int64))
    outlier_values: F64 = field(default_factory=lambda: np.zeros(0))
    outlier_azimuths: F64 = field(default_factory=lambda: np.zeros(0))
    outlier_counts: I64 = field(default_factory=lambda: np.zeros(0, np.int64))
    blocks: I64 = field(default_factory=lambda: np.zeros((0, 3), np.int64))
    flagged: I64 = field(default_factory=lambda: np.zeros(0, np.int64))
    outliers: int = 0
    duplicates: int = 0
    garbled: int = 0
    policy: str = "keep"

    def __post_init__(self) -> None:
        v.choice("policy", self.policy, SUSPECT_POLICIES)
        v.choice("condition", self.condition, tuple(CONDITIONS))
        for name in ("sparse_values", "sparse_azimuths", "sparse_counts", "outlier_values",
                     "outlier_azimuths", "outlier_counts", "blocks", "flagged"):
            arr = np.array(getattr(self, name))
            arr.setflags(write=False)
            object.__setattr__(self, name, arr)

    @property
    def found(self) -> bool:
        """Whether anything was flagged."""
        return bool(self.flagged.size)

    def findings(self) -> list[str]:
        """One line per kind of finding (empty when nothing was flagged)."""
        out = []
        if self.sparse_counts.size:
            where = _labels(self.sparse_values, self.sparse_azimuths, self.condition)
            out.append(f"{count(self.sparse_counts.size, 'condition')} with far fewer samples "
                       f"than the others (median {self.median_count:g}): " + _listed(
                           [f"{w} ({count(int(n), 'sample')})"
                            for w, n in zip(where, self.sparse_counts, strict=True)]))
        if self.outliers:
            what = ("from both neighbours (spikes)" if self.condition == "time"
                    else "from their condition's median")
            text = (f"{count(self.outliers, 'sample')} beyond {OUTLIER_SIGMAS:g} robust "
                    f"standard deviations {what}")
            if self.outlier_counts.size:
                where = _labels(self.outlier_values, self.outlier_azimuths, self.condition)
                text += ": " + _listed([f"{n} at {w}" for w, n in
                                        zip(where, self.outlier_counts, strict=True)])
            out.append(text)
        if self.garbled:
            out.append(f"{count(self.garbled, 'sample')} with a value too small to be measured "
                       f"(0 < |x| < {TINY:g}: a damaged exponent)")
        if self.duplicates:
            out.append(f"{count(self.duplicates, 'row')} repeating earlier rows bit for bit ("
                       + _listed([f"rows {b + 1}–{b + n} repeat rows {c + 1}–{c + n}"
                                  for b, n, c in self.blocks.tolist()], 3) + ")")
        return out

    def report(self) -> str:
        """The findings and what was done with them, or that nothing was found."""
        found = self.findings()
        if not found:
            return f"quality: {self.samples} samples checked, nothing flagged"
        done = {"keep": "kept (omit them: --suspect omit)", "omit": "left out",
                "raise": "the reason the recording is refused"}[self.policy]
        n = int(self.flagged.size)
        these = "this sample is" if n == 1 else f"these {n} samples are"
        return f"quality: {'; '.join(found)}; {these} {done}"

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready, SI (conditions in rad, N or m/s; rows 0-based)."""
        return {"samples": self.samples, "condition": self.condition,
                "median_count": self.median_count, "flagged": int(self.flagged.size),
                "sparse_values": self.sparse_values.tolist(),
                "sparse_azimuths_rad": self.sparse_azimuths.tolist(),
                "sparse_counts": self.sparse_counts.tolist(), "outliers": self.outliers,
                "outlier_values": self.outlier_values.tolist(),
                "outlier_azimuths_rad": self.outlier_azimuths.tolist(),
                "outlier_counts": self.outlier_counts.tolist(), "duplicates": self.duplicates,
                "duplicate_blocks": self.blocks.tolist(), "garbled": self.garbled,
                "policy": self.policy}

    def kept(self, columns: Mapping[str, NDArray[Any]]) -> dict[str, NDArray[Any]]:
        """``columns`` (shapes (s,), the samples checked) without the flagged rows."""
        keep = np.ones(self.samples, dtype=bool)
        keep[self.flagged] = False
        return {k: np.asarray(a)[keep] for k, a in columns.items()}

    @classmethod
    def from_dict(cls, data: Mapping[str, Any]) -> RecordingQuality:
        """Rebuild from :meth:`to_dict` output (the flagged rows are not kept there: only their
        number, as that many placeholders)."""
        with v.rebuilding("quality data", "RecordingQuality"):
            return cls(
                samples=int(data["samples"]), condition=str(data["condition"]),
                median_count=float(data["median_count"]),
                sparse_values=np.asarray(data["sparse_values"], np.float64),
                sparse_azimuths=np.asarray(data["sparse_azimuths_rad"], np.float64),
                sparse_counts=np.asarray(data["sparse_counts"], np.int64),
                outlier_values=np.asarray(data["outlier_values"], np.float64),
                outlier_azimuths=np.asarray(data["outlier_azimuths_rad"], np.float64),
                outlier_counts=np.asarray(data["outlier_counts"], np.int64),
                blocks=np.asarray(data["duplicate_blocks"], np.int64).reshape(-1, 3),
                flagged=np.full(int(data["flagged"]), -1, np.int64),
                outliers=int(data["outliers"]), duplicates=int(data["duplicates"]),
                garbled=int(data.get("garbled", 0)), policy=str(data["policy"]))

    def _display_items(self) -> list[Item]:
        return [("samples", str(self.samples)), ("flagged", str(int(self.flagged.size))),
                ("sparse conditions", str(self.sparse_counts.size)),
                ("outliers", str(self.outliers)), ("duplicated rows", str(self.duplicates)),
                ("garbled", str(self.garbled)),
                ("policy", self.policy)]


def check_samples(condition: ArrayLike | None, observable: ArrayLike, *,
                  azimuth: ArrayLike | None = None, polarity: ArrayLike | None = None,
                  rows: list[ArrayLike] | None = None, kind: str = "angle",
                  policy: str = "keep") -> RecordingQuality:
    """Run the three checks on a recording's samples.

    Parameters
    ----------
    condition : array-like, shape (s,), or None
        Each sample's condition, as grouped (the rounded angle in deg, or the load): samples of
        equal value are one condition. None for a time series (spikes, no sparse conditions).
    observable : array-like, shape (s,) or (s, w)
        The output (V) or the field components (T).
    azimuth : array-like, shape (s,), optional
        Each sample's azimuth, deg (with ``condition``: conditions are (azimuth, value) pairs).
    polarity : array-like, shape (s,), optional
        +1/−1 set/reset marks: outliers are judged per polarity.
    rows : list of array-like, each shape (s,), optional
        Every column read, for the duplicates (default: the observable, condition and azimuth).
    kind : {"angle", "force", "flow"}
        What ``condition`` is a value of; its values are in deg, uN or mm/s (the grouping units
        of :mod:`magcilia.io.recordings`) and the result holds them in SI.
    policy : {"keep", "omit", "raise"}
        Kept in the result (what the caller does with the flagged samples).

    Returns
    -------
    RecordingQuality
        Samples whose condition or observable is not finite are not judged (they are counted
        elsewhere).
    """
    policy = v.choice("policy", policy, SUSPECT_POLICIES)
    y = _table(observable)
    s = y.shape[0]
    columns: list[ArrayLike] = [y[:, j] for j in range(y.shape[1])]
    finite = np.isfinite(y).all(axis=1)
    sign = None if polarity is None else np.asarray(polarity, dtype=np.float64).ravel()
    if sign is not None:
        finite &= (sign == 1.0) | (sign == -1.0)
    quality: dict[str, Any] = {"samples": s, "policy": policy}
    flagged = np.zeros(s, dtype=bool)
    outlier = np.zeros(s, dtype=bool)
    if condition is None:
        use: slice | NDArray[np.intp] = slice(None) if finite.all() else np.flatnonzero(finite)
        outlier[use] = spikes(y[use], None if sign is None else sign[use])
        quality["condition"] = "time"
    else:
        cond = np.asarray(condition, dtype=np.float64).ravel()
        az = None if azimuth is None else np.asarray(azimuth, dtype=np.float64).ravel()
        columns += [cond] if az is None else [cond, az]
        finite &= np.isfinite(cond) & (True if az is None else np.isfinite(az))
        use = slice(None) if finite.all() else np.flatnonzero(finite)
        if az is None:  # grouped by the value alone (as the reduction does), at azimuth 0
            values, group = by_value(cond[use])
            distinct = values.astype(np.complex128) * 1j
        else:
            key = np.empty(cond[use].size, np.complex128)
            key.real, key.imag = az[use], cond[use]
            distinct, group = by_value(key)
            del key
        counts = np.bincount(group, minlength=distinct.size)
        sparse = sparse_conditions(counts)
        unit_factor = CONDITIONS[kind][1]
        found = robust_outliers(group, y[use], None if sign is None else sign[use])
        if sparse.any():
            flagged[use] = sparse[group]
            found &= ~sparse[group]
        outlier[use] = found
        per = np.bincount(group[found], minlength=distinct.size).astype(np.int64)
        has = per > 0
        quality.update(
            condition=kind, median_count=float(np.median(counts)) if counts.size else 0.0,
            sparse_values=distinct.imag[sparse] / unit_factor,
            sparse_azimuths=np.radians(distinct.real[sparse]), sparse_counts=counts[sparse],
            outlier_values=distinct.imag[has] / unit_factor,
            outlier_azimuths=np.radians(distinct.real[has]), outlier_counts=per[has])
    duplicate, blocks = duplicated_rows(list(columns if rows is None else rows))
    garbled = np.zeros(s, dtype=bool)
    with np.errstate(invalid="ignore"):
        for column in columns:
            x = np.asarray(column, dtype=np.float64)
            garbled |= (np.abs(x) < TINY) & (x != 0.0)
    flagged |= outlier | duplicate | garbled
    quality.update(outliers=int(outlier.sum()), duplicates=int(duplicate.sum()), blocks=blocks,
                   garbled=int(garbled.sum()), flagged=np.flatnonzero(flagged).astype(np.int64))
    return RecordingQuality(**quality)


def quality_counts(data: Mapping[str, Any] | None) -> dict[str, int]:
    """The counts of a :meth:`RecordingQuality.to_dict` (for tables and summaries): flagged
    samples, sparse conditions, outliers, duplicated rows, garbled values (zeros for None)."""
    data = data or {}
    return {"flagged": int(data.get("flagged", 0)),
            "sparse_conditions": len(data.get("sparse_counts") or []),
            "outliers": int(data.get("outliers", 0)),
            "duplicates": int(data.get("duplicates", 0)), "garbled": int(data.get("garbled", 0))}


def check_quality(columns: Mapping[str, F64], suspect: str = "keep") -> RecordingQuality:
    """:func:`check_samples` of a recording's raw columns by key (``angle_deg`` or a load,
    ``azimuth_deg``, ``voltage_V`` or the field components, ``setreset``, ``time_s``; shapes
    (s,), as :func:`magcilia.io.recordings.read_samples` returns them), the conditions grouped as
    :func:`magcilia.io.recordings.read_measurements` groups them; without an angle or load
    column, a time series. ``suspect`` is kept as the result's policy."""
    kind, condition = "angle", columns.get("angle_deg")
    for name, (key, factor, _) in LOAD_UNITS.items():
        if key in columns:
            kind, condition = name, scaled(columns[key], factor)
    azimuth = columns.get("azimuth_deg")
    fields = [columns[k] for k in FIELD_KEYS if k in columns]
    observable = np.stack(fields, axis=1) if fields else columns["voltage_V"]
    with np.errstate(invalid="ignore", over="ignore"):
        return check_samples(
            None if condition is None else np.round(condition, ANGLE_DECIMALS), observable,
            azimuth=(None if azimuth is None or condition is None
                     else np.round(azimuth, ANGLE_DECIMALS)),
            polarity=columns.get("setreset"), rows=list(columns.values()), kind=kind,
            policy=suspect)


def refuse_suspects(source: str, quality: RecordingQuality) -> None:
    """The error for a recording whose samples the quality checks flagged, under the policy
    ``"raise"``; nothing otherwise."""
    if quality.found and quality.policy == "raise":
        raise MagciliaError(f"{source}: {'; '.join(quality.findings())}; clean the "
                            "recording, or pass suspect='omit' to leave them out or 'keep' to "
                            "keep them (CLI: --suspect omit|keep)")
