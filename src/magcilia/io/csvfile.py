"""CSV recordings: a fast reader for plain files and a careful reader for everything else.

The format is :mod:`magcilia.io.recordings`' (a header with ``angle_deg`` and ``voltage_V``, one
row per sample). Two readers give the same columns:

- **The fast reader** (:func:`plain_csv_blocks`) parses the data in blocks of
  :data:`CSV_BLOCK_BYTES` (cut at line ends) with pandas' C reader and yields each block's
  columns, so that a caller can reduce as it reads: memory is one block and its columns, whatever
  the file's size. It reads only *plain* files, on which pandas and the careful reader cannot
  differ: the lines up to the header are UTF-8 without a lone carriage return and the header has
  no quote; after it every byte is one of :data:`PLAIN_CSV_BYTES` (digits, signs, separators,
  white space and the letters of nan, inf(inity), set and reset: no quotes, comments, NUL or
  non-ASCII text), line ends are LF or CRLF, no line is longer than the careful reader allows,
  every field of every column (ours and the others) is a number as ``float`` reads it (pandas'
  parser gives the same doubles, and NaN only for ``float``'s spellings of it, never for an
  empty field or a missing one) and every ``setreset`` field is one of :data:`SETRESET_TEXT`.
  Anything else raises :class:`NotPlainCSV`, possibly after some blocks: the caller forgets them
  and asks the careful reader.
- **The careful reader** (:func:`read_csv_carefully`) reads any file line by line with the
  ``csv`` module: comments anywhere, quotes, other text columns; it names the line of anything
  wrong in a one-line error. It is about 20 times slower and holds the whole columns.

A header problem (a missing column, one of ours named twice) is the same error from both.
"""

from __future__ import annotations

import codecs
import csv
import io
import itertools
from array import array
from collections.abc import Iterator
from pathlib import Path
from typing import IO, Any

import numpy as np
from numpy.typing import NDArray

from magcilia._errors import MagciliaError
from magcilia._validate import printable

F64 = NDArray[np.float64]

SETRESET_TEXT = {"set": 1.0, "reset": -1.0, "+1": 1.0, "1": 1.0, "-1": -1.0, "1.0": 1.0,
                 "-1.0": -1.0, "+1.0": 1.0}
#: Bytes the fast reader parses after the header; a file with any other byte is read carefully.
PLAIN_CSV_BYTES = b"0123456789.+-, \t\r\naefinrstyAEFINRSTY"
#: How ``float`` spells NaN (sign and case): the only fields the fast reader takes as NaN.
NAN_TEXT = tuple(sign + "".join(c) for sign in ("", "+", "-")
                 for c in itertools.product("nN", "aA", "nN"))
#: Rows the fast reader parses at a time.
CSV_BLOCK_ROWS = 1 << 20


class NotPlainCSV(Exception):  # noqa: N818 (a signal between the readers, not an error)
    """The fast reader gives up on this file: read it with :func:`read_csv_carefully`."""


def names_text(names: list[str], limit: int = 12) -> str:
    """Names taken from a file, escaped and cut for a one-line message."""
    shown = [printable(n if len(n) <= 40 else n[:40] + "…") for n in names[:limit]]
    more = f", … ({len(names)} in all)" if len(names) > limit else ""
    return (", ".join(shown) or "none") + more


def too_many_samples(path: Path, what: str, limit: int) -> MagciliaError:
    """The error for a recording beyond ``magcilia.io.recordings.MAX_SAMPLES`` (= ``limit``)."""
    return MagciliaError(
        f"{path}: {what} has more than MAX_SAMPLES = {limit:,} samples; split the "
        "recording, or raise magcilia.io.recordings.MAX_SAMPLES for a genuine long one"
    )


def _setreset_value(text: str) -> float | None:
    """+1.0 (set) or −1.0 (reset) for a setreset field, None if it is neither."""
    return SETRESET_TEXT.get(text.strip().lower())


def _column_index(header: list[str], path: Path, columns: tuple[str, ...],
                  required: tuple[str, ...]) -> dict[str, int]:
    """Where each of ``columns`` is in the header (names stripped); a missing required column or
    one of ours named twice is an error."""
    for col in required:
        if col not in header:
            raise MagciliaError(
                f"{path}: missing column {col!r} (header: {names_text(header)}); the CSV needs "
                f"columns {' and '.join(required)}"
            )
    idx: dict[str, int] = {}
    for col in columns:
        at = [i for i, h in enumerate(header) if h == col]
        if len(at) > 1:
            raise MagciliaError(
                f"{path}: column {col!r} appears {len(at)} times in the header (columns "
                f"{', '.join(str(i + 1) for i in at)}); keep one, it is ambiguous which to use"
            )
        if at:
            idx[col] = at[0]
    return idx


