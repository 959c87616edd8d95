"""``magcilia readout``: span edges, tare, units (--si) and progress, run in-process."""

from __future__ import annotations

import csv
import json
import sys
from pathlib import Path

import numpy as np
import pytest

import magcilia as mc
from magcilia.cli import main
from magcilia.cli import readout as readout_cli
from magcilia.mechanics import output_at

TIP = ["--tip-radius", "0.05mm"]
SETUP = mc.Setup.paper(tip_radius=5e-5)
RATE = 1000.0


def _record(path: Path, volts: np.ndarray, times: bool = True) -> Path:
    head = "time_s,voltage_V\n" if times else "voltage_V\n"
    path.write_text(head + "".join(
        (f"{i / RATE!r},{float(v)!r}\n" if times else f"{float(v)!r}\n")
        for i, v in enumerate(volts)))
    return path


def _session(offset: float = 0.0, seed: int = 2) -> tuple[np.ndarray, np.ndarray]:
    """0.1 s unloaded, then 0.1 s at each of 0.05, 0.1 and 0.2 mN (the top of the span), with
    the sensor's noise and an output ``offset`` (V) the model does not know."""
    forces = np.repeat([0.0, 5e-5, 1e-4, 2e-4], 100)
    clean = output_at(SETUP, "force", np.array([0.0, 5e-5, 1e-4, 2e-4]))
    volts = np.repeat(clean, 100) + SETUP.sensor.noise(forces.size, RATE, rng=seed) + offset
    return forces, volts


def _rows(path: Path) -> list[dict[str, str]]:
    return list(csv.DictReader(path.read_text().splitlines()))


def _run(args: list[str], capsys: pytest.CaptureFixture[str]) -> str:
    assert main(["readout", "paper", *args, "--quantity", "force", "--span", "0:0.2", *TIP]) == 0
    return capsys.readouterr().out


