"""The coil calibration sweep: drive a sequence of uniform fields, record the sensor at each.

A :class:`CoilSequence` lists the fields (T, board frame, the field at the cilium) with an optional
dwell per step; :func:`record_coil` applies each one — on a
:class:`~magcilia.acquire.simulated_coil.SimulatedCoilSource` by its own coil, on a device through
a :class:`CoilDriver` (:class:`~magcilia.acquire.coil_output.NidaqCoilOutput`: an NI analog
output per axis) written before the step's samples — drops ``settle`` s while the hair and the
coil's current settle, and records the step's samples into one crash-safe recording
(:class:`~magcilia.io.recording_file.RecordingWriter`, the same machinery, atomicity and
``overwrite`` rule as :func:`~magcilia.acquire.record_sweep`) with the applied field of every
sample in ``actuation_x_T``, ``actuation_y_T``, ``actuation_z_T`` and no ``angle_deg``: a coil
recording, which ``magcilia calibrate --model physical`` fits. The applied field recorded is the
source's own (simulated), else the driver's measured one (a current-sense channel), else the
command.

Bad sequences are refused before anything runs (:meth:`CoilSequence.check`): a field beyond the
sensor's linear range along its sensing axis, or one whose magnitude reaches the field that may
flip the AMR element's magnetization (``Sensor.flip_field``).
"""

from __future__ import annotations

import csv
import functools
import time
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Protocol

import numpy as np
from numpy.typing import ArrayLike, NDArray

from magcilia import _validate as v
from magcilia._display import Display, Item, count, si
from magcilia._errors import MagciliaError
from magcilia.acquire.simulated_coil import ACTUATION_COLUMNS, SimulatedCoilSource, field_text
from magcilia.acquire.source import Block, Counters, Source
from magcilia.acquire.sweep import record_step
from magcilia.device.sensor import Sensor
from magcilia.io.recording_file import RecordingWriter, chunk_for
from magcilia.io.recordings import nptdms_module
from magcilia.units import parse_value

F64 = NDArray[np.float64]


class CoilDriver(Protocol):
    """What drives a coil: ``set_field(b)`` applies the field b (3,), T, and returns the field
    actually applied (measured where the driver can, else the command)."""

    def set_field(self, field: F64) -> F64: ...

    def close(self) -> None: ...


@dataclass(frozen=True)
class CoilStep:
    """One step of a coil sequence: the uniform field (3,), T, and its dwell, s (None: the
    sweep's ``samples``)."""

    field: tuple[float, float, float]
    dwell: float | None = None


@dataclass(frozen=True)
class CoilSequence:
    """The fields a coil sweep applies, in order (see the module docstring).

    Build it with :meth:`parse` (``"0,0,0; 5,0,0; 0,5,0"`` in gauss, or with a unit per
    component: ``"0.5mT,0,0"``), :meth:`read` (a CSV with columns ``bx_G, by_G, bz_G`` and an
    optional ``dwell_s``) or from a list of fields in T (:meth:`of`).
    """

    steps: tuple[CoilStep, ...]

    def __post_init__(self) -> None:
        if not self.steps:
            raise v.fail("coil sequence", "no steps", "at least one field")

    @classmethod
    def of(cls, fields: ArrayLike, dwell: float | None = None) -> CoilSequence:
        """Steps of the fields ``fields`` (s, 3), T, each with the same ``dwell`` (s)."""
        arr = v.finite_array("fields", fields, unit="T")
        if arr.ndim != 2 or arr.shape[1] != 3:
            raise v.fail("fields", f"an array of shape {arr.shape}", "fields of shape (s, 3), T")
        d = None if dwell is None else v.positive("dwell", dwell, "s", "duration")
        return cls(tuple(CoilStep((float(b[0]), float(b[1]), float(b[2])), d) for b in arr))

    @classmethod
    def parse(cls, text: str, key: str = "--coil") -> CoilSequence:
        """Fields ``"BX,BY,BZ; BX,BY,BZ; …"``, gauss unless a component carries a unit."""
        fields = []
        for part in str(text).replace("\n", ";").split(";"):
            if not part.strip():
                continue
            comps = part.split(",")
            if len(comps) != 3:
                raise v.fail(key, part.strip(), "fields BX,BY,BZ (gauss) separated by ';', "
                             "e.g. '0,0,0;5,0,0;0,5,0'")
            fields.append([parse_value(c.strip(), "field", "G", key, "5,0,0") for c in comps])
        if not fields:
            raise v.fail(key, text, "at least one field BX,BY,BZ (gauss), e.g. '0,0,0;5,0,0'")
        return cls.of(fields)

    @classmethod
    def read(cls, path: str | Path) -> CoilSequence:
        """A CSV file of steps: columns ``bx_G``, ``by_G``, ``bz_G`` (gauss) and optionally
        ``dwell_s`` (s) per row."""
        path = Path(path)
        try:
            with path.open(newline="") as fh:
                rows = list(csv.DictReader(fh))
        except (OSError, UnicodeDecodeError, csv.Error) as exc:
            raise MagciliaError(f"{path}: cannot read the coil sequence ({exc})") from None
        steps = []
        for i, row in enumerate(rows, 2):
            try:
                b = tuple(float(row[c]) * 1e-4 for c in ("bx_G", "by_G", "bz_G"))
                dwell = row.get("dwell_s")
                d = float(dwell) if dwell not in (None, "") else None
            except (KeyError, TypeError, ValueError):
                raise MagciliaError(f"{path}:{i}: a coil step needs numbers in columns bx_G, "
                                    "by_G, bz_G (gauss) and optionally dwell_s (s)") from None
            steps.append(CoilStep((v.real("bx", b[0], "T"), v.real("by", b[1], "T"),
                                   v.real("bz", b[2], "T")),
                                  None if d is None else v.positive("dwell_s", d, "s")))
        if not steps:
            raise MagciliaError(f"{path}: no coil steps (columns bx_G, by_G, bz_G, dwell_s)")
        return cls(tuple(steps))

    @classmethod
    def from_text(cls, text: str, key: str = "--coil") -> CoilSequence:
        """A CSV file's steps when ``text`` names a file, else :meth:`parse`."""
        return cls.read(text) if Path(text).is_file() else cls.parse(text, key)

    @property
    def fields(self) -> F64:
        """The steps' fields, T, shape (s, 3)."""
        return np.array([s.field for s in self.steps], dtype=np.float64)

    def check(self, sensor: Sensor, key: str = "--coil") -> None:
        """Refuse (one line) a field beyond ``sensor``'s range on its sensing axis (x) or one
        that may flip its element (|B| ≥ flip_field)."""
        for i, b in enumerate(self.fields, 1):
            if abs(b[0]) > sensor.field_range:
                raise v.fail(f"{key} step {i}", field_text(b), f"within the sensor's range "
                             f"(|Bx| ≤ {sensor.field_range * 1e4:g} G on its sensing axis); "
                             "lower that step's field")
            if float(np.linalg.norm(b)) >= sensor.flip_field:
                raise v.fail(f"{key} step {i}", field_text(b), f"below the field that may flip "
                             f"the sensor's element (|B| < {sensor.flip_field * 1e4:g} G); lower "
                             "that step's field")


