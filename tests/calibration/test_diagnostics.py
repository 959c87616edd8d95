"""Calibration warnings (at a bound, a bias that absorbed the signal, implausible standard errors)
and held parameters, on seeded synthetic data: each warning has a case that triggers it and a
clean case that does not."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

import magcilia as mc
from magcilia.acquire.synthetic import synthetic_recording
from magcilia.calibration import WARNING_KINDS, CalibrationWarning
from magcilia.calibration import diagnostics as dg
from magcilia.io.recordings import measurement_from_samples

ANGLES = np.radians(np.linspace(0.0, 85.0, 33))
TRUTH = mc.Setup.paper()
P = TRUTH.params()
GEOMETRY = ("height", "base_radius", "z", "n_loops", "dipoles_per_loop")


def _data(seed: int = 3, samples: int = 400) -> mc.Measurement:
    rec = synthetic_recording(TRUTH, ANGLES, samples_per_angle=samples, rng=seed, bias=2e-3,
                              drift=0.0)
    return measurement_from_samples(rec.angle_deg, rec.voltage, source="synthetic")


def _kinds(result: mc.CalibrationResult) -> list[str]:
    return [w.kind for w in result.diagnostics]


@pytest.fixture(scope="module")
def held_geometry() -> mc.CalibrationResult:
    """The geometry held at the truth: x, y and the offset are determined."""
    return mc.calibrate(_data(), initial=TRUTH.replace(x=0.0, y=1e-3),
                        bounds={"x": (-3e-3, 3e-3), "y": (0.5e-3, 3e-3)},
                        fixed={n: P[n] for n in GEOMETRY}, rng=1, starts=32)


def test_warnings_are_records_with_known_kinds(held_geometry: mc.CalibrationResult) -> None:
    fit = held_geometry
    assert fit.warnings == tuple(w.message for w in fit.diagnostics)
    assert all(isinstance(w, CalibrationWarning) and w.kind in WARNING_KINDS
               for w in fit.diagnostics)
    doc = json.loads(json.dumps(fit.to_dict()))
    assert [d["kind"] for d in doc["diagnostics"]] == _kinds(fit)


# -- held parameters --------------------------------------------------------------------------

def test_held_parameters_are_kept_exactly_and_the_others_recovered(
        held_geometry: mc.CalibrationResult) -> None:
    fit = held_geometry
    for name in GEOMETRY:
        assert fit.values[name] == P[name]  # exactly, not approximately
    assert set(fit.fixed) == set(GEOMETRY)
    assert set(fit.stderr) == {"x", "y", "offset"}  # held: no standard error
    for name in ("x", "y"):
        assert abs(fit.values[name] - P[name]) < 4 * fit.stderr[name]
    assert abs(fit.values["offset"] - 2e-3) < 4 * fit.stderr["offset"]
    rows = {r["parameter"]: r for r in fit.table()}
    assert rows["height"]["fixed"] and not rows["x"]["fixed"]
    assert "fixed" in fit.report().splitlines()[3]  # the height row
    assert json.loads(json.dumps(fit.to_dict()))["fixed"]["height"] == P["height"]
    assert not {"at_bound", "implausible_stderr", "weakly_determined", "undetermined",
                "integer_parameters"} & set(_kinds(fit))


def test_names_hold_the_initial_values_and_equal_bounds_count_as_fixed() -> None:
    start = TRUTH.replace(x=1.0e-3)
    fit = mc.calibrate(_data(samples=100), initial=start, rng=0, starts=16,
                       fixed=("height", "base_radius", "y", "z"),
                       bounds={"n_loops": (2, 2), "dipoles_per_loop": (5, 5)})
    assert fit.fixed == {"height": P["height"], "base_radius": P["base_radius"], "y": P["y"],
                         "z": P["z"], "n_loops": 2.0, "dipoles_per_loop": 5.0}
    assert fit.values["x"] == pytest.approx(P["x"], abs=4 * fit.stderr["x"])
    one = mc.calibrate(_data(samples=100), initial=start, rng=0, starts=16, fixed="height")
    assert one.fixed == {"height": P["height"]}


def test_a_fixed_value_outside_the_default_bounds_is_allowed() -> None:
    fit = mc.calibrate(_data(samples=100), rng=0, starts=8,
                       fixed={"height": 4.5e-3, **{n: P[n] for n in GEOMETRY[1:]}})
    assert fit.values["height"] == 4.5e-3
    assert fit.setup.cilium.height == 4.5e-3


@pytest.mark.parametrize(
    ("fixed", "bounds", "match"),
    [
        ({"colour": 1.0}, None, "fixed key must be one of height"),
        ({"offset": 0.0}, None, "bias='none'"),
        ({"height": -3e-3}, None, r"fixed\['height'\] must be a positive length in m"),
        ({"n_loops": 2.5}, None, r"fixed\['n_loops'\] must be an integer"),
        ({"height": float("nan")}, None, "fixed"),
        ({"height": 3e-3}, {"height": (2e-3, 4e-3)}, "both fixed and given bounds"),
        (3.0, None, "a mapping of parameter names"),
    ],
    ids=["unknown", "offset", "negative", "fractional-n", "nan", "and-bounds", "number"],
)
def test_bad_fixed(fixed: object, bounds: dict | None, match: str) -> None:
    with pytest.raises(mc.MagciliaError, match=match):
        mc.calibrate(_data(samples=20), fixed=fixed, bounds=bounds)  # type: ignore[arg-type]


# -- at a bound -------------------------------------------------------------------------------

def test_a_parameter_at_its_bound_is_flagged() -> None:
    others = {n: P[n] for n in ("base_radius", "x", "y", "z", "n_loops", "dipoles_per_loop")}
    start = TRUTH.replace(height=2.5e-3)
    capped = mc.calibrate(_data(), initial=start, bounds={"height": (2e-3, 3e-3)}, fixed=others,
                          rng=0, starts=16)
    warned = [w for w in capped.diagnostics if w.kind == "at_bound"]
    assert [w.parameters for w in warned] == [("height",)]
    text = warned[0].message
    assert "height = 3 mm sits at its upper bound" in text
    assert "--bound height=2:3.5" in text and "--fix height=" in text
    free = mc.calibrate(_data(), initial=start, fixed=others, rng=0, starts=16)  # bounds 2..4 mm
    assert "at_bound" not in _kinds(free)
    assert free.values["height"] == pytest.approx(P["height"], abs=4 * free.stderr["height"])


def test_at_bound_rules() -> None:
    box = {"height": (2e-3, 4e-3), "n_loops": (1.0, 10.0), "x": (-3e-3, 3e-3), "z": (0.0, 1e-3)}
    values = {"height": 2e-3 + 1e-9, "n_loops": 1.0, "x": 0.0, "z": 1e-3}
    found = dg.at_bound(values, box, undetermined=frozenset({"z"}))
    # n = 1 is the smallest possible value, not a bound the fit ran into
    assert [w.parameters for w in found] == [("height",), ("z",)]
    assert "lower bound" in found[0].message and "--bound height=1:4" in found[0].message
    assert "the bound, not the data, chose this value" in found[1].message
    assert dg.at_bound({"n_loops": 10.0}, {"n_loops": (1.0, 10.0)})[0].message.count(
        "--bound n_loops=1:15") == 1
    assert dg.at_bound({"height": 3e-3}, {"height": (3e-3, 3e-3)}) == []  # held


# -- a bias that absorbed the signal ----------------------------------------------------------

def test_a_cubic_bias_that_absorbs_the_signal_is_flagged() -> None:
    cubic = mc.calibrate(_data(), bias="polynomial", bias_degree=3, rng=0, starts=64)
    warned = [w for w in cubic.diagnostics if w.kind == "bias_absorbs_signal"]
    assert len(warned) == 1
    assert "degree-3 bias polynomial" in warned[0].message
    assert "lower --bias-degree" in warned[0].message


def test_a_real_drift_under_a_held_geometry_is_not_flagged() -> None:
    rec = synthetic_recording(TRUTH, ANGLES, samples_per_angle=200, rng=8, drift=0.0)
    volts = rec.voltage + 1e-4 * np.radians(rec.angle_deg)  # 0.1 mV per rad
    data = measurement_from_samples(rec.angle_deg, volts)
    fit = mc.calibrate(data, initial=TRUTH, fixed=("height", "base_radius", "x", "y", "z",
                                                   "n_loops", "dipoles_per_loop"),
                       bias="polynomial", bias_degree=1)
    assert fit.bias_coefficients[1] == pytest.approx(1e-4, rel=0.2)
    assert "bias_absorbs_signal" not in _kinds(fit)


def test_bias_absorption_thresholds() -> None:
    model = 1e-3 * np.sin(ANGLES)  # span 1 mV
    assert dg.bias_absorption(ANGLES, np.array([2e-3]), model) is None  # degree 0
    small = dg.bias_absorption(ANGLES, np.array([0.0, 1e-4]), model)  # 0.15 mV, correlated
    assert small is None
    correlated = dg.bias_absorption(ANGLES, np.array([0.0, 3e-4]), model)  # 0.45 mV, +0.96
    assert correlated is not None and "correlation +0.9" in correlated.message
    flat = dg.bias_absorption(ANGLES, np.array([0.0, 0.0, 1e-3]), np.zeros_like(ANGLES) + 1e-3)
    assert flat is not None and "inf x" in flat.message  # all the curve's shape is bias


# -- implausible standard errors --------------------------------------------------------------

def test_standard_error_below_the_noise_floor_is_flagged() -> None:
    # the case: a magnetization-scale error of 1.4e-9 on data with a 4 µV RMS residual
    # and a slope of 1 mV per unit scale (the least error the noise allows is 4e-3)
    names = ("magnetization_scale", "offset")
    found = dg.stderr_checks(names, {"magnetization_scale": 1.0, "offset": 2e-3},
                             np.array([1.4e-9, 7e-4]), np.array([1e-3, math.sqrt(33)]),
                             4e-6, 4e-6, 1e-3, {})
    assert [(w.kind, w.parameters) for w in found] == [("implausible_stderr", names[:1])]
    assert "below the least the noise allows" in found[0].message
    # a steep parameter may be known to 1e-8 by the floor, but not on noisy data ...
    steep = dg.stderr_checks(("x",), {"x": 1.0}, np.array([1e-8]), np.array([1e4]), 4e-6,
                             4e-6, 1e-3, {})
    assert [w.kind for w in steep] == ["implausible_stderr"]
    assert "more precise than data" in steep[0].message
    # ... only on noiseless data
    assert dg.stderr_checks(("x",), {"x": 1.0}, np.array([1e-8]), np.array([1e4]), 1e-16,
                            1e-16, 1e-3, {}) == []


def test_standard_error_wider_than_the_bounds_is_flagged(
        held_geometry: mc.CalibrationResult) -> None:
    # y is known to ~0.045 mm; bounds 0.02 mm wide cannot hold that error
    fit = mc.calibrate(_data(), initial=TRUTH, bounds={"x": (-3e-3, 3e-3),
                                                       "y": (1.98e-3, 2.0e-3)},
                       fixed={n: P[n] for n in GEOMETRY}, rng=1, starts=32)
    warned = [w for w in fit.diagnostics if w.kind == "implausible_stderr"]
    assert [w.parameters for w in warned] == [("y",)]
    assert "exceeds its whole bound width (0.02 mm)" in warned[0].message
    # the same data with wide bounds: a plausible error
    assert held_geometry.stderr["y"] < 0.25 * 2.5e-3


def test_real_fits_have_plausible_standard_errors() -> None:
    fit = mc.calibrate(_data(), rng=0, starts=64)
    assert "implausible_stderr" not in _kinds(fit)
