"""A device on a pseudo-terminal: the serial protocol, end to end, without hardware.

:class:`DeviceEmulator` opens a pseudo-terminal pair (POSIX), whose slave side is a serial port
that :class:`~magcilia.acquire.serial.SerialSource` (or any terminal program) opens like a USB
device, and a thread that writes frames of the :mod:`.protocol` to it, with samples taken from any
:class:`~magcilia.acquire.source.Source` (usually a
:class:`~magcilia.acquire.simulated.SimulatedSource`), converted to int32 ADC counts. It paces
the frames at the source's rate or sends them as fast as the reader takes them.

It speaks magcilia's framed protocol (``format="magcilia"``) or one of the formats without a
checksum that labs' firmware sends (:mod:`.serial_formats`): ``"ascii"`` (comma-separated text
lines of the values in V, after an optional header line) or ``"floats"`` (bare little-endian
float32 values per sample, ending in ``\r\n``, as ReSkin/AnySkin boards send).

It injects the faults a real link has, deterministically through ``rng``: damaged frames (bytes
flipped inside them), bursts of garbage between frames, a stall, and an unplugged cable. It
remembers which frames it damaged (:attr:`DeviceEmulator.damaged`) so that tests can check the
reader's counts exactly.
"""

from __future__ import annotations

import contextlib
import itertools
import os
import select
import threading
import time
import tty
from types import TracebackType
from typing import Self

import numpy as np

from magcilia import _validate as v
from magcilia._errors import AcquisitionError
from magcilia.acquire.protocol import DELIMITER, _encode, _flags
from magcilia.acquire.serial_formats import FLOAT_END, FORMATS
from magcilia.acquire.source import Source

#: the default ADC step: a 24-bit converter over ±2.048 V (ADS1220, internal reference, gain 1), V
VOLTS_PER_COUNT = 2.048 / 2**23
#: frames taken from the source at once
_FRAMES_PER_READ = 8
#: longest single wait of the writer thread, s (how fast it notices stop, stall and unplug)
_TICK = 0.02


