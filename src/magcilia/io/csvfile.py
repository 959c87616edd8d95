"""CSV recordings: a fast reader for plain files and a careful reader for everything else.

The format is :mod:`magcilia.io.recordings`' (a header with ``angle_deg`` and ``voltage_V``, one
row per sample). Two readers give the same columns:

- **The fast reader** (:func:`plain_csv_blocks`) parses the data in blocks of
  :data:`CSV_BLOCK_ROWS` with NumPy's C reader or pandas' (:mod:`magcilia.io.csvparsers`:
  NumPy for a file of up to 64 MB with a decimal point, a one-character delimiter and no
  ``setreset`` column, where importing pandas costs more than NumPy's parse) and yields each
  block's columns, so that a caller can reduce as it reads: memory is one block and its columns
  whatever the file's size (NumPy's parse holds the rest of its file, at most 64 MB, at once).
  It reads only *plain* files, on which
either parser and the careful reader cannot differ: the lines up to the header are UTF-8
  without a lone carriage return and the header has no quote; after it every byte is one of
  :data:`PLAIN_CSV_BYTES` (digits, signs, separators, white space and the letters of nan,
  inf(inity), set and reset: no quotes, comments, NUL or non-ASCII text), line ends are LF or
  CRLF, no line is longer than the careful reader allows, every field of every column (ours and
  the others) is a number as ``float`` reads it (pandas' parser gives the same doubles, and NaN
  only for ``float``'s spellings of it, never for an empty field or a missing one) and every
  ``setreset`` field is one of :data:`SETRESET_TEXT`. Anything else raises :class:`NotPlainCSV`,
  possibly after some blocks: the caller forgets them and asks the careful reader.
- **The careful reader** (:func:`read_csv_carefully`) reads any file line by line with the
  ``csv`` module: comments anywhere, quotes, other text columns; it names the line of anything
  wrong in a one-line error. It is about 20 times slower and holds the whole columns. Its numbers
  follow the fast reader's grammar (:data:`NUMBER`: ASCII digits, an optional decimal mark and
  exponent, nan and inf(inity)), not all of Python's ``float`` (``1_0`` is not ten, ``١٢`` not
  twelve), and a line that starts with a spreadsheet's error value (``#N/A``, ``#VALUE!``,
  :data:`SPREADSHEET_ERROR`) is a row whose field is not a number, not a comment.

A header problem (a missing column, one of ours named twice) is the same error from both.

Delimiter and decimal mark
--------------------------
Both readers take the ``delimiter`` (``","``, ``";"``, tab, or runs of white space; by default
sniffed from the header line: a tab if it has one, else a semicolon, else a comma, else white
space) and the ``decimal`` mark (``"."`` or ``","``: European exports write ``1,25`` with ``;``
between fields). pandas parses them with its ``sep`` and ``decimal``; the careful reader with
the ``csv`` module (``str.split`` for white space, whose fields cannot be quoted) and ``float``
after replacing the comma. With ``decimal=","`` a field with a decimal point is an error, and
with ``"."`` one that would be a number with a decimal comma is an error that says so: neither
is read as something else. A comma for both is read carefully only (its numbers are quoted).
"""

from __future__ import annotations

import codecs
import csv
import io
import itertools
import re
from array import array
from collections.abc import Callable, Iterator, Mapping
from pathlib import Path
from typing import IO, Any

import numpy as np
from numpy.typing import NDArray

from magcilia._atomic import write_text
from magcilia._errors import MagciliaError
from magcilia._validate import fail, printable
from magcilia.io.csvparsers import numpy_frames, numpy_parses, pandas_frames

F64 = NDArray[np.float64]

SETRESET_TEXT = {"set": 1.0, "reset": -1.0, "+1": 1.0, "1": 1.0, "-1": -1.0, "1.0": 1.0,
                 "-1.0": -1.0, "+1.0": 1.0}
#: Bytes the fast reader parses after the header; a file with any other byte is read carefully.
PLAIN_CSV_BYTES = b"0123456789.+-,; \t\r\naefinrstyAEFINRSTY"
#: How ``float`` spells NaN (sign and case): the only fields the fast reader takes as NaN.
NAN_TEXT = tuple(sign + "".join(c) for sign in ("", "+", "-")
                 for c in itertools.product("nN", "aA", "nN"))
#: A number as both readers read it (after the decimal comma is made a point): ASCII digits, an
#: optional decimal point and exponent, or nan/inf/infinity, with a sign and spaces or tabs
#: around.
NUMBER = re.compile(r"[ \t]*[+-]?(?:(?:[0-9]+\.?[0-9]*|\.[0-9]+)(?:[eE][+-]?[0-9]+)?"
                    r"|[iI][nN][fF](?:[iI][nN][iI][tT][yY])?|[nN][aA][nN])[ \t]*")