@dataclass(frozen=True, repr=False)
class CoilPoint(Display):
    """One step of a coil sweep (SI).

    Attributes
    ----------
    field : tuple of float
        The applied field (Bx, By, Bz), T (as recorded).
    mean, sem : float
        The step's reading and its standard error, V (offset-free with set/reset).
    samples : int
        Samples recorded.
    saturated : int
        Samples beyond the sensor's linear range.
    """

    field: tuple[float, float, float]
    mean: float
    sem: float
    samples: int
    saturated: int

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready content (SI)."""
        return {"field_T": list(self.field), "mean_V": self.mean, "sem_V": self.sem,
                "samples": self.samples, "saturated": self.saturated}

    def report(self) -> str:
        """One line: field (G), mean ± s.e. (mV), samples and the saturation flag."""
        flag = f"  SATURATED ({self.saturated} samples beyond range)" if self.saturated else ""
        return (f"{field_text(self.field)}  {self.mean * 1e3:+.5f} ± {self.sem * 1e3:.5f} mV  "
                f"({self.samples} samples){flag}")

    def _display_items(self) -> list[Item]:
        return [("field", field_text(self.field)), ("mean", si(self.mean, "V")),
                ("s.e.", si(self.sem, "V")), ("samples", str(self.samples)),
                ("saturated", str(self.saturated))]


@dataclass(frozen=True, eq=False, repr=False)
class CoilResult(Display):
    """What a coil sweep recorded (immutable): the recording's ``path``, one :class:`CoilPoint`
    per step, the source's counters, whether it completed (else ``stopped``: why and where) and
    the wall time ``elapsed``, s."""

    path: str
    points: tuple[CoilPoint, ...]
    counters: Counters
    complete: bool = True
    stopped: str | None = None
    elapsed: float = 0.0

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready content (SI)."""
        c = self.counters
        return {"path": self.path, "complete": self.complete, "stopped": self.stopped,
                "elapsed_s": self.elapsed, "points": [p.to_dict() for p in self.points],
                "samples": c.samples, "dropped": c.dropped, "corrupt": c.corrupt}

    def report(self) -> str:
        """The steps' readings and a closing line."""
        lines = [p.report() for p in self.points]
        end = "complete" if self.complete else f"stopped: {self.stopped}"
        lines.append(f"{self.path}: {len(self.points)} coil steps, {self.counters.report()}; "
                     f"{end}")
        return "\n".join(lines)

    def _display_items(self) -> list[Item]:
        return [("", count(len(self.points), "coil step")),
                ("complete", "yes" if self.complete else f"no ({self.stopped})"),
                ("elapsed", si(self.elapsed, "s")), ("path", self.path)]


