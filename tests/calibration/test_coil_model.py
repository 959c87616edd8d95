"""The coil experiment's model (calibration.coil_model through Problem) against a loop of
mc.bend(..., actuation=) + Setup.field, and against the exact body (magpylib)."""

import numpy as np
import pytest

import magcilia as mc
from magcilia.calibration.experiments import CoilExperiment, experiment
from magcilia.calibration.problem import Problem
from magcilia.io.recordings import Measurement

FIELDS = np.array([[5e-4, 0.0, 0.0], [3e-4, 3e-4, 1e-4], [0.0, 0.0, 5e-4],
                   [-2e-4, 1e-4, -3e-4], [0.0, -4e-4, 0.0]])
NAMES = ("height", "base_radius", "x", "y", "z", "youngs_modulus", "magnetization_scale")
BOUNDS = {"height": (2e-3, 4e-3), "base_radius": (1e-4, 4e-4), "x": (-3e-3, 3e-3),
          "y": (-3e-3, 3e-3), "z": (0.0, 1e-3), "youngs_modulus": (1e5, 1e7),
          "magnetization_scale": (0.05, 5.0), "sensitivity": (5.0, 20.0)}


def _setup(**kw: float) -> mc.Setup:
    return mc.Setup.paper(height=3.26e-3, base_radius=1.8e-4, tip_radius=5e-5,
                          youngs_modulus=5e5).replace(**kw)


def _coil(b: np.ndarray, fields: np.ndarray | None = None, volts: np.ndarray | None = None
          ) -> Measurement:
    a = b.shape[0]
    common = (np.zeros(a), np.ones(a, np.int64), np.zeros(a, np.int64), np.zeros(a, np.int64))
    if fields is not None:
        return Measurement(common[0], np.full(a, np.nan), np.full(a, np.nan), *common[1:],
                           fields=fields, field_sem=np.full((a, 3), 1e-9), actuation=b)
    assert volts is not None
    return Measurement(common[0], volts, np.full(a, 1e-6), *common[1:], actuation=b)


def _loop(setup: mc.Setup, b: np.ndarray) -> np.ndarray:
    """The cilium's field under each applied field, one bend and one Setup.field at a time."""
    return np.array([setup.field(mc.bend(setup, 0.0, actuation=mc.Actuation.uniform(x)))[0]
                     for x in b])


def _vector(setup: mc.Setup, names: tuple[str, ...]) -> np.ndarray:
    values = {**setup.params(), "youngs_modulus": setup.youngs_modulus,
              "sensitivity": setup.sensor.sensitivity}
    return np.array([values[n] for n in names])


def test_experiment_picks_coil_and_rows() -> None:
    m = _coil(FIELDS, fields=np.zeros((5, 3)) + FIELDS)
    assert isinstance(experiment(m), CoilExperiment)
    assert experiment(m).tilts is None


@pytest.mark.parametrize("observable", ["field", "output"])
def test_model_matches_bend_and_setup_field(observable: str) -> None:
    truth = _setup(magnetization_scale=0.7, youngs_modulus=3e5)
    base = _setup()
    reading = _loop(truth, FIELDS) + FIELDS
    names = NAMES
    if observable == "field":
        m = _coil(FIELDS, fields=reading + np.array([1e-5, -2e-5, 3e-5]))
    else:
        names = (*NAMES, "sensitivity")
        m = _coil(FIELDS, volts=truth.sensor.scale * reading[:, 0] + 0.02)
    problem = Problem([experiment(m)], base, names, BOUNDS)
    p = _vector(truth, names)[None, :]
    r = problem.residuals(p)
    # the offsets projected out, the batched model reproduces the loop to round-off
    sigma = 1e-9 if observable == "field" else 1e-6
    assert np.abs(r).max() * sigma < (1e-14 if observable == "field" else 1e-12)
    # and a wrong magnetization scale or modulus does not
    q = p.copy()
    q[0, names.index("youngs_modulus")] *= 2.0
    assert np.abs(problem.residuals(q)).max() > 1.0


