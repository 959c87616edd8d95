"""Calibration: recovery from seeded synthetic data, bias handling, identifiability, bad input."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

import magcilia as mc
from magcilia.acquire.synthetic import synthetic_recording
from magcilia.calibration import DEFAULT_BOUNDS
from magcilia.io.recordings import measurement_from_samples

ANGLES = np.radians(np.linspace(0.0, 85.0, 33))
TRUTH = mc.Setup.paper()


def _data(seed: int = 3, samples: int = 400, bias: float = 2e-3, drift: float = 0.0,
          truth: mc.Setup = TRUTH) -> mc.Measurement:
    rec = synthetic_recording(truth, ANGLES, samples_per_angle=samples, rng=seed, bias=bias,
                              drift=drift)
    return measurement_from_samples(rec.angle_deg, rec.voltage, source="synthetic")


@pytest.fixture(scope="module")
def full_fit() -> mc.CalibrationResult:
    return mc.calibrate(_data(), initial=mc.Setup.paper_initial(), rng=0)


def test_global_fit_matches_truth_within_noise(full_fit: mc.CalibrationResult) -> None:
    data = full_fit.data
    truth_curve = TRUTH.output(data.angles) + 2e-3
    # fitted curve vs the noiseless truth (up to the jointly fitted offset): within a few s.e.
    diff = full_fit.setup.output(data.angles) - truth_curve
    diff -= diff.mean()
    assert np.sqrt(np.mean(diff**2)) < 3 * data.sem.mean()
    # cost at or below the cost of the true parameters (with their best offset)
    r_true = data.volts - TRUTH.output(data.angles)
    r_true -= r_true.mean()
    assert full_fit.cost <= float(r_true @ r_true) * (1 + 1e-9)
    assert full_fit.rms == pytest.approx(np.sqrt(full_fit.cost / 33))
    np.testing.assert_allclose(full_fit.fitted, full_fit.setup.output(data.angles), atol=1e-12)


def test_degenerate_parameters_are_flagged(full_fit: mc.CalibrationResult) -> None:
    text = " ".join(full_fit.warnings)
    assert "not determined" in text
    assert "sign of y" in text
    assert any(se == np.inf for se in full_fit.stderr.values())
    assert "undetermined" in full_fit.report()


def test_identifiable_parameters_recovered_within_errors() -> None:
    # fix the geometry; x, y (one sign) and the offset are then determined by the data
    p = TRUTH.params()
    bounds = {name: (p[name], p[name]) for name in ("height", "base_radius", "z", "n_loops",
                                                    "dipoles_per_loop")}
    bounds |= {"x": (-3e-3, 3e-3), "y": (0.5e-3, 3e-3)}
    start = TRUTH.replace(x=0.0, y=1.0e-3)
    result = mc.calibrate(_data(seed=4), initial=start, bounds=bounds, rng=1, restarts=1)
    assert not any("not determined" in w for w in result.warnings)
    for name in ("x", "y"):
        se = result.stderr[name]
        assert 0 < se < 1e-4
        assert abs(result.values[name] - p[name]) < 4 * se
    assert abs(result.values["offset"] - 2e-3) < 4 * result.stderr["offset"]


def test_reproducible_for_a_seed() -> None:
    data = _data(seed=5, samples=100)
    kw = {"initial": mc.Setup.paper_initial(), "starts": 32}
    a = mc.calibrate(data, rng=7, **kw)
    b = mc.calibrate(data, rng=7, **kw)
    assert a.values == b.values and a.cost == b.cost


def test_magnetization_scale_is_recovered_in_closed_form() -> None:
    truth = TRUTH.replace(magnetization_scale=0.35)
    p = truth.params()
    bounds = {name: (p[name], p[name]) for name in DEFAULT_BOUNDS}
    result = mc.calibrate(_data(seed=6, truth=truth), initial=TRUTH, bounds=bounds, rng=0,
                          restarts=1, fit_scale=True)
    se = result.stderr["magnetization_scale"]
    assert result.values["magnetization_scale"] == pytest.approx(0.35, abs=max(4 * se, 1e-3))
    assert result.setup.material.magnetization_scale == result.values["magnetization_scale"]


def test_polynomial_bias_removes_a_drift() -> None:
    # a linear drift in the angle is absorbed by a degree-1 bias, not by the geometry
    p = TRUTH.params()
    bounds = {name: (p[name], p[name]) for name in DEFAULT_BOUNDS}
    rec = synthetic_recording(TRUTH, ANGLES, samples_per_angle=200, rng=8, drift=0.0)
    volts = rec.voltage + 1e-4 * np.radians(rec.angle_deg)  # 0.1 mV per rad
    data = measurement_from_samples(rec.angle_deg, volts)
    offset_only = mc.calibrate(data, initial=TRUTH, bounds=bounds, restarts=1)
    poly = mc.calibrate(data, initial=TRUTH, bounds=bounds, restarts=1, bias="polynomial",
                        bias_degree=1)
    noise_floor = float(np.sum(data.sem**2))
    assert poly.cost < 2.0 * noise_floor < offset_only.cost
    assert poly.bias_coefficients[1] == pytest.approx(1e-4, rel=0.2)
    # degree 0 is the same model as "offset"
    deg0 = mc.calibrate(data, initial=TRUTH, bounds=bounds, restarts=1, bias="polynomial")
    assert deg0.cost == pytest.approx(offset_only.cost, rel=1e-9)


def test_result_serialises(full_fit: mc.CalibrationResult, tmp_path: Path) -> None:
    doc = json.loads(json.dumps(full_fit.to_dict(), allow_nan=True))
    assert doc["cost_V2"] == pytest.approx(full_fit.cost)
    rows = {r["parameter"]: r for r in full_fit.table()}
    assert rows["height"]["initial"] == pytest.approx(3.0)  # mm
    mc.save_setup(full_fit.setup, tmp_path / "fit.toml")
    back = mc.load_setup(tmp_path / "fit.toml")
    np.testing.assert_allclose(back.output(ANGLES), full_fit.setup.output(ANGLES), rtol=1e-9)


@pytest.mark.parametrize(
    ("bounds", "match"),
    [
        ({"height": (4e-3, 2e-3)}, "low <= high"),
        ({"height": (3.5e-3, 4e-3)}, r"initial height must be inside its bounds"),
        ({"n_loops": (0, 5)}, "whole numbers >= 1"),
        ({"colour": (0, 1)}, "bounds key must be one of"),
        ({"x": (float("nan"), 1.0)}, "finite"),
        ({"x": "wide"}, r"\(low, high\) pair"),
    ],
    ids=["reversed", "initial-outside", "n0", "unknown", "nan", "not-a-pair"],
)
def test_bad_bounds(bounds: dict, match: str) -> None:
    with pytest.raises(mc.MagciliaError, match=match):
        mc.calibrate(_data(samples=20), initial=mc.Setup.paper_initial(), bounds=bounds)


def test_too_few_angles() -> None:
    data = measurement_from_samples([0.0, 10.0], [1e-3, 2e-3])
    with pytest.raises(mc.MagciliaError, match="record more angles"):
        mc.calibrate(data)


def test_sign_of_y_follows_the_initial_setup(full_fit: mc.CalibrationResult) -> None:
    # paper_initial has y = 0: the fit reports y >= 0; the mirrored placement fits exactly as well
    assert full_fit.values["y"] > 0.0
    data = full_fit.data
    mirrored = full_fit.setup.replace(y=-full_fit.values["y"])
    np.testing.assert_allclose(mirrored.output(data.angles), full_fit.setup.output(data.angles),
                               rtol=1e-12, atol=1e-15)
    p = TRUTH.params()
    fixed = {n: (p[n], p[n]) for n in ("height", "base_radius", "z", "n_loops", "dipoles_per_loop")}
    negative = mc.calibrate(data, initial=TRUTH.replace(y=-1e-3), bounds=fixed, rng=0, restarts=1)
    assert negative.values["y"] < 0.0
    assert negative.values["y"] == pytest.approx(-p["y"], rel=0.05)


def test_truth_is_shown_beside_the_fit(full_fit: mc.CalibrationResult) -> None:
    truth = {**TRUTH.params(), "offset": 2e-3}
    truth.pop("tip_radius", None)
    shown = full_fit.with_truth(truth)
    assert full_fit.truth is None and "truth" not in full_fit.table()[0]
    rows = {r["parameter"]: r for r in shown.table()}
    assert rows["height"]["truth"] == pytest.approx(3.2613)  # mm
    assert rows["offset"]["truth"] == pytest.approx(2.0)  # mV
    text = shown.report()
    assert text.splitlines()[2].split()[-1] == "truth"
    lines = shown.truth_comparison()
    assert lines[0].startswith("fit versus truth")
    assert "reproduces the data to the noise level" in lines[1]
    undetermined = next(w for w in full_fit.diagnostics if w.kind == "undetermined").parameters
    assert any(line.startswith(f"- {', '.join(undetermined)} differ from the truth")
               for line in lines)
    assert "README" in lines[-1]
    assert json.loads(json.dumps(shown.to_dict()))["truth"]["height"] == pytest.approx(3.2613e-3)
    with pytest.raises(mc.MagciliaError, match="truth key must be one of"):
        full_fit.with_truth({"colour": 1.0})
