"""Measured field-vs-tilt recordings: reading files and reducing raw samples to per-angle means.

Formats (chosen by the file suffix):

- **CSV** (``.csv``, ``.txt``): a header row with ``angle_deg`` and ``voltage_V``; one row per raw
  sample, repeated angles are samples of the same angle. Optional ``time_s`` and ``setreset``
  (``set``/``reset`` or ``+1``/``-1``: samples taken after a set or a reset pulse of the AMR
  strap). Lines starting with ``#`` are comments. Other columns are ignored; a column we read
  that appears twice in the header is an error (which one is meant is ambiguous).
- **MATLAB** (``.mat``): variables ``angle_deg`` and ``voltage_V`` (real numeric vectors of equal
  length), optionally ``time_s`` and ``setreset``. Versions 4 and 5/7 (SciPy) and 7.3 (MATLAB's
  default for large data: HDF5, read with the optional ``h5py``: ``pip install
  'magcilia[hdf5]'``). Complex, text, cell, struct, sparse or matrix-shaped variables and a
  variable saved twice are errors.
- **TDMS** (``.tdms``, NI LabVIEW, needs the optional ``npTDMS``: ``pip install
  'magcilia[tdms]'``): channels named ``angle_deg`` and ``voltage_V`` in any group (or in the
  group named by ``group``). A channel we read must appear in one group only (a name in two
  groups is ambiguous and an error); magcilia's own recordings keep the samples in group
  ``recording`` and give the further groups (``readout``, ``events``) other channel names
  (:mod:`magcilia.io.recording_file`).
- **HDF5** (``.h5``, ``.hdf5``, needs the optional ``h5py``: ``pip install 'magcilia[hdf5]'``):
  1-D datasets named as the columns, at the root or in the group named by ``group``
  (:mod:`magcilia.io.hdf5file`).

Other names and units
---------------------
``columns`` maps the roles (angle, voltage, time, setreset) to the file's own names with units:
``columns={"angle": "Tilt[deg]", "voltage": "Vout[mV]"}`` or the CLI's
``--columns angle=Tilt[deg],voltage=Vout[mV]``; a header ``Vout [mV]`` names its unit itself
(:mod:`magcilia.io.columns`). Whatever the file's units, the columns read are in deg, V and s.
CSV files take a ``delimiter`` (sniffed from the header by default: tab, ``;``, ``,`` or white
space) and a ``decimal`` mark (``","`` for European exports such as ``1,25;0,031``); see
:mod:`magcilia.io.csvfile`.

With set/reset samples the offset-free reading of an angle is ``(mean(V_set) − mean(V_reset))/2``
(the bridge flips polarity, the offset does not; HMC1021 datasheet).

Hostile files
-------------
Every failure of a reader becomes one :class:`~magcilia.MagciliaError` line naming the file and
what is wrong; an unexpected exception of a third-party parser is caught at the reader boundary
(:func:`read_samples`) and kept as the error's ``__cause__``. Sizes taken from a file are bounded
by the module constants below (each error names the constant to raise where a genuine file can
exceed it): :data:`MAX_SAMPLES` samples per column, :data:`MAX_LINE_CHARS` characters per CSV
line, and for MATLAB files those of :mod:`magcilia.io.matfile`.

MATLAB files are parsed in a child process after a check of their structure
(:mod:`magcilia.io.matfile`, which says why and what it costs).

Speed and memory
----------------
A plain CSV file (numbers only after the header) is parsed by pandas' C reader in blocks of a
million rows, each reduced as it comes (:mod:`magcilia.io.csvfile`); anything else goes to the
careful line-by-line reader, which gives the same columns and the errors that name a line. The
reduction (:func:`measurement_from_samples`, and every reader through it) is one pass over pieces
of :data:`REDUCE_SAMPLES` samples: the runs of equal angles are grouped, their sums gathered per
angle with ``np.bincount``, in a two-pass form accurate on a large offset, and the pieces merged
with Chan's formulas. A 1e7-row CSV recording (300 MB) reads in under a second on one core with
about 100 MB above the interpreter's own (``benchmarks/bench_recordings.py``).

Angles are tilt angles in degrees: a finite ``|angle_deg|`` above :data:`MAX_ANGLE_DEG` (a
column in the wrong unit, or garbage) is an error rather than grouped, so the grouping by
rounding to :data:`ANGLE_DECIMALS` decimals never overflows.
"""

from __future__ import annotations

import contextlib
import logging
import math
import time
from collections.abc import Callable, Iterator, Mapping
from dataclasses import dataclass, field
from importlib import resources
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from magcilia import _validate as v
from magcilia._display import Display, Item, Table, count, dataframe, number, si
from magcilia._errors import MagciliaError, MissingDependencyError, require
from magcilia._validate import printable
from magcilia.constants import GAUSS
from magcilia.device.sensor import Sensor
from magcilia.io.columns import Columns
from magcilia.io.csvfile import (
    NotPlainCSV,
    decimal_of,
    delimiter_of,
    names_text,
    plain_csv_blocks,
    read_csv_carefully,
    too_many_samples,
)
from magcilia.io.hdf5file import read_hdf5
from magcilia.io.matfile import read_mat
from magcilia.io.moments import Moments, by_value, group_moments, grow_rows, summarize

