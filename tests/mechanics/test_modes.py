"""Bending modes (magcilia.mechanics.modal): closed forms, an independent shooting model of the
tapered cilium, invariants of the modal figures, gravity and fluid loading."""

from __future__ import annotations

import itertools
import math
from pathlib import Path

import numpy as np
import pytest
from scipy.integrate import solve_ivp
from scipy.optimize import brentq

import magcilia as mc
from magcilia import MagciliaError
from magcilia.mechanics import GLYCEROL, WATER, Fluid, tip_compliance
from magcilia.mechanics.hydrodynamic import circular_gamma

ROOT = Path(__file__).resolve().parents[2]
SENSOR = mc.load_setup(ROOT / "examples" / "force-sensor.toml")
#: clamped-free uniform beam: β_n L (Rayleigh; Blevins, Formulas for Natural Frequency and Mode
#: Shape, table 8-1)
BETA_L = (1.875104068711961, 4.694091132974175, 7.854757438237613)


def _cylinder(radius: float = 1e-4, height: float = 3e-3, modulus: float = 1e6) -> mc.Setup:
    return mc.Setup.paper(height=height, base_radius=radius, tip_radius=radius,
                          youngs_modulus=modulus)


def _uniform_frequencies(setup: mc.Setup, extra_mass_per_length: float = 0.0) -> np.ndarray:
    c = setup.cilium
    area, second = math.pi * c.base_radius**2, math.pi * c.base_radius**4 / 4
    mass = setup.material.density * area + extra_mass_per_length
    return np.array([b**2 / (2 * math.pi * c.height**2)
                     * math.sqrt(setup.youngs_modulus * second / mass) for b in BETA_L])


def test_uniform_rod_matches_the_closed_form() -> None:
    setup = _cylinder()
    m = mc.modes(setup)
    np.testing.assert_allclose(m.frequencies, _uniform_frequencies(setup), rtol=1e-3)
    np.testing.assert_allclose(m.frequencies, _uniform_frequencies(setup), rtol=1e-5)
    assert np.all(m.damping_ratios == 0) and not m.overdamped.any()
    np.testing.assert_array_equal(m.damped_frequencies, m.frequencies)


def _shooting_frequencies(setup: mc.Setup, count: int = 3) -> np.ndarray:
    """The Euler–Bernoulli ODE (EI w'')'' = ρ A ω² w of the tapered body, clamped at s = 0, free
    at L, by shooting (solve_ivp): the ω where the tip's moment and shear determinant vanishes.
    Independent of the finite elements: its own quadrature of r(s), its own solver."""
    c, e, rho = setup.cilium, setup.youngs_modulus, setup.material.density
    knots = np.asarray(c.shape[0]) * c.height
    radii = c.radius(knots)

    def tip(omega: float) -> float:
        def rhs(s: float, y: np.ndarray) -> np.ndarray:
            r = float(np.interp(s, knots, radii))
            ei, rho_a = e * math.pi * r**4 / 4, rho * math.pi * r * r
            return np.array([y[1], y[2] / ei, y[3], rho_a * omega**2 * y[0],
                             y[5], y[6] / ei, y[7], rho_a * omega**2 * y[4]])

        y = np.array([0, 0, 1, 0, 0, 0, 0, 1], dtype=float)
        for a, b in itertools.pairwise(knots):  # r(s) is smooth between the knots
            y = solve_ivp(rhs, (a, b), y, rtol=1e-10, atol=1e-30, method="DOP853").y[:, -1]
        return float(y[2] * y[7] - y[3] * y[6])

    grid = np.geomspace(2 * math.pi * 20, 2 * math.pi * 1500 * count, 40 * count)
    values = [tip(w) for w in grid]
    roots = []
    for a, b, fa, fb in zip(grid[:-1], grid[1:], values[:-1], values[1:], strict=True):
        if fa * fb < 0:
            roots.append(brentq(tip, a, b, xtol=1e-10))
        if len(roots) == count:
            break
    return np.array(roots) / (2 * math.pi)


def test_tapered_cilium_matches_an_independent_shooting_model() -> None:
    m = mc.modes(SENSOR)
    reference = _shooting_frequencies(SENSOR)
    err = np.abs(m.frequencies / reference - 1)
    assert err[0] < 0.01 and np.all(err[1:] < 0.03), err
    assert np.all(err < 1e-4), err  # in fact the same to the elements' accuracy (24 elements)


