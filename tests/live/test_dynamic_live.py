"""``magcilia live --dynamic`` and ``--sim-dynamics``: the dynamic read-out in the live pipeline,
the simulated hair that moves, and the views saying which read-out is in use."""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest

from magcilia.cli import main
from magcilia.cli._live import build_live
from magcilia.live.feed import Dashboard
from magcilia.live.render import summary_line
from magcilia.readout.dynamic import DynamicReadout

OPTIONS = {"source_spec": "sim", "setup_arg": "force-sensor", "quantity": "force",
           "span_text": None, "calibration_path": None, "fluid": "water", "rate": None,
           "source_rate": None, "channel": "output", "set_reset": None, "no_tare": False,
           "tracking": 30.0, "record_dir": "recordings", "seed": 0, "tip_radius": None,
           "modulus": None}


def _values(text: str) -> list[dict[str, object]]:
    return [d for d in (json.loads(x) for x in text.splitlines() if x.startswith("{"))
            if "value" in d]


def test_live_dynamic_streams_estimates(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["live", "--dynamic", "--duration", "1.5", "--json-lines", "--every", "20"]) == 0
    lines = _values(capsys.readouterr().out)
    assert len(lines) >= 5  # a 1.5 s run prints ~70; a loaded machine starts late (no timing)
    good = [d for d in lines if d["value"] is not None and not d["flags"]]
    assert good and all(math.isfinite(d["value"]) and d["sigma"] > 0 for d in good)


def test_the_views_say_which_read_out_is_in_use() -> None:
    live = build_live(**OPTIONS, dynamic=True)
    assert isinstance(live.readout, DynamicReadout)
    assert live.readout.averaged and live.readout.rate == 1000.0
    assert live.source.dynamics  # the simulated hair moves too
    limits = live.limits()
    assert limits.mode.startswith("dynamic read-out (Kalman")
    assert "dynamic read-out" in limits.report()
    info = Dashboard(live).info()
    assert info["mode"].startswith("dynamic read-out") and "Kalman" in info["readout"]
    with live:
        live.wait(50)
        line = summary_line(live.status, live.history.last(1.0, live.rate), limits)
    assert "(dynamic)" in line
    static = build_live(**OPTIONS)
    assert static.limits().mode == "" and Dashboard(static).info()["mode"] == "static"
    assert not static.source.dynamics


def test_sim_dynamics_moves_the_hair_under_the_static_read_out() -> None:
    live = build_live(**OPTIONS, sim_dynamics=True)
    assert live.source.dynamics and not isinstance(live.readout, DynamicReadout)


@pytest.mark.parametrize(("args", "message"), [
    (["--sensor", "MMC5983MA", "--dynamic"], "--dynamic must be left out for a 3-axis sensor"),
    (["--source", "serial:/dev/null", "--sim-dynamics"],
     "--sim-dynamics must be given with --source sim only"),
    (["--dynamic", "--rate", "250"], "rate must be above twice the hair's first mode"),
])
def test_bad_combinations_are_one_line(args: list[str], message: str,
                                       capsys: pytest.CaptureFixture[str]) -> None:
    code = main(["live", *args, "--duration", "0.2", "--json-lines"])
    err = capsys.readouterr().err.strip().splitlines()
    assert code == 2 and len(err) == 1 and message in err[0]


def test_record_with_a_moving_hair(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    rec = tmp_path / "s.tdms"
    assert main(["record", "--setup", "force-sensor", "--sim-dynamics", "--angles", "0:10:10",
                 "--samples", "50", "--record", str(rec), "--json"]) == 0
    doc = json.loads(capsys.readouterr().out)
    assert rec.exists() and len(doc["points"]) == 2
    sharp = tmp_path / "sharp.tdms"
    code = main(["record", "--sim-dynamics", "--angles", "0:10:10", "--record", str(sharp)])
    err = capsys.readouterr().err.strip().splitlines()
    assert code == 2 and len(err) == 1 and "tip_radius must be > 0" in err[0]
    assert not sharp.exists()
    assert np.isfinite([p["mean_mV"] for p in doc["points"]]).all()


def test_a_dynamic_recording_replays_with_its_filter(tmp_path: Path,
                                                     capsys: pytest.CaptureFixture[str]) -> None:
    """``live --dynamic --record`` stores the filter (rate, bandwidth, window means, fluid);
    ``live --source FILE`` replays the same estimates; ``readout FILE`` reads it statically and
    says so."""
    rec = tmp_path / "d.tdms"
    assert main(["live", "--dynamic", "--duration", "1.2", "--record", str(rec),
                 "--json-lines"]) == 0
    shown = {d["t"]: d for d in _values(capsys.readouterr().out)}
    assert main(["live", "--source", str(rec), "--json-lines"]) == 0
    again = _values(capsys.readouterr().out)
    matched = [(shown[d["t"]], d) for d in again if d["t"] in shown and d["value"] is not None
               and shown[d["t"]]["value"] is not None]
    assert len(matched) > 500
    for a, b in matched:
        assert b["value"] == pytest.approx(a["value"], rel=1e-6, abs=1e-3 * a["sigma"])
        assert b["sigma"] == pytest.approx(a["sigma"], rel=1e-6)
    assert main(["readout", str(rec), "--csv", str(tmp_path / "r.csv")]) == 0
    assert "read here statically" in capsys.readouterr().out