F64 = NDArray[np.float64]
logger = logging.getLogger(__name__)
NAN_POLICIES = ("raise", "omit")
SATURATION_POLICIES = ("raise", "omit", "keep")
ANGLE_DECIMALS = 9  # angles equal to 1e-9 deg are the same angle
#: The columns a recording may hold (other columns, variables or channels are ignored), by
#: their default names (:class:`~magcilia.io.columns.Columns` maps others onto them).
COLUMNS = ("angle_deg", "voltage_V", "time_s", "setreset")
#: A reader's progress: ``progress(bytes_read, file_size)``.
Progress = Callable[[int, int], None]

#: Largest |tilt angle| accepted, deg; beyond it the column is in the wrong unit or garbage.
MAX_ANGLE_DEG = 360.0
#: Most samples per column in any format (4 columns × 8 bytes × 50 million = 1.6 GB of arrays).
MAX_SAMPLES = 50_000_000
#: Longest CSV line, characters (a recording's line is tens of characters).
MAX_LINE_CHARS = 1 << 20


@dataclass(frozen=True, eq=False, repr=False)
class Measurement(Display):
    """Per-angle summary of a recording (SI units).

    Attributes
    ----------
    angles : ndarray, shape (a,)
        Distinct tilt angles, rad, increasing.
    volts : ndarray, shape (a,)
        Mean output per angle, V (offset-free when set/reset samples were given).
    sem : ndarray, shape (a,)
        Standard error of each mean, V (sample std / sqrt(count); 0 for a single sample).
    counts : ndarray of int, shape (a,)
        Samples used per angle.
    saturated : ndarray of int, shape (a,)
        Samples beyond the sensor's linear range at each angle (dropped if the policy was 'omit').
    nonfinite : ndarray of int, shape (a,)
        NaN/inf samples dropped at each angle (nan_policy 'omit').
    set_reset : bool
        Whether the readings are set/reset differences.
    source : str
        Where the data came from (file name).
    metadata : dict
        JSON-ready notes. ``metadata["dropped"]`` (present only when needed) counts the dropped
        samples that no angle's counts can hold: ``no_angle`` (samples whose angle was NaN/inf,
        nan_policy 'omit'), ``angles_deg`` (angles left without a usable sample) and ``samples``
        (how many samples those angles had); :meth:`report` says them.
    azimuths : ndarray, shape (a,)
        Tilt direction φ of each condition, rad (0: tilt toward +x, the paper's path; the tilt
        axis is horizontal, perpendicular to φ). Conditions are ordered by azimuth, then angle.
        Default: all 0.
    fields : ndarray, shape (a, 3), or None
        For a 3-axis magnetometer at the sensing point: mean field (B_x, B_y, B_z) per condition,
        T (axes as in the frame figure); ``volts`` and ``sem`` are then NaN. None for the
        single-axis sensor's output.
    field_sem : ndarray, shape (a, 3), or None
        Standard errors of ``fields``, T (None with ``fields``).
    """

    angles: F64
    volts: F64
    sem: F64
    counts: NDArray[np.int64]
    saturated: NDArray[np.int64]
    nonfinite: NDArray[np.int64]
    set_reset: bool = False
    source: str = "<array>"
    metadata: dict[str, Any] = field(default_factory=dict)
    azimuths: F64 = field(default_factory=lambda: np.zeros(0))
    fields: F64 | None = None
    field_sem: F64 | None = None

    def __post_init__(self) -> None:
        if np.size(self.azimuths) == 0:
            object.__setattr__(self, "azimuths", np.zeros(np.shape(self.angles)))
        if (self.fields is None) != (self.field_sem is None):
            raise v.fail("field_sem", "given without fields" if self.fields is None
                         else "missing", "both fields and field_sem, or neither")
        for name in ("angles", "volts", "sem", "counts", "saturated", "nonfinite", "azimuths",
                     "fields", "field_sem"):
            value = getattr(self, name)
            if value is None:
                continue
            arr = np.array(value)
            arr.setflags(write=False)
            object.__setattr__(self, name, arr)
        a = self.angles.shape
        if self.azimuths.shape != a or (self.fields is not None and self.field_sem is not None and (
                self.fields.shape != (*a, 3) or self.field_sem.shape != (*a, 3))):
            raise v.fail("azimuths / fields", "arrays of other shapes than the angles",
                         "azimuths of shape (a,) and fields, field_sem of shape (a, 3)")

    @property
    def observable(self) -> str:
        """``"output"`` (the single-axis sensor's voltage) or ``"field"`` (3-axis data)."""
        return "output" if self.fields is None else "field"

    def __len__(self) -> int:
        return int(self.angles.size)

    @property
    def angles_deg(self) -> F64:
        """Angles in degrees, shape (a,)."""
        return np.degrees(self.angles)

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready summary (SI: angles in rad, volts in V)."""
        return {
            "source": self.source, "set_reset": self.set_reset,
            "angle_rad": self.angles.tolist(), "voltage_V": self.volts.tolist(),
            "sem_V": self.sem.tolist(), "count": self.counts.tolist(),
            "saturated": self.saturated.tolist(), "nonfinite": self.nonfinite.tolist(),
            "metadata": dict(self.metadata), "azimuth_rad": self.azimuths.tolist(),
            **({} if self.fields is None or self.field_sem is None else {
                "field_T": self.fields.tolist(), "field_sem_T": self.field_sem.tolist()}),
        }

    @classmethod
    def from_dict(cls, data: Mapping[str, Any]) -> Measurement:
        """Rebuild from :meth:`to_dict` output."""
        with v.rebuilding("measurement data", "Measurement"):
            return cls(
                angles=np.asarray(data["angle_rad"], dtype=np.float64),
                volts=np.asarray(data["voltage_V"], dtype=np.float64),
                sem=np.asarray(data["sem_V"], dtype=np.float64),
                counts=np.asarray(data["count"], dtype=np.int64),
                saturated=np.asarray(data["saturated"], dtype=np.int64),
                nonfinite=np.asarray(data["nonfinite"], dtype=np.int64),
                set_reset=bool(data["set_reset"]), source=str(data["source"]),
                metadata=dict(data.get("metadata") or {}),
                azimuths=np.asarray(data.get("azimuth_rad") or [], dtype=np.float64),
                fields=(None if data.get("field_T") is None
                        else np.asarray(data["field_T"], dtype=np.float64)),
                field_sem=(None if data.get("field_sem_T") is None
                           else np.asarray(data["field_sem_T"], dtype=np.float64)),
            )

    def report(self) -> str:
        """One line: source, angles, samples and what was dropped."""
        deg = self.angles_deg
        text = (f"{self.source}: {len(self)} angles {deg.min():.4g}..{deg.max():.4g} deg, "
                f"{int(self.counts.sum())} samples"
                + (" (set/reset differences)" if self.set_reset else ""))
        dropped = [f"{int(n.sum())} {what}" for n, what in ((self.saturated, "saturated"),
                                                            (self.nonfinite, "non-finite"))
                   if n.sum()]
        lost = self.metadata.get("dropped") or {}
        if lost.get("no_angle"):
            dropped.append(f"{lost['no_angle']} without a finite angle")
        if lost.get("angles_deg"):
            dropped.append(f"{lost['samples']} at {len(lost['angles_deg'])} angle(s) left with no "
                           f"usable sample ({', '.join(f'{a:g}' for a in lost['angles_deg'])} deg)")
        return text + (f"; {', '.join(dropped)}" if dropped else "")

    # -- display --------------------------------------------------------------------------------
    def _display_items(self) -> list[Item]:
        deg = np.degrees(self.angles)
        items = [("", count(len(self), "angle")),
                 ("angles", f"{number(deg.min())}…{number(deg.max())} deg" if len(self) else "-"),
                 ("output", f"{si(self.volts.min(), 'V')}…{si(self.volts.max(), 'V')}"
                  if len(self) else "-"),
                 ("median s.e.", si(float(np.median(self.sem)), "V") if len(self) else "-"),
                 ("samples", str(int(self.counts.sum())))]
        if self.saturated.any():
            items.append(("saturated", str(int(self.saturated.sum()))))
        if self.set_reset:
            items.append(("", "set/reset"))
        return [*items, ("source", self.source)]

    def _display_table(self) -> Table:
        return (("angle (deg)", "output (mV)", "s.e. (µV)", "samples"),
                [(number(a, 5), number(v * 1e3, 5), number(e * 1e6), str(int(n)))
                 for a, v, e, n in zip(self.angles_deg, self.volts, self.sem, self.counts,
                                       strict=True)])

    def to_dataframe(self) -> Any:
        """The reduced measurements as a ``pandas.DataFrame``, one row per angle, SI: columns
        ``angle_rad``, ``output_V`` (mean), ``sem_V`` (its standard error), ``count``,
        ``saturated``, ``nonfinite`` (samples per angle)."""
        return dataframe({"angle_rad": self.angles, "output_V": self.volts, "sem_V": self.sem,
                          "count": self.counts, "saturated": self.saturated,
                          "nonfinite": self.nonfinite})


def beyond_range(volts: ArrayLike, sensor: Sensor) -> NDArray[np.bool_]:
    """True where an output (V, any shape) lies beyond the sensor's linear range. The bias is not
    known at this point: the field is judged relative to the sensor's offset."""
    field = np.array(volts, dtype=np.float64)  # a copy, worked on in place
    with np.errstate(over="ignore", invalid="ignore"):  # huge outputs are beyond the range
        field -= sensor.offset
        field /= abs(sensor.scale)
        return np.asarray(np.abs(field, out=field) > sensor.field_range)


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