def test_notes_figure_130_hz_at_half_a_megapascal() -> None:
    """NOTES §8: f₁ ≈ 130 Hz for the force-sensor cilium at 0.5 MPa in vacuum (ρ ≈ 1,670)."""
    m = mc.modes(SENSOR.replace(youngs_modulus=0.5e6), count=1)
    assert m.frequencies[0] == pytest.approx(130.0, rel=0.03)
    assert SENSOR.material.density == pytest.approx(1668.0, abs=1.0)


def test_modal_figures_are_referred_to_the_tip() -> None:
    m = mc.modes(SENSOR, count=6)
    np.testing.assert_allclose(m.shapes[:, -1], 1.0)
    np.testing.assert_array_equal(m.shapes[:, 0], 0.0)
    assert m.arc[0] == 0.0 and m.arc[-1] == pytest.approx(SENSOR.cilium.height)
    np.testing.assert_allclose(m.modal_stiffnesses, m.angular_frequencies**2 * m.modal_masses,
                               rtol=1e-9)
    assert np.all(np.diff(m.frequencies) > 0)
    # the modes' static compliances add up to the exact tip compliance L³/(3 E I₀ λ)
    exact = tip_compliance(SENSOR)
    many = mc.modes(SENSOR, count=20, elements=60)
    assert many.static_compliance == pytest.approx(exact, rel=2e-3)
    assert 0.7 * exact < 1 / m.modal_stiffnesses[0] < exact  # the first mode carries most


def test_element_count_converges() -> None:
    fine = mc.modes(SENSOR, elements=96).frequencies
    for elements, tol in ((8, 1e-3), (24, 2e-5), (48, 1e-6)):
        np.testing.assert_allclose(mc.modes(SENSOR, elements=elements).frequencies, fine,
                                   rtol=tol)


def test_a_measured_profile_is_integrated_at_its_knots() -> None:
    """A frustum written as a 50-point profile gives the frustum's modes; a profile with a
    thick middle differs."""
    c = SENSOR.cilium
    s = np.linspace(0.0, c.height, 50)
    as_profile = SENSOR.replace(cilium=mc.Cilium.from_profile(
        s, c.radius(s), youngs_modulus=SENSOR.youngs_modulus))
    np.testing.assert_allclose(mc.modes(as_profile).frequencies, mc.modes(SENSOR).frequencies,
                               rtol=1e-9)
    few = np.linspace(0.0, c.height, 9)
    bump = c.radius(few) * (1 + 0.3 * np.sin(np.pi * few / c.height))
    bumped = SENSOR.replace(cilium=mc.Cilium.from_profile(
        few, bump, youngs_modulus=SENSOR.youngs_modulus))
    assert mc.modes(bumped).frequencies[0] != pytest.approx(mc.modes(SENSOR).frequencies[0],
                                                            rel=0.02)
    reference = _shooting_frequencies(bumped, count=2)
    np.testing.assert_allclose(mc.modes(bumped, count=2).frequencies, reference, rtol=1e-4)


def test_gravity_softens_an_upright_hair_and_a_long_soft_one_buckles() -> None:
    setup = _cylinder(radius=1e-4, height=3e-3, modulus=1e6)
    free, loaded = mc.modes(setup), mc.modes(setup, gravity=True)
    assert np.all(loaded.frequencies < free.frequencies)
    # a uniform column under its own weight q: f₁² falls linearly to 0 at q_cr = 7.837 EI/L³
    # (Greenhill 1881; Timoshenko & Gere, Theory of Elastic Stability, §2.10)
    ei = setup.youngs_modulus * math.pi * 1e-16 / 4
    q = setup.material.density * math.pi * 1e-8 * 9.80665
    ratio = q / (7.837 * ei / 3e-3**3)
    drop = 1 - (loaded.frequencies[0] / free.frequencies[0]) ** 2
    assert drop == pytest.approx(ratio, rel=0.1)
    # in water the weight less buoyancy, (ρ − ρ_w) g A, loads the column: the modal stiffness
    # falls by the vacuum's fraction times (ρ − ρ_w)/ρ
    wet, wet_loaded = mc.modes(setup, WATER), mc.modes(setup, WATER, gravity=True)
    rho = setup.material.density
    np.testing.assert_allclose(1 - wet_loaded.modal_stiffnesses / wet.modal_stiffnesses,
                               (1 - loaded.modal_stiffnesses / free.modal_stiffnesses)
                               * (rho - WATER.density) / rho, rtol=1e-2)
    light = Fluid(density=10 * rho, viscosity=WATER.viscosity)  # buoyancy pulls: stiffer
    assert (mc.modes(setup, light, gravity=True).frequencies[0]
            > mc.modes(setup, light).frequencies[0])
    with pytest.raises(MagciliaError, match="buckles under its own weight"):
        mc.modes(_cylinder(radius=2e-5, height=8e-3, modulus=1e5), gravity=True)


