"""What the readers find reaches every output of the commands (issue 25): a sweep cut short is
reported as incomplete by ``calibrate`` (console, report.md, result.json, with the planned
angles it lacks), a recording cut before its first chunk is one error line in ``calibrate`` and
``readout``, and the quality checks' findings are counted in ``calibrate``, ``readout`` and
``batch calibrate`` (``--suspect`` shared by the three)."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

import magcilia as mc
from magcilia.cli import main
from magcilia.io.csvfile import write_samples_csv

nptdms = pytest.importorskip("nptdms")

SETUP = mc.Setup.paper()
PLANNED = list(np.arange(0.0, 85.0, 5.0))  # 17 angles
PER = 40
FAST = ["--setup", "paper", "--starts", "8", "--quiet"]


def _samples(angles: list[float], seed: int = 1) -> dict[str, np.ndarray]:
    angle = np.repeat(np.asarray(angles, dtype=np.float64), PER)
    volts = SETUP.output(np.radians(angle)) + np.random.default_rng(seed).normal(0, 2e-6,
                                                                                angle.size)
    return {"time_s": np.arange(angle.size) * 1e-3, "voltage_V": volts, "angle_deg": angle}


def _sweep(path: Path, angles: list[float], *, closing: dict[str, object] | None) -> Path:
    """A sweep as magcilia records one (crafted with npTDMS), killed before its closing note
    when ``closing`` is None."""
    props = {"magcilia_version": "0.test", "complete": False, "samples_per_angle": PER,
             "planned_angles_deg": json.dumps(PLANNED), "rate_Hz": 1000.0}
    cols = _samples(angles) if angles else {}
    with path.open("wb") as f, nptdms.TdmsWriter(f) as writer:
        writer.write_segment([nptdms.RootObject(props), nptdms.GroupObject("recording")])
        for a in angles:
            rows = cols["angle_deg"] == a
            writer.write_segment([nptdms.ChannelObject("recording", k, v[rows])
                                  for k, v in cols.items()])
        if closing is not None:
            writer.write_segment([nptdms.RootObject(closing)])
    return path


def test_calibrate_reports_a_cut_sweep_as_incomplete(tmp_path: Path,
                                                     capsys: pytest.CaptureFixture[str]) -> None:
    path = _sweep(tmp_path / "cut.tdms", PLANNED[:12], closing=None)
    out = tmp_path / "cal"
    assert main(["calibrate", str(path), "--out", str(out), *FAST]) == 0
    console = capsys.readouterr().out
    missing = "missing 60, 65, 70, 75, 80 deg"
    line = (f"note: {path}: the recording is incomplete (complete=False: it was cut short); "
            f"12 of 17 planned angles recorded, {missing}")
    assert line in console.splitlines()
    report = (out / "report.md").read_text()
    assert "## Data" in report and "note: the recording is incomplete" in report
    assert missing in report
    (data,) = json.loads((out / "result.json").read_text())["data"]
    assert data["recording"]["complete"] is False
    assert data["recording"]["missing_angles_deg"] == [60.0, 65.0, 70.0, 75.0, 80.0]
    assert data["notes"][0].startswith("the recording is incomplete")
    assert data["quality"]["flagged"] == 0


def test_a_complete_sweep_has_nothing_to_say(tmp_path: Path,
                                             capsys: pytest.CaptureFixture[str]) -> None:
    path = _sweep(tmp_path / "whole.tdms", PLANNED,
                  closing={"complete": True, "samples": PER * len(PLANNED)})
    out = tmp_path / "cal"
    assert main(["calibrate", str(path), "--out", str(out), *FAST, "--json"]) == 0
    doc = json.loads(capsys.readouterr().out)
    assert doc["data"][0]["notes"] == [] and doc["data"][0]["recording"]["complete"] is True


@pytest.mark.parametrize("command", ["calibrate", "readout"])
def test_a_recording_cut_before_its_first_chunk(tmp_path: Path, command: str,
                                                capsys: pytest.CaptureFixture[str]) -> None:
    path = _sweep(tmp_path / "empty.tdms", [], closing=None)
    out = tmp_path / "out"
    argv = (["calibrate", str(path), "--out", str(out), *FAST] if command == "calibrate" else
            ["readout", "--setup", "paper", str(path), "--quantity", "angle", "--span", "0:80",
             "--csv", str(tmp_path / "ro.csv")])
    assert main(argv) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert err == [(f"magcilia: error: {path}: the recording was cut before its first chunk "
                   "(complete=False, no samples on disk); record again")]
    assert not out.exists() and not (tmp_path / "ro.csv").exists()


def test_calibrate_names_a_dropped_digit_and_omits_it_on_request(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    cols = _samples(PLANNED)
    del cols["time_s"]
    cols["angle_deg"][PER * 8 + 3] = 4.0  # 40 -> 4 deg: a 1-sample "angle"
    path = write_samples_csv(tmp_path / "digit.csv", cols)
    assert main(["calibrate", str(path), "--out", str(tmp_path / "keep"), *FAST]) == 0
    console = capsys.readouterr().out
    assert (f"note: {path}: quality: 1 condition with far fewer samples than the others "
            "(median 40): 4 deg (1 sample); this sample is kept (omit them: --suspect omit)"
            ) in console
    assert "calibration of" in console and ": 18 angles" in console
    doc = json.loads((tmp_path / "keep" / "result.json").read_text())
    assert doc["data"][0]["quality"]["sparse_counts"] == [1]
    assert "1 sparse conditions" in (tmp_path / "keep" / "report.md").read_text()
    assert main(["calibrate", str(path), "--out", str(tmp_path / "omit"), *FAST,
                 "--suspect", "omit"]) == 0
    assert ": 17 angles" in capsys.readouterr().out
    assert main(["calibrate", str(path), "--out", str(tmp_path / "raise"), *FAST,
                 "--suspect", "raise"]) == 2
    assert "clean the recording" in capsys.readouterr().err
    assert not (tmp_path / "raise").exists()


def test_readout_reports_a_spike(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    t = np.arange(3000) * 1e-3
    volts = SETUP.output(np.radians(30.0 + 20.0 * np.sin(t))) + np.random.default_rng(2).normal(
        0.0, 2e-6, t.size)
    volts[1234] += 5e-3
    path = write_samples_csv(tmp_path / "ro.csv", {"time_s": t, "voltage_V": volts})
    base = ["readout", "paper", str(path), "--quantity", "angle", "--span", "0:80"]
    assert main([*base, "--out", str(tmp_path / "a.csv"), "--json"]) == 0
    doc = json.loads(capsys.readouterr().out)
    assert doc["quality"]["outliers"] == 1 and doc["quality"]["condition"] == "time"
    assert "spikes" in doc["notes"][0]
    assert main([*base, "--out", str(tmp_path / "b.csv"), "--suspect", "omit"]) == 0
    console = capsys.readouterr().out
    assert "this sample is left out" in console
    assert len((tmp_path / "b.csv").read_text().splitlines()) == len(
        (tmp_path / "a.csv").read_text().splitlines()) - 1


def test_batch_counts_what_was_flagged(tmp_path: Path,
                                       capsys: pytest.CaptureFixture[str]) -> None:
    for name, bad in (("a", False), ("b", True)):
        cols = _samples(PLANNED, seed=3)
        if bad:
            cols = {k: np.concatenate([v[:200], v[100:200], v[200:]]) for k, v in cols.items()}
        write_samples_csv(tmp_path / f"{name}.csv", cols)
    out = tmp_path / "batch"
    assert main(["batch", "calibrate", str(tmp_path / "*.csv"), "--out", str(out), "--setup",
                 "paper", "--starts", "16", "--workers", "1", "--no-figures", "--quiet"]) == 0
    console = capsys.readouterr().out
    assert "note: b: quality: 100 rows repeating earlier rows bit for bit" in console
    rows = {r["recording"]: r for r in mc.batch.calibrate_batch(
        str(tmp_path / "*.csv"), out, setup=SETUP, starts=16, workers=1, figures=False,
        progress=False).rows}
    assert rows["a"]["flagged"] == 0 and rows["a"]["notes"] == ""
    assert rows["b"]["flagged"] == 100 and "100 rows repeating" in rows["b"]["notes"]
    assert "note: b: quality" in (out / "summary.md").read_text()