#: Samples reduced at a time: arrays of a few MB, which the allocator reuses (a fresh array of a
#: whole recording's size costs page faults that take longer than the arithmetic).
REDUCE_SAMPLES = 1 << 20


class _Reduction:
    """A recording's samples reduced to per-angle statistics as they come, block by block.

    :meth:`add` never raises: the first sample of each kind of problem is noted and
    :meth:`measurement` raises the error the whole recording deserves, in the order the checks
    have always had (an angle beyond ±:data:`MAX_ANGLE_DEG`, a non-finite or unlabelled sample
    under nan_policy 'raise', a saturated one under saturation 'raise', then per angle), so that a
    reader's errors on a later block come first. Blocks are merged with Chan's parallel formulas
    (Chan, Golub & LeVeque 1983): the result does not depend on where blocks are cut.
    """

    def __init__(self, sensor: Sensor | None, nan_policy: str, saturation: str, source: str):
        self.nan_policy = v.choice("nan_policy", nan_policy, NAN_POLICIES)
        self.saturation = v.choice("saturation", saturation, SATURATION_POLICIES)
        self.sensor, self.source = sensor or Sensor(), source
        self.samples = self.no_angle = 0
        self.problems: dict[str, str] = {}  # "far", "bad", "saturated" -> message of the first
        self.angles = np.zeros(0)  # distinct angles (rounded), deg, increasing: shape (a,)
        self.counts = np.zeros((0, 2), np.int64)  # non-finite and saturated samples per angle
        self.peak = np.zeros(0)  # largest |V| used per angle
        self.k = 0  # statistics per angle: 1, or 2 with set/reset (reset, set); 0 before samples
        self.stats = Moments(np.zeros((0, 0), np.int64), *np.zeros((3, 0, 0)))  # shapes (a, k)

    def add(self, ang: F64, volt: F64, sr: F64 | None = None) -> None:
        """Add samples (shapes (s,): angle in deg, output in V, +1/−1 set/reset or None), in
        pieces of :data:`REDUCE_SAMPLES`."""
        if not self.k:
            self.k = 1 if sr is None else 2
            self.stats = Moments(np.zeros((0, self.k), np.int64), *np.zeros((3, 0, self.k)))
        for s in range(0, ang.size, REDUCE_SAMPLES):
            part = slice(s, s + REDUCE_SAMPLES)
            self._add(ang[part], volt[part], None if sr is None else sr[part])

    def _note(self, kind: str, where: NDArray[np.bool_], message: Callable[[int], str]) -> None:
        if kind not in self.problems and where.any():
            self.problems[kind] = message(int(np.argmax(where)))

    def _add(self, ang: F64, volt: F64, sr: F64 | None) -> None:
        source, offset = self.source, self.samples
        self.samples += ang.size
        finite = np.isfinite(ang)
        self._note("far", finite & (np.abs(ang) > MAX_ANGLE_DEG), lambda i: (
            f"{source}: sample {offset + i + 1} has angle_deg={ang[i]:.6g}, beyond "
            f"±{MAX_ANGLE_DEG:g} deg; angle_deg must be the tilt in degrees (check the column "
            "and its unit)"))
        bad = ~(finite & np.isfinite(volt))
        if sr is not None:
            bad |= (sr != 1.0) & (sr != -1.0)
        if self.nan_policy == "raise":
            self._note("bad", bad, lambda i: (
                f"{source}: sample {offset + i + 1} "
                + (f"is not finite (angle_deg={ang[i]}, voltage_V={volt[i]})"
                   if not (math.isfinite(ang[i]) and math.isfinite(volt[i])) or sr is None
                   else f"has setreset={sr[i]:g}, neither +1 (set) nor -1 (reset)")
                + "; clean the file or pass nan_policy='omit' (CLI: --nan-policy omit)"))
        sat = ~bad & beyond_range(volt, self.sensor)
        if self.saturation == "raise":
            self._note("saturated", sat, lambda i: (
                f"{source}: sample {offset + i + 1} (voltage_V={volt[i]:.6g} at {ang[i]:g} deg) "
                f"is beyond the sensor's linear range (±{self.sensor.field_range / GAUSS:g} "
                f"gauss = ±{self.sensor.field_range * abs(self.sensor.scale):.4g} V); check gain "
                "and offset, or pass saturation='omit' (CLI: --saturation omit) to drop such "
                "samples"))
        if self.problems:  # the recording is refused (and a far angle must not be rounded)
            return
        on: slice | NDArray[np.bool_] = slice(None) if finite.all() else finite  # no copy if all
        angles, group = by_value(np.round(ang[on], ANGLE_DECIMALS))
        self.no_angle += ang.size - group.size  # (nan_policy 'omit')
        a, k = angles.size, self.k
        counts = np.stack([np.bincount(group[bad[on]], minlength=a),
                           np.bincount(group[sat[on]], minlength=a)], axis=1)
        use = ~bad & ~sat if self.saturation == "omit" else ~bad
        if not use.all():
            group, volt, sr = (group[use[on]], volt[use & finite],
                               None if sr is None else sr[use & finite])
        stats, peak = group_moments(group if sr is None else 2 * group + (sr > 0), volt, a * k)
        self._merge(angles, counts, stats.reshape(a, k),
                    peak.reshape(a, k).max(axis=1))

    def _merge(self, angles: F64, counts: NDArray[np.int64], block: Moments, peak: F64
               ) -> None:
        """Merge a block's per-angle statistics (shapes (b,), (b, 2) and (b, k)) into ours."""
        union = np.union1d(self.angles, angles)
        if union.size > self.angles.size:  # angles not seen before: make room
            old = np.searchsorted(union, self.angles)
            self.counts, self.peak = (grow_rows(x, old, union.size)
                                      for x in (self.counts, self.peak))
            self.stats = Moments(*(grow_rows(x, old, union.size) for x in self.stats))
            self.angles = union
        at = np.searchsorted(self.angles, angles)
        self.counts[at] += counts
        self.peak[at] = np.maximum(self.peak[at], peak)
        n, hi, lo, m2 = self.stats
        na, new = n[at], n[at] == 0
        with np.errstate(invalid="ignore", over="ignore"):  # overflow: checked at the end
            share = block.n / np.maximum(na + block.n, 1)
            delta = (block.hi - hi[at]) + (block.lo - lo[at])  # (hi - hi: exact)
            hi[at] = np.where(new, block.hi, hi[at])
            lo[at] = np.where(new, block.lo, lo[at] + delta * share)
            m2[at] = np.where(new, block.m2, m2[at] + block.m2 + delta * delta * na * share)
        n[at] = na + block.n

    def measurement(self) -> Measurement:
        """The :class:`Measurement` of the samples added, or the error the recording deserves."""
        source = self.source
        if not self.samples:
            raise v.fail(f"{source}", "no samples", "a recording with at least two angles")
        for kind in ("far", "bad", "saturated"):
            if kind in self.problems:
                raise MagciliaError(self.problems[kind])
        n, hi, lo, _ = self.stats
        volts, sem, count = summarize(self.stats)
        has = count > 0  # angles left with a usable sample
        with np.errstate(over="ignore", invalid="ignore"):  # a sum beyond the doubles overflows
            sums = np.isfinite((hi + lo) * n).all(axis=1)  # (as when summed in one piece)
        wrong = has & ~(np.isfinite(volts) & np.isfinite(sem) & sums & (n.min(axis=1) > 0))
        if wrong.any():  # the first angle missing a polarity, or whose reading overflows
            i = int(np.argmax(wrong))
            if n[i].min() == 0:
                raise _polarity_error(f"{source}: angle {self.angles[i]:g} deg", n[i])
            raise MagciliaError(
                f"{source}: the reading at {self.angles[i]:g} deg overflows (samples up to "
                f"{self.peak[i]:.3g} V); voltage_V must be in volts"
            )
        if has.sum() < 2:
            raise MagciliaError(
                f"{source}: the recording has {has.sum()} usable angle(s); calibration needs at "
                "least two distinct angles (rows of angle_deg, voltage_V)"
            )
        if np.ptp(volts[has]) == 0.0:
            raise MagciliaError(
                f"{source}: all readings are equal ({volts[has][0]:.6g} V); the sensor output "
                "does not vary with the angle (check the wiring, the gain and that the cilium is "
                "magnetized)"
            )
        nonfinite, saturated = self.counts.T
        metadata: dict[str, Any] = {}
        if self.no_angle or not has.all():  # dropped samples that no angle's counts can hold
            lost = nonfinite + (saturated if self.saturation == "omit" else 0)
            metadata["dropped"] = {"no_angle": self.no_angle,
                                   "angles_deg": self.angles[~has].tolist(),
                                   "samples": int(lost[~has].sum())}
        logger.info("%s: %d samples reduced to %d angles", source, self.samples, int(has.sum()))
        return Measurement(
            angles=np.radians(self.angles[has]), volts=volts[has], sem=sem[has],
            counts=count[has], saturated=saturated[has], nonfinite=nonfinite[has],
            set_reset=self.k == 2, source=source, metadata=metadata,
        )


