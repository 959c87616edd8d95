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

The functions take plain arrays (pure, vectorised NumPy, a few passes over the samples and no
sort of them in the common case: :mod:`magcilia.io.sample_checks`, which says how, and where a
condition of more than :data:`~magcilia.io.sample_checks.OUTLIER_SUBSAMPLE` samples takes its
median and MAD from that many evenly spaced ones); :func:`check_samples` runs them all.
What is done with the findings is the caller's policy (:data:`SUSPECT_POLICIES`: keep them and
say so, omit them and say so, or refuse the recording), applied by :func:`screen`.
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
from magcilia.io.columns import (
    ACTUATION_KEYS,
    ANGLE_DECIMALS,
    FIELD_KEYS,
    LOAD_UNITS,
    actuation_ids,
    scaled,
)
from magcilia.io.moments import runs
from magcilia.io.sample_checks import (
    duplicated_blocks,
    garbled,
    outliers_in_runs,
    spikes_in_series,
)

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
#: the quantity a condition is a value of -> (unit in reports, factor from SI)
CONDITIONS = {"angle": ("deg", float(np.degrees(1.0))), "force": ("uN", 1e6),
              "flow": ("mm/s", 1e3), "time": ("", 1.0), "coil": ("(coil field no.)", 1.0)}


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


def robust_outliers(group: ArrayLike, values: ArrayLike, polarity: ArrayLike | None = None, *,
                    sigmas: float = OUTLIER_SIGMAS,
                    min_samples: int = OUTLIER_MIN_SAMPLES) -> NDArray[np.bool_]:
    """Which samples lie more than ``sigmas`` robust standard deviations (1.4826 × MAD, floored
    at the smallest non-zero deviation: the quantum of quantised data) from the median of their
    group (and polarity), in groups of at least ``min_samples``. A group of more than
    :data:`~magcilia.io.sample_checks.OUTLIER_SUBSAMPLE` samples takes its median and MAD from
    that many evenly spaced ones (:mod:`magcilia.io.sample_checks`).

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
    starts, lengths = runs(key)
    distinct, run_group = np.unique(key[starts], return_inverse=True)
    out, _ = outliers_in_runs([x[:, j] for j in range(x.shape[1])], starts, lengths,
                              run_group.ravel(), distinct.size, sign, sigmas=sigmas,
                              min_samples=min_samples)
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
    return _spikes([x[:, j] for j in range(x.shape[1])], polarity, sigmas)


def _spikes(columns: list[F64], polarity: ArrayLike | None, sigmas: float = OUTLIER_SIGMAS
            ) -> NDArray[np.bool_]:
    """:func:`spikes` of columns (shapes (s,))."""
    out = np.zeros(columns[0].size, dtype=bool)
    series = ([None] if polarity is None else
              [np.flatnonzero(np.asarray(polarity) == p) for p in (1.0, -1.0)])
    for rows in series:
        for column in columns:
            y = column if rows is None else column[rows]
            found = spikes_in_series(np.ascontiguousarray(y), sigmas)
            out[found if rows is None else rows[found]] = True
    return out


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
    return duplicated_blocks(_columns(rows), length)


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
    """Run the checks on a recording's samples (sparse conditions, outliers, duplicated blocks,
    garbled values).

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
    y = _table(observable)
    return _check(None if condition is None else np.asarray(condition, np.float64).ravel(),
                  [y[:, j] for j in range(y.shape[1])],
                  None if azimuth is None else np.asarray(azimuth, np.float64).ravel(),
                  None if polarity is None else np.asarray(polarity, np.float64).ravel(),
                  rows=rows, kind=kind, policy=policy)


def _run_keys(cond: F64, azimuth: F64 | None, starts: I64, factor: float,
              decimals: int | None) -> tuple[F64, F64 | None]:
    """The condition (times ``factor``) and azimuth of each run, rounded to ``decimals``."""
    cv, av = scaled(cond[starts], factor), None if azimuth is None else azimuth[starts]
    if decimals is not None:
        cv, av = np.round(cv, decimals), None if av is None else np.round(av, decimals)
    return cv, av


