"""CRC-32 checksums of the flushed chunks of magcilia's own recordings: what the writer
(:class:`magcilia.io.recording_file.RecordingWriter`) stores, and how a reader
(:mod:`magcilia.io.tdmsfile`) verifies them.

TDMS has no checksums: a byte of raw data changed in place (a bad disk block, a copy gone wrong)
reads as a measured value. magcilia's recordings carry their own, in a form that readers which
do not know it (npTDMS, LabVIEW, earlier magcilia) read past as one more channel:

- the root property ``checksums = "crc32"`` says that the file has them;
- group ``checksums``, channel ``chunks`` (uint64) holds, in every segment that writes the
  channels of group ``recording`` (each flushed chunk, and the first segment, which declares
  them with no sample), one row of 2 + c values: the index of the chunk's first sample, its
  number of samples, and for each of the c channels of group ``recording``, in the order of the
  channel property ``layout`` (``first_sample,samples,crc32:time_s,crc32:voltage_V,…``), the
  CRC-32 of the chunk's raw bytes of that channel as stored (little-endian float64; int8 for
  ``setreset``). The CRC is the serial protocol's (``zlib.crc32``, ISO-HDLC;
  :mod:`magcilia.acquire.protocol`).
- The row is the last raw data of its segment: a segment cut by a kill has none, so every
  whole segment's chunk verifies and the samples of a cut one are those that the reader's note on
  the cut segment speaks of. Further groups (a read-out's values, events) are not covered.

A reader (:func:`verify_chunks`) checks that the rows follow one another (no chunk missing,
repeated or out of order), that they cover the samples, and each chunk's CRC of each channel
read; a mismatch names the chunk and its samples. Files written by other programs have no such
rows and cannot be checked this way.
"""

from __future__ import annotations

import zlib
from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np
from numpy.typing import NDArray

from magcilia._validate import printable

#: the group, channel and root property of the checksums (see the module docstring)
GROUP = "checksums"
CHANNEL = "chunks"
PROPERTY = "checksums"
KIND = "crc32"
#: the two values of a row before the CRCs
HEAD = ("first_sample", "samples")


def layout(names: Sequence[str]) -> str:
    """The ``layout`` property of rows for the channels ``names`` (in the order written)."""
    return ",".join((*HEAD, *(f"crc32:{n}" for n in names)))


def crc32(values: NDArray[Any]) -> int:
    """CRC-32 of an array's bytes as stored (C order)."""
    return zlib.crc32(np.ascontiguousarray(values).data)


def chunk_row(first: int, arrays: Sequence[NDArray[Any]]) -> NDArray[np.uint64]:
    """The row of a chunk starting at sample ``first`` whose channels hold ``arrays`` (as
    written: shapes (n,)), shape (2 + c,)."""
    n = arrays[0].size if arrays else 0
    return np.array([first, n, *(crc32(a) for a in arrays)], dtype=np.uint64)


def _range(a: int, b: int) -> str:
    return f"samples {a + 1}–{b}" if b > a else "no samples"


def verify_chunks(values: NDArray[Any], layout_text: Any, arrays: Mapping[str, NDArray[Any]],
                  *, cut: bool) -> list[str]:
    """What is wrong with a recording's chunks against their checksums (phrases; empty when
    every chunk verifies).

    Parameters
    ----------
    values : ndarray, shape (r · (2 + c),)
        The ``chunks`` channel as read.
    layout_text : str
        Its ``layout`` property.
    arrays : mapping of str to ndarray, each shape (s,)
        The channels of group ``recording`` to verify, by channel name, as stored (native
        type, not converted).
    cut : bool
        The file's last segment was cut (a kill): the samples after the last whole chunk are
        those of the cut segment and carry no checksum (the cut is noted elsewhere).
    """
    names = str(layout_text).split(",") if isinstance(layout_text, str) else []
    if tuple(names[:2]) != HEAD or not all(n.startswith("crc32:") for n in names[2:]):
        return ["the chunks' checksums are unreadable (their layout property is damaged)"]
    if np.asarray(values).dtype != np.uint64:
        return ["the chunks' checksums are unreadable (their channel's type is damaged)"]
    width = len(names)
    rows = values[:values.size // width * width].reshape(-1, width).astype(np.int64)
    problems = []
    if values.size % width and not cut:
        problems.append("the chunks' checksums end in a partial row (the file is damaged)")
    counts = rows[:, 1]
    bounds = np.concatenate(([0], np.cumsum(counts)))
    numbers = np.cumsum(counts > 0)  # chunk numbers (the first row declares the channels)
    off = np.flatnonzero((rows[:, 0] != bounds[:-1]) | (counts < 0))
    if off.size:
        k = int(off[0])
        problems.append(f"chunk {numbers[k]} of {numbers[-1]} starts at sample {rows[k, 0] + 1} "
                        f"by its checksums, where sample {bounds[k] + 1} is due: chunks are "
                        "missing, repeated or out of order")
        return problems
    column = {n.removeprefix("crc32:"): 2 + i for i, n in enumerate(names[2:])}
    for name, data in arrays.items():
        if name not in column:
            problems.append(f"channel {printable(name)} has no checksums")
            continue
        if data.size < bounds[-1]:
            problems.append(f"channel {printable(name)} holds {data.size:,} values; its "
                            f"chunks' checksums cover {bounds[-1]:,}")
            continue
        stored = rows[:, column[name]]
        wrong = [k for k in range(len(rows))
                 if crc32(data[bounds[k]:bounds[k + 1]]) != stored[k]]
        if wrong:
            k = wrong[0]
            problems.append(
                f"the chunk of {_range(bounds[k], bounds[k + 1])} (chunk {numbers[k]} of "
                f"{numbers[-1]}) of channel "
                f"{printable(name)} does not match its CRC-32 (its raw data changed after it "
                "was written)" + (f"; so do {len(wrong) - 1} more chunk(s)" if len(wrong) > 1
                                  else ""))
        if data.size > bounds[-1] and not cut:
            problems.append(f"the last {data.size - bounds[-1]:,} value(s) of channel "
                            f"{printable(name)} are in no checksummed chunk")
    return problems