def measurement_from_samples(
    angle_deg: ArrayLike,
    voltage: ArrayLike,
    *,
    setreset: ArrayLike | None = None,
    sensor: Sensor | None = None,
    nan_policy: str = "raise",
    saturation: str = "raise",
    source: str = "<array>",
) -> Measurement:
    """Reduce raw samples to a :class:`Measurement`, in one pass over pieces of
    :data:`REDUCE_SAMPLES` samples (per-angle means and standard errors accurate on a large
    offset; the result does not depend on the pieces).

    Parameters
    ----------
    angle_deg : array-like, shape (s,)
        Tilt angle of each sample, degrees (the file convention).
    voltage : array-like, shape (s,)
        Sensor output of each sample, V.
    setreset : array-like, shape (s,), optional
        +1 for samples after a set pulse, −1 after a reset pulse.
    sensor : Sensor, optional
        Used to flag samples beyond the linear range (|V − offset| / |scale| > field_range);
        default the HMC1021Z preset at the paper's settings.
    nan_policy : {"raise", "omit"}
        What to do with NaN/inf samples.
    saturation : {"raise", "omit", "keep"}
        What to do with samples beyond the sensor's range.
    source : str
        Name used in messages.
    """
    reduction = _Reduction(sensor, nan_policy, saturation, source)
    ang = np.asarray(angle_deg, dtype=np.float64).ravel()
    volt = np.asarray(voltage, dtype=np.float64).ravel()
    sr = None if setreset is None else np.asarray(setreset, dtype=np.float64).ravel()
    if ang.size != volt.size or (sr is not None and sr.size != ang.size):
        raise v.fail(f"{source}: columns", f"lengths {ang.size}, {volt.size}", "of equal length")
    reduction.add(ang, volt, sr)
    return reduction.measurement()


