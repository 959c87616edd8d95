"""A sensor on a serial port that prints ASCII lines or bare float32 frames (no checksum).

:class:`UnverifiedSerialSource` reads the formats of :mod:`.serial_formats` from firmware a lab
already runs (an Arduino sketch printing ``x,y,z`` lines, a ReSkin/AnySkin board sending float
frames), through the same port handling as :class:`~magcilia.acquire.serial.SerialSource` (its
one-line errors for a missing, busy or vanished port and a stalled device). What these formats
cannot say, the source cannot know: the sample rate is given (``rate``), a lost line leaves no
gap in the time axis, and a flipped digit is a wrong sample. Every sample handed out is counted
as unverified (:attr:`~magcilia.acquire.source.Counters.unverified`), every malformed line or
frame as corrupt; a live status says "unverified (no checksum)".
"""

from __future__ import annotations

import time
from collections.abc import Sequence
from typing import Any

import numpy as np
from numpy.typing import NDArray

from magcilia import _validate as v
from magcilia._errors import AcquisitionError
from magcilia.acquire.serial import SerialSource, _pyserial
from magcilia.acquire.serial_formats import (
    Field,
    FloatParser,
    LineParser,
    default_fields,
    parse_fields,
)
from magcilia.acquire.source import Block, Channel


class UnverifiedSerialSource(SerialSource):
    """A device printing ASCII lines or bare float32 frames on a serial port (see the module
    docstring).

    Parameters
    ----------
    port : str
        The serial port, e.g. ``/dev/ttyACM0`` or ``COM3``.
    format : {"ascii", "floats"}
        Text lines of numbers, or float32 frames ending in ``\\r\\n``.
    rate : float
        The device's sample rate, Hz (these formats do not carry it): it sets the time axis.
    fields : str, optional
        ``NAME[unit],...`` naming each field of a line or frame in order (``-`` skips one;
        units convert to SI: ``bx[uT]`` is read as T). Default: an ASCII header line's names,
        else ``output``, ``ch1``, ... in V.
    channels : int, optional
        Values per float frame (``floats``; default: the number of ``fields``). With ``ascii``,
        the number of fields a line must have.
    names : sequence of Channel, optional
        The fields' names and SI units when ``fields`` is not given (what a read-out reads,
        e.g. a 3-axis part's ``NAME.x`` in T); the values are taken in those units.
    baudrate, stall :
        As :class:`~magcilia.acquire.serial.SerialSource`.

    Examples
    --------
    >>> from magcilia.acquire.serial_unverified import UnverifiedSerialSource
    >>> src = UnverifiedSerialSource("/dev/ttyACM0", format="floats", rate=100.0,
    ...                              fields="bx[uT],by[uT],bz[uT]")  # doctest: +SKIP
    """

    verified = False

    def __init__(self, port: str, *, format: str, rate: float,
                 fields: str | None = None, channels: int | None = None,
                 names: Sequence[Channel] | None = None, baudrate: int = 115200,
                 stall: float = 2.0) -> None:
        super().__init__(port, baudrate=baudrate, stall=stall, rate=None)
        if format not in ("ascii", "floats"):
            raise v.fail("format", format, "ascii or floats (magcilia's framed protocol: "
                         "SerialSource)")
        self.format = format
        self.rate = v.positive("rate", rate, "Hz", "frequency")
        self._fields = None if fields is None else parse_fields(fields)
        if self._fields is None and names is not None:
            self._fields = tuple(Field(c.name, c.unit) for c in names)
        if channels is not None:
            channels = v.integer("channels", channels, 1)
            if self._fields is not None and channels != len(self._fields):
                raise v.fail("--channels", channels, f"the number of --fields ({fields!r} has "
                             f"{len(self._fields)}), or left out")
            if self._fields is None:
                self._fields = default_fields(channels)
        if format == "floats" and self._fields is None:
            raise v.fail("--channels", None, "the number of float32 values per frame (or "
                         "--fields naming them) with --format floats")
        self._set_channels()
        self._rows: list[NDArray[np.float64]] = []
        self._available = 0
        self._next = 0  # index of the next sample handed out
        self._text = self._make_parser()

    def _make_parser(self) -> LineParser | FloatParser:
        if self.format == "ascii":
            return LineParser(self._fields, midstream=True)
        assert self._fields is not None
        return FloatParser(len(self._fields), midstream=True)

    def _set_channels(self) -> None:
        fields = self._fields if self._fields is not None else default_fields(1)
        self.channels = tuple(Channel(f.name, f.unit) for f in fields if not f.skipped)

    @property
    def parser(self) -> LineParser | FloatParser:
        """The parser of the current session (its ``corrupt`` count, an ASCII header seen)."""
        return self._text

    # -- Source ---------------------------------------------------------------------------------
    def _open(self) -> None:
        self._open_port()
        self._text = self._make_parser()
        self._rows.clear()
        self._available = 0
        self._next = 0
        self._restart_timer()
        try:
            while not self._available:
                self._fill()
        except BaseException:
            self._close()
            raise

    def discard(self) -> None:
        """Drop what was received but not read (the input buffer and a partial line or
        frame); not counted as lost."""
        if self._serial is None:
            return
        try:
            self._serial.reset_input_buffer()
        except (OSError, _pyserial().SerialException) as exc:
            raise self._vanished(exc) from None
        self._text = self._make_parser()
        self._rows.clear()
        self._available = 0
        self._restart_timer()

    def _fill(self) -> None:
        data = self._receive()
        now = time.monotonic()
        corrupt = self._text.corrupt
        rows = self._text.feed(data) if data else np.zeros((0, 0))
        self._count_loss(corrupt=self._text.corrupt - corrupt)
        if len(rows):
            if isinstance(self._text, LineParser) and self._fields is None:
                self._fields = self._text.fields
                self._set_channels()
            self._rows.append(rows)
            self._available += len(rows)
            self._restart_timer()
            return
        self._bytes_since_good += len(data)
        self._corrupt_since_good += self._text.corrupt - corrupt
        if now - self._last_good > self.stall:
            raise self._stalled()

    def _read(self, n: int) -> Block:
        while self._available < n:
            self._fill()
        rows = np.concatenate(self._rows)
        taken, rest = rows[:n], rows[n:]
        self._rows = [rest] if len(rest) else []
        self._available -= n
        index = self._next + np.arange(n)
        self._next += n
        return Block(time=index / self.rate, data=taken.T, channels=self.channels,
                     first=int(index[0]))

    def metadata(self) -> dict[str, Any]:
        """The source's settings: port, baud rate, format, the fields read (name and unit)."""
        meta = {k: val for k, val in super().metadata().items()
                if k not in ("protocol_version", "device_rate_Hz", "device_first_sample")}
        return {**meta, "format": self.format, "verified": False,
                "fields": [f"{f.name}[{f.unit}]" if f.name else "-"
                           for f in (self._fields or ())]}

    def _stalled(self) -> AcquisitionError:
        port, stall = self.port, self.stall
        if not self._bytes_since_good:
            return AcquisitionError(f"serial port {port}: the device stopped sending (nothing "
                                    f"for {stall:g} s)")
        what = "lines" if self.format == "ascii" else "float frames"
        return AcquisitionError(
            f"serial port {port}: no well-formed {what} for {stall:g} s "
            f"({self._bytes_since_good} bytes, {self._corrupt_since_good} malformed; check the "
            f"baud rate, --format {self.format} and the number of fields or --channels)")
