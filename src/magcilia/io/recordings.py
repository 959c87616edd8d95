"""Measured field-vs-tilt recordings: reading files and reducing raw samples to per-angle means.

Formats (chosen by the file suffix):

- **CSV** (``.csv``, ``.txt``): a header row with ``angle_deg`` and ``voltage_V``; one row per raw
  sample, repeated angles are samples of the same angle. Optional ``time_s`` and ``setreset``
  (``set``/``reset`` or ``+1``/``-1``: samples taken after a set or a reset pulse of the AMR
  strap). Lines starting with ``#`` are comments.
- **MATLAB** (``.mat``, via SciPy): variables ``angle_deg`` and ``voltage_V`` (vectors of equal
  length), optionally ``time_s`` and ``setreset``.
- **TDMS** (``.tdms``, NI LabVIEW, needs the optional ``npTDMS``: ``pip install
  'magcilia[tdms]'``): channels named ``angle_deg`` and ``voltage_V`` in any group.

With set/reset samples the offset-free reading of an angle is ``(mean(V_set) − mean(V_reset))/2``
(the bridge flips polarity, the offset does not; HMC1021 datasheet).
"""

from __future__ import annotations

import contextlib
import csv
import logging
import math
from collections.abc import Iterator, Mapping
from dataclasses import dataclass, field
from importlib import resources
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from magcilia import _validate as v
from magcilia._errors import MagciliaError, require
from magcilia.constants import GAUSS
from magcilia.device.sensor import Sensor

F64 = NDArray[np.float64]
NAN_POLICIES = ("raise", "omit")
SATURATION_POLICIES = ("raise", "omit", "keep")
ANGLE_DECIMALS = 9  # angles equal to 1e-9 deg are the same angle


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
        return text + (f"; {', '.join(dropped)}" if dropped else "")


