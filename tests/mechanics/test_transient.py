"""The time-domain forward model (:mod:`magcilia.mechanics.transient`) against an independent full
dynamic solve (a finite-element Euler–Bernoulli rod integrated by Newmark, ``beam_reference.py``),
its static limit, its discretisation and its streaming."""

from __future__ import annotations

import importlib.util
import math
import sys
from pathlib import Path

import numpy as np
import pytest
from scipy.integrate import solve_ivp

import magcilia as mc
from magcilia.mechanics import output_at, tip_compliance
from magcilia.mechanics.transient import (
    ModalDynamics,
    ResponseStream,
    StaticMap,
    TransientResponse,
    simulate_response,
)


def _reference():
    name = "magcilia_beam_reference"
    if name not in sys.modules:
        spec = importlib.util.spec_from_file_location(name,
                                                      Path(__file__).with_name("beam_reference.py"))
        assert spec is not None and spec.loader is not None
        module = importlib.util.module_from_spec(spec)
        sys.modules[name] = module
        spec.loader.exec_module(module)
    return sys.modules[name]


SETUP = mc.presets.load("force-sensor")
RATE = 10_000.0
ZETA = 0.02


@pytest.fixture(scope="module")
def fe_modes():
    return _reference().modes(SETUP, 3, ZETA, elements=40)


@pytest.mark.parametrize(("load", "tolerance"), [
    pytest.param(np.r_[np.zeros(5), np.full(395, 1e-8)], 0.01, id="step"),
    pytest.param(1e-8 * np.sin(2 * np.pi * 120 * np.arange(400) / RATE), 0.02, id="120 Hz"),
])
def test_small_loads_follow_the_full_finite_element_solve(fe_modes, load, tolerance):
    """Three modes and the higher modes' static share against the full FE rod (40 elements,
    every mode, Newmark with 16 steps a sample) under a tip force held over each sample."""
    full = _reference().newmark_tip(SETUP, load, RATE, ZETA, substeps=16, elements=40)
    r = simulate_response(SETUP, load, RATE, modes=fe_modes)
    assert np.max(np.abs(r.tip - full)) <= tolerance * np.max(np.abs(full))


def test_more_modes_converge_on_the_full_solve():
    """Driven at 300 Hz (between the first two modes) the truncation shows; it falls with more
    modes (3 → 8)."""
    ref = _reference()
    t = np.arange(400) / RATE
    load = 1e-8 * np.sin(2 * np.pi * 300 * t) * t / t[-1]
    full = ref.newmark_tip(SETUP, load, RATE, ZETA, substeps=16, elements=40)
    errors = [np.max(np.abs(simulate_response(SETUP, load, RATE, modes=ref.modes(
        SETUP, m, ZETA, elements=40)).tip - full)) / np.max(np.abs(full)) for m in (3, 8)]
    assert errors[1] < 0.3 * errors[0] and errors[1] < 0.01


def test_the_modes_of_magcilia_give_the_same_ringing():
    """The reduced model on :func:`magcilia.modes` (vacuum) against the FE rod over the first
    periods of a step (their frequencies agree to well under 1 %)."""
    ref = _reference()
    load = np.r_[0.0, np.full(199, 1e-8)]
    full = ref.newmark_tip(SETUP, load, RATE, 0.0, substeps=16, elements=40)
    r = simulate_response(SETUP, load, RATE)
    assert np.max(np.abs(r.tip - full)) <= 0.02 * np.max(np.abs(full))


def test_exact_discretisation_matches_an_ode_solve(fe_modes):
    """The biquads against solve_ivp of the modal ODE, with the load linear between samples."""
    rate = 2_000.0  # coarse: an inexact step would show
    t = np.arange(120) / rate
    load = 1e-8 * np.cos(2 * np.pi * 90 * t) + 5e-9 * (t > 0.02)
    r = simulate_response(SETUP, load, rate, modes=fe_modes, hold="foh")
    dyn = ModalDynamics.from_modes(fe_modes, tip_compliance(SETUP))
    a, b, c, d = dyn.state_space()

    def u(x):
        return np.interp(x, t, load)

    x0 = np.column_stack([dyn.shares, np.zeros(3)]).reshape(-1) * load[0]
    sol = solve_ivp(lambda x, y: a @ y + b * u(x), (0, t[-1]), x0, t_eval=t, rtol=1e-10,
                    atol=1e-20, max_step=1e-4)
    want = (c @ sol.y + d * load) * tip_compliance(SETUP)
    assert np.max(np.abs(r.tip - want)) <= 1e-5 * np.max(np.abs(want))


@pytest.mark.parametrize("hold", ["zoh", "foh"])
def test_a_constant_load_is_the_static_model(hold, fe_modes):
    """At rest under a load the output is the static large-deflection model's (no drift: the
    static gain is exactly 1), at small and at large deflection."""
    for force in (1e-7, 1.5e-5):
        r = simulate_response(SETUP, np.full(50, force), RATE, modes=fe_modes, hold=hold)
        rest, want = output_at(SETUP, "force", [0.0, force])
        # the static map is a 257-point table: its interpolation error, ≤ 3e-5 of the change
        assert np.allclose(r.output, want, rtol=0, atol=5e-5 * abs(want - rest))
        assert np.allclose(r.effective, force, rtol=1e-12)


