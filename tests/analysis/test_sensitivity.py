"""Sensitivity analysis: one-at-a-time sweeps against direct model evaluations, the calibration
cost, the physical domain, Sobol indices of the Ishigami function (known analytic values),
global indices of the model, placement tolerance and the report files."""

from __future__ import annotations

import json
import math
import sys
from pathlib import Path

import numpy as np
import pytest

import magcilia as mc
from magcilia.acquire.synthetic import synthetic_recording
from magcilia.analysis import (
    STUDY_PARAMETERS,
    default_spans,
    offset_cost,
    rms_change,
    sobol_analysis,
)
from magcilia.io.recordings import measurement_from_samples
from magcilia.report.sensitivity import write_sensitivity_report

ANGLES = np.radians(np.linspace(0.0, 85.0, 33))


@pytest.fixture(scope="module")
def data() -> mc.Measurement:
    rec = synthetic_recording(mc.Setup.paper(), ANGLES, samples_per_angle=20, rng=3)
    return measurement_from_samples(rec.angle_deg, rec.voltage)


def test_offset_cost_is_the_calibration_cost(data: mc.Measurement) -> None:
    setup = mc.Setup.paper()
    model = setup.output(data.angles)
    cost = offset_cost(model, data.volts)
    # brute force over the offset: the closed form is the minimum
    offsets = np.linspace(-5e-3, 5e-3, 20001)
    brute = np.min(np.sum((data.volts - model - offsets[:, None]) ** 2, axis=1))
    assert cost == pytest.approx(brute, rel=1e-4)
    assert offset_cost(model + 0.7, data.volts) == pytest.approx(cost, rel=1e-9)
    # the same number calibrate() reports with every parameter held at this setup's values
    p = setup.params()
    fixed = {k: (p[k], p[k]) for k in ("height", "base_radius", "x", "y", "z", "n_loops",
                                       "dipoles_per_loop")}
    result = mc.calibrate(data, initial=setup, bounds=fixed, restarts=1)
    assert result.cost == pytest.approx(float(cost), rel=1e-9)


@pytest.mark.parametrize("parameter", ["x", "z", "height", "base_radius", "n_loops",
                                       "dipoles_per_loop", "magnetization_scale"])
def test_oat_matches_direct_model_evaluation(parameter: str, data: mc.Measurement) -> None:
    setup = mc.Setup.paper()
    nominal = setup.params()[parameter]
    if parameter in ("n_loops", "dipoles_per_loop"):
        values = np.array([1.0, 2.0, 3.0, 5.0, 8.0])
    else:
        values = (nominal * np.array([0.9, 0.95, 1.0, 1.05, 1.1]) if nominal
                  else np.array([0.0, 1e-4]))
    res = mc.oat_sweep(setup, parameter, values, angles=ANGLES, data=data)
    assert res.skipped == ()
    ref = setup.output(ANGLES)
    np.testing.assert_allclose(res.reference, ref)
    for val, curve, rms, cost in zip(res.values, res.curves, res.rms_change, res.cost, strict=True):
        direct = setup.replace(**{parameter: val}).output(ANGLES)
        np.testing.assert_allclose(curve, direct, rtol=1e-11, atol=1e-15)
        assert rms == pytest.approx(math.sqrt(np.mean((direct - ref) ** 2)), rel=1e-9, abs=1e-15)
        r = data.volts - setup.replace(**{parameter: val}).output(data.angles)
        assert cost == pytest.approx(np.sum((r - r.mean()) ** 2), rel=1e-9)
    at_nominal = int(np.argmin(np.abs(res.values - nominal)))
    if res.values[at_nominal] == nominal:
        assert res.rms_change[at_nominal] < 1e-15


def test_y_sweep_is_symmetric_about_the_tilt_plane() -> None:
    # the paper: the error is symmetric in y (B_x is even in y)
    setup = mc.Setup.paper(y=0.0)
    res = mc.oat_sweep(setup, "y", np.linspace(-1e-3, 1e-3, 21))
    np.testing.assert_allclose(res.rms_change, res.rms_change[::-1], rtol=1e-9, atol=1e-15)
    assert res.rms_change[10] == 0.0 and res.rms_change[0] > 0.0


def test_values_outside_the_physical_domain_are_skipped_or_rejected() -> None:
    centred = mc.Setup.paper(x=0.0, y=0.0, z=0.0)
    # z < -depth (0.71 mm) puts the sensing element inside the cilium's base
    res = mc.oat_sweep(centred, "z", np.linspace(-1.0e-3, 0.5e-3, 16))
    assert res.values.min() > -0.71e-3 and len(res.skipped) + res.values.size == 16
    assert all("outside the cilium" in why for _, why in res.skipped)
    with pytest.raises(mc.MagciliaError, match="z values must include at least one physical setup"):
        mc.oat_sweep(centred, "z", [-1.0e-3, -0.9e-3])
    study = mc.sensitivity_study(centred, spans={"z": (-1.0e-3, 1.0e-3)}, points=5, map_points=3)
    assert any(n.startswith("z: ") and "skipped" in n for n in study.notes)


