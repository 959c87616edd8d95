"""The protocol every source of samples follows: simulated, serial, NI-DAQmx.

A source is opened and closed (a context manager), has a sample rate and named channels with
units, and :meth:`Source.read` blocks until it has ``n`` samples per channel, returned as a
:class:`Block` with timestamps. Sources count what they lost: samples the device never delivered
(``dropped``, e.g. gaps in a serial stream's sequence numbers) and frames that arrived damaged
(``corrupt``); a corrupt sample is never handed out.

A source whose samples are paced by a clock (a device, or a simulation run in real time) has
``realtime = True``: a reader that falls behind loses samples, it cannot make the source wait.

Shape letters: ``c`` channels, ``n`` samples.
"""

from __future__ import annotations

import abc
from dataclasses import dataclass
from types import TracebackType
from typing import Any, Self

import numpy as np
from numpy.typing import NDArray

from magcilia import _validate as v

F64 = NDArray[np.float64]

#: the channel that carries the sensor output, V (what recordings call ``voltage_V``)
OUTPUT = "output"


@dataclass(frozen=True)
class Channel:
    """One channel of a source: its name and its SI unit (``"V"``, ``""`` for a plain number)."""

    name: str
    unit: str = "V"


@dataclass(frozen=True)
class Counters:
    """What a source (or a background reader) has lost so far.

    Attributes
    ----------
    samples : int
        Samples per channel delivered so far.
    dropped : int
        Samples per channel the device sent but that never arrived whole (sequence gaps, lost
        frames), or that a full buffer overwrote before anyone read them.
    corrupt : int
        Frames (or lines) that failed their check (bad length, framing or CRC; a malformed line
        or float frame) and were discarded.
    unverified : int
        Of the delivered samples, those from a format without a checksum (ASCII lines, bare
        floats: :mod:`magcilia.acquire.serial_formats`), which nothing could check.
    """

    samples: int = 0
    dropped: int = 0
    corrupt: int = 0
    unverified: int = 0

    def __add__(self, other: Counters) -> Counters:
        """The counts of two spans summed (a read-out across reconnections)."""
        return Counters(self.samples + other.samples, self.dropped + other.dropped,
                        self.corrupt + other.corrupt, self.unverified + other.unverified)

    def report(self) -> str:
        """One line: delivered, dropped and corrupt counts (and the unverified ones)."""
        unverified = (f", {self.unverified} unverified (no checksum)" if self.unverified
                      else "")
        return (f"{self.samples} samples delivered, {self.dropped} dropped, "
                f"{self.corrupt} corrupt frames discarded{unverified}")


@dataclass(frozen=True, eq=False)
class Block:
    """``n`` samples of each channel of a source (immutable).

    Attributes
    ----------
    time : ndarray, shape (n,)
        Sample times, s, from the source's first sample (gaps where samples were dropped).
    data : ndarray, shape (c, n)
        Samples in each channel's unit.
    channels : tuple of Channel
        The c channels, in the rows' order.
    first : int
        Index of the first sample since the source opened (counts dropped samples too).
    setreset : ndarray of int8, shape (n,), or None
        +1 for samples taken after a set pulse of the AMR strap, −1 after a reset pulse; None
        when the source does not alternate them.
    received : float or None
        Wall-clock time (:func:`time.time`, s) at which the last sample reached this computer,
        stamped by :class:`~magcilia.acquire.BackgroundReader` (None where nobody stamped it);
        what live read-outs measure their latency from.
    """

    time: F64
    data: F64
    channels: tuple[Channel, ...]
    first: int = 0
    setreset: NDArray[np.int8] | None = None
    received: float | None = None

    def __post_init__(self) -> None:
        for name in ("time", "data"):
            arr = np.asarray(getattr(self, name), dtype=np.float64)
            arr.setflags(write=False)
            object.__setattr__(self, name, arr)
        if self.data.ndim != 2 or self.data.shape != (len(self.channels), self.time.size):
            raise v.fail("block data", f"shape {self.data.shape}",
                         f"shape ({len(self.channels)}, {self.time.size}) (channels, samples)")
        if self.setreset is not None:
            sr = np.asarray(self.setreset, dtype=np.int8)
            sr.setflags(write=False)
            object.__setattr__(self, "setreset", sr)

    def __len__(self) -> int:
        return int(self.time.size)

    def __getitem__(self, name: str) -> F64:
        """The samples of the channel called ``name``, shape (n,)."""
        for i, ch in enumerate(self.channels):
            if ch.name == name:
                return self.data[i]
        raise v.fail("channel", name, "one of " + ", ".join(c.name for c in self.channels))

    def extra(self) -> dict[str, F64] | None:
        """The channels other than the sensor output (:data:`OUTPUT`) by name, or None."""
        out = {c.name: self.data[i] for i, c in enumerate(self.channels) if c.name != OUTPUT}
        return out or None

    @classmethod
    def concatenate(cls, blocks: list[Block]) -> Block:
        """One block of consecutive blocks of the same channels."""
        if not blocks:
            raise v.fail("blocks", "an empty list", "at least one block")
        sr = None
        if all(b.setreset is not None for b in blocks):
            sr = np.concatenate([b.setreset for b in blocks if b.setreset is not None])
        return cls(time=np.concatenate([b.time for b in blocks]),
                   data=np.concatenate([b.data for b in blocks], axis=1),
                   channels=blocks[0].channels, first=blocks[0].first, setreset=sr,
                   received=blocks[-1].received)


