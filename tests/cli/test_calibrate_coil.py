"""``magcilia calibrate`` on a coil recording (examples/coil): the physical model with a height
prior writes the usual outputs; without size information it ends in one line, exit 2, nothing
written; the paper's model refuses coil data."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

import magcilia as mc
from magcilia.cli import main

EXAMPLE = Path(__file__).resolve().parents[2] / "examples" / "coil"
DATA, SETUP = str(EXAMPLE / "coil_3axis.csv"), str(EXAMPLE / "setup.toml")


def test_the_example_is_a_coil_recording() -> None:
    m = mc.read_measurements(DATA, sensor=mc.load_setup(SETUP).sensor)
    assert m.is_coil and len(m) == 43 and m.fields is not None
    assert not m.notes()  # nothing dropped: every field within the part's range


def test_the_paper_model_refuses_coil_data(tmp_path: Path,
                                          capsys: pytest.CaptureFixture[str]) -> None:
    out = tmp_path / "paper"
    assert main(["calibrate", DATA, "--setup", SETUP, "--out", str(out), "--quiet"]) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith("magcilia: error:") and "\n" not in err
    assert "3-axis field data under applied coil fields" in err and "physical" in err
    assert not out.exists()


@pytest.mark.slow
def test_coil_calibration_writes_outputs(tmp_path: Path,
                                         capsys: pytest.CaptureFixture[str]) -> None:
    out = tmp_path / "coil"
    assert main(["calibrate", DATA, "--setup", SETUP, "--model", "physical", "--prior",
                 "height=3.26:0.15", "--out", str(out), "--starts", "8", "--quiet"]) == 0
    text = capsys.readouterr().out
    assert "43 applied fields" in text
    assert {p.name for p in out.iterdir()} >= {"fitted_setup.toml", "result.json", "report.md",
                                               "fit.png"}
    result = mc.CalibrationResult.load(out / "result.json")
    truth = {"height": 3.2613e-3, "base_radius": 1.801e-4, "x": 1.4727e-3, "y": 1.9891e-3,
             "z": 3.804e-4, "magnetization_scale": 0.8}  # scripts/make_coil_recording.py
    for name, value in truth.items():
        assert abs(result.values[name] - value) < 2.0 * result.stderr[name], name
    assert json.loads((out / "result.json").read_text())["experiments"][0]["actuation_T"]


@pytest.mark.slow
def test_coil_calibration_without_size_exits_2(tmp_path: Path,
                                               capsys: pytest.CaptureFixture[str]) -> None:
    out = tmp_path / "nosize"
    assert main(["calibrate", DATA, "--setup", SETUP, "--model", "physical", "--out", str(out),
                 "--starts", "4", "--quiet"]) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith("magcilia: error: coil calibration:") and "\n" not in err
    assert "scale symmetry" in err and "--prior height=" in err
    assert not out.exists()
