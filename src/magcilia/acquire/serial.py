"""A sensor on a serial port that streams the magcilia protocol (:mod:`.protocol`).

:class:`SerialSource` opens the port with pyserial (the ``serial`` extra), waits for the first good
frame to learn the sample rate and the channels, and then hands out samples in V, timed by the
device's own sample index: a lost frame shows as a gap in :attr:`Block.time` and is counted in
:attr:`~Source.counters` (``dropped``), a damaged one is discarded and counted (``corrupt``).
Losses are counted when the next good sample is handed out, so the counters describe exactly the
span that was delivered. No sample of a damaged frame is ever handed out.

Failures are :class:`~magcilia._errors.AcquisitionError` with one line naming the port: a port that
does not exist or is busy, a device that vanished (unplugged) or stopped sending valid frames for
``stall`` seconds.
"""

from __future__ import annotations

import errno
import time
from collections import deque
from collections.abc import Sequence
from typing import Any

import numpy as np

from magcilia import _validate as v
from magcilia._errors import AcquisitionError, require
from magcilia.acquire.protocol import MAX_RATE, MIN_RATE, VERSION, Frame, FrameParser
from magcilia.acquire.source import OUTPUT, Block, Channel, Source

#: relative difference between a given rate and the device's above which they disagree
_RATE_TOLERANCE = 0.01
#: longest wait in one read of the port, s (the stall timer is checked after each)
_POLL = 0.05


def _pyserial() -> Any:
    return require("serial", package="pyserial", extra="serial", purpose="Serial acquisition")


def _line(exc: BaseException) -> str:
    """An exception's message on one line."""
    return " ".join(str(exc).split()) or type(exc).__name__


