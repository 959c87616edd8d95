"""The temperatures a calibration saw (issue #29 item 4 follow-up): the range over the samples
fitted, kept in the result, result.json and fitted_setup.toml's [temperature] table, so that a
read-out of a hotter recording flags TEMPERATURE_OUTSIDE without the user typing the range."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

import magcilia as mc
from magcilia.calibration.temperature import calibration_temperature
from magcilia.cli import main
from magcilia.io.temperature_table import fitted_temperature_table, load_temperature
from magcilia.readout.protocol import Flag
from magcilia.report.calibration import write_calibration_files

SETUP = mc.Setup.paper_initial()
ANGLES = np.repeat(np.arange(-40.0, 41.0, 5.0), 20)  # deg, 17 angles of 20 samples
HELD = ("height", "base_radius", "n_loops", "dipoles_per_loop")


def _recording(path: Path, celsius: np.ndarray, volts: np.ndarray | None = None,
               angles: np.ndarray = ANGLES) -> Path:
    if volts is None:
        noise = np.random.default_rng(1).normal(0.0, 2e-6, angles.size)
        volts = np.asarray(SETUP.output(np.radians(angles))) + noise
    path.write_text("angle_deg,voltage_V,temperature_degC\n" + "".join(
        f"{float(a)!r},{float(v)!r},{float(t)!r}\n"
        for a, v, t in zip(angles, volts, celsius, strict=True)), encoding="utf-8")
    return path


def test_the_range_is_over_the_samples_used(tmp_path: Path) -> None:
    """The lowest and highest temperature of the samples the reduction used (°C read as K);
    a sample dropped (non-finite output, nan_policy 'omit') does not count; NaN temperatures
    are not known, not extreme."""
    celsius = np.linspace(20.05, 23.65, ANGLES.size)
    celsius[5] = 80.0  # its output is NaN: dropped
    celsius[7] = np.nan
    volts = np.asarray(SETUP.output(np.radians(ANGLES)))
    volts[5] = np.nan
    m = mc.read_measurements(_recording(tmp_path / "r.csv", celsius, volts), nan_policy="omit")
    assert m.temperature_range == pytest.approx((293.2, 296.8))
    good = np.delete(celsius, [5, 7]) + 273.15
    assert m.metadata["temperature_K"]["mean"] == pytest.approx(good.mean())
    assert m.metadata["temperature_K"]["samples"] == good.size
    plain = tmp_path / "plain.csv"
    plain.write_text("angle_deg,voltage_V\n0,0.003\n10,0.0031\n", encoding="utf-8")
    assert mc.read_measurements(plain).temperature_range is None
    other = tmp_path / "other.csv"  # a temperature in units magcilia does not take: left alone
    other.write_text("angle_deg,voltage_V,temp_F\n0,0.003,70\n10,0.0031,71\n", encoding="utf-8")
    assert mc.read_measurements(other).temperature_range is None


def test_several_recordings_join() -> None:
    """Over several recordings: the extremes of all, the mean weighted by their samples."""
    def measurement(lo: float, hi: float, mean: float, n: int) -> mc.Measurement:
        return mc.Measurement(angles=np.zeros(2), volts=np.zeros(2), sem=np.zeros(2),
                              counts=np.ones(2, np.int64), saturated=np.zeros(2, np.int64),
                              nonfinite=np.zeros(2, np.int64), metadata={"temperature_K": {
                                  "min": lo, "max": hi, "mean": mean, "samples": n}})

    plain = mc.Measurement(angles=np.zeros(2), volts=np.zeros(2), sem=np.zeros(2),
                           counts=np.ones(2, np.int64), saturated=np.zeros(2, np.int64),
                           nonfinite=np.zeros(2, np.int64))
    seen = calibration_temperature([measurement(293.0, 295.0, 294.0, 100), plain,
                                    measurement(294.5, 299.0, 297.0, 300)])
    assert seen == pytest.approx((293.0, 299.0, (294.0 * 100 + 297.0 * 300) / 400))
    assert calibration_temperature(plain) is None


def test_the_fitted_table() -> None:
    """The initial table's keys kept as written; the reference the mean, the range rounded
    outward to 1 mK; the table as given without temperatures; None without either."""
    given = {"sensitivity_tempco": "-2700 ppm/K +- 100 ppm/K", "reference": "25 degC"}
    out = fitted_temperature_table(given, (293.20049, 296.80001), 295.0)
    assert out == {"sensitivity_tempco": "-2700 ppm/K +- 100 ppm/K", "reference": "295.000 K",
                   "calibrated_range": "293.200 K:296.801 K"}
    assert fitted_temperature_table(given, None) == given
    assert fitted_temperature_table(None, None) is None


def test_round_trip_through_fitted_setup_toml(tmp_path: Path) -> None:
    """mc.calibrate of a recording with a temperature keeps its range and mean; the files carry
    them (result.json, report.md, fitted_setup.toml's [temperature] with the initial table's
    coefficients) and read back; a recording without a temperature writes the table as given."""
    celsius = np.linspace(20.05, 23.65, ANGLES.size)
    data = mc.read_measurements(_recording(tmp_path / "cal.csv", celsius))
    for model in ("paper", "physical"):
        fit = mc.calibrate(data, SETUP, rng=0, starts=8, model=model,
                           fixed=HELD if model == "paper" else ("height", "base_radius"))
        assert fit.temperature_range == pytest.approx((293.2, 296.8))
        assert fit.temperature_mean == pytest.approx(295.0)
        assert "temperature 293.2–296.8 K during calibration" in fit.report().splitlines()[2]
        out = tmp_path / model
        out.mkdir()
        write_calibration_files(fit, out, figures=False, data=[data], temperature={
            "sensitivity_tempco": "-2700 ppm/K +- 100 ppm/K"})
        model_back = load_temperature(out / "fitted_setup.toml")
        assert model_back is not None
        assert model_back.calibrated_range == pytest.approx((293.2, 296.8), abs=1e-3)
        assert model_back.calibrated_range[0] <= 293.2 and model_back.calibrated_range[1] >= 296.8
        assert model_back.reference == pytest.approx(295.0, abs=1e-3)
        assert model_back.sensitivity_tempco == pytest.approx(-2700e-6)
        doc = json.loads((out / "result.json").read_text())
        assert doc["temperature_K"]["min"] == pytest.approx(293.2)
        back = mc.CalibrationResult.load(out)
        assert back.temperature_range == pytest.approx(fit.temperature_range)
        assert back.temperature_mean == pytest.approx(fit.temperature_mean)
        assert "293.2–296.8 K" in (out / "report.md").read_text()
        mc.load_setup(out / "fitted_setup.toml")  # the setup reads as before
    plain = tmp_path / "plain.csv"
    plain.write_text("angle_deg,voltage_V\n" + "".join(
        f"{float(a)!r},{float(v)!r}\n" for a, v in zip(
            ANGLES, SETUP.output(np.radians(ANGLES)), strict=True)), encoding="utf-8")
    fit = mc.calibrate(mc.read_measurements(plain), SETUP, rng=0, starts=8, fixed=HELD)
    assert fit.temperature_range is None and "during calibration" not in fit.report()
    assert mc.CalibrationResult.from_dict(fit.to_dict()).temperature_range is None
    for table, expected in ((None, None), ({"reference": "25 degC"}, 298.15)):
        out = tmp_path / f"plain-{expected}"
        out.mkdir()
        write_calibration_files(fit, out, figures=False, temperature=table)
        again = load_temperature(out / "fitted_setup.toml")
        assert (again is None) if expected is None else (
            again is not None and again.reference == pytest.approx(expected)
            and again.calibrated_range is None)


def test_calibrate_then_readout_of_a_hotter_recording(tmp_path: Path,
                                                      capsys: pytest.CaptureFixture[str]) -> None:
    """``magcilia calibrate`` of a recording at 20–23.6 °C writes the range; ``magcilia readout``
    with the fitted setup flags the readings of a recording at 30 °C TEMPERATURE_OUTSIDE, with
    the one-line note, and those within the range not."""
    celsius = np.linspace(20.05, 23.65, ANGLES.size)
    cal = _recording(tmp_path / "cal.csv", celsius)
    args = ["calibrate", str(cal), "--setup", "paper-initial", "--starts", "8", "--quiet",
            "--fix=height=3mm", "--fix=base_radius=0.25mm", "--fix=n_loops=6",
            "--fix=dipoles_per_loop=3"]
    assert main([*args, "--out", str(tmp_path / "fit")]) == 0
    assert "temperature 293.2–296.8 K during calibration" in capsys.readouterr().out
    fitted = mc.load_setup(tmp_path / "fit" / "fitted_setup.toml")
    volts = np.asarray(fitted.output(np.radians([10.0, 20.0, 30.0] * 4)))
    for name, temps, outside in (("hot", np.full(12, 303.15), 12),
                                 ("within", np.linspace(293.5, 296.5, 12), 0)):
        rec = tmp_path / f"{name}.csv"
        rec.write_text("voltage_V,temperature_K\n" + "".join(
            f"{float(v)!r},{float(t)!r}\n" for v, t in zip(volts, temps, strict=True)))
        out = tmp_path / f"{name}-angles.csv"
        assert main(["readout", str(tmp_path / "fit" / "fitted_setup.toml"), str(rec),
                     "--quantity", "angle", "--span", "0deg:40deg", "--out", str(out)]) == 0
        lines = capsys.readouterr().out.splitlines()
        notes = [line for line in lines if "leaves the calibrated range" in line]
        assert len(notes) == (1 if outside else 0)
        if outside:
            assert "303.15…303.15 K leaves the calibrated range 293.20…296.80 K" in notes[0]
        assert main(["readout", str(tmp_path / "fit" / "fitted_setup.toml"), str(rec),
                     "--quantity", "angle", "--span", "0deg:40deg", "--out",
                     str(tmp_path / f"{name}-2.csv"), "--json"]) == 0
        doc = json.loads(capsys.readouterr().out)
        assert doc["temperature"]["outside_calibrated_range"] == outside
        assert doc["temperature"]["calibrated_range_K"] == pytest.approx([293.2, 296.8],
                                                                         abs=1e-3)
    assert int(Flag.TEMPERATURE_OUTSIDE) == 16384
