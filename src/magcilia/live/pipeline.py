"""The streaming read-out: a source's samples in, force, angle or flow speed with σ and flags out.

::

    source ─► reader thread ─► ring buffer ─► read-out thread ─► History ─► views
              (acquire)        (overruns)     average, demodulate,          (terminal, browser),
                                              tare, read-out, record        each with a cursor

The read-out thread takes the samples in chunks of ``batch`` seconds, averages each window of
``factor = source rate / output rate`` samples (:mod:`magcilia.live.windows`, set/reset
demodulated), adds the tare correction (:mod:`magcilia.live.zero`), flags windows in which any raw
sample left the sensor's range, and turns the readings into estimates with
:meth:`Readout.read <magcilia.Readout.read>` (σ from the noise measured at the last tare, else
the larger of the sensor's noise over half the output rate and the spread of the last second's
successive readings, :func:`~magcilia.live.zero.difference_noise`). It appends them to a
:class:`History` that any number of views read at their own pace: a slow or stalled view never
delays acquisition.

**Latency** (sample in -> value out): a sample *arrives* when the source hands over the chunk that
holds it (the reader thread stamps the chunk's wall-clock time), and its value is *out* when the
window's estimate is in the History. That takes the wait for the rest of the read-out chunk
(``batch``, 5 ms by default) plus the processing (≈ 0.1 ms); every sample's
``published − received`` is kept (:attr:`LiveSamples.latency`). Before a sample arrives it has
spent up to one source chunk on the way (``batch`` for the simulation, a frame for a serial
device) and its window up to ``1/rate``; after it, a view's refresh period and drawing add the
rest (the dashboard measures that too).

**Faults**: a source that stops sending or vanishes is closed and reopened every ``reconnect`` s
(the status says so); the samples meanwhile are a gap, the recording stays open and notes the
event; what the views show resumes when the source comes back.
"""

from __future__ import annotations

import contextlib
import datetime as dt
import math
import threading
import time
from dataclasses import dataclass
from pathlib import Path
from types import TracebackType
from typing import Any, Self

import numpy as np
from numpy.typing import NDArray

from magcilia import _validate as v
from magcilia._display import Display, Item, si
from magcilia._errors import AcquisitionError, MagciliaError
from magcilia.acquire.buffer import BackgroundReader
from magcilia.acquire.source import OUTPUT, Block, Counters, Source
from magcilia.device.parameters import MEASURANDS
from magcilia.device.sensor import DEFAULT_BANDWIDTH
from magcilia.io.recording_file import RecordingWriter, chunk_for
from magcilia.io.recordings import beyond_range
from magcilia.io.setup_files import setup_to_dict
from magcilia.live.history import COLUMNS, History, LiveSamples
from magcilia.live.recorded import recorded_clock, replay_finished, replay_metadata, replayed_tare
from magcilia.live.windows import Averager
from magcilia.live.zero import Zero, difference_noise
from magcilia.mechanics import output_at
from magcilia.readout.inverse import Readout, ReadoutFlag

F64 = NDArray[np.float64]

#: event codes stored in a live recording's ``events`` group (channel ``event_code``)
EVENTS = {"start": 0, "tare": 1, "disconnected": 2, "reconnected": 3, "recording": 4}
#: fraction of the last second's readings outside the span above which the status warns
_OUTSIDE_WARNING = 0.9


