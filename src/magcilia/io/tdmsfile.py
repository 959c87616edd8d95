"""TDMS recordings (``.tdms``, NI LabVIEW; read with the optional npTDMS): the columns, what the
file says about itself, and the damage it shows.

Layout: channels named as the columns (:mod:`magcilia.io.recordings`) in any group, or in the
group named by ``group``; a channel we read must appear in one group only.

**Nothing outside the file.** The file is opened here and handed to npTDMS as an open file, so
npTDMS never opens an index file (``x.tdms_index``) beside it (given a *path*, it reads the
segment metadata from such a file when there is one: a planted index file would decide how the
data file's bytes are cut into channels). A file that is itself an index file (it starts with
``TDSh``) is refused. TDMS has no links to other files.

**Damage is said, not absorbed.** TDMS has no checksums of its own; what can be checked is, in
four layers:

1. the segments' lead-ins (28 bytes each: ``TDSm``, the table of contents, the version, the
   next-segment and raw-data offsets) are walked here (:func:`segments`; a lead-in equal to the
   one before, as a recording's chunks have, is not parsed again): each segment must end where
   the next one begins and the last one at the end of the file, its data must lie inside it, the
   version, byte order and interleaving must be the same in every segment, and bytes of data
   that the table of contents does not announce are damage;
2. npTDMS's own warnings (data that is not a whole number of chunks, a last segment cut short,
   versions that differ, ...), which it logs and would otherwise be lost, are caught and said in
   magcilia's words (:func:`nptdms_warnings`);
3. magcilia's own recordings (the root property ``magcilia_version``,
   :mod:`magcilia.io.recording_file`) are read chunk by chunk (one pass over the segments, into
   arrays of the declared length) and checked further: at most one chunk per segment, every
   channel of group ``recording`` with the same number of values in each chunk, no interleaved
   or big-endian data, and the closing ``samples`` count. Where they have checksums (the root
   property ``checksums``, or the rows themselves where damage hit the properties), every
   flushed chunk of every channel read from group ``recording`` is verified against its CRC-32
   (:mod:`magcilia.io.chunk_checksums`: raw data changed in place, chunks missing, repeated or
   out of order; the rows are taken from the ends of the segments, where npTDMS would read
   them segment by segment in Python). Earlier recordings have none;
4. names of groups and channels holding control characters (a NUL in a name is damage: a column
   whose name was hit would otherwise be silently missing).

Files from other programs carry no checksums: a byte of their raw data changed in place reads as
a value (the quality checks of :mod:`magcilia.io.quality` catch the gross ones).

A finding is an error for a file that says it is complete (the property ``complete`` is True: a
whole magcilia recording, which cannot be damaged without something being wrong) and a note
otherwise (a file from another program, or a recording cut short, whose last segment a kill
leaves cut: its whole samples are kept, and the note says so). What a recording cut short lacks
(planned angles never reached) is said by :mod:`magcilia.io.recording_state`.
"""

from __future__ import annotations

import contextlib
import io
import logging
import os
import struct
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import IO, Any, NamedTuple

import numpy as np
from numpy.typing import NDArray

from magcilia._errors import MagciliaError, require
from magcilia._validate import printable
from magcilia.io import chunk_checksums
from magcilia.io.columns import Columns, scaled
from magcilia.io.csvfile import names_text, too_many_samples
from magcilia.io.recording_state import RawRecording, RecordingState

F64 = NDArray[np.float64]
#: the group of a magcilia recording's samples (written by :mod:`magcilia.io.recording_file`)
GROUP = "recording"

#: bytes of a segment's lead-in
LEAD_IN = 28
#: table-of-contents bits (NI, "TDMS file format internal structure")
TOC_META, TOC_RAW, TOC_INTERLEAVED, TOC_BIG_ENDIAN, TOC_DAQMX = 0x2, 0x8, 0x20, 0x40, 0x80
#: the next-segment offset of a segment whose writer stopped before it could write its length
UNKNOWN_LENGTH = 0xFFFF_FFFF_FFFF_FFFF
#: TDMS versions (2.0 and 1.0)
VERSIONS = (4713, 4712)


