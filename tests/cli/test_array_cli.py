"""``magcilia array`` run in-process: forward map, read-out vs truth, crosstalk, metrics vs
pitch, units, figures and one-line errors with nothing half-written."""

from __future__ import annotations

import csv
import importlib.util
import json
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from matplotlib.figure import Figure

import magcilia as mc
from magcilia.cli import main
from magcilia.constants import GAUSS
from magcilia.readout.array import ArrayReadout, array_metrics, field_for_loads

EXAMPLE = str(Path(__file__).resolve().parents[2] / "examples" / "array.toml")

_spec = importlib.util.spec_from_file_location(
    "magcilia_test_figures_array_cli",
    Path(__file__).resolve().parents[1] / "report" / "test_figures.py")
assert _spec is not None and _spec.loader is not None
_figures = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(_figures)


@pytest.fixture(scope="module")
def array() -> mc.CiliaArray:
    return mc.load_array(EXAMPLE)


def _json(args: list[str], capsys: pytest.CaptureFixture[str]) -> dict[str, Any]:
    assert main(["array", EXAMPLE, *args, "--json"]) == 0, capsys.readouterr().err
    doc: dict[str, Any] = json.loads(capsys.readouterr().out)
    return doc


def _rows(path: Path) -> list[dict[str, str]]:
    return list(csv.DictReader(path.read_text().splitlines()))


def test_rest_field_and_its_read_out(array: mc.CiliaArray,
                                     capsys: pytest.CaptureFixture[str]) -> None:
    doc = _json([], capsys)
    assert doc["units"] == "display" and doc["loads"] == "none" and doc["span_mN"] == 0.02
    rest = array.field()
    got = np.array([[r["Bx_gauss"], r["By_gauss"], r["Bz_gauss"]] for r in doc["field"]])
    np.testing.assert_allclose(got, rest / GAUSS, rtol=1e-12)
    assert [r["sensor"] for r in doc["field"]] == [s.name for s in array.sensors]
    assert doc["field"][0]["x_mm"] == pytest.approx(-6.0)
    est = doc["readout"]
    assert len(est) == 16 and all(r["true_force_mN"] == 0.0 for r in est)
    # at rest the estimates are noise: a few sigma at most, sigma ~ 0.4 uN
    assert all(r["error_per_sigma"] < 5.0 for r in est)
    assert 1e-4 < doc["summary"]["median_sigma_force_mN"] < 1e-3
    assert doc["summary"]["saturated_readings"] == 0
    # the text: the two tables, in display units
    assert main(["array", EXAMPLE]) == 0
    out = capsys.readouterr().out
    assert "16 cilia over 16 sensors, span 0.02 mN" in out and "units: display" in out
    assert "Bx_gauss" in out and "true_Fx_mN" in out and "direction_deg" in out
    assert "crosstalk" not in out


