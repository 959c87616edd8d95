"""Background acquisition: a reader thread fills a bounded ring buffer, so that a slow consumer
never stalls the device.

When the consumer falls behind a real-time source, the oldest unread samples are overwritten and
counted as *overruns* (never silently): :attr:`BackgroundReader.counters` reports them with the
source's own drops. A source that is not paced by a clock (a simulation run as fast as it goes)
instead waits for room, since nothing is lost by waiting.

The buffer is sized when the reader starts, from the rate and channels the source then reports
(a serial device announces them in its first frame), and never takes more than
:data:`MAX_BUFFER_BYTES` of memory, whatever a device announces.
"""

from __future__ import annotations

import math
import threading
import time
from types import TracebackType
from typing import Self

import numpy as np

from magcilia import _validate as v
from magcilia._errors import AcquisitionError
from magcilia.acquire.source import Block, Channel, Counters, Source

#: most memory a background reader's ring buffer takes, bytes (its length in seconds shrinks at
#: rates and channel counts that would need more)
MAX_BUFFER_BYTES = 256 * 2**20
#: reads of a paced source per second of samples when no chunk is given (how soon the consumer
#: sees samples and the thread notices a stop)
READS_PER_SECOND = 50.0


def buffer_capacity(seconds: float, rate: float, channels: int) -> int:
    """Samples a ring buffer of ``seconds`` at ``rate`` (Hz) holds, within
    :data:`MAX_BUFFER_BYTES` for ``channels`` channels (at least 2)."""
    per_sample = 8 * channels + 25  # data, time, first index, received time, set/reset
    cap = max(2, MAX_BUFFER_BYTES // per_sample)
    want = seconds * rate if math.isfinite(rate) and rate > 0.0 else 2.0
    return int(max(2, min(cap, math.ceil(want))))


class RingBuffer:
    """A bounded first-in first-out buffer of samples, safe between one writer and one reader.

    Parameters
    ----------
    channels : int
        Channels per sample.
    capacity : int
        Samples it holds; writing more than there is room for overwrites the oldest (counted in
        :attr:`overruns`) unless ``overwrite`` is False, in which case the writer waits.
    overwrite : bool
        Whether a full buffer overwrites (real-time sources) or makes the writer wait.
    """

    def __init__(self, channels: int, capacity: int, overwrite: bool = True) -> None:
        self.capacity = v.integer("capacity", capacity, 1)
        self.overwrite = overwrite
        self._time = np.zeros(self.capacity)
        self._data = np.zeros((v.integer("channels", channels, 1), self.capacity))
        self._sr = np.zeros(self.capacity, dtype=np.int8)
        self._first = np.zeros(self.capacity, dtype=np.int64)
        self._received = np.zeros(self.capacity)  # wall time each sample was written
        self._start = 0  # index of the oldest unread sample
        self._size = 0
        self._has_sr = True
        self.overruns = 0
        self._lock = threading.Condition()
        self._closed = False

    def __len__(self) -> int:
        return self._size

    def write(self, block: Block) -> None:
        """Append a block's samples (waits for room only when ``overwrite`` is False); each is
        stamped with the block's ``received`` time, or the wall-clock time now. After
        :meth:`close` nobody reads: a block is dropped, not counted as overruns."""
        received = time.time() if block.received is None else block.received
        n = len(block)
        if self._closed:
            return
        if n > self.capacity:  # keep the newest that fit
            lost = n - self.capacity
            with self._lock:
                self.overruns += lost
            block = Block(block.time[lost:], block.data[:, lost:], block.channels,
                          block.first + lost,
                          None if block.setreset is None else block.setreset[lost:])
            n = self.capacity
        with self._lock:
            if not self.overwrite:
                while self.capacity - self._size < n and not self._closed:
                    self._lock.wait(0.1)
            if self._closed:
                return
            free = self.capacity - self._size
            if n > free:  # overwrite the oldest
                lost = n - free
                self.overruns += lost
                self._start = (self._start + lost) % self.capacity
                self._size -= lost
            idx = (self._start + self._size + np.arange(n)) % self.capacity
            self._time[idx] = block.time
            self._data[:, idx] = block.data
            self._first[idx] = block.first + np.arange(n)
            self._received[idx] = received
            if block.setreset is None:
                self._has_sr = False
            else:
                self._sr[idx] = block.setreset
            self._size += n
            self._lock.notify_all()

    def read(self, n: int, timeout: float | None,
             channels: tuple[Channel, ...]) -> Block | None:
        """The oldest ``n`` unread samples as a Block (``received``: when its last sample was
        written), or None if they did not come within ``timeout`` s (None: wait for ever) or the
        buffer was closed."""
        deadline = None if timeout is None else time.monotonic() + timeout
        with self._lock:
            while self._size < n:
                if self._closed:
                    return None
                remaining = None if deadline is None else deadline - time.monotonic()
                if remaining is not None and remaining <= 0.0:
                    return None
                self._lock.wait(remaining if remaining is not None else 0.1)
            idx = (self._start + np.arange(n)) % self.capacity
            block = Block(time=self._time[idx].copy(), data=self._data[:, idx].copy(),
                          channels=channels, first=int(self._first[idx[0]]),
                          setreset=self._sr[idx].copy() if self._has_sr else None,
                          received=float(self._received[idx[-1]]))
            self._start = (self._start + n) % self.capacity
            self._size -= n
            self._lock.notify_all()
            return block

    def clear(self) -> int:
        """Drop every unread sample (not counted as overruns); returns how many."""
        with self._lock:
            dropped, self._size = self._size, 0
            self._lock.notify_all()
            return dropped

    def close(self) -> None:
        """Wake every waiting reader and writer; later reads return what is left, then None."""
        with self._lock:
            self._closed = True
            self._lock.notify_all()


class BackgroundReader:
    """Reads a source on a thread into a :class:`RingBuffer`; the consumer reads the buffer.

    Parameters
    ----------
    source : Source
        Opened when the reader starts, closed when it stops.
    seconds : float
        Buffer length, s of samples at the source's rate (at most :data:`MAX_BUFFER_BYTES`).
    chunk : int, optional
        Samples per read of the source (default: 1/50 s of samples at the rate the source has
        once open, at least 1).
    stall : float
        Seconds :meth:`read` waits for samples before raising (a device that stopped sending).

    Examples
    --------
    >>> import magcilia as mc
    >>> from magcilia.acquire import SimulatedSource
    >>> with BackgroundReader(SimulatedSource(mc.Setup.paper(), rng=0)) as reader:
    ...     block = reader.read(500)
    >>> len(block)
    500
    """

    def __init__(self, source: Source, seconds: float = 10.0, chunk: int | None = None,
                 stall: float = 5.0) -> None:
        if not isinstance(source, Source):
            raise v.fail("source", type(source).__name__, "a magcilia acquisition Source")
        self.source = source
        self.seconds = v.positive("seconds", seconds, "s", "duration")
        self._given_chunk = None if chunk is None else v.integer("chunk", chunk, 1)
        self.stall = v.positive("stall", stall, "s", "duration")
        self.chunk = 1
        self.buffer = self._size()
        self._thread: threading.Thread | None = None
        self._stop = threading.Event()
        self._error: Exception | None = None

    def _size(self) -> RingBuffer:
        """A ring buffer (and the chunk) for the source's rate and channels as they are now."""
        rate = float(self.source.rate)
        channels = len(self.source.channels)
        auto = max(1, round(rate / READS_PER_SECOND)) if math.isfinite(rate) and rate > 0 else 1
        capacity = buffer_capacity(self.seconds, rate, channels)
        self.chunk = min(self._given_chunk or auto, max(1, capacity // 2))
        capacity = max(capacity, 2 * self.chunk)
        return RingBuffer(channels, capacity, overwrite=self.source.realtime)

    # -- life cycle -------------------------------------------------------------------------------
    def start(self) -> Self:
        """Open the source, size the buffer for the rate and channels it reports, and start the
        reader thread (idempotent)."""
        if self._thread is None:
            self.source.open()
            self.buffer = self._size()
            self._thread = threading.Thread(target=self._run, name="magcilia-reader",
                                            daemon=True)
            self._thread.start()
        return self

    def stop(self) -> None:
        """Stop the thread and close the source (idempotent). A thread stuck in a source's read
        for longer than ``stall`` s (at least 1 s) is left to end when the source closes under
        it."""
        self._stop.set()
        self.buffer.close()
        if self._thread is not None:
            self._thread.join(timeout=max(1.0, self.stall))
        self.source.close()

    def __enter__(self) -> Self:
        return self.start()

    def __exit__(self, exc_type: type[BaseException] | None, exc: BaseException | None,
                 tb: TracebackType | None) -> None:
        self.stop()

    def _run(self) -> None:
        try:
            while not self._stop.is_set():
                self.buffer.write(self.source.read(self.chunk))
        except Exception as exc:  # noqa: BLE001 - handed to the consumer on its next read
            self._error = exc
            self.buffer.close()

    # -- the consumer's side ----------------------------------------------------------------------
    def read(self, n: int) -> Block:
        """The next ``n`` samples per channel, in order.

        Raises
        ------
        AcquisitionError
            If the reader thread failed (its error, one line) or no samples came for
            ``stall`` seconds.
        """
        n = v.integer("n", n, 1)
        if self._thread is None:
            self.start()
        if n > self.buffer.capacity:
            raise v.fail("samples per read", n, f"at most the buffer's {self.buffer.capacity} "
                         "samples")
        block = self.buffer.read(n, self.stall + n / self.source.rate, self.source.channels)
        if block is not None:
            return block
        if self._error is not None:
            if isinstance(self._error, AcquisitionError):
                raise AcquisitionError(str(self._error)) from None
            raise AcquisitionError(f"{self.source.name}: acquisition stopped "
                                   f"({type(self._error).__name__}: {self._error})") from None
        raise AcquisitionError(f"{self.source.name}: no samples for {self.stall:g} s; the device "
                               "stopped sending (check the cable and its power)")

    def clear(self) -> int:
        """Drop the samples read so far but not consumed (before a fresh measurement)."""
        return self.buffer.clear()

    @property
    def counters(self) -> Counters:
        """The source's counters with this reader's overruns added to ``dropped``."""
        c = self.source.counters
        return c + Counters(0, self.buffer.overruns)

    @property
    def overruns(self) -> int:
        """Samples the buffer overwrote before the consumer read them."""
        return self.buffer.overruns