def nptdms_module(purpose: str = "Reading TDMS files") -> Any:
    """The optional npTDMS package, or a one-line error naming the ``tdms`` extra."""
    return require("nptdms", package="npTDMS", extra="tdms", purpose=purpose)


def _nptdms_loggers() -> list[logging.Logger]:
    """npTDMS's loggers (it sets a level on each of its modules' loggers)."""
    names = [n for n in list(logging.Logger.manager.loggerDict)
             if n == "nptdms" or n.startswith("nptdms.")]
    return [logging.getLogger(n) for n in names or ["nptdms"]]


@contextlib.contextmanager
def quiet_nptdms() -> Iterator[None]:
    """npTDMS's log messages silenced, for callers that say what matters themselves (a
    recording's properties: :func:`magcilia.io.recording_file.recording_properties`)."""
    with nptdms_warnings():
        yield


class _Collect(logging.Handler):
    def __init__(self, into: list[str]) -> None:
        super().__init__(logging.WARNING)
        self.into = into

    def emit(self, record: logging.LogRecord) -> None:
        with contextlib.suppress(Exception):  # logging must never raise into the reader
            self.into.append(record.getMessage())


@contextlib.contextmanager
def nptdms_warnings() -> Iterator[list[str]]:
    """npTDMS's warnings while inside, collected (raw text) instead of printed; the caller says
    them in magcilia's words (:func:`warning_note`)."""
    found: list[str] = []
    handler = _Collect(found)
    loggers = _nptdms_loggers()
    saved = [(log.level, log.propagate, log.handlers) for log in loggers]
    for log in loggers:  # npTDMS's own console handler set aside: it would print them
        log.setLevel(logging.WARNING)
        log.propagate = False
        log.handlers = [handler]
    try:
        yield found
    finally:
        for log, (level, propagate, handlers) in zip(loggers, saved, strict=True):
            log.handlers = handlers
            log.setLevel(level)
            log.propagate = propagate


#: npTDMS's warnings (their starts) in magcilia's words
_WARNINGS = (
    ("Last segment metadata is incomplete",
     ("the last segment's metadata is cut short (the file ends inside it); that segment is "
     "left out")),
    ("Last segment of file has less data than expected",
     "the last segment holds less data than its lead-in declares (the file ends inside it)"),
    ("Data size", ("a segment's data is not a whole number of chunks of its channels (its last "
                  "values were read from a partial chunk)")),
    ("Segment version mismatch", "the segments' TDMS versions differ"),
    ("Unrecognised version number", "the TDMS version number is unknown"),
    ("Cropping data", "interleaved data was cut to whole rows"),
    ("Error decoding string", "a name or text property is not UTF-8"),
    ("Unsupported scale type", "a channel's scaling is of a kind npTDMS does not apply"),
)


def warning_note(message: str) -> str:
    """One of npTDMS's warnings in magcilia's words (an unknown one quoted, cut to one line)."""
    for start, words in _WARNINGS:
        if message.startswith(start):
            return words
    return f"npTDMS warns: {printable(message)[:160]}"


class Segment(NamedTuple):
    """A TDMS segment as its lead-in describes it: start, table of contents, version, where its
    raw data starts and where the segment ends (absolute byte positions; ``end`` is None for a
    segment whose length was never written)."""

    position: int
    toc: int
    version: int
    data: int
    end: int | None

    @property
    def big_endian(self) -> bool:
        return bool(self.toc & TOC_BIG_ENDIAN)

    @property
    def interleaved(self) -> bool:
        return bool(self.toc & TOC_INTERLEAVED)


