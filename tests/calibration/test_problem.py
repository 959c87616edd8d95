"""One calibration problem (issue 26, item 2): experiments are residual objects that add, the
paper's model is one experiment type of the same problem, parameters are objects named
structurally, and one result class reads back the files of earlier releases."""

from __future__ import annotations

import json
import math
import shutil
from pathlib import Path

import numpy as np
import pytest

import magcilia as mc
from magcilia._atomic import json_text
from magcilia._errors import MagciliaError
from magcilia.calibration import (
    NONFINITE_COST,
    CalibrationResult,
    FieldPath,
    JointCalibrationResult,
    ParameterKey,
    Prior,
    Problem,
    TiltPath,
)
from magcilia.calibration.joint import calibrate_joint, joint_problem
from magcilia.calibration.layout import PhysicalLayout
from magcilia.calibration.problem import GEOMETRY
from magcilia.io import Measurement

LAYOUT = PhysicalLayout(8, 5)
TRUTH = mc.Setup.paper(n_loops=8, dipoles_per_loop=5, ring="rms")
ANGLES = np.radians(np.arange(0.0, 81.0, 5.0))
OUTPUT_SE, FIELD_SE = 2e-6, 2e-8
EARLIER = Path(__file__).parent / "earlier_results"


def _output(seed: int, azimuth: float = 0.0, setup: mc.Setup = TRUTH) -> Measurement:
    """The single-axis output along one tilt path, constant standard errors, seeded noise."""
    rng = np.random.default_rng(seed)
    a = ANGLES.size
    volts = setup.output(ANGLES, azimuth=azimuth) + 3e-3 + rng.normal(0.0, OUTPUT_SE, a)
    return Measurement(angles=ANGLES.copy(), volts=volts, sem=np.full(a, OUTPUT_SE),
                       counts=np.full(a, 100), saturated=np.zeros(a, np.int64),
                       nonfinite=np.zeros(a, np.int64), azimuths=np.full(a, azimuth),
                       source=f"output {azimuth:g}")


def _field(seed: int, azimuth: float = 0.5) -> Measurement:
    """A 3-axis magnetometer's field along one tilt path, constant offsets, seeded noise."""
    rng = np.random.default_rng(seed)
    a = ANGLES.size
    b = TRUTH.field(ANGLES, azimuth=azimuth) + [2e-6, -1e-6, 4e-6] + rng.normal(0, FIELD_SE,
                                                                               (a, 3))
    return Measurement(angles=ANGLES.copy(), volts=np.zeros(a), sem=np.zeros(a),
                       counts=np.full(a, 100), saturated=np.zeros(a, np.int64),
                       nonfinite=np.zeros(a, np.int64), azimuths=np.full(a, azimuth),
                       fields=b, field_sem=np.full((a, 3), FIELD_SE), source=f"field {azimuth:g}")


def _rows(count: int, seed: int = 0) -> np.ndarray:
    """Parameter sets (count, 5) around the truth, SI."""
    p0 = np.array([TRUTH.params()[n] for n in GEOMETRY])
    return p0 * (1.0 + 0.03 * np.random.default_rng(seed).standard_normal((count, 5)))


def _problem(terms: object) -> Problem:
    bounds = {n: mc.calibration.DEFAULT_BOUNDS[n] for n in GEOMETRY}
    return Problem(terms, TRUTH, GEOMETRY, bounds)  # type: ignore[arg-type]


def test_experiments_add_their_costs() -> None:
    out, field = TiltPath(_output(1)), FieldPath(_field(2))
    prior = Prior("height", 3.1e-3, 0.1e-3)
    total = out + field + prior
    assert len(total) == 3 and total.priors == {"height": (3.1e-3, 0.1e-3)}
    P = _rows(6)
    joint = _problem(total)
    parts = _problem(out).cost(P) + _problem(field).cost(P) + _problem(prior + out).cost(P) - (
        _problem(out).cost(P))
    np.testing.assert_allclose(joint.cost(P), parts, rtol=1e-10)
    r = joint.residuals(P)
    assert r.shape == (6, ANGLES.size * 4 + 1) == (6, joint.size)
    np.testing.assert_allclose(np.einsum("nm,nm->n", r, r), joint.cost(P), rtol=1e-12)
    np.testing.assert_allclose(r[:, -1], (P[:, 0] - 3.1e-3) / 0.1e-3, rtol=1e-12)
    jac = joint.jacobian(P[0])  # the prior's row exact, the data rows as their differences
    np.testing.assert_array_equal(jac[-1], [1e4, 0.0, 0.0, 0.0, 0.0])
    step = np.array([0.0, 0.0, 1e-8, 0.0, 0.0])
    diff = (joint.residuals(P[0] + step) - joint.residuals(P[0] - step))[0] / 2e-8
    np.testing.assert_allclose(jac[:, 2], diff, rtol=1e-3, atol=1e-6 * np.abs(diff).max())
    # the bias parameters are named by experiment and axis, not by strings
    assert joint.bias_keys == (ParameterKey("offset", 0), *(ParameterKey("offset", 1, axis=c)
                                                            for c in range(3)))
    assert [k.label(many=True) for k in joint.bias_keys] == [
        "offset[0]", "offset_x[1]", "offset_y[1]", "offset_z[1]"]


