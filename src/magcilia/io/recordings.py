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
  'magcilia[tdms]'``): channels named ``angle_deg`` and ``voltage_V`` in any group. A channel we
  read must appear in one group only (a name in two groups is ambiguous and an error);
  magcilia's own recordings keep the samples in group ``recording`` and give the further groups
  (``readout``, ``events``) other channel names (:mod:`magcilia.io.recording_file`).

With set/reset samples the offset-free reading of an angle is ``(mean(V_set) − mean(V_reset))/2``
(the bridge flips polarity, the offset does not; HMC1021 datasheet).

Hostile files
-------------
Every failure of a reader becomes one :class:`~magcilia.MagciliaError` line naming the file and
what is wrong; an unexpected exception of a third-party parser is caught at the reader boundary
(:func:`read_samples`) and kept as the error's ``__cause__``. Sizes taken from a file are bounded
by the module constants below (each error names the constant to raise where a genuine file can
exceed it): :data:`MAX_SAMPLES` samples per column, :data:`MAX_LINE_CHARS` characters per CSV
line, :data:`MAX_DECOMPRESSED` inflated bytes per compressed MATLAB variable, and for the MATLAB
reader :data:`MAT_MEMORY_LIMIT` and :data:`MAT_TIMEOUT_S`.

**Why MATLAB files are parsed in a child process.** ``scipy.io.loadmat`` (C/Cython) crashes the
interpreter (SIGSEGV/SIGBUS) on some damaged files and HDF5 (under ``h5py``) is a large C library
with a long history of such crashes; no check in Python can prove a file safe for either. The CSV
and TDMS readers are pure Python and NumPy and cannot crash the process, so they run in-process. A
``.mat`` file is therefore (1) checked in-process by a small pure-Python scan of its container
(empty, unknown header, elements running past the end of the file, damaged zlib streams, and the
declared and the real inflated size of every compressed variable we read, counted in bounded pieces
against :data:`MAX_DECOMPRESSED`: a 6.5 MB file that inflates to 6.25 GiB is refused after 2 s in
constant memory, one that declares its size at once), then (2) parsed by SciPy or h5py in a fresh
interpreter (``python -P -c``, importing only NumPy and SciPy or h5py, never magcilia) whose address
space is capped (``RLIMIT_AS``, Linux: :data:`MAT_MEMORY_LIMIT` above what the interpreter uses at
start; elsewhere only the scan of step 1 bounds them) and whose run time is capped
(:data:`MAT_TIMEOUT_S`); the arrays come back through a temporary ``.npz`` file read without
pickles. A crash, a kill or a timeout of the child is one error line (``x.mat: the MATLAB reader
crashed on this file (signal 11, SIGSEGV); it is damaged or not a MAT file``). The price is the
start of that interpreter, paid once per file read: for a recording of the bundled example's size
(66,000 samples × 3 columns, 1.6 MB) ``read_samples`` takes 0.22–0.27 s (v5, plain or compressed)
and 0.11–0.18 s (v7.3) against 1–4 ms for ``loadmat``/h5py in-process (medians of 9, 2-core AMD EPYC
Linux VM); a 6.6-million-sample compressed file (64 MB) takes about 2 s against 0.6 s. A forking or
persistent worker would be cheaper but forks a threaded process (the live read-out) or leaves a
process behind; a pure-Python MAT parser would be a second implementation of SciPy's and still
leaves HDF5.

Angles are tilt angles in degrees: a finite ``|angle_deg|`` above :data:`MAX_ANGLE_DEG` (a
column in the wrong unit, or garbage) is an error rather than grouped, so the grouping by
rounding to :data:`ANGLE_DECIMALS` decimals never overflows.
"""

from __future__ import annotations

import codecs
import contextlib
import csv
import inspect
import json
import logging
import math
import os
import signal
import struct
import subprocess
import sys
import tempfile
import zlib
from array import array
from collections.abc import Iterator, Mapping
from dataclasses import dataclass, field
from importlib import resources
from pathlib import Path
from typing import IO, Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from magcilia import _validate as v
from magcilia._errors import MagciliaError, MissingDependencyError, require
from magcilia._validate import printable
from magcilia.constants import GAUSS
from magcilia.device.sensor import Sensor

F64 = NDArray[np.float64]
NAN_POLICIES = ("raise", "omit")
SATURATION_POLICIES = ("raise", "omit", "keep")
ANGLE_DECIMALS = 9  # angles equal to 1e-9 deg are the same angle
#: The columns a recording may hold (other columns, variables or channels are ignored).
COLUMNS = ("angle_deg", "voltage_V", "time_s", "setreset")

#: Largest |tilt angle| accepted, deg; beyond it the column is in the wrong unit or garbage.
MAX_ANGLE_DEG = 360.0
#: Most samples per column in any format (4 columns × 8 bytes × 50 million = 1.6 GB of arrays).
MAX_SAMPLES = 50_000_000
#: Longest CSV line, characters (a recording's line is tens of characters).
MAX_LINE_CHARS = 1 << 20
#: Most bytes one compressed MATLAB variable may inflate to (a column of MAX_SAMPLES is 400 MB).
MAX_DECOMPRESSED = 1 << 30
#: Address space the MATLAB reader's child process may add to what it uses at start (Linux).
MAT_MEMORY_LIMIT = 4 << 30
#: Longest time the MATLAB reader's child process may take, s.
MAT_TIMEOUT_S = 120.0


@dataclass(frozen=True, eq=False)
class Measurement:
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

    def __post_init__(self) -> None:
        for name in ("angles", "volts", "sem", "counts", "saturated", "nonfinite"):
            arr = np.array(getattr(self, name))
            arr.setflags(write=False)
            object.__setattr__(self, name, arr)

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
            "metadata": dict(self.metadata),
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


def beyond_range(volts: ArrayLike, sensor: Sensor) -> NDArray[np.bool_]:
    """True where an output (V, any shape) lies beyond the sensor's linear range. The bias is not
    known at this point: the field is judged relative to the sensor's offset."""
    with np.errstate(over="ignore", invalid="ignore"):  # huge outputs are beyond the range
        field = (np.asarray(volts, dtype=np.float64) - sensor.offset) / abs(sensor.scale)
        return np.asarray(np.abs(field) > sensor.field_range)


