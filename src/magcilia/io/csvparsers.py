"""The fast CSV reader's two parsers (:func:`magcilia.io.csvfile.plain_csv_blocks`): NumPy's
C reader (``np.loadtxt``) and pandas', over the plain bytes after the header, each giving
blocks of columns indexed 0 … width - 1 (doubles; the ``setreset`` column as text) and raising
``ValueError`` for anything that is not a plain row (not a number as ``float`` reads it, an
empty field, a row longer or shorter than the header): the reader then hands the file to the
careful one. Which parses: :func:`numpy_parses`.
"""

from __future__ import annotations

import io
import re
from collections.abc import Iterator
from typing import Any

import numpy as np
from numpy.typing import NDArray

F64 = NDArray[np.float64]


class NotPlainRowError(ValueError):
    """A parser met a row that is not plain (its message says what)."""


#: The parser: "numpy", "pandas" or None (the default: NumPy's C reader, ``np.loadtxt``, for a
#: file of up to :data:`NUMPY_BYTES` with a decimal point, a one-character delimiter and no
#: ``setreset`` column; pandas' for the rest). Importing pandas costs more than NumPy's parse of
#: such a file (one thread, a 23 MB recording of 1e6 rows: ``np.loadtxt`` 0.10 s; pandas'
#: import 0.3 s and parse 0.04 s)
PARSER: str | None = None
#: The largest file that NumPy parses by default (it reads the rest of the file at once)
NUMPY_BYTES = 64 << 20


def numpy_parses(delim: str, decimal: str, size: int, setreset: int | None) -> bool:
    """Whether the fast reader parses with NumPy (:data:`PARSER`; it can where the file has a
    decimal point, a one-character delimiter and no ``setreset`` column, and does by default up
    to :data:`NUMPY_BYTES`)."""
    if delim == " " or decimal != "." or setreset is not None:
        return False
    if PARSER is not None:
        return PARSER == "numpy"
    return size <= NUMPY_BYTES


def numpy_frames(f: io.RawIOBase, width: int, delim: str, decimal: str, setreset: int | None,
                 block_rows: int, nan_text: tuple[str, ...]) -> Iterator[list[F64]]:
    """:func:`pandas_frames` by ``np.loadtxt`` (NumPy's C reader) over the rest of the file at
    once, cut into blocks of ``block_rows`` rows, each a list of the ``width`` columns (doubles;
    lines of only blanks skipped, as pandas skips them; NaN only as ``float`` spells it, which
    ``nan_text`` lists). For plain files only (:func:`numpy_parses`)."""
    del decimal, setreset, nan_text  # (a point; none; float's spellings: the reader's own)
    data = f.read()
    try:
        table = _loadtxt(data, delim)
    except ValueError as exc:  # not a number, a row too long or too short, a line of blanks, ...
        kept = _BLANK_LINE.sub(b"", data)  # (looked for only now: a scan of the whole file)
        if kept == data:
            raise NotPlainRowError(str(exc)) from None
        try:
            table = _loadtxt(kept, delim)
        except ValueError as again:
            raise NotPlainRowError(str(again)) from None
    if table.size == 0:  # a header without data rows
        return
    if table.shape[1] != width:
        raise NotPlainRowError(f"rows of {table.shape[1]} fields under a header of {width}")
    for start in range(0, table.shape[0], block_rows):
        part = table[start:start + block_rows]
        yield [np.ascontiguousarray(part[:, i]) for i in range(width)]


def pandas_frames(f: io.RawIOBase, width: int, delim: str, decimal: str, setreset: int | None,
                  block_rows: int, nan_text: tuple[str, ...]) -> Iterator[Any]:
    """The plain data after the header as pandas frames of ``block_rows`` rows (columns
    0 … ``width`` - 1: doubles, the ``setreset`` column categorical; NaN only for the fields
    ``nan_text``)."""
    import pandas as pd

    for frame in pd.read_csv(
            f, engine="c", header=None, names=list(range(width)),
            sep=r"\s+" if delim == " " else delim, decimal=decimal,
            dtype={i: "category" if i == setreset else np.float64 for i in range(width)},
            keep_default_na=False, na_values=list(nan_text), chunksize=block_rows):
        if not isinstance(frame.index, pd.RangeIndex):  # pandas took the first columns as
            raise NotPlainRowError("a row longer than the header")  # the index
        yield frame


def _loadtxt(data: bytes, delim: str) -> F64:
    """The rows of ``data`` (ASCII bytes) as a (rows, fields) table, by ``np.loadtxt`` (read as
    bytes: no decoded copy of the file; a non-ASCII byte is a ValueError like a bad field)."""
    if _CONTENT.search(data) is None:  # only line ends (NumPy warns on an empty input)
        return np.zeros((0, 0))
    return np.loadtxt(io.BytesIO(data), dtype=np.float64, comments=None, delimiter=delim,
                      ndmin=2, encoding="ascii")


#: Anything but a line end (a file of data rows has one at once)
_CONTENT = re.compile(rb"[^\r\n]")
#: A line of only spaces and tabs (pandas skips it as blank; NumPy would take it for a row)
_BLANK_LINE = re.compile(rb"(?m)^[ \t]+(?=\r?$)")