def record_coil(
    source: Source,
    path: str | Path,
    sequence: CoilSequence,
    *,
    driver: CoilDriver | None = None,
    samples: int = 2000,
    settle: float = 0.0,
    sensor: Sensor | None = None,
    metadata: dict[str, Any] | None = None,
    chunk: int | None = None,
    overwrite: bool = True,
    on_point: Callable[[CoilPoint], None] | None = None,
) -> CoilResult:
    """Record a coil calibration sweep into one crash-safe TDMS recording.

    Parameters
    ----------
    source : Source
        Where the samples come from; a :class:`SimulatedCoilSource` applies the fields itself.
    path : str or Path
        The recording (``.tdms``), read by :func:`magcilia.read_measurements`.
    sequence : CoilSequence
        The fields, in order; checked against ``sensor`` before anything runs.
    driver : CoilDriver, optional
        Applies each field on a device (needed unless the source is simulated); written before
        the step's samples and closed at the end.
    samples : int
        Samples per step without a dwell of its own.
    settle : float
        Seconds of samples dropped after each field change (the hair's ringing, the coil's L/R).
    sensor : Sensor, optional
        For the checks and the saturation count (default: the HMC1021Z).
    metadata, chunk, overwrite, on_point
        As :func:`~magcilia.acquire.record_sweep` (``on_point`` gets each :class:`CoilPoint`).

    Returns
    -------
    CoilResult

    Raises
    ------
    MagciliaError
        A field beyond the sensor's range or flip field (nothing runs), or no way to apply the
        fields.
    AcquisitionError
        When the source, the driver or the disk fails: the recording made so far is kept.
    """
    if not isinstance(source, Source):
        raise v.fail("source", type(source).__name__, "a magcilia acquisition Source")
    if not isinstance(sequence, CoilSequence):
        raise v.fail("sequence", type(sequence).__name__, "a CoilSequence")
    simulated = isinstance(source, SimulatedCoilSource)
    if driver is None and not simulated:
        raise v.fail("coil", "no driver for a device source",
                     "a coil output (CLI: --coil-output nidaq:Dev1/ao0,ao1,ao2)")
    samples = v.integer("samples", samples, 2)
    settle = v.non_negative("settle", settle, "s", "duration")
    sensor = sensor or Sensor()
    sequence.check(sensor)
    points: list[CoilPoint] = []
    t0 = time.perf_counter()
    where = "before the first step"
    nptdms_module("Recording to TDMS files")
    try:
        with source:
            piece = chunk_for(source.rate)
            writer = RecordingWriter(path, chunk=chunk or piece, overwrite=overwrite, metadata={
                **source.metadata(), **(metadata or {}), "experiment": "coil",
                "samples_per_step": samples,
                "planned_fields_G": [list(np.asarray(s.field) * 1e4) for s in sequence.steps],
            }).open()
            with writer.keeping(lambda: where):
                for i, step in enumerate(sequence.steps):
                    where = f"at coil step {i + 1} ({field_text(step.field)})"
                    applied = _apply(source, driver, np.asarray(step.field, dtype=np.float64))
                    take = samples if step.dwell is None else max(2, round(step.dwell *
                                                                           source.rate))
                    block, mean, sem, n_read, saturated = record_step(
                        source, writer, take, round(settle * source.rate), piece, where, sensor,
                        functools.partial(_columns, applied))
                    recorded = (block.extra() or {})
                    shown = (tuple(float(np.mean(recorded[c])) for c in ACTUATION_COLUMNS)
                             if ACTUATION_COLUMNS[0] in recorded else tuple(applied.tolist()))
                    point = CoilPoint((shown[0], shown[1], shown[2]), mean, sem, n_read,
                                      saturated)
                    points.append(point)
                    if on_point is not None:
                        on_point(point)
                    where = f"after coil step {i + 1}"
                if driver is not None:
                    _apply(source, driver, np.zeros(3))  # leave the coil off
    finally:
        if driver is not None:
            driver.close()
    writer.close(complete=True)
    return CoilResult(path=str(path), points=tuple(points), counters=source.counters,
                      elapsed=time.perf_counter() - t0)


def _apply(source: Source, driver: CoilDriver | None, field: F64) -> F64:
    """Apply ``field`` (T) with the driver, else the simulated source's coil; the field applied."""
    if driver is not None:
        return np.asarray(driver.set_field(field), dtype=np.float64)
    assert isinstance(source, SimulatedCoilSource)
    source.set_field(field)
    return field


def _columns(applied: F64, block: Block) -> dict[str, Any]:
    """A coil step's columns: the block's extra channels, with the applied field's columns added
    where the source has none."""
    extra = dict(block.extra() or {})
    if ACTUATION_COLUMNS[0] not in extra:
        for name, b in zip(ACTUATION_COLUMNS, applied, strict=True):
            extra[name] = np.full(len(block), float(b))
    return {"extra": extra}
