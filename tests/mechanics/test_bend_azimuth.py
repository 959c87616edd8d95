"""Bending in any direction: a force or flow at any azimuth, a force vector, vertical loads and
buckling; the x–z results stay today's bit for bit."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.optimize import brentq
from scipy.special import ellipe, ellipk

import magcilia as mc
from magcilia.mechanics import bend_3d, buckling_load

L, R, E = 3e-3, 2e-4, 2e6
EI = E * math.pi * R**4 / 4.0


@pytest.fixture(scope="module")
def cylinder() -> mc.Setup:
    return mc.Setup.paper(height=L, base_radius=R, tip_radius=R, youngs_modulus=E)


@pytest.fixture(scope="module")
def tapered() -> mc.Setup:
    return mc.Setup.paper(height=L, base_radius=R, tip_radius=5e-5, youngs_modulus=E)


def _turn(phi: float) -> np.ndarray:
    c, s = math.cos(phi), math.sin(phi)
    return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])


@pytest.mark.parametrize("phi", [0.3, math.pi / 2, 2.0, math.pi, -0.7],
                         ids=["0.3", "pi/2", "2.0", "pi", "-0.7"])
def test_force_at_an_azimuth_is_the_x_z_shape_turned(tapered: mc.Setup, phi: float) -> None:
    flat = mc.bend(tapered, force=1e-4)
    turned = mc.bend(tapered, force=1e-4, azimuth=phi)
    assert isinstance(turned, mc.SpatialBentShape) and turned.plane == phi
    x0, _, z0 = flat.tip
    np.testing.assert_allclose(turned.tip, [math.cos(phi) * x0, math.sin(phi) * x0, z0],
                               rtol=0, atol=1e-18)
    np.testing.assert_allclose(turned.points[0], flat.points[0] @ _turn(phi).T, rtol=0,
                               atol=1e-18)
    assert turned.tip_angle == pytest.approx(flat.tip_angle, rel=1e-14)
    assert turned.deflection == pytest.approx(x0, rel=1e-14)
    assert turned.tip_azimuth == pytest.approx(math.remainder(phi, 2 * math.pi), abs=1e-14)
    assert turned.load.azimuth == phi and turned.load.force == 1e-4
    np.testing.assert_allclose(turned.load.vector, 1e-4 * np.array(
        [math.cos(phi), math.sin(phi), 0.0]), rtol=0, atol=1e-19)
    assert turned.residual == flat.residual and turned.nodes == flat.nodes


def test_the_x_z_plane_is_today_bit_for_bit(tapered: mc.Setup) -> None:
    today = mc.bend(tapered, force=1e-4)
    for again in (mc.bend(tapered, force=1e-4, azimuth=0.0),
                  mc.bend(tapered, force=(1e-4, 0.0, 0.0)),
                  mc.bend(tapered, force=np.array([1e-4, 0.0, 0.0]))):
        assert type(again) is mc.BentShape
        np.testing.assert_array_equal(again.points, today.points)
        np.testing.assert_array_equal(again.angles, today.angles)
        assert again.to_dict() == today.to_dict()
    # a vector in the x–z plane: today's signed direction
    tilted = mc.bend(tapered, force=(3e-5, 0.0, 4e-5))
    expected = mc.bend(tapered, force=5e-5, direction=math.atan2(3e-5, 4e-5))
    assert type(tilted) is mc.BentShape
    np.testing.assert_allclose(tilted.points, expected.points, rtol=0, atol=1e-18)
    backward = mc.bend(tapered, force=(-1e-4, 0.0, 0.0))
    assert type(backward) is mc.BentShape
    np.testing.assert_allclose(backward.tip, today.tip * [-1, 1, 1], rtol=1e-12)


def test_force_vector_at_an_azimuth(tapered: mc.Setup) -> None:
    phi = 1.1
    vec = 1e-4 * np.array([math.cos(phi), math.sin(phi), 0.0])
    shape = mc.bend(tapered, force=vec)
    reference = mc.bend(tapered, force=1e-4, azimuth=phi)
    assert isinstance(shape, mc.SpatialBentShape)
    np.testing.assert_allclose(shape.tip, reference.tip, rtol=1e-12, atol=1e-17)
    np.testing.assert_allclose(shape.load.vector, vec, rtol=1e-14, atol=1e-20)
    # a downward-slanted force: its own vertical plane, direction from +z past π/2
    down = np.array([4e-5, -3e-5, -2e-5])
    slanted = mc.bend(tapered, force=down)
    same = mc.bend(tapered, force=float(np.linalg.norm(down)),
                   direction=math.atan2(5e-5, -2e-5), azimuth=math.atan2(-3e-5, 4e-5))
    np.testing.assert_allclose(slanted.tip, same.tip, rtol=1e-12, atol=1e-17)
    doc = slanted.to_dict()
    np.testing.assert_allclose(doc["load"]["force_N"], down, rtol=1e-14)


def test_vertical_force_below_buckling_leaves_the_rod_straight(cylinder: mc.Setup) -> None:
    critical = buckling_load(cylinder)
    assert critical == pytest.approx(math.pi**2 * EI / (4 * L**2), rel=1e-10)  # Euler
    for fz in (0.9 * critical, -0.9 * critical, 0.0):
        shape = mc.bend(cylinder, force=(0.0, 0.0, -fz))
        np.testing.assert_allclose(shape.tip, [0.0, 0.0, L], rtol=0, atol=1e-15)
    assert buckling_load(cylinder, at=L / 2) == pytest.approx(
        math.pi**2 * EI / (4 * (L / 2) ** 2), rel=1e-8)


@pytest.mark.parametrize("ratio", [1.1, 2.0, 4.0])
def test_beyond_buckling_the_buckled_elastica(cylinder: mc.Setup, ratio: float) -> None:
    # Euler's post-buckled cantilever: √(P/EI) L = K(p), tip x/L = 2p/K, z/L = 2E/K − 1
    m = brentq(lambda m: ellipk(m) - 0.5 * math.pi * math.sqrt(ratio), 1e-14, 1 - 1e-15,
               xtol=1e-15)
    x, z = 2 * math.sqrt(m) / ellipk(m), 2 * ellipe(m) / ellipk(m) - 1
    force = ratio * buckling_load(cylinder)
    shape = mc.bend(cylinder, force=(0.0, 0.0, -force))
    assert type(shape) is mc.BentShape  # the default plane: x–z, tip toward +x
    np.testing.assert_allclose(shape.tip / L, [x, 0.0, z], rtol=0, atol=1e-9)
    # the plane at ``azimuth`` picks the branch
    turned = mc.bend(cylinder, force=(0.0, 0.0, -force), azimuth=2.5)
    np.testing.assert_allclose(turned.tip / L, [x * math.cos(2.5), x * math.sin(2.5), z],
                               rtol=0, atol=1e-9)


@pytest.mark.parametrize("phi", [0.4, -2.0])
def test_flow_from_any_azimuth(tapered: mc.Setup, phi: float) -> None:
    flow = mc.Flow.uniform(0.5)
    flat = mc.bend(tapered, flow=flow)
    shape = mc.bend(tapered, flow=mc.Flow.uniform(0.5, azimuth=phi))
    assert isinstance(shape, mc.SpatialBentShape) and shape.plane == phi
    np.testing.assert_allclose(shape.tip, _turn(phi) @ flat.tip, rtol=0, atol=1e-17)
    # a flow against the plane of a force: the planar solver, with the speed's sign
    both = mc.bend(tapered, force=2e-5, azimuth=phi, flow=mc.Flow.uniform(0.3,
                                                                          azimuth=phi + math.pi))
    flat_both = mc.bend(tapered, force=2e-5, flow=mc.Flow.uniform(-0.3))
    assert both.plane == phi
    np.testing.assert_allclose(both.tip, _turn(phi) @ flat_both.tip, rtol=0, atol=1e-17)


def test_flow_keeps_its_behaviour_at_azimuth_zero() -> None:
    flow = mc.Flow.uniform(0.2)
    assert flow.azimuth == 0.0 and flow == mc.Flow.uniform(0.2, azimuth=0.0)
    assert flow.describe() == "uniform flow of water, 0.2 m/s"
    np.testing.assert_array_equal(flow.velocity(np.array([0.0, 1e-3])), [0.2, 0.2])
    np.testing.assert_array_equal(flow.direction, [1.0, 0.0, 0.0])
    turned = flow.with_azimuth(math.pi / 2)
    assert "toward azimuth 90 deg" in turned.describe()
    np.testing.assert_allclose(turned.direction, [0.0, 1.0, 0.0], atol=1e-16)
    shear = mc.Flow.shear(rate=100.0, azimuth=0.5)
    assert shear.azimuth == 0.5 and shear.kind == "shear"
    with pytest.raises(mc.MagciliaError, match="azimuth must be a finite number"):
        mc.Flow.uniform(0.2, azimuth=float("nan"))


def test_force_and_flow_from_different_azimuths_leave_the_plane(tapered: mc.Setup) -> None:
    flow = mc.Flow.uniform(0.5, azimuth=math.pi / 2)  # along +y
    shape = mc.bend(tapered, force=3e-5, flow=flow)  # force along +x
    assert isinstance(shape, mc.SpatialBentShape) and shape.plane is None
    assert shape.tip[0] > 0.0 and shape.tip[1] > 0.0
    # each alone, in the linear regime, adds up
    fx = mc.bend(tapered, force=3e-7).tip[0]
    uy = mc.bend(tapered, flow=mc.Flow.uniform(0.05, azimuth=math.pi / 2)).tip[1]
    small = mc.bend(tapered, force=3e-7, flow=mc.Flow.uniform(0.05, azimuth=math.pi / 2))
    np.testing.assert_allclose(small.tip[:2], [fx, uy], rtol=2e-3)
    # the 3-D rod on its own gives the same shape
    again = bend_3d(tapered, force=3e-5, flow=flow)
    np.testing.assert_allclose(again.tip, shape.tip, rtol=0, atol=1e-15)


def test_sweep_at_an_azimuth(tapered: mc.Setup) -> None:
    forces = np.linspace(0.0, 1e-4, 5)
    flat = mc.bend_sweep(tapered, forces)
    assert type(flat) is mc.Centreline
    same = mc.bend_sweep(tapered, forces, azimuth=0.0)
    np.testing.assert_array_equal(same.points, flat.points)
    turned = mc.bend_sweep(tapered, forces, azimuth=0.8)
    assert isinstance(turned, mc.SpatialCentreline)
    np.testing.assert_allclose(turned.points, flat.points @ _turn(0.8).T, rtol=0, atol=1e-18)
    speeds = np.linspace(0.1, 0.5, 3)
    flow = mc.Flow.uniform(1.0, azimuth=-1.0)
    swept = mc.bend_sweep(tapered, speeds=speeds, flow=flow)
    reference = mc.bend_sweep(tapered, speeds=speeds, flow=mc.Flow.uniform(1.0))
    np.testing.assert_allclose(swept.points, reference.points @ _turn(-1.0).T, rtol=0,
                               atol=1e-18)
    with pytest.raises(mc.MagciliaError, match="azimuth must be 0 or the swept flow's"):
        mc.bend_sweep(tapered, speeds=speeds, flow=flow, azimuth=0.5)


def test_output_at_a_flow_azimuth_uses_the_turned_model(tapered: mc.Setup) -> None:
    from magcilia.mechanics import output_at

    speeds = np.array([0.1, 0.3])
    flow = mc.Flow.uniform(1.0, azimuth=0.6)
    shapes = mc.bend_sweep(tapered, speeds=speeds, flow=mc.Flow.uniform(1.0))
    np.testing.assert_allclose(output_at(tapered, "flow", speeds, flow),
                               tapered.output(shapes, azimuth=0.6), rtol=1e-13)


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        ({"force": (1e-4, 0.0)}, "force must be three numbers"),
        ({"force": (1e-4, 0.0, float("nan"))}, "force must be finite"),
        ({"force": (1e-4, 1e-4, 0.0), "direction": 0.3}, "direction must be left at its default"),
        ({"force": (1e-4, 1e-4, 0.0), "azimuth": 0.3}, "azimuth must be 0 with a horizontal"),
        ({"force": 1e-4, "azimuth": float("inf")}, "azimuth must be a finite number"),
        ({"force": 1e-4, "azimuth": "east"}, "azimuth must be a finite number"),
        ({"force": 1e-4, "actuation": (0.0, 0.0, 1e-3)}, "actuation must be a magcilia Actuation"),
        ({"force": 1e-4, "at": 2 * L, "azimuth": 1.0}, "at must be an arc length"),
    ],
    ids=["short-vector", "nan-vector", "direction-with-vector", "azimuth-with-vector",
         "inf-azimuth", "text-azimuth", "actuation-not-an-Actuation", "at-beyond-tip"],
)
def test_bad_input(tapered: mc.Setup, kwargs: dict[str, object], match: str) -> None:
    with pytest.raises(mc.MagciliaError, match=match) as info:
        mc.bend(tapered, **kwargs)  # type: ignore[arg-type]
    assert "\n" not in str(info.value)


def test_a_force_vector_on_a_sharp_cone_needs_a_tip_radius() -> None:
    with pytest.raises(mc.MagciliaError, match="tip compliance is infinite"):
        mc.bend(mc.Setup.paper(), force=(1e-5, 1e-5, 0.0))
