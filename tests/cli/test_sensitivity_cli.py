"""The `sensitivity` and `approximate` commands run in-process: files, tables, JSON, C header,
errors (exit code 2, one line, nothing written)."""

from __future__ import annotations

import json
import re
import sys
from pathlib import Path

import numpy as np
import pytest

import magcilia as mc
from magcilia.acquire.synthetic import synthetic_recording
from magcilia.cli import main


@pytest.fixture
def recording(tmp_path: Path) -> Path:
    rec = synthetic_recording(mc.Setup.paper(), np.radians(np.linspace(0.0, 85.0, 12)),
                              samples_per_angle=10, rng=5)
    path = tmp_path / "rec.csv"
    lines = ["angle_deg,voltage_V"] + [
        f"{a:.17g},{v:.17g}" for a, v in zip(rec.angle_deg, rec.voltage, strict=True)]
    path.write_text("\n".join(lines) + "\n")
    return path


def test_help_lists_both_commands(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["--help"]) == 0
    out = capsys.readouterr().out
    assert "sensitivity" in out and "approximate" in out
    assert main(["sensitivity", "--help"]) == 0
    assert "mm" in capsys.readouterr().out
    assert main(["approximate", "--help"]) == 0
    assert "degrees" in capsys.readouterr().out


def test_sensitivity_writes_report(tmp_path: Path, recording: Path,
                                   capsys: pytest.CaptureFixture[str]) -> None:
    out = tmp_path / "sens"
    code = main(["sensitivity", "paper", "--data", str(recording), "--out", str(out),
                 "--points", "5", "--map-points", "5", "--sobol-base", "64",
                 "--span", "z=0:0.8", "--accuracy", "0.5", "--sobol-measure", "cost"])
    assert code == 0
    text = capsys.readouterr().out
    assert "min cost/V^2" in text and "x must be known to" in text and "Sobol indices" in text
    names = {p.name for p in out.iterdir()}
    assert {"fig09_xy.png", "fig12_geometry.png", "xy_map.png", "sobol.png", "sensitivity.json",
            "summary.md"} <= names
    doc = json.loads((out / "sensitivity.json").read_text())
    assert doc["units"] == "display" and doc["spans"]["z_mm"] == pytest.approx([0.0, 0.8])
    assert doc["data"] == str(recording) or doc["data"].endswith("rec.csv")
    assert doc["tolerance"]["angle_accuracy_deg"] == pytest.approx(0.5)
    assert doc["sobol"]["measure"] == "cost" and doc["sobol"]["n_evaluations"] == 64 * 9
    assert not [p for p in tmp_path.iterdir() if p.name.startswith(".")]  # staging removed


def test_sensitivity_json_stdout(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["sensitivity", "paper", "--out", str(tmp_path / "o"), "--points", "3",
                 "--map-points", "3", "--sobol-base", "0", "--json"]) == 0
    doc = json.loads(capsys.readouterr().out)
    assert doc["sobol"] is None and doc["sweeps"]["n_loops"]["values"] == list(range(1, 11))


@pytest.mark.parametrize(
    ("args", "match"),
    [
        (["--sweep", "w=0:1"], "--sweep must be NAME=LOW:HIGH with NAME one of"),
        (["--sweep", "z=1:0"], r"--sweep must be NAME=LOW:HIGH with LOW <= HIGH; got 'z=1:0'"),
        (["--sweep", "height=-1:3"],
         r"--sweep must be positive values within \[1e-06, 1000\] mm; got 'height=-1:3'"),
        (["--sobol-base", "100"], "n_base must be a power of 2"),
        (["--bandwidth", "10:1"], "--bandwidth must be a range with stop > start"),
        (["--bandwidth", "0:10"], "--bandwidth must be F_LOW:F_HIGH in Hz with 0 < F_LOW"),
        (["--accuracy", "0"], "--accuracy must be a positive angle"),
        (["--sobol-measure", "cost", "--sobol-base", "64"],
         "--sobol-measure must be used with --data"),
        (["--data", "missing.csv"], "missing.csv"),
    ],
    ids=["span-name", "span-reversed", "negative-height", "sobol-base", "band", "band-zero",
         "accuracy", "cost-without-data", "missing-data"],
)
def test_sensitivity_errors(args: list[str], match: str, tmp_path: Path,
                            capsys: pytest.CaptureFixture[str]) -> None:
    out = tmp_path / "o"
    code = main(["sensitivity", "--setup", "paper", "--out", str(out), "--points", "3",
                 "--map-points", "3",
                 *args])
    assert code == 2
    err = capsys.readouterr().err
    assert err.startswith("magcilia: error: ") and re.search(match, err)
    assert len(err.strip().splitlines()) == 1
    assert not out.exists()


