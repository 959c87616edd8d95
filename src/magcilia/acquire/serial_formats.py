"""The serial formats labs already run, besides magcilia's framed protocol (:mod:`.protocol`).

* ``ascii``: text lines of comma-, semicolon-, tab- or space-separated numbers, one sample per
  line, as Arduino sketches print them (``Serial.print(x); Serial.print(','); ...``), with an
  optional header line naming the fields (``bx[uT],by[uT],bz[uT]``; a repeated header after a
  board reset is skipped);
* ``floats``: bare little-endian float32 values, ``c`` per sample, each sample ending in
  ``\\r\\n``, as ReSkin and AnySkin boards send them (NOTES §7).

Neither carries a checksum, a sequence number or a sample rate: a flipped digit is a wrong sample
nobody can see, a lost line is a gap nobody can count. The parsers here discard what is
*visibly* malformed (a line whose field count differs or that holds no number, a float frame
not followed by ``\\r\\n`` or holding NaN/inf) and count it as corrupt; they re-synchronise at the
next line end (ascii) or at the next ``\\r\\n`` that ends a whole frame (floats). Everything they
hand out is *unverified*, and the serial source counts it so
(:attr:`~magcilia.acquire.source.Counters.unverified`).

A field is described by a :class:`Field` (name and unit; SI after reading); ``fields`` text is
``NAME[unit],NAME[unit],...`` with ``-`` for a field to skip (``--fields`` on the command line).
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from magcilia._validate import fail
from magcilia.acquire.source import OUTPUT
from magcilia.io.columns import split_unit
from magcilia.units import UNITS, si_unit, unit_dimension

#: the serial formats: magcilia's framed protocol, text lines, bare float32 frames
FORMATS = ("magcilia", "ascii", "floats")
#: the end of a float frame (ReSkin, AnySkin)
FLOAT_END = b"\r\n"
#: longest text line, bytes; a longer run without a line end is corrupt
MAX_LINE = 4096
#: most channels of an unverified format
MAX_CHANNELS = 255
#: a field without a unit is taken in this unit (an ADC's voltage)
DEFAULT_UNIT = "V"

_SEPARATORS = re.compile(rb"[,;\t ]+")
_NAME = re.compile(r"^[A-Za-z_][A-Za-z0-9_.]*$")
_SUFFIX = re.compile(r"^(.*?)_([A-Za-zµ°/]+)$")


@dataclass(frozen=True)
class Field:
    """One field of a line or a float frame (immutable).

    Attributes
    ----------
    name : str
        The channel's name (``output`` for the sensor output); "" for a field that is skipped.
    unit : str
        The channel's SI unit after reading (``V``, ``T``, ...).
    scale : float
        Factor from the device's unit to ``unit`` (1e-6 for µT read as T).
    """

    name: str
    unit: str = DEFAULT_UNIT
    scale: float = 1.0

    @property
    def skipped(self) -> bool:
        """Whether the field is read and dropped."""
        return not self.name

    @classmethod
    def parse(cls, text: str, key: str = "--fields") -> Field:
        """One ``NAME[unit]`` (or ``NAME_unit`` in a header, or ``-`` to skip): the field in SI
        (``bx[uT]`` -> ``Field("bx", "T", 1e-6)``)."""
        text = text.strip()
        if text in ("-", "_"):
            return cls("")
        name, unit = split_unit(text)
        if unit is None:
            match = _SUFFIX.match(name)
            if match is not None and unit_dimension(match.group(2)) is not None:
                name, unit = match.group(1), match.group(2)
        if not _NAME.match(name):
            raise fail(key, text, "NAME[unit] with a name of letters, digits, _ and . (e.g. "
                       "output[mV] or bx[uT]), or - to skip the field")
        if unit is None:
            return cls(name)
        dimension = unit_dimension(unit)
        if dimension is None or dimension in ("celsius",):
            raise fail(key, text, "a unit of voltage, field or another known quantity (mV, uT, "
                       "G, K, ...)")
        return cls(name, si_unit(dimension), UNITS[dimension][unit])


def parse_fields(text: str, key: str = "--fields") -> tuple[Field, ...]:
    """``NAME[unit],...`` -> the fields in order (``-`` skips one); names must differ and at
    least one field must be kept."""
    parts = re.split(r"[,;]", text) if isinstance(text, str) else []
    if not parts or any(not p.strip() for p in parts):
        raise fail(key, text, "a comma-separated list NAME[unit],... (e.g. output[mV] or "
                   "-,bx[uT],by[uT],bz[uT])")
    fields = tuple(Field.parse(p, key) for p in parts)
    names = [f.name for f in fields if not f.skipped]
    if not names or len(names) > MAX_CHANNELS:
        raise fail(key, text, f"1 to {MAX_CHANNELS} fields kept (- skips one)")
    if len(set(names)) != len(names):
        raise fail(key, text, "fields with different names")
    return fields


def default_fields(channels: int) -> tuple[Field, ...]:
    """``channels`` unnamed fields: ``output``, ``ch1``, ``ch2``, ... in V (the framed
    protocol's names)."""
    return tuple(Field(OUTPUT if i == 0 else f"ch{i}") for i in range(channels))


def _numbers(parts: list[bytes]) -> list[float] | None:
    """The fields as floats, or None when one is not a finite number."""
    out = []
    for p in parts:
        try:
            x = float(p)
        except ValueError:
            return None
        if not math.isfinite(x):
            return None
        out.append(x)
    return out


class LineParser:
    """Split a byte stream of text lines into samples (see the module docstring).

    Parameters
    ----------
    fields : tuple of Field, optional
        The fields of every line, in order; None learns them from a header line (names, units
        as ``name[unit]`` or ``name_unit``) or, without one, from the first line of numbers
        (``output``, ``ch1``, ... in V).
    midstream : bool
        The stream may start inside a line (a port opened while the device sends): the bytes up
        to the first line end are dropped without counting (unless they are a header line).

    Attributes
    ----------
    fields : tuple of Field or None
        The fields, once known.
    lines : int
        Good lines (samples) returned so far.
    corrupt : int
        Malformed lines discarded (wrong number of fields, not numbers, too long).
    headers : int
        Header lines seen.
    """

    def __init__(self, fields: tuple[Field, ...] | None = None, *,
                 midstream: bool = False) -> None:
        self.fields = fields
        self._header: list[bytes] | None = None
        self._given = fields is not None
        self._from_numbers = False
        self._pending = b""
        self._synced = not midstream
        self.lines = 0
        self.corrupt = 0
        self.headers = 0

    def feed(self, data: bytes) -> NDArray[np.float64]:
        """Parse ``data``; the samples of its complete lines, shape (n, c) in each field's SI
        unit (skipped fields left out; (0, c) when none, (0, 0) before the fields are known)."""
        *lines, self._pending = (self._pending + data).split(b"\n")
        if len(self._pending) > MAX_LINE:
            self._pending = b""
            self.corrupt += 1
        rows: list[list[float]] = []
        for line in lines:
            if not self._synced:  # maybe the tail of a line: only a header is taken from it
                self._synced = True
                corrupt = self.corrupt
                if _numbers([p for p in _SEPARATORS.split(line.strip()) if p]) is None:
                    self._maybe_header([p for p in _SEPARATORS.split(line.strip()) if p])
                self.corrupt = corrupt
                continue
            row = self._line(line.strip())
            if row is not None:
                rows.append(row)
        return self._table(rows)

    def _table(self, rows: list[list[float]]) -> NDArray[np.float64]:
        if self.fields is None:
            return np.zeros((0, 0))
        keep = [i for i, f in enumerate(self.fields) if not f.skipped]
        scale = np.array([self.fields[i].scale for i in keep])
        if not rows:
            return np.zeros((0, len(keep)))
        return np.asarray(rows, dtype=np.float64)[:, keep] * scale

    def _line(self, line: bytes) -> list[float] | None:
        if not line:
            return None
        parts = [p for p in _SEPARATORS.split(line) if p]
        values = _numbers(parts)
        if values is None:
            self._maybe_header(parts)
            return None
        if self.fields is None:
            if len(values) > MAX_CHANNELS:
                self.corrupt += 1
                return None
            self.fields = default_fields(len(values))
            self._from_numbers = True
        if len(values) != len(self.fields):
            self.corrupt += 1
            return None
        self.lines += 1
        return values

    def _maybe_header(self, parts: list[bytes]) -> None:
        """A line that is not all numbers: a header before the first sample (a later one
        replaces an earlier one: a greeting then the header), the same header again after a
        reset, or corrupt."""
        if parts == self._header:
            self.headers += 1
            return
        if self.lines == 0 and not self._from_numbers:
            if self._given:
                self._header = parts  # the given fields win over the device's names
                self.headers += 1
                return
            try:
                fields = tuple(Field.parse(p.decode("ascii"), "header field") for p in parts)
            except (UnicodeDecodeError, ValueError):
                fields = ()
            names = [f.name for f in fields if not f.skipped]
            if names and len(set(names)) == len(names) and len(fields) <= MAX_CHANNELS:
                self.fields, self._header = fields, parts
                self.headers += 1
                return
        self.corrupt += 1


class FloatParser:
    """Split a byte stream of bare float32 frames (``c`` values + ``\\r\\n``) into samples.

    In step, every frame is ``4 c`` bytes followed by ``\\r\\n``; a frame whose end is not
    ``\\r\\n`` or that holds NaN or inf is corrupt: the parser drops the bytes up to the next
    ``\\r\\n`` and counts one corrupt frame per such slip (however many bytes it skips).

    Parameters
    ----------
    channels : int
        Values per frame.
    midstream : bool
        The stream may start inside a frame: the first slip is not counted.

    Attributes
    ----------
    frames : int
        Good frames (samples) returned so far.
    corrupt : int
        Slips: a frame not ending in ``\\r\\n`` or holding NaN or inf, with the bytes dropped
        until the parser is back in step (one count per slip, however many bytes it skips).
    """

    def __init__(self, channels: int, *, midstream: bool = False) -> None:
        if not (isinstance(channels, int) and 1 <= channels <= MAX_CHANNELS):
            raise fail("channels", channels, f"a whole number from 1 to {MAX_CHANNELS}")
        self.channels = channels
        self.size = 4 * channels + len(FLOAT_END)
        self._pending = b""
        self._slipping = midstream  # out of step (a port opened mid-frame: not counted)
        self.frames = 0
        self.corrupt = 0

    def feed(self, data: bytes) -> NDArray[np.float64]:
        """Parse ``data``; the samples of its complete frames, shape (n, c), float64."""
        buf = self._pending + data
        size, c = self.size, self.channels
        rows: list[NDArray[np.float32]] = []
        pos = 0
        while len(buf) - pos >= size:
            end = pos + size
            if buf[end - 2:end] == FLOAT_END:
                values = np.frombuffer(buf, dtype="<f4", count=c, offset=pos)
                if np.all(np.isfinite(values)):
                    rows.append(values)
                    pos = end
                    self._slipping = False
                    continue
            nxt = buf.find(FLOAT_END, pos)  # a slip: resume after the next frame end
            if not self._slipping:
                self.corrupt += 1
                self._slipping = True
            if nxt < 0:
                pos = max(pos, len(buf) - 1)  # keep a trailing \r that may start the end
                break
            pos = nxt + len(FLOAT_END)
        self._pending = buf[pos:]
        self.frames += len(rows)
        if not rows:
            return np.zeros((0, c))
        return np.asarray(rows, dtype=np.float64)


@dataclass(frozen=True)
class SerialFormat:
    """What a serial device sends (immutable; ``--format``, ``--fields``, ``--channels``).

    Attributes
    ----------
    format : {"magcilia", "ascii", "floats"}
        magcilia's framed protocol (checked), text lines or float32 frames (unverified).
    fields : str or None
        ``NAME[unit],...`` of the fields (:func:`parse_fields`), unverified formats only.
    channels : int or None
        Values per line or float frame, unverified formats only.
    """

    format: str = "magcilia"
    fields: str | None = None
    channels: int | None = None

    def __post_init__(self) -> None:
        if self.format not in FORMATS:
            raise fail("--format", self.format, "one of " + ", ".join(FORMATS))
        if self.format == "magcilia":
            for name, value in (("--fields", self.fields), ("--channels", self.channels)):
                if value is not None:
                    raise fail(name, value, "given with --format ascii or floats (magcilia's "
                               "frames name their channels)")
        if self.fields is not None:
            parse_fields(self.fields)
        if self.channels is not None and not (isinstance(self.channels, int)
                                              and 1 <= self.channels <= MAX_CHANNELS):
            raise fail("--channels", self.channels, f"a whole number from 1 to {MAX_CHANNELS}")
        if self.format == "floats" and self.fields is None and self.channels is None:
            raise fail("--channels", None, "the number of float32 values per frame (or "
                       "--fields naming them) with --format floats")

    @property
    def verified(self) -> bool:
        """Whether the format carries a checksum (only magcilia's frames do)."""
        return self.format == "magcilia"
