"""The guided calibration sweep (the paper's Sec. IV.A): tilt, record, repeat; one recording that
``magcilia calibrate`` reads as it is.

For each angle the sweep takes the tilt (from a list, or asked of the user: typed in degrees or
measured on a photo), drops what the device sent meanwhile (and ``settle`` seconds more, while the
hair stops ringing), records ``samples`` samples into the
recording (:class:`~magcilia.io.recording_file.RecordingWriter`, crash-safe) with the angle of
each sample, and reports the angle's reading (mean ± standard error, the offset-free set/reset
difference when the source alternates them) and how many samples were beyond the sensor's range.
If anything fails on the way, the recording made so far is kept, closed with a note saying where
it stopped.
"""

from __future__ import annotations

import functools
import math
import time
from collections.abc import Callable, Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import ArrayLike

from magcilia import _validate as v
from magcilia._display import Display, Item, Table, count, dataframe, rows_table, si
from magcilia.acquire.simulated import SimulatedSource
from magcilia.acquire.source import OUTPUT, Block, Counters, Source
from magcilia.device.sensor import Sensor
from magcilia.io.recording_file import RecordingWriter, chunk_for
from magcilia.io.recordings import beyond_range, nptdms_module, reading

#: asked for each new angle (0, 1, …): the tilt in rad, or None to end the sweep
AskAngle = Callable[[int], float | None]


@dataclass(frozen=True, repr=False)
class SweepPoint(Display):
    """One angle of a sweep (SI).

    Attributes
    ----------
    angle : float
        Tilt, rad.
    mean, sem : float
        The angle's reading and its standard error, V (offset-free with set/reset).
    samples : int
        Samples recorded.
    saturated : int
        Samples beyond the sensor's linear range.
    """

    angle: float
    mean: float
    sem: float
    samples: int
    saturated: int

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready content (SI)."""
        return {"angle_rad": self.angle, "mean_V": self.mean, "sem_V": self.sem,
                "samples": self.samples, "saturated": self.saturated}

    def report(self) -> str:
        """One line: angle (deg), mean ± s.e. (mV), samples and the saturation flag."""
        flag = f"  SATURATED ({self.saturated} samples beyond range)" if self.saturated else ""
        return (f"{math.degrees(self.angle):8.3f} deg  {self.mean * 1e3:+.5f} ± "
                f"{self.sem * 1e3:.5f} mV  ({self.samples} samples){flag}")

    # -- display --------------------------------------------------------------------------------
    def _display_items(self) -> list[Item]:
        return [("angle", f"{math.degrees(self.angle):.4g} deg"), ("mean", si(self.mean, "V")),
                ("s.e.", si(self.sem, "V")), ("samples", str(self.samples)),
                ("saturated", str(self.saturated))]


@dataclass(frozen=True, eq=False, repr=False)
class SweepResult(Display):
    """What a sweep recorded (immutable).

    Attributes
    ----------
    path : str
        The recording.
    points : tuple of SweepPoint
        One per angle recorded.
    counters : Counters
        The source's delivered, dropped and corrupt counts at the end.
    complete : bool
        Whether the sweep ended as planned.
    stopped : str or None
        Why and where it stopped early.
    elapsed : float
        Wall time, s.
    """

    path: str
    points: tuple[SweepPoint, ...]
    counters: Counters
    complete: bool = True
    stopped: str | None = None
    elapsed: float = 0.0

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready content (SI)."""
        c = self.counters
        return {"path": self.path, "complete": self.complete, "stopped": self.stopped,
                "elapsed_s": self.elapsed, "points": [p.to_dict() for p in self.points],
                "samples": c.samples, "dropped": c.dropped, "corrupt": c.corrupt,
                "unverified": c.unverified}

    def report(self) -> str:
        """The angles' readings and a closing line."""
        lines = [p.report() for p in self.points]
        end = "complete" if self.complete else f"stopped: {self.stopped}"
        lines.append(f"{self.path}: {len(self.points)} angles, {self.counters.report()}; {end}")
        return "\n".join(lines)

    # -- display --------------------------------------------------------------------------------
    def _display_items(self) -> list[Item]:
        return [("", count(len(self.points), "angle")),
                ("complete", "yes" if self.complete else f"no ({self.stopped})"),
                ("elapsed", si(self.elapsed, "s")), ("dropped", str(self.counters.dropped)),
                ("path", self.path)]

    def _display_table(self) -> Table | None:
        return rows_table(self.to_dataframe().to_dict("records"))

    def to_dataframe(self) -> Any:
        """One row per angle as a ``pandas.DataFrame``, SI: ``angle_rad``, ``output_V`` (mean),
        ``sem_V``, ``samples``, ``saturated``."""
        p = self.points
        return dataframe({"angle_rad": [x.angle for x in p], "output_V": [x.mean for x in p],
                          "sem_V": [x.sem for x in p], "samples": [x.samples for x in p],
                          "saturated": [x.saturated for x in p]})


