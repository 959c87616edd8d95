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

#: these tests exercise the command with the loads they were written for (0–0.2 mN) on a given
#: modulus of 3.4 MPa (taken as exact: no force scale in σ); the presets' assumed modulus and its
#: force scale: test_the_summary_names_the_force_scale
PINNED = ["--modulus", "3.4"]
TIP = ["--tip-radius", "0.05mm", *PINNED]
SETUP = mc.Setup.paper(tip_radius=5e-5, youngs_modulus=3.4e6)
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
    # --force: the tests read one output file again and again (issue 30: replaced only with it)
    assert main(["readout", "paper", *args, "--quantity", "force", "--span", "0:0.2", *TIP,
                 "--force"]) == 0
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


# -- sensing while actuating, force vectors from a 3-axis sensor (issue 15) ----------------------

FORCE_SENSOR = mc.Setup.paper(tip_radius=5e-5, layout="converged",  # the preset
                              youngs_modulus=3.4e6)  # a given modulus: the 0.2 mN loads


def test_readout_compensates_an_actuation(tmp_path: Path,
                                          capsys: pytest.CaptureFixture[str]) -> None:
    from magcilia.readout.inverse import model_output

    forces = np.linspace(0.0, 2e-4, 9)
    act = mc.Actuation.uniform((2e-4, 0.0, 0.0))
    rec = _record(tmp_path / "rec.csv", model_output(FORCE_SENSOR, "force", forces, None, act))
    out = tmp_path / "f.csv"
    base = ["readout", "force-sensor", str(rec), "--quantity", "force", "--span", "0:0.2",
            "--out", str(out), "--force", *PINNED]
    assert main([*base, "--actuation-field", "2,0,0"]) == 0
    text = capsys.readouterr().out
    assert text.startswith("compensating the actuation (uniform field): direct field (2, 0, 0) "
                           "gauss at the element (+15 mV)")
    est = np.array([float(r["force_mN"]) for r in _rows(out)])
    np.testing.assert_allclose(est, forces * 1e3, rtol=0, atol=1e-5)
    # without the compensation nothing is read (15 mV of direct field: beyond the span)
    assert main(base) == 0
    capsys.readouterr()
    assert all(r["force_mN"] == "" for r in _rows(out))
    assert main([*base, "--actuation-field", "0.2,0,0mT", "--json", "--si"]) == 0
    doc = json.loads(capsys.readouterr().out)
    assert doc["actuation"]["direct_field_T"] == pytest.approx([2e-4, 0.0, 0.0])
    assert doc["actuation"]["direct_output_V"] == pytest.approx(0.015)
    assert doc["estimated"] == forces.size