def test_loads_from_a_file_are_read_back_within_their_sigma(
        array: mc.CiliaArray, tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    rng = np.random.default_rng(7)
    forces = rng.uniform(-1.0, 1.0, (16, 2)) * 1.2e-5  # N
    loads = tmp_path / "loads.csv"
    loads.write_text("cilium,Fx_uN,Fy_uN\n" + "".join(
        f"{n},{float(fx) * 1e6!r},{float(fy) * 1e6!r}\n" for n, (fx, fy) in zip(array.names, forces,
                                                                  strict=True)))
    fmap, ro = tmp_path / "map.csv", tmp_path / "ro.csv"
    doc = _json(["--loads", str(loads), "--seed", "3", "--csv", str(fmap), "--readout-csv",
                 str(ro), "--si"], capsys)
    assert doc["units"] == "SI" and doc["loads"] == "file" and doc["span_N"] == 2e-5
    # the forward map is the exact elastica's field
    exact = field_for_loads(array, forces)
    got = np.array([[r["Bx_T"], r["By_T"], r["Bz_T"]] for r in doc["field"]])
    np.testing.assert_allclose(got, exact, rtol=1e-12)
    # the noisy readings are the seeded sensors' (the same seed, the same numbers)
    readings = array.readings(exact, np.random.default_rng(3))
    got = np.array([[r["reading_x_T"], r["reading_y_T"], r["reading_z_T"]] for r in doc["field"]])
    np.testing.assert_array_equal(got, readings)
    est = ArrayReadout(array, 2e-5).read(readings)
    np.testing.assert_allclose([[r["Fx_N"], r["Fy_N"]] for r in doc["readout"]], est.force,
                               rtol=1e-12)
    np.testing.assert_allclose([[r["true_Fx_N"], r["true_Fy_N"]] for r in doc["readout"]],
                               forces, rtol=1e-12)
    assert max(r["error_per_sigma"] for r in doc["readout"]) < 4.5
    # the CSV files hold the same numbers with unit-suffixed columns (SI here)
    rows = _rows(fmap)
    assert list(rows[0])[:5] == ["set", "sensor", "x_m", "y_m", "z_m"] and len(rows) == 16
    assert float(rows[3]["Bz_T"]) == pytest.approx(exact[3, 2], rel=1e-12)
    rows = _rows(ro)
    assert {"true_Fx_N", "sigma_force_N", "direction_rad", "error_per_sigma", "flags"} <= set(
        rows[0])
    assert float(rows[5]["Fy_N"]) == pytest.approx(est.force[5, 1], rel=1e-12)


def test_random_load_sets_are_seeded_and_recovered_within_two_sigma(
        capsys: pytest.CaptureFixture[str]) -> None:
    doc = _json(["--random", "12", "--seed", "5"], capsys)
    again = _json(["--random", "12", "--seed", "5"], capsys)
    assert doc == again
    other = _json(["--random", "12", "--seed", "6"], capsys)
    assert other["readout"] != doc["readout"]
    assert doc["summary"]["sets"] == 12 and len(doc["readout"]) == 12 * 16
    assert {r["set"] for r in doc["readout"]} == set(range(1, 13))
    # the done-when of the issue: random loads on all 16 cilia within 2 sigma of the noise
    # (about 95 % of the 384 components: the truth shares the model's modulus, so the force
    # scale's share of sigma cannot show), none flagged; loads within 0.9 of the span
    assert 0.9 <= doc["summary"]["within_2sigma"] <= 0.99
    assert doc["summary"]["flagged"] == 0
    assert max(r["true_force_mN"] for r in doc["readout"]) <= 0.9 * 0.02
    # each sigma carries the assumed modulus's relative sigma (27 %) of |F| on top of the noise's
    s = doc["summary"]
    assert s["median_sigma_force_mN"] > 5 * s["median_sigma_force_noise_mN"]
    rel = mc.Setup.paper().modulus.relative
    assert all(r["sigma_force_mN"] >= rel * r["force_mN"] * (1 - 1e-9) for r in doc["readout"])
    assert doc["scale_note"] == "force scale from an assumed modulus ±27 % (E 0.669 MPa)"
    assert main(["array", EXAMPLE, "--random", "3"]) == 0
    out = capsys.readouterr().out
    assert "3 sets, seed 0" in out and "load set 1; all sets in --csv / --json" in out
    assert "within 2 noise sigma" in out
    assert "force scale from an assumed modulus ±27 % (E 0.669 MPa): in every sigma" in out


def test_crosstalk_and_metrics_tables(array: mc.CiliaArray,
                                      capsys: pytest.CaptureFixture[str]) -> None:
    doc = _json(["--metrics", "--pitches", "3.5:5:0.5mm", "--span", "20uN"], capsys)
    ct = ArrayReadout(array, 2e-5).crosstalk()
    assert doc["crosstalk"]["ratio_max"] == pytest.approx(float(ct.ratio.max()), rel=1e-12)
    assert doc["crosstalk"]["rows"][0]["response_gauss_per_mN"] == pytest.approx(
        float(ct.response[ct.site[0], 0]) / GAUSS * 1e-3, rel=1e-12)
    grid = mc.Setup.paper(tip_radius=5e-5, position=(0.0, 0.0, 1.5e-3 - 0.71e-3),
                          layout="converged")  # the presets' assumed modulus, as the example
    ref = array_metrics(grid, [3.5e-3, 4e-3, 4.5e-3, 5e-3],
                        sensor=mc.Magnetometer.preset("MMC5983MA"), span=2e-5, depth=1.5e-3)
    rows = doc["metrics"]["rows"]
    assert [r["pitch_mm"] for r in rows] == pytest.approx([3.5, 4.0, 4.5, 5.0])
    np.testing.assert_allclose([r["ratio_max"] for r in rows], ref.ratio.max(axis=1),
                               rtol=1e-9)
    np.testing.assert_allclose([r["minimum_median_mN"] for r in rows],
                               np.median(ref.minimum, axis=1) * 1e3, rtol=1e-9)
    assert rows[1]["ratio_max"] < 1.0  # the example's pitch
    assert main(["array", EXAMPLE, "--crosstalk", "--metrics", "--pitches", "3.5:4.5:0.5"]) == 0
    out = capsys.readouterr().out
    assert "crosstalk: ratio median 0.485" in out and "worst_other_gauss_per_mN" in out
    assert "metrics vs pitch" in out and "minimum_median_mN" in out


def test_lists_file_works_and_metrics_need_a_grid(tmp_path: Path,
                                                  capsys: pytest.CaptureFixture[str]) -> None:
    arr = mc.load_array(EXAMPLE)
    saved = tmp_path / "lists.toml"
    mc.save_array(arr, saved)  # the same array as [[cilia]] and [[sensors]] lists
    assert main(["array", str(saved), "--json", "--crosstalk"]) == 0
    doc = json.loads(capsys.readouterr().out)
    assert len(doc["readout"]) == 16
    assert main(["array", str(saved), "--metrics", "--pitches", "2:3:0.5mm"]) == 2
    assert "an array file with the [array] grid" in capsys.readouterr().err


@pytest.mark.parametrize(
    ("args", "message"),
    [
        (["--loads", "x.csv", "--random", "2"], "either --loads or --random, not both"),
        (["--pitches", "2:3:0.5"], "--pitches must be given with --metrics"),
        (["--metrics"], "--metrics must be --metrics with --pitches"),
        (["--metrics", "--pitches", "2:3"], "--pitches must be START:STOP:STEP"),
        (["--metrics", "--pitches", "1.5:3:0.5mm"],
         "--pitches 1.5:3:0.5mm: span must be loads the cilia can take without touching"),
        (["--span", "0.02kg"], "--span must be a number in mN or with a force unit"),
        (["--span", "0"], "--span must be a positive force"),
        (["--span", "10mN"], "span must be loads the cilia can take without touching"),
        (["--plot", "map.xyz"], "--plot"),
        (["--random", "0"], "Invalid value for '--random'"),
    ],
)
def test_errors_are_one_line_and_nothing_is_written(args: list[str], message: str,
                                                    tmp_path: Path, monkeypatch: Any,
                                                    capsys: pytest.CaptureFixture[str]) -> None:
    monkeypatch.chdir(tmp_path)
    outs = ["--csv", "f.csv", "--readout-csv", "r.csv", "--json-file", "a.json"]
    code = main(["array", "--setup", EXAMPLE, *args, *outs, "--crosstalk-plot", "xt.png"])
    err = capsys.readouterr().err
    assert code == 2 and err.startswith("magcilia: error: ") and err.count("\n") == 1, err
    assert message in err
    assert sorted(p.name for p in tmp_path.iterdir()) == []


def test_bad_files_are_one_line_errors(tmp_path: Path,
                                       capsys: pytest.CaptureFixture[str]) -> None:
    bad = tmp_path / "bad.toml"
    bad.write_text(Path(EXAMPLE).read_text().replace('pitch = "4 mm"', 'pitch = "0.3 mm"'))
    assert main(["array", str(bad)]) == 2
    err = capsys.readouterr().err
    assert "bad.toml: [array]: cilia must be cilia that do not overlap" in err
    loads = tmp_path / "loads.csv"
    loads.write_text("cilium,Fx_mN,Fy_mN\nr9c9,0.01,0\n")
    assert main(["array", EXAMPLE, "--loads", str(loads)]) == 2
    assert "line 2: cilium must be a cilium of the array" in capsys.readouterr().err
    assert main(["array", str(tmp_path / "missing.toml")]) == 2
    assert "cannot access" in capsys.readouterr().err


@pytest.mark.parametrize("style", ["screen", "paper"])
def test_figures_pass_the_rendering_checks(style: str, tmp_path: Path, monkeypatch: Any,
                                           capsys: pytest.CaptureFixture[str]) -> None:
    seen: list[list[str]] = []
    original = Figure.savefig

    def savefig(self: Figure, fname: Any, *args: Any, **kwargs: Any) -> None:
        original(self, fname, *args, **kwargs)
        seen.append(_figures.problems(self))

    monkeypatch.setattr(Figure, "savefig", savefig)
    ext = ".png" if style == "screen" else ".pdf"
    fmap, xt = tmp_path / f"map{ext}", tmp_path / f"xt{ext}"
    assert main(["array", EXAMPLE, "--random", "1", "--plot", str(fmap), "--crosstalk-plot",
                 str(xt), "--style", style]) == 0, capsys.readouterr().err
    assert len(seen) == 2 and seen == [[], []], seen
    for f in (fmap, xt):
        data = f.read_bytes()
        assert data.startswith(_figures.MAGIC[ext]) and len(data) > 2000
    # without loads the map shows the rest field
    assert main(["array", EXAMPLE, "--plot", str(tmp_path / "rest.svg")]) == 0
    assert b"<svg" in (tmp_path / "rest.svg").read_bytes()[:2000] and seen[-1] == []
