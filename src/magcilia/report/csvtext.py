"""CSV text of whole numeric columns at NumPy speed (no Python loop over rows).

Each column becomes a matrix of ASCII bytes, one row per value, padded with NUL bytes; the
columns are set side by side with commas and a newline, and the NULs are dropped: that is the
CSV text. Numbers are written as Python writes them:

* :func:`shortest`: the shortest text that reads back as the same float, as ``repr(x)``
  (found from 15 significant digits and checked by an exactly rounded multiplication; the rare
  values that need 16 or 17 digits, or lie beyond ~1e±22 of their digits, take ``repr``);
* :func:`significant`: ``f"{x:.{p}g}"`` with ``p`` ≤ 15 significant digits (values whose last
  digit lies within the scaling's rounding of a tie take Python's formatting);
* :func:`table`: an integer code's text from a small table (flags, names).

>>> import numpy as np
>>> rows([shortest(np.array([0.1, -2.0, 1e-05])), significant(np.array([np.pi, np.nan, 1e20]), 4)])
b'0.1,3.142\\n-2.0,\\n1e-05,1e+20\\n'
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
from numpy.typing import NDArray

F64 = NDArray[np.float64]
U8 = NDArray[np.uint8]

#: powers of ten that int64 holds exactly, 10**0 … 10**18
POW10 = 10 ** np.arange(19, dtype=np.int64)
#: the width of the longest ``repr`` of a float (``-2.2250738585072014e-308``)
REPR_WIDTH = 24
_DOT, _ZERO, _MINUS, _PLUS, _E = (ord(c) for c in ".0-+e")


def _scaled(a: F64, k: NDArray[np.int64]) -> F64:
    """``a · 10**k``, the power taken in two halves so that neither overflows."""
    h = k // 2
    return a * np.power(10.0, h) * np.power(10.0, k - h)


def _digits(a: F64, p: int) -> tuple[NDArray[np.int64], NDArray[np.int64], F64]:
    """``m`` with ``p`` digits (10**(p-1) ≤ m < 10**p) and the exponent ``e`` of positive finite
    ``a``: ``m = rint(r)``, ``r = a · 10**(p − 1 − e)`` (also returned), shapes (n,)."""
    with np.errstate(divide="ignore"):
        e = np.floor(np.log10(a)).astype(np.int64)
    r = _scaled(a, p - 1 - e)
    m = np.rint(r)
    for _ in range(3):  # log10 may be one off either way near powers of ten
        up = m >= POW10[p]
        down = m < POW10[p - 1]
        fix = up | down
        if not fix.any():
            break
        e += up.astype(np.int64) - down.astype(np.int64)
        r[fix] = _scaled(a[fix], p - 1 - e[fix])
        m[fix] = np.rint(r[fix])
    return m.astype(np.int64), e, r


def _digit_chars(m: NDArray[np.int64], p: int) -> tuple[U8, NDArray[np.int64]]:
    """The ``p`` digits of ``m`` as ASCII (n, p + 2; two more '0' columns for numbers written
    with more integer digits than significant ones) and how many are left without the trailing
    zeros (≥ 1)."""
    d = np.full((m.size, p + 2), _ZERO, np.uint8)
    rest = m.astype(np.float64)  # exact below 2**53, and floating division is fast:
    for j in range(p - 1, -1, -1):  # floor(rest / 10) is exact for rest < 1e15
        nxt = np.floor(rest / 10.0)
        d[:, j] += (rest - 10.0 * nxt).astype(np.uint8)
        rest = nxt
    q = p - np.argmax(d[:, p - 1::-1] != _ZERO, axis=1).astype(np.int64)
    return d, q


def _layout(m: NDArray[np.int64], e: NDArray[np.int64], p: int, below: int,
            point_zero: bool) -> U8:
    """Bytes (n, w) of the positive numbers ``m`` (``p`` digits) · 10**(e − p + 1) without
    trailing zeros: positional when −4 ≤ e < ``below``, else scientific; ``point_zero`` writes
    ``.0`` after whole numbers (as ``repr``; ``%g`` does not). Rows with the same ``e`` share one
    layout: a gather of their digit columns."""
    digits, q = _digit_chars(m, p)
    if m.size and e.min() == e.max():
        return _group(digits, q, int(e[0]), p, below, point_zero)
    groups = []
    for ev in np.unique(e).tolist():
        rows_ = np.flatnonzero(e == ev)
        groups.append((rows_, _group(digits[rows_], q[rows_], ev, p, below, point_zero)))
    width = max((g.shape[1] for _, g in groups), default=0)
    out = np.zeros((m.size, width), np.uint8)
    for rows_, g in groups:
        out[rows_, :g.shape[1]] = g
    return out


def _group(digits: U8, q: NDArray[np.int64], e: int, p: int, below: int,
           point_zero: bool) -> U8:
    """:func:`_layout` of rows that share the exponent ``e``: slices of digit columns and
    constant characters, then the fraction's trailing zeros dropped."""
    pieces: list[tuple[int, int] | bytes] = []  # digit columns [a, b) or constant characters
    positional = -4 <= e < below
    if positional and e >= 0:
        pieces = [(0, e + 1), b".", (e + 1, max(p, e + 2))]
        fraction = e + 1  # the digit index of the first character after the point
    elif positional:
        pieces = [b"0." + b"0" * (-e - 1), (0, p)]
        fraction = 0
    else:
        pieces = [(0, 1), b".", (1, max(p, 2)),
                  f"e{'-' if e < 0 else '+'}{abs(e):02d}".encode()]
        fraction = 1
    width = sum(len(x) if isinstance(x, bytes) else x[1] - x[0] for x in pieces)
    out = np.empty((q.size, width), np.uint8)
    at = 0
    point = frac_start = frac_stop = 0
    for piece in pieces:
        if isinstance(piece, bytes):
            out[:, at:at + len(piece)] = np.frombuffer(piece, np.uint8)
            if b"." in piece:
                point = at + piece.index(b".")
            at += len(piece)
        else:
            lo, hi = piece
            out[:, at:at + hi - lo] = digits[:, lo:hi]
            if hi > fraction and (frac_stop == 0):  # the digits after the point
                frac_start, frac_stop = at + max(fraction - lo, 0), at + hi - lo
            at += hi - lo
    # drop the trailing zeros of the fraction (and the point with them, unless ".0" is wanted)
    keep_first = point_zero and positional and e >= 0  # "100.0"
    index = fraction + np.arange(frac_stop - frac_start)
    drop = q[:, None] <= index[None, :]
    if keep_first and drop.shape[1]:
        drop[:, 0] = False
    view = out[:, frac_start:frac_stop]
    view[drop] = 0
    if not keep_first:
        out[:, point] = np.where(q > fraction, _DOT, 0)
    return out