def test_an_experiment_takes_recordings_of_its_kind() -> None:
    with pytest.raises(MagciliaError, match="TiltPath data must be a recording of its kind"):
        TiltPath(_field(1))
    with pytest.raises(MagciliaError, match="FieldPath fits this one"):
        TiltPath(_field(1))
    with pytest.raises(MagciliaError, match="not priors alone"):
        _problem(Prior("height", 3e-3, 1e-4))
    with pytest.raises(MagciliaError, match="two priors on one parameter"):
        _problem(TiltPath(_output(1)) + Prior("z", 1e-3, 1e-4) + Prior("z", 1e-3, 2e-4))


def test_the_non_finite_cost_is_one_value_for_every_problem() -> None:
    """A set whose model is not finite costs NONFINITE_COST whatever the experiments."""
    P = _rows(2)
    P[1, 0] = np.nan  # a model that is not finite
    for terms in (TiltPath(_output(1)), FieldPath(_field(2)), TiltPath(_output(1)) + Prior(
            "z", 1e-3, 1e-4)):
        with np.errstate(all="ignore"):
            problem = _problem(terms)
            cost, r = problem.cost(P), problem.residuals(P)
        assert cost[0] < NONFINITE_COST and cost[1] == NONFINITE_COST
        assert np.isfinite(r[1, :problem.y.size]).all()
    paper = Problem.paper(_output(1), TRUTH)
    assert paper.names == mc.calibration.PARAMETERS and paper.integer.sum() == 2


def test_the_paper_experiment_is_the_joint_problem_of_one_path() -> None:
    """The unweighted paper path and the weighted joint problem of the same recording (equal
    standard errors) are the same objective up to the constant 1/σ², so the same fit."""
    data = _output(3)
    paper = Problem.paper(data, TRUTH)
    joint = joint_problem([data], TRUTH, LAYOUT, mc.calibration.DEFAULT_BOUNDS, GEOMETRY)
    P = _rows(5, seed=4)
    full = np.concatenate([P, np.full((5, 2), [8.0, 5.0])], axis=1)  # n, k at the layout
    np.testing.assert_allclose(joint.cost(P) * OUTPUT_SE**2, paper.cost(full), rtol=1e-9)
    fixed = {"n_loops": 8, "dipoles_per_loop": 5}
    a = mc.calibrate(data, initial=TRUTH, rng=0, starts=32, fixed=fixed)
    b = mc.calibrate(data, initial=TRUTH, rng=0, starts=32, model="physical", layout=LAYOUT)
    assert type(a) is type(b) is CalibrationResult and (a.model, b.model) == ("paper", "physical")
    for n in ("x", "y", "z"):  # the size is undetermined along one path (scale symmetry)
        assert a.values[n] == pytest.approx(b.values[n], abs=0.02 * b.stderr[n] + 1e-9)
    assert a.cost / OUTPUT_SE**2 == pytest.approx(b.chi2, rel=1e-3)


def test_parameters_recovered_from_seeded_data_through_the_one_problem() -> None:
    data = [_output(5), _field(6)]
    fit = mc.calibrate(data, initial=TRUTH, rng=1, starts=16, model="physical", layout=LAYOUT)
    for n in GEOMETRY:
        assert abs(fit.values[n] - TRUTH.params()[n]) < 4.0 * fit.stderr[n], n
    assert fit.values["offset_x[1]"] == pytest.approx(2e-6, abs=4 * fit.stderr["offset_x[1]"])
    params = {p.label: p for p in fit.parameters}
    assert params["offset_z[1]"].key == ParameterKey("offset", 1, axis=2)
    assert params["offset_z[1]"].unit == "T" and params["height"].unit == "m"
    assert params["height"].bounds == fit.bounds["height"] and params["height"].vary
    assert fit.key("offset[0]") == ParameterKey("offset", 0)


def test_fixed_parameters_stay_put() -> None:
    data = [_output(7), _field(8)]
    held = 1.234e-3
    fit = mc.calibrate(data, initial=TRUTH, rng=2, starts=8, model="physical", layout=LAYOUT,
                       fixed={"z": held})
    assert fit.values["z"] == held and fit.fixed == {"z": held} and "z" not in fit.stderr
    assert fit.setup.params()["z"] == held
    z = next(p for p in fit.parameters if p.label == "z")
    assert z.fixed and not z.vary and math.isnan(z.stderr)
    paper = mc.calibrate(data[0], initial=TRUTH, rng=2, starts=8,
                         fixed={"x": 1.3e-3, "n_loops": 8, "dipoles_per_loop": 5})
    assert paper.values["x"] == 1.3e-3 and "x" not in paper.stderr