def test_population_and_jacobian() -> None:
    truth = _setup()
    m = _coil(FIELDS, fields=_loop(truth, FIELDS) + FIELDS)
    problem = Problem([experiment(m)], truth, NAMES, BOUNDS)
    p = _vector(truth, NAMES)
    rng = np.random.default_rng(1)
    pop = p * (1.0 + 0.05 * rng.standard_normal((4, p.size)))
    pop[:, 4] = np.abs(pop[:, 4])
    together = problem.residuals(pop)
    apart = np.concatenate([problem.residuals(row[None]) for row in pop])
    np.testing.assert_allclose(together, apart, rtol=1e-9, atol=1e-6)
    jac = problem.jacobian(p)
    assert jac.shape == (problem.size, len(NAMES)) and np.isfinite(jac).all()
    # coil data alone: the scale symmetry (every length × λ) is a near-null direction
    d = np.array([p[0], p[1], p[2], p[3], problem.base.sensor.depth + p[4], 0.0, 0.0])
    along = np.linalg.norm(jac @ d) / np.linalg.norm(jac, axis=0) @ np.abs(d)
    assert along < 1e-4


def test_invalid_sets_get_the_penalty() -> None:
    truth = _setup()
    m = _coil(FIELDS, fields=_loop(truth, FIELDS) + FIELDS)
    problem = Problem([experiment(m)], truth, NAMES, BOUNDS)
    p = _vector(truth, NAMES)
    bad = p.copy()
    bad[1] = 1e-5  # base radius below the tip radius: no valid setup
    cost = problem.cost(np.stack([p, bad]))
    assert cost[0] < 1e-6 and cost[1] >= 1e29


def test_with_tilt_and_load_experiments() -> None:
    """Coil, tilt (output) and force data in one problem: the search's magnetization scale and
    sensitivity reach the tilt outputs and the load fields too (model values from the loop)."""
    truth = _setup(magnetization_scale=0.7, youngs_modulus=3e5, sensitivity=1.2e-3 / 1e-4)
    base = _setup()
    angles = np.radians(np.linspace(-30.0, 30.0, 7))
    a = angles.size
    common = (np.ones(a, np.int64), np.zeros(a, np.int64), np.zeros(a, np.int64))
    tilt = Measurement(angles, truth.output(angles) + 0.01, np.full(a, 1e-6), *common)
    forces = np.linspace(0.0, 2e-5, 5)
    shapes = mc.bend_sweep(truth, forces)
    load = Measurement(np.zeros(5), np.full(5, np.nan), np.full(5, np.nan),
                       np.ones(5, np.int64), np.zeros(5, np.int64), np.zeros(5, np.int64),
                       fields=truth.field(shapes), field_sem=np.full((5, 3), 1e-9),
                       forces=forces)
    coil = _coil(FIELDS, volts=truth.sensor.scale * (_loop(truth, FIELDS) + FIELDS)[:, 0])
    names = (*NAMES, "sensitivity")
    problem = Problem([experiment(tilt), experiment(load), experiment(coil)], base, names,
                      BOUNDS)
    assert problem.all_names == names
    p = _vector(truth, names)[None, :]
    r = problem.residuals(p)
    assert np.abs(r).max() < 1e-3  # round-off of the bends, in units of the s.e.
    q = p.copy()
    q[0, names.index("sensitivity")] *= 1.01  # the tilt outputs and the coil's both move
    assert np.abs(problem.residuals(q)[0, :a]).max() > 3.0


def test_model_error_against_the_exact_body() -> None:
    """The physical layout's coil model against the exact body (magpylib cylinders) of the same
    bent shapes: after the offsets, within a few 1e-4 of the cilium's field change."""
    from magcilia.calibration.layout import converged_layout
    from magcilia.model.exact import exact_field

    truth = _setup(magnetization_scale=0.8, youngs_modulus=6.69e5)
    applied = 4.0 * FIELDS
    cilium = np.array([exact_field(truth, mc.bend(truth, 0.0, actuation=mc.Actuation.uniform(b)),
                                   400)[0] for b in applied])
    lay = converged_layout(truth)
    base = truth.replace(n_loops=lay.n_loops, dipoles_per_loop=lay.dipoles_per_loop,
                         ring=lay.ring)
    problem = Problem([experiment(_coil(applied, fields=cilium + applied))], base, NAMES, BOUNDS)
    error = problem.residuals(_vector(truth, NAMES)[None, :])[0] * 1e-9  # T (s.e. 1 nT)
    change = np.ptp(cilium, axis=0).max()
    assert change > 1e-6
    assert np.abs(error).max() < 5e-4 * change