def test_edges_of_the_span(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    forces, volts = _session()
    rec = _record(tmp_path / "rec.csv", volts)
    out = tmp_path / "est.csv"
    blank = _run([str(rec), "--out", str(out), "--edge", "blank"], capsys)
    rows = _rows(out)
    empty = sum(r["force_mN"] == "" for r in rows)
    assert 60 <= empty <= 140  # about half of the unloaded and of the full-scale readings
    assert f"{400 - empty}/400 readings estimated" in blank
    line = _run([str(rec), "--out", str(out)], capsys)
    rows = _rows(out)
    assert all(r["force_mN"] != "" and r["sigma_force_mN"] != "" for r in rows)
    assert "400/400 readings estimated" in line and f"{empty} extrapolated" in line
    names = {r["flag_names"] for r in rows}
    assert names == {"", "extrapolated|below_span", "extrapolated|above_span"}
    got = np.array([float(r["force_mN"]) for r in rows])
    for f in (0.0, 5e-5, 1e-4, 2e-4):
        part = got[forces == f]
        assert abs(part.mean() - f * 1e3) < 4 * part.std() / np.sqrt(part.size)
    # the summary is in the CSV's unit (mN), as is the JSON
    assert "force -0." in line and " mN, median 1-σ" in line and "table error ≤" in line
    doc = json.loads(_run([str(rec), "--out", str(out), "--edge", "clip", "--edge-tolerance",
                           "10%", "--json"], capsys))
    assert doc["clipped"] == empty and doc["edge"] == "clip"
    assert doc["edge_tolerance_mN"] == pytest.approx([0.02, 0.02])
    rows = _rows(out)
    clipped = [r for r in rows if "clipped" in r["flag_names"]]
    assert len(clipped) == empty and {float(r["force_mN"]) for r in clipped} == {0.0, 0.2}


def test_json_summary_in_display_or_si_units(tmp_path: Path,
                                             capsys: pytest.CaptureFixture[str]) -> None:
    _, volts = _session()
    rec = _record(tmp_path / "rec.csv", volts)
    out = tmp_path / "est.csv"
    doc = json.loads(_run([str(rec), "--out", str(out), "--json", "--edge-tolerance",
                           "0.02mN"], capsys))
    assert doc["unit"] == "mN" and doc["units"] == "display"
    assert doc["span_mN"] == [0.0, 0.2]
    assert doc["edge_tolerance_mN"] == pytest.approx([0.02, 0.02])
    assert doc["readings"] == doc["estimated"] == 400 and doc["outside_span"] == 0
    assert doc["extrapolated"] == doc["below_span"] + doc["above_span"] > 0
    assert doc["range_mN"][0] < 0 < 0.2 < doc["range_mN"][1] < 0.22
    assert len(doc["output_range_mV"]) == 2 and doc["tare"] is None
    assert not any(k.endswith(("_N", "_V")) for k in doc)
    si = json.loads(_run([str(rec), "--out", str(out), "--json", "--si"], capsys))
    assert si["unit"] == "N" and si["units"] == "SI" and si["span_N"] == [0.0, 2e-4]
    assert si["median_sigma_N"] == pytest.approx(doc["median_sigma_mN"] * 1e-3, rel=1e-12)
    assert si["output_range_V"] == pytest.approx([x * 1e-3 for x in doc["output_range_mV"]])
    header = out.read_text().splitlines()[0]
    assert header == "time_s,voltage_V,force_N,sigma_force_N,flags,flag_names"
    line = _run([str(rec), "--out", str(out), "--si"], capsys)
    assert " N, median 1-σ" in line and "mN" not in line


@pytest.mark.parametrize("how", ["0.1s", "100ms", "100", "file"])
def test_tare_removes_an_unknown_offset(how: str, tmp_path: Path,
                                        capsys: pytest.CaptureFixture[str]) -> None:
    forces, volts = _session(offset=4e-4)  # 4 mV/10 ≈ 0.4 gauss: far beyond the span
    rec = _record(tmp_path / "rec.csv", volts)
    out = tmp_path / "est.csv"
    untared = json.loads(_run([str(rec), "--out", str(out), "--json"], capsys))
    assert untared["estimated"] < 300
    if how == "file":
        _, base = _session(offset=4e-4, seed=9)
        tare = ["--tare-file", str(_record(tmp_path / "zero.csv", base[:100], times=False))]
    else:
        tare = ["--tare", how]
    doc = json.loads(_run([str(rec), "--out", str(out), "--json", *tare], capsys))
    assert doc["estimated"] == 400
    assert doc["tare"]["readings"] == 100
    assert doc["tare"]["correction_mV"] == pytest.approx(-0.4, abs=0.01)
    assert doc["tare"]["standard_error_mV"] == pytest.approx(
        doc["tare"]["noise_mV"] / 10, rel=1e-12)
    got = np.array([float(r["force_mN"]) for r in _rows(out)])
    sigma = np.array([float(r["sigma_force_mN"]) for r in _rows(out)])
    for f in (0.0, 5e-5, 1e-4, 2e-4):
        part = got[forces == f]
        assert abs(part.mean() - f * 1e3) < 5 * np.median(sigma) / np.sqrt(10)
    if how != "file":  # the baseline itself averages to zero, far within its standard error
        assert abs(got[:100].mean()) < 0.05 * np.median(sigma[:100]) / np.sqrt(100)
    line = _run([str(rec), "--out", str(out), *tare], capsys)
    assert "tared on 100 readings (zero " in line and " mV ± " in line


@pytest.mark.parametrize(
    ("args", "match"),
    [
        (["--tare", "0.1s", "--tare-file", "x.csv"], "either --tare or --tare-file"),
        (["--tare", "abc"], "--tare must be a duration"),
        (["--tare", "0.5"], "--tare must be a duration"),
        (["--tare", "1"], "covering at least 2 readings"),
        (["--tare", "9999"], "at most the recording's 400 readings"),
        (["--tare-file", "missing.csv"], "missing.csv"),
        (["--edge-tolerance", "-1%"], "--edge-tolerance must be a non-negative"),
        (["--edge-tolerance", "3 parsecs"], "--edge-tolerance must be a percentage"),
        (["--edge", "wrap"], "Invalid value for '--edge'"),
    ],
)
def test_errors_are_one_line(args: list[str], match: str, tmp_path: Path,
                             capsys: pytest.CaptureFixture[str]) -> None:
    _, volts = _session()
    rec = _record(tmp_path / "rec.csv", volts)
    out = tmp_path / "est.csv"
    code = main(["readout", "paper", str(rec), "--quantity", "force", "--span", "0:0.2", *TIP,
                 "--out", str(out), *args])
    assert code == 2
    err = capsys.readouterr().err
    assert match in err and "Traceback" not in err
    assert not out.exists()


def test_tare_by_duration_needs_times(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    _, volts = _session()
    rec = _record(tmp_path / "rec.csv", volts, times=False)
    assert main(["readout", "paper", str(rec), "--quantity", "force", "--span", "0:0.2", *TIP,
                 "--out", str(tmp_path / "e.csv"), "--tare", "0.1s"]) == 2
    assert "the recording has no time_s column" in capsys.readouterr().err
    _run([str(rec), "--out", str(tmp_path / "e.csv"), "--tare", "100"], capsys)
    assert _rows(tmp_path / "e.csv")[0].keys() == {"voltage_V", "force_mN", "sigma_force_mN",
                                                   "flags", "flag_names"}


@pytest.mark.parametrize("quiet", [False, True])
def test_progress_on_a_terminal_unless_quiet(quiet: bool, tmp_path: Path,
                                             capsys: pytest.CaptureFixture[str],
                                             monkeypatch: pytest.MonkeyPatch) -> None:
    _, volts = _session()
    rec = _record(tmp_path / "rec.csv", volts)
    monkeypatch.setattr(readout_cli, "PROGRESS_READINGS", 100)
    monkeypatch.setattr(sys.stderr, "isatty", lambda: True)
    assert main(["readout", "paper", str(rec), "--quantity", "force", "--span", "0:0.2", *TIP,
                 "--out", str(tmp_path / "e.csv"), *(["--quiet"] if quiet else [])]) == 0
    err = capsys.readouterr().err
    assert ("readout" in err and "400/400" in err) != quiet