#: A spreadsheet's error value at the start of a line (``#N/A``, ``#VALUE!``, ``#DIV/0!``, ...):
#: a data row with a field that is not a number, not a comment.
SPREADSHEET_ERROR = re.compile(r'"?#(?:N/A|[A-Z][A-Z0-9/_]*[!?])(?:"|[ \t,;]|$)')
#: Rows the fast reader yields at a time (pandas' blocks; NumPy's parse is cut to it).
CSV_BLOCK_ROWS = 1 << 20
#: Delimiters by the names the readers take (" " stands for runs of white space).
DELIMITERS = {",": ",", ";": ";", "\t": "\t", "tab": "\t", "whitespace": " ", " ": " "}
#: Decimal marks the readers take.
DECIMALS = (".", ",")

#: A header's names -> where each column read is (key -> index); raises for a bad header.
Locate = Callable[[list[str]], dict[str, int]]
#: Progress of a read: (bytes read so far, file size).
Progress = Callable[[int, int], None]


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


def delimiter_of(value: str | None) -> str | None:
    r"""A ``delimiter`` argument checked: None (sniff it), ``","``, ``";"``, ``"\t"`` or
    ``" "`` (white space); ``"auto"``, ``"tab"`` and ``"whitespace"`` are the names the CLI
    takes."""
    if value is None or value == "auto":
        return None
    if not isinstance(value, str) or value not in DELIMITERS:
        raise fail("delimiter", value, "auto, ',', ';', tab or whitespace")
    return DELIMITERS[value]


def decimal_of(value: str) -> str:
    """A ``decimal`` argument checked: ``"."`` or ``","``."""
    if value not in DECIMALS:
        raise fail("decimal", value, "'.' or ',' (a decimal comma)")
    return value


def sniff_delimiter(header: str) -> str:
    r"""The delimiter of a header line: a tab if it has one, else ``;``, else ``,``, else white
    space (``" "``).

    >>> [sniff_delimiter(h) for h in ("a\tb c", "a;b,c", "a,b", "a  b", "a")]
    ['\t', ';', ',', ' ', ',']
    """
    for delim in ("\t", ";", ","):
        if delim in header:
            return delim
    return " " if len(header.split()) > 1 else ","


def split_header(text: str, delimiter: str) -> list[str]:
    """A header line without quotes as its names (stripped)."""
    return text.split() if delimiter == " " else [h.strip() for h in text.split(delimiter)]


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
                     max_samples: int, max_line_chars: int, delimiter: str | None = None,
                     decimal: str = ".", locate: Locate | None = None,
                     progress: Progress | None = None) -> Iterator[dict[str, F64]]:
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
    delimiter : {None, ",", ";", "\\t", " "}
        Between fields (" ": runs of white space); None sniffs it from the header line.
    decimal : {".", ","}
        The decimal mark.
    locate : callable, optional
        The header's names -> where each column to return is (key -> index), raising for a bad
        header; replaces ``columns`` and ``required`` (the column and unit mapping).
    progress : callable, optional
        Called as ``progress(bytes_read, file_size)`` after each block.

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
    limit = min(max_line_chars, csv.field_size_limit())
    size = path.stat().st_size
    with path.open("rb") as f:
        header, delim = _plain_header(f, limit, delimiter)
        idx = (_column_index(header, path, columns, required) if locate is None
               else locate(header))
        if delim == decimal:  # (numbers quoted: the careful reader's)
            raise NotPlainCSV
        setreset = idx.get("setreset")
        parse = numpy_frames if numpy_parses(delim, decimal, size, setreset) else pandas_frames
        rows = 0
        try:
            for frame in parse(_PlainBytes(f, limit), len(header), delim, decimal, setreset,
                               CSV_BLOCK_ROWS, NAN_TEXT):
                block = {col: _plain_values(frame[i], col == "setreset")
                         for col, i in idx.items()}
                rows += len(frame[0])
                if rows > max_samples:  # (after the checks of the block's rows, as the careful
                    raise too_many_samples(path, "the file", max_samples)  # reader does)
                if progress is not None:
                    progress(min(f.tell(), size), size)
                yield block
        except MagciliaError:
            raise
        except ValueError:  # a parser's: not a number, a row too long or too short, ...
            raise NotPlainCSV from None
        if not rows:  # a header without data rows
            yield {col: np.zeros(0) for col in idx}


