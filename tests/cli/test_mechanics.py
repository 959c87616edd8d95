"""The bend, readout and design commands, run in-process."""

from __future__ import annotations

import csv
import json
import math
from pathlib import Path

import numpy as np
import pytest

import magcilia as mc
from magcilia.cli import main

TIP = ["--tip-radius", "0.05mm"]


def test_help_mentions_units(capsys: pytest.CaptureFixture[str]) -> None:
    for name, unit in (("bend", "0.2mN"), ("readout", "mN"), ("design", "Hz")):
        assert main([name, "--help"]) == 0
        assert unit in capsys.readouterr().out


def test_bend_table_json_and_plot(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    png = tmp_path / "shape.png"
    assert main(["bend", "paper", "--force", "0.2mN", *TIP, "--plot", str(png)]) == 0
    out = capsys.readouterr().out
    assert "tip position" in out and "tip angle" in out and "output" in out
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert main(["bend", "paper", "--force", "0.2mN", *TIP, "--json"]) == 0
    doc = json.loads(capsys.readouterr().out)
    setup = mc.Setup.paper(tip_radius=5e-5)
    shape = mc.bend(setup, force=2e-4)
    np.testing.assert_allclose(doc["tip_mm"], shape.tip * 1e3, rtol=1e-12)
    assert doc["tip_angle_deg"] == pytest.approx(math.degrees(shape.tip_angle), rel=1e-12)
    assert doc["output_mV"] == pytest.approx(setup.output(shape)[0] * 1e3, rel=1e-12)
    assert doc["units"] == "display" and doc["load"]["force_mN"] == pytest.approx(0.2)
    assert len(doc["centreline_mm"]["x"]) == shape.s.size
    assert doc["centreline_mm"]["z"][0] == 0.0
    assert not list(tmp_path.glob(".*"))


def test_bend_flow_and_load_below_tip(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["bend", "paper", "--flow", "0.2m/s", "--fluid", "water", *TIP, "--json"]) == 0
    doc = json.loads(capsys.readouterr().out)
    expected = mc.bend(mc.Setup.paper(tip_radius=5e-5), flow=mc.Flow.uniform(0.2))
    np.testing.assert_allclose(doc["tip_mm"], expected.tip * 1e3, rtol=1e-10)
    # a sharp cone accepts a load below the tip
    assert main(["bend", "paper", "--force", "0.01mN", "--at", "2.5mm", "--json"]) == 0
    assert json.loads(capsys.readouterr().out)["load"]["at_mm"] == pytest.approx(2.5)


@pytest.mark.parametrize(
    ("args", "match"),
    [
        (["bend", "--setup", "paper", "--tip-force", "0.2mN"], "--tip-radius"),
        (["bend", "--setup", "paper", "--tip-force", "0.2mm"],
         "--tip-force must be a number in mN or with a force"),
        (["bend", "--setup", "paper", "--flow", "1e6m/s", *TIP], "drag law ends"),
        (["bend", "--setup", "paper", "--tip-force", "0.1mN", "--at", "9mm"],
         "at must be an arc length"),
        (["readout", "--setup", "paper", "missing.csv", "--quantity", "angle", "--span", "0:40",
          "--csv", "x.csv"], "missing.csv: no such file"),
        (["design", "--setup", "paper", "--bandwidth", "10:1"], "--bandwidth must be a range"),
    ],
    ids=["cone-tip", "wrong-unit", "too-fast", "at-beyond", "missing-recording", "bandwidth"],
)
def test_errors_are_one_line(args: list[str], match: str,
                             capsys: pytest.CaptureFixture[str]) -> None:
    assert main(args) == 2
    err = capsys.readouterr().err
    assert match in err
    assert err.count("\n") == 1 and "Traceback" not in err


def test_readout_writes_estimates_and_flags(tmp_path: Path,
                                            capsys: pytest.CaptureFixture[str]) -> None:
    setup = mc.Setup.paper(tip_radius=5e-5)
    forces = np.array([2e-5, 1e-4, 1.5e-4, 3e-4])  # the last one is beyond the span
    volts = setup.output(mc.bend_sweep(setup, forces=forces))
    rec = tmp_path / "rec.csv"
    rec.write_text("time_s,voltage_V\n" + "".join(
        f"{0.1 * i},{float(v)!r}\n" for i, v in enumerate(volts)))
    out = tmp_path / "est.csv"
    code = main(["readout", "paper", str(rec), "--quantity", "force", "--span", "0:0.2",
                 "--out", str(out), *TIP])
    assert code == 0
    assert "3/4 readings estimated" in capsys.readouterr().out
    rows = list(csv.DictReader(out.read_text().splitlines()))
    assert [r["flags"] for r in rows] == ["0", "0", "0", "65"]  # outside_span | above_span
    assert rows[3]["flag_names"] == "outside_span|above_span" and rows[3]["force_mN"] == ""
    np.testing.assert_allclose([float(r["force_mN"]) for r in rows[:3]], forces[:3] * 1e3,
                               atol=1e-5)  # table error ~1e-7 mN
    assert all(float(r["sigma_force_mN"]) > 0 for r in rows[:3])
    assert float(rows[2]["time_s"]) == pytest.approx(0.2)


def test_readout_angle_with_units_and_bad_recording(tmp_path: Path,
                                                    capsys: pytest.CaptureFixture[str]) -> None:
    setup = mc.Setup.paper()
    rec = tmp_path / "rec.csv"
    rec.write_text("voltage_V\n" + "".join(f"{float(v)!r}\n" for v in
                                           setup.output(np.radians([10.0, 30.0]))))
    out = tmp_path / "a.csv"
    assert main(["readout", "paper", str(rec), "--quantity", "angle", "--span", "0deg:60deg",
                 "--out", str(out), "--json"]) == 0
    assert json.loads(capsys.readouterr().out)["estimated"] == 2
    rows = list(csv.DictReader(out.read_text().splitlines()))
    np.testing.assert_allclose([float(r["angle_deg"]) for r in rows], [10.0, 30.0], atol=1e-3)
    bad = tmp_path / "bad.csv"
    bad.write_text("volts\n1.0\n")
    out2 = tmp_path / "never.csv"
    assert main(["readout", "paper", str(bad), "--quantity", "angle", "--span", "0:60",
                 "--out", str(out2)]) == 2
    assert "voltage_V" in capsys.readouterr().err
    assert not out2.exists()


def test_design_table_json_plot(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    png = tmp_path / "design.png"
    assert main(["design", "paper", *TIP, "--plot", str(png), "--bandwidth", "0.5:50"]) == 0
    out = capsys.readouterr().out
    assert "min. detectable" in out and "mV/mN" in out
    assert png.exists()
    assert main(["design", "paper", "--json"]) == 0
    doc = json.loads(capsys.readouterr().out)
    assert doc["metrics"]["force"]["sensitivity_mV_per_mN"] is None  # sharp cone
    assert doc["metrics"]["angle"]["range_deg"] == pytest.approx(90.0)


def test_bundled_force_sensor_example_bends_and_reads_back(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """examples/force-sensor.toml needs no overrides: bend, then read the force back."""
    example = str(Path(__file__).resolve().parents[2] / "examples" / "force-sensor.toml")
    assert main(["bend", example, "--force", "0.1mN", "--json"]) == 0
    volts = json.loads(capsys.readouterr().out)["output_mV"] * 1e-3
    rec = tmp_path / "rec.csv"
    rec.write_text(f"voltage_V\n{volts!r}\n")
    out = tmp_path / "f.csv"
    assert main(["readout", example, str(rec), "--quantity", "force", "--span", "0:0.2",
                 "--out", str(out)]) == 0
    row = out.read_text().splitlines()[1].split(",")
    assert float(row[1]) == pytest.approx(0.1, rel=1e-5)  # mN


def test_readout_with_calibration_covariance(tmp_path: Path) -> None:
    from magcilia.io import example_path

    fit = tmp_path / "fit"
    assert main(["calibrate", str(example_path()), "--out", str(fit), "--restarts", "1",
                 "--quiet"]) == 0
    setup = mc.load_setup(fit / "fitted_setup.toml")
    rec = tmp_path / "rec.csv"
    rec.write_text("voltage_V\n" + "".join(f"{float(v)!r}\n" for v in
                                           setup.output(np.radians([20.0, 40.0, 60.0]))))
    sigmas = []
    for extra in ([], ["--calibration", str(fit)]):
        out = tmp_path / f"out{len(extra)}.csv"
        assert main(["readout", str(fit / "fitted_setup.toml"), str(rec), "--quantity", "angle",
                     "--span", "0:85", "--out", str(out), *extra]) == 0
        rows = [line.split(",") for line in out.read_text().splitlines()[1:]]
        np.testing.assert_allclose([float(r[1]) for r in rows], [20.0, 40.0, 60.0], atol=1e-3)
        sigmas.append(np.array([float(r[2]) for r in rows]))
    assert np.all(sigmas[1] > sigmas[0])


def test_the_force_sensor_preset_is_the_bundled_example() -> None:
    from magcilia.cli._common import PRESETS

    example = mc.load_setup(Path(__file__).resolve().parents[2] / "examples" / "force-sensor.toml")
    assert PRESETS["force-sensor"]().params() == pytest.approx(example.params())


# -- bending in any direction and actuation (issue 15) -------------------------------------------

FORCE_SENSOR = mc.Setup.paper(tip_radius=5e-5, layout="converged")  # the preset


def test_bend_toward_an_azimuth(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["bend", "force-sensor", "--force", "0.02", "--azimuth", "30deg", "--json"]) == 0
    doc = json.loads(capsys.readouterr().out)
    shape = mc.bend(FORCE_SENSOR, 2e-5, azimuth=math.radians(30.0))
    np.testing.assert_allclose(doc["tip_mm"], shape.tip * 1e3, rtol=1e-12, atol=1e-15)
    assert doc["tip_azimuth_deg"] == pytest.approx(30.0, abs=1e-9)
    assert doc["deflection_mm"] == pytest.approx(math.hypot(*shape.tip[:2]) * 1e3, rel=1e-12)
    b = FORCE_SENSOR.field(shape)[0]
    np.testing.assert_allclose(doc["B_gauss"], b / 1e-4, rtol=1e-12)
    assert doc["output_mV"] == pytest.approx(FORCE_SENSOR.output(shape)[0] * 1e3, rel=1e-12)
    assert doc["direct_field_gauss"] is None and doc["solver"] == "planar"
    assert len(doc["centreline_mm"]["y"]) == shape.s.size
    # the text names the azimuth; --si renames every key
    assert main(["bend", "force-sensor", "--force", "0.02", "--azimuth", "30"]) == 0
    out = capsys.readouterr().out
    assert "toward azimuth 30 deg" in out and "y 0.55" in out  # 0.02 mN on 0.669 MPa
    assert "force scale from an assumed modulus ±27 % (E 0.669 MPa): under this load tip" in out
    assert doc["scale_note"].startswith("force scale from an assumed modulus")
    assert doc["sigma_output_mV"] > 0 and len(doc["sigma_tip_mm"]) == 3
    assert main(["bend", "force-sensor", "--force", "0.02", "--azimuth", "30", "--json",
                 "--si"]) == 0
    si = json.loads(capsys.readouterr().out)
    assert si["tip_azimuth_rad"] == pytest.approx(math.radians(30.0))
    assert si["B_T"] == pytest.approx(list(b), rel=1e-12)


def test_bend_with_a_force_vector_and_a_flow_azimuth(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["bend", "force-sensor", "--force-vector", "0.05,0.05,0mN", "--json"]) == 0
    doc = json.loads(capsys.readouterr().out)
    shape = mc.bend(FORCE_SENSOR, (5e-5, 5e-5, 0.0))
    np.testing.assert_allclose(doc["tip_mm"], shape.tip * 1e3, rtol=1e-12, atol=1e-15)
    assert doc["tip_azimuth_deg"] == pytest.approx(45.0)
    assert doc["load"]["force_mN"] == pytest.approx([0.05, 0.05, 0.0])
    assert main(["bend", "force-sensor", "--flow", "0.1", "--flow-azimuth", "90", "--json"]) == 0
    doc = json.loads(capsys.readouterr().out)
    flow = mc.bend(FORCE_SENSOR, flow=mc.Flow.uniform(0.1, azimuth=math.pi / 2))
    np.testing.assert_allclose(doc["tip_mm"], flow.tip * 1e3, rtol=1e-10, atol=1e-12)
    assert doc["tip_azimuth_deg"] == pytest.approx(90.0)


def test_bend_under_an_actuation(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    args = ["bend", "force-sensor", "--force", "0.1", "--actuation-field", "0,0,5", "--json"]
    assert main(args) == 0
    doc = json.loads(capsys.readouterr().out)
    act = mc.Actuation.uniform((0.0, 0.0, 5e-4))
    shape = mc.bend(FORCE_SENSOR, 1e-4, actuation=act)
    np.testing.assert_allclose(doc["tip_mm"], shape.tip * 1e3, rtol=1e-12, atol=1e-15)
    assert doc["direct_field_gauss"] == pytest.approx([0.0, 0.0, 5.0])
    total = FORCE_SENSOR.field(shape)[0] + [0.0, 0.0, 5e-4]
    np.testing.assert_allclose(doc["B_gauss"], total / 1e-4, rtol=1e-12)
    assert doc["load"]["actuation"]["field_gauss"] == pytest.approx([0.0, 0.0, 5.0])
    # the same field in mT, from a file and from the setup file's own [actuation] table
    assert main([*args[:5], "0,0,0.5mT", "--json"]) == 0
    assert json.loads(capsys.readouterr().out)["tip_mm"] == doc["tip_mm"]
    coil = tmp_path / "coil.toml"
    coil.write_text('[actuation]\nfield = ["0 G", "0 G", "2.5 G"]\nscale = 2.0\n')
    assert main(["bend", "force-sensor", "--force", "0.1", "--actuation", str(coil),
                 "--json"]) == 0
    assert json.loads(capsys.readouterr().out)["tip_mm"] == doc["tip_mm"]
    setup_file = tmp_path / "setup.toml"
    mc.save_setup(FORCE_SENSOR, setup_file)
    setup_file.write_text(setup_file.read_text() + '\n[actuation]\nfield = ["0 G", "0 G", '
                          '"10 G"]\n')
    assert main(["bend", str(setup_file), "--force", "0.1", "--actuation-scale", "0.5",
                 "--json"]) == 0
    from_setup = json.loads(capsys.readouterr().out)
    np.testing.assert_allclose(from_setup["tip_mm"], doc["tip_mm"], rtol=1e-12)
    # the text says what the actuation adds at the element
    assert main(["bend", "force-sensor", "--force", "0.1", "--actuation-field", "2,1,0"]) == 0
    out = capsys.readouterr().out
    assert "direct field (2, 1, 0) gauss at the element" in out and "3-D rod" in out


@pytest.mark.parametrize(
    ("args", "match"),
    [
        (["--tip-force", "0.1", "--force-vector", "0.1,0,0"],
         "either --tip-force or --force-vector"),
        (["--force-vector", "0.1,0"], "--force-vector must be X,Y,Z, each a number in mN"),
        (["--force-vector", "0.1,0,0", "--azimuth", "30"], "--azimuth must be left out"),
        (["--force-vector", "0.1,0,0", "--direction", "45"], "--direction must be left out"),
        (["--flow-azimuth", "30"], "--flow-azimuth must be given with --flow"),
        (["--actuation-field", "0,0,5mm"], "--actuation-field must be X,Y,Z, each a number"),
        (["--actuation-field", "0,0,5", "--actuation", "x.toml"], "either --actuation-field or"),
        (["--actuation-scale", "2"], "--actuation-scale must be given with an actuation"),
        (["--actuation", "missing.toml"], "missing.toml"),
    ],
)
def test_bend_any_direction_errors(args: list[str], match: str, tmp_path: Path,
                                   monkeypatch: pytest.MonkeyPatch,
                                   capsys: pytest.CaptureFixture[str]) -> None:
    monkeypatch.chdir(tmp_path)  # relative files resolve in tmp_path
    assert main(["bend", "--setup", "force-sensor", *args]) == 2
    err = capsys.readouterr().err
    assert err.startswith("magcilia: error: ") and match in err and err.count("\n") == 1
    assert "Traceback" not in err


def test_bend_spatial_plot_and_json_file(tmp_path: Path,
                                         capsys: pytest.CaptureFixture[str]) -> None:
    png, out = tmp_path / "bend.png", tmp_path / "bend.json"
    assert main(["bend", "force-sensor", "--force-vector", "0.1,-0.08,0", "--actuation-field",
                 "2,-1,0", "--plot", str(png), "--json-file", str(out)]) == 0
    capsys.readouterr()
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    doc = json.loads(out.read_text())
    assert doc["units"] == "display" and doc["solver"] == "3-D rod"
    assert doc["tip_azimuth_deg"] < 0.0
