"""The streaming read-out: a source's samples in, force, angle or flow speed — or force vectors of a
3-axis sensor or an array — with σ and flags out.

::

    source ─► reader thread ─► ring buffer ─► read-out thread ─► History ─► views
              (acquire)        (overruns)     average, demodulate,          (terminal, browser),
                                              tare, read-out, record        each with a cursor

The read-out thread takes the samples of the channels the read-out names (its ``inputs``: the
output, or every part's ``NAME.x``, ``.y``, ``.z``) in chunks of ``batch`` seconds (an output
with a temperature brought to the reference temperature first: :mod:`magcilia.live.thermal`),
averages each window of ``factor = source rate / output rate`` samples per channel (set/reset
demodulated), adds the tare and zero-tracking correction (:mod:`magcilia.live.zero`), flags
windows in which any raw sample left its channel's range, and reads the chunk with one call of
the read-out's ``read(samples, noise=)``: the noise
measured at the tare (else the larger of the model's and the last second's spread) with the
zero's σ added; every estimate carries the zero's TARE_UNDER_LOAD and ZERO_DRIFT. It appends
them — a number, a force vector (2,) or one per cilium (C, 2) per reading — to a
:class:`History` that views read at their own pace: a stalled view never delays acquisition.

**Latency** (sample in -> value out): from the reader thread's wall-clock stamp of the chunk
that holds a sample to its window's estimate in the History: the wait for the rest of the
read-out chunk (``batch``, 5 ms by default) plus the processing (≈ 0.1 ms for one output, ≈ 2 ms
per window for a 16-cilium array's inverse, ``benchmarks/bench_live_vectors.py``); kept per
sample (:attr:`LiveSamples.latency`). Upstream a sample spends up to one source chunk and its
window up to ``1/rate``; downstream a view's refresh and drawing add the rest.

**Faults**: a source that stops or vanishes is reopened every ``reconnect`` s (the status says
so); the samples meanwhile are a gap the recording notes, and the views resume with the source.
"""

from __future__ import annotations

import contextlib
import math
import threading
import time
from pathlib import Path
from typing import Any, Self

import numpy as np
from numpy.typing import NDArray

from magcilia import _validate as v
from magcilia._errors import AcquisitionError, MagciliaError
from magcilia.acquire.buffer import BackgroundReader
from magcilia.acquire.source import OUTPUT, Block, Counters, Source
from magcilia.io.recording_file import RecordingWriter, chunk_for
from magcilia.live.history import NO_ESTIMATE, History, LiveSamples
from magcilia.live.readouts import LiveSensor, live_sensor
from magcilia.live.recorded import (
    recorded_clock,
    recording_metadata,
    replay_finished,
    replayed_tare,
)
from magcilia.live.recording import new_recording_path, readout_group, sample_columns
from magcilia.live.status import EVENTS, Event, Limits, LiveStatus, tare_text
from magcilia.live.thermal import WARNING_FLAGS
from magcilia.live.windows import Averager
from magcilia.live.zero import Zero
from magcilia.readout.protocol import FLAG_DTYPE, Flag
from magcilia.readout.tare import difference_noise

F64 = NDArray[np.float64]

__all__ = ["EVENTS", "Event", "Limits", "LiveReadout", "LiveStatus"]

#: fraction of the last second's readings outside the span above which the status warns
_OUTSIDE_WARNING = 0.9


