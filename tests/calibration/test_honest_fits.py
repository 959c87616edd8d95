"""Fits that say what they cannot tell (issue 24): on recordings made from the EXACT body (a stack
of magpylib cylinders, not the model that fits them), the physical fit holds the truth within 2σ
for base radius, x and z, or says "ambiguous"; a direction only a prior determines keeps the
prior's σ; undetermined parameters have null covariance entries in the JSON, and the
"undetermined" warning names what fixes the size (the scale symmetry: no tilt can).

The bundled example is the exact body of Table I's cilium (scripts/make_example_recording.py).
"""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest

import magcilia as mc
from magcilia.acquire.synthetic import clean_field, synthetic_recording
from magcilia.calibration import ParameterCovariance
from magcilia.calibration.joint import PhysicalLayout
from magcilia.cli import main
from magcilia.io import example_path
from magcilia.io.recordings import Measurement, measurement_from_samples

TRUTH = mc.Setup.paper()
#: the done-when's parameters: those a height prior and the tilt path pin down
CHECKED = ("base_radius", "x", "z")
HEIGHT_SIGMA = 0.15e-3
LAYOUT = PhysicalLayout(64, 5)  # converged_layout's choice for the paper's cilium


def _holds_or_ambiguous(fit: mc.JointCalibrationResult) -> bool:
    truth = TRUTH.params()
    holds = all(abs(fit.values[n] - truth[n]) <= 2 * fit.stderr[n] for n in CHECKED)
    return holds or any(w.kind == "ambiguous" for w in fit.diagnostics)


@pytest.fixture(scope="module")
def example_fit() -> mc.JointCalibrationResult:
    """The issue's command: the bundled example, physical model, height 3.2 ± 0.15 mm."""
    data = mc.read_measurements(example_path())
    return mc.calibrate(data, model="physical", priors={"height": (3.2e-3, HEIGHT_SIGMA)}, rng=0)


def test_the_example_is_the_exact_body_and_says_so() -> None:
    meta = json.loads(example_path().with_suffix(".json").read_text(encoding="utf-8"))
    body = meta["body"]
    assert body["model"] == "exact" and body["n_slices"] == 2000
    assert body["convergence"]["max_relative_field_difference"] < 1e-6
    assert body["paper_layout_error"]["max_relative_field_error"] > 0.1  # the 2 x 5 model
    assert "n_loops" not in meta["truth"]  # a body has no dipole layout
    # the clean signal is the exact body's: the per-angle means sit on it within the noise
    data = mc.read_measurements(example_path())
    angles = np.radians(meta["angles_deg"])
    exact = TRUTH.sensor.voltage(clean_field(TRUTH, angles, exact_slices=200)[:, 0])
    paper = TRUTH.output(angles)
    bias = meta["noise"]["bias"]
    resid_exact = data.volts - exact - bias
    resid_paper = data.volts - paper - bias
    # the drift (20 µV over the run) and 1/f noise remain, the coarse model's error does not
    assert np.abs(resid_exact - resid_exact.mean()).max() < 30e-6
    assert np.abs(resid_paper - resid_paper.mean()).max() > 100e-6


def test_the_bundled_example_holds_the_truth_or_says_ambiguous(
        example_fit: mc.JointCalibrationResult) -> None:
    assert _holds_or_ambiguous(example_fit), example_fit.report()
    # with an exact-body recording the physical model fits to the noise
    assert example_fit.chi2 / example_fit.dof < 1.5


def test_a_prior_only_direction_keeps_the_priors_sigma(
        example_fit: mc.JointCalibrationResult) -> None:
    """Tilt data leave the size free (scale symmetry): the height is the prior's alone, and the
    reduced χ² above 1 inflates the data's standard errors, not the prior's."""
    assert example_fit.chi2 / example_fit.dof > 1.0
    assert any(w.kind == "chi2" for w in example_fit.diagnostics)
    assert example_fit.stderr["height"] == pytest.approx(HEIGHT_SIGMA, rel=1e-3)
    assert not example_fit.undetermined()  # the prior determines the scale, and it alone
    note = next(w for w in example_fit.diagnostics if w.kind == "prior_only")
    assert "height" in note.parameters and "scale symmetry" in note.message
    assert "through the priors alone" in example_fit.report()