def _reader(file: IO[bytes]) -> Callable[[int, int], bytes]:
    """``read(n, position)``: bytes of the file at a position, without moving it (``os.pread``
    where the file has a descriptor; no mapping, whose pages would count as the process's)."""
    try:
        fd = file.fileno()
        os.pread(fd, 0, 0)
    except (OSError, AttributeError, io.UnsupportedOperation):
        def read(n: int, position: int) -> bytes:
            file.seek(position)
            return file.read(n)
        return read
    return lambda n, position: os.pread(fd, n, position)


def segments(file: IO[bytes], size: int, limit: int = 1 << 24) -> tuple[list[Segment], list[str]]:
    """Walk the segments of a TDMS file by their lead-ins (nothing else is parsed): the segments
    and what is wrong with the structure (phrases, empty for a sound file). A lead-in equal to
    the one before (a recording's chunks) is not parsed again.

    Parameters
    ----------
    file : binary file
        The open ``.tdms`` file (its position is changed).
    size : int
        The file's size, bytes.
    limit : int
        Most segments walked (a bound on work; the rest is not checked).
    """
    found: list[Segment] = []
    problems: list[str] = []
    read = _reader(file)
    pos, last = 0, b""
    while pos < size and len(found) < limit:
        head = read(LEAD_IN, pos)
        if head == last:  # like the segment before, which was sound (a recording's chunks)
            before = found[-1]
            step = (before.end or size) - before.position
            if pos + step <= size:
                found.append(Segment(pos, before.toc, before.version,
                                     pos + before.data - before.position, pos + step))
                pos += step
                continue
        said = len(problems)
        if len(head) < LEAD_IN:
            problems.append(f"{len(head)} stray bytes after the last segment (byte {pos}; a "
                            "lead-in is 28 bytes)")
            break
        if head[:4] != b"TDSm":
            problems.append(f"the segment at byte {pos} does not start with 'TDSm'")
            break
        toc = struct.unpack_from("<I", head, 4)[0]
        order = ">" if toc & TOC_BIG_ENDIAN else "<"
        version, next_offset, raw_offset = struct.unpack_from(order + "IQQ", head, 8)
        end = None if next_offset == UNKNOWN_LENGTH else pos + LEAD_IN + next_offset
        segment = Segment(pos, toc, version, pos + LEAD_IN + raw_offset, end)
        found.append(segment)
        if end is not None and raw_offset > next_offset:
            problems.append(f"the segment at byte {pos} places its data ({raw_offset:,} bytes "
                            f"on) beyond its end ({next_offset:,} bytes on)")
        if end is None:
            problems.append(f"the segment at byte {pos} never had its length written (the "
                            "writer stopped inside it)")
            break
        if end > size:
            problems.append(f"the last segment (byte {pos}) declares {end - pos:,} bytes; the "
                            f"file holds {size - pos:,} of them (it was cut)")
            break
        if not toc & TOC_RAW and end > segment.data and not toc & TOC_DAQMX:
            problems.append(f"the segment at byte {pos} holds {end - segment.data:,} bytes of "
                            "data its table of contents does not announce")
        last = head if len(problems) == said else b""  # (each unsound segment is said)
        pos = end
    if found:
        first = found[0]
        for what, key in (("TDMS versions", lambda s: s.version),
                          ("byte orders", lambda s: s.toc & TOC_BIG_ENDIAN),
                          ("interleaving", lambda s: s.toc & TOC_INTERLEAVED)):
            if len({key(s) for s in found}) > 1:
                other = next(s for s in found if key(s) != key(first))
                problems.append(f"the segments differ in their {what} (byte {first.position} and "
                                f"byte {other.position})")
        if first.version not in VERSIONS:
            problems.append(f"the TDMS version {first.version} is unknown (4712 or 4713)")
    return found, problems