@dataclass(frozen=True, repr=False)
class Event(Display):
    """Something that happened during a live read-out (immutable).

    Attributes
    ----------
    time : float
        s since the read-out started.
    kind : str
        One of :data:`EVENTS`.
    text : str
        What happened, one line.
    """

    time: float
    kind: str
    text: str

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready content."""
        return {"time_s": self.time, "kind": self.kind, "text": self.text}

    def report(self) -> str:
        """One line."""
        return f"{self.time:8.2f} s  {self.kind}: {self.text}"

    # -- display --------------------------------------------------------------------------------
    def _display_items(self) -> list[Item]:
        return [("", self.kind), ("time", f"{self.time:.6g} s"), ("", self.text)]


@dataclass(frozen=True, repr=False)
class LiveStatus(Display):
    """Where a live read-out stands (immutable; :attr:`LiveReadout.status`).

    Attributes
    ----------
    state : str
        ``"starting"``, ``"running"``, ``"taring"``, ``"disconnected"``, ``"failed"`` or
        ``"stopped"``.
    message : str
        One line for people: the last fault, a hint, or "".
    counters : Counters
        Samples delivered by the source, dropped (by the device and by buffer overruns, summed
        over reconnections) and corrupt frames.
    overruns : int
        Samples the ring buffer overwrote because the read-out fell behind.
    samples : int
        Output samples so far.
    rate : float
        Output samples per second, Hz.
    tared : bool
        Whether a tare was taken.
    correction : float
        Current tare + zero-tracking correction, V.
    drift : float
        Zero tracking's share of it since the last tare, V.
    noise : float
        Noise RMS of one reading used for σ, V: measured at the tare; before one, the larger of
        the sensor model's and the spread of the last second's readings.
    recording : str or None
        The file being recorded.
    latency_median, latency_p99 : float
        Sample in -> value out over the last second, s (NaN before any output).
    """

    state: str
    message: str
    counters: Counters
    overruns: int
    samples: int
    rate: float
    tared: bool
    correction: float
    drift: float
    noise: float
    recording: str | None
    latency_median: float
    latency_p99: float

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready content (SI)."""
        c = self.counters
        return {"state": self.state, "message": self.message, "delivered": c.samples,
                "dropped": c.dropped, "corrupt": c.corrupt, "overruns": self.overruns,
                "samples": self.samples, "rate_Hz": self.rate, "tared": self.tared,
                "correction_V": self.correction, "drift_V": self.drift, "noise_V": self.noise,
                "recording": self.recording, "latency_median_s": self.latency_median,
                "latency_p99_s": self.latency_p99}

    def report(self) -> str:
        """One line."""
        tare = (f"tared (correction {self.correction * 1e3:+.4g} mV, drift "
                f"{self.drift * 1e6:+.3g} µV)" if self.tared else "not tared")
        rec = f", recording {self.recording}" if self.recording else ""
        msg = f" — {self.message}" if self.message else ""
        return (f"{self.state}: {self.samples} samples at {self.rate:g} Hz, {tare}; "
                f"{self.counters.dropped} dropped, {self.overruns} overruns, latency "
                f"{self.latency_median * 1e3:.2g} ms (p99 {self.latency_p99 * 1e3:.2g} ms)"
                f"{rec}{msg}")

    # -- display --------------------------------------------------------------------------------
    def _display_items(self) -> list[Item]:
        items = [("", self.state), ("samples", str(self.samples)), ("rate", f"{self.rate:.4g} Hz"),
                 ("tared", "yes" if self.tared else "no"), ("noise", si(self.noise, "V")),
                 ("dropped", str(self.counters.dropped)), ("overruns", str(self.overruns))]
        if self.message:
            items.append(("message", self.message))
        if self.recording:
            items.append(("recording", self.recording))
        return items