def test_understated_noise_inflates_the_data_not_the_prior() -> None:
    data = mc.read_measurements(example_path())
    half = Measurement(angles=data.angles, volts=data.volts, sem=data.sem / 3.0,
                       counts=data.counts, saturated=data.saturated, nonfinite=data.nonfinite,
                       source="understated")
    fit = mc.calibrate(half, model="physical", priors={"height": (3.2e-3, HEIGHT_SIGMA)},
                       layout=LAYOUT, rng=0, starts=16)
    assert fit.chi2 / fit.dof > 5.0
    assert fit.stderr["height"] == pytest.approx(HEIGHT_SIGMA, rel=1e-3)


def _single_path(seed: int) -> Measurement:
    """A single-path exact-body recording as the example's, 33 angles, 200 samples each."""
    rec = synthetic_recording(TRUTH, np.radians(np.linspace(0.0, 85.0, 33)),
                              samples_per_angle=200, exact_slices=400, rng=seed)
    return measurement_from_samples(rec.angle_deg, rec.voltage, source=f"exact{seed}")


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_single_path_exact_body_recordings_hold_the_truth_or_say_ambiguous(seed: int) -> None:
    """Seeded synthetic recordings of the exact body, a manual height (±0.15 mm, itself a noisy
    reading): the recovered base radius, x and z lie within 2σ of the truth, or the fit names
    the equally good alternative."""
    mu = TRUTH.params()["height"] + np.random.default_rng(seed).normal(0.0, HEIGHT_SIGMA)
    fit = mc.calibrate(_single_path(seed), model="physical", layout=LAYOUT, rng=seed,
                       priors={"height": (mu, HEIGHT_SIGMA)})
    assert _holds_or_ambiguous(fit), fit.report()


@pytest.mark.slow
def test_single_path_exact_body_rate() -> None:
    """Over 60 seeds, a fit that neither holds the truth within 2σ nor says "ambiguous" is rare:
    that happens when the noise favours the mirrored basin by more than Δχ² = 4, which the
    threshold allows a few % of the time (measured when written: 1 of these 60, 24 of them
    saying "ambiguous"; 0 of 20 at the example's noise; 3 of 100 with 17 angles and 3x the
    noise)."""
    misses = 0
    for seed in range(100, 160):
        mu = TRUTH.params()["height"] + np.random.default_rng(seed).normal(0.0, HEIGHT_SIGMA)
        fit = mc.calibrate(_single_path(seed), model="physical", layout=LAYOUT, rng=seed,
                           priors={"height": (mu, HEIGHT_SIGMA)})
        misses += not _holds_or_ambiguous(fit)
    assert misses <= 4