class DeviceEmulator:
    """A magcilia device on a pseudo-terminal (see the module docstring).

    The emulator opens ``source`` when it starts and closes it when it stops. The thread starts
    with :meth:`start` or the ``with`` statement; the port exists from construction until
    :meth:`close` or :meth:`unplug`.

    Parameters
    ----------
    source : Source
        Where the samples come from (all its channels are sent; values in V).
    samples_per_frame : int
        Samples per channel in a frame (frames also end where the set/reset state changes).
    volts_per_count : float
        The ADC step, V per count (counts are rounded and clipped to int32).
    realtime : bool
        Pace the frames at the source's rate (a frame leaves when its last sample is taken);
        False writes as fast as the reader takes them.
    corrupt : float
        Probability that a frame is damaged: 1 to 3 of its bytes are changed (never to 0x00, so
        the damage stays inside the frame).
    garbage : float
        Probability that a burst of random bytes (any values, 0x00 included) precedes a frame;
        a burst that does not end in 0x00 runs into the frame and damages it.
    garbage_size : int
        Longest burst, bytes (each is 1 to ``garbage_size`` bytes long).
    rate : float, optional
        The sample rate the frames announce, Hz (default: the source's, which paces them); any
        finite value, even outside the protocol's limits, to play a faulty device.
    first : int
        Index of the first sample sent (as if the device had been running; tests of the
        2**32 wrap-around start just below it).
    sequence : int
        Sequence number of the first frame.
    rng : int, Generator or None
        Randomness of the faults; an int repeats them exactly.
    format : {"magcilia", "ascii", "floats"}
        What goes on the wire: frames of the protocol, text lines (``%.9g`` V, comma-separated,
        ``\r\n``), or float32 frames ending in ``\r\n``. A "frame" of the faults is then a
        block of ``samples_per_frame`` lines or float frames.
    header : str, optional
        ``ascii``: a header line sent first (e.g. ``"output[mV]"``: the names and units a reader
        learns; the values are sent in V whatever it says).

    Attributes
    ----------
    port : str
        The serial port to open (the pseudo-terminal's slave, e.g. ``/dev/pts/3``).
    frames : int
        Frames written so far.
    samples : int
        Samples per channel written so far.
    damaged : list of (int, int)
        (first sample index, samples) of every frame sent damaged (flipped, or run into by
        garbage), in order.
    junk : list of int
        For every piece of garbage that forms a corrupt frame of its own (ends in 0x00), the index
        of the first sample of the frame sent after it.
    error : BaseException or None
        What stopped the writer thread, if anything but :meth:`close` or :meth:`unplug`.

    Examples
    --------
    >>> import magcilia as mc
    >>> from magcilia.acquire.emulator import DeviceEmulator
    >>> from magcilia.acquire.serial import SerialSource
    >>> from magcilia.acquire.simulated import SimulatedSource
    >>> with DeviceEmulator(SimulatedSource(mc.Setup.paper(), 0.3, rng=0)) as device:
    ...     with SerialSource(device.port) as source:
    ...         block = source.read(100)
    >>> block.data.shape
    (1, 100)
    """

    def __init__(self, source: Source, *, samples_per_frame: int = 32,
                 volts_per_count: float = VOLTS_PER_COUNT, realtime: bool = True,
                 corrupt: float = 0.0, garbage: float = 0.0, garbage_size: int = 64,
                 rate: float | None = None, first: int = 0, sequence: int = 0,
                 rng: int | np.random.Generator | None = None, format: str = "magcilia",
                 header: str | None = None) -> None:
        if not isinstance(source, Source):
            raise v.fail("source", type(source).__name__, "a magcilia Source")
        if format not in FORMATS:
            raise v.fail("format", format, "one of " + ", ".join(FORMATS))
        if header is not None and format != "ascii":
            raise v.fail("header", header, "given with format='ascii' only")
        self.format = format
        self._header = None if header is None else header.encode("ascii") + b"\r\n"
        self.source = source
        self.samples_per_frame = v.integer("samples_per_frame", samples_per_frame, 1)
        self.volts_per_count = v.positive("volts_per_count", volts_per_count, "V", "step")
        self.realtime = bool(realtime)
        self.corrupt = self._probability("corrupt", corrupt)
        self.garbage = self._probability("garbage", garbage)
        self.garbage_size = v.integer("garbage_size", garbage_size, 1)
        self.rate = None if rate is None else v.real("rate", rate, "Hz")
        self._index = v.integer("first", first, 0)
        self._sequence = v.integer("sequence", sequence, 0)
        self._gen = np.random.default_rng(rng)
        self.frames = 0
        self.samples = 0
        self.damaged: list[tuple[int, int]] = []
        self.junk: list[int] = []
        self.error: BaseException | None = None
        self._stop = threading.Event()
        self._lock = threading.Lock()
        self._stall_until = 0.0
        self._thread: threading.Thread | None = None
        self._master, self._slave = os.openpty()
        tty.setraw(self._slave)
        os.set_blocking(self._master, False)
        self.port = os.ttyname(self._slave)
        self._closed = False

    @staticmethod
    def _probability(name: str, value: float) -> float:
        p = v.non_negative(name, value, "", "probability")
        if p > 1.0:
            raise v.fail(name, value, "a probability in [0, 1]")
        return p

    # -- life cycle ------------------------------------------------------------------------------
    def start(self) -> Self:
        """Start writing frames (idempotent); returns the emulator."""
        if self._closed:
            raise AcquisitionError(f"device emulator on {self.port} is closed")
        if self._thread is None:
            self.source.open()
            self._thread = threading.Thread(target=self._run, name=f"emulator {self.port}",
                                            daemon=True)
            self._thread.start()
        return self

    def close(self) -> None:
        """Stop the thread, close the source and the pseudo-terminal (idempotent; the port
        vanishes). Raises what stopped the thread, if it failed."""
        if self._closed:
            return
        self._shutdown()
        if self.error is not None:
            raise self.error

    def unplug(self) -> None:
        """Pull the cable: stop sending and close the pseudo-terminal; a reader's next read of
        the port fails."""
        self._shutdown()

    def stall(self, duration: float) -> None:
        """Send nothing for ``duration`` seconds from now (then carry on where it stopped), s."""
        duration = v.non_negative("duration", duration, "s", "time")
        with self._lock:
            self._stall_until = time.monotonic() + duration

    def __enter__(self) -> Self:
        return self.start()

    def __exit__(self, exc_type: type[BaseException] | None, exc: BaseException | None,
                 tb: TracebackType | None) -> None:
        self.close()

    def _shutdown(self) -> None:
        self._stop.set()
        if self._thread is not None:
            self._thread.join()
        if not self._closed:
            self._closed = True
            for fd in (self._master, self._slave):
                with contextlib.suppress(OSError):  # already gone
                    os.close(fd)
            self.source.close()

    # -- the writer thread -----------------------------------------------------------------------
    def _run(self) -> None:
        try:
            self._loop()
        except BaseException as exc:  # noqa: BLE001 - reported through `error` and close()
            self.error = exc

    def _loop(self) -> None:
        rate = float(self.source.rate)
        paced_from: tuple[float, int] | None = None  # (monotonic s, sample index) of the pace
        while not self._stop.is_set():
            block = self.source.read(self.samples_per_frame * _FRAMES_PER_READ)
            if self.format == "magcilia":
                counts = np.clip(np.rint(block.data.T / self.volts_per_count), -2**31,
                                 2**31 - 1).astype("<i4")
            else:
                counts = block.data.T
            for start, stop, sr in self._frames_of(len(block), block.setreset):
                if self._sit_out_stall():
                    paced_from = None
                if paced_from is None:
                    paced_from = (time.monotonic(), self._index)
                if self.realtime and not self._wait_until(
                        paced_from[0] + (self._index + stop - start - paced_from[1]) / rate):
                    return
                if not self._write_all(self._wire(counts[start:stop], sr)):
                    return

    def _sit_out_stall(self) -> bool:
        """Wait while a stall is on (or until stopped); whether there was one."""
        stalled = False
        while not self._stop.is_set():
            with self._lock:
                left = self._stall_until - time.monotonic()
            if left <= 0.0:
                break
            stalled = True
            self._stop.wait(min(left, _TICK))
        return stalled

    def _frames_of(self, n: int, setreset: np.ndarray | None) -> list[tuple[int, int, int]]:
        """(start, stop, set/reset) of the frames a block of ``n`` samples makes."""
        edges = set(range(0, n, self.samples_per_frame))
        if setreset is not None:
            edges |= {int(i) for i in np.flatnonzero(np.diff(setreset)) + 1}
        cuts = [*sorted(edges), n]
        return [(a, b, 0 if setreset is None else int(setreset[a]))
                for a, b in itertools.pairwise(cuts)]

    def _unverified(self, values: np.ndarray) -> bytes:
        """Samples (n, c) in V as text lines or float32 frames; the header before the first."""
        if self.format == "ascii":
            text = "".join(",".join(f"{x:.9g}" for x in row) + "\r\n" for row in values)
            header, self._header = self._header, None
            return (header or b"") + text.encode("ascii")
        packed = np.ascontiguousarray(values, dtype="<f4")
        return b"".join(row.tobytes() + FLOAT_END for row in packed)

    def _wire(self, counts: np.ndarray, setreset: int) -> bytes:
        """One frame's bytes on the wire, faults included."""
        n, c = counts.shape
        rate = float(self.source.rate) if self.rate is None else self.rate
        if self.format != "magcilia":
            frame = self._unverified(counts)
        else:
            frame = _encode(counts.tobytes(), n, c, self._sequence, self._index,
                            _flags(setreset), rate, self.volts_per_count)
        gen = self._gen
        damaged = False
        if self.corrupt and gen.random() < self.corrupt:
            frame = self._flip(frame)
            damaged = True
        if self.garbage and gen.random() < self.garbage:
            junk = gen.integers(0, 256, int(gen.integers(1, self.garbage_size + 1)),
                                dtype=np.uint8).tobytes()
            *alone, last = junk.split(DELIMITER)
            self.junk.extend([self._index] * sum(1 for a in alone if a))
            damaged |= bool(last)
            frame = junk + frame
        if damaged:
            self.damaged.append((self._index, n))
        self._index += n
        self._sequence += 1
        self.frames += 1
        self.samples += n
        return frame

    def _flip(self, frame: bytes) -> bytes:
        """The frame with 1 to 3 of its bytes (not the delimiter) changed, never to 0x00."""
        out = bytearray(frame)
        gen = self._gen
        for pos in gen.choice(len(out) - 1, size=int(gen.integers(1, 4)), replace=False):
            new = out[pos]
            while new in (0, out[pos]):
                new = int(gen.integers(1, 256))
            out[pos] = new
        return bytes(out)

    def _wait_until(self, deadline: float) -> bool:
        """Sleep until ``deadline`` (monotonic s); False if stopped meanwhile."""
        while (left := deadline - time.monotonic()) > 0.0:
            if self._stop.wait(min(left, _TICK)):
                return False
        return not self._stop.is_set()

    def _write_all(self, data: bytes) -> bool:
        """Write all of ``data`` to the master side; False if stopped first."""
        view = memoryview(data)
        while view:
            if self._stop.is_set():
                return False
            _, ready, _ = select.select([], [self._master], [], _TICK)
            if not ready:
                continue
            try:
                view = view[os.write(self._master, view):]
            except BlockingIOError:
                continue
        return True
