"""The fast CSV reader's two parsers (:func:`magcilia.io.csvfile.plain_csv_blocks`): pandas'
C reader and pyarrow's streaming reader, over the plain bytes after the header, each giving
blocks of columns indexed 0 … width - 1 (doubles; the ``setreset`` column as text) and raising
``ValueError`` for anything that is not a plain row (not a number as ``float`` reads it, an
empty field, a row longer or shorter than the header): the reader then hands the file to the
careful one. Which parses: :func:`arrow_parses`.
"""

from __future__ import annotations

import io
import re
import sys
from collections.abc import Iterator
from functools import cache
from typing import IO, Any

import numpy as np


class NotPlainRowError(ValueError):
    """A parser met a row that is not plain (its message says what)."""


#: The parser: "arrow", "pandas" or None, the faster of the two counting the import: pyarrow
#: for files up to :data:`ARROW_BYTES` while pandas is not imported (one thread, a 23 MB
#: recording: pyarrow's import 0.09 s and parse 0.05 s against pandas' 0.3 s and 0.04 s)
PARSER: str | None = None
#: The largest file that pyarrow parses by default (its parse costs ~2 ms per MB more)
ARROW_BYTES = 64 << 20
#: Bytes pyarrow reads at a time
ARROW_BLOCK_BYTES = 1 << 24


def arrow_parses(delim: str, size: int) -> bool:
    """Whether the fast reader parses with pyarrow (:data:`PARSER`; by default where pyarrow is
    installed, pandas is not imported yet and the file is small enough that pyarrow's third of
    pandas' import time outweighs its slower single-threaded parse: ≤ :data:`ARROW_BYTES`)."""
    if delim == " ":  # (runs of white space: pandas only)
        return False
    if PARSER is not None:
        return PARSER == "arrow"
    return size <= ARROW_BYTES and "pandas" not in sys.modules and _has_pyarrow()


@cache
def _has_pyarrow() -> bool:
    """Whether pyarrow's CSV reader can be imported (the fast reader's parser where it can)."""
    try:
        import pyarrow.csv  # noqa: F401
    except ImportError:
        return False
    return True


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


def arrow_frames(f: io.RawIOBase, width: int, delim: str, decimal: str, setreset: int | None,
                 block_rows: int, nan_text: tuple[str, ...]) -> Iterator[Any]:
    """:func:`pandas_frames` by pyarrow's streaming CSV reader (one thread, reading
    :data:`ARROW_BLOCK_BYTES` at a time, cut into blocks of ``block_rows``): every field of
    every column a number as ``float`` reads it (pyarrow's grammar on the plain bytes: digits,
    a point or the decimal comma, an exponent, a sign, nan, inf, infinity, spaces around; an
    empty field is refused, never NaN), rows as long as the header; the ``setreset`` column as
    text. Each batch is indexed by column."""
    import pyarrow as pa
    import pyarrow.csv as pc

    del nan_text  # (pyarrow reads NaN exactly as float spells it: the fields nan_text names)
    names = [f"c{i}" for i in range(width)]
    types = {n: pa.string() if i == setreset else pa.float64() for i, n in enumerate(names)}
    try:
        reader = pc.open_csv(
            _WithoutBlankLines(f),
            read_options=pc.ReadOptions(column_names=names, use_threads=False,
                                        block_size=ARROW_BLOCK_BYTES),
            parse_options=pc.ParseOptions(delimiter=delim, quote_char=False,
                                          double_quote=False, escape_char=False,
                                          newlines_in_values=False, ignore_empty_lines=True),
            convert_options=pc.ConvertOptions(column_types=types, null_values=[],
                                              true_values=[], false_values=[],
                                              strings_can_be_null=False,
                                              quoted_strings_can_be_null=False,
                                              decimal_point=decimal))
        for batch in reader:
            for start in range(0, batch.num_rows, block_rows):  # (blocks of rows, as pandas')
                part = batch.slice(start, block_rows)
                yield [part.column(i) for i in range(width)]
    except (pa.ArrowInvalid, pa.ArrowTypeError) as exc:  # not a number, a row too long, ...
        if str(exc).startswith("Empty CSV file"):  # (a header without data rows)
            return
        raise NotPlainRowError(str(exc)) from None


def arrow_values(column: Any, dtype: Any) -> Any:
    """The values of a pyarrow array of numbers without nulls as a NumPy array of ``dtype``
    (its type), copied from its buffer (pyarrow's ``to_numpy`` imports pandas)."""
    width = np.dtype(dtype).itemsize
    return np.frombuffer(column.buffers()[1], dtype=dtype, count=len(column),
                         offset=column.offset * width).copy()


class _WithoutBlankLines(io.RawIOBase):
    """Whole lines of a stream, those of only spaces and tabs emptied (pandas skips them as
    blank, pyarrow would take them for a row of one field)."""

    BLANK = re.compile(rb"(?m)^[ \t]+(?=\r?$)")

    def __init__(self, f: IO[bytes] | io.RawIOBase):
        self.f, self.rest = f, b""

    def readable(self) -> bool:
        return True

    def read(self, size: int | None = -1) -> bytes:
        data = self.rest
        while True:
            more = self.f.read(-1 if size is None else max(size, 1))
            data += more
            end = data.rfind(b"\n") + 1
            if end or not more:
                break
        if not more:  # the end: the last line too
            end = len(data)
        data, self.rest = data[:end], data[end:]
        if b"\n " in data or b"\n\t" in data or data[:1] in (b" ", b"\t"):
            data = self.BLANK.sub(b"", data)
        return data
