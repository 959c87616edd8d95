"""The read-out's CSV rows in one compiled pass: the bytes of :mod:`magcilia.report.csvtext`.

:func:`readout_rows` writes the lines of ``magcilia readout``'s table ([time_s,] voltage_V, the
estimate to 10 significant digits and its 1-σ to 4, empty without an estimate, the flag bits and
names) row by row into one byte buffer (numba, compiled on first use and cached on disk by
:func:`magcilia._jit.compile_kernel`, as every kernel; its helpers inlined), with the arithmetic of
:mod:`~magcilia.report.csvtext`: the shortest text that reads back as the same float (``repr``) from
15 significant digits checked by an exactly rounded product or quotient (Clinger's fast path),
``%.Ng`` from the scaled and rounded value away from a tie. A number it cannot prove that way
(``repr`` needing 16 or 17 digits or lying beyond ~1e±22 of its digits, ``%g`` within a rounding of
a tie: rare in measured data) leaves its row to :mod:`~magcilia.report.csvtext` (``repr`` and
``format``), spliced in at its place; so the bytes are csvtext's, which are Python's
(``tests/report/test_csv_rows.py``). Where numba is missing (or
:data:`magcilia.model.compiled.ENABLED` is False) :func:`readout_rows` returns None and the caller
writes with csvtext.

Shape letters: ``n`` rows, ``k`` distinct flag values.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from fractions import Fraction
from functools import cache
from typing import Any, cast

import numpy as np
from numpy.typing import NDArray

from magcilia._jit import compile_kernel
from magcilia.model import compiled as _model

F64 = NDArray[np.float64]
U8 = NDArray[np.uint8]

#: the powers of ten 10**-350 … 10**350, each the float nearest to it (index k + 350)
_POW_SPAN = 350
#: the widest line: time and voltage (``repr``, ≤ 24 characters each), the estimate (``%.10g``,
#: ≤ 16) and its σ (``%.4g``, ≤ 10), four commas and the newline; the flag text comes on top
_LINE = 24 + 24 + 16 + 10 + 5
#: how far from a tie (relative to the scaled value) ``%g``'s rounding must be to be trusted:
#: twice the worst error of the scaling (two table powers and two products, ≤ 2 ulp)
_TIE = 1e-15
#: where a number's digits are put before they are laid out: this far after its start (its
#: text is at most 24 characters)
SCRATCH = 32
#: log10(2), for a float's decimal exponent from its binary one
_LOG10_2 = math.log10(2.0)
#: the digits 0 and the characters of the layout
_ZERO, _DOT, _MINUS, _PLUS, _E, _COMMA, _NL = (ord(c) for c in "0.-+e,\n")


#: :func:`_powers`, set by :func:`_compile` before the kernel is compiled (it reads it as a
#: constant)
_PW: F64 = np.empty(0)


@cache
def _powers() -> F64:
    """10**k for k = -350 … 350, correctly rounded (``Fraction`` divides exactly; inf beyond
    the largest float, never reached: the scaling takes two halves of ≤ 175)."""
    return np.array([float(Fraction(10) ** k) if k <= 308 else math.inf
                     for k in range(-_POW_SPAN, _POW_SPAN + 1)])


def _put_digits(m: int, p: int, d: U8, base: int) -> int:
    """The ``p`` digits of ``m`` (10**(p-1) ≤ m < 10**p) into ``d[base:base + p]``, two at a
    time; returns how many are left without the trailing zeros (≥ 1)."""
    j = p
    u = np.uint64(m)
    while j >= 2:
        nxt = u // np.uint64(100)
        pair = int(u - nxt * np.uint64(100))
        d[base + j - 1] = _ZERO + pair % 10
        d[base + j - 2] = _ZERO + pair // 10
        u = nxt
        j -= 2
    if j == 1:
        d[base] = _ZERO + int(u)
    q = p
    while q > 1 and d[base + q - 1] == _ZERO:
        q -= 1
    return q


def _layout(base: int, q: int, e: int, below: int, point_zero: bool, out: U8, at: int) -> int:
    """The number of digits ``out[base:base + q]`` (no trailing zeros; beyond the text)
    times 10**(e - q + 1), positional when -4 ≤ e < ``below`` else scientific, ``.0`` after a
    whole number with ``point_zero`` (``repr``; ``%g`` writes none), into ``out`` from ``at``;
    returns the end."""
    if -4 <= e < below:
        if e >= 0:
            for j in range(e + 1):
                out[at] = out[base + j] if j < q else _ZERO
                at += 1
            if q > e + 1:
                out[at] = _DOT
                at += 1
                for j in range(e + 1, q):
                    out[at] = out[base + j]
                    at += 1
            elif point_zero:
                out[at] = _DOT
                out[at + 1] = _ZERO
                at += 2
        else:
            out[at] = _ZERO
            out[at + 1] = _DOT
            at += 2
            for _ in range(-e - 1):
                out[at] = _ZERO
                at += 1
            for j in range(q):
                out[at] = out[base + j]
                at += 1
        return at
    out[at] = out[base]
    at += 1
    if q > 1:
        out[at] = _DOT
        at += 1
        for j in range(1, q):
            out[at] = out[base + j]
            at += 1
    out[at] = _E
    out[at + 1] = _MINUS if e < 0 else _PLUS
    at += 2
    a = abs(e)
    if a >= 100:
        out[at] = _ZERO + a // 100
        at += 1
    out[at] = _ZERO + (a // 10) % 10
    out[at + 1] = _ZERO + a % 10
    return at + 2


def _put_number(x: float, p: int, shortest: bool, out: U8, at: int) -> int:
    """``repr(x)`` (``shortest``, p = 15) or ``f"{x:.{p}g}"`` (NaN: nothing) into ``out`` from
    ``at``; returns the end, or -1 where the arithmetic cannot prove the text (the caller
    formats it in Python). The digits go first to ``out[at + SCRATCH:]``, then in place; the
    powers of ten are the compiled constant ``_PW`` (:func:`_powers`)."""
    pw = _PW
    if math.isnan(x):
        if shortest:
            out[at] = 110  # "nan"
            out[at + 1] = 97
            out[at + 2] = 110
            return at + 3
        return at
    if x < 0.0 or (x == 0.0 and math.copysign(1.0, x) < 0.0):
        out[at] = _MINUS
        at += 1
    a = abs(x)
    if a == math.inf:
        out[at] = 105  # "inf"
        out[at + 1] = 110
        out[at + 2] = 102
        return at + 3
    if a == 0.0:
        out[at] = _ZERO
        at += 1
        if shortest:
            out[at] = _DOT
            out[at + 1] = _ZERO
            at += 2
        return at
    e = math.floor((math.frexp(a)[1] - 1) * _LOG10_2)  # 10**e ≤ a < 10**(e + 2)
    if a >= pw[e + 1 + _POW_SPAN]:
        e += 1
    top = pw[p + _POW_SPAN]
    r = 0.0
    m = 0.0
    settled = False
    for _ in range(3):  # the rounding may carry to the next power of ten
        k = p - 1 - e
        if abs(k) > 2 * _POW_SPAN - 4:
            return -1
        h = k // 2
        r = a * pw[h + _POW_SPAN] * pw[k - h + _POW_SPAN]
        m = float(np.rint(r))
        if m >= top:
            e += 1
        elif m < top / 10.0:
            e -= 1
        else:
            settled = True
            break
    if not settled:
        return -1
    if shortest:  # does the text read back as the float? (exactly rounded: Clinger)
        k = e - p + 1
        if abs(k) > 22:
            return -1
        back = m * pw[k + _POW_SPAN] if k >= 0 else m / pw[-k + _POW_SPAN]
        if back != a:
            return -1
    else:  # a tie in the last digit, within the scaling's rounding: Python rounds it exactly
        if abs(r - math.floor(r) - 0.5) <= _TIE * r:
            return -1
        r10 = r * 10.0
        if m == top / 10.0 and abs(r10 - math.floor(r10) - 0.5) <= 2.0 * _TIE * r10:
            return -1
    base = at + SCRATCH
    q = _put_digits(int(m), p, out, base)
    return _layout(base, q, e, 16 if shortest else p, shortest, out, at)


def rows_pass(times: F64, volts: F64, value: F64, sigma: F64, factor: float,
              codes: NDArray[np.intp], texts: U8, lengths: NDArray[np.intp], start: int,
              stop: int, out: U8, hard: NDArray[np.intp],
              hard_at: NDArray[np.intp]) -> tuple[int, int]:
    """The CSV lines of rows ``start`` … ``stop`` - 1 into ``out`` (numba source): [time,] volts
    (``repr``), value / ``factor`` (``%.10g``) and sigma / ``factor`` (``%.4g``), empty where
    NaN, then the flag text ``texts[codes[row], :lengths[codes[row]]]``
    (``flags,flag_names``). ``times`` is empty without a time column. A row with a number that
    cannot be proven is left out: its index goes to ``hard`` and where it belongs in ``out`` to
    ``hard_at``. Returns the bytes written and the rows left out."""
    at = 0
    n_hard = 0
    with_times = times.size > 0
    for r in range(start, stop):
        begin = at
        ok = True
        if with_times:
            at = _put_number(times[r], 15, True, out, at)
            ok = at >= 0
            if ok:
                out[at] = _COMMA
                at += 1
        if ok:
            at = _put_number(volts[r], 15, True, out, at)
            ok = at >= 0
        if ok:
            out[at] = _COMMA
            v = value[r]
            at = _put_number(v / factor if factor != 1.0 else v, 10, False, out, at + 1)
            ok = at >= 0
        if ok:
            out[at] = _COMMA
            s = sigma[r]
            at = _put_number(s / factor if factor != 1.0 else s, 4, False, out, at + 1)
            ok = at >= 0
        if not ok:
            hard[n_hard] = r
            hard_at[n_hard] = begin
            n_hard += 1
            at = begin
            continue
        out[at] = _COMMA
        at += 1
        c = codes[r]
        for j in range(lengths[c]):
            out[at + j] = texts[c, j]
        at += lengths[c]
        out[at] = _NL
        at += 1
    return at, n_hard


#: numba's options for the kernel's helpers: inlined into it (so compiled in memory only, no
#: cache file of their own), and no reference counting of the arrays they are handed (they
#: allocate none; the atomic increments and decrements of a call per number took 5/6 of the time)
HELPER_OPTIONS: dict[str, Any] = {"_nrt": False, "forceinline": True, "nogil": False,
                                  "cache": False}


@cache
def _compile() -> Callable[..., tuple[int, int]] | None:
    rows_pass.__globals__["_PW"] = _powers()  # a constant of the kernel
    helpers = tuple(compile_kernel(helper, **HELPER_OPTIONS)
                    for helper in (_put_digits, _layout, _put_number))
    return cast("Callable[..., tuple[int, int]] | None", compile_kernel(rows_pass, calls=helpers))


def kernel() -> Callable[..., tuple[int, int]] | None:
    """The compiled :func:`rows_pass`, or None where numba is missing or the compiled kernels
    are switched off (:data:`magcilia.model.compiled.ENABLED`)."""
    return _compile() if _model.ENABLED else None


def flag_texts(flags: NDArray[np.uint16],
               name_of: Callable[[int], str]) -> tuple[NDArray[np.intp], U8, NDArray[np.intp]]:
    """Each reading's code into a small table of the texts ``"{flags},{names}"`` of the flag
    values that occur (``name_of(flags)``: their names), the table as bytes (k, w) and each
    text's length (k,)."""
    seen = np.flatnonzero(np.bincount(flags, minlength=1))
    lut = np.zeros(max(int(seen[-1]) + 1 if seen.size else 1, 1), dtype=np.intp)
    lut[seen] = np.arange(seen.size)
    texts = [f"{f},{name_of(int(f))}".encode("ascii") for f in seen] or [b""]
    width = max(len(t) for t in texts)
    table = np.zeros((len(texts), max(width, 1)), dtype=np.uint8)
    for i, t in enumerate(texts):
        table[i, :len(t)] = np.frombuffer(t, np.uint8)
    return lut[flags], table, np.array([len(t) for t in texts], dtype=np.intp)