@pytest.mark.parametrize("sigma", [0.05e-3, 0.2e-3])
def test_a_prior_pulls_as_its_sigma_says(sigma: float) -> None:
    """One tilt path leaves the size undetermined (all lengths scaled together fit as well, the
    data-only standard error is inf): a prior on the height then sets it, near its value, with
    its σ, and the fit says the prior alone determines it."""
    mu = 3.4e-3
    free = mc.calibrate(_output(9), initial=TRUTH, rng=3, starts=16, model="physical",
                        layout=LAYOUT)
    assert free.stderr["height"] == math.inf
    fit = mc.calibrate(_output(9), initial=TRUTH, rng=3, starts=16, model="physical",
                       layout=LAYOUT, priors={"height": (mu, sigma)})
    assert fit.values["height"] == pytest.approx(mu, abs=0.5 * sigma)
    assert fit.stderr["height"] == pytest.approx(sigma, rel=1e-3)
    assert "height" in next(w for w in fit.diagnostics if w.kind == "prior_only").parameters
    assert next(p for p in fit.parameters if p.label == "height").prior == (mu, sigma)


@pytest.mark.parametrize("which", ["paper", "joint"])
def test_earlier_result_files_still_load(which: str, tmp_path: Path) -> None:
    folder = tmp_path / which
    shutil.copytree(EARLIER / which, folder)
    doc = json.loads((folder / "result.json").read_text())
    fit = CalibrationResult.load(folder)
    assert fit.model == ("paper" if which == "paper" else "physical")
    assert fit.values == doc["values"]
    assert fit.setup.params() == mc.load_setup(folder / "fitted_setup.toml").params()
    for name, se in doc["stderr"].items():
        assert fit.stderr[name] == (math.inf if se is None else se)
    assert fit.warnings == tuple(doc["warnings"]) and fit.report()
    assert JointCalibrationResult is CalibrationResult
    if which == "paper":
        assert fit.cost == doc["cost_V2"] and fit.rms == doc["rms_V"]
        np.testing.assert_allclose(fit.path.angles_deg, doc["angle_deg"], rtol=1e-12)
        np.testing.assert_allclose(fit.fitted, doc["fitted_V"], rtol=1e-12)
        assert fit.table()[0]["initial"] == pytest.approx(doc["table"][0]["initial"])
    else:
        assert fit.chi2 == doc["chi2"] and fit.dof == doc["dof"]
        assert [e.source for e in fit.experiments] == [e["source"] for e in doc["experiments"]]
        assert fit.key("offset_y[1]") == ParameterKey("offset", 1, axis=1)
        assert fit.priors == {k: tuple(p) for k, p in doc["priors"].items()}
    # what the file held keeps its meaning when written again
    again = json.loads(json_text(fit.to_dict()))
    for key, value in doc.items():
        if key not in ("table", "data", "units", "elapsed_s", "posterior"):
            assert again[key] == value, key


def test_results_round_trip_through_their_files() -> None:
    fit = mc.calibrate(_output(10), initial=TRUTH, rng=0, starts=8,
                       fixed={"n_loops": 8, "dipoles_per_loop": 5})
    back = CalibrationResult.from_dict(json.loads(json_text(fit.to_dict())))
    assert back.values == fit.values and back.stderr == fit.stderr
    assert back.model == "paper" and back.cost == fit.cost
    np.testing.assert_array_equal(back.path.sem, fit.path.sem)
    assert back.setup.params() == pytest.approx(fit.setup.params(), rel=1e-12)


def test_calibrate_takes_a_sum_of_experiments() -> None:
    """The physical fit of experiment objects that add is the fit of their recordings and
    priors."""
    a, b = _output(11), _field(12)
    prior = {"height": (3.3e-3, 0.1e-3)}
    by_sum = calibrate_joint(TiltPath(a) + FieldPath(b) + Prior("height", *prior["height"]),
                             initial=TRUTH, rng=4, starts=8, layout=LAYOUT)
    by_list = mc.calibrate([a, b], initial=TRUTH, rng=4, starts=8, model="physical",
                           layout=LAYOUT, priors=prior)
    assert by_sum.values == pytest.approx(by_list.values, rel=1e-9, abs=1e-15)
    assert by_sum.priors == by_list.priors == prior
    with pytest.raises(MagciliaError, match="use model='physical' to fit several"):
        mc.calibrate([a, b], initial=TRUTH)