def plain_csv_columns(path: Path, columns: tuple[str, ...], required: tuple[str, ...], *,
                      progress: Progress | None = None,
                      on_block: Callable[[dict[str, F64]], None] | None = None,
                      **options: Any) -> dict[str, F64]:
    """The columns of a plain CSV recording, whole: :func:`plain_csv_blocks`' blocks (same
    parameters and errors) copied into arrays sized from the first block's share of the file
    (5 % more; grown by half where a file's later rows are shorter), so that the columns are
    held once while the file is read, not as blocks and again joined. ``on_block`` is called
    with each block after it is copied (a reduction that follows the reading works on data still
    in cache)."""
    size = max(path.stat().st_size, 1)
    read = [0]

    def seen(done: int, total: int) -> None:
        read[0] = done
        if progress is not None:
            progress(done, total)

    out: dict[str, F64] = {}
    n = 0
    for block in plain_csv_blocks(path, columns, required, progress=seen, **options):
        k = len(next(iter(block.values()))) if block else 0
        capacity = len(next(iter(out.values()))) if out else 0
        if n + k > capacity or not out:
            rows = n + k
            guess = int(rows * size / read[0] * 1.05) + 1024 if read[0] > 0 else rows
            grown = max(rows, guess, capacity + capacity // 2 if out else 0)
            for col, arr in block.items():  # (untouched rows cost no memory)
                bigger = np.empty(grown, dtype=arr.dtype)
                bigger[:n] = out[col][:n] if col in out else 0.0
                out[col] = bigger
        for col, arr in block.items():
            out[col][n:n + k] = arr
        n += k
        if on_block is not None:
            on_block(block)
    return {col: arr[:n] for col, arr in out.items()}


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
        first = data.find(b"\n")
        if first < 0:
            longest = self.line = self.line + len(data)
        else:
            longest = self.line + first + 1
            last = data.rfind(b"\n")
            half = max(1, self.limit // 2)  # a line longer than the limit between two line ends
            # holds one of these stretches of half the limit without a line end (most data: none)
            if any(data.find(b"\n", a, a + half) < 0 for a in range(first, last - half + 1, half)):
                ends = np.flatnonzero(np.frombuffer(data, dtype=np.uint8) == ord("\n"))
                longest = max(longest, int(np.diff(ends).max(initial=0)))
            self.line = len(data) - 1 - last
        if longest > self.limit:
            raise NotPlainCSV
        return data


def _plain_header(f: IO[bytes], limit: int, delimiter: str | None) -> tuple[list[str], str]:
    """The header's names (stripped) and the delimiter (``delimiter``, or sniffed) if the lines
    up to it are plain, ``f`` left after it."""
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
            delim = delimiter or sniff_delimiter(name)
            return split_header(text, delim), delim
        line = f.readline(limit + 1)
    raise NotPlainCSV  # (an empty file too)


def _plain_values(column: Any, setreset: bool) -> F64:
    """A column of a parsed block as doubles (NumPy's array, or a pandas Series: float or
    categorical)."""
    if isinstance(column, np.ndarray):
        return column
    if not setreset:
        return np.asarray(column.to_numpy(dtype=np.float64))
    codes = column.cat.codes.to_numpy()
    values = [_setreset_value(str(c)) for c in column.cat.categories]
    if None in values or (codes < 0).any():
        raise NotPlainCSV
    return np.array(values, dtype=np.float64)[codes]


# -- the careful reader -------------------------------------------------------------------------
def read_csv_carefully(path: Path, columns: tuple[str, ...], required: tuple[str, ...], *,
                       max_samples: int, max_line_chars: int, delimiter: str | None = None,
                       decimal: str = ".", locate: Locate | None = None,
                       progress: Progress | None = None) -> dict[str, F64]:
    """The columns of any CSV recording, line by line with the ``csv`` module (the parameters
    and the columns returned are :func:`plain_csv_blocks`'; ``progress`` is called every 65,536
    rows with the characters read so far): a file that is not a recording is a one-line error
    naming its line."""
    where = [0, 0]  # the number of the line last read, characters read
    size = path.stat().st_size
    try:
        with path.open(encoding="utf-8-sig", newline="") as f:
            lines = _csv_lines(f, path, where, max_line_chars)
            first = next(lines, None)
            if first is None:
                raise MagciliaError(f"{path}: the file is empty; expected a header with "
                                    f"{','.join(required)}")
            delim = delimiter or sniff_delimiter(first.strip())
            rows: Iterator[list[str]] = (
                (line.split() for line in itertools.chain([first], lines)) if delim == " "
                else csv.reader(itertools.chain([first], lines), delimiter=delim))
            return _parse_csv(rows, path, columns, required, where, max_samples,
                              decimal=decimal, locate=locate,
                              progress=None if progress is None
                              else lambda: progress(min(where[1], size), size))
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
        where[1] += len(line)
        if len(line) > limit:
            raise MagciliaError(
                f"{path}: line {where[0]} is longer than MAX_LINE_CHARS = {limit:,} "
                "characters; a recording's lines are short (damaged file?), or raise "
                "magcilia.io.recordings.MAX_LINE_CHARS"
            )
        text = line.strip()
        if text and (not text.startswith("#") or SPREADSHEET_ERROR.match(text)):
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


def _number(text: str, decimal: str) -> float:
    """A field as a double (``decimal``: the decimal mark); ValueError if it is not a number."""
    if decimal == ",":
        if "." in text:
            raise ValueError(text)
        text = text.replace(",", ".")
    if not NUMBER.fullmatch(text):
        raise ValueError(text)
    return float(text)


def _not_a_number(path: Path, row: int, col: str, text: str, decimal: str) -> MagciliaError:
    """The error for a field that is not a number, with the decimal mark it seems to need."""
    hint = ""
    if decimal == "." and "," in text:
        try:
            _number(text.strip(), ",")
            hint = "; a decimal comma? pass decimal=',' (CLI: --decimal ,)"
        except ValueError:
            pass
    elif decimal == "," and "." in text:
        hint = " with a decimal comma (decimal=','); for a decimal point pass decimal='.'"
    return MagciliaError(f"{path}: row {row}, column {col}: {_quote(text)} is not a number"
                         f"{hint}")


def _parse_csv(reader: Iterator[list[str]], path: Path, columns: tuple[str, ...],
               required: tuple[str, ...], where: list[int], max_samples: int, *,
               decimal: str = ".", locate: Locate | None = None,
               progress: Callable[[], None] | None = None) -> dict[str, F64]:
    first = next(reader, None)
    if first is None:
        raise MagciliaError(f"{path}: the file is empty; expected a header with "
                            f"{','.join(required)}")
    header = [h.strip() for h in first]
    idx = _column_index(header, path, columns, required) if locate is None else locate(header)
    data = {col: array("d") for col in idx}
    for n, row in enumerate(reader):
        if progress is not None and not n & 0xFFFF:
            progress()
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
                    value = _number(text, decimal)
                except ValueError:
                    raise _not_a_number(path, where[0], names_text([header[i]]), text,
                                        decimal) from None
            data[col].append(value)
    return {col: np.frombuffer(values, dtype=np.float64).copy() if len(values) else np.zeros(0)
            for col, values in data.items()}


# -- writing ------------------------------------------------------------------------------------
def write_samples_csv(path: str | Path, columns: Mapping[str, Any], *,
                      comment: str | None = None) -> Path:
    """Write raw samples as a CSV recording (atomically): a header of the keys, one row per
    sample, every value with 17 significant digits (read back as the same doubles).

    Parameters
    ----------
    path : str or Path
        The ``.csv`` file (replaced only once written in full).
    columns : mapping of str to array-like, shape (s,)
        Column name (with its unit: ``angle_deg``, ``field_x_T``) -> values, all of one length.
    comment : str, optional
        A first line ``# comment`` (one line: a synthetic recording says so).

    Returns
    -------
    Path
        ``path``.

    Examples
    --------
    >>> import tempfile
    >>> with tempfile.TemporaryDirectory() as tmp:
    ...     p = Path(tmp) / "r.csv"
    ...     write_samples_csv(p, {"angle_deg": [0, 10], "voltage_V": [0.5, 1]}).read_text()
    'angle_deg,voltage_V\\n0,0.5\\n10,1\\n'
    """
    names = [str(k) for k in columns]
    if not names or any(not n or any(c in n for c in ",\"\r\n#") for n in names):
        raise fail("columns", names, "names without commas, quotes, # or line breaks")
    arrays = [np.asarray(columns[k], dtype=np.float64).ravel() for k in columns]
    if len({a.size for a in arrays}) > 1:
        raise fail("columns", "lengths " + ", ".join(str(a.size) for a in arrays),
                   "of equal length")
    if comment is not None and ("\n" in comment or "\r" in comment):
        raise fail("comment", comment, "one line")
    buf = io.StringIO()
    if comment is not None:
        buf.write(f"# {comment}\n")
    buf.write(",".join(names) + "\n")
    if arrays[0].size:
        np.savetxt(buf, np.column_stack(arrays), fmt="%.17g", delimiter=",")
    write_text(path, buf.getvalue())
    return Path(path)
