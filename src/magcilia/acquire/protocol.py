"""The magcilia serial protocol: COBS-framed, CRC-checked frames of ADC counts.

Magnetic-skin streams often send bare floats, so a flipped bit or a lost byte silently becomes a
wrong sample. A magcilia device instead sends *frames*, each carrying a header, a block of int32
ADC counts and a CRC-32, COBS-encoded so that the byte 0x00 never occurs inside a frame and marks
its end. The host splits the stream at 0x00, decodes, checks length, version and CRC, and hands
out only frames that pass; a damaged frame is discarded and counted, and the reader is back in
step at the next delimiter. ``docs/serial-protocol.md`` is the same description for firmware
writers, with a worked example.

Decoded frame (all fields little-endian; offsets in bytes)::

    0   uint8    version            1 (VERSION)
    1   uint8    type               1 = samples (FRAME_SAMPLES); other types are skipped
    2   uint8    flags              bit 0: set/reset state valid; bit 1: state is "set"
                                    (after a set pulse), else "reset"; bits 2-7: 0
    3   uint8    channels c         1..255
    4   uint16   samples n          1..65535, with 28 + 4 n c <= MAX_FRAME
    6   uint16   reserved           sent as 0, ignored
    8   uint32   sequence           frame counter, +1 per frame sent, wraps at 2**32
    12  uint32   first              index of the frame's first sample since the device
                                    started, wraps at 2**32
    16  float32  rate               sample rate, Hz: 0 (unknown) or MIN_RATE .. MAX_RATE
    20  float32  volts per count    V per ADC count, MIN_VOLTS_PER_COUNT .. MAX_VOLTS_PER_COUNT
    24  int32    counts[n][c]       sample-major: s0c0 s0c1 ... s1c0 s1c1 ...
    24+4nc uint32 crc               CRC-32 (zlib / ISO-HDLC) of bytes 0 .. 23+4nc

On the wire: ``COBS(decoded frame)`` followed by one 0x00. Empty frames (two 0x00 in a row) are
idle filler and ignored. A frame is *corrupt* when COBS decoding fails, it is shorter than a
header + CRC or longer than :data:`MAX_FRAME`, its version is not :data:`VERSION`, its length
disagrees with ``n`` and ``c``, its header values are impossible (n or c = 0, unknown flag bits, a
rate or volts per count outside the limits above, −0 or not finite), its format (channels,
rate, volts per count) differs from the session's, or its CRC does not match.

A *session* is the stream from the first good frame after the parser starts (the port opens)
until the device restarts (``first`` goes backwards): its first frame sets the format, and a
CRC-valid frame in another format within it is rejected as corrupt (counted in
:attr:`FrameParser.implausible` too), so a device cannot change its rate or gain under a
recording; a restarted device may announce a new format (the serial source then stops with one
line).

The host numbers samples by ``first`` (unwrapped to 64 bits): a frame whose ``first`` is ahead of
where the previous good frame ended means the samples in between were lost (dropped frames or
corrupt ones); that gap is reported with the frame (:attr:`Frame.gap`). A ``first`` that goes
backwards means the device restarted; the host continues its count from where it was.

Shape letters: ``n`` samples, ``c`` channels.
"""

from __future__ import annotations

import math
import struct
import zlib
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from magcilia import _validate as v
from magcilia._errors import require

#: protocol version carried in byte 0
VERSION = 1
#: frame type of a block of samples
FRAME_SAMPLES = 1
#: flags bit 0: the set/reset state of the AMR strap is known for this frame
FLAG_SETRESET_VALID = 0x01
#: flags bit 1: the strap's last pulse was a set pulse (else a reset pulse); valid with bit 0
FLAG_SET = 0x02
#: the header: version, type, flags, channels, samples, reserved, sequence, first, rate, V/count
HEADER = struct.Struct("<BBBBHHIIff")
#: bytes of the CRC-32 after the counts
CRC_SIZE = 4
#: largest decoded frame, bytes (header + counts + CRC)
MAX_FRAME = 16384
#: largest COBS-encoded frame without its delimiter, bytes
MAX_ENCODED = MAX_FRAME + MAX_FRAME // 254 + 1
#: the frame delimiter
DELIMITER = b"\x00"
#: slowest sample rate a frame may announce, Hz (one sample per 10 s; 0 means unknown)
MIN_RATE = 0.1
#: fastest sample rate a frame may announce, Hz (a USB full-speed link carries about 3e5 int32
#: values per second; 1 MHz leaves room for high-speed links)
MAX_RATE = 1e6
#: smallest ADC step a frame may announce, V per count (a 32-bit converter spanning ±2 µV)
MIN_VOLTS_PER_COUNT = 1e-15
#: largest ADC step a frame may announce, V per count (a converter with a 1 V step)
MAX_VOLTS_PER_COUNT = 1.0