def _csv_limits() -> dict[str, int]:
    """The limits of the CSV readers (read at each call, so that they can be raised)."""
    return {"max_samples": MAX_SAMPLES, "max_line_chars": MAX_LINE_CHARS}


@dataclass(frozen=True)
class _How:
    """How to read a recording: the column and unit mapping, the CSV delimiter (None: sniffed)
    and decimal mark, the group (HDF5, TDMS; "" for any or the root), a progress callback."""

    columns: Columns = field(default_factory=Columns)
    delimiter: str | None = None
    decimal: str = "."
    group: str = ""
    progress: Progress | None = None


def _how(path: Path, columns: Columns | Mapping[str, str] | str | None, delimiter: str | None,
         decimal: str, group: str | None, progress: Progress | None) -> _How:
    """The reading options checked (the CSV ones on a CSV file, ``group`` on HDF5 and TDMS)."""
    how = _How(Columns.coerce(columns), delimiter_of(delimiter), decimal_of(decimal),
               "" if group is None else str(group), progress)
    suffix = path.suffix.lower()
    if READERS[suffix] is not _read_csv and (how.delimiter is not None or how.decimal != "."):
        raise v.fail("delimiter" if how.delimiter is not None else "decimal",
                     delimiter if how.delimiter is not None else decimal,
                     f"left out for a {FORMATS[suffix]} file (delimiter and decimal mark are "
                     "CSV options)")
    if how.group.strip("/") and READERS[suffix] not in (_read_hdf5, _read_tdms):
        raise v.fail("group", group, f"left out for a {FORMATS[suffix]} file (groups are in "
                                     "HDF5 and TDMS files)")
    if progress is not None and not callable(progress):
        raise v.fail("progress", type(progress).__name__, "a callable progress(done, total)")
    return how