def test_approximate_table(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["approximate", "paper", "--corners", "2", "--range", "0:85",
                 "--table-size", "64"]) == 0
    out = capsys.readouterr().out
    approx = mc.piecewise_linear(mc.Setup.paper(), 2)
    for k, v in zip(np.degrees(approx.knots), approx.values, strict=True):
        assert f"{k:10.4f} {v * 1e3:12.6f}" in out
    assert f"max error {approx.max_error * 1e3:.4g} mV" in out
    assert "lookup table V->angle, 64 entries" in out


def test_approximate_json_and_c_header(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    header, js = tmp_path / "approx.h", tmp_path / "approx.json"
    assert main(["approximate", "paper", "--corners", "1", "--range", "5:60", "--json",
                 "--c-header", str(header), "--fixed-point", "--name", "cil",
                 "--json-file", str(js)]) == 0
    doc = json.loads(capsys.readouterr().out)
    assert doc["corners"] == 1 and doc["angle_range_deg"] == pytest.approx([5, 60])
    assert json.loads(js.read_text()) == doc
    assert main(["approximate", "paper", "--corners", "1", "--range", "5:60", "--json",
                 "--si"]) == 0  # the SI document is the one PiecewiseLinear.from_dict reads
    doc = json.loads(capsys.readouterr().out)
    text = header.read_text()
    assert "int32_t cil_output_q(int32_t tilt_q)" in text and "CIL_VOLT_FRAC_BITS" in text
    again = mc.approximation.PiecewiseLinear.from_dict(doc)
    assert again(np.radians([30.0]))[0] == pytest.approx(
        mc.Setup.paper().output(np.radians([30.0]))[0], abs=doc["max_error_V"] * 1.01)


@pytest.mark.parametrize(
    ("args", "match"),
    [
        (["--range", "85:0"], "--range must be a range with stop > start"),
        (["--range", "0:85:5"], "--range must be START:STOP in degrees (no step)"),
        (["--corners", "-1"], "corners must be an integer >= 0"),
        (["--corners", "5", "--grid", "6"], "corners must be at most 4"),
        (["--name", "bad name", "--c-header", "x.h"], "name must be a C identifier"),
        (["centred.toml", "--table-size", "8"], "lookup table needs a strictly monotonic"),
    ],
    ids=["reversed", "step", "negative", "too-many", "c-name", "fold"],
)
def test_approximate_errors(args: list[str], match: str, tmp_path: Path,
                            capsys: pytest.CaptureFixture[str],
                            monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.chdir(tmp_path)
    mc.save_setup(mc.Setup.paper(y=0.0), tmp_path / "centred.toml")  # output turns at ~56 deg
    args = list(args)
    setup = args.pop(0) if args[0].endswith(".toml") else "paper"
    assert main(["approximate", "--setup", setup, *args]) == 2
    err = capsys.readouterr().err
    assert err.startswith("magcilia: error: ") and match in err
    assert not (tmp_path / "x.h").exists()


def test_sensitivity_without_salib_says_how(tmp_path: Path, monkeypatch: pytest.MonkeyPatch,
                                            capsys: pytest.CaptureFixture[str]) -> None:
    monkeypatch.setitem(sys.modules, "SALib", None)  # as if the extra were not installed
    out = tmp_path / "o"
    assert main(["sensitivity", "paper", "--out", str(out), "--points", "3",
                 "--map-points", "3"]) == 2
    err = capsys.readouterr().err
    assert "magcilia[sensitivity]" in err and "--sobol-base 0" in err and not out.exists()
    assert main(["sensitivity", "paper", "--out", str(out), "--points", "3", "--map-points", "3",
                 "--sobol-base", "0"]) == 0
    assert (out / "sensitivity.json").is_file()
