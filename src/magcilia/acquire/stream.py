"""Continuous recording: a reader thread fills the ring buffer, this thread writes the file.

The device never waits for the disk: when the writer falls behind, the ring buffer overwrites the
oldest samples and counts them (overruns), and the count is reported and stored in the file.
"""

from __future__ import annotations

import time
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from magcilia import _validate as v
from magcilia._display import Display, Item, si
from magcilia.acquire.buffer import READS_PER_SECOND, BackgroundReader
from magcilia.acquire.source import OUTPUT, Counters, Source
from magcilia.io.recording_file import RecordingWriter, chunk_for
from magcilia.io.recordings import nptdms_module

#: samples per read of a source that is not paced (a simulation run as fast as it goes: larger
#: reads cost less per sample, and nobody waits for them); a paced one is read 1/50 s at a time
#: (:data:`~magcilia.acquire.buffer.READS_PER_SECOND`)
UNPACED_CHUNK = 4096


@dataclass(frozen=True, repr=False)
class StreamResult(Display):
    """What a continuous recording wrote (immutable).

    Attributes
    ----------
    path : str
        The recording.
    samples : int
        Samples per channel written.
    counters : Counters
        Delivered, dropped (the device's and the buffer's overruns) and corrupt counts.
    overruns : int
        Samples the ring buffer overwrote because the writer fell behind.
    elapsed : float
        Wall time, s.
    """

    path: str
    samples: int
    counters: Counters
    overruns: int
    elapsed: float

    @property
    def rate(self) -> float:
        """Samples written per second of wall time."""
        return self.samples / self.elapsed if self.elapsed > 0 else 0.0

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready content (SI)."""
        c = self.counters
        return {"path": self.path, "samples": self.samples, "elapsed_s": self.elapsed,
                "overruns": self.overruns, "dropped": c.dropped, "corrupt": c.corrupt,
                "unverified": c.unverified}

    def report(self) -> str:
        """One line."""
        return (f"{self.path}: {self.samples} samples in {self.elapsed:.3g} s "
                f"({self.rate:.4g} samples/s), {self.overruns} overruns, "
                f"{self.counters.dropped} dropped, {self.counters.corrupt} corrupt frames"
                + (f", {self.counters.unverified} unverified (no checksum)"
                   if self.counters.unverified else ""))

    # -- display --------------------------------------------------------------------------------
    def _display_items(self) -> list[Item]:
        return [("samples", str(self.samples)), ("elapsed", si(self.elapsed, "s")),
                ("dropped", str(self.counters.dropped)), ("overruns", str(self.overruns)),
                ("path", self.path)]


def record_stream(source: Source, path: str | Path, seconds: float, *,
                  metadata: dict[str, Any] | None = None, chunk: int | None = None,
                  buffer_seconds: float = 10.0, stall: float = 5.0,
                  overwrite: bool = True) -> StreamResult:
    """Record ``seconds`` of the source's samples into a crash-safe TDMS recording.

    The source is opened first (a serial device announces its rate in its first frame: the
    number of samples is ``seconds`` times that rate); the recording is created only once it
    delivers, so a source that fails to open leaves no file and an existing one as it was. The
    consumer takes the samples from the ring buffer in pieces of about
    :data:`~magcilia.io.recording_file.FLUSH_SECONDS` s and the file flushes them at least that
    often: a crash loses at most about a second of samples.

    Parameters
    ----------
    source : Source
        Where the samples come from (opened and closed here).
    path : str or Path
        The recording (``.tdms``).
    seconds : float
        Duration, s of samples at the source's rate.
    metadata : dict, optional
        More to store in the recording, added to the source's.
    chunk : int, optional
        Most samples per flushed chunk of the file (default: half a second of samples,
        :func:`~magcilia.io.recording_file.chunk_for`).
    buffer_seconds : float
        Ring buffer length, s.
    stall : float
        Seconds without samples after which the source counts as stopped, s (the recording
        then ends, kept, saying where).
    overwrite : bool
        Replace an existing ``path`` (once the new recording holds its first chunk); False
        refuses it.

    Raises
    ------
    AcquisitionError
        When the source or the disk fails; the recording so far is kept and says where it
        stopped (with no sample recorded, no file is left and an existing one is untouched).
    """
    seconds = v.positive("seconds", seconds, "s", "duration")
    given_chunk = None if chunk is None else v.integer("chunk", chunk, 1)
    nptdms_module("Recording to TDMS files")  # imported before the source starts delivering
    unpaced = None if source.realtime else max(UNPACED_CHUNK,
                                               round(float(source.rate) / READS_PER_SECOND))
    reader = BackgroundReader(source, seconds=buffer_seconds, chunk=unpaced, stall=stall)
    written = 0
    total = 0
    t0 = time.perf_counter()
    with reader:  # opens the source: a failure here leaves no file
        rate = float(source.rate)
        total = max(1, round(seconds * rate))
        step = min(chunk_for(rate), reader.buffer.capacity // 2 or 1)
        writer = RecordingWriter(path, chunk=given_chunk or chunk_for(rate),
                                 metadata={**source.metadata(), **(metadata or {}),
                                           "planned_samples": total},
                                 overwrite=overwrite).open()
        with writer.keeping(lambda: f"after {written} of {total} samples"):
            while written < total:
                block = reader.read(min(step, total - written))
                writer.write(block.time, block[OUTPUT], setreset=block.setreset,
                             extra=block.extra())
                written += len(block)
    writer.close(complete=True)
    elapsed = time.perf_counter() - t0
    return StreamResult(str(path), written, reader.counters, reader.overruns, elapsed)