class _CSVLocator:
    """The column mapping for the CSV readers: the header's names -> key -> index, the unit
    factors kept."""

    def __init__(self, path: Path, how: _How, required: tuple[str, ...]):
        self.path, self.how, self.required = path, how, required
        self.factors: dict[str, float] = {}

    def __call__(self, header: list[str]) -> dict[str, int]:
        found = self.how.columns.locate(header, where=str(self.path), required=self.required)
        self.factors = {k: f for k, (_, f) in found.items() if f != 1.0}
        return {k: i for k, (i, _) in found.items()}

    def scaled(self, block: dict[str, F64]) -> dict[str, F64]:
        """A block's columns in deg, V and s."""
        for key, factor in self.factors.items():
            block[key] = block[key] * factor
        return block

    def options(self) -> dict[str, Any]:
        """The readers' keyword arguments."""
        return {"delimiter": self.how.delimiter, "decimal": self.how.decimal, "locate": self,
                **_csv_limits()}


def _read_csv(path: Path, required: tuple[str, ...], how: _How) -> dict[str, F64]:
    """A CSV recording's columns: the fast reader's blocks joined, or the careful reader's."""
    locate = _CSVLocator(path, how, required)
    try:
        blocks = list(plain_csv_blocks(path, COLUMNS, required, progress=how.progress,
                                       **locate.options()))
    except NotPlainCSV:
        return locate.scaled(read_csv_carefully(path, COLUMNS, required, progress=how.progress,
                                                **locate.options()))
    return locate.scaled({col: np.concatenate([b[col] for b in blocks]) for col in blocks[0]})


def _reduce_csv(path: Path, how: _How, start: Callable[[], _Reduction]) -> _Reduction:
    """A CSV recording reduced as it is read: block by block from the fast reader, or, where it
    gives up (even after some blocks), afresh from the careful reader's columns."""
    reduction = start()
    required = ("angle_deg", "voltage_V")
    locate = _CSVLocator(path, how, required)
    try:
        for piece in plain_csv_blocks(path, COLUMNS, required, progress=how.progress,
                                      **locate.options()):
            block = locate.scaled(piece)
            reduction.add(block["angle_deg"], block["voltage_V"], block.get("setreset"))
    except NotPlainCSV:
        reduction = start()
        cols = locate.scaled(read_csv_carefully(path, COLUMNS, required, progress=how.progress,
                                                **locate.options()))
        reduction.add(cols["angle_deg"], cols["voltage_V"], cols.get("setreset"))
    return reduction


def nptdms_module(purpose: str = "Reading TDMS files") -> Any:
    """The optional npTDMS package, or a one-line error naming the ``tdms`` extra."""
    return require("nptdms", package="npTDMS", extra="tdms", purpose=purpose)


@contextlib.contextmanager
def quiet_nptdms() -> Iterator[None]:
    """npTDMS logs warnings for a file cut inside its last segment (a recording whose writer was
    killed); such a file is read, and the caller says what matters in one line."""
    names = [n for n in list(logging.Logger.manager.loggerDict)
             if n == "nptdms" or n.startswith("nptdms.")]  # npTDMS sets each module's level
    logs = [logging.getLogger(n) for n in names or ["nptdms"]]
    levels = [log.level for log in logs]
    for log in logs:
        log.setLevel(logging.ERROR)
    try:
        yield
    finally:
        for log, level in zip(logs, levels, strict=True):
            log.setLevel(level)


def _read_tdms(path: Path, required: tuple[str, ...], how: _How) -> dict[str, F64]:
    nptdms = nptdms_module()
    size = path.stat().st_size
    with quiet_nptdms(), path.open("rb") as file, nptdms.TdmsFile.open(file) as tdms:
        places: dict[str, list[tuple[str, Any]]] = {}
        groups = tdms.groups()
        wanted = how.group.strip("/")
        if wanted:
            names = [str(g.name) for g in groups]
            if wanted not in names:
                raise MagciliaError(f"{path}: no group {printable(wanted)!r} (groups: "
                                    f"{names_text(names)}); pass one of them as the group")
            groups = [g for g in groups if str(g.name) == wanted]
        for group in groups:
            for channel in group.channels():
                places.setdefault(str(channel.name), []).append((str(group.name), channel))
        everything = list(places)
        located = how.columns.locate(everything, where=str(path), required=required,
                                     kind="channel")
        chosen: dict[str, tuple[str, float]] = {}
        for key, (i, factor) in located.items():
            name, where = everything[i], places[everything[i]]
            if len(where) > 1:
                raise MagciliaError(
                    f"{path}: channel {printable(name)} appears in {len(where)} groups "
                    f"({names_text([g for g, _ in where])}); keep it in one group, it is ambiguous "
                    "which to use (or pass the group)"
                )
            chosen[key] = (name, factor)
        out: dict[str, F64] = {}
        for key, (name, factor) in chosen.items():
            ((group_name, channel),) = places[name]
            what = f"{path}: channel {printable(name)} (group {printable(group_name)})"
            dtype = np.dtype(channel.dtype)
            if dtype.kind not in "biuf":
                raise MagciliaError(f"{what} holds {channel.data_type.__name__} values, not real "
                                    "numbers; store the samples as numbers")
            n = len(channel)
            if n > MAX_SAMPLES:
                raise too_many_samples(path, f"channel {printable(name)}", MAX_SAMPLES)
            if n * dtype.itemsize > size:
                raise MagciliaError(f"{what} declares {n:,} values, more than the file's "
                                    f"{size:,} bytes can hold; the file is damaged")
            data = np.asarray(channel[:], dtype=np.float64).ravel()
            if data.size != n:
                raise MagciliaError(f"{what} holds {data.size:,} of the {n:,} values it "
                                    "declares; the file is damaged")
            out[key] = data * factor if factor != 1.0 else data
        complete = tdms.properties.get("complete")
    if complete is False and out:  # a magcilia recording cut short (a crash): its last
        # segment may end inside a channel; the samples in every channel are whole
        n = min(a.size for a in out.values())
        out = {k: a[:n] for k, a in out.items()}
    return out