@pytest.mark.parametrize(
    ("parameter", "values", "match"),
    [
        ("height", [3e-3, -1e-3], "height values must be positive lengths in m; got -0.001"),
        ("base_radius", [0.0], "base_radius values must be positive"),
        ("n_loops", [0, 1], "n_loops values must be whole numbers >= 1; got 0"),
        ("dipoles_per_loop", [2.5], "whole numbers >= 1; got 2.5"),
        ("x", [], "x values must be at least one value"),
        ("x", [math.nan], "x values must be finite"),
        ("offset", [0.0], "parameter must be one of"),
    ],
    ids=["negative-height", "zero-radius", "n-zero", "k-fraction", "empty", "nan", "unknown"],
)
def test_oat_bad_spans(parameter: str, values: list[float], match: str) -> None:
    with pytest.raises(mc.MagciliaError, match=match):
        mc.oat_sweep(mc.Setup.paper(), parameter, values)


def test_study_default_spans_and_content(data: mc.Measurement) -> None:
    setup = mc.Setup.paper()
    spans = default_spans(setup)
    assert spans["x"] == pytest.approx((0.4727e-3, 2.4727e-3))
    assert spans["z"] == (0.0, 1e-3) and spans["n_loops"] == (1.0, 10.0)
    assert spans["height"] == pytest.approx((0.8 * 3.2613e-3, 1.2 * 3.2613e-3))
    study = mc.sensitivity_study(setup, data, points=7, map_points=9)
    assert tuple(study.sweeps) == STUDY_PARAMETERS
    np.testing.assert_array_equal(study.sweeps["n_loops"].values, np.arange(1.0, 11.0))
    assert setup.params()["x"] in study.sweeps["x"].values  # the nominal value is included
    assert study.xy_map.rms_change.shape == (9, 9) and study.xy_map.cost is not None
    # the measured data were made from this setup: the cost is smallest near the nominal x
    x_sweep = study.sweeps["x"]
    assert abs(x_sweep.values[np.argmin(x_sweep.cost)] - setup.params()["x"]) <= 0.35e-3
    rows = {r["parameter"]: r for r in study.summary()}
    assert rows["dipoles_per_loop"]["max_rms_change_V"] < rows["n_loops"]["max_rms_change_V"]
    assert json.loads(json.dumps(study.to_dict()))["spans"]["z"] == [0.0, 1e-3]
    with pytest.raises(mc.MagciliaError, match=r"spans\['z'\] must be a finite .* low <= high"):
        mc.sensitivity_study(setup, spans={"z": (1e-3, 0.0)})
    with pytest.raises(mc.MagciliaError, match="spans key must be one of"):
        mc.sensitivity_study(setup, spans={"offset": (0.0, 1.0)})


def test_placement_map_matches_direct_evaluation() -> None:
    setup = mc.Setup.paper(x=0.0, y=0.0, z=-0.6e-3)
    xs = np.array([-0.3e-3, 0.0, 0.4e-3])
    ys = np.array([0.0, 0.5e-3])
    xy = mc.placement_map(setup, xs, ys)
    ref = setup.output(ANGLES)
    for j, y in enumerate(ys):
        for i, x in enumerate(xs):
            try:
                direct = setup.replace(x=x, y=y).output(ANGLES)
            except mc.MagciliaError:
                assert math.isnan(xy.rms_change[j, i])
                continue
            assert xy.rms_change[j, i] == pytest.approx(rms_change(direct, ref),
                                                        rel=1e-9, abs=1e-15)
    assert np.isnan(xy.rms_change).any()  # the element is inside the cilium somewhere on this grid


# -- Sobol ---------------------------------------------------------------------------------------
def ishigami(X: np.ndarray, a: float = 7.0, b: float = 0.1) -> np.ndarray:
    return np.sin(X[:, 0]) + a * np.sin(X[:, 1]) ** 2 + b * X[:, 2] ** 4 * np.sin(X[:, 0])


def ishigami_indices(a: float = 7.0, b: float = 0.1) -> tuple[np.ndarray, np.ndarray]:
    """Analytic first-order and total indices (Ishigami & Homma 1990; Sobol' & Levitan 1999)."""
    pi = math.pi
    v1 = 0.5 * (1 + b * pi**4 / 5) ** 2
    v2 = a**2 / 8
    v13 = b**2 * pi**8 * (1 / 18 - 1 / 50)
    var = v1 + v2 + v13
    return np.array([v1, v2, 0.0]) / var, np.array([v1 + v13, v2, v13]) / var