@dataclass(frozen=True, repr=False)
class Limits(Display):
    """What the read-out can measure (immutable; SI, :meth:`LiveReadout.limits`).

    Attributes
    ----------
    quantity, unit : str
    span : (float, float)
        The read-out's span.
    range : (float, float)
        The part of the span inside the sensor's linear range and before any fold.
    minimum : float
        Minimum detectable change at rest: the noise of one reading through the slope there.
    limited_by : str
        What ends the range ("span", "sensor range", "fold").
    scale_note : str
        Where a force's or flow's scale comes from (:meth:`magcilia.Modulus.note`: its σ is in
        every reading's ± σ); "" for an angle.
    """

    quantity: str
    unit: str
    span: tuple[float, float]
    range: tuple[float, float]
    minimum: float
    limited_by: str
    scale_note: str = ""

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready content (SI)."""
        return {"quantity": self.quantity, "unit": self.unit, "span": list(self.span),
                "range": list(self.range), "minimum": self.minimum,
                "limited_by": self.limited_by, "scale_note": self.scale_note}

    def report(self) -> str:
        """One line in display units (and the force scale's note for a force or flow)."""
        q = MEASURANDS[self.quantity]
        lo, hi = (q.to_display(x) for x in self.range)
        note = f"; ± σ includes the {self.scale_note}" if self.scale_note else ""
        return (f"{q.label} range {lo:.4g}…{hi:.4g} {q.display} ({self.limited_by}), minimum "
                f"detectable {q.to_display(self.minimum):.3g} {q.display}{note}")

    # -- display --------------------------------------------------------------------------------
    def _display_items(self) -> list[Item]:
        q = MEASURANDS[self.quantity]
        return [("", self.quantity), ("span", f"{q.text(self.span[0])}…{q.text(self.span[1])}"),
                ("range", f"{q.text(self.range[0])}…{q.text(self.range[1])}"),
                ("minimum", q.text(self.minimum)), ("limited by", self.limited_by)]


class LiveReadout:
    """A streaming read-out of a source (see the module docstring).

    Parameters
    ----------
    source : Source
        Where the samples come from (opened by :meth:`start`, closed by :meth:`stop`).
    readout : Readout
        The inverse read-out (setup, quantity, span, calibration).
    rate : float
        Output samples per second, Hz; each averages ``round(source rate / rate)`` samples
        (the actual output rate is :attr:`rate` after :meth:`start`).
    channel : str
        The source's channel that carries the sensor output.
    history : float
        Seconds of output kept for the views.
    batch : float
        Seconds of samples per chunk read from the source and per processing step (the main
        term of the latency).
    tare_seconds : float
        Seconds of unloaded readings a tare averages.
    tare_at_start : bool
        Tare on the first ``tare_seconds`` (the cilium must be unloaded when it starts).
    tracking : float or None
        Zero-tracking time constant, s (None: off); see :mod:`magcilia.live.zero`.
    band : float
        Zero-tracking band, noise σ.
    demodulate : bool or None
        Demodulate set/reset samples (None: whenever the source marks them).
    stall : float
        Seconds without samples after which the source counts as disconnected.
    reconnect : float
        Seconds between attempts to reopen a disconnected source.
    record : str or Path, optional
        Record into this file from the first sample on (``magcilia live --record``; as
        :meth:`start_recording`), so that the whole run can be replayed
        (:mod:`magcilia.live.replay`).

    Examples
    --------
    >>> import magcilia as mc
    >>> from magcilia.acquire import SimulatedSource
    >>> setup = mc.Setup.paper()
    >>> readout = mc.Readout(setup, "angle", span=(-0.5, 0.5))
    >>> source = SimulatedSource(setup, 0.2, readout_noise=2e-5, rng=0)  # tilted 0.2 rad
    >>> with LiveReadout(source, readout, rate=100) as live:
    ...     samples = live.wait(50)
    >>> len(samples), round(float(np.median(samples.value)), 2)
    (50, 0.2)
    """

    def __init__(self, source: Source, readout: Readout, *, rate: float = 1000.0,
                 channel: str = OUTPUT, history: float = 60.0, batch: float = 0.005,
                 tare_seconds: float = 0.5, tare_at_start: bool = False,
                 tracking: float | None = 30.0, band: float = 3.0,
                 demodulate: bool | None = None, stall: float = 2.0,
                 reconnect: float = 1.0, record: str | Path | None = None) -> None:
        if not isinstance(source, Source):
            raise v.fail("source", type(source).__name__, "a magcilia acquisition Source")
        if not isinstance(readout, Readout):
            raise v.fail("readout", type(readout).__name__, "a magcilia.Readout")
        self.source = source
        self.readout = readout
        self.requested_rate = v.positive("rate", rate, "Hz", "frequency")
        self.channel = str(channel)
        self.history_seconds = v.positive("history", history, "s", "duration")
        self.batch = v.positive("batch", batch, "s", "duration")
        self.tare_seconds = v.positive("tare_seconds", tare_seconds, "s", "duration")
        self.demodulate = demodulate
        self.stall = v.positive("stall", stall, "s", "duration")
        self.reconnect = v.positive("reconnect", reconnect, "s", "duration")
        setup = readout.setup
        flow = readout.flow if readout.quantity == "flow" else None
        rest = float(output_at(setup, readout.quantity, np.zeros(1), flow)[0])
        self.zero = Zero(rest, tracking, band)
        self.factor = 1
        self.rate = self.requested_rate
        self.history = History(readout.quantity, readout.unit, 1)
        self.events: list[Event] = []
        self._tare_wanted = bool(tare_at_start)
        self._tare_readings: list[F64] = []
        self._averager = Averager(1, setup.sensor.offset)
        self._reader: BackgroundReader | None = None
        self._thread: threading.Thread | None = None
        self._stop = threading.Event()
        self._lock = threading.RLock()  # the writer, the events, the status fields
        self._recording_lock = threading.Lock()  # starting and stopping a recording
        self._writer: RecordingWriter | None = None
        self._state = "starting"
        self._message = ""
        self._lost = Counters()  # counters of readers before the current one
        self._lost_overruns = 0
        self._t0 = 0.0
        self._offset: float | None = None
        self._spread = math.nan  # difference_noise of the last second, before a tare
        self._spread_at = -math.inf
        self._record_at_start = None if record is None else Path(record)
        self._tare_started = False  # a tare's first readings are in this block (for replays)
        self._noise_used = math.nan  # the noise σ used for the last block, V

    # -- life cycle -------------------------------------------------------------------------------
    def start(self) -> Self:
        """Open the source, check its channels and rate, and start reading (idempotent).

        Raises
        ------
        AcquisitionError
            If the source cannot be opened (the port does not exist, is busy, no driver).
        MagciliaError
            If the source has no channel ``channel`` or samples slower than the output rate.
        """
        if self._thread is not None:
            return self
        self._t0 = time.monotonic()
        self._connect()
        rate = self.source.rate
        self.factor = max(1, round(rate / self.requested_rate))
        if rate < self.requested_rate * (1 - 1e-9):
            self._disconnect()
            raise v.fail("output rate", f"{self.requested_rate:g} Hz",
                         f"at most the source's sample rate ({rate:g} Hz)")
        self.rate = rate / self.factor
        assert self._reader is not None
        self._reader.chunk = self._chunk()
        self.history = History(self.readout.quantity, self.readout.unit,
                               max(2, round(self.history_seconds * self.rate)))
        self._averager = Averager(self.factor, self.readout.setup.sensor.offset)
        self._event("start", f"{self.source.name} at {rate:g} Hz, read-out at {self.rate:g} Hz "
                    f"({self.factor} samples per reading)")
        self._state = "taring" if self._tare_wanted else "running"
        if self._record_at_start is not None:
            try:
                self.start_recording(self._record_at_start)
            except BaseException:
                self._disconnect()
                raise
        self._thread = threading.Thread(target=self._run, name="magcilia-live", daemon=True)
        self._thread.start()
        return self

    def stop(self) -> None:
        """Stop reading, close a recording (complete) and the source (idempotent)."""
        self._stop.set()
        reader = self._reader
        if reader is not None:
            reader.buffer.close()  # wakes a read waiting for samples
        if self._thread is not None and self._thread.ident is not None:  # (started)
            self._thread.join()
        self.stop_recording()
        self._disconnect()
        if self._state != "failed":
            self._state = "stopped"

    def __enter__(self) -> Self:
        return self.start()

    def __exit__(self, exc_type: type[BaseException] | None, exc: BaseException | None,
                 tb: TracebackType | None) -> None:
        self.stop()

    @property
    def running(self) -> bool:
        """Whether the read-out thread is alive."""
        return self._thread is not None and self._thread.is_alive()

    # -- what views use -------------------------------------------------------------------------
    def tare(self, wait: float | None = None) -> bool:
        """Take the next ``tare_seconds`` of readings as the unloaded zero (the cilium must be
        unloaded meanwhile). Returns at once, or with ``wait`` s, waits for the tare; whether
        it is done."""
        with self._lock:
            self._tare_wanted = True
            self._tare_readings = []
            if self._state == "running":
                self._state = "taring"
        if wait is None:
            return False
        deadline = time.monotonic() + wait
        while time.monotonic() < deadline and self._tare_wanted and self.running:
            time.sleep(0.01)
        return not self._tare_wanted

    def wait(self, count: int, timeout: float = 10.0) -> LiveSamples:
        """Wait for the next ``count`` output samples and return them.

        Raises
        ------
        AcquisitionError
            If they did not come within ``timeout`` s (the status's message says why).
        """
        count = v.integer("count", count, 1)
        cursor = self.history.total
        deadline = time.monotonic() + timeout
        while self.history.total < cursor + count:
            left = deadline - time.monotonic()
            if left <= 0 or not self.running:
                raise AcquisitionError(f"{self.source.name}: {self.history.total - cursor} of "
                                       f"{count} read-out samples in {timeout:g} s "
                                       f"({self.status.report()})")
            self.history.wait(cursor + count - 1, min(left, 0.1))
        return LiveSamples(**_first(self.history.since(cursor)[0], count))

    @property
    def status(self) -> LiveStatus:
        """Where the read-out stands now."""
        recent = self.history.last(1.0, self.rate) if self.history.total else None
        lat = recent.latency if recent is not None else np.zeros(0)
        lat = lat[np.isfinite(lat)]
        message = self._message
        if recent is not None and not message and len(recent) and np.mean(
                recent.flags & ReadoutFlag.OUTSIDE_SPAN > 0) > _OUTSIDE_WARNING:
            message = ("readings lie outside the read-out's output range: tare with the cilium "
                       "unloaded, or check that the setup matches this sensor")
        reader = self._reader
        c = reader.counters if reader is not None else Counters()
        overruns = self._lost_overruns + (reader.overruns if reader is not None else 0)
        noise = self.noise
        with self._lock:
            recording = str(self._writer.path) if self._writer is not None else None
        return LiveStatus(
            state=self._state, message=message,
            counters=Counters(self._lost.samples + c.samples, self._lost.dropped + c.dropped,
                              self._lost.corrupt + c.corrupt),
            overruns=overruns, samples=self.history.total, rate=self.rate,
            tared=self.zero.tared_at is not None, correction=self.zero.correction,
            drift=self.zero.drift, noise=noise, recording=recording,
            latency_median=float(np.median(lat)) if lat.size else math.nan,
            latency_p99=float(np.quantile(lat, 0.99)) if lat.size else math.nan)

    def limits(self) -> Limits:
        """The span, the usable range within it and the minimum detectable change at rest."""
        r = self.readout
        table = r.table
        sensor = r.setup.sensor
        ok = sensor.in_range(sensor.field(table.output))
        q = table.quantity
        limited = "fold" if r.fold is not None else "span"
        if not ok.all():
            limited = "sensor range"
        inside = q[ok] if ok.any() else q[:1]
        rest_slope = abs(float(np.interp(self.zero.rest, table.volts, table.slope)))
        return Limits(r.quantity, r.unit, r.span, (float(inside.min()), float(inside.max())),
                      self.noise * rest_slope, limited, r.scale_note)

    @property
    def noise(self) -> float:
        """Noise RMS of one reading that σ uses, V (see :attr:`LiveStatus.noise`)."""
        if self.zero.noise is not None:
            return self.zero.noise
        model = self.readout.setup.sensor.output_noise_rms(*self._bandwidth())
        return max(model, self._spread) if math.isfinite(self._spread) else model

    def _bandwidth(self) -> tuple[float, float]:
        return DEFAULT_BANDWIDTH[0], max(self.rate / 2.0, DEFAULT_BANDWIDTH[0] * 2.0)

    # -- recording ------------------------------------------------------------------------------
    def start_recording(self, path: str | Path | None = None,
                        directory: str | Path = ".") -> Path:
        """Record the raw samples, the read-out values and the events into a crash-safe TDMS
        file (as ``magcilia record`` writes); returns its path.

        Parameters
        ----------
        path : str or Path, optional
            The file (``.tdms``; replaced if it exists); default ``live-YYYYmmdd-HHMMSS.tdms``
            in ``directory``, with ``-2``, ``-3`` … added when that file exists.
        directory : str or Path
            Where a default-named file goes.
        """
        with self._recording_lock:  # one start or stop at a time; each file its own name
            reserved = path is None
            if path is None:
                path = _new_recording_path(Path(directory))
            r = self.readout
            metadata = {**self.source.metadata(), "live": True, "readout": r.to_dict(),
                        "setup": setup_to_dict(r.setup), "output_rate_Hz": self.rate,
                        "factor": self.factor, "event_codes": EVENTS,
                        "tare_correction_V": self.zero.correction,
                        **replay_metadata(self)}
            writer = RecordingWriter(path, metadata=metadata, reserved=reserved,
                                     chunk=chunk_for(self.source.rate))
            try:
                writer.open()
            except BaseException:
                if reserved and Path(path).is_file() and Path(path).stat().st_size == 0:
                    Path(path).unlink(missing_ok=True)  # the name reserved, never written
                raise
            with self._lock:
                if self._writer is not None:  # the one open is closed, and says so
                    self._event("recording", f"stopped {self._writer.path}")
                self._close_writer(complete=True)
                self._writer = writer
                self._event("recording", f"started {writer.path}")
            return writer.path

    def stop_recording(self) -> Path | None:
        """Close the recording (complete); returns its path (None if none was open)."""
        with self._recording_lock, self._lock:
            if self._writer is None:
                return None
            path = self._writer.path
            self._event("recording", f"stopped {path}")
            self._close_writer(complete=True)
            return path

    @property
    def recording(self) -> Path | None:
        """The file being recorded (None: none is open)."""
        with self._lock:
            return self._writer.path if self._writer is not None else None

    def _close_writer(self, complete: bool, stopped: str | None = None) -> None:
        writer, self._writer = self._writer, None
        if writer is not None:
            try:
                writer.close(complete=complete, stopped=stopped)
            except MagciliaError as exc:
                self._message = str(exc)

    # -- the thread -----------------------------------------------------------------------------
    def _chunk(self) -> int:
        """Samples per read: whole windows, about ``batch`` seconds of them."""
        return self.factor * max(1, round(self.batch * self.source.rate / self.factor))

    def _connect(self) -> None:
        self.source.open()  # first: a serial device tells its rate when it opens
        reader = BackgroundReader(self.source, seconds=10.0, stall=self.stall)
        try:
            reader.start()
        except BaseException:
            with contextlib.suppress(Exception):
                reader.stop()
            raise
        names = [c.name for c in self.source.channels]
        if self.channel not in names:
            with contextlib.suppress(Exception):
                reader.stop()
            raise v.fail("channel", self.channel, f"a channel of {self.source.name} (it has "
                         f"{', '.join(names)}; choose one with --channel)")
        reader.chunk = self._chunk()  # the rate is known once the source is open
        self._reader = reader
        self._offset = None

    def _disconnect(self) -> None:
        reader, self._reader = self._reader, None
        if reader is not None:
            c = reader.counters
            self._lost = Counters(self._lost.samples + c.samples, self._lost.dropped + c.dropped,
                                  self._lost.corrupt + c.corrupt)
            self._lost_overruns += reader.overruns
            with contextlib.suppress(Exception):
                reader.stop()

    def _run(self) -> None:
        try:
            while not self._stop.is_set():
                if self._reader is None and not self._try_reconnect():
                    continue
                assert self._reader is not None
                try:
                    block = self._reader.read(self._reader.chunk)
                except (MagciliaError, OSError) as exc:
                    if replay_finished(self.source):  # a replayed recording has ended
                        self._message = f"replay of {self.source.name} finished"
                        break
                    if not self._stop.is_set():
                        self._disconnected(str(exc))
                    continue
                self._process(block)
        except Exception as exc:  # noqa: BLE001 - a failure the views must show
            self._state = "failed"
            self._message = f"read-out stopped ({type(exc).__name__}: {exc})"
            with self._lock:
                self._close_writer(complete=False, stopped=self._message)

    def _disconnected(self, why: str) -> None:
        self._disconnect()
        self._state = "disconnected"
        self._message = f"{why}; retrying every {self.reconnect:g} s"
        self._event("disconnected", why)

    def _try_reconnect(self) -> bool:
        if self._stop.wait(self.reconnect):
            return False
        try:
            self._connect()
        except (MagciliaError, OSError) as exc:
            self._message = f"{exc}; retrying every {self.reconnect:g} s"
            return False
        self._averager.reset()
        self._state = "taring" if self._tare_wanted else "running"
        self._message = ""
        self._event("reconnected", f"{self.source.name} is back")
        return True

    def _process(self, block: Block) -> None:
        if self._offset is None:  # the read-out's clock continues across reconnections
            self._offset = (0.0 if recorded_clock(self.source) else
                            (time.monotonic() - self._t0) - float(block.time[-1]))
        if replayed_tare(self.source, block):  # where the recorded run's tare began
            self.tare()
        t = block.time + self._offset
        raw = block[self.channel]
        sensor = self.readout.setup.sensor
        sr = block.setreset if self.demodulate is not False else None
        if self.demodulate and sr is None:
            raise MagciliaError(f"{self.source.name} does not mark set/reset samples; "
                                "demodulation needs them")
        w = self._averager.push(t, raw, beyond_range(raw, sensor), sr)
        zero = self.zero
        with self._lock:  # a tare asked for from now on begins with the next block
            collecting = self._tare_wanted
            self._tare_started = collecting and not self._tare_readings
        if collecting:
            self._collect_tare(w.volts, float(w.time[-1]))
        if zero.noise is None and t[-1] - self._spread_at >= 0.25 and self.history.total:
            self._spread = difference_noise(self.history.last(1.0, self.rate).raw)
            self._spread_at = float(t[-1])
        self._noise_used = zero.total_noise(self.noise)  # with the zero's σ (and recorded)
        correction = zero.correction  # the one this block is read with (tracking moves it)
        result = self.readout.read(w.volts + correction, noise=self._noise_used)
        flags = result.flags | np.where(w.beyond, np.uint16(ReadoutFlag.SATURATED), np.uint16(0))
        bad = np.where(flags != 0, np.nan, 1.0)
        flags = flags | np.uint16(zero.flags)  # warnings (TARE_UNDER_LOAD, ZERO_DRIFT): kept
        if not (collecting and self._tare_wanted):
            zero.track(w.volts, 1.0 / self.rate, at=float(w.time[-1]))
        now = time.time()
        received = block.received if block.received is not None else now
        columns = np.array([w.time, w.volts, result.value * bad, result.sigma * bad, flags,
                            np.full(w.time.size, correction), np.full(w.time.size, received),
                            np.full(w.time.size, now)])
        self.history.append(columns)
        with self._lock:
            if self._writer is not None:
                self._record(block, t, dict(zip(COLUMNS, columns, strict=True)))

    def _collect_tare(self, volts: F64, at: float) -> None:
        if not self._tare_wanted:
            return
        with self._lock:
            self._tare_readings.append(volts)
            have = sum(x.size for x in self._tare_readings)
            if have < max(2, round(self.tare_seconds * self.rate)):
                return
            readings = np.concatenate(self._tare_readings)
            self._tare_readings = []
            try:
                taken = self.zero.tare(readings, at, dt=1.0 / self.rate)
            except MagciliaError as exc:
                self._message = str(exc)
                return
            self._tare_wanted = False
            if self._state == "taring":
                self._state = "running"
            self._message = self.zero.notice  # refused, or under load: the views say why
            if not taken:
                self._event("tare", self.zero.notice)
                return
            self._event("tare", f"zero at {readings.mean() * 1e3:.6g} mV (correction "
                        f"{self.zero.correction * 1e3:+.4g} mV, noise "
                        f"{(self.zero.noise or 0.0) * 1e6:.3g} µV per reading)"
                        + (" — NOT AT REST" if self.zero.under_load else ""))

    def _record(self, block: Block, t: F64, out: dict[str, F64]) -> None:
        """Write the block's samples and read-out values (the lock is held)."""
        assert self._writer is not None
        try:
            if self._tare_started:  # where a replay re-takes this tare
                self._writer.write_group("tares", {"tare_sample": [self._writer.written]})
            self._writer.write(t, block[self.channel], setreset=block.setreset,
                               extra={k: x for k, x in (block.extra() or {}).items()
                                      if k != self.channel} or None)
            self._writer.write_group("readout", {
                "readout_time_s": out["time"], "raw_V": out["raw"], "value": out["value"],
                "sigma": out["sigma"], "flags": out["flags"], "correction_V": out["correction"],
                "noise_V": np.full(out["time"].size, self._noise_used),
            }, units={"readout_time_s": "s", "raw_V": "V", "value": self.readout.unit,
                      "sigma": self.readout.unit, "correction_V": "V", "noise_V": "V"})
        except MagciliaError as exc:
            path = self._writer.path
            kept = self._writer.abort(f"stopped: {exc}")
            self._writer = None
            self._message = (f"recording stopped ({exc})" + (f"; kept in {path}" if kept
                                                             else ""))

    def _event(self, kind: str, text: str) -> None:
        """Note an event (and record it); the lock is taken here."""
        with self._lock:
            now = time.monotonic() - self._t0
            self.events.append(Event(now, kind, text))
            if self._writer is not None:
                try:
                    self._writer.write_group("events", {"event_time_s": [now],
                                                        "event_code": [EVENTS[kind]]},
                                             units={"event_time_s": "s"})
                except MagciliaError as exc:
                    self._message = str(exc)


def _new_recording_path(directory: Path) -> Path:
    """``live-YYYYmmdd-HHMMSS.tdms`` in ``directory``, made unique with ``-2``, ``-3`` …, and
    reserved: created empty at once (exclusively), so that no other recording takes the name."""
    directory.mkdir(parents=True, exist_ok=True)
    base = directory / f"live-{dt.datetime.now().strftime('%Y%m%d-%H%M%S')}"
    path, k = base.with_suffix(".tdms"), 2
    while True:
        try:
            path.open("xb").close()
        except FileExistsError:
            path, k = Path(f"{base}-{k}.tdms"), k + 1
        else:
            return path


def _first(samples: LiveSamples, count: int) -> dict[str, Any]:
    """The fields of the first ``count`` samples."""
    out: dict[str, Any] = {"quantity": samples.quantity, "unit": samples.unit}
    out.update({name: getattr(samples, name)[:count] for name in COLUMNS})
    return out
