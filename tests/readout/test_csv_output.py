"""The read-out's CSV: whole-column number formatting (report.csvtext) against Python's own, and
the table against the row-by-row csv-module writer it replaces."""

from __future__ import annotations

import csv
import io
import math
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import magcilia as mc
from magcilia.readout.inverse import ReadoutFlag
from magcilia.report import csvtext
from magcilia.report import readout as report


def _texts(matrix: np.ndarray) -> list[str]:
    return [bytes(row[row != 0]).decode() for row in matrix]


def _values() -> np.ndarray:
    rng = np.random.default_rng(1)
    return np.concatenate([
        rng.standard_normal(4000) * 10.0 ** rng.integers(-30, 30, 4000),  # 17-digit floats
        [float(f"{x:.{k}f}") for x, k in zip(rng.uniform(-5, 5, 4000),
                                             rng.integers(0, 12, 4000), strict=True)],
        np.arange(3000) / 1000.0,  # a sample clock
        [0.0, -0.0, np.nan, np.inf, -np.inf, 1e16, 1e15, 9.999999999999999e15, 1e-4, 1e-5,
         0.0001234, 5e-324, 2.2250738585072014e-308, 1.7976931348623157e308, 1e22, 1e23, 2.5,
         100.0, 0.95, 0.35, 9.5, 0.5, 1.5, 2.675, 1.0000000001, 123456789012345.0, 1e100,
         -1e-100, 99999.99999, 0.00009999999999]])


def test_shortest_is_repr() -> None:
    x = _values()
    assert _texts(csvtext.shortest(x)) == [repr(v) for v in x.tolist()]


@pytest.mark.parametrize("digits", [1, 2, 4, 6, 10, 12, 15])
def test_significant_is_percent_g(digits: int) -> None:
    x = _values()
    want = [f"{v:.{digits}g}" for v in x.tolist()]
    got = _texts(csvtext.significant(x, digits, nan=b"nan"))
    assert got == want
    blank = _texts(csvtext.significant(np.array([np.nan, 1.0]), digits))
    assert blank == ["", "1"]


@settings(max_examples=200, deadline=None)
@given(st.lists(st.floats(allow_nan=True, allow_infinity=True), min_size=1, max_size=40),
       st.integers(1, 15))
def test_any_floats(values: list[float], digits: int) -> None:
    x = np.array(values, dtype=np.float64)
    assert _texts(csvtext.shortest(x)) == [repr(v) for v in values]
    assert _texts(csvtext.significant(x, digits, nan=b"nan")) == [f"{v:.{digits}g}"
                                                                  for v in values]


def test_rows_and_tables() -> None:
    flags = np.array([0, 3, 1], dtype=np.uint8)
    text = csvtext.rows([csvtext.shortest(np.array([1.0, -0.5, 2e-9])),
                         csvtext.table(flags, ["a", "bc", "", "def"])])
    assert text == b"1.0,a\n-0.5,def\n2e-09,bc\n"
    assert csvtext.rows([csvtext.table(np.zeros(0, np.uint8), ["x"])]) == b""
    with pytest.raises(ValueError, match="digits must be from 1 to 15"):
        csvtext.significant(np.ones(1), 16)


@pytest.fixture(scope="module")
def result() -> tuple[mc.ReadoutResult, np.ndarray, np.ndarray]:
    setup = mc.Setup.paper(tip_radius=5e-5, n_loops=16)  # 0.5 % from the exact body
    r = mc.Readout(setup, quantity="force", span=(0.0, 2e-4), table_size=65)
    lo, hi = sorted(r.output_range)
    rng = np.random.default_rng(4)
    volts = np.concatenate([rng.uniform(lo - 0.1 * (hi - lo), hi + 0.1 * (hi - lo), 997),
                            [np.nan, setup.sensor.voltage(7e-4), hi]])
    times = np.arange(volts.size) / 1000.0
    return r.read(volts), volts, times


def _reference_csv(res: mc.ReadoutResult, volts: np.ndarray, times: np.ndarray | None,
                   si: bool) -> str:
    """magcilia 0.1's row-by-row writer (the csv module), with the unit policy's columns."""
    unit, factor = report.units(res.quantity, si)
    col = f"{res.quantity}_{unit.replace('/', '_per_')}"
    buf = io.StringIO()
    writer = csv.writer(buf, lineterminator="\n")
    writer.writerow([*(["time_s"] if times is not None else []), "voltage_V", col,
                     f"sigma_{col}", "flags", "flag_names"])
    for i, volt in enumerate(volts):
        flag = int(res.flags[i])
        value = res.value[i]
        writer.writerow([
            *([repr(float(times[i]))] if times is not None else []), repr(float(volt)),
            "" if math.isnan(value) else f"{value / factor:.10g}",
            "" if math.isnan(value) else f"{res.sigma[i] / factor:.4g}", flag,
            report.flag_names(flag)])
    return buf.getvalue()


@pytest.mark.parametrize("si", [False, True])
@pytest.mark.parametrize("with_times", [True, False])
def test_readout_csv_equals_the_row_by_row_writer(result: tuple, si: bool,
                                                  with_times: bool) -> None:
    res, volts, times = result
    t = times if with_times else None
    text = report.readout_csv(res, volts, t, si=si)
    assert text == _reference_csv(res, volts, t, si)
    assert text.splitlines()[0].split(",")[-4:] == (
        ["force_N", "sigma_force_N", "flags", "flag_names"] if si else
        ["force_mN", "sigma_force_mN", "flags", "flag_names"])
    names = {row.split(",")[-1] for row in text.splitlines()[1:]}
    assert {"", "extrapolated|above_span", "extrapolated|below_span",
            "outside_span|saturated"} <= names


def test_written_in_parts_atomically(result: tuple, tmp_path: Path,
                                     monkeypatch: pytest.MonkeyPatch) -> None:
    res, volts, times = result
    monkeypatch.setattr(report, "ROWS", 96)
    done: list[int] = []
    out = tmp_path / "sub" / "est.csv"
    report.write_readout_csv(out, res, volts, times, progress=done.append)
    assert out.read_text() == report.readout_csv(res, volts, times)
    assert sum(done) == volts.size and len(done) == math.ceil(volts.size / 96)
    assert [p.name for p in out.parent.iterdir()] == ["est.csv"]  # no temporary left
    frame = pd.read_csv(out, keep_default_na=False, na_values=[""], dtype={"voltage_V": str})
    np.testing.assert_array_equal([float(x) for x in frame["voltage_V"]], volts)  # exact
    estimated = res.estimated
    np.testing.assert_allclose(frame["force_mN"].to_numpy()[estimated],
                               res.value[estimated] * 1e3, rtol=5e-10)
    assert frame["force_mN"].isna().to_numpy().tolist() == (~estimated).tolist()
    assert (frame["flags"].to_numpy() == res.flags).all()
    assert frame["flags"][frame["flag_names"] == "outside_span"].eq(
        int(ReadoutFlag.OUTSIDE_SPAN)).all()
