"""``magcilia optimise`` in-process: units, files, the chosen setup, one-line errors."""

from __future__ import annotations

import csv
import json
from pathlib import Path

import pytest

import magcilia as mc
from magcilia.cli import main

FAST = ["--designs", "128", "--refine", "12", "--workers", "1", "--quiet", "--seed", "2"]


def _run(capsys: pytest.CaptureFixture[str], argv: list[str]) -> str:
    assert main(argv) == 0, capsys.readouterr().err
    return capsys.readouterr().out


def test_display_units_by_default_and_si_with_si(tmp_path: Path,
                                                 capsys: pytest.CaptureFixture[str]) -> None:
    doc = json.loads(_run(capsys, ["optimise", "force-sensor", *FAST, "--min-force", "1uN",
                                   "--json"]))
    assert doc["units"] == "display" and doc["objective"] == "force-range"
    best = doc["best"]
    assert {"height_mm", "x_mm", "minimum_mN", "range_mN", "peak_field_gauss",
            "cobalt_mass_mg"} <= set(best)
    assert doc["constraints"]["min_force_mN"] == pytest.approx(1e-3)
    assert best["minimum_mN"] <= 1e-3
    si = json.loads(_run(capsys, ["optimise", "force-sensor", *FAST, "--min-force", "1uN",
                                 "--json", "--si"]))
    assert si["units"] == "SI"
    assert si["best"]["range_N"] == pytest.approx(best["range_mN"] * 1e-3, rel=1e-12)
    assert si["best"]["height_m"] == pytest.approx(best["height_mm"] * 1e-3, rel=1e-12)
    text = _run(capsys, ["optimise", "force-sensor", *FAST, "--min-force", "0.001"])
    assert "mN" in text and "Pareto front (minimum_mN, range_mN, sensor)" in text
    # the comparison with SETUP is a statement (the JSON keys stay beats_reference, comparison)
    assert isinstance(doc["beats_reference"], bool)
    assert f"\ncompared with SETUP's: {doc['comparison']}\n" in text
    assert doc["comparison"].startswith("resolution ") and "?" not in doc["comparison"]


def test_files_and_the_chosen_setup(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    out = {k: tmp_path / n for k, n in (("csv", "front.csv"), ("json", "r.json"),
                                       ("plot", "pareto.png"), ("setup", "best.toml"))}
    _run(capsys, ["optimise", *FAST, "--bound", "height=2mm:5mm", "--bound", "z=0:0.5",
                  "--csv", str(out["csv"]), "--json-file", str(out["json"]),
                  "--plot", str(out["plot"]), "--setup-out", str(out["setup"])])
    doc = json.loads(out["json"].read_text())
    with out["csv"].open() as f:
        rows = list(csv.DictReader(f))
    assert len(rows) == len(doc["front"]) and "range_mN" in rows[0]
    assert all(2.0 <= float(r["height_mm"]) <= 5.0 and float(r["z_mm"]) <= 0.5 for r in rows)
    best = mc.load_setup(out["setup"])
    assert best.cilium.height * 1e3 == pytest.approx(doc["best"]["height_mm"], rel=1e-9)
    force = mc.design_metrics(best).force
    assert force.range * 1e3 == pytest.approx(doc["best"]["range_mN"], rel=1e-6)
    assert out["plot"].read_bytes().startswith(b"\x89PNG")


def test_flow_objective(capsys: pytest.CaptureFixture[str]) -> None:
    doc = json.loads(_run(capsys, ["optimise", *FAST, "--objective", "flow-sensitivity",
                                   "--speed", "200mm/s", "--json"]))
    assert doc["quantity"] == "flow" and doc["constraints"]["speed_m_per_s"] == 0.2
    assert doc["best"]["range_m_per_s"] >= 0.2 and "minimum_m_per_s" in doc["best"]


@pytest.mark.parametrize(("argv", "message"), [
    (["--min-force", "1e-9mN"], "min_force must be reachable within the bounds"),
    (["--bound", "x=0:0", "--bound", "y=0:0", "--bound", "z=0:0", "--bound",
      "base_radius=0.4:0.4"], "'sensor range at zero load' constraint eliminated all"),
    (["--bound", "x=0:0", "--bound", "y=0:0", "--bound", "z=0:0", "--bound",
      "base_radius=0.4:0.4", "--max-field", "100gauss"], "'flip field' constraint eliminated"),
    (["--objective", "flow-sensitivity"], "speed must be a flow speed"),
    (["--bound", "colour=1:2"], "--bound must be NAME=LOW:HIGH with NAME one of"),
    (["--sensors", "HMC1021Z,NOPE"], "sensor must be HMC1021Z"),
    (["--min-force", "1mm"], "--min-force"),
    (["--plot", "pareto.nope"], "--plot must be a figure file"),
])
def test_errors_are_one_line(argv: list[str], message: str, tmp_path: Path,
                             capsys: pytest.CaptureFixture[str]) -> None:
    csv_path = tmp_path / "front.csv"
    assert main(["optimise", *FAST, *argv, "--csv", str(csv_path)]) == 2
    err = capsys.readouterr().err
    assert err.startswith("magcilia: error: ") and message in err, err
    assert err.count("\n") == 1
    assert not csv_path.exists()