def reading(volts: F64, setreset: NDArray[Any] | None = None,
            where: str = "samples") -> tuple[float, float, int]:
    """One angle's reading from its samples: mean (V), standard error (V), samples used.

    Parameters
    ----------
    volts : ndarray, shape (s,)
        Samples, V (at least one).
    setreset : ndarray, shape (s,), optional
        +1 after a set pulse, −1 after a reset pulse: the reading is then the offset-free
        ``(mean(V_set) − mean(V_reset)) / 2`` (the bridge flips, its offset does not).
    where : str
        Names the samples in the error when set/reset samples lack one polarity.
    """
    with np.errstate(over="ignore", invalid="ignore"):  # huge samples: inf, checked by callers
        if setreset is None:
            sem = float(volts.std(ddof=1) / math.sqrt(volts.size)) if volts.size > 1 else 0.0
            return float(volts.mean()), sem, int(volts.size)
        vs, vr = volts[setreset > 0], volts[setreset < 0]
        if vs.size == 0 or vr.size == 0:
            raise MagciliaError(f"{where} has {vs.size} set and {vr.size} reset samples; "
                                "set/reset readings need both at every angle")
        var = float(sum(x.var(ddof=1) / x.size for x in (vs, vr) if x.size > 1)) / 4.0
        return float((vs.mean() - vr.mean()) / 2.0), math.sqrt(var), int(vs.size + vr.size)


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
    """Reduce raw samples to a :class:`Measurement`.

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
    v.choice("nan_policy", nan_policy, NAN_POLICIES)
    v.choice("saturation", saturation, SATURATION_POLICIES)
    sensor = sensor or Sensor()
    ang = np.asarray(angle_deg, dtype=np.float64).ravel()
    volt = np.asarray(voltage, dtype=np.float64).ravel()
    sr = None if setreset is None else np.asarray(setreset, dtype=np.float64).ravel()
    if ang.size != volt.size or (sr is not None and sr.size != ang.size):
        raise v.fail(f"{source}: columns", f"lengths {ang.size}, {volt.size}", "of equal length")
    if ang.size == 0:
        raise v.fail(f"{source}", "no samples", "a recording with at least two angles")
    far = np.isfinite(ang) & (np.abs(ang) > MAX_ANGLE_DEG)
    if far.any():
        i = int(np.argmax(far))
        raise MagciliaError(
            f"{source}: sample {i + 1} has angle_deg={ang[i]:.6g}, beyond ±{MAX_ANGLE_DEG:g} deg; "
            "angle_deg must be the tilt in degrees (check the column and its unit)"
        )
    bad = ~(np.isfinite(ang) & np.isfinite(volt))
    if sr is not None:
        bad |= ~np.isin(sr, (-1.0, 1.0))
    if bad.any() and nan_policy == "raise":
        i = int(np.argmax(bad))
        what = (f"is not finite (angle_deg={ang[i]}, voltage_V={volt[i]})"
                if not (math.isfinite(ang[i]) and math.isfinite(volt[i])) or sr is None
                else f"has setreset={sr[i]:g}, neither +1 (set) nor -1 (reset)")
        raise MagciliaError(
            f"{source}: sample {i + 1} {what}; clean the file or pass nan_policy='omit' "
            "(CLI: --nan-policy omit)"
        )
    sat = ~bad & beyond_range(volt, sensor)
    if sat.any() and saturation == "raise":
        i = int(np.argmax(sat))
        raise MagciliaError(
            f"{source}: sample {i + 1} (voltage_V={volt[i]:.6g} at {ang[i]:g} deg) is beyond the "
            f"sensor's linear range (±{sensor.field_range / GAUSS:g} gauss = "
            f"±{sensor.field_range * abs(sensor.scale):.4g} V); check gain and offset, or pass "
            "saturation='omit' (CLI: --saturation omit) to drop such samples"
        )
    finite_angle = np.isfinite(ang)  # |angle| <= MAX_ANGLE_DEG: the rounding cannot overflow
    distinct, group = np.unique(np.round(ang[finite_angle], ANGLE_DECIMALS), return_inverse=True)
    use = (~bad & ~(sat & (saturation == "omit")))[finite_angle]
    bad_f, sat_f, volt_f = bad[finite_angle], sat[finite_angle], volt[finite_angle]
    sr_f = None if sr is None else sr[finite_angle]
    rows: list[tuple[float, float, float, int, int, int]] = []
    empty: list[float] = []  # angles whose every sample was dropped
    n_empty = 0
    for g, a in enumerate(distinct):
        at = group == g
        sel = at & use
        n_bad, n_sat = int((at & bad_f).sum()), int((at & sat_f).sum())
        if not sel.any():
            empty.append(float(a))
            n_empty += int(at.sum())
            continue
        mean, sem, count = reading(volt_f[sel], None if sr_f is None else sr_f[sel],
                                   f"{source}: angle {a:g} deg")
        if not (math.isfinite(mean) and math.isfinite(sem)):
            raise MagciliaError(
                f"{source}: the reading at {a:g} deg overflows (samples up to "
                f"{np.abs(volt_f[sel]).max():.3g} V); voltage_V must be in volts"
            )
        rows.append((math.radians(a), mean, sem, count, n_sat, n_bad))
    if len(rows) < 2:
        raise MagciliaError(
            f"{source}: the recording has {len(rows)} usable angle(s); calibration needs at least "
            "two distinct angles (rows of angle_deg, voltage_V)"
        )
    arr = np.array(rows)
    if np.ptp(arr[:, 1]) == 0.0:
        raise MagciliaError(
            f"{source}: all readings are equal ({arr[0, 1]:.6g} V); the sensor output does not "
            "vary with the angle (check the wiring, the gain and that the cilium is magnetized)"
        )
    no_angle = int((~finite_angle).sum())  # only with nan_policy 'omit'
    metadata: dict[str, Any] = {}
    if no_angle or empty:  # dropped samples that no angle's counts can hold: counted here
        metadata["dropped"] = {"no_angle": no_angle, "angles_deg": empty, "samples": n_empty}
    return Measurement(
        angles=arr[:, 0], volts=arr[:, 1], sem=arr[:, 2], counts=arr[:, 3].astype(np.int64),
        saturated=arr[:, 4].astype(np.int64), nonfinite=arr[:, 5].astype(np.int64),
        set_reset=sr is not None, source=source, metadata=metadata,
    )


def _quote(text: str, limit: int = 40) -> str:
    """``text`` quoted for a one-line message (control characters escaped), cut at ``limit``."""
    return repr(text if len(text) <= limit else text[:limit] + "…")


def _names(names: list[str], limit: int = 12) -> str:
    """Names taken from a file, escaped and cut for a one-line message."""
    shown = [printable(n if len(n) <= 40 else n[:40] + "…") for n in names[:limit]]
    more = f", … ({len(names)} in all)" if len(names) > limit else ""
    return (", ".join(shown) or "none") + more


def _too_many(path: Path, what: str) -> MagciliaError:
    return MagciliaError(
        f"{path}: {what} has more than MAX_SAMPLES = {MAX_SAMPLES:,} samples; split the "
        "recording, or raise magcilia.io.recordings.MAX_SAMPLES for a genuine long one"
    )


SETRESET_TEXT = {"set": 1.0, "reset": -1.0, "+1": 1.0, "1": 1.0, "-1": -1.0, "1.0": 1.0,
                 "-1.0": -1.0, "+1.0": 1.0}


def _csv_lines(f: IO[str], path: Path, where: list[int]) -> Iterator[str]:
    """The data lines of an open CSV file (comments and blank lines skipped); ``where[0]`` is the
    number of the line last read. A line longer than :data:`MAX_LINE_CHARS` is an error."""
    while True:
        line = f.readline(MAX_LINE_CHARS + 1)
        if not line:
            return
        where[0] += 1
        if len(line) > MAX_LINE_CHARS:
            raise MagciliaError(
                f"{path}: line {where[0]} is longer than MAX_LINE_CHARS = {MAX_LINE_CHARS:,} "
                "characters; a recording's lines are short (damaged file?), or raise "
                "magcilia.io.recordings.MAX_LINE_CHARS"
            )
        text = line.strip()
        if text and not text.startswith("#"):
            yield line


def _bad_utf8_line(path: Path) -> int:
    """The number of the first line of ``path`` that is not UTF-8 (0 if every line is)."""
    decode = codecs.getincrementaldecoder("utf-8")()
    line = 1
    with path.open("rb") as f:
        while piece := f.read(1 << 16):
            try:
                decode.decode(piece)
            except UnicodeDecodeError as exc:
                return line + piece[:max(exc.start, 0)].count(b"\n")
            line += piece.count(b"\n")
    return 0


def _read_csv(path: Path, required: tuple[str, ...]) -> dict[str, F64]:
    where = [0]
    try:
        with path.open(encoding="utf-8-sig", newline="") as f:
            return _parse_csv(csv.reader(_csv_lines(f, path, where)), path, required, where)
    except UnicodeDecodeError:
        raise MagciliaError(f"{path}: not a UTF-8 text file (line {_bad_utf8_line(path)}); "
                            "export the recording as CSV") from None
    except csv.Error as exc:  # a field over the csv module's limit, a NUL character, ...
        raise MagciliaError(f"{path}: row {where[0]} is not well-formed CSV "
                            f"({printable(str(exc))}); the file is damaged or not a recording"
                            ) from exc


def _parse_csv(reader: Iterator[list[str]], path: Path, required: tuple[str, ...],
               where: list[int]) -> dict[str, F64]:
    first = next(reader, None)
    if first is None:
        raise MagciliaError(f"{path}: the file is empty; expected a header with "
                            f"{','.join(required)}")
    header = [h.strip() for h in first]
    for col in required:
        if col not in header:
            raise MagciliaError(
                f"{path}: missing column {col!r} (header: {_names(header)}); the CSV needs "
                f"columns {' and '.join(required)}"
            )
    idx: dict[str, int] = {}
    for col in COLUMNS:
        at = [i for i, h in enumerate(header) if h == col]
        if len(at) > 1:
            raise MagciliaError(
                f"{path}: column {col!r} appears {len(at)} times in the header (columns "
                f"{', '.join(str(i + 1) for i in at)}); keep one, it is ambiguous which to use"
            )
        if at:
            idx[col] = at[0]
    data = {col: array("d") for col in idx}
    for n, row in enumerate(reader):
        if len(row) != len(header):
            raise MagciliaError(
                f"{path}: row {where[0]} has {len(row)} fields, the header has {len(header)} "
                "(truncated or malformed file)"
            )
        if n >= MAX_SAMPLES:
            raise _too_many(path, "the file")
        for col, i in idx.items():
            text = row[i]
            if col == "setreset":
                value = SETRESET_TEXT.get(text.strip().lower())
                if value is None:
                    raise MagciliaError(f"{path}: row {where[0]}, column setreset: "
                                        f"{_quote(text)} is not set/reset or +1/-1")
            else:
                try:
                    value = float(text)
                except ValueError:
                    raise MagciliaError(f"{path}: row {where[0]}, column {col}: {_quote(text)} "
                                        "is not a number") from None
            data[col].append(value)
    return {col: np.frombuffer(values, dtype=np.float64).copy() if len(values) else np.zeros(0)
            for col, values in data.items()}
_HDF5_SIGNATURE = b"\x89HDF\r\n\x1a\n"
_MI_MATRIX, _MI_COMPRESSED = 14, 15
_V4_ITEMSIZE = {0: 8, 1: 4, 2: 4, 3: 2, 4: 2, 5: 1}  # MAT v4 precision code P -> bytes


def _gib(n: int) -> str:
    return f"{n / (1 << 30):g} GiB"


def _mat_kind(path: Path, f: IO[bytes], size: int) -> str:
    """Which MAT format the file holds: ``"hdf5"`` (7.3: an HDF5 superblock at byte 0, 512, 1024
    or 2048), ``"v4"`` or ``"v5"`` (5, 6 and 7; SciPy's tests); anything else is an error."""
    if size == 0:
        raise MagciliaError(f"{path}: the file is empty (0 bytes); not a MATLAB .mat file")
    for offset in (0, 512, 1024, 2048):  # an HDF5 superblock (v7.3, or plain HDF5)
        f.seek(offset)
        if f.read(8) == _HDF5_SIGNATURE:
            return "hdf5"
    f.seek(0)
    head = f.read(128)
    if len(head) >= 4 and 0 in head[:4]:  # v4: a zero in the first 4 bytes (as SciPy decides)
        if head.count(0) == len(head):
            raise MagciliaError(f"{path}: cannot read as a MATLAB .mat file (it starts with "
                                f"{len(head)} zero bytes: damaged)")
        return "v4"
    if len(head) == 128 and head[126:128] in (b"IM", b"MI"):
        major = head[125] if head[126:128] == b"IM" else head[124]  # as SciPy reads it
        if major == 1:
            return "v5"
        if major == 2:
            raise MagciliaError(f"{path}: cannot read as a MATLAB .mat file (a MATLAB 7.3 header "
                                "without HDF5 data: truncated or damaged)")
    raise MagciliaError(f"{path}: cannot read as a MATLAB .mat file (no MAT-file header: not a "
                        "MAT file, or damaged at the start)")


def _small_tag(buf: bytes, pos: int, endian: str) -> tuple[int, bytes, int] | None:
    """The MAT v5 sub-element at ``pos`` of ``buf``: (type, data, next position), or None when
    ``buf`` ends first."""
    if pos + 8 > len(buf):
        return None
    mdtype, nbytes = struct.unpack_from(endian + "II", buf, pos)
    if mdtype >> 16:  # small data element: the data sits in the tag's second word
        n = mdtype >> 16
        return mdtype & 0xFFFF, buf[pos + 4:pos + 4 + min(n, 4)], pos + 8
    end = pos + 8 + nbytes
    return (mdtype, buf[pos + 8:end], end + (-nbytes % 8)) if end <= len(buf) else None


def _matrix_name(buf: bytes, endian: str) -> str | None:
    """The variable name of a MAT v5 matrix element whose body starts ``buf`` (flags, dims, name
    sub-elements), or None when ``buf`` is too short to tell."""
    pos, data = 0, b""
    for _ in range(3):
        tag = _small_tag(buf, pos, endian)
        if tag is None:
            return None
        _, data, pos = tag
    return data.decode("latin-1")


def _inflated(f: IO[bytes], start: int, nbytes: int, limit: int) -> tuple[bytes, int]:
    """Inflate the zlib stream of ``nbytes`` at ``start`` in bounded pieces: (the first 64 KiB,
    the total inflated size, at most ``limit + 1``). Raises ``zlib.error``."""
    inflate = zlib.decompressobj()
    f.seek(start)
    prefix, total, left = b"", 0, nbytes
    while left > 0 and total <= limit and not inflate.eof:
        piece = f.read(min(left, 1 << 20))
        if not piece:
            break
        left -= len(piece)
        while piece and total <= limit:
            out = inflate.decompress(piece, 1 << 22)
            if len(prefix) < 1 << 16:
                prefix += out[:(1 << 16) - len(prefix)]
            total += len(out)
            piece = inflate.unconsumed_tail
    return prefix, total


def _check_compressed(path: Path, f: IO[bytes], pos: int, nbytes: int, endian: str) -> None:
    """A compressed MAT v5 variable at ``pos`` (``nbytes`` of zlib data) that we read must
    declare and inflate to at most :data:`MAX_DECOMPRESSED` bytes; its name is read first, and
    variables we do not read are skipped, as SciPy does."""
    try:
        prefix, total = _inflated(f, pos + 8, nbytes, 1 << 16)
        name = _matrix_name(prefix[8:], endian)
        if name is not None and name not in COLUMNS:
            return
        declared = struct.unpack(endian + "I", prefix[4:8])[0] if len(prefix) >= 8 else 0
        if declared <= MAX_DECOMPRESSED:
            prefix, total = _inflated(f, pos + 8, nbytes, MAX_DECOMPRESSED)
    except zlib.error as exc:
        raise MagciliaError(f"{path}: cannot read as a MATLAB .mat file (the compressed "
                            f"variable at byte {pos} is damaged: {exc})") from None
    what = (f"declares {declared:,} bytes, more than" if declared > MAX_DECOMPRESSED
            else "inflates to more than" if total > MAX_DECOMPRESSED else "")
    if what:
        raise MagciliaError(
            f"{path}: variable {printable(name or '?')} (byte {pos}, {nbytes:,} bytes "
            f"compressed) {what} MAX_DECOMPRESSED = {_gib(MAX_DECOMPRESSED)}; the file is "
            "damaged or hostile, or raise magcilia.io.recordings.MAX_DECOMPRESSED for a genuine "
            "large recording"
        )


def _scan_mat_v5(path: Path, f: IO[bytes], size: int) -> None:
    """Walk the top-level elements of a MAT v5 file without parsing them: each must lie inside
    the file, and each compressed variable we read (named in :data:`COLUMNS`, or whose name
    cannot be told) must inflate cleanly to at most :data:`MAX_DECOMPRESSED` bytes (counted in
    bounded pieces, nothing is kept)."""
    f.seek(126)
    endian = "<" if f.read(2) == b"IM" else ">"
    pos = 128
    while pos < size:
        f.seek(pos)
        tag = f.read(8)
        if len(tag) < 8:
            raise MagciliaError(f"{path}: cannot read as a MATLAB .mat file ({len(tag)} stray "
                                f"bytes at the end, byte {pos}: truncated or damaged)")
        mdtype, nbytes = struct.unpack(endian + "II", tag)
        if mdtype not in (_MI_MATRIX, _MI_COMPRESSED):
            raise MagciliaError(f"{path}: cannot read as a MATLAB .mat file (element of type "
                                f"{mdtype} at byte {pos}, expected a variable: damaged)")
        if nbytes > size - pos - 8:
            raise MagciliaError(f"{path}: cannot read as a MATLAB .mat file (the variable at "
                                f"byte {pos} declares {nbytes:,} bytes, {size - pos - 8:,} "
                                "remain: truncated or damaged)")
        if mdtype == _MI_COMPRESSED:
            _check_compressed(path, f, pos, nbytes, endian)
        pos += 8 + nbytes


def _scan_mat_v4(path: Path, f: IO[bytes], size: int) -> None:
    """Walk the variables of a MAT v4 file: each one's declared data must lie inside the file
    (SciPy allocates what a header declares before reading it)."""
    f.seek(0)
    mopt = struct.unpack("<i", f.read(4))[0]
    endian = ">" if mopt < 0 or mopt > 5000 else "<"
    pos = 0
    while pos + 20 <= size:
        f.seek(pos)
        mopt, rows, cols, imagf, namlen = struct.unpack(endian + "5i", f.read(20))
        itemsize = _V4_ITEMSIZE.get(mopt % 100 // 10)
        if itemsize is None or min(rows, cols, namlen) < 0:
            return  # SciPy says what is wrong
        nbytes = 20 + namlen + rows * cols * itemsize * (2 if imagf else 1)
        if nbytes > size - pos:
            raise MagciliaError(f"{path}: cannot read as a MATLAB .mat file (the variable at "
                                f"byte {pos} declares {nbytes:,} bytes, {size - pos:,} remain: "
                                "truncated or damaged)")
        pos += nbytes


def _mat_child() -> None:  # pragma: no cover (runs in the child process)
    """The MATLAB reader's child process (see the module docstring): its source is sent with
    ``python -P -c``, so it is self-contained and imports nothing from magcilia.

    argv: file, output .npz, kind ("v4", "v5", "hdf5"), memory limit (bytes), largest variable
    (bytes), the variable names to read (comma-separated). Prints one JSON line: ``found`` (the
    names in the file), ``saved`` (written to the .npz), ``problems`` (name -> what is wrong),
    ``error`` (why the file could not be read, "memory" for a MemoryError, or null).
    """
    import contextlib
    import json
    import os
    import sys
    import warnings
    from pathlib import Path

    path, out, kind = sys.argv[1:4]
    memory, max_bytes, wanted = int(sys.argv[4]), int(sys.argv[5]), sys.argv[6].split(",")
    found: list[str] = []
    problems: dict[str, str] = {}
    saved: list[str] = []
    error = None
    try:
        import numpy as np

        if kind == "hdf5":
            import h5py
        else:
            from scipy.io import loadmat, whosmat
        with contextlib.suppress(ImportError, OSError, ValueError):  # Linux: cap the memory
            import resource

            used = int(Path("/proc/self/statm").read_text().split()[0]) * os.sysconf(
                "SC_PAGE_SIZE")
            soft, hard = resource.getrlimit(resource.RLIMIT_AS)
            cap = used + memory if hard == resource.RLIM_INFINITY else min(used + memory, hard)
            if soft == resource.RLIM_INFINITY or soft > cap:
                resource.setrlimit(resource.RLIMIT_AS, (cap, hard))
        arrays: dict[str, Any] = {}
        numeric = ("double", "single", "logical", "int8", "uint8", "int16", "uint16", "int32",
                   "uint32", "int64", "uint64")
        if kind == "hdf5":
            with h5py.File(path, "r") as mat:
                found = [str(k) for k in mat if not str(k).startswith("#")]
                for k in wanted:
                    if k not in found:
                        continue
                    if not isinstance(mat.get(k, getlink=True), h5py.HardLink):
                        problems[k] = "is a link, not a numeric vector"
                        continue
                    obj = mat[k]
                    cls = obj.attrs.get("MATLAB_class", b"")
                    cls = cls.decode("latin-1") if isinstance(cls, bytes) else str(cls)
                    if not isinstance(obj, h5py.Dataset):
                        problems[k] = f"is a MATLAB {cls or 'group'}, not a numeric vector"
                    elif cls and cls not in numeric:
                        problems[k] = f"is a MATLAB {cls} array, not a numeric vector"
                    elif obj.attrs.get("MATLAB_empty", 0):
                        arrays[k] = np.zeros(0)
                    elif obj.dtype.names:
                        problems[k] = ("is complex; save its real part" if "imag" in
                                       obj.dtype.names else "is a compound, not numbers")
                    elif obj.dtype.kind not in "biuf":
                        problems[k] = f"holds HDF5 type {obj.dtype}, not numbers"
                    elif obj.size * obj.dtype.itemsize > max_bytes:
                        problems[k] = (f"holds {obj.size * obj.dtype.itemsize:,} bytes, more "
                                       f"than MAX_DECOMPRESSED = {max_bytes:,}; raise magcilia."
                                       "io.recordings.MAX_DECOMPRESSED for a genuine recording")
                    else:
                        arrays[k] = np.asarray(obj[()]).T  # MATLAB's dimensions are reversed
        else:
            with warnings.catch_warnings(record=True) as caught:
                warnings.simplefilter("always")
                listing = whosmat(path)
                found = [str(name) for name, _, _ in listing]
                classes = {str(name): str(cls) for name, _, cls in listing}
                for k in wanted:
                    if found.count(k) > 1:
                        problems[k] = (f"appears {found.count(k)} times; keep one, it is "
                                       "ambiguous which to use")
                read = [k for k in wanted if k in found and k not in problems]
                mat = loadmat(path, squeeze_me=True, variable_names=read) if read else {}
            if caught:
                raise ValueError(str(caught[0].message).splitlines()[0])
            for k in read:
                value = np.asarray(mat.get(k))
                if value.dtype.kind == "c":
                    problems[k] = "is complex; save its real part"
                elif value.dtype.kind not in "biuf":
                    problems[k] = f"is a MATLAB {classes.get(k, '?')} array, not a numeric vector"
                else:
                    arrays[k] = value
        if arrays:
            np.savez(out, **arrays)
            saved = sorted(arrays)
    except MemoryError:
        error = "memory"
    except Exception as exc:  # noqa: BLE001 (the parent turns it into one line)
        error = f"{type(exc).__name__}: {exc}"
    sys.stdout.write(json.dumps({"found": found[:100], "n_found": len(found), "saved": saved,
                                 "problems": problems, "error": error}) + "\n")


def _mat_child_code() -> str:
    """The child's program: :func:`_mat_child`'s source and a call."""
    return inspect.getsource(_mat_child) + "\n_mat_child()\n"


def _run_mat_child(path: Path, kind: str) -> tuple[dict[str, Any], dict[str, NDArray[Any]]]:
    """Parse ``path`` in a child process (see the module docstring): its report and arrays."""
    if not sys.executable:
        raise MagciliaError(f"{path}: cannot start the MATLAB reader (no Python interpreter: "
                            "sys.executable is empty)")
    env = {**os.environ, "OPENBLAS_NUM_THREADS": "1", "OMP_NUM_THREADS": "1",
           "MKL_NUM_THREADS": "1"}
    with tempfile.TemporaryDirectory(prefix="magcilia-mat-") as tmp:
        out = Path(tmp) / "variables.npz"
        argv = [sys.executable, "-P", "-c", _mat_child_code(), str(path.resolve()), str(out),
                kind, str(int(MAT_MEMORY_LIMIT)), str(int(MAX_DECOMPRESSED)), ",".join(COLUMNS)]
        try:
            proc = subprocess.run(argv, stdin=subprocess.DEVNULL, capture_output=True,
                                  timeout=MAT_TIMEOUT_S, env=env, cwd=tmp, check=False)
        except subprocess.TimeoutExpired:
            raise MagciliaError(
                f"{path}: the MATLAB reader took longer than MAT_TIMEOUT_S = {MAT_TIMEOUT_S:g} s "
                "and was stopped; the file is damaged, or raise "
                "magcilia.io.recordings.MAT_TIMEOUT_S for a genuine large file") from None
        except OSError as exc:
            raise MagciliaError(f"{path}: cannot start the MATLAB reader "
                                f"({printable(str(exc))})") from exc
        report: dict[str, Any] | None = None
        lines = proc.stdout.decode("utf-8", "replace").strip().splitlines()
        if proc.returncode == 0 and lines:
            with contextlib.suppress(ValueError):
                report = json.loads(lines[-1])
        memory = (f"{path}: reading this file needs more than MAT_MEMORY_LIMIT = "
                  f"{_gib(MAT_MEMORY_LIMIT)} of memory; the file is damaged, or raise "
                  "magcilia.io.recordings.MAT_MEMORY_LIMIT for a genuine large file")
        if not isinstance(report, dict):
            if b"MemoryError" in proc.stderr:
                raise MagciliaError(memory)
            rc = proc.returncode
            if rc < 0:
                how = f"signal {-rc}"
                with contextlib.suppress(ValueError):
                    how = f"signal {-rc}, {signal.Signals(-rc).name}"
                raise MagciliaError(f"{path}: the MATLAB reader crashed on this file ({how}); "
                                    "it is damaged or not a MAT file")
            last = (proc.stderr.decode("utf-8", "replace").strip().splitlines() or [""])[-1]
            raise MagciliaError(f"{path}: the MATLAB reader failed on this file (exit code {rc}"
                                f"{': ' + printable(last[:160]) if last else ''}); it is "
                                "damaged or not a MAT file")
        if report.get("error") == "memory":
            raise MagciliaError(memory)
        if report.get("error"):
            raise MagciliaError(f"{path}: cannot read as a MATLAB .mat file "
                                f"({printable(str(report['error'])[:200])})")
        arrays: dict[str, NDArray[Any]] = {}
        if report.get("saved"):
            with np.load(out, allow_pickle=False) as npz:
                arrays = {k: npz[k] for k in npz.files if k in COLUMNS}
    return report, arrays


def _read_mat(path: Path, required: tuple[str, ...]) -> dict[str, F64]:
    size = path.stat().st_size
    with path.open("rb") as f:
        kind = _mat_kind(path, f, size)
        if kind == "v5":
            _scan_mat_v5(path, f, size)
        elif kind == "v4":
            _scan_mat_v4(path, f, size)
    if kind == "hdf5":
        require("h5py", package="h5py", extra="hdf5", purpose="Reading MATLAB v7.3 .mat files")
    report, arrays = _run_mat_child(path, kind)
    problems = report.get("problems") or {}
    if problems:
        name, problem = next(iter(problems.items()))
        fix = "" if ";" in str(problem) else f"; save {name} as a real numeric vector"
        raise MagciliaError(f"{path}: variable {printable(str(name))} "
                            f"{printable(str(problem))}{fix}")
    missing = [k for k in required if k not in arrays]
    if missing:
        found = [str(n) for n in report.get("found", []) if not str(n).startswith("__")]
        raise MagciliaError(
            f"{path}: missing variable(s) {', '.join(missing)} (found: {_names(found)}); save "
            f"vectors named {' and '.join(required)}"
        )
    out: dict[str, F64] = {}
    for key, value in arrays.items():
        arr = np.squeeze(value)
        if arr.ndim > 1:
            raise MagciliaError(f"{path}: variable {key} is a {'×'.join(map(str, arr.shape))} "
                                "matrix; save a vector (one value per sample)")
        out[key] = arr.astype(np.float64).ravel()
    return out


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


def _read_tdms(path: Path, required: tuple[str, ...]) -> dict[str, F64]:
    nptdms = nptdms_module()
    size = path.stat().st_size
    with quiet_nptdms(), path.open("rb") as file, nptdms.TdmsFile.open(file) as tdms:
        places: dict[str, list[tuple[str, Any]]] = {}
        everything: list[str] = []
        for group in tdms.groups():
            for channel in group.channels():
                everything.append(str(channel.name))
                if channel.name in COLUMNS:
                    places.setdefault(channel.name, []).append((str(group.name), channel))
        for name, where in places.items():
            if len(where) > 1:
                raise MagciliaError(
                    f"{path}: channel {name} appears in {len(where)} groups "
                    f"({_names([g for g, _ in where])}); keep it in one group, it is ambiguous "
                    "which to use"
                )
        missing = [k for k in required if k not in places]
        if missing:
            raise MagciliaError(
                f"{path}: missing channel(s) {', '.join(missing)} (found: {_names(everything)}); "
                f"name the channels {' and '.join(required)}"
            )
        out: dict[str, F64] = {}
        for name, ((group_name, channel),) in places.items():
            what = f"{path}: channel {name} (group {printable(group_name)})"
            dtype = np.dtype(channel.dtype)
            if dtype.kind not in "biuf":
                raise MagciliaError(f"{what} holds {channel.data_type.__name__} values, not real "
                                    "numbers; store the samples as numbers")
            n = len(channel)
            if n > MAX_SAMPLES:
                raise _too_many(path, f"channel {name}")
            if n * dtype.itemsize > size:
                raise MagciliaError(f"{what} declares {n:,} values, more than the file's "
                                    f"{size:,} bytes can hold; the file is damaged")
            data = np.asarray(channel[:], dtype=np.float64).ravel()
            if data.size != n:
                raise MagciliaError(f"{what} holds {data.size:,} of the {n:,} values it "
                                    "declares; the file is damaged")
            out[name] = data
        complete = tdms.properties.get("complete")
    if complete is False and out:  # a magcilia recording cut short (a crash): its last
        # segment may end inside a channel; the samples in every channel are whole
        n = min(a.size for a in out.values())
        out = {k: a[:n] for k, a in out.items()}
    return out


READERS = {".csv": _read_csv, ".txt": _read_csv, ".mat": _read_mat, ".tdms": _read_tdms}
FORMATS = {".csv": "CSV", ".txt": "CSV", ".mat": "MATLAB .mat", ".tdms": "TDMS"}


def _describe(exc: BaseException) -> str:
    """An exception as a short, harmless line: ``TypeName: message``."""
    text = printable(str(exc))
    return type(exc).__name__ + (f": {text[:160]}" + ("…" if len(text) > 160 else "")
                                 if text else "")


def read_samples(
    path: str | Path, required: tuple[str, ...] = ("angle_deg", "voltage_V")
) -> dict[str, F64]:
    """Raw sample columns of a recording (CSV, MATLAB .mat or TDMS), without any reduction.

    Parameters
    ----------
    path : str or Path
        The file; its suffix selects the reader (see the module docstring for the formats).
    required : tuple of str
        Columns that must be present (a one-line error names the file and the missing column).

    Returns
    -------
    dict of str to ndarray, shape (samples,)
        The columns found among ``angle_deg`` (deg), ``voltage_V`` (V), ``time_s`` (s) and
        ``setreset`` (+1 set, −1 reset), all of the same length (possibly 0: a recording
        stopped before its first sample; :func:`read_measurements` rejects it).

    Raises
    ------
    MagciliaError
        For any file that cannot be read as a recording (one line naming the file and what is
        wrong; an unexpected exception of a third-party parser is its ``__cause__``).
    MissingDependencyError
        For a TDMS or MATLAB v7.3 file without the optional package that reads it.
    """
    p = Path(path)
    reader = READERS.get(p.suffix.lower())
    if reader is None:
        raise v.fail(f"{p}: file type", p.suffix or "(none)", "one of " + ", ".join(READERS))
    if not p.is_file():
        raise MagciliaError(f"{p}: no such file")
    try:
        cols = reader(p, required)
    except (MagciliaError, MissingDependencyError):
        raise
    except (PermissionError, IsADirectoryError, FileNotFoundError) as exc:
        raise MagciliaError(f"{p}: cannot read the file ({printable(exc.strerror or str(exc))})"
                            ) from exc
    except Exception as exc:  # the reader boundary: any parser failure is one line
        raise MagciliaError(f"{p}: cannot read as a {FORMATS[p.suffix.lower()]} file "
                            f"({_describe(exc)}); the file is damaged or not a recording"
                            ) from exc
    lengths = {k: a.size for k, a in cols.items()}
    if len(set(lengths.values())) > 1:
        raise MagciliaError(
            f"{p}: the columns have different lengths "
            f"({', '.join(f'{k} {n}' for k, n in lengths.items())}); every column needs one "
            "value per sample"
        )
    if any(n > MAX_SAMPLES for n in lengths.values()):
        raise _too_many(p, "the recording")
    return cols


def read_measurements(
    path: str | Path,
    *,
    sensor: Sensor | None = None,
    nan_policy: str = "raise",
    saturation: str = "raise",
) -> Measurement:
    """Read a recording (CSV, MATLAB .mat or TDMS) and reduce it to per-angle means.

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

    Returns
    -------
    Measurement
    """
    p = Path(path)
    cols = read_samples(p)
    return measurement_from_samples(
        cols["angle_deg"], cols["voltage_V"], setreset=cols.get("setreset"), sensor=sensor,
        nan_policy=nan_policy, saturation=saturation, source=str(p),
    )


def example_path() -> Path:
    """Path of the bundled SYNTHETIC example recording (CSV; made by
    ``scripts/make_example_recording.py`` from the paper's Table I, truth and seed in the JSON
    beside it)."""
    return Path(str(resources.files("magcilia") / "data" / "example_recording.csv"))