class LiveReadout:
    """A streaming read-out of a source (see the module docstring).

    Parameters
    ----------
    source : Source
        Where the samples come from (opened by :meth:`start`, closed by :meth:`stop`).
    readout : SensorReadout
        Any read-out that follows :class:`~magcilia.readout.protocol.SensorReadout`: the
        single-axis :class:`~magcilia.Readout` (setup, quantity, span, calibration; one value per
        sample), the force vector of a 3-axis sensor (:class:`~magcilia.BiaxialReadout`: (Fx, Fy)
        per sample) or every cilium's force vector of an array (:class:`~magcilia.ArrayReadout`:
        (C, 2) per sample). It reads the source's channels named by its ``inputs``
        (:func:`~magcilia.live.readouts.live_sensor`).
    rate : float
        Output samples per second, Hz; each averages ``round(source rate / rate)`` samples
        (the actual output rate is :attr:`rate` after :meth:`start`).
    channel : str
        The source's channel that carries the sensor output (a single-axis read-out; the others
        read the channels their ``inputs`` name).
    history : float
        Seconds of output kept for the views.
    batch : float
        Seconds of samples per chunk read from the source and per processing step (the main
        term of the latency).
    tare_seconds : float
        Seconds of unloaded readings a tare averages.
    tare_at_start : bool
        Tare on the first ``tare_seconds`` (the cilium must be unloaded when it starts). Force
        vectors are not estimated before that first tare (flag OUTSIDE_SPAN): their readings
        still hold the Earth's field and the parts' offsets.
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
        :meth:`start_recording`), for :mod:`magcilia.live.replay`.
    recalibration : LiveRecalibration, optional
        Coil-pulse re-calibration (:mod:`magcilia.live.recalibrating`; pulses flagged COIL_PULSE).

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

    def __init__(self, source: Source, readout: Any, *, rate: float = 1000.0,
                 channel: str = OUTPUT, history: float = 60.0, batch: float = 0.005,
                 tare_seconds: float = 0.5, tare_at_start: bool = False,
                 tracking: float | None = 30.0, band: float = 3.0,
                 demodulate: bool | None = None, stall: float = 2.0,
                 reconnect: float = 1.0, record: str | Path | None = None,
                 recalibration: Any = None) -> None:
        if not isinstance(source, Source):
            raise v.fail("source", type(source).__name__, "a magcilia acquisition Source")
        self.sensor: LiveSensor = live_sensor(readout)
        self.source, self.readout, self.recalibration = source, readout, recalibration
        self.requested_rate = v.positive("rate", rate, "Hz", "frequency")
        self.channel = str(channel)
        self.history_seconds = v.positive("history", history, "s", "duration")
        self.batch = v.positive("batch", batch, "s", "duration")
        self.tare_seconds = v.positive("tare_seconds", tare_seconds, "s", "duration")
        self.demodulate = demodulate
        self.stall = v.positive("stall", stall, "s", "duration")
        self.reconnect = v.positive("reconnect", reconnect, "s", "duration")
        sensor = self.sensor
        scalar = sensor.kind == "scalar"
        #: the source channels read, in the read-out's order
        self.inputs = (self.channel, *sensor.inputs[1:]) if scalar else sensor.inputs
        self.zero = Zero(float(sensor.rest[0]) if scalar else sensor.rest, tracking, band,
                         unit=sensor.channel_unit, names=() if scalar else sensor.inputs)
        self.factor = 1
        self.rate = self.requested_rate
        self.history = self._new_history(1)
        self.events: list[Event] = []
        self._tare_wanted = bool(tare_at_start)
        self._tare_readings: list[F64] = []
        self._averager = self._new_averager(1)
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
        self._spread: Any = math.nan  # difference_noise of the last second, before a tare
        self._spread_at = -math.inf
        self._limits: tuple[bytes, Limits] | None = None
        self._record_at_start = None if record is None else Path(record)
        self._tare_started = False  # a tare's first readings are in this block (for replays)
        self._noise_used: Any = math.nan  # the noise σ used for the last block, channel units

    def _new_history(self, capacity: int) -> History:
        s = self.sensor
        c = () if s.kind == "scalar" else (s.channels,)
        return History(s.quantity, s.unit, capacity, {
            "value": s.value_shape, "sigma": s.value_shape, "flags": s.flags_shape, "raw": c,
            "correction": c}, s.names)

    def _new_averager(self, factor: int) -> Averager:
        offset = self.sensor.offset
        return Averager(factor, float(offset[0]) if self.sensor.kind == "scalar" else offset)

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
        self.history = self._new_history(max(2, round(self.history_seconds * self.rate)))
        self._averager = self._new_averager(self.factor)
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

    def __exit__(self, *exc: object) -> None:
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
        return self.history.since(cursor)[0].first(count)

    @property
    def status(self) -> LiveStatus:
        """Where the read-out stands now."""
        recent = self.history.last(1.0, self.rate) if self.history.total else None
        lat = recent.latency if recent is not None else np.zeros(0)
        lat = lat[np.isfinite(lat)]
        message = self._message
        untared = self.sensor.kind != "scalar" and self.zero.tared_at is None  # (no estimates)
        if recent is not None and not message and not untared and len(recent) and np.mean(
                recent.flags & FLAG_DTYPE(Flag.OUTSIDE_SPAN) > 0) > _OUTSIDE_WARNING:
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
            counters=self._lost + c,
            overruns=overruns, samples=self.history.total, rate=self.rate,
            tared=self.zero.tared_at is not None, correction=self.zero.correction,
            drift=self.zero.drift, noise=noise, recording=recording,
            latency_median=float(np.median(lat)) if lat.size else math.nan,
            latency_p99=float(np.quantile(lat, 0.99)) if lat.size else math.nan,
            unit=self.sensor.channel_unit,
            recalibration=self.recalibration.text() if self.recalibration else "",
            temperature=self.sensor.temperature_text())

    def limits(self) -> Limits:
        """The span, the usable range within it and the minimum detectable change at rest (kept
        while the noise it is computed with stays the same)."""
        noise = np.atleast_1d(np.asarray(self.noise, dtype=np.float64))
        kept = self._limits
        if kept is None or kept[0] != noise.tobytes():
            kept = self._limits = (noise.tobytes(), self.sensor.limits(noise))
        return kept[1]

    @property
    def noise(self) -> Any:
        """Noise RMS of one reading that σ uses (see :attr:`LiveStatus.noise`): V, a float, for
        a single-axis read-out; per channel (c,) in their unit for the others."""
        return self.zero.noise if self.zero.noise is not None else self._rest_noise()

    def _rest_noise(self) -> Any:
        return self.sensor.rest_noise(self.rate, self.factor, self._spread)

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
            path = new_recording_path(Path(directory)) if path is None else path
            writer = RecordingWriter(path, metadata=recording_metadata(self), reserved=reserved,
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
        missing = [name for name in self.inputs if name not in names]
        if missing:
            with contextlib.suppress(Exception):
                reader.stop()
            if missing == [self.channel]:
                raise v.fail("channel", self.channel, f"a channel of {self.source.name} (it "
                             f"has {', '.join(names)}; choose one with --channel)")
            raise v.fail("source", self.source.name, f"a source of the read-out's channels "
                         f"({', '.join(missing[:3])}{' …' if len(missing) > 3 else ''} are "
                         f"missing; it has {', '.join(names[:6])})")
        reader.chunk = self._chunk()  # the rate is known once the source is open
        self._reader = reader
        self._offset = None

    def _disconnect(self) -> None:
        reader, self._reader = self._reader, None
        if reader is not None:
            c = reader.counters
            self._lost += c
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
        raw = recorded = self.sensor.samples(block, self.channel)
        raw, pulsed = self.recalibration.process(block, raw) if self.recalibration else (raw, None)
        sr = block.setreset if self.demodulate is not False else None
        if self.demodulate and sr is None:
            raise MagciliaError(f"{self.source.name} does not mark set/reset samples; "
                                "demodulation needs them")
        beyond = self.sensor.beyond(raw.reshape(raw.shape[0], -1))
        w = self._averager.push(t, self.sensor.compensate(block, raw, self.zero), beyond, sr)
        zero = self.zero
        with self._lock:  # a tare asked for from now on begins with the next block
            collecting = self._tare_wanted
            self._tare_started = collecting and not self._tare_readings
        if collecting:
            self._collect_tare(w.volts, float(w.time[-1]))
        untared = zero.noise is None or zero.under_load  # (the spread is σ's, or the rest's)
        if untared and t[-1] - self._spread_at >= 0.25 and self.history.total:
            self._spread = difference_noise(self.history.last(1.0, self.rate).raw)
            self._spread_at = float(t[-1])
        self._noise_used = zero.total_noise(self.noise)  # with the zero's σ (and recorded)
        correction = zero.correction  # the one this block is read with (tracking moves it)
        readings = w.volts + correction  # (m,) for one output, (m, c) for several
        if self.sensor.kind != "scalar" and zero.tared_at is None and self._tare_wanted:
            value, sigma, flags = self.sensor.no_estimates(w.time.size)  # the tare's baseline
        else:
            result = self.sensor.view.read(readings, noise=self._noise_used)
            value, sigma = np.asarray(result.value), np.asarray(result.sigma)
            flags = np.asarray(result.flags, dtype=FLAG_DTYPE)
        if pulsed is not None:  # a coil pulse's readings: COIL_PULSE, no value; the rest scaled
            value, flags = self.recalibration.flag(value, flags, pulsed, self.factor)
        saturated = np.where(w.beyond, FLAG_DTYPE(Flag.SATURATED), FLAG_DTYPE(0))
        flags = flags | saturated.reshape(-1, *(1 for _ in flags.shape[1:]))
        if self.sensor.kind == "scalar":  # any flag but a warning: no value (as always shown)
            bad = np.where(flags & ~WARNING_FLAGS != 0, np.nan, 1.0)
        else:  # a vector near zero or ambiguous in direction keeps its components
            bad = np.where(flags & FLAG_DTYPE(NO_ESTIMATE) != 0, np.nan, 1.0)[..., None]
        flags = flags | self.sensor.zero_flags(zero.channel_flags)  # TARE_UNDER_LOAD, ZERO_DRIFT
        if not (collecting and self._tare_wanted):
            zero.track(w.volts, 1.0 / self.rate, at=float(w.time[-1]))
        now = time.time()
        received = block.received if block.received is not None else now
        m = w.time.size
        columns: dict[str, Any] = {
            "time": w.time, "raw": w.volts, "value": value * bad, "sigma": sigma * bad,
            "flags": flags, "correction": np.broadcast_to(correction, w.volts.shape),
            "received": np.full(m, received), "published": np.full(m, now)}
        self.history.append(columns)
        with self._lock:
            if self._writer is not None:
                self._record(block, t, recorded, columns)

    def _collect_tare(self, volts: F64, at: float) -> None:
        with self._lock:
            self._tare_readings.append(volts)
            have = sum(x.shape[0] for x in self._tare_readings)
            if have < max(2, round(self.tare_seconds * self.rate)):
                return
            readings = np.concatenate(self._tare_readings)
            self._tare_readings = []
            try:
                z = self.zero  # the rest check's noise: a tare's at rest, else the model's
                taken = z.tare(readings, at, dt=1.0 / self.rate, expected_noise=(
                    z.noise if z.noise is not None and not z.under_load else self._rest_noise()))
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
            self._event("tare", tare_text(self.zero, readings))

    def _record(self, block: Block, t: F64, raw: F64, out: dict[str, Any]) -> None:
        """Write the block's samples and read-out values (the lock is held)."""
        assert self._writer is not None
        s = self.sensor
        try:
            if self._tare_started:  # where a replay re-takes this tare
                self._writer.write_group("tares", {"tare_sample": [self._writer.written]})
            if s.kind == "scalar":
                self._writer.write(t, raw, setreset=block.setreset,
                                   extra={k: x for k, x in (block.extra() or {}).items()
                                          if k != self.channel} or None)
            else:
                self._writer.write(t, None, setreset=block.setreset,
                                   extra=sample_columns(self.inputs, raw))
            columns, units = readout_group(out, unit=s.unit, channel_unit=s.channel_unit,
                                           inputs=self.inputs, names=s.names,
                                           noise=self._noise_used)
            self._writer.write_group("readout", columns, units=units)
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