def readout_rows(times: F64 | None, volts: F64, value: F64, sigma: F64, factor: float,
                 flags: NDArray[np.uint16], name_of: Callable[[int], str],
                 hard_rows: Callable[[NDArray[np.intp]], bytes]
                 ) -> Callable[[int, int], bytes] | None:
    """A writer of the read-out's CSV lines of rows [start, stop) (see :func:`rows_pass`; all
    arrays (n,)), or None where the compiled pass is not available; ``hard_rows(rows)`` gives
    csvtext's lines of the rows it leaves out (their text from Python's own formatting)."""
    run = kernel()
    if run is None:
        return None
    codes, texts, lengths = flag_texts(flags, name_of)
    t = np.zeros(0) if times is None else np.ascontiguousarray(times, dtype=np.float64)
    line = _LINE + texts.shape[1]
    slack = SCRATCH + 20  # (the last row's digits)

    buffers: list[tuple[U8, NDArray[np.intp], NDArray[np.intp]]] = []  # (reused: warm pages)

    def lines(start: int, stop: int) -> bytes:
        rows = stop - start
        if not buffers or buffers[0][1].size < rows:
            buffers[:] = [(np.empty(rows * line + slack, dtype=np.uint8),
                           np.empty(rows, dtype=np.intp),
                           np.empty(rows, dtype=np.intp))]
        out, hard, hard_at = buffers[0]
        end, n_hard = run(t, volts, value, sigma, factor, codes, texts, lengths, start, stop,
                          out, hard, hard_at)
        if not n_hard:
            return out[:end].tobytes()
        texts_ = hard_rows(hard[:n_hard]).splitlines(keepends=True)
        pieces: list[bytes] = []
        last = 0
        for at, text in zip(hard_at[:n_hard].tolist(), texts_, strict=True):
            pieces += [out[last:at].tobytes(), text]
            last = at
        pieces.append(out[last:end].tobytes())
        return b"".join(pieces)

    return lines