def record_sweep(
    source: Source,
    path: str | Path,
    *,
    angles: ArrayLike | None = None,
    ask: AskAngle | None = None,
    samples: int = 2000,
    settle: float = 0.0,
    sensor: Sensor | None = None,
    metadata: dict[str, Any] | None = None,
    chunk: int | None = None,
    overwrite: bool = True,
    on_point: Callable[[SweepPoint], None] | None = None,
) -> SweepResult:
    """Record a calibration sweep into one crash-safe TDMS recording.

    Parameters
    ----------
    source : Source
        Where the samples come from; a :class:`SimulatedSource` with an angle script is tilted to
        each angle by the sweep itself.
    path : str or Path
        The recording (``.tdms``), read by :func:`magcilia.read_measurements`.
    angles : array-like, shape (a,), optional
        Tilt angles, rad, in the order they are visited.
    ask : callable, optional
        Instead of ``angles``: called with the angle's number, returns its tilt in rad (typed or
        measured on a photo) or None to end the sweep.
    samples : int
        Samples recorded per angle (the paper: 2000 at 1 kHz).
    settle : float
        Seconds of samples dropped after each tilt before recording (the hair's ringing, and
        frames already on their way from the device), s.
    sensor : Sensor, optional
        For the saturation count (default: the HMC1021Z at the paper's settings).
    metadata : dict, optional
        More to store in the recording (the setup, the sensor…), added to the source's.
    chunk : int, optional
        Most samples per flushed chunk of the file (default: half a second of samples,
        :func:`~magcilia.io.recording_file.chunk_for`); the file is flushed at least every half
        second as well, and each angle's samples reach it in pieces of that size, so a crash
        loses at most about a second of samples.
    overwrite : bool
        Replace an existing ``path`` (once the new recording holds its first chunk; a source that
        fails to open leaves it as it was); False refuses it.
    on_point : callable, optional
        Called with each angle's :class:`SweepPoint` as soon as it is recorded.

    Returns
    -------
    SweepResult

    Raises
    ------
    AcquisitionError
        When the source or the disk fails: the message says where the sweep stopped; the
        recording made so far is kept (with no sample recorded, no file is left and an existing
        one is untouched).
    """
    if not isinstance(source, Source):
        raise v.fail("source", type(source).__name__, "a magcilia acquisition Source")
    if (angles is None) == (ask is None):
        raise v.fail("sweep", "both or neither of angles and ask",
                     "given a list of angles or a function that asks for them")
    samples = v.integer("samples", samples, 2)
    given_chunk = None if chunk is None else v.integer("chunk", chunk, 1)
    settle = v.non_negative("settle", settle, "s", "duration")
    sensor = sensor or Sensor()
    planned = None if angles is None else [
        float(a) for a in v.finite_array("angles", angles, ndim=1, unit="rad")]
    tilt = source.set_value if (isinstance(source, SimulatedSource)
                                and source.script.quantity == "angle") else None
    points: list[SweepPoint] = []
    t0 = time.perf_counter()
    where = "before the first angle"
    nptdms_module("Recording to TDMS files")  # imported before the source starts delivering
    with source:  # opened first: a serial device announces its rate, and a failure leaves no file
        piece = chunk_for(source.rate)
        settle_samples = round(settle * source.rate)
        writer = RecordingWriter(path, chunk=given_chunk or piece, overwrite=overwrite, metadata={
            **source.metadata(), **(metadata or {}), "samples_per_angle": samples,
            "planned_angles_deg": None if planned is None else [
                math.degrees(a) for a in planned]}).open()
        with writer.keeping(lambda: where):
            for i, angle in enumerate(_angles(planned, ask)):
                where = f"at angle {i + 1} ({math.degrees(angle):.4g} deg)"
                if tilt is not None:
                    tilt(angle)
                _, mean, sem, count, saturated = record_step(
                    source, writer, samples, settle_samples, piece, where, sensor,
                    functools.partial(_angle_columns, math.degrees(angle)))
                point = SweepPoint(angle, mean, sem, count, saturated)
                points.append(point)
                if on_point is not None:
                    on_point(point)
                where = f"after angle {i + 1}"
    writer.close(complete=True)
    return SweepResult(path=str(path), points=tuple(points), counters=source.counters,
                       elapsed=time.perf_counter() - t0)


def record_step(source: Source, writer: RecordingWriter, take: int, settle: int, piece: int,
                where: str, sensor: Sensor, columns: Callable[[Block], dict[str, Any]]
                ) -> tuple[Block, float, float, int, int]:
    """One step of a sweep (an angle, a coil field): drop what was received and ``settle``
    samples, record ``take`` samples in reads of at most ``piece`` (each read reaches the file at
    once, with the step's ``columns(block)`` as ``RecordingWriter.write`` keywords), and return
    the step's samples, its reading (mean, s.e. in V, samples used; offset-free with set/reset)
    and how many samples lie beyond ``sensor``'s range."""
    source.discard()
    for n in _pieces(settle, piece):
        source.read(n)
    blocks = []
    for n in _pieces(take, piece):
        block = source.read(n)
        writer.write(block.time, block[OUTPUT], setreset=block.setreset, **columns(block))
        blocks.append(block)
    block = Block.concatenate(blocks)
    volts = block[OUTPUT]
    mean, sem, count = reading(volts, block.setreset, where)
    return block, mean, sem, count, int(beyond_range(volts, sensor).sum())


def _angle_columns(deg: float, block: Block) -> dict[str, Any]:
    """A tilt step's columns: the angle (deg) of every sample, the source's extra channels."""
    return {"angle_deg": np.full(len(block), deg), "extra": block.extra()}


def _pieces(total: int, piece: int) -> Iterator[int]:
    """Sizes of the reads that make ``total`` samples, at most ``piece`` each."""
    while total > 0:
        yield min(piece, total)
        total -= piece


def _angles(planned: list[float] | None, ask: AskAngle | None) -> Iterator[float]:
    if planned is not None:
        yield from planned
        return
    assert ask is not None
    i = 0
    while (angle := ask(i)) is not None:
        yield v.real("angle", angle, "rad")
        i += 1