def _texts(values: Sequence[str] | Sequence[bytes], width: int | None = None) -> U8:
    """Bytes (n, w) of ASCII strings, NUL-padded."""
    arr = np.array([s.encode() if isinstance(s, str) else s for s in values], dtype=bytes)
    w = max(arr.dtype.itemsize, width or 0, 1)
    return np.frombuffer(arr.astype(f"S{w}").tobytes(), np.uint8).reshape(len(arr), w)


def _column(x: F64, p: int, below: int, point_zero: bool, nan: bytes, zero: bytes,
            shortest_check: bool) -> U8:
    x = np.asarray(x, dtype=np.float64).reshape(-1)
    neg = np.signbit(x)
    a = np.abs(x)
    normal = np.isfinite(a) & (a > 0)
    everything = bool(normal.all())
    rows_ = np.flatnonzero(normal)
    m, e, r = _digits(a if everything else a[rows_], p)
    k = e - p + 1
    if shortest_check:  # does the text read back as the float? (exactly rounded: Clinger)
        with np.errstate(over="ignore"):
            back = np.where(k >= 0, m * np.power(10.0, np.clip(k, 0, 22)),
                            m / np.power(10.0, np.clip(-k, 0, 22)))
        fine = (np.abs(k) <= 22) & (back == a[rows_])
    else:  # a tie in the last digit, within the scaling's rounding: Python rounds it exactly
        fine = np.abs(r - np.floor(r) - 0.5) > 4.5e-16 * r
        r10 = r * 10.0  # the scaling before a carry to the next power of ten (0.95 -> 1)
        fine &= (m != POW10[p - 1]) | (np.abs(r10 - np.floor(r10) - 0.5) > 9e-16 * r10)
    everything &= bool(fine.all())
    fallback = rows_[~fine]
    if not everything:
        rows_, m, e = rows_[fine], m[fine], e[fine]
    body = _layout(m, e, p, below, point_zero)
    special = np.flatnonzero(~normal)
    width = max(body.shape[1], len(nan), len(zero), 3, REPR_WIDTH if fallback.size else 0) + 1
    out = np.zeros((x.size, width), np.uint8)
    if everything:
        out[:, 1:1 + body.shape[1]] = body
        out[:, 0] = neg.view(np.uint8) * np.uint8(_MINUS)
    else:
        out[rows_, 1:1 + body.shape[1]] = body
        out[rows_, 0] = neg[rows_].view(np.uint8) * np.uint8(_MINUS)
    if special.size:
        xs = x[special]
        texts = [nan if np.isnan(v) else (b"-inf" if v < 0 else b"inf") if np.isinf(v) else
                 (b"-" + zero if np.signbit(v) else zero) for v in xs.tolist()]
        out[special] = _texts(texts, width)
    if fallback.size:
        text = repr if shortest_check else f"{{:.{p}g}}".format
        out[fallback] = _texts([text(v) for v in x[fallback].tolist()], width)
    return out


def shortest(x: F64) -> U8:
    """Bytes (n, w) of ``repr(float(v))`` for each value of ``x`` (shape (n,)): the shortest text
    that reads back as the same float (``nan``, ``inf``, ``-0.0`` included)."""
    return _column(x, 15, 16, True, b"nan", b"0.0", shortest_check=True)


def significant(x: F64, digits: int, nan: bytes = b"") -> U8:
    """Bytes (n, w) of ``f"{v:.{digits}g}"`` for each value of ``x`` (shape (n,)); NaN as
    ``nan`` (default: an empty field). ``digits`` from 1 to 15."""
    if not 1 <= digits <= 15:
        raise ValueError(f"digits must be from 1 to 15; got {digits}")
    return _column(x, digits, digits, False, nan, b"0", shortest_check=False)


def table(codes: NDArray[np.integer], texts: Sequence[str]) -> U8:
    """Bytes (n, w) of ``texts[code]`` for each of ``codes`` (shape (n,), 0 ≤ code < len(texts))."""
    return _texts(list(texts))[np.asarray(codes, dtype=np.intp).reshape(-1)]


def rows(columns: Sequence[U8]) -> bytes:
    """The CSV lines of columns of :func:`shortest`, :func:`significant` or :func:`table` bytes
    (each (n, w_i), the same n): comma-separated, one line per row, each ending with a newline."""
    n = columns[0].shape[0]
    sep = np.full((n, 1), ord(","), np.uint8)
    parts: list[U8] = []
    for col in columns:
        parts += [col, sep]
    parts[-1] = np.full((n, 1), ord("\n"), np.uint8)
    flat = np.concatenate(parts, axis=1).reshape(-1)
    return flat[flat != 0].tobytes()