_OVERHEAD = HEADER.size + CRC_SIZE
_WRAP = 1 << 32
_HALF = 1 << 31
_CRC = struct.Struct("<I")
_cobs_module: Any = None


def _cobs() -> Any:
    """The ``cobs.cobs`` module (the ``serial`` extra)."""
    global _cobs_module  # noqa: PLW0603 - imported once, on first use
    if _cobs_module is None:
        _cobs_module = require("cobs.cobs", package="cobs", extra="serial",
                               purpose="The serial protocol")
    return _cobs_module


@dataclass(frozen=True, slots=True, eq=False)
class Frame:
    """One good frame of samples, as the host received it (immutable).

    Attributes
    ----------
    sequence : int
        The frame counter as sent (uint32).
    first : int
        Index of the frame's first sample since the device started, as sent (uint32).
    index : int
        ``first`` unwrapped past 2**32 by the parser (continues across device restarts).
    flags : int
        The flags byte (:data:`FLAG_SETRESET_VALID`, :data:`FLAG_SET`).
    rate : float
        Sample rate the device reports, Hz (0: unknown).
    volts_per_count : float
        V per ADC count.
    counts : ndarray of int32, shape (n, c)
        The ADC counts, sample-major (read-only).
    gap : int
        Samples lost between the previous good frame and this one (0 for the first frame after
        the parser started or was reset).
    corrupt : int
        Corrupt frames discarded between the previous good frame and this one (0 for the first
        frame after the parser started or was reset).
    """

    sequence: int
    first: int
    index: int
    flags: int
    rate: float
    volts_per_count: float
    counts: NDArray[np.int32]
    gap: int = 0
    corrupt: int = 0

    @property
    def n(self) -> int:
        """Samples per channel in the frame."""
        return int(self.counts.shape[0])

    @property
    def channels(self) -> int:
        """Channels per sample."""
        return int(self.counts.shape[1])

    @property
    def setreset(self) -> int:
        """+1 after a set pulse, −1 after a reset pulse, 0 when the frame does not say."""
        if not self.flags & FLAG_SETRESET_VALID:
            return 0
        return 1 if self.flags & FLAG_SET else -1

    def volts(self) -> NDArray[np.float64]:
        """The samples in V, shape (c, n)."""
        return np.multiply(self.counts.T, self.volts_per_count, dtype=np.float64)


def header_problem(channels: int, samples: int, flags: int, rate: float,
                   volts_per_count: float) -> str | None:
    """Why a frame's header values are impossible (one phrase), or None when they are within
    the protocol's limits (see the module docstring)."""
    if not 1 <= channels <= 255:
        return f"{channels} channels (1 to 255)"
    if not (1 <= samples <= 0xFFFF and _OVERHEAD + 4 * samples * channels <= MAX_FRAME):
        return f"{samples} samples of {channels} channels (28 + 4 n c <= {MAX_FRAME} bytes)"
    if flags & ~(FLAG_SETRESET_VALID | FLAG_SET):
        return f"flags 0x{flags:02x} (bits 2-7 must be 0)"
    if not (rate == 0.0 and math.copysign(1.0, rate) > 0.0) and not (
            MIN_RATE <= rate <= MAX_RATE):
        return f"rate {rate:g} Hz (0 = unknown, or {MIN_RATE:g} Hz to {MAX_RATE:g} Hz)"
    if not MIN_VOLTS_PER_COUNT <= volts_per_count <= MAX_VOLTS_PER_COUNT:
        return (f"{volts_per_count:g} V per count ({MIN_VOLTS_PER_COUNT:g} to "
                f"{MAX_VOLTS_PER_COUNT:g} V)")
    return None


def _flags(setreset: int | None) -> int:
    if setreset is None or setreset == 0:
        return 0
    return FLAG_SETRESET_VALID | (FLAG_SET if setreset > 0 else 0)


def _encode(payload: bytes, n: int, c: int, sequence: int, first: int, flags: int,
            rate: float, volts_per_count: float) -> bytes:
    """Encode counts already packed as little-endian int32 (no checks): the fast path."""
    body = HEADER.pack(VERSION, FRAME_SAMPLES, flags, c, n, 0, sequence % _WRAP, first % _WRAP,
                       rate, volts_per_count) + payload
    encoded: bytes = _cobs().encode(body + _CRC.pack(zlib.crc32(body)))
    return encoded + DELIMITER