def _by_condition(starts: I64, lengths: I64, cv: F64, av: F64 | None, observable: list[F64],
                  sign: F64 | None, kind: str) -> tuple[NDArray[np.bool_], NDArray[np.bool_],
                                                        dict[str, Any]]:
    """Outliers and the samples of sparse conditions among finite samples in runs of equal
    conditions (run values ``cv``, ``av``), and the findings per condition."""
    if av is None:  # grouped by the value alone (as the reduction does), at azimuth 0
        values, run_group = np.unique(cv, return_inverse=True)
        distinct = values.astype(np.complex128) * 1j
    else:
        key = np.empty(cv.size, np.complex128)
        key.real, key.imag = av, cv
        distinct, run_group = np.unique(key, return_inverse=True)
    run_group = run_group.ravel()
    counts = np.bincount(run_group, lengths, minlength=distinct.size).astype(np.int64)
    sparse = sparse_conditions(counts)
    outlier, per = outliers_in_runs(observable, starts, lengths, run_group, distinct.size,
                                    None if sign is None else sign > 0, sigmas=OUTLIER_SIGMAS,
                                    min_samples=OUTLIER_MIN_SAMPLES, skip=sparse)
    unit_factor = CONDITIONS[kind][1]
    has = per > 0
    return outlier, np.repeat(sparse[run_group], lengths), {
        "condition": kind, "median_count": float(np.median(counts)) if counts.size else 0.0,
        "sparse_values": distinct.imag[sparse] / unit_factor,
        "sparse_azimuths": np.radians(distinct.real[sparse]), "sparse_counts": counts[sparse],
        "outlier_values": distinct.imag[has] / unit_factor,
        "outlier_azimuths": np.radians(distinct.real[has]), "outlier_counts": per[has]}