def test_sobol_ishigami_matches_analytic_indices() -> None:
    box = {"x1": (-math.pi, math.pi), "x2": (-math.pi, math.pi), "x3": (-math.pi, math.pi)}
    res = sobol_analysis(ishigami, box, n_base=8192, rng=1)
    s1, st = ishigami_indices()
    np.testing.assert_allclose(s1, [0.3139, 0.4424, 0.0], atol=1e-4)  # the literature values
    np.testing.assert_allclose(res.S1, s1, atol=0.03)
    np.testing.assert_allclose(res.ST, st, atol=0.03)
    assert np.all(res.S1_conf > 0) and np.all(res.S1_conf < 0.05)
    assert res.n_evaluations == 8192 * 5 and res.names == ("x1", "x2", "x3")
    again = sobol_analysis(ishigami, box, n_base=8192, rng=1)
    np.testing.assert_array_equal(again.S1, res.S1)  # seeded: reproducible (also the bootstrap)
    np.testing.assert_array_equal(again.S1_conf, res.S1_conf)


def test_sobol_integer_inputs_are_uniform_whole_numbers() -> None:
    seen: list[np.ndarray] = []

    def f(X: np.ndarray) -> np.ndarray:
        seen.append(X[:, 0].copy())
        return X[:, 0] + X[:, 1]

    sobol_analysis(f, {"n": (1, 3), "u": (0.0, 1.0)}, n_base=1024, integer=["n"], rng=0)
    n = np.concatenate(seen)
    values, counts = np.unique(n, return_counts=True)
    np.testing.assert_array_equal(values, [1.0, 2.0, 3.0])
    np.testing.assert_allclose(counts / n.size, 1 / 3, atol=0.02)


def test_sobol_indices_of_the_model() -> None:
    setup = mc.Setup.paper()
    # x varies over 1 mm, height over 0.1 um: the output's variance is all x's
    res = mc.sobol_indices(setup, bounds={"x": (1.0e-3, 2.0e-3), "height": (3.2613e-3, 3.2614e-3)},
                           n_base=512, rng=0)
    assert res.names == ("x", "height") and res.n_evaluations == 512 * 4
    assert res.S1[0] == pytest.approx(1.0, abs=0.05) and res.ST[0] == pytest.approx(1.0, abs=0.05)
    assert abs(res.ST[1]) < 0.01
    full = mc.sobol_indices(setup, n_base=256, rng=0)  # the calibration bounds, 7 inputs
    assert full.n_evaluations == 256 * 9 and len(full.names) == 7
    assert np.all(full.ST > -0.05) and full.ST.sum() >= 0.9  # totals cover the variance
    assert "Sobol indices (rms" in full.report()


def test_sobol_cost_measure(data: mc.Measurement) -> None:
    setup = mc.Setup.paper()
    res = mc.sobol_indices(setup, bounds={"x": (1.2e-3, 1.8e-3), "z": (0.3e-3, 0.5e-3)},
                           n_base=256, measure="cost", data=data, rng=2)
    assert res.measure == "cost" and res.output_mean > 0
    with pytest.raises(mc.MagciliaError, match="data must be a Measurement when measure='cost'"):
        mc.sobol_indices(setup, measure="cost", n_base=64)


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        ({"n_base": 1000}, "n_base must be a power of 2"),
        ({"bounds": {"x": (2e-3, 1e-3)}}, r"bounds\['x'\] must be a finite .* low < high"),
        ({"bounds": {"height": (0.0, 1e-3)}}, r"bounds\['height'\] must be positive"),
        ({"bounds": {"n_loops": (0, 3)}}, "whole numbers >= 1"),
        ({"bounds": {"offset": (0, 1)}}, "bounds key must be one of"),
        ({"measure": "max"}, "measure must be one of"),
    ],
    ids=["n-base", "reversed", "height", "n-zero", "unknown", "measure"],
)
def test_sobol_bad_input(kwargs: dict, match: str) -> None:
    with pytest.raises(mc.MagciliaError, match=match):
        mc.sobol_indices(mc.Setup.paper(), **{"n_base": 64, **kwargs})