def _locate(path: Path, tdms: Any, columns: Columns, required: tuple[str, ...],
            wanted: str) -> dict[str, tuple[str, Any, float]]:
    """key -> (group name, channel, unit factor) of the channels to read."""
    places: dict[str, list[tuple[str, Any]]] = {}
    groups = tdms.groups()
    if wanted:
        names = [str(g.name) for g in groups]
        if wanted not in names:
            raise MagciliaError(f"{path}: no group {printable(wanted)!r} (groups: "
                                f"{names_text(names)}); pass one of them as the group")
        groups = [g for g in groups if str(g.name) == wanted]
    for group in groups:
        for channel in group.channels():
            places.setdefault(str(channel.name), []).append((str(group.name), channel))
    everything = list(places)
    located = columns.locate(everything, where=str(path), required=required, kind="channel")
    chosen: dict[str, tuple[str, Any, float]] = {}
    for key, (i, factor) in located.items():
        name, where = everything[i], places[everything[i]]
        if len(where) > 1:
            raise MagciliaError(
                f"{path}: channel {printable(name)} appears in {len(where)} groups "
                f"({names_text([g for g, _ in where])}); keep it in one group, it is ambiguous "
                "which to use (or pass the group)"
            )
        chosen[key] = (where[0][0], where[0][1], factor)
    return chosen


def _check_channel(path: Path, group: str, channel: Any, size: int, max_samples: int) -> None:
    """A channel's type and declared length, checked before its data is read."""
    name = str(channel.name)
    what = f"{path}: channel {printable(name)} (group {printable(group)})"
    dtype = np.dtype(channel.dtype)
    if dtype.kind not in "biuf":
        raise MagciliaError(f"{what} holds {channel.data_type.__name__} values, not real "
                            "numbers; store the samples as numbers")
    n = len(channel)
    if n > max_samples:
        raise too_many_samples(path, f"channel {printable(name)}", max_samples)
    if n * dtype.itemsize > size:
        raise MagciliaError(f"{what} declares {n:,} values, more than the file's {size:,} bytes "
                            "can hold; the file is damaged")


def _read_native(path: Path, chosen: dict[str, tuple[str, Any, float]]) -> dict[str, Any]:
    """The channels read whole, as stored (their own types)."""
    out: dict[str, Any] = {}
    for key, (group, channel, _) in chosen.items():
        n = len(channel)
        data = np.asarray(channel[:]).ravel()
        if data.size != n:
            raise MagciliaError(f"{path}: channel {printable(str(channel.name))} (group "
                                f"{printable(group)}) holds {data.size:,} of the {n:,} values "
                                "it declares; the file is damaged")
        out[key] = data
    return out


def _as_columns(native: dict[str, Any], chosen: dict[str, tuple[str, Any, float]]
                ) -> dict[str, F64]:
    """Channels as read, in doubles and the unit of their key."""
    return {key: scaled(np.asarray(data, dtype=np.float64), chosen[key][2])
            for key, data in native.items()}


def _has_checksums(tdms: Any) -> bool:
    """Whether a file has (or says it has) the chunks' checksums of a magcilia recording."""
    if tdms.properties.get(chunk_checksums.PROPERTY) is not None:
        return True
    try:
        layout = tdms[chunk_checksums.GROUP][chunk_checksums.CHANNEL].properties.get("layout")
    except KeyError:
        return False
    return isinstance(layout, str) and layout.startswith(",".join(chunk_checksums.HEAD))


def _near_misses(tdms: Any, columns: Columns, chosen: dict[str, tuple[str, Any, float]]
                 ) -> list[str]:
    """Channels left unread whose name is one character from the name of a column not found:
    a name hit by damage (a flipped bit) would otherwise drop the column silently."""
    wanted = {name for key, name in columns.names().items() if key not in chosen}
    out = []
    for group in tdms.groups():
        for channel in group.channels():
            name = str(channel.name)
            for want in wanted:
                if len(name) == len(want) and sum(a != b for a, b in zip(name, want,
                                                                         strict=True)) == 1:
                    out.append(f"channel {printable(name)} (group {printable(str(group.name))}) "
                               f"is one character from {printable(want)} and is not read: a "
                               "damaged name (or map it with columns=)")
    return out