class Source(abc.ABC):
    """A source of samples (see the module docstring). Subclasses implement :meth:`_open`,
    :meth:`_close` and :meth:`_read`; use them as context managers::

        with SimulatedSource(setup) as source:
            block = source.read(2000)

    Attributes
    ----------
    rate : float
        Samples per second per channel, Hz.
    channels : tuple of Channel
        What each sample holds; the sensor output is the channel :data:`OUTPUT` (V).
    realtime : bool
        Whether a clock paces the samples (a reader that falls behind loses samples).
    name : str
        What the source is, for messages and recordings' metadata (e.g. ``serial:/dev/ttyACM0``).
    verified : bool
        Whether each sample passed a check on its way (a CRC, a driver); False for formats
        without one, whose samples the counters count as ``unverified``.
    """

    rate: float
    channels: tuple[Channel, ...]
    realtime: bool = True
    name: str = "source"
    verified: bool = True

    def __init__(self) -> None:
        self._open_now = False
        self._counters = Counters()

    # -- life cycle -------------------------------------------------------------------------------
    def open(self) -> Self:
        """Start acquiring (idempotent); returns the source."""
        if not self._open_now:
            self._open()
            self._open_now = True
        return self

    def close(self) -> None:
        """Stop acquiring and release the device (idempotent)."""
        if self._open_now:
            self._open_now = False
            self._close()

    @property
    def is_open(self) -> bool:
        """Whether the source is acquiring."""
        return self._open_now

    def __enter__(self) -> Self:
        return self.open()

    def __exit__(self, exc_type: type[BaseException] | None, exc: BaseException | None,
                 tb: TracebackType | None) -> None:
        self.close()

    # -- reading ----------------------------------------------------------------------------------
    def read(self, n: int) -> Block:
        """The next ``n`` samples per channel; blocks until they are there.

        Raises
        ------
        AcquisitionError
            If the device stalls, vanishes or was never there (one-line message).
        """
        n = v.integer("n", n, 1)
        if not self._open_now:
            self.open()
        block = self._read(n)
        c = self._counters
        self._counters = Counters(c.samples + len(block), c.dropped, c.corrupt,
                                  c.unverified + (0 if self.verified else len(block)))
        return block

    def discard(self) -> None:
        """Drop what the device has sent but nobody has read yet (before a fresh measurement);
        the default does nothing (a source without a backlog)."""
        return

    @property
    def counters(self) -> Counters:
        """What was delivered and lost so far."""
        return self._counters

    def _count_loss(self, dropped: int = 0, corrupt: int = 0) -> None:
        self._counters += Counters(0, dropped, corrupt)

    def metadata(self) -> dict[str, Any]:
        """What a recording should remember about the source (JSON-ready)."""
        return {"source": self.name, "rate_Hz": self.rate, "realtime": self.realtime,
                "channels": {c.name: c.unit for c in self.channels}}

    # -- to implement ----------------------------------------------------------------------------
    @abc.abstractmethod
    def _open(self) -> None:
        """Connect to the device and start it."""

    @abc.abstractmethod
    def _close(self) -> None:
        """Stop the device and disconnect."""

    @abc.abstractmethod
    def _read(self, n: int) -> Block:
        """Exactly ``n`` samples per channel (blocking)."""

