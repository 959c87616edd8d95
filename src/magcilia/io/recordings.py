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
line, and for MATLAB files those of :mod:`magcilia.io.matfile`.

MATLAB files are parsed in a child process after a check of their structure
(:mod:`magcilia.io.matfile`, which says why and what it costs).

Angles are tilt angles in degrees: a finite ``|angle_deg|`` above :data:`MAX_ANGLE_DEG` (a
column in the wrong unit, or garbage) is an error rather than grouped, so the grouping by
rounding to :data:`ANGLE_DECIMALS` decimals never overflows.
"""

from __future__ import annotations

import codecs
import contextlib
import csv
import logging
import math
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
from magcilia.io.matfile import read_mat

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


def _read_mat(path: Path, required: tuple[str, ...]) -> dict[str, F64]:
    return read_mat(path, COLUMNS, required)


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
