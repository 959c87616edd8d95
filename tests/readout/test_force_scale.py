"""The force scale in every force and flow read-out: the Young's modulus's uncertainty (issue 24).

References: a Monte Carlo over E (draw E from its stated distribution, recompute the quantity of
one fixed reading through the model by root finding, compare the spread with the reported σ),
the exact scaling of a tip force with E at a fixed shape, the drag law's local exponent for a
flow, and central differences of independently built read-outs for the actuated ones.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
from scipy.optimize import brentq

import magcilia as mc
from magcilia.device.magnetometer import Magnetometer
from magcilia.mechanics import output_at
from magcilia.mechanics.drag import AIR, WATER, Fluid, drag_exponent, drag_per_length
from magcilia.readout.actuated import ActuatedReadout
from magcilia.readout.biaxial import channels
from magcilia.readout.inverse import model_output
from magcilia.readout.vector_model import actuated_polar_model

EXAMPLES = Path(__file__).resolve().parents[2] / "examples"
#: draws of E in a Monte Carlo (each a root finding through the model)
DRAWS = 48


@pytest.fixture(scope="module")
def setup() -> mc.Setup:
    """examples/force-sensor.toml (the presets' assumed modulus, 0.669 MPa ± 27 %) with fewer
    slices."""
    return mc.load_setup(EXAMPLES / "force-sensor.toml").replace(n_loops=12)


def _moduli(setup: mc.Setup, seed: int) -> np.ndarray:
    """``DRAWS`` moduli from the stated distribution: mean E, standard deviation σ_E (lognormal,
    so every draw is positive), Pa."""
    e, rel = setup.youngs_modulus, setup.youngs_modulus_uncertainty
    s = math.sqrt(math.log1p(rel * rel))
    return np.random.default_rng(seed).lognormal(math.log(e) - 0.5 * s * s, s, DRAWS)


def _recomputed(setup: mc.Setup, quantity: str, volts: float, moduli: np.ndarray, guess: float,
                flow: mc.Flow | None = None) -> np.ndarray:
    """The quantity whose model output is ``volts`` for each modulus (root finding on
    :func:`output_at`, bracketed by ``guess`` scaled with E)."""
    out = []
    for e in moduli:
        s = setup.replace(youngs_modulus=float(e))
        hi = 4.0 * guess * e / setup.youngs_modulus

        def residual(q: float, s: mc.Setup = s) -> float:
            return float(output_at(s, quantity, np.array([q]), flow)[0] - volts)

        out.append(brentq(residual, 0.0, hi, xtol=1e-15, rtol=1e-12))
    return np.array(out)


@pytest.mark.parametrize("seed", [0, 1])
def test_force_sigma_matches_a_monte_carlo_over_the_modulus(setup: mc.Setup, seed: int) -> None:
    """Draws of E move the force of one reading exactly as the reported σ_scale says: the force
    scales with E, so its spread is the draws' spread of E times F/E (a control variate: the
    draws' own spread, so any seed passes at the solver's precision); and σ_scale is
    |F| σ_E/E."""
    force = 2.5e-5
    volts = float(output_at(setup, "force", np.array([force]))[0])
    res = mc.Readout(setup, "force", (0.0, 4e-5), table_size=129).read([volts])
    rel = setup.youngs_modulus_uncertainty
    assert rel == pytest.approx(0.266, abs=0.001)
    assert res.sigma_scale[0] == pytest.approx(abs(res.value[0]) * rel, rel=1e-12)
    assert res.sigma[0] == pytest.approx(math.hypot(res.sigma_noise[0], res.sigma_scale[0]),
                                         rel=1e-12)
    assert res.sigma[0] > 10 * res.sigma_noise[0]  # the force scale dominates here
    moduli = _moduli(setup, seed)
    forces = _recomputed(setup, "force", volts, moduli, force)
    spread_e = float(np.std(moduli, ddof=1)) / setup.youngs_modulus
    assert float(np.std(forces, ddof=1)) == pytest.approx(
        res.sigma_scale[0] * spread_e / rel, rel=1e-4)
    # and plainly: the Monte Carlo spread is the reported σ_scale within its sampling error
    assert float(np.std(forces, ddof=1)) == pytest.approx(res.sigma_scale[0], rel=0.5)
    assert "force scale from an assumed modulus ±27 %" in res.report()


@pytest.mark.parametrize("speed", [0.05, 0.2])
def test_flow_sigma_matches_a_monte_carlo_over_the_modulus(setup: mc.Setup,
                                                           speed: float) -> None:
    """A flow speed scales as E^(1/n) (the drag law's exponent n): the Monte Carlo's spread over
    E, against the draws' own spread of E, is the reported σ_scale to first order (the curvature
    of E^(1/n) leaves a few %)."""
    flow = mc.Flow.uniform(1.0, WATER)
    volts = float(output_at(setup, "flow", np.array([speed]), flow)[0])
    res = mc.Readout(setup, "flow", (0.0, 0.3), flow=flow, table_size=65).read([volts])
    rel = setup.youngs_modulus_uncertainty
    moduli = _moduli(setup, 7)
    speeds = _recomputed(setup, "flow", volts, moduli, speed, flow)
    spread_e = float(np.std(moduli, ddof=1)) / setup.youngs_modulus
    assert float(np.std(speeds, ddof=1)) == pytest.approx(
        res.sigma_scale[0] * spread_e / rel, rel=0.05)
    assert 0.5 * rel * speed < res.sigma_scale[0] < rel * speed  # 1 < n < 2
    assert res.sigma[0] == pytest.approx(math.hypot(res.sigma_noise[0], res.sigma_scale[0]),
                                         rel=1e-12)


@pytest.mark.parametrize(("fluid", "speed"), [(AIR, 3.0), (AIR, 8.0), (WATER, 0.05),
                                              (WATER, 0.2)])
def test_flow_share_is_the_drag_laws_exponent(setup: mc.Setup, fluid: mc.Fluid,
                                              speed: float) -> None:
    """σ_U/U = (σ_E/E)/n with n the drag law's local exponent d ln f/d ln U, averaged over the
    hair with the weight of each element's moment about the base (the bent shape moves this by
    about 1 %)."""
    flow = mc.Flow.uniform(1.0, fluid)
    volts = output_at(setup, "flow", np.array([speed]), flow)
    res = mc.Readout(setup, "flow", (0.0, 2 * speed), flow=flow, table_size=65).read(volts)
    share = res.sigma_scale[0] / (res.value[0] * setup.youngs_modulus_uncertainty)
    s = np.linspace(0.0, setup.cilium.height, 401)
    d = 2.0 * setup.cilium.radius(s)
    moment = np.abs(drag_per_length(np.full_like(d, speed), d, fluid)) * s
    n = float(np.sum(moment * drag_exponent(speed, d, fluid)) / np.sum(moment))
    assert 1.4 < n < 1.9
    assert share == pytest.approx(1.0 / n, rel=0.02)


def test_creeping_flow_scales_exactly_with_the_modulus(setup: mc.Setup) -> None:
    """Below Re ≈ 0.02 the drag is linear in U (the slender-body law): U ∝ E, σ_U = U σ_E/E."""
    glycerol = Fluid(density=1260.0, viscosity=1.41, name="glycerol")
    flow = mc.Flow.uniform(1.0, glycerol)
    assert float(glycerol.reynolds(2e-3, 2 * setup.cilium.base_radius)) < 0.02
    volts = output_at(setup, "flow", np.array([1e-3]), flow)
    res = mc.Readout(setup, "flow", (0.0, 2e-3), flow=flow, table_size=65).read(volts)
    assert res.sigma_scale[0] == pytest.approx(1e-3 * setup.youngs_modulus_uncertainty,
                                               rel=1e-4)
    assert float(drag_exponent(1e-3, 3e-4, glycerol, slender=8.0)) == pytest.approx(1.0,
                                                                                  abs=1e-9)


def test_sources_of_the_modulus(setup: mc.Setup) -> None:
    """A given modulus without σ is exact (no scale part, said so); with σ it is measured; an
    angle never carries it."""
    volts = output_at(setup, "force", np.array([2e-5]))
    exact = setup.replace(youngs_modulus=6e5)
    res = mc.Readout(exact, "force", (0.0, 4e-5), table_size=65).read(volts)
    assert (res.sigma_scale == 0).all() and (res.sigma == res.sigma_noise).all()
    assert res.scale_note == "force scale: modulus given, taken as exact (E 0.6 MPa)"
    measured = setup.replace(youngs_modulus=6e5, youngs_modulus_sigma=3e4)
    res = mc.Readout(measured, "force", (0.0, 4e-5), table_size=65).read(volts)
    assert res.sigma_scale[0] == pytest.approx(0.05 * res.value[0], rel=1e-12)
    assert "force scale from a measured modulus ±5 % (E 0.6 MPa)" in res.report()
    angle = mc.Readout(setup, "angle", (0.0, 0.5), table_size=33)
    out = angle.read(setup.output([0.2]))
    assert out.sigma_scale[0] == 0.0 and out.scale_note == "" and "force scale" not in out.report()
    doc = mc.Readout(setup, "force", (0.0, 4e-5), table_size=33).to_dict()
    assert doc["modulus"]["source"] == "assumed"
    assert doc["modulus"]["relative"] == pytest.approx(setup.youngs_modulus_uncertainty)


def test_actuated_share_against_readouts_built_at_other_moduli(setup: mc.Setup) -> None:
    """Under an actuation the magnetic loads do not scale with E: the share comes from the model.
    Reference: the estimates of the same reading by read-outs built at E·(1 ± 1 %)."""
    coil = mc.Actuation.uniform((2e-4, 0.0, 0.0))
    span = (0.0, 4e-5)
    volts = model_output(setup, "force", np.array([2e-5]), actuation=coil)
    res = mc.Readout(setup, "force", span, actuation=coil, table_size=65).read(volts)
    e = setup.youngs_modulus
    up, down = (mc.Readout(setup.replace(youngs_modulus=e * f), "force", (0.0, 5e-5),
                           actuation=coil, table_size=65).estimate(volts)[0]
                for f in (1.01, 0.99))
    rate = (up - down) / 0.02
    assert res.sigma_scale[0] == pytest.approx(abs(rate) * setup.youngs_modulus_uncertainty,
                                               rel=0.01)
    assert abs(rate) != pytest.approx(2e-5, rel=0.01)  # not the plain scaling
    levels = ActuatedReadout(setup, "force", span, coil, [0.0, 1.0], table_size=65)
    both = levels.read(volts, 1.0)
    assert both.sigma_scale[0] == pytest.approx(res.sigma_scale[0], rel=1e-9)
    assert "force scale from an assumed modulus" in levels.report()


def test_force_vector_scale_is_along_the_force(setup: mc.Setup) -> None:
    sensor = Magnetometer(field_range=1e-3, resolution=1e-9, noise=2e-8, rate=100.0)
    r = mc.BiaxialReadout(setup, sensor, span=4e-5, table_size=(17, 32))
    plain = mc.BiaxialReadout(setup.replace(youngs_modulus=setup.youngs_modulus), sensor,
                              span=4e-5, table_size=(17, 32))
    b = sensor.to_sensor(setup.field(mc.bend(setup, 2e-5), azimuth=0.5))
    res, ref = r.read(b), plain.read(b)
    rel = setup.youngs_modulus_uncertainty
    f = res.vector[0]
    np.testing.assert_allclose(res.covariance_scale[0], rel**2 * np.outer(f, f), rtol=1e-12)
    np.testing.assert_allclose(res.covariance_noise, ref.covariance, rtol=1e-9, atol=1e-30)
    assert res.sigma_magnitude[0] == pytest.approx(math.hypot(ref.sigma_magnitude[0],
                                                              rel * res.magnitude[0]), rel=1e-9)
    assert res.sigma_direction[0] == pytest.approx(ref.sigma_direction[0], rel=1e-9)
    assert res.sigma_scale[0] == pytest.approx(rel * res.magnitude[0], rel=1e-12)
    assert "assumed modulus" in res.report() and "taken as exact" in ref.report()


def test_actuated_force_vector_share_against_readouts_at_other_moduli(setup: mc.Setup) -> None:
    sensor = Magnetometer(field_range=1e-3, resolution=1e-9, noise=2e-8, rate=100.0)
    act = mc.Actuation.uniform((0.0, 0.0, 5e-4))
    fields, _ = actuated_polar_model(setup, channels(sensor), np.array([2e-5]), np.array([0.5]),
                                     act)
    r = mc.BiaxialReadout(setup, sensor, span=4e-5, table_size=(17, 32), actuation=act)
    res = r.read(fields[0])
    e = setup.youngs_modulus
    up, down = (mc.BiaxialReadout(setup.replace(youngs_modulus=e * f), sensor, span=5e-5,
                                  table_size=(17, 32), actuation=act).read(fields[0]).vector[0]
                for f in (1.01, 0.99))
    rate = (up - down) / 0.02
    assert res.sigma_scale[0] == pytest.approx(
        float(np.hypot(*rate)) * setup.youngs_modulus_uncertainty, rel=0.01)


def test_array_cilia_of_one_modulus_share_its_error() -> None:
    part = Magnetometer(field_range=5e-3, resolution=1.5e-7, noise=3e-7, rate=100.0)
    cilium = mc.Setup.paper(tip_radius=5e-5, position=(0.0, 0.0, 0.0))
    array = mc.CiliaArray.grid(cilium, 1, 2, 2.5e-3, sensor=part)
    r = mc.ArrayReadout(array, 2e-5, table_size=9)
    loads = np.array([[1e-5, 0.0], [0.0, -5e-6]])
    est = r.read(mc.field_for_loads(array, loads))
    rel = cilium.youngs_modulus_uncertainty
    vec = est.force.reshape(-1)
    np.testing.assert_allclose(est.covariance_scale, rel**2 * np.outer(vec, vec), rtol=1e-12)
    np.testing.assert_allclose(est.sigma_scale, rel * est.magnitude, rtol=1e-12)
    assert est.report().endswith(cilium.modulus.note())
    # the noise's share alone: what the same array gives with its modulus taken as exact
    exact = cilium.replace(youngs_modulus=cilium.youngs_modulus)
    assert exact.modulus.source == "exact"
    alone = mc.ArrayReadout(mc.CiliaArray.grid(exact, 1, 2, 2.5e-3, sensor=part), 2e-5,
                            table_size=9).read(mc.field_for_loads(array, loads))
    np.testing.assert_allclose(est.sigma_noise, alone.sigma, rtol=1e-6)
    np.testing.assert_allclose(est.sigma**2, est.sigma_noise**2 + rel**2 * est.force**2,
                               rtol=1e-9)


def test_bend_and_design_carry_the_force_scale(setup: mc.Setup) -> None:
    """Under a small tip force the tip deflects by F·L³/(3 E I₀ λ) (the closed-form compliance of
    a frustum), ∝ 1/E: its σ is the deflection times σ_E/E. Design metrics: a force's minimum
    and range scale exactly with E; a flow's with the drag law's 1/n."""
    from magcilia.mechanics import tip_compliance
    from magcilia.report.mechanics import bend_scale

    rel = setup.youngs_modulus_uncertainty
    force = 1e-8  # N: linear
    shape = mc.bend(setup, force)
    c = setup.cilium
    closed = c.height**3 / (3.0 * setup.youngs_modulus * math.pi * c.base_radius**4 / 4.0
                            * c.taper)
    assert tip_compliance(setup) == pytest.approx(closed, rel=1e-12)
    assert shape.tip[0] == pytest.approx(force * closed, rel=1e-4)
    scale = bend_scale(setup, shape)
    assert scale["sigma_tip_m"][0] == pytest.approx(force * closed * rel, rel=1e-4)
    assert scale["scale_note"] == setup.modulus.note()
    exact = bend_scale(setup.replace(youngs_modulus=6e5), shape)
    assert exact["sigma_tip_m"] == [0.0, 0.0, 0.0] and "taken as exact" in exact["scale_note"]
    metrics = mc.design_metrics(setup, points=31)
    f = metrics.force
    assert f.sigma_minimum == pytest.approx(rel * f.minimum, rel=1e-12)
    assert f.sigma_range == pytest.approx(rel * f.range, rel=1e-12)
    u = metrics.flow
    assert 0.5 * rel * u.minimum < u.sigma_minimum < rel * u.minimum
    assert metrics.angle.sigma_minimum == 0.0
    assert metrics.scale_note.startswith(setup.modulus.note() + ": force minimum ±27 %")
    assert metrics.to_dict()["modulus"]["source"] == "assumed"