class SerialSource(Source):
    """A device streaming the magcilia protocol on a serial port (see the module docstring).

    Channel 0 is :data:`~magcilia.acquire.source.OUTPUT` (the sensor output, V); further channels
    are ``ch1``, ``ch2``, … (V). ``rate`` and ``channels`` are learnt from the first good frame
    when the source opens (before that, ``rate`` is the given rate or 0 and one channel is
    assumed).

    Parameters
    ----------
    port : str
        The serial port, e.g. ``/dev/ttyACM0`` or ``COM3`` (list them with
        ``python -m serial.tools.list_ports``).
    baudrate : int
        Bits per second (ignored by USB CDC devices).
    stall : float
        Seconds without a good frame after which the device counts as stopped, s (longer than
        one frame takes: 32 samples at 20 Hz take 1.6 s).
    rate : float or None
        The sample rate, Hz, when known better than the device reports it (a clock measured
        against a reference), within the protocol's limits (:data:`~.protocol.MIN_RATE` to
        :data:`~.protocol.MAX_RATE`); it must agree with a reported rate within 1 %. None takes
        the device's rate; a device that reports 0 (unknown) needs it.
    names : sequence of Channel, optional
        What the frames' channels are, in order (names and units; the frames' scale per count is
        then in that unit, e.g. T for a 3-axis part's ``NAME.x``, ``NAME.y``, ``NAME.z``);
        default ``output``, ``ch1``, … in V. A device sending another number of channels is
        refused with one line.

    Examples
    --------
    >>> from magcilia.acquire.serial import SerialSource
    >>> with SerialSource("/dev/ttyACM0") as source:  # doctest: +SKIP
    ...     block = source.read(1000)
    """

    def __init__(self, port: str, *, baudrate: int = 115200, stall: float = 2.0,
                 rate: float | None = None, names: Sequence[Channel] | None = None) -> None:
        super().__init__()
        if not isinstance(port, str) or not port:
            raise v.fail("port", port, "a serial port name such as '/dev/ttyACM0' or 'COM3'")
        self.port = port
        self.baudrate = v.integer("baudrate", baudrate, 1)
        self.stall = v.positive("stall", stall, "s", "time")
        self._given_rate = None if rate is None else v.positive("rate", rate, "Hz", "frequency")
        if self._given_rate is not None and not MIN_RATE <= self._given_rate <= MAX_RATE:
            raise v.fail("rate", rate, f"a sample rate from {MIN_RATE:g} Hz to {MAX_RATE:g} Hz")
        self.rate = self._given_rate or 0.0
        self._names = None if names is None else tuple(names)
        if self._names is not None and not (
                self._names and all(isinstance(c, Channel) for c in self._names)):
            raise v.fail("names", names, "a sequence of Channel")
        self.channels = (Channel(OUTPUT, "V"),)
        self.realtime = True
        self.name = f"serial:{port}"
        self._serial: Any = None
        self._parser = FrameParser(midstream=True)
        self._frames: deque[Frame] = deque()
        self._used = 0  # samples of the first buffered frame already handed out
        self._available = 0  # samples buffered and not handed out
        self._origin: int | None = None  # device index of the source's sample 0
        self._device_rate = 0.0
        self._last_good = 0.0
        self._bytes_since_good = 0
        self._corrupt_since_good = 0
        self._implausible_since_good = 0

    @property
    def device_first(self) -> int | None:
        """The device's (unwrapped) sample index of this source's sample 0; None before the
        first good frame."""
        return self._origin

    # -- Source ---------------------------------------------------------------------------------
    def _open_port(self) -> None:
        """Open the port (one-line errors)."""
        serial = _pyserial()
        try:
            self._serial = serial.Serial(self.port, self.baudrate, timeout=min(_POLL, self.stall),
                                         exclusive=True)
        except (serial.SerialException, OSError, ValueError) as exc:
            raise self._open_error(exc) from None

    def _receive(self) -> bytes:
        """What the port has (waiting at most ``_POLL`` s; b"" when nothing came)."""
        ser = self._serial
        if ser is None:
            raise AcquisitionError(f"serial port {self.port} is closed")
        serial = _pyserial()
        try:
            waiting = ser.in_waiting
            data: bytes = ser.read(waiting if waiting else 1)
        except (serial.SerialException, OSError) as exc:
            raise self._vanished(exc) from None
        return data

    def _open(self) -> None:
        self._open_port()
        self._parser = FrameParser(midstream=True)
        self._frames.clear()
        self._used = self._available = 0
        self._origin = None
        self._restart_timer()
        try:
            while not self._frames:
                self._fill()
        except BaseException:
            self._close()
            raise

    def _close(self) -> None:
        ser, self._serial = self._serial, None
        if ser is not None:
            try:
                ser.close()
            except (OSError, _pyserial().SerialException):
                pass  # the device vanished; nothing left to release

    def discard(self) -> None:
        """Drop the bytes and frames received but not read yet (the input buffer and the
        parser's incomplete frame); the next samples come fresh, and what was dropped here is
        not counted as lost."""
        if self._serial is None:
            return
        try:
            self._serial.reset_input_buffer()
        except (OSError, _pyserial().SerialException) as exc:
            raise self._vanished(exc) from None
        self._parser.reset()
        self._frames.clear()
        self._used = self._available = 0
        self._restart_timer()

    def _read(self, n: int) -> Block:
        while self._available < n:
            self._fill()
        counts, vpc, index, setreset = [], [], [], []
        any_sr = False
        dropped = corrupt = 0
        need = n
        while need:
            frame = self._frames[0]
            if self._used == 0:
                dropped += frame.gap
                corrupt += frame.corrupt
            take = min(need, frame.n - self._used)
            start = self._used
            counts.append(frame.counts[start:start + take])
            vpc.append(np.full(take, frame.volts_per_count))
            index.append(frame.index - (self._origin or 0) + np.arange(start, start + take))
            sr = frame.setreset
            any_sr |= sr != 0
            setreset.append(np.full(take, sr, dtype=np.int8))
            need -= take
            self._used += take
            if self._used == frame.n:
                self._frames.popleft()
                self._used = 0
        self._available -= n
        self._count_loss(dropped=dropped, corrupt=corrupt)
        idx = np.concatenate(index)
        data = np.concatenate(counts).T * np.concatenate(vpc)
        return Block(time=idx / self.rate, data=data, channels=self.channels, first=int(idx[0]),
                     setreset=np.concatenate(setreset) if any_sr else None)

    def metadata(self) -> dict[str, Any]:
        """The source's settings: port, baud rate, protocol version, the device's rate."""
        return {**super().metadata(), "port": self.port, "baudrate": self.baudrate,
                "protocol_version": VERSION, "device_rate_Hz": self._device_rate,
                "device_first_sample": self._origin}

    # -- the port -------------------------------------------------------------------------------
    def _restart_timer(self) -> None:
        self._last_good = time.monotonic()
        self._bytes_since_good = 0
        self._corrupt_since_good = 0
        self._implausible_since_good = 0

    def _fill(self) -> None:
        """Read what the port has (waiting at most ``_POLL`` s) and parse it."""
        data = self._receive()
        now = time.monotonic()
        corrupt, implausible = self._parser.corrupt, self._parser.implausible
        frames = self._parser.feed(data) if data else []
        if frames:
            if self._origin is None:
                self._learn(frames[0])
            for frame in frames:
                self._check(frame)
                self._available += frame.n
            self._frames.extend(frames)
            self._restart_timer()
            return
        self._bytes_since_good += len(data)
        self._corrupt_since_good += self._parser.corrupt - corrupt
        self._implausible_since_good += self._parser.implausible - implausible
        if now - self._last_good > self.stall:
            raise self._stalled()

    def _learn(self, frame: Frame) -> None:
        """Rate and channels from the first good frame."""
        self._device_rate = frame.rate
        if self._given_rate is None:
            if frame.rate <= 0.0:
                raise AcquisitionError(f"serial port {self.port}: the device does not report its "
                                       "sample rate; pass rate= (Hz) to SerialSource")
            self.rate = frame.rate
        elif frame.rate > 0.0 and abs(self._given_rate / frame.rate - 1.0) > _RATE_TOLERANCE:
            raise AcquisitionError(f"serial port {self.port}: the device reports "
                                   f"{frame.rate:g} Hz but rate={self._given_rate:g} Hz was given")
        if self._names is not None and len(self._names) != frame.channels:
            raise AcquisitionError(
                f"serial port {self.port}: the device sends {frame.channels} channels, the "
                f"read-out needs {len(self._names)} ({', '.join(c.name for c in self._names)})")
        self.channels = self._names or (
            Channel(OUTPUT, "V"), *(Channel(f"ch{i}", "V") for i in range(1, frame.channels)))
        self._origin = frame.index

    def _check(self, frame: Frame) -> None:
        """A frame must keep the format the source learnt (the parser rejects other formats
        within a session; a device that restarts may announce a new one)."""
        if frame.channels != len(self.channels) or frame.rate != self._device_rate:
            raise AcquisitionError(
                f"serial port {self.port}: the device restarted in another format "
                f"({len(self.channels)} channels at {self._device_rate:g} Hz, now "
                f"{frame.channels} at {frame.rate:g} Hz); close and reopen the source")

    # -- one-line errors -------------------------------------------------------------------------
    def _open_error(self, exc: BaseException) -> AcquisitionError:
        code = getattr(exc, "errno", None)
        text = _line(exc)
        port = self.port
        if code == errno.ENOENT or "FileNotFoundError" in text or "No such file" in text:
            return AcquisitionError(f"serial port {port} does not exist (list the ports with: "
                                    "python -m serial.tools.list_ports)")
        if code in (errno.EBUSY, errno.EAGAIN, errno.EWOULDBLOCK) or "lock" in text.lower() or (
                "PermissionError" in text and "Access is denied" in text):
            return AcquisitionError(f"serial port {port} is busy (another program has it open)")
        if code == errno.EACCES:
            return AcquisitionError(f"serial port {port}: permission denied (on Linux, add "
                                    "yourself to the 'dialout' group and log in again)")
        return AcquisitionError(f"serial port {port} cannot be opened: {text}")

    def _vanished(self, exc: BaseException) -> AcquisitionError:
        return AcquisitionError(f"serial port {self.port} vanished (unplugged?): {_line(exc)}")

    def _stalled(self) -> AcquisitionError:
        port, stall = self.port, self.stall
        if not self._bytes_since_good:
            return AcquisitionError(f"serial port {port}: the device stopped sending (nothing "
                                    f"for {stall:g} s)")
        if self._implausible_since_good:
            return AcquisitionError(
                f"serial port {port}: the device sends no frames within the protocol's limits "
                f"({self._implausible_since_good} frames in {stall:g} s rejected, the last for "
                f"{self._parser.rejected}; see docs/serial-protocol.md)")
        return AcquisitionError(
            f"serial port {port}: the device stopped sending valid frames "
            f"({self._bytes_since_good} bytes, {self._corrupt_since_good} corrupt frames in "
            f"{stall:g} s; check the baud rate and that the firmware speaks protocol version "
            f"{VERSION})")