def _row_tails(file: IO[bytes], size: int, found: list[Segment], width: int,
               declared: int) -> NDArray[np.uint64] | None:
    """The checksum rows of a magcilia recording taken from the ends of its segments' raw data
    (the row is each segment's last raw data), when the segments holding raw data are as many
    as the rows that npTDMS counts (else None: npTDMS reads them)."""
    ends = [s.end for s in found if s.end is not None and s.data < s.end <= size]
    starts = [s.data for s in found if s.end is not None and s.data < s.end <= size]
    if len(ends) * width != declared or any(
            e - d < 8 * width for e, d in zip(ends, starts, strict=True)):
        return None
    read = _reader(file)
    tails = b"".join(read(8 * width, e - 8 * width) for e in ends)
    return np.frombuffer(tails, dtype="<u8").astype(np.uint64)


def _checksummed(tdms: Any, chosen: dict[str, tuple[str, Any, float]], native: dict[str, Any],
                 tails: Callable[[int, int], NDArray[np.uint64] | None], cut: bool
                 ) -> list[str]:
    """What the chunks' checksums say of the channels read from group ``recording`` of a
    magcilia recording that has them (:mod:`magcilia.io.chunk_checksums`); ``tails(width,
    declared)`` reads the rows from the ends of the segments where it can (npTDMS reads a
    channel segment by segment in Python)."""
    try:
        channel = tdms[chunk_checksums.GROUP][chunk_checksums.CHANNEL]
    except KeyError:
        return ["the chunks' checksums are missing (the file says it has them)"]
    layout = channel.properties.get("layout")
    width = len(layout.split(",")) if isinstance(layout, str) else 0
    values = (tails(width, len(channel)) if width and np.dtype(channel.dtype) == np.uint64
              else None)
    if values is None:
        values = np.asarray(channel[:]).ravel()
    mine = {str(ch.name): native[key] for key, (group, ch, _) in chosen.items()
            if group == GROUP}
    return chunk_checksums.verify_chunks(values, layout, mine, cut=cut)


def _read_chunks(tdms: Any, chosen: dict[str, tuple[str, Any, float]], data_segments: int,
                 problems: list[str], cut: bool) -> dict[str, Any]:
    """The channels of a magcilia recording read chunk by chunk (one pass over the segments:
    npTDMS reads a whole channel segment by segment, once per channel), as stored, into arrays
    of the length the metadata declares; checking that each chunk holds the same number of
    values of every channel read of the ``recording`` group (but the last one of a file ``cut``
    inside it), and that there are no more chunks than segments with data (the writer makes one
    chunk per segment)."""
    out = {key: np.empty(len(channel), dtype=channel.dtype)
           for key, (_, channel, _) in chosen.items()}
    filled = dict.fromkeys(chosen, 0)
    chunks = 0
    uneven = None
    for chunk in tdms.data_chunks():
        chunks += 1
        lengths = {}
        for key, (group, channel, _) in chosen.items():
            values = np.asarray(chunk[group][str(channel.name)][:]).ravel()
            at = filled[key]
            if at + values.size > out[key].size:  # (more values than declared: damage)
                out[key] = np.concatenate([out[key][:at], values])
            else:
                out[key][at:at + values.size] = values
            filled[key] = at + values.size
            if group == GROUP:
                lengths[key] = values.size
        if uneven is None and len(set(lengths.values())) > 1:
            uneven = chunks
    if uneven is not None and not (cut and uneven == chunks):
        problems.append(f"chunk {uneven} holds different numbers of values of the channels "
                        "(the table of contents or a channel's length is damaged)")
    if chunks > data_segments:
        problems.append(f"the data are cut into {chunks} chunks in {data_segments} segments; "
                        "magcilia writes one chunk per segment (a channel's length is damaged)")
    return {key: out[key][:filled[key]] for key in chosen}