def test_uniform_rod_in_a_fluid_follows_sader() -> None:
    """For a uniform beam the added mass and damping are uniform: the vacuum shape stays, and
    Sader's relations hold exactly: ω_f = ω_v (1 + ρ_f Γ_r(ω_f) / ρ_c)^(-1/2) and
    Q = (ρ_c/ρ_f + Γ_r) / Γ_i (J. Appl. Phys. 84, 64 (1998), eqs. 20–21 for a circular section)."""
    setup = _cylinder(radius=1e-4)
    rho_c = setup.material.density
    m = mc.modes(setup, WATER)
    for n in range(3):
        omega = m.angular_frequencies[n]
        g = complex(circular_gamma(WATER.density * omega * 1e-8 / WATER.viscosity))
        vac = _uniform_frequencies(setup)[n] * 2 * math.pi
        assert omega == pytest.approx(vac / math.sqrt(1 + WATER.density * g.real / rho_c),
                                      rel=1e-4)
        assert m.quality_factors[n] == pytest.approx((rho_c / WATER.density + g.real) / g.imag,
                                                     rel=1e-4)


def test_glycerol_overdamps_every_mode_without_nan() -> None:
    m = mc.modes(SENSOR, GLYCEROL)
    assert m.overdamped.all() and np.all(m.damping_ratios >= 1)
    np.testing.assert_array_equal(m.damped_frequencies, 0.0)
    for name in ("frequencies", "damping_ratios", "modal_masses", "modal_dampings"):
        assert np.all(np.isfinite(getattr(m, name))), name
    water = mc.modes(SENSOR, "water")
    assert water.frequencies[0] < mc.modes(SENSOR).frequencies[0]
    assert 0 < water.damping_ratios[0] < 1 and not water.overdamped[0]


def test_loss_factor_gives_half_eta_in_vacuum() -> None:
    m = mc.modes(SENSOR, loss_factor=0.1)
    np.testing.assert_allclose(m.damping_ratios, 0.05)


def test_bad_input_names_the_value() -> None:
    for kwargs, word in (({"count": 0}, "count"), ({"count": 50}, "count"),
                         ({"elements": 1}, "elements"), ({"fluid": "honey"}, "fluid"),
                         ({"gravity": "yes"}, "gravity"), ({"loss_factor": -1}, "loss_factor")):
        with pytest.raises(MagciliaError, match=word):
            mc.modes(SENSOR, **kwargs)  # type: ignore[arg-type]


def test_result_protocol() -> None:
    m = mc.modes(SENSOR, "water", count=2)
    doc = m.to_dict()
    assert doc["fluid"]["name"] == "water" and len(doc["modes"]) == 2
    assert "Hz" in repr(m) and "mode 2" in m.report()
    with pytest.raises(ValueError, match="read-only"):
        m.frequencies[0] = 1.0


def test_hydrodynamic_function_limits_and_table() -> None:
    """Γ of a circular section: the high-Re asymptote 1 + 2√2 (1 + i)/√Re (the potential added
    mass and the boundary layer; Sader 1998, Stokes 1851), the Stokes-paradox growth of both
    parts at low Re, and the spline table within 1e-9 of the exact Bessel form."""
    from magcilia.mechanics.hydrodynamic import gamma_table

    for re in (1e10, 1e12):  # the next term is O(1/Re)
        assert complex(circular_gamma(re)) == pytest.approx(
            1 + 2 * math.sqrt(2) * (1 + 1j) / math.sqrt(re), rel=1e-9)
    low = circular_gamma([1e-6, 1e-4, 1e-2])
    assert np.all(np.diff(low.real) < 0) and np.all(np.diff(low.imag) < 0) and low[0].real > 1e4
    re = np.geomspace(1e-13, 1e13, 5001)
    np.testing.assert_allclose(gamma_table(re), circular_gamma(re), rtol=1e-9)