def beyond_range(volts: ArrayLike, sensor: Sensor) -> NDArray[np.bool_]:
    """True where an output (V, any shape) lies beyond the sensor's linear range. The bias is not
    known at this point: the field is judged relative to the sensor's offset."""
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
    if setreset is None:
        sem = float(volts.std(ddof=1) / math.sqrt(volts.size)) if volts.size > 1 else 0.0
        return float(volts.mean()), sem, int(volts.size)
    vs, vr = volts[setreset > 0], volts[setreset < 0]
    if vs.size == 0 or vr.size == 0:
        raise MagciliaError(f"{where} has {vs.size} set and {vr.size} reset samples; set/reset "
                            "readings need both at every angle")
    var = sum(x.var(ddof=1) / x.size for x in (vs, vr) if x.size > 1) / 4.0
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
    bad = ~(np.isfinite(ang) & np.isfinite(volt))
    if sr is not None:
        bad |= ~np.isin(sr, (-1.0, 1.0))
    if bad.any() and nan_policy == "raise":
        i = int(np.argmax(bad))
        raise MagciliaError(
            f"{source}: sample {i + 1} is not finite (angle_deg={ang[i]}, voltage_V={volt[i]}); "
            "clean the file or pass nan_policy='omit' (CLI: --nan-policy omit)"
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
    finite_angle = np.isfinite(ang)
    distinct, group = np.unique(
        np.round(np.where(finite_angle, ang, np.inf), ANGLE_DECIMALS), return_inverse=True
    )
    use = ~bad & ~(sat & (saturation == "omit"))
    rows: list[tuple[float, float, float, int, int, int]] = []
    for g, a in enumerate(distinct):
        if not math.isfinite(a):
            continue
        at = group == g
        sel = at & use
        n_bad, n_sat = int((at & bad).sum()), int((at & sat).sum())
        if not sel.any():
            continue
        mean, sem, count = reading(volt[sel], None if sr is None else sr[sel],
                                   f"{source}: angle {a:g} deg")
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
    return Measurement(
        angles=arr[:, 0], volts=arr[:, 1], sem=arr[:, 2], counts=arr[:, 3].astype(np.int64),
        saturated=arr[:, 4].astype(np.int64), nonfinite=arr[:, 5].astype(np.int64),
        set_reset=sr is not None, source=source,
    )


def _parse_setreset(values: list[str], source: str) -> F64:
    table = {"set": 1.0, "reset": -1.0, "+1": 1.0, "1": 1.0, "-1": -1.0, "1.0": 1.0, "-1.0": -1.0}
    out = np.empty(len(values))
    for i, text in enumerate(values):
        key = text.strip().lower()
        if key not in table:
            raise MagciliaError(
                f"{source}: row {i + 2}, column setreset: {text!r} is not set/reset or +1/-1"
            )
        out[i] = table[key]
    return out


def _read_csv(path: Path, required: tuple[str, ...]) -> dict[str, Any]:
    try:
        text = path.read_text(encoding="utf-8-sig")
    except UnicodeDecodeError:
        raise MagciliaError(f"{path}: not a UTF-8 text file; export the recording as CSV") from None
    lines = [ln for ln in text.splitlines() if ln.strip() and not ln.lstrip().startswith("#")]
    if not lines:
        raise MagciliaError(f"{path}: the file is empty; expected a header with "
                            f"{','.join(required)}")
    reader = csv.reader(lines)
    header = [h.strip() for h in next(reader)]
    for col in required:
        if col not in header:
            raise MagciliaError(
                f"{path}: missing column {col!r} (header: {', '.join(header)}); the CSV needs "
                f"columns {' and '.join(required)}"
            )
    idx = {name: header.index(name) for name in header}
    data: dict[str, list[str]] = {name: [] for name in header}
    for row_no, row in enumerate(reader, start=2):
        if len(row) != len(header):
            raise MagciliaError(
                f"{path}: row {row_no} has {len(row)} fields, the header has {len(header)} "
                "(truncated or malformed file)"
            )
        for name, i in idx.items():
            data[name].append(row[i])
    out: dict[str, Any] = {}
    for col in ("angle_deg", "voltage_V", "time_s"):
        if col in data:
            vals = np.empty(len(data[col]))
            for i, text in enumerate(data[col]):
                try:
                    vals[i] = float(text)
                except ValueError:
                    raise MagciliaError(
                        f"{path}: row {i + 2}, column {col}: {text!r} is not a number"
                    ) from None
            out[col] = vals
    if "setreset" in data:
        out["setreset"] = _parse_setreset(data["setreset"], str(path))
    return out


def _read_mat(path: Path, required: tuple[str, ...]) -> dict[str, Any]:
    from scipy.io import loadmat

    try:
        mat = loadmat(path, squeeze_me=True)
    except (ValueError, TypeError, OSError, KeyError, IndexError) as exc:  # not a MAT file
        raise MagciliaError(f"{path}: cannot read as a MATLAB .mat file ({exc})") from None
    missing = [k for k in required if k not in mat]
    if missing:
        found = ", ".join(k for k in mat if not k.startswith("__")) or "none"
        raise MagciliaError(
            f"{path}: missing variable(s) {', '.join(missing)} (found: {found}); save vectors "
            f"named {' and '.join(required)}"
        )
    out: dict[str, Any] = {}
    for key in ("angle_deg", "voltage_V", "time_s", "setreset"):
        if key in mat:
            try:
                out[key] = np.asarray(mat[key], dtype=np.float64).ravel()
            except (TypeError, ValueError):
                raise MagciliaError(f"{path}: variable {key} is not numeric") from None
    return out


def nptdms_module(purpose: str = "Reading TDMS files") -> Any:
    """The optional npTDMS package, or a one-line error naming the ``tdms`` extra."""
    return require("nptdms", package="npTDMS", extra="tdms", purpose=purpose)


@contextlib.contextmanager
def quiet_nptdms() -> Iterator[None]:
    """npTDMS logs warnings for a file cut inside its last segment (a recording whose writer was
    killed); such a file is read, and the caller says what matters in one line."""
    log = logging.getLogger("nptdms")
    level = log.level
    log.setLevel(logging.ERROR)
    try:
        yield
    finally:
        log.setLevel(level)


def _read_tdms(path: Path, required: tuple[str, ...]) -> dict[str, Any]:
    nptdms = nptdms_module()
    try:
        with quiet_nptdms():
            tdms = nptdms.TdmsFile.read(path)
    except (ValueError, TypeError, OSError, KeyError, IndexError) as exc:  # corrupt files
        raise MagciliaError(f"{path}: cannot read as a TDMS file ({exc})") from None
    channels = {ch.name: ch for group in tdms.groups() for ch in group.channels()}
    missing = [k for k in required if k not in channels]
    if missing:
        raise MagciliaError(
            f"{path}: missing channel(s) {', '.join(missing)} (found: "
            f"{', '.join(channels) or 'none'}); name the channels {' and '.join(required)}"
        )
    out = {k: np.asarray(channels[k][:], dtype=np.float64) for k in
           ("angle_deg", "voltage_V", "time_s", "setreset") if k in channels}
    if tdms.properties.get("complete") is False:  # a magcilia recording cut short (a crash):
        # its last segment may end inside a channel; the samples in every channel are whole
        n = min(a.size for a in out.values())
        out = {k: a[:n] for k, a in out.items()}
    return out


READERS = {".csv": _read_csv, ".txt": _read_csv, ".mat": _read_mat, ".tdms": _read_tdms}


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
        ``setreset`` (+1 set, −1 reset).
    """
    p = Path(path)
    reader = READERS.get(p.suffix.lower())
    if reader is None:
        raise v.fail(f"{p}: file type", p.suffix or "(none)", "one of " + ", ".join(READERS))
    if not p.is_file():
        raise MagciliaError(f"{p}: no such file")
    return reader(p, required)


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