def encode_frame(counts: ArrayLike, *, sequence: int, first: int, rate: float,
                 volts_per_count: float, setreset: int | None = None) -> bytes:
    """One frame of samples as it goes on the wire (COBS-encoded, with its 0x00 delimiter).

    Parameters
    ----------
    counts : array-like of int, shape (n,) or (n, c)
        ADC counts, sample-major; one channel when 1-D. Values must fit int32.
    sequence : int
        Frame counter (taken modulo 2**32).
    first : int
        Index of the first sample since the device started (taken modulo 2**32).
    rate : float
        Sample rate, Hz: 0 (unknown) or :data:`MIN_RATE` to :data:`MAX_RATE`.
    volts_per_count : float
        V per ADC count, :data:`MIN_VOLTS_PER_COUNT` to :data:`MAX_VOLTS_PER_COUNT`.
    setreset : {None, 1, -1}
        The strap's state: +1 after a set pulse, −1 after a reset pulse, None unknown.

    Returns
    -------
    bytes
        ``COBS(header + counts + CRC-32) + b"\\x00"``.

    Examples
    --------
    >>> from magcilia.acquire.protocol import FrameParser, encode_frame
    >>> wire = encode_frame([1, -2, 3], sequence=0, first=0, rate=1000.0, volts_per_count=1e-6)
    >>> FrameParser().feed(wire)[0].counts[:, 0].tolist()
    [1, -2, 3]
    """
    arr = np.asarray(counts)
    if arr.ndim == 1:
        arr = arr[:, None]
    if arr.ndim != 2 or arr.size == 0 or not (np.issubdtype(arr.dtype, np.integer)
                                              or np.issubdtype(arr.dtype, np.bool_)):
        raise v.fail("counts", f"an array of dtype {arr.dtype} and shape {arr.shape}",
                     "integers of shape (n,) or (n, c)")
    n, c = arr.shape
    if not (1 <= c <= 255 and 1 <= n <= 0xFFFF and _OVERHEAD + 4 * n * c <= MAX_FRAME):
        raise v.fail("counts", f"shape {arr.shape}",
                     f"(n, c) with c <= 255 and 28 + 4 n c <= {MAX_FRAME} bytes")
    if arr.min() < -_HALF or arr.max() >= _HALF:
        raise v.fail("counts", f"values in [{arr.min()}, {arr.max()}]", "int32 values")
    sequence = v.integer("sequence", sequence, 0)
    first = v.integer("first", first, 0)
    rate = v.non_negative("rate", rate, "Hz", "frequency")
    volts_per_count = v.positive("volts_per_count", volts_per_count, "V", "step")
    if setreset not in (None, 1, -1):
        raise v.fail("setreset", setreset, "None, 1 (set) or -1 (reset)")
    wire_rate, wire_vpc = struct.unpack("<ff", struct.pack("<ff", rate, volts_per_count))
    problem = header_problem(c, n, 0, wire_rate, wire_vpc)
    if problem is not None:
        raise v.fail("frame header", problem, "within the protocol's limits")
    payload = np.ascontiguousarray(arr, dtype="<i4").tobytes()
    return _encode(payload, n, c, sequence, first, _flags(setreset), rate, volts_per_count)