# -- the fast reader ----------------------------------------------------------------------------
def plain_csv_blocks(path: Path, columns: tuple[str, ...], required: tuple[str, ...], *,
                     max_samples: int, max_line_chars: int) -> Iterator[dict[str, F64]]:
    """The columns of a plain CSV recording, block by block (at least one block, possibly empty).

    Parameters
    ----------
    path : Path
        The file.
    columns : tuple of str
        The columns to return where the header has them.
    required : tuple of str
        Columns the header must have.
    max_samples, max_line_chars : int
        Most data rows, and most characters per line (with its line end).

    Yields
    ------
    dict of str to ndarray, shape (rows,)
        The columns found among ``columns`` for the next (at most) :data:`CSV_BLOCK_ROWS` rows.

    Raises
    ------
    NotPlainCSV
        Where the file is not plain (see the module docstring), possibly after some blocks.
    MagciliaError
        For a header without a required column or with one of ours twice, and for more rows
        than ``max_samples`` (the careful reader's errors for them).
    """
    import pandas as pd

    limit = min(max_line_chars, csv.field_size_limit())
    with path.open("rb") as f:
        header = _plain_header(f, limit)
        idx = _column_index(header, path, columns, required)
        rows = 0
        try:
            for frame in pd.read_csv(
                    _PlainBytes(f, limit), engine="c", header=None,
                    names=list(range(len(header))),
                    dtype={i: "category" if i == idx.get("setreset") else np.float64
                           for i in range(len(header))},
                    keep_default_na=False, na_values=list(NAN_TEXT), chunksize=CSV_BLOCK_ROWS):
                if not isinstance(frame.index, pd.RangeIndex):  # pandas took the first columns
                    raise NotPlainCSV  # as the index: the first row is longer than the header
                block = {col: _plain_values(frame[i], col == "setreset") for col, i in idx.items()}
                rows += len(frame)
                if rows > max_samples:  # (after the checks of the block's rows, as the careful
                    raise too_many_samples(path, "the file", max_samples)  # reader does)
                yield block
        except MagciliaError:
            raise
        except ValueError:  # pandas: not a number, a row too long or too short, ...
            raise NotPlainCSV from None
        if not rows:  # a header without data rows
            yield {col: np.zeros(0) for col in idx}


class _PlainBytes(io.RawIOBase):
    """The rest of a binary file, as pandas reads it, checked piece by piece: every byte one of
    :data:`PLAIN_CSV_BYTES`, every carriage return followed by a line feed, no line longer than
    ``limit`` characters (with its line end); else :class:`NotPlainCSV`."""

    def __init__(self, f: IO[bytes], limit: int):
        self.f, self.limit, self.line = f, limit, 0  # line: characters of the unfinished line

    def readable(self) -> bool:
        return True

    def read(self, size: int | None = -1) -> bytes:
        data = self.f.read(-1 if size is None else size)
        if data.endswith(b"\r"):  # keep a CRLF whole
            data += self.f.read(1)
        if data.translate(None, PLAIN_CSV_BYTES) or (
                b"\r" in data and data.count(b"\r") != data.count(b"\r\n")):
            raise NotPlainCSV  # a byte we do not parse, or a lone CR (a line end that pandas and
            # the csv module read differently, at least at the start of the data)
        ends = np.flatnonzero(np.frombuffer(data, dtype=np.uint8) == ord("\n"))
        if ends.size:
            longest = max(self.line + int(ends[0]) + 1, int(np.diff(ends).max(initial=0)))
            self.line = len(data) - 1 - int(ends[-1])
        else:
            longest = self.line = self.line + len(data)
        if longest > self.limit:
            raise NotPlainCSV
        return data


def _plain_header(f: IO[bytes], limit: int) -> list[str]:
    """The header's names (stripped) if the lines up to it are plain, ``f`` left after it."""
    line = f.readline(limit + 1).removeprefix(codecs.BOM_UTF8)
    while line and len(line) <= limit and b"\r" not in line.removesuffix(b"\n")[:-1]:
        try:
            text = line.decode()
        except UnicodeDecodeError:
            break
        name = text.strip()
        if name and not name.startswith("#"):
            if '"' in text or "\0" in text:
                break
            return [h.strip() for h in text.split(",")]
        line = f.readline(limit + 1)
    raise NotPlainCSV  # (an empty file too)


