"""``magcilia plan``: the table next to the paper's sweep, JSON with unit suffixes, --si, and
one-line errors."""

from __future__ import annotations

import json

import pytest

from magcilia.cli import main


def test_plan_prints_the_comparison(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["plan", "paper", "--budget", "33", "--prior", "height=3.26:0.1",
                 "--noise", "0.05"]) == 0
    out = capsys.readouterr().out
    assert "paper (1 path)" in out and "plan" in out
    for name in ("height", "base_radius", "x", "y", "z"):
        assert f"σ {name} (mm)" in out
    assert "condition number" in out and "rank" in out
    assert "planned readings (azimuth: angles in deg" in out
    assert "undetermined" not in out


def test_plan_without_a_prior_says_what_is_undetermined(
        capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["plan", "paper", "--budget", "12", "--sensor", "field"]) == 0
    out = capsys.readouterr().out
    assert "undetermined by any design here" in out and "--prior" in out


def test_plan_json_in_display_and_si_units(capsys: pytest.CaptureFixture[str]) -> None:
    argv = ["plan", "paper", "--budget", "10", "--prior", "height=3.26:0.1", "--azimuths",
            "0,45deg,90", "--angles", "0:80:10", "--json"]
    assert main(argv) == 0
    doc = json.loads(capsys.readouterr().out)
    assert doc["units"] == "display" and doc["budget"] == 10
    assert sum(c["repeats"] for c in doc["conditions"]) == 10
    assert all(set(c) == {"angle_deg", "azimuth_deg", "repeats"} for c in doc["conditions"])
    assert {c["azimuth_deg"] for c in doc["conditions"]} <= {0.0, 45.0, 90.0}
    assert set(doc["plan"]["stderr"]) == {"height_mm", "base_radius_mm", "x_mm", "y_mm", "z_mm"}
    assert doc["plan"]["stderr"]["height_mm"] == pytest.approx(0.1, rel=1e-3)
    assert len(doc["paper"]["angles_deg"]) == 10 and "noise_mV" in doc
    assert main([*argv, "--si"]) == 0
    si = json.loads(capsys.readouterr().out)
    assert si["units"] == "SI" and si["plan"]["stderr"]["height_m"] == pytest.approx(1e-4, rel=1e-3)
    assert "noise_V" in si and "angle_rad" in si["conditions"][0]


@pytest.mark.parametrize(("argv", "message"), [
    (["--budget", "4"], "--budget must be at least 5 readings"),
    (["--budget", "10", "--prior", "height=3:0"], "positive SIGMA"),
    (["--budget", "10", "--prior", "mass=3:1"], "NAME one of height"),
    (["--budget", "10", "--noise", "-1"], "--noise"),
    (["--budget", "10", "--azimuths", "0,abc"], "--azimuths"),
])
def test_bad_input_is_one_line(argv: list[str], message: str,
                               capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["plan", "--setup", "paper", *argv]) == 2
    err = capsys.readouterr().err
    assert message in err and err.count("\n") == 1 and "Traceback" not in err