def test_paper_fit_json_has_null_covariance_for_undetermined_parameters(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    out = tmp_path / "cal"
    assert main(["calibrate", str(example_path()), "--out", str(out), "--quiet", "--json"]) == 0
    doc = json.loads(capsys.readouterr().out)
    undetermined = {n.removesuffix("_mm") for n, se in doc["stderr"].items() if se is None}
    assert {"height", "base_radius", "z"} <= undetermined  # the scale symmetry
    names = doc["covariance"]["names"]
    for i, name in enumerate(names):
        row = doc["covariance"]["matrix"][i]
        if name in undetermined:
            assert all(c is None for c in row), name
            assert all(r[i] is None for r in doc["covariance"]["matrix"]), name
        else:
            assert all((c is None) == (other in undetermined)
                       for c, other in zip(row, names, strict=True)), name
    # what propagation needs travels beside it, named for what it is, and is read back
    assert "propagation_covariance" in doc
    saved = json.loads((out / "result.json").read_text())
    assert saved["propagation_covariance"]["matrix"][0][0] is not None
    assert all(c is None for c in saved["covariance"]["matrix"][names.index("height")])
    back = ParameterCovariance.load(out)
    np.testing.assert_array_equal(back.covariance, np.array(
        saved["propagation_covariance"]["matrix"]))
    # the undetermined warning names the scale symmetry and what fixes the size
    text = next(d["message"] for d in saved["diagnostics"] if d["kind"] == "undetermined")
    assert "scale symmetry" in text and "--fix height=VALUE" in text
    assert "another azimuth" not in text.split("what fixes it is")[1]


def test_a_determined_fit_keeps_its_covariance_whole() -> None:
    data = mc.read_measurements(example_path())
    fit = mc.calibrate(data, rng=0, fixed={"height": 3.2613e-3, "n_loops": 2,
                                           "dipoles_per_loop": 5})
    doc = fit.uncertainty.to_dict()
    assert not fit.uncertainty.undetermined() and "propagation_covariance" not in doc
    np.testing.assert_array_equal(np.array(doc["covariance"]["matrix"]), fit.covariance)


def test_the_scale_symmetry_is_recognised_and_only_it() -> None:
    from magcilia.calibration.diagnostics import is_scale_symmetry, scale_direction

    names = ("height", "base_radius", "x", "z", "offset")
    values = {"height": 3e-3, "base_radius": 0.2e-3, "x": 1e-3, "z": 0.4e-3, "offset": 0.0}
    s = scale_direction(names, values, 0.71e-3)
    assert s.tolist() == pytest.approx([3e-3, 0.2e-3, 1e-3, 1.11e-3, 0.0])
    # a Jacobian whose only null direction is s (columns scaled to unit norm, as the SVD sees)
    rng = np.random.default_rng(0)
    jac = rng.normal(size=(30, 5))
    jac -= np.outer(jac @ s, s) / (s @ s)
    slopes = np.linalg.norm(jac, axis=0)
    _, sv, vt = np.linalg.svd(jac / slopes)
    null = vt[sv < 1e-9 * sv[0]]
    assert null.shape[0] == 1 and is_scale_symmetry(jac, null, names, values, 0.71e-3)
    other = np.zeros((1, 5))
    other[0, 2] = 1.0  # x alone: not the scale
    assert not is_scale_symmetry(jac, other, names, values, 0.71e-3)


def test_without_a_size_the_physical_fit_asks_for_one() -> None:
    """Two azimuths of 3-axis data without a prior: the size is undetermined, and the warning
    asks for a size or load data, never for the azimuths and field data it already has."""
    angles = np.radians(np.linspace(0.0, 80.0, 9))
    data = []
    for phi in (0.0, math.pi / 2):
        b = clean_field(TRUTH, angles, phi, exact_slices=400)
        a = angles.size
        data.append(Measurement(
            angles=angles, volts=np.full(a, np.nan), sem=np.full(a, np.nan),
            counts=np.full(a, 100), saturated=np.zeros(a, np.int64),
            nonfinite=np.zeros(a, np.int64), source=f"az{phi:.1f}", azimuths=np.full(a, phi),
            fields=b + np.random.default_rng(1).normal(0.0, 0.2e-6, b.shape),
            field_sem=np.full((a, 3), 0.2e-6)))
    fit = mc.calibrate(data, model="physical", layout=LAYOUT, rng=0, starts=8,
                       initial=TRUTH.replace(height=3.0e-3))
    text = next(w.message for w in fit.diagnostics if w.kind == "undetermined")
    assert set(fit.undetermined()) >= {"height", "base_radius"}
    assert "scale symmetry" in text and "--prior height=VALUE:SIGMA" in text
    assert "force or flow" in text and "another azimuth" not in text
