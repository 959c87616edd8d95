"""``magcilia readout --dynamic``: a recorded time series read through the dynamic read-out."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

import magcilia as mc
from magcilia.cli import main

SETUP = mc.presets.load("force-sensor")


def _recording(path: Path, rate: float, n: int) -> None:
    load = np.r_[np.zeros(n // 4), np.full(n - n // 4, 1.6e-5)]
    r = mc.simulate_response(SETUP, load, rate, fluid=mc.AIR)
    volts = r.output + np.random.default_rng(0).normal(0.0, 2e-5, n)
    path.write_text("time_s,voltage_V\n" + "".join(
        f"{t!r},{v!r}\n" for t, v in zip(r.time.tolist(), volts.tolist(), strict=True)))


def test_readout_dynamic_writes_the_filtered_estimates(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    rec, out = tmp_path / "step.csv", tmp_path / "d.csv"
    _recording(rec, 10_000.0, 2000)
    args = ["readout", "--setup", "force-sensor", str(rec), "--quantity", "force", "--span",
            "-0.04:0.04", "--tare", "400", "--csv", str(out), "--force"]  # (written twice)
    assert main([*args, "--dynamic", "--json"]) == 0
    doc = json.loads(capsys.readouterr().out)
    assert doc["dynamic"]["rate_Hz"] == pytest.approx(10_000.0)
    assert doc["dynamic"]["fluid"] == "air"
    dynamic = np.genfromtxt(out, delimiter=",", names=True)
    assert main(args) == 0
    static = np.genfromtxt(out, delimiter=",", names=True)
    late = slice(1000, None)  # 3 periods after the step: the static read-out still rings
    truth = 0.016  # mN
    assert np.max(np.abs(dynamic["force_mN"][late] - truth)) < 0.5 * np.nanmax(
        np.abs(static["force_mN"][late] - truth))
    assert main([*args, "--dynamic"]) == 0
    assert "dynamic read-out (Kalman" in capsys.readouterr().out


@pytest.mark.parametrize(("rate", "extra", "message"), [
    (200.0, [], "the recording's rate (time_s) must be above twice the hair's first mode"),
    (10_000.0, ["--biaxial", "--sensor", "MMC5983MA"], "--dynamic must be given for a recording"),
])
def test_readout_dynamic_bad_input_is_one_line(tmp_path: Path, rate: float, extra: list[str],
                                               message: str,
                                               capsys: pytest.CaptureFixture[str]) -> None:
    rec, out = tmp_path / "r.csv", tmp_path / "d.csv"
    _recording(rec, rate, 400)
    code = main(["readout", "--setup", "force-sensor", str(rec), "--quantity", "force",
                 "--span", "-0.04:0.04", "--csv", str(out), "--dynamic", *extra])
    err = capsys.readouterr().err.strip().splitlines()
    assert code == 2 and len(err) == 1 and message in err[0]
    assert not out.exists()