def _plain_values(column: Any, setreset: bool) -> F64:
    """A column of a parsed block as doubles (pandas Series, float or categorical)."""
    if not setreset:
        return np.asarray(column.to_numpy(dtype=np.float64))
    codes = column.cat.codes.to_numpy()
    values = [_setreset_value(str(c)) for c in column.cat.categories]
    if None in values or (codes < 0).any():
        raise NotPlainCSV
    return np.array(values, dtype=np.float64)[codes]


# -- the careful reader -------------------------------------------------------------------------
def read_csv_carefully(path: Path, columns: tuple[str, ...], required: tuple[str, ...], *,
                       max_samples: int, max_line_chars: int) -> dict[str, F64]:
    """The columns of any CSV recording, line by line with the ``csv`` module (the parameters
    and the columns returned are :func:`plain_csv_blocks`'): a file that is not a recording is a
    one-line error naming its line."""
    where = [0]
    try:
        with path.open(encoding="utf-8-sig", newline="") as f:
            lines = _csv_lines(f, path, where, max_line_chars)
            return _parse_csv(csv.reader(lines), path, columns, required, where, max_samples)
    except UnicodeDecodeError:
        raise MagciliaError(f"{path}: not a UTF-8 text file (line {_bad_utf8_line(path)}); "
                            "export the recording as CSV") from None
    except csv.Error as exc:  # a field over the csv module's limit, a NUL character, ...
        raise MagciliaError(f"{path}: row {where[0]} is not well-formed CSV "
                            f"({printable(str(exc))}); the file is damaged or not a recording"
                            ) from exc


def _csv_lines(f: IO[str], path: Path, where: list[int], limit: int) -> Iterator[str]:
    """The data lines of an open CSV file (comments and blank lines skipped); ``where[0]`` is the
    number of the line last read. A line longer than ``limit`` is an error."""
    while True:
        line = f.readline(limit + 1)
        if not line:
            return
        where[0] += 1
        if len(line) > limit:
            raise MagciliaError(
                f"{path}: line {where[0]} is longer than MAX_LINE_CHARS = {limit:,} "
                "characters; a recording's lines are short (damaged file?), or raise "
                "magcilia.io.recordings.MAX_LINE_CHARS"
            )
        text = line.strip()
        if text and not text.startswith("#"):
            yield line


def _bad_utf8_line(path: Path) -> int:
    """The number of the first line of ``path`` that is not UTF-8 (0 if every line is)."""
    decode = codecs.getincrementaldecoder("utf-8")()
    line = 1
    with path.open("rb") as f:
        while piece := f.read(1 << 16):
            try:
                decode.decode(piece)
            except UnicodeDecodeError as exc:
                return line + piece[:max(exc.start, 0)].count(b"\n")
            line += piece.count(b"\n")
    return 0


def _quote(text: str, limit: int = 40) -> str:
    """``text`` quoted for a one-line message (control characters escaped), cut at ``limit``."""
    return repr(text if len(text) <= limit else text[:limit] + "…")


def _parse_csv(reader: Iterator[list[str]], path: Path, columns: tuple[str, ...],
               required: tuple[str, ...], where: list[int], max_samples: int
               ) -> dict[str, F64]:
    first = next(reader, None)
    if first is None:
        raise MagciliaError(f"{path}: the file is empty; expected a header with "
                            f"{','.join(required)}")
    header = [h.strip() for h in first]
    idx = _column_index(header, path, columns, required)
    data = {col: array("d") for col in idx}
    for n, row in enumerate(reader):
        if len(row) != len(header):
            raise MagciliaError(
                f"{path}: row {where[0]} has {len(row)} fields, the header has {len(header)} "
                "(truncated or malformed file)"
            )
        if n >= max_samples:
            raise too_many_samples(path, "the file", max_samples)
        for col, i in idx.items():
            text = row[i]
            if col == "setreset":
                value = _setreset_value(text)
                if value is None:
                    raise MagciliaError(f"{path}: row {where[0]}, column setreset: "
                                        f"{_quote(text)} is not set/reset or +1/-1")
            else:
                try:
                    value = float(text)
                except ValueError:
                    raise MagciliaError(f"{path}: row {where[0]}, column {col}: {_quote(text)} "
                                        "is not a number") from None
            data[col].append(value)
    return {col: np.frombuffer(values, dtype=np.float64).copy() if len(values) else np.zeros(0)
            for col, values in data.items()}