class FrameParser:
    """Split a byte stream into good frames, discarding and counting the damaged ones.

    Feed it bytes as they arrive, in pieces of any size; it keeps an incomplete frame for the next
    :meth:`feed`. Each corrupt frame (bad COBS, length, version, header or CRC) is discarded and
    counted, and parsing resumes at the next delimiter; no sample of a corrupt frame is ever
    returned.

    Parameters
    ----------
    midstream : bool
        The stream may start inside a frame (a port opened while the device is sending): the bytes
        up to the first delimiter are dropped silently if they do not form a good frame. False
        (default): the stream starts at a frame boundary and leading garbage counts as corrupt.

    Attributes
    ----------
    frames : int
        Good frames returned so far.
    corrupt : int
        Corrupt frames discarded so far.
    dropped : int
        Samples per channel lost in gaps of the sample index so far.
    lost_frames : int
        Frames missing from the sequence numbers so far.
    skipped : int
        Good frames of other types than :data:`FRAME_SAMPLES`, ignored.
    restarts : int
        Times the sample index went backwards (the device restarted).
    implausible : int
        Of the corrupt frames, those with a good CRC but impossible header values or a format
        (channels, rate, volts per count) other than the session's.
    rejected : str or None
        Why the last such frame was rejected (one phrase), for messages.
    """

    def __init__(self, *, midstream: bool = False) -> None:
        self.frames = 0
        self.corrupt = 0
        self.dropped = 0
        self.lost_frames = 0
        self.skipped = 0
        self.restarts = 0
        self.implausible = 0
        self.rejected: str | None = None
        self._format: tuple[int, float, float] | None = None  # the session's c, rate, V/count
        self._pending = b""
        self._overflow = False
        self._synced = not midstream
        self._next: int | None = None  # unwrapped index after the last good frame
        self._next_raw = 0  # the same as the device counts it (uint32)
        self._next_seq = 0
        self._count_gap = False
        self._corrupt_since = 0

    @property
    def pending(self) -> int:
        """Bytes held back as the start of an incomplete frame."""
        return len(self._pending)

    def reset(self) -> None:
        """Forget the bytes held back and resynchronise at the next delimiter (after the input
        was flushed): the next good frame reports no gap and no corrupt frames, and its index
        continues the unwrapped count."""
        self._pending = b""
        self._overflow = False
        self._synced = False
        self._count_gap = False
        self._corrupt_since = 0

    def feed(self, data: bytes | bytearray | memoryview) -> list[Frame]:
        """Parse the next bytes of the stream.

        Parameters
        ----------
        data : bytes-like
            The bytes that arrived, any amount (an incomplete frame at the end is kept).

        Returns
        -------
        list of Frame
            The good sample frames completed by these bytes, in stream order.
        """
        buf = self._pending + bytes(data) if self._pending else bytes(data)
        chunks = buf.split(DELIMITER)
        tail = chunks.pop()
        if self._overflow:  # inside an over-long run without a delimiter, already counted
            if not chunks:
                self._pending = b""
                return []
            chunks[0] = b""
            self._overflow = False
        overflow = len(tail) > MAX_ENCODED
        self._pending = b"" if overflow else tail
        out: list[Frame] = []
        decode = _cobs().decode
        error = _cobs().DecodeError
        for chunk in chunks:
            if not chunk:
                continue
            synced = self._synced
            self._synced = True
            if len(chunk) > MAX_ENCODED:
                if synced:
                    self._bad()
                continue
            try:
                raw = decode(chunk)
            except error:
                if synced:
                    self._bad()
                continue
            frame = self._frame(raw, synced)
            if frame is not None:
                out.append(frame)
        if overflow:  # an over-long run without a delimiter: one corrupt frame, dropped
            self._overflow = True
            if self._synced:
                self._bad()
            self._synced = True
        return out

    # -- one frame -------------------------------------------------------------------------------
    def _bad(self) -> None:
        self.corrupt += 1
        self._corrupt_since += 1

    def _frame(self, raw: bytes, synced: bool) -> Frame | None:
        size = len(raw)
        if size < _OVERHEAD or size > MAX_FRAME:
            self._reject(synced)
            return None
        version, kind, flags, c, n, _, seq, first, rate, vpc = HEADER.unpack_from(raw)
        if (version != VERSION or size != _OVERHEAD + 4 * n * c
                or zlib.crc32(memoryview(raw)[:-CRC_SIZE]) != _CRC.unpack_from(raw, size - 4)[0]):
            self._reject(synced)
            return None
        if kind != FRAME_SAMPLES:
            self.skipped += 1
            return None
        problem = header_problem(c, n, flags, rate, vpc)
        delta = 0 if self._next is None else (first - self._next_raw) % _WRAP
        restart = delta >= _HALF
        fmt = (c, float(rate), float(vpc))
        if problem is None and self._format is not None and fmt != self._format and not restart:
            problem = (f"a format change without a restart ({self._format[0]} channels at "
                       f"{self._format[1]:g} Hz, {self._format[2]:g} V per count, now {c} at "
                       f"{rate:g} Hz, {vpc:g} V per count)")
        if problem is not None:
            if synced:
                self.implausible += 1
                self.rejected = problem
            self._reject(synced)
            return None
        self._format = fmt
        counts = np.frombuffer(raw, dtype="<i4", count=n * c, offset=HEADER.size).reshape(n, c)
        gap = 0
        if self._next is None:
            index = first
        else:
            if not restart:
                index = self._next + delta
                gap = delta if self._count_gap else 0
            else:
                index = self._next
                self.restarts += 1
            if self._count_gap:
                lost = (seq - self._next_seq) % _WRAP
                self.lost_frames += lost if lost < _HALF else 0
        self._next = index + n
        self._next_raw = (first + n) % _WRAP
        self._next_seq = (seq + 1) % _WRAP
        self.dropped += gap
        corrupt = self._corrupt_since if self._count_gap else 0
        self._count_gap = True
        self._corrupt_since = 0
        self.frames += 1
        return Frame(seq, first, index, flags, float(rate), float(vpc), counts, gap, corrupt)

    def _reject(self, synced: bool) -> None:
        if synced:
            self._bad()
