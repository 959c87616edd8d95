"""Cylinder drag law (Lamb–Oseen, White's correlation and the blend), fluid presets, flow
profiles, and the flow-loaded elastica against linear beam theory."""

from __future__ import annotations

import math

import numpy as np
import pytest

import magcilia as mc
from magcilia.mechanics import AIR, WATER, Flow, Fluid, drag_coefficient, drag_per_length


def lamb(re: float) -> float:
    return 8.0 * math.pi / (re * (0.5 - 0.5772156649015329 - math.log(re / 8.0)))


@pytest.mark.parametrize(
    ("re", "expected"),
    [(0.01, 380.37), (0.1, 58.383), (0.3, 26.129)],
    ids=["Re0.01", "Re0.1", "Re0.3"],
)
def test_lamb_oseen_values(re: float, expected: float) -> None:
    # 8π / (Re (2.0022 − ln Re)), values worked by hand
    assert float(drag_coefficient(re)) == pytest.approx(expected, rel=2e-4)
    assert float(drag_coefficient(re)) == pytest.approx(lamb(re), rel=1e-12)


@pytest.mark.parametrize(
    ("re", "expected"),
    [(1.0, 11.0), (10.0, 3.1544), (100.0, 1.4642), (1e3, 1.1), (1e5, 1.0046)],
    ids=["Re1", "Re10", "Re100", "Re1e3", "Re1e5"],
)
def test_white_correlation_values(re: float, expected: float) -> None:
    assert float(drag_coefficient(re)) == pytest.approx(expected, rel=2e-4)


@pytest.mark.parametrize(
    ("re", "measured", "tol"),
    [(10.0, 2.9, 0.15), (100.0, 1.4, 0.1), (1e4, 1.15, 0.15)],
    ids=["Re10", "Re100", "Re1e4"],
)
def test_against_the_measured_cylinder_curve(re: float, measured: float, tol: float) -> None:
    # the standard C_D(Re) curve of a circular cylinder (Tritton 1959; Wieselsberger), read
    # off to about ±10 %: the correlation must follow it
    assert float(drag_coefficient(re)) == pytest.approx(measured, rel=tol)


def test_blend_is_continuous_and_monotone() -> None:
    re = np.geomspace(1e-3, 1e5, 4001)
    cd = drag_coefficient(re)
    assert np.all(np.diff(cd) < 0.0)
    for edge in (0.5, 1.0):
        left, right = drag_coefficient([edge * (1 - 1e-9), edge * (1 + 1e-9)])
        assert left == pytest.approx(right, rel=1e-6)
    mid = float(drag_coefficient(math.sqrt(0.5)))
    assert min(lamb(math.sqrt(0.5)), 1 + 10 * 0.5 ** (-1 / 3)) < mid < lamb(0.5)


def test_drag_per_length_is_the_textbook_formula() -> None:
    d = np.array([1e-4, 3e-4])
    for fluid in (AIR, WATER):
        for u in (1e-3, 0.05, 2.0):
            re = fluid.density * u * d / fluid.viscosity
            expected = 0.5 * fluid.density * u**2 * d * drag_coefficient(re)
            np.testing.assert_allclose(drag_per_length(np.full(2, u), d, fluid), expected,
                                       rtol=1e-12)
    # odd in the speed, finite and vanishing at zero speed (no 0/0)
    u = np.array([-0.1, 0.0, 0.1])
    f = drag_per_length(u, np.full(3, 2e-4), WATER)
    assert f[1] == 0.0 and f[0] == -f[2] and f[2] > 0.0


def test_fluid_presets() -> None:
    assert (AIR.density, AIR.viscosity) == (1.204, 1.81e-5)
    assert (WATER.density, WATER.viscosity) == (998.2, 1.002e-3)
    with pytest.raises(mc.MagciliaError, match="viscosity must be a positive"):
        Fluid(1000.0, -1.0)


def test_flow_profiles() -> None:
    z = np.array([0.0, 1e-3, 3e-3])
    np.testing.assert_allclose(Flow.uniform(0.2).velocity(z), 0.2)
    np.testing.assert_allclose(Flow.shear(speed=0.3, height=3e-3).velocity(z), [0.0, 0.1, 0.3])
    np.testing.assert_allclose(Flow.shear(rate=100.0).velocity(z), 100.0 * z)
    custom = Flow.custom(lambda zz: 1.0 - np.exp(-zz / 1e-3), speed=2.0)
    np.testing.assert_allclose(custom.velocity(z), 2.0 * (1.0 - np.exp(-z / 1e-3)))
    assert custom.with_speed(1.0).velocity(z)[2] == pytest.approx(1.0 - math.exp(-3.0))
    with pytest.raises(mc.MagciliaError, match="profile must be a vectorised callable"):
        Flow.custom(lambda zz: 1.0)
    with pytest.raises(mc.MagciliaError, match="shear must be given a rate"):
        Flow.shear(speed=1.0)


def test_uniform_flow_on_a_cylinder_matches_linear_beam_theory() -> None:
    # small deflection: constant load q = f(U) per length -> tip deflection q L^4 / (8 E I)
    r, length, e = 1e-4, 3e-3, 2e6
    setup = mc.Setup.paper(height=length, base_radius=r, tip_radius=r, youngs_modulus=e)
    u = 3e-3  # Re = 0.6: the cylinder law, uniform along the rod (below Re 0.5 the slender-body
    # law makes the load vary along it: tests/mechanics/test_slender_drag.py)
    q = float(drag_per_length(np.array([u]), np.array([2 * r]), WATER)[0])
    expected = q * length**4 / (8.0 * e * math.pi * r**4 / 4.0)
    shape = mc.bend(setup, flow=Flow.uniform(u))
    assert expected / length < 1e-3  # linear regime
    assert shape.deflection == pytest.approx(expected, rel=2e-5)
    # the flow bends the cilium downstream, and flow toward -x mirrors it
    assert mc.bend(setup, flow=Flow.uniform(-u)).deflection == pytest.approx(-shape.deflection)


def test_strong_flow_bends_but_less_than_rigid_drag() -> None:
    # cross-flow principle: as the cilium bends, the normal speed (and drag) falls
    setup = mc.Setup.paper(height=3e-3, base_radius=2e-4, tip_radius=5e-5, youngs_modulus=2e6)
    weak, strong = (mc.bend(setup, flow=Flow.uniform(u, AIR)) for u in (1.0, 30.0))
    assert 0.0 < weak.tip_angle < strong.tip_angle < math.pi / 2
    assert strong.deflection < 900.0 * weak.deflection


def test_flow_input_errors() -> None:
    tapered = mc.Setup.paper(tip_radius=5e-5)
    with pytest.raises(mc.MagciliaError, match=r"flow speed must be at most .* drag law ends"):
        mc.bend(tapered, flow=Flow.uniform(1e4, WATER))
    with pytest.raises(mc.MagciliaError, match="tip_radius must be positive for a flow load"):
        mc.bend(mc.Setup.paper(), flow=Flow.uniform(0.1))
    with pytest.raises(mc.MagciliaError, match="reynolds must be in"):
        drag_coefficient(3e5)
    with pytest.raises(mc.MagciliaError, match=r"flow must be a magcilia\.Flow"):
        mc.bend(tapered, flow=0.1)  # type: ignore[arg-type]