def _read_mat(path: Path, required: tuple[str, ...], how: _How) -> dict[str, F64]:
    names = how.columns.names()  # key -> variable name (MATLAB names carry no unit)
    variables = read_mat(path, tuple(dict.fromkeys(names.values())),
                         tuple(names[k] for k in required))
    found = list(variables)
    located = how.columns.locate(found, where=str(path), required=required, kind="variable")
    return {key: variables[found[i]] * factor if factor != 1.0 else variables[found[i]]
            for key, (i, factor) in located.items()}


def _read_hdf5(path: Path, required: tuple[str, ...], how: _How) -> dict[str, F64]:
    return read_hdf5(path, how.columns, required, group=how.group or "/",
                     max_samples=MAX_SAMPLES)


READERS = {".csv": _read_csv, ".txt": _read_csv, ".mat": _read_mat, ".tdms": _read_tdms,
           ".h5": _read_hdf5, ".hdf5": _read_hdf5}
FORMATS = {".csv": "CSV", ".txt": "CSV", ".mat": "MATLAB .mat", ".tdms": "TDMS", ".h5": "HDF5",
           ".hdf5": "HDF5"}


def _describe(exc: BaseException) -> str:
    """An exception as a short, harmless line: ``TypeName: message``."""
    text = printable(str(exc))
    return type(exc).__name__ + (f": {text[:160]}" + ("…" if len(text) > 160 else "")
                                 if text else "")


def _recording_path(path: str | Path) -> Path:
    """``path`` as a Path, checked to be an existing file of a format we read."""
    p = Path(path)
    if p.suffix.lower() not in READERS:
        raise v.fail(f"{p}: file type", p.suffix or "(none)", "one of " + ", ".join(READERS))
    if not p.is_file():
        raise MagciliaError(f"{p}: no such file")
    return p


@contextlib.contextmanager
def _reader_boundary(p: Path) -> Iterator[None]:
    """Any failure of a reader of ``p`` as one :class:`MagciliaError` line (the parser's own
    exception kept as its ``__cause__``)."""
    t0 = time.perf_counter()
    try:
        yield
        logger.info("read %s in %.3g s", p, time.perf_counter() - t0)
    except (MagciliaError, MissingDependencyError):
        raise
    except (PermissionError, IsADirectoryError, FileNotFoundError) as exc:
        raise MagciliaError(f"{p}: cannot read the file ({printable(exc.strerror or str(exc))})"
                            ) from exc
    except Exception as exc:  # the reader boundary: any parser failure is one line
        raise MagciliaError(f"{p}: cannot read as a {FORMATS[p.suffix.lower()]} file "
                            f"({_describe(exc)}); the file is damaged or not a recording"
                            ) from exc


