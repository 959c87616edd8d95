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
from magcilia.acquire.buffer import BackgroundReader
from magcilia.acquire.source import OUTPUT, Counters, Source
from magcilia.io.recording_file import RecordingWriter


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
                "overruns": self.overruns, "dropped": c.dropped, "corrupt": c.corrupt}

    def report(self) -> str:
        """One line."""
        return (f"{self.path}: {self.samples} samples in {self.elapsed:.3g} s "
                f"({self.rate:.4g} samples/s), {self.overruns} overruns, "
                f"{self.counters.dropped} dropped, {self.counters.corrupt} corrupt frames")

    # -- display --------------------------------------------------------------------------------
    def _display_items(self) -> list[Item]:
        return [("samples", str(self.samples)), ("elapsed", si(self.elapsed, "s")),
                ("dropped", str(self.counters.dropped)), ("overruns", str(self.overruns)),
                ("path", self.path)]


def record_stream(source: Source, path: str | Path, seconds: float, *,
                  metadata: dict[str, Any] | None = None, chunk: int = 65536,
                  buffer_seconds: float = 10.0) -> StreamResult:
    """Record ``seconds`` of the source's samples into a crash-safe TDMS recording.

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
    chunk : int
        Samples per read of the buffer and per flushed chunk of the file.
    buffer_seconds : float
        Ring buffer length, s.

    Raises
    ------
    AcquisitionError
        When the source or the disk fails; the recording so far is kept.
    """
    seconds = v.positive("seconds", seconds, "s", "duration")
    total = max(1, round(seconds * source.rate))
    writer = RecordingWriter(path, chunk=chunk, metadata={**source.metadata(), **(metadata or {})})
    reader = BackgroundReader(source, seconds=buffer_seconds, chunk=min(chunk, total))
    written = 0
    t0 = time.perf_counter()
    with writer.keeping(lambda: f"after {written} of {total} samples"), reader:
        writer.open()
        while written < total:
            block = reader.read(min(chunk, total - written))
            writer.write(block.time, block[OUTPUT], setreset=block.setreset,
                         extra=block.extra())
            written += len(block)
    elapsed = time.perf_counter() - t0
    writer.close(complete=True)
    return StreamResult(str(path), written, reader.counters, reader.overruns, elapsed)