@pytest.mark.parametrize(
    ("field", "match"),
    [("30,0,0", "within the HMC1021Z's 20 G flip field"),
     ("8,0,0", "keeps B_x within the HMC1021Z's ±6 G range")],
)
def test_readout_refuses_an_actuation_beyond_the_sensor(
        field: str, match: str, tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    rec = _record(tmp_path / "rec.csv", np.full(4, 3e-3))
    out = tmp_path / "f.csv"
    assert main(["readout", "--setup", "force-sensor", str(rec), "--quantity", "force", "--span",
                 "0:0.2", "--csv", str(out), "--actuation-field", field]) == 2
    err = capsys.readouterr().err
    assert err.startswith("magcilia: error: actuation must be a field") and match in err
    assert not out.exists()


def _field_recording(path: Path, seed: int = 4) -> tuple[Path, np.ndarray]:
    from magcilia.device.magnetometer import Magnetometer

    sensor = Magnetometer.preset("MMC5983MA")
    rng = np.random.default_rng(seed)
    f = rng.uniform(0.3e-4, 1.8e-4, 12)
    phi = rng.uniform(-np.pi, np.pi, 12)
    rows = []
    for fi, p in zip(f, phi, strict=True):
        b = sensor.to_sensor(FORCE_SENSOR.field(mc.bend(FORCE_SENSOR, fi, azimuth=p)))[0]
        rows.append(",".join(repr(float(x)) for x in (len(rows) / RATE, *(b / 1e-4))) + "\n")
    path.write_text("time_s,Bx,By,Bz\n" + "".join(rows))
    return path, np.stack([f * np.cos(phi), f * np.sin(phi)], -1)


def test_readout_biaxial_force_vectors(tmp_path: Path,
                                       capsys: pytest.CaptureFixture[str]) -> None:
    rec, truth = _field_recording(tmp_path / "b.csv")
    out = tmp_path / "vec.csv"
    args = ["readout", "force-sensor", str(rec), "--biaxial", "--sensor", "mmc5983ma", "--span",
            "0.2mN", "--columns", "field_x=Bx[G],field_y=By[G],field_z=Bz[G]", "--out", str(out),
            "--force", *PINNED]
    assert main(args) == 0
    assert "12/12 force vectors estimated from the MMC5983MA" in capsys.readouterr().out
    rows = _rows(out)
    assert list(rows[0]) == ["time_s", "fx_mN", "fy_mN", "magnitude_mN", "direction_deg",
                             "sigma_fx_mN", "sigma_fy_mN", "sigma_magnitude_mN",
                             "sigma_direction_deg", "chi2", "flags", "flag_names"]
    est = np.array([[float(r["fx_mN"]), float(r["fy_mN"])] for r in rows])
    np.testing.assert_allclose(est, truth * 1e3, rtol=0, atol=1e-3 * 0.2)
    direction = np.array([float(r["direction_deg"]) for r in rows])
    np.testing.assert_allclose(direction, np.degrees(np.arctan2(truth[:, 1], truth[:, 0])),
                               atol=0.1)
    assert all(r["flags"] == "0" and r["flag_names"] == "" for r in rows)
    # SI and JSON
    assert main([*args, "--si", "--json"]) == 0
    doc = json.loads(capsys.readouterr().out)
    assert doc["units"] == "SI" and doc["span_N"] == pytest.approx(2e-4)
    assert doc["estimated"] == 12 and "fx_N" in _rows(out)[0]
    # tare on the first readings is accepted (they are loaded here: only the plumbing)
    assert main([*args, "--tare", "3"]) == 0
    assert "tared on 3 readings" in capsys.readouterr().out


@pytest.mark.parametrize(
    ("extra", "match"),
    [
        ([], "--sensor must be a 3-axis magnetometer preset with --biaxial"),
        (["--sensor", "MLX90393"], "--sensor-noise must be the RMS noise per axis"),
        (["--sensor", "LIS3MDL", "--quantity", "angle"], "--quantity must be force"),
        (["--sensor", "LIS3MDL", "--actuation-field", "0,0,50"],
         "actuation must be within its range ±4 G"),
        (["--sensor", "LIS3MDL", "--sensor-noise", "-1mG"], "--sensor-noise must be"),
    ],
)
def test_readout_biaxial_errors(extra: list[str], match: str, tmp_path: Path,
                                capsys: pytest.CaptureFixture[str]) -> None:
    rec, _ = _field_recording(tmp_path / "b.csv")
    assert main(["readout", "--setup", "force-sensor", str(rec), "--biaxial", "--span", "0.2",
                 "--columns", "field_x=Bx[G],field_y=By[G],field_z=Bz[G]", "--csv",
                 str(tmp_path / "v.csv"), *extra]) == 2
    err = capsys.readouterr().err
    assert err.startswith("magcilia: error: ") and match in err
    assert not (tmp_path / "v.csv").exists()


def test_readout_needs_a_quantity_without_biaxial(tmp_path: Path,
                                                  capsys: pytest.CaptureFixture[str]) -> None:
    rec = _record(tmp_path / "rec.csv", np.full(4, 3e-3))
    assert main(["readout", "force-sensor", str(rec), "--span", "0:0.2", "--out",
                 str(tmp_path / "f.csv")]) == 2
    assert "Missing option '--quantity'" in capsys.readouterr().err
    assert main(["readout", "force-sensor", str(rec), "--quantity", "force", "--span", "0:0.2",
                 "--sensor", "LIS3MDL", "--out", str(tmp_path / "f.csv")]) == 2
    assert "--sensor must be given with --biaxial only" in capsys.readouterr().err


def test_readout_biaxial_while_actuating(tmp_path: Path,
                                         capsys: pytest.CaptureFixture[str]) -> None:
    from magcilia.device.magnetometer import Magnetometer

    sensor = Magnetometer.preset("MMC5983MA")
    act = mc.Actuation.uniform((0.0, 0.0, 5e-4))  # 5 G along z
    truth = np.array([[1e-4, 0.0], [0.0, -1.5e-4], [-5e-5, 5e-5]])
    rows = []
    for fx, fy in truth:
        shape = mc.bend(FORCE_SENSOR, float(np.hypot(fx, fy)),
                        azimuth=float(np.arctan2(fy, fx)), actuation=act)
        b = sensor.to_sensor(FORCE_SENSOR.field(shape)[0] + [0.0, 0.0, 5e-4])
        rows.append(",".join(repr(float(x)) for x in b) + "\n")
    rec = tmp_path / "b.csv"
    rec.write_text("field_x_T,field_y_T,field_z_T\n" + "".join(rows))
    out = tmp_path / "v.csv"
    assert main(["readout", "force-sensor", str(rec), "--biaxial", "--sensor", "MMC5983MA",
                 "--span", "0.2", "--out", str(out), "--actuation-field", "0,0,5", *PINNED]) == 0
    text = capsys.readouterr().out
    assert "compensating the actuation: its direct field on the sensor's axes (0, 0, 5) gauss" \
        in text
    est = np.array([[float(r["fx_mN"]), float(r["fy_mN"])] for r in _rows(out)])
    np.testing.assert_allclose(est, truth * 1e3, rtol=0, atol=1e-4)


def test_the_summary_names_the_force_scale(tmp_path: Path,
                                          capsys: pytest.CaptureFixture[str]) -> None:
    """The presets' modulus is assumed (±27 %: in every force's σ, said in the summary); a
    --modulus without a σ is taken as exact, one with a σ is measured."""
    setup = mc.Setup.paper(tip_radius=5e-5)
    forces = np.array([0.0, 1e-5, 2e-5, 4e-5])
    rec = _record(tmp_path / "rec.csv", output_at(setup, "force", forces))
    out = tmp_path / "est.csv"
    base = ["readout", "paper", str(rec), "--quantity", "force", "--span", "0:0.04",
            "--tip-radius", "0.05mm", "--out", str(out), "--force"]
    assert main(base) == 0
    assert "; force scale from an assumed modulus ±27 % (E 0.669 MPa)" in capsys.readouterr().out
    got = np.array([float(r["force_mN"]) for r in _rows(out)])
    sigma = np.array([float(r["sigma_force_mN"]) for r in _rows(out)])
    np.testing.assert_allclose(got, forces * 1e3, rtol=1e-6, atol=1e-9)
    rel = setup.youngs_modulus_uncertainty
    assert (sigma >= rel * np.abs(got)).all() and sigma[-1] == pytest.approx(rel * got[-1],
                                                                             rel=1e-3)
    assert main([*base, "--modulus", "0.6"]) == 0
    assert "force scale: modulus given, taken as exact (E 0.6 MPa)" in capsys.readouterr().out
    assert main([*base, "--modulus", "0.6MPa:60kPa"]) == 0
    assert "force scale from a measured modulus ±10 % (E 0.6 MPa)" in capsys.readouterr().out
    assert main([*base, "--modulus", "0.6:-0.1"]) == 2
    assert "--modulus must be" in capsys.readouterr().err
