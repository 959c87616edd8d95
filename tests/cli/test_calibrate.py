"""The calibrate and demo commands, in-process."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

import magcilia as mc
from magcilia.cli import main
from magcilia.io import example_path


def test_bundled_example_is_labelled_synthetic() -> None:
    path = example_path()
    assert path.read_text().startswith("# SYNTHETIC")
    meta = json.loads(path.with_suffix(".json").read_text())
    assert meta["synthetic"] is True
    m = mc.read_measurements(path)
    assert len(m) == 33 and m.counts.tolist() == [2000] * 33


def test_demo_writes_the_report(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    out = tmp_path / "demo"
    assert main(["demo", "--out", str(out), "--quiet"]) == 0
    text = capsys.readouterr().out
    assert "cost" in text and "synthetic" in text
    names = {p.name for p in out.iterdir()}
    assert names == {"fitted_setup.toml", "result.json", "report.md", "fit.png", "residuals.png"}
    fitted = mc.load_setup(out / "fitted_setup.toml")
    result = json.loads((out / "result.json").read_text())
    data = mc.read_measurements(example_path())
    np.testing.assert_allclose(fitted.output(data.angles), result["fitted_V"],
                               rtol=1e-8, atol=1e-12)
    assert result["cost_V2"] < 1e-8  # within the synthetic noise
    assert "![data and models (Fig. 8)](fit.png)" in (out / "report.md").read_text()
    assert not [p for p in tmp_path.iterdir() if p.name.startswith(".")]


def test_calibrate_with_bounds_and_json(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    out = tmp_path / "cal"
    code = main(["calibrate", str(example_path()), "--setup", "paper", "--out", str(out),
                 "--bound", "height=3.2613:3.2613", "--bound", "base_radius=0.1801:0.1801",
                 "--bound", "n_loops=2:2", "--bound", "dipoles_per_loop=5:5",
                 "--bound", "y=0.5:3", "--restarts", "1", "--json", "--quiet"])
    assert code == 0
    doc = json.loads(capsys.readouterr().out)
    assert doc["units"] == "display"
    assert doc["values"]["x_mm"] == pytest.approx(1.4727, abs=0.1)
    assert doc["bounds"]["y_mm"] == pytest.approx([0.5, 3.0])
    saved = json.loads((out / "result.json").read_text())  # the format read back: SI
    assert saved["units"] == "SI" and saved["values"]["x"] == pytest.approx(
        doc["values"]["x_mm"] * 1e-3, rel=1e-12)
    assert (out / "fitted_setup.toml").exists()


@pytest.mark.parametrize(
    ("args", "match"),
    [
        (["--bound", "height=4:2"], "LOW <= HIGH"),
        (["--bound", "width=1:2"], "--bound must be NAME=LOW:HIGH"),
        (["--bound", "height=a:b"], "--bound must be NAME=LOW:HIGH"),
        (["--setup", "missing.toml"], "cannot access missing.toml"),
    ],
    ids=["reversed", "unknown", "text", "missing-setup"],
)
def test_calibrate_errors_leave_nothing(tmp_path: Path, capsys: pytest.CaptureFixture[str],
                                        args: list[str], match: str) -> None:
    out = tmp_path / "cal"
    code = main(["calibrate", str(example_path()), "--out", str(out), "--quiet", *args])
    assert code == 2
    err = capsys.readouterr().err
    assert match in err and err.count("\n") == 1
    assert not out.exists()
    assert not list(tmp_path.iterdir())


def test_calibrate_bad_data_file(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    bad = tmp_path / "bad.csv"
    bad.write_text("angle_deg,volts\n0,1\n")
    assert main(["calibrate", str(bad), "--out", str(tmp_path / "o"), "--quiet"]) == 2
    assert "missing column 'voltage_V'" in capsys.readouterr().err
    assert not (tmp_path / "o").exists()