def read_tdms(path: Path, columns: Columns, required: tuple[str, ...], *, group: str = "",
              max_samples: int) -> RawRecording:
    """The columns of a TDMS recording, by key (``angle_deg``, ``voltage_V``, ...) in deg, V, s
    and T, with what the file says about itself and the notes on its damage (see the module
    docstring).

    Parameters
    ----------
    path : Path
        The ``.tdms`` file.
    columns : Columns
        Which channel holds which role, with units.
    required : tuple of str
        Keys that must be found.
    group : str
        The group holding the channels ("" for any group).
    max_samples : int
        Most values per channel.

    Raises
    ------
    MagciliaError
        One line naming the file and what is wrong: a channel missing, ambiguous or not numbers;
        damage in a file that says it is complete; a recording cut before its first chunk.
    MissingDependencyError
        Without npTDMS (the ``tdms`` extra).
    """
    nptdms = nptdms_module()
    size = path.stat().st_size
    with path.open("rb") as file:
        if file.read(4) == b"TDSh":
            raise MagciliaError(f"{path}: a TDMS index file (it starts with 'TDSh'), not a "
                                "recording; read the .tdms data file it belongs to")
        found, problems = segments(file, size)
        file.seek(0)
        with nptdms_warnings() as warned, nptdms.TdmsFile.open(file) as tdms:
            state = RecordingState.from_properties(dict(tdms.properties))
            garbled = [str(o.name) for g in tdms.groups() for o in (g, *g.channels())
                       if not str(o.name).isprintable()]
            if garbled:  # (a genuine name never holds NUL or control characters)
                problems.append(f"{len(garbled)} group or channel name(s) hold control "
                                f"characters ({printable(garbled[0])[:60]}): damaged metadata; "
                                "a column under such a name is not read")
            try:
                chosen = _locate(path, tdms, columns, required, group.strip("/"))
            except MagciliaError:  # a recording cut before its channels (or before any value)
                state.require_samples(path, sum(len(c) for g in tdms.groups()
                                                for c in g.channels()))
                raise
            for key in chosen:
                g, channel, _ = chosen[key]
                _check_channel(path, g, channel, size, max_samples)
            problems += _near_misses(tdms, columns, chosen)
            cut_inside = bool(found) and (found[-1].end is None or found[-1].end > size)
            if state.own and any(s.big_endian or s.interleaved for s in found):
                problems.append("a segment's table of contents marks its data big-endian or "
                                "interleaved, which magcilia never writes")
            checksummed = _has_checksums(tdms)  # (also where damage hit the own-file property)
            if state.own or checksummed:  # magcilia's: chunk by chunk, and their checksums
                data_segments = sum(1 for s in found if s.end is None or s.end > s.data)
                native = _read_chunks(tdms, chosen, data_segments, problems, cut_inside)
                if checksummed:
                    problems += _checksummed(tdms, chosen, native, lambda width, declared: (
                        _row_tails(file, size, found, width, declared)), cut_inside)
            else:
                native = _read_native(path, chosen)
            out = _as_columns(native, chosen)
    notes = list(dict.fromkeys([*problems, *(warning_note(w) for w in warned)]))
    if state.complete is False and out:  # a magcilia recording cut short (a crash): its last
        # segment may end inside a channel; the samples in every channel are whole
        n = min(a.size for a in out.values())
        cut = max(a.size for a in out.values()) - n
        out = {k: a[:n] for k, a in out.items()}
        if cut:
            notes.append(f"the last {cut} value(s) of the longer channels (samples cut in half "
                         "by the stop) were left out")
    n = min((a.size for a in out.values()), default=0)
    state.require_samples(path, n)
    if state.samples is not None and state.complete and n != state.samples and "recording" in {
            g for g, _, _ in chosen.values()}:
        notes.append(f"the file holds {n:,} samples; its closing note says {state.samples:,}")
    if notes and state.complete:
        raise MagciliaError(f"{path}: the file says it is complete, but {notes[0]}"
                            + (f" (and {len(notes) - 1} more finding(s))" if len(notes) > 1
                               else "")
                            + "; the file is damaged: copy it again from where it was recorded")
    return RawRecording(out, tuple(notes), state)