def test_sobol_without_salib(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setitem(sys.modules, "SALib.sample.sobol", None)
    with pytest.raises(mc.MissingDependencyError, match=r"magcilia\[sensitivity\]"):
        mc.sobol_indices(mc.Setup.paper(), n_base=64)


# -- placement tolerance -------------------------------------------------------------------------
def test_placement_tolerance_reproduces_the_target_angle_error() -> None:
    setup = mc.Setup.paper()
    target = math.radians(0.05)
    tol = mc.placement_tolerance(setup, angle_accuracy=target, coordinates=("x", "y", "z"))
    fine = np.linspace(0.0, math.radians(85.0), 40001)
    nominal = setup.output(fine)  # decreasing: invert by interpolation
    for name, dx, worst in zip(tol.coordinates, tol.tolerance, tol.worst_angle, strict=True):
        moved = setup.replace(**{name: setup.params()[name] + dx}).output(ANGLES)
        inferred = np.interp(moved, nominal[::-1], fine[::-1])
        err = np.abs(inferred - ANGLES)
        inside = (moved < nominal[0]) & (moved > nominal[-1])
        assert err[inside].max() == pytest.approx(target, rel=0.05), name
        i = int(np.argmin(np.abs(ANGLES - worst)))
        if inside[i]:
            assert err[i] == pytest.approx(target, rel=0.05)
    # noise: scale x field noise over the band, divided by the smallest slope
    band = tol.bandwidth
    assert tol.noise_rms == pytest.approx(75.0 * setup.sensor.noise_rms(*band))
    assert tol.noise_angle == pytest.approx(tol.noise_rms / np.abs(tol.slope).min())
    assert np.all(tol.tolerance_with_noise <= tol.tolerance)
    assert "x must be known to ±" in tol.report()


def test_placement_tolerance_symmetry_and_bad_input() -> None:
    tol = mc.placement_tolerance(mc.Setup.paper(y=0.0), coordinates=("x", "y"))
    assert math.isinf(tol.tolerance[1]) and math.isfinite(tol.tolerance[0])
    assert "y: no first-order effect" in tol.report()
    with pytest.raises(mc.MagciliaError, match="angle_accuracy must be a positive angle"):
        mc.placement_tolerance(mc.Setup.paper(), angle_accuracy=0.0)
    with pytest.raises(mc.MagciliaError, match="coordinate must be one of"):
        mc.placement_tolerance(mc.Setup.paper(), coordinates=("w",))
    with pytest.raises(mc.MagciliaError, match="f_high must be greater than f_low"):
        mc.placement_tolerance(mc.Setup.paper(), bandwidth=(10.0, 1.0))


def test_report_files(tmp_path: Path, data: mc.Measurement) -> None:
    setup = mc.Setup.paper()
    study = mc.sensitivity_study(setup, data, points=5, map_points=6)
    sobol = mc.sobol_indices(setup, n_base=64, rng=0)
    tol = mc.placement_tolerance(setup)
    written = write_sensitivity_report(study, tmp_path, sobol, tol)
    expected = {"fig09_xy.png", "fig10_z.png", "fig11_nk.png", "fig12_geometry.png", "xy_map.png",
                "sobol.png", "sensitivity.json", "summary.md"}
    assert set(written) == expected
    assert {p.name for p in tmp_path.iterdir()} == expected  # nothing else (no temporaries)
    doc = json.loads((tmp_path / "sensitivity.json").read_text())
    assert doc["sobol"]["n_evaluations"] == 64 * 9
    assert doc["sweeps"]["x"]["cost_V2"] is not None
    summary = (tmp_path / "summary.md").read_text()
    assert "| base radius |" in summary and "x must be known to" in summary


def test_offset_free_change_reproduces_the_papers_ranking() -> None:
    # Sec. IV.C: x is the most sensitive; y and z are tolerant; k matters little, n matters; the
    # base diameter matters more than the height. With the offset free (as in the fit), the model
    # agrees over the default spans (x, y ±1 mm, z 0..1 mm, n, k 1..10, ±20 % geometry).
    study = mc.sensitivity_study(mc.Setup.paper(), points=21, map_points=3)
    shape = {k: float(r.shape_change.max()) for k, r in study.sweeps.items()}
    assert max(shape, key=shape.__getitem__) == "x"
    assert shape["y"] < 0.5 * shape["x"] and shape["z"] < 0.2 * shape["x"]
    assert shape["dipoles_per_loop"] < 0.5 * shape["n_loops"]
    assert shape["base_radius"] > 2 * shape["height"]
    for r in study.sweeps.values():  # shape² = rms² − mean²
        mean = np.mean(r.curves - r.reference, axis=1)
        np.testing.assert_allclose(r.shape_change**2, r.rms_change**2 - mean**2, atol=1e-18)
    # without the offset freed, y's level shift dominates: the measure matters
    assert study.sweeps["y"].rms_change.max() > study.sweeps["x"].rms_change.max()
    res = mc.sobol_indices(mc.Setup.paper(), bounds={"x": (1e-3, 2e-3), "y": (1.5e-3, 2.5e-3)},
                           measure="shape", n_base=128, rng=0)
    assert res.measure == "shape" and res.ST[0] > res.ST[1]