def test_a_slow_ramp_is_quasi_static(fe_modes):
    """A ramp over 100 first-mode periods (linear between samples: exact) lags as the modes
    say once the start's transient has died out, each mode's share by 2ζ/ω, and stays on the
    static map."""
    n = 6000
    load = np.linspace(0.0, 1e-7, n)  # small: the effective load is the force
    r = simulate_response(SETUP, load, RATE, modes=fe_modes, hold="foh")
    dyn = ModalDynamics.from_modes(fe_modes, tip_compliance(SETUP))
    delay = np.sum(dyn.shares * 2 * dyn.damping_ratios / (2 * np.pi * dyn.frequencies))
    lag = delay * (load[1] - load[0]) * RATE
    end = slice(n - 500, n)
    assert np.allclose(r.effective[end], load[end] - lag, rtol=0, atol=3e-3 * lag)
    rest, *want = output_at(SETUP, "force", [0.0, *r.effective[::500]])
    assert np.allclose(r.output[::500], want, rtol=0, atol=1e-5 * abs(want[-1] - rest))


def test_streaming_in_blocks_equals_one_call(fe_modes):
    rng = np.random.default_rng(3)
    load = np.cumsum(rng.normal(0.0, 2e-8, 1000))
    one = simulate_response(SETUP, load, RATE, modes=fe_modes)
    stream = ResponseStream(SETUP, "force", RATE, modes=fe_modes)
    stream.prepare(load)
    parts = [stream.push(load[i:i + 137])[2] for i in range(0, 1000, 137)]
    assert np.allclose(np.concatenate(parts), one.output, rtol=0, atol=1e-12)


def test_air_rings_and_water_damps():
    step = np.r_[0.0, np.full(2999, 5e-6)]
    air = simulate_response(SETUP, step, RATE, fluid=mc.AIR)
    water = simulate_response(SETUP, step, RATE, fluid=mc.WATER)
    overshoot = [(x.effective.max() - 5e-6) / 5e-6 for x in (air, water)]
    zeta_air, zeta_water = air.damping_ratios[0], water.damping_ratios[0]
    # a second-order step's overshoot exp(−πζ/√(1−ζ²)) (the first mode carries most of it)
    assert overshoot[0] > 0.5 and overshoot[1] < overshoot[0]
    assert overshoot[1] == pytest.approx(
        math.exp(-math.pi * zeta_water / math.sqrt(1 - zeta_water**2)) * 0.8, rel=0.35)
    assert zeta_air < zeta_water < 1.0


def test_flow_and_angle_follow_the_same_dynamics(fe_modes):
    flow = simulate_response(SETUP, np.r_[0.0, np.full(3999, 0.05)], RATE,
                             quantity="flow", modes=fe_modes)
    assert flow.fluid == "water" and flow.unit == "m/s"
    assert flow.effective[-1] == pytest.approx(0.05, rel=0.01)  # the ringing gone (ζ = 0.02)
    assert flow.effective.max() > 0.06
    tilt = simulate_response(SETUP, np.r_[0.0, np.full(99, 0.2)], RATE, quantity="angle",
                             modes=fe_modes)
    assert tilt.effective.max() > 0.3
    assert tilt.output[0] == pytest.approx(SETUP.output([0.0])[0])


def test_the_reduction_states_its_stiffening(fe_modes):
    small = simulate_response(SETUP, np.r_[0.0, np.full(9, 1e-8)], RATE, modes=fe_modes)
    large = simulate_response(SETUP, np.r_[0.0, np.full(9, 1.5e-5)], RATE, modes=fe_modes)
    assert small.stiffening < 1e-3 < large.stiffening
    assert "stiffness change" in large.report()


def test_static_map_and_result_shapes():
    smap = StaticMap.build(SETUP, "force", -1e-5, 1e-5, points=33)
    assert smap.values.shape == smap.tip.shape == smap.output.shape == (33,)
    assert smap.load(np.array([0.0]))[0] == pytest.approx(0.0, abs=1e-15)
    r = simulate_response(SETUP, np.zeros(4), RATE)
    assert isinstance(r, TransientResponse)
    assert r.time.shape == r.output.shape == (4,)
    assert r.to_dataframe().shape == (4, 5)


@pytest.mark.parametrize(("kwargs", "message"), [
    ({"quantity": "torque"}, "quantity must be one of"),
    ({"hold": "cubic"}, "hold must be one of"),
    ({"rate": -1.0}, "rate must be a positive frequency"),
])
def test_bad_input_is_one_line(kwargs, message):
    args = {"rate": RATE, **kwargs}
    with pytest.raises(mc.MagciliaError, match=message):
        simulate_response(SETUP, np.zeros(3), **args)


def test_a_sharp_cone_has_no_dynamics_of_a_tip_load():
    with pytest.raises(mc.MagciliaError, match="tip_radius"):
        simulate_response(mc.Setup.paper(), np.zeros(3), RATE)
