"""A recording's temperature column (issue #29 item 4): temperature_K or temperature_degC in every
reader format, the unknown-unit error, and the commands that use it."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path
from typing import Any

import numpy as np
import pytest

import magcilia as mc
from magcilia.io.recordings import read_samples

N = 40
TIME = np.arange(N) * 1e-2
VOLT = 3e-3 + 1e-4 * np.sin(TIME)
KELVIN = np.linspace(293.15, 313.15, N)


def _csv(path: Path, names: list[str], columns: list[np.ndarray], quoted: bool = False) -> Path:
    q = '"' if quoted else ""
    lines = [",".join(f"{q}{n}{q}" for n in names)]
    lines += [",".join(repr(float(c[i])) for c in columns) for i in range(len(columns[0]))]
    path.write_text("\n".join(lines) + "\n", encoding="utf-8")
    return path


def _write(fmt: str, path: Path, columns: dict[str, np.ndarray]) -> Path:
    """``columns`` (name -> values) as a recording of format ``fmt``."""
    if fmt in ("csv", "csv-careful"):
        return _csv(path.with_suffix(".csv"), list(columns), list(columns.values()),
                    quoted=fmt == "csv-careful")
    if fmt == "mat":
        from scipy.io import savemat

        savemat(path.with_suffix(".mat"), columns)
        return path.with_suffix(".mat")
    if fmt == "tdms":
        nptdms = pytest.importorskip("nptdms")
        out = path.with_suffix(".tdms")
        with nptdms.TdmsWriter(out) as writer:
            writer.write_segment([nptdms.ChannelObject("recording", n, c)
                                  for n, c in columns.items()])
        return out
    h5py = pytest.importorskip("h5py")
    out = path.with_suffix(".h5")
    with h5py.File(out, "w") as f:
        for name, values in columns.items():
            f.create_dataset(name, data=values)
    return out


FORMATS = ("csv", "csv-careful", "mat", "tdms", "hdf5")


@pytest.mark.parametrize("fmt", FORMATS)
@pytest.mark.parametrize(("name", "values"), [("temperature_K", KELVIN),
                                               ("temperature_degC", KELVIN - 273.15)])
def test_temperature_round_trip(tmp_path: Path, fmt: str, name: str, values: np.ndarray) -> None:
    path = _write(fmt, tmp_path / "r", {"time_s": TIME, "voltage_V": VOLT, name: values})
    cols = read_samples(path, ("voltage_V",), temperature=True)
    assert "temperature_degC" not in cols
    np.testing.assert_allclose(cols["temperature_K"], KELVIN, rtol=1e-13)
    np.testing.assert_array_equal(cols["voltage_V"], VOLT)


def test_a_mapped_kelvin_column(tmp_path: Path) -> None:
    path = _csv(tmp_path / "m.csv", ["time_s", "voltage_V", "Tchip"],
                [TIME, VOLT, KELVIN * 1e3])
    cols = read_samples(path, ("voltage_V",), columns="temperature=Tchip[mK]",
                        temperature=True)
    np.testing.assert_allclose(cols["temperature_K"], KELVIN, rtol=1e-13)


@pytest.mark.parametrize(("fmt", "name"), [  # (a unit in brackets: a CSV header's way)
    *((f, n) for f in ("csv", "csv-careful", "tdms", "hdf5") for n in ("temperature", "temp_F")),
    ("csv", "Temp [C]"), ("csv-careful", "Temp [C]")])
def test_a_temperature_in_unknown_units_is_a_one_line_error(tmp_path: Path, fmt: str,
                                                           name: str) -> None:
    path = _write(fmt, tmp_path / "u", {"time_s": TIME, "voltage_V": VOLT, name: KELVIN})
    with pytest.raises(mc.MagciliaError) as exc:
        read_samples(path, ("voltage_V",), temperature=True)
    text = str(exc.value)
    assert "\n" not in text and repr(name) in text
    assert "temperature_K" in text and "temperature_degC" in text


def test_the_temperature_is_read_only_where_it_is_used(tmp_path: Path) -> None:
    """Without ``temperature=True`` a temperature column is left unread, and one in unknown
    units is no error (a file that was read before still is)."""
    path = _csv(tmp_path / "o.csv", ["voltage_V", "temperature_K", "temp_F"],
                [VOLT, KELVIN, KELVIN])
    assert set(read_samples(path, ("voltage_V",))) == {"voltage_V"}
    with pytest.raises(mc.MagciliaError, match="temp_F"):
        read_samples(path, ("voltage_V",), temperature=True)


def test_kelvin_and_celsius_together_are_refused(tmp_path: Path) -> None:
    path = _csv(tmp_path / "b.csv", ["voltage_V", "temperature_K", "temperature_degC"],
                [VOLT, KELVIN, KELVIN - 273.15])
    with pytest.raises(mc.MagciliaError, match="keep one"):
        read_samples(path, ("voltage_V",), temperature=True)


def test_a_temperature_column_leaves_calibration_reading_alone(tmp_path: Path) -> None:
    """(a °C column beside a tilt recording leaves the readings alone; the calibration keeps
    the range of its temperatures)"""
    angles = np.repeat([0.0, 10.0, 20.0], 10)
    volts = 3e-3 + 1e-5 * angles
    path = _csv(tmp_path / "c.csv", ["angle_deg", "voltage_V", "temperature_degC"],
                [angles, volts, np.full(30, 20.0)])
    m = mc.read_measurements(path)
    np.testing.assert_allclose(m.volts, [3e-3, 3.1e-3, 3.2e-3])
    assert m.temperature_range == pytest.approx((293.15, 293.15))


def _run(*args: str, cwd: Path) -> subprocess.CompletedProcess[str]:
    return subprocess.run([sys.executable, "-m", "magcilia", *args], cwd=cwd, text=True,
                          capture_output=True, timeout=300, check=False)


def test_record_and_readout_with_a_temperature(tmp_path: Path) -> None:
    """``record --temperature START:END`` writes temperature_K; ``readout`` compensates with it,
    notes the range left and counts TEMPERATURE_OUTSIDE."""
    rec = _run("record", "--setup", "force-sensor", "--duration", "1s", "--source-rate", "200",
               "--temperature", "20degC:40degC", "--record", "ramp.tdms", cwd=tmp_path)
    assert rec.returncode == 0, rec.stderr
    cols = read_samples(tmp_path / "ramp.tdms", ("voltage_V",), temperature=True)
    assert cols["temperature_K"][0] == pytest.approx(293.15)
    assert cols["temperature_K"][-1] > 312.0
    out = _run("readout", "--setup", "force-sensor", "ramp.tdms", "--quantity", "force",
               "--span=-0.04:0.04", "--csv", "f.csv", "--tare", "20", "--json", cwd=tmp_path)
    assert out.returncode == 0, out.stderr
    doc: dict[str, Any] = json.loads(out.stdout)
    temp = doc["temperature"]
    assert temp["calibrated_range_K"][0] == pytest.approx(293.15)
    assert temp["outside_calibrated_range"] > 100
    assert doc["temperature_outside"] == temp["outside_calibrated_range"]
    assert any("calibrated range" in n for n in doc["notes"])
    assert "temperature_outside" in (tmp_path / "f.csv").read_text()


def test_readout_refuses_a_temperature_in_unknown_units(tmp_path: Path) -> None:
    _csv(tmp_path / "x.csv", ["time_s", "voltage_V", "temp_F"], [TIME, VOLT, KELVIN])
    out = _run("readout", "--setup", "force-sensor", "x.csv", "--quantity", "force",
               "--span=-0.04:0.04", "--csv", "f.csv", cwd=tmp_path)
    assert out.returncode == 2
    assert out.stderr.count("\n") == 1 and "temp_F" in out.stderr and "Traceback" not in out.stderr
    assert not (tmp_path / "f.csv").exists()


def test_record_temperature_errors(tmp_path: Path) -> None:
    out = _run("record", "--setup", "force-sensor", "--angles", "0:10:10", "--samples", "10",
               "--temperature", "293K:313K", "--record", "a.tdms", cwd=tmp_path)
    assert out.returncode == 2 and "--duration" in out.stderr
    out = _run("record", "--setup", "force-sensor", "--duration", "0.1s",
               "--temperature", "-300degC", "--record", "b.tdms", cwd=tmp_path)
    assert out.returncode == 2 and "absolute zero" in out.stderr