def _check(cond: F64 | None, observable: list[F64], azimuth: F64 | None, sign: F64 | None, *,
           rows: list[ArrayLike] | None, kind: str, policy: str, factor: float = 1.0,
           decimals: int | None = None) -> RecordingQuality:
    """:func:`check_samples` on columns (shapes (s,)); the condition is grouped as its values
    times ``factor``, rounded to ``decimals`` (done on the runs of equal raw values: no array
    of the recording's size is made for it)."""
    policy = v.choice("policy", policy, SUSPECT_POLICIES)
    s = observable[0].size
    quality: dict[str, Any] = {"samples": s, "policy": policy}
    ok = all(bool(np.isfinite(c).all()) for c in observable) and (
        sign is None or bool(((sign == 1.0) | (sign == -1.0)).all()))

    def usable() -> NDArray[np.bool_]:
        finite = np.ones(s, dtype=bool)
        for c in observable:
            finite &= np.isfinite(c)
        return finite if sign is None else finite & ((sign == 1.0) | (sign == -1.0))

    outlier = np.zeros(s, dtype=bool)
    flagged = np.zeros(s, dtype=bool)
    garbled_rows = [garbled(c, TINY) for c in observable]
    if cond is None:
        use = slice(None) if ok else np.flatnonzero(usable())
        outlier[use] = _spikes([c[use] for c in observable], None if sign is None else sign[use])
        quality["condition"] = "time"
    else:
        keys = (cond,) if azimuth is None else (cond, azimuth)
        starts, lengths = runs(*keys)
        cv, av = _run_keys(cond, azimuth, starts, factor, decimals)
        run_ok = np.isfinite(cv) if av is None else np.isfinite(cv) & np.isfinite(av)
        with np.errstate(invalid="ignore"):
            tiny = (np.abs(cv) < TINY) & (cv != 0.0)
            if av is not None:
                tiny |= (np.abs(av) < TINY) & (av != 0.0)
        if tiny.any():
            garbled_rows.append(np.repeat(tiny, lengths))
        if ok and run_ok.all():
            outlier, flagged, found = _by_condition(starts, lengths, cv, av, observable, sign,
                                                    kind)
        else:  # the finite samples only
            use = np.flatnonzero(np.repeat(run_ok, lengths) & usable())
            part = [c[use] for c in keys]
            st, ln = runs(*part)
            cvu, avu = _run_keys(part[0], None if azimuth is None else part[1], st, factor,
                                 decimals)
            outlier[use], flagged[use], found = _by_condition(
                st, ln, cvu, avu, [c[use] for c in observable],
                None if sign is None else sign[use], kind)
        quality.update(found)
    if rows is None:
        rows = [*observable, *([] if cond is None else [cond]),
                *([] if azimuth is None or cond is None else [azimuth])]
    duplicate, blocks = duplicated_rows(list(rows))
    bad = np.zeros(s, dtype=bool)
    for g in garbled_rows:
        if g is not None:
            bad |= g
    flagged |= outlier | duplicate | bad
    quality.update(outliers=int(np.count_nonzero(outlier)),
                   duplicates=int(np.count_nonzero(duplicate)), blocks=blocks,
                   garbled=int(np.count_nonzero(bad)),
                   flagged=np.flatnonzero(flagged).astype(np.int64))
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
    :func:`magcilia.io.recordings.read_measurements` groups them (rounded to
    :data:`~magcilia.io.columns.ANGLE_DECIMALS` decimals of deg, uN or mm/s); without an angle or
    load column, a time series. ``suspect`` is kept as the result's policy."""
    kind, condition, factor = "angle", columns.get("angle_deg"), 1.0
    for name, (key, unit_factor, _) in LOAD_UNITS.items():
        if key in columns:
            kind, condition, factor = name, columns[key], unit_factor
    if ACTUATION_KEYS[0] in columns:  # a coil recording: grouped by the applied field
        kind, condition = "coil", actuation_ids([columns[k] for k in ACTUATION_KEYS], {})
    azimuth = columns.get("azimuth_deg")
    fields = [columns[k] for k in FIELD_KEYS if k in columns]
    polarity = columns.get("setreset")
    with np.errstate(invalid="ignore", over="ignore"):
        return _check(
            None if condition is None else np.asarray(condition, np.float64).ravel(),
            [np.asarray(c, np.float64).ravel() for c in (fields or [columns["voltage_V"]])],
            None if azimuth is None or condition is None else np.asarray(azimuth, np.float64),
            None if polarity is None else np.asarray(polarity, np.float64).ravel(),
            rows=list(columns.values()), kind=kind, policy=suspect, factor=factor,
            decimals=ANGLE_DECIMALS)


def screen(columns: Mapping[str, F64], suspect: str, source: str
           ) -> tuple[RecordingQuality, Mapping[str, F64]]:
    """A recording's raw columns checked (:func:`check_quality`) and the policy ``suspect``
    applied: the checks' result and the columns to use, ``columns`` itself (``"keep"``, or
    nothing flagged), a copy without the flagged rows (``"omit"``), or the one-line error of
    :func:`refuse_suspects` (``"raise"``, naming ``source``)."""
    quality = check_quality(columns, suspect)
    refuse_suspects(source, quality)
    if quality.found and quality.policy == "omit":
        return quality, quality.kept(columns)
    return quality, columns


def refuse_suspects(source: str, quality: RecordingQuality) -> None:
    """The error for a recording whose samples the quality checks flagged, under the policy
    ``"raise"``; nothing otherwise."""
    if quality.found and quality.policy == "raise":
        raise MagciliaError(f"{source}: {'; '.join(quality.findings())}; clean the "
                            "recording, or pass suspect='omit' to leave them out or 'keep' to "
                            "keep them (CLI: --suspect omit|keep)")