def read_samples(
    path: str | Path, required: tuple[str, ...] = ("angle_deg", "voltage_V"), *,
    columns: Columns | Mapping[str, str] | str | None = None, delimiter: str | None = None,
    decimal: str = ".", group: str | None = None, progress: Progress | None = None,
) -> dict[str, F64]:
    """Raw sample columns of a recording (CSV, MATLAB .mat, TDMS or HDF5), without any reduction.

    Parameters
    ----------
    path : str or Path
        The file; its suffix selects the reader (see the module docstring for the formats).
    required : tuple of str
        Columns that must be present, by their keys ``angle_deg``, ``voltage_V``, ``time_s``,
        ``setreset`` (a one-line error names the file, the missing column and those it has).
    columns : Columns, mapping or str, optional
        Which of the file's columns holds the angle, voltage, time and setreset, with units:
        ``{"angle": "Tilt[deg]", "voltage": "Vout[mV]"}``, a
        :class:`~magcilia.io.columns.Columns` or the CLI's ``"angle=Tilt[deg],voltage=Vout[mV]"``
        (default: the names ``angle_deg``, ``voltage_V``, ``time_s``, ``setreset``).
    delimiter : {None, ",", ";", "\\t", "tab", " ", "whitespace", "auto"}
        CSV only: between fields; None or "auto" sniffs it from the header line.
    decimal : {".", ","}
        CSV only: the decimal mark (``","`` for ``1,25``; fields are then ``;``-separated, or
        quoted).
    group : str, optional
        HDF5 and TDMS only: the group that holds the columns (HDF5 default: the root; TDMS
        default: any group).
    progress : callable, optional
        Called as ``progress(bytes_read, file_size)`` while the file is read (CSV: after each
        block; other formats: at the start and the end).

    Returns
    -------
    dict of str to ndarray, shape (samples,)
        The columns found among ``angle_deg`` (deg), ``voltage_V`` (V), ``time_s`` (s) and
        ``setreset`` (+1 set, −1 reset), whatever the file's names and units, all of the same
        length (possibly 0: a recording stopped before its first sample;
        :func:`read_measurements` rejects it).

    Raises
    ------
    MagciliaError
        For any file that cannot be read as a recording (one line naming the file and what is
        wrong; an unexpected exception of a third-party parser is its ``__cause__``).
    MissingDependencyError
        For a TDMS, HDF5 or MATLAB v7.3 file without the optional package that reads it.
    """
    p = _recording_path(path)
    how = _how(p, columns, delimiter, decimal, group, progress)
    unknown = [k for k in required if k not in COLUMNS]
    if unknown:
        raise v.fail("required", unknown[0], "keys among " + ", ".join(COLUMNS))
    with _reader_boundary(p):
        cols = _read(p, required, how)
    lengths = {k: a.size for k, a in cols.items()}
    if len(set(lengths.values())) > 1:
        raise MagciliaError(
            f"{p}: the columns have different lengths "
            f"({', '.join(f'{k} {n}' for k, n in lengths.items())}); every column needs one "
            "value per sample"
        )
    if any(n > MAX_SAMPLES for n in lengths.values()):
        raise too_many_samples(p, "the recording", MAX_SAMPLES)
    logger.debug("%s: %d rows of %s", p, max(lengths.values(), default=0), ", ".join(cols))
    return cols


def _read(p: Path, required: tuple[str, ...], how: _How) -> dict[str, F64]:
    """A reader's columns, with the progress at the start and end of a format read at once."""
    reader = READERS[p.suffix.lower()]
    if how.progress is None:
        return reader(p, required, how)
    size = p.stat().st_size
    if reader is not _read_csv:
        how.progress(0, size)
    cols = reader(p, required, how)
    how.progress(size, size)
    return cols


def read_measurements(
    path: str | Path,
    *,
    sensor: Sensor | None = None,
    nan_policy: str = "raise",
    saturation: str = "raise",
    columns: Columns | Mapping[str, str] | str | None = None,
    delimiter: str | None = None,
    decimal: str = ".",
    group: str | None = None,
    progress: Progress | None = None,
) -> Measurement:
    """Read a recording (CSV, MATLAB .mat, TDMS or HDF5) and reduce it to per-angle means.

    Parameters
    ----------
    path : str or Path
        The file; its suffix selects the reader (see the module docstring for the formats).
    sensor : Sensor, optional
        Sensor settings for the range check (default: HMC1021Z at the paper's settings).
    nan_policy : {"raise", "omit"}
        NaN/inf samples: an error, or dropped and counted in ``Measurement.nonfinite``.
    saturation : {"raise", "omit", "keep"}
        Samples beyond the sensor's linear range: an error, dropped, or kept; always counted.
    columns : Columns, mapping or str, optional
        Which of the file's columns holds the angle, voltage, time and setreset, with units:
        ``{"angle": "Tilt[deg]", "voltage": "Vout[mV]"}``, a
        :class:`~magcilia.io.columns.Columns` or the CLI's ``"angle=Tilt[deg],voltage=Vout[mV]"``
        (default: the names ``angle_deg``, ``voltage_V``, ``time_s``, ``setreset``).
    delimiter : {None, ",", ";", "\\t", "tab", " ", "whitespace", "auto"}
        CSV only: between fields; None or "auto" sniffs it from the header line.
    decimal : {".", ","}
        CSV only: the decimal mark (``","`` for ``1,25``; fields are then ``;``-separated, or
        quoted).
    group : str, optional
        HDF5 and TDMS only: the group that holds the columns (HDF5 default: the root; TDMS
        default: any group).
    progress : callable, optional
        Called as ``progress(bytes_read, file_size)`` while the file is read (CSV: after each
        block; other formats: at the start and the end).

    Returns
    -------
    Measurement

    Examples
    --------
    A European export (``Zeit;Winkel;Spannung`` with ``0,001;-40;12,5``, the voltage in mV)::

        read_measurements("run.csv", decimal=",", columns={
            "time": "Zeit[s]", "angle": "Winkel[deg]", "voltage": "Spannung[mV]"})
    """
    p = _recording_path(path)
    how = _how(p, columns, delimiter, decimal, group, progress)

    def start() -> _Reduction:
        return _Reduction(sensor, nan_policy, saturation, str(p))

    if READERS[p.suffix.lower()] is _read_csv:  # reduced as it is read, in bounded memory
        with _reader_boundary(p):
            reduction = _reduce_csv(p, how, start)
        if progress is not None:
            size = p.stat().st_size
            progress(size, size)
        return reduction.measurement()
    reduction = start()
    cols = read_samples(p, columns=how.columns, group=group, progress=progress)
    reduction.add(cols["angle_deg"], cols["voltage_V"], cols.get("setreset"))
    return reduction.measurement()


def example_path() -> Path:
    """Path of the bundled SYNTHETIC example recording (CSV; made by
    ``scripts/make_example_recording.py`` from the paper's Table I, truth and seed in the JSON
    beside it)."""
    return Path(str(resources.files("magcilia") / "data" / "example_recording.csv"))
