"""The compiled CSV rows (report/csvrows.py) against Python's own formatting, line by line: the
shortest text (``repr``) of the time and voltage, ``%.10g`` and ``%.4g`` of the estimate and its
σ (empty for NaN), the flag text; the rows the kernel cannot prove come from the caller."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from magcilia.model import compiled
from magcilia.report import csvrows

pytest.importorskip("numba")


def _nasty() -> np.ndarray:
    """17-digit floats over 60 decades, short decimals, a sample clock, ties, powers of ten,
    subnormals, the extremes, signed zeros, NaN and infinities."""
    rng = np.random.default_rng(1)
    return np.concatenate([
        rng.standard_normal(3000) * 10.0 ** rng.integers(-30, 30, 3000),
        [float(f"{x:.{k}f}") for x, k in zip(rng.uniform(-5, 5, 3000),
                                             rng.integers(0, 12, 3000), strict=True)],
        np.arange(3000) / 1000.0,
        [0.0, -0.0, np.nan, np.inf, -np.inf, 1e16, 1e15, 9.999999999999999e15, 1e-4, 1e-5,
         0.0001234, 5e-324, 2.2250738585072014e-308, 1.7976931348623157e308, 1e22, 1e23, 2.5,
         100.0, 0.95, 0.35, 9.5, 0.5, 1.5, 2.675, 1.0000000001, 123456789012345.0, 1e100,
         -1e-100, 99999.99999, 0.00009999999999, 0.99995, 9.9995, 0.000123456789012345]])


def _names(flags: int) -> str:
    return "" if flags == 0 else "|".join(f"bit{b}" for b in range(16) if flags >> b & 1)


def _python_line(t: float | None, v: float, value: float, sigma: float, factor: float,
                 flag: int) -> str:
    def g(x: float, p: int) -> str:
        return "" if math.isnan(x) else f"{x:.{p}g}"

    if factor != 1.0:
        value, sigma = value / factor, sigma / factor
    head = "" if t is None else repr(t) + ","
    return f"{head}{v!r},{g(value, 10)},{g(sigma, 4)},{flag},{_names(flag)}\n"


def _check(x: np.ndarray, factor: float, with_times: bool, block: int | None = None) -> int:
    """The compiled lines of rows built from ``x`` equal Python's; returns how many rows the
    kernel left to the caller."""
    n = x.size
    rng = np.random.default_rng(n)
    times = rng.permutation(x) if with_times else None
    value, sigma = rng.permutation(x), rng.permutation(x)
    flags = rng.choice(np.array([0, 0, 0, 5, 1 << 15, 33], dtype=np.uint16), n)
    want = [_python_line(None if times is None else float(times[i]), float(x[i]),
                         float(value[i]), float(sigma[i]), factor, int(flags[i]))
            for i in range(n)]
    left: list[int] = []

    def hard(rows: np.ndarray) -> bytes:
        left.extend(rows.tolist())
        return "".join(want[i] for i in rows.tolist()).encode()

    lines = csvrows.readout_rows(times, x, value, sigma, factor, flags, _names, hard)
    assert lines is not None
    step = block or n
    got = b"".join(lines(a, min(a + step, n)) for a in range(0, n, step)).decode()
    assert got.splitlines() == "".join(want).splitlines()
    assert got == "".join(want)
    return len(left)


@pytest.mark.parametrize(("factor", "with_times"), [(1.0, True), (1e-3, False),
                                                    (math.pi / 180.0, True)])
def test_rows_are_pythons_text(factor: float, with_times: bool) -> None:
    left = _check(_nasty(), factor, with_times, block=777)
    assert left < 0.7 * _nasty().size  # most of even these come from the kernel


def test_measured_data_rarely_leaves_a_row() -> None:
    """A DAQ's 10-digit volts and a sample clock: the kernel writes (nearly) every row."""
    rng = np.random.default_rng(2)
    volts = np.array([float(f"{v:.10g}") for v in rng.uniform(2e-3, 4e-3, 20000)])
    assert _check(volts, 1e-3, True) <= 5


@settings(max_examples=150, deadline=None)
@given(st.lists(st.floats(allow_nan=True, allow_infinity=True), min_size=1, max_size=30))
def test_any_floats(values: list[float]) -> None:
    _check(np.array(values, dtype=np.float64), 1.0, True)


def test_none_without_the_compiled_kernels(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(compiled, "ENABLED", False)
    x = np.ones(3)
    assert csvrows.readout_rows(None, x, x, x, 1.0, np.zeros(3, np.uint16), _names,
                                lambda rows: b"") is None


def test_powers_of_ten_are_correctly_rounded() -> None:
    p = csvrows._powers()
    k = np.arange(-22, 23)
    np.testing.assert_array_equal(p[k + 350], [float(10.0 ** int(i)) if i >= 0 else
                                               1.0 / 10.0 ** int(-i) for i in k])
    assert p[350 + 308] == 1e308 and p[350 - 320] == 1e-320 and p[350 + 309] == math.inf
