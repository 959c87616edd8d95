"""Magnetic actuation: the Actuation field object, and the cilium bent by the field's couple and
force (closed forms for a uniform rod, the pole equivalence, a magpylib source)."""

from __future__ import annotations

import math

import magpylib
import numpy as np
import pytest

import magcilia as mc
from magcilia.mechanics import bend_3d, buckling_load, elastica, flip_field, uniform_field_tip

L, R, E = 3e-3, 2e-4, 2e6
EI = E * math.pi * R**4 / 4.0


@pytest.fixture(scope="module")
def cylinder() -> mc.Setup:
    return mc.Setup.paper(height=L, base_radius=R, tip_radius=R, youngs_modulus=E)


def _mu(setup: mc.Setup) -> float:
    """Moment per length of a uniform cilium, A·m."""
    return setup.spec.magnetization * math.pi * R**2


def _kappa_field(setup: mc.Setup, kappa: float) -> float:
    """The field (T) with μ B L² / EI = kappa."""
    return kappa * EI / (_mu(setup) * L**2)


# -- the Actuation object ---------------------------------------------------------------------

def test_uniform_field_is_its_vector_everywhere() -> None:
    b = np.array([1e-3, -2e-3, 5e-3])
    act = mc.Actuation.uniform(b)
    rng = np.random.default_rng(0)
    for shape in [(3,), (7, 3), (2, 4, 3)]:
        pts = rng.normal(scale=1e-2, size=shape)
        np.testing.assert_array_equal(act.field(pts), np.broadcast_to(b, shape))
        np.testing.assert_array_equal(act.gradient(pts), np.zeros((*shape, 3)))
    np.testing.assert_array_equal(act.scaled(-2.5).field(np.zeros(3)), -2.5 * b)
    assert act.scaled(2.0).scaled(0.5).scale == 1.0 and act.is_uniform
    doc = act.scaled(2.0).to_dict()
    assert doc == {"kind": "uniform", "scale": 2.0, "field_T": (2 * b).tolist()}
    assert "mT" in act.report() and repr(act).startswith("Actuation(uniform")
    b[0] = 7.0  # the caller's array stays theirs (copied, not frozen)
    assert act.field(np.zeros(3))[0] == 1e-3


def _magnet() -> magpylib.magnet.Cuboid:
    return magpylib.magnet.Cuboid(polarization=(0.2, 0.0, 1.0), dimension=(2e-3, 2e-3, 1e-3),
                                  position=(6e-3, 1e-3, 1e-3))


def test_a_magpylib_source_gives_magpylib_s_field() -> None:
    magnet = _magnet()
    coil = magpylib.current.Circle(current=2.0, diameter=8e-3, position=(0.0, 0.0, -2e-3))
    rng = np.random.default_rng(1)
    pts = rng.uniform(-3e-3, 3e-3, size=(4, 5, 3)) + [0.0, 0.0, 4e-3]
    act = mc.Actuation.magpylib(magnet)
    np.testing.assert_array_equal(act.field(pts), magpylib.getB(magnet, pts))
    np.testing.assert_allclose(act.scaled(3.0).field(pts), 3.0 * magpylib.getB(magnet, pts),
                               rtol=1e-15)
    both = mc.Actuation.magpylib([magnet, coil], scale=0.5)
    np.testing.assert_allclose(both.field(pts), 0.5 * (magpylib.getB(magnet, pts)
                                                       + magpylib.getB(coil, pts)), rtol=1e-13)
    collection = mc.Actuation.magpylib(magpylib.Collection(magnet, coil))
    np.testing.assert_allclose(collection.field(pts), 2.0 * both.field(pts), rtol=1e-15)
    one = act.field(pts[0, 0])
    assert one.shape == (3,)
    assert act.to_dict()["kind"] == "magpylib" and "Cuboid at (6, 1, 1) mm" in act.report()


def test_a_source_s_gradient_is_curl_and_divergence_free_and_matches_wider_differences() -> None:
    act = mc.Actuation.magpylib(_magnet())
    pts = np.array([[0.0, 0.0, 3e-3], [1e-3, 2e-3, 4e-3], [2e-3, -1e-3, 2e-3]])
    g = act.gradient(pts)
    scale = np.abs(g).max()
    np.testing.assert_allclose(np.trace(g, axis1=-2, axis2=-1), 0.0, atol=1e-8 * scale)
    np.testing.assert_allclose(g, np.swapaxes(g, -1, -2), atol=1e-8 * scale)
    wide = mc.Actuation.magpylib(_magnet(), step=1e-6).gradient(pts)  # truncation ~ 1e-7
    np.testing.assert_allclose(g, wide, atol=1e-6 * scale)
    d = np.array([0.3, -0.2, 0.9])
    np.testing.assert_allclose(act.directional(pts, np.broadcast_to(d, pts.shape)), g @ d,
                               atol=1e-8 * scale)


@pytest.mark.parametrize(
    ("make", "match"),
    [
        (lambda: mc.Actuation.uniform((0.0, 0.0, float("nan"))), "field must be finite"),
        (lambda: mc.Actuation.uniform((0.0, math.inf, 0.0)), "field must be finite"),
        (lambda: mc.Actuation.uniform((0.0, 1e-3)), "field must be three numbers"),
        (lambda: mc.Actuation.uniform((0.0, 0.0, 1e-3)).scaled(float("nan")),
         "k must be a finite number"),
        (lambda: mc.Actuation.magpylib("magnet"), "source must be a magpylib source"),
        (lambda: mc.Actuation.magpylib(magpylib.Sensor()), "source must be a magpylib source"),
        (lambda: mc.Actuation.magpylib([]), "source must be a magpylib source"),
        (lambda: mc.Actuation.magpylib(magpylib.misc.Dipole(
            moment=(0, 0, 1e-3), position=[(0, 0, 0), (0, 0, 1e-3)])), "path length 1"),
        (mc.Actuation, "built with Actuation.uniform"),
        (lambda: mc.Actuation.uniform((0.0, 0.0, 1e-3)).field([1.0, 2.0]),
         "points must be positions of shape"),
    ],
    ids=["nan-field", "inf-field", "two-components", "nan-scale", "text-source", "sensor",
         "empty-list", "moving-source", "nothing", "bad-points"],
)
def test_bad_actuation(make: object, match: str) -> None:
    with pytest.raises(mc.MagciliaError, match=match) as info:
        make()  # type: ignore[operator]
    assert "\n" not in str(info.value)


# -- closed forms -----------------------------------------------------------------------------

def test_small_deflection_matches_the_closed_form(cylinder: mc.Setup) -> None:
    # θ(L) = μBL²/(2EI), δ = μBL³/(3EI): the moment at s is ∫ₛᴸ μB cos θ dσ ≈ μB (L − s)
    b = _kappa_field(cylinder, 1e-3)
    shape = mc.bend(cylinder, actuation=mc.Actuation.uniform((b, 0.0, 0.0)))
    mu = _mu(cylinder)
    assert type(shape) is mc.BentShape
    assert shape.deflection == pytest.approx(mu * b * L**3 / (3 * EI), rel=1e-3)
    assert shape.tip_angle == pytest.approx(mu * b * L**2 / (2 * EI), rel=1e-3)
    x, _, theta = uniform_field_tip(1e-3, linear=True)
    assert shape.deflection / L == pytest.approx(x, rel=1e-3)
    assert shape.tip_angle == pytest.approx(theta, rel=1e-3)


@pytest.mark.parametrize("kappa", [1.1, 2.0, 3.0, 4.5])
def test_large_deflection_matches_the_exact_elastica(cylinder: mc.Setup, kappa: float) -> None:
    x, z, theta = uniform_field_tip(kappa)
    assert 0.5 <= theta <= 1.2
    b = _kappa_field(cylinder, kappa)
    shape = mc.bend(cylinder, actuation=mc.Actuation.uniform((b, 0.0, 0.0)))
    np.testing.assert_allclose(shape.tip / L, [x, 0.0, z], rtol=0, atol=1e-6)
    assert shape.tip_angle == pytest.approx(theta, abs=1e-6)


@pytest.mark.parametrize("kappa", [0.05, 0.3, 1.0, 2.5, 8.0])
def test_uniform_field_quadrature_equals_the_tip_force_elastica(kappa: float) -> None:
    # the magnetic poles: μB on the tip pole is Bisshopp & Drucker's tip load α = κ (whose
    # x = 1 − (2/√α)(E − E) loses digits at small α: compared from 0.05 on)
    np.testing.assert_allclose(uniform_field_tip(kappa), mc.mechanics.cantilever_tip(kappa),
                               rtol=1e-11, atol=1e-14)


def test_field_and_force_add_as_the_tip_pole(cylinder: mc.Setup) -> None:
    # a uniform rod: the field's loads are a dead tip force μB (the base pole's goes to the clamp)
    mu = _mu(cylinder)
    b = np.array([0.6, 0.0, -0.3]) * _kappa_field(cylinder, 1.0)
    f = np.array([1.0, 0.0, 0.2]) * EI / L**2
    with_field = mc.bend(cylinder, force=tuple(f), actuation=mc.Actuation.uniform(b))
    poles = mc.bend(cylinder, force=tuple(f + mu * b))
    np.testing.assert_allclose(with_field.points, poles.points, rtol=0, atol=1e-12 * L)
    # out of the plane of the force: the 3-D rod, and the same equivalence
    b3 = np.array([0.0, 0.8, 0.1]) * _kappa_field(cylinder, 1.0)
    across = mc.bend(cylinder, force=tuple(f), actuation=mc.Actuation.uniform(b3))
    assert isinstance(across, mc.SpatialBentShape) and across.plane is None
    reference = mc.bend(cylinder, force=tuple(f + mu * b3))  # in a plane: the planar solver
    np.testing.assert_allclose(across.points, reference.points, rtol=0, atol=1e-10 * L)


def test_a_field_turns_the_cilium_toward_it_never_past(cylinder: mc.Setup) -> None:
    strong = 10 * _kappa_field(cylinder, 1.0)
    for beta in (0.4, 1.2, 2.5):
        b = strong * np.array([math.sin(beta), 0.0, math.cos(beta)])
        shape = mc.bend(cylinder, actuation=mc.Actuation.uniform(b))
        assert np.all(shape.angles >= -1e-12) and np.all(shape.angles <= beta + 1e-9)
        assert shape.tip_angle > 0.9 * beta
    toward_y = mc.bend(cylinder, actuation=mc.Actuation.uniform((0.0, strong, 0.0)))
    assert isinstance(toward_y, mc.SpatialBentShape)
    assert toward_y.plane == pytest.approx(math.pi / 2)
    assert toward_y.tip[1] > 0.5 * L and abs(toward_y.tip[0]) < 1e-15
    along = mc.bend(cylinder, actuation=mc.Actuation.uniform((0.0, 0.0, strong)))
    np.testing.assert_allclose(along.tip, [0.0, 0.0, L], rtol=0, atol=1e-15)


def test_a_field_against_the_magnetization_flips_the_cilium(cylinder: mc.Setup) -> None:
    critical = flip_field(cylinder)
    mu = _mu(cylinder)
    assert critical == pytest.approx(math.pi**2 * EI / (4 * mu * L**2), rel=1e-10)
    assert critical == pytest.approx(buckling_load(cylinder) / mu, rel=1e-10)
    below = mc.bend(cylinder, actuation=mc.Actuation.uniform((0.0, 0.0, -0.9 * critical)))
    np.testing.assert_allclose(below.tip, [0.0, 0.0, L], rtol=0, atol=1e-15)
    flipped = mc.bend(cylinder, actuation=mc.Actuation.uniform((0.0, 0.0, -4.0 * critical)))
    buckled = mc.bend(cylinder, force=(0.0, 0.0, -4.0 * critical * mu))  # the tip pole
    np.testing.assert_allclose(flipped.tip, buckled.tip, rtol=0, atol=1e-9 * L)
    assert flipped.tip[2] < 0.0 and flipped.tip_angle > 0.5 * math.pi
    unmagnetized = mc.Setup.paper(height=L, base_radius=R, tip_radius=R, youngs_modulus=E,
                                  magnetization_scale=0.0)
    assert flip_field(unmagnetized) == math.inf


def test_a_tapered_cilium_s_field_load_in_plane_and_across(cylinder: mc.Setup) -> None:
    tapered = mc.Setup.paper(height=L, base_radius=R, tip_radius=5e-5, youngs_modulus=E)
    b = _kappa_field(cylinder, 1.0)
    for phi in (0.0, 0.9, -2.2):
        act = mc.Actuation.uniform(b * np.array([math.cos(phi), math.sin(phi), 0.3]))
        planar = mc.bend(tapered, actuation=act)
        rod = bend_3d(tapered, actuation=act)
        assert (planar.plane if isinstance(planar, mc.SpatialBentShape) else 0.0) \
            == pytest.approx(phi)
        np.testing.assert_allclose(rod.tip, planar.tip, rtol=0, atol=1e-8 * L)
        assert planar.tip[:2] @ [math.cos(phi), math.sin(phi)] > 0.1 * L


# -- a magpylib source: its field along the cilium --------------------------------------------

def test_a_source_s_field_is_taken_where_the_cilium_is(cylinder: mc.Setup) -> None:
    magnet = magpylib.magnet.Cuboid(polarization=(0.0, 0.0, 1.0), dimension=(2e-3, 2e-3, 2e-3),
                                    position=(7e-3, 0.0, 2e-3))
    shape = mc.bend(cylinder, actuation=mc.Actuation.magpylib(magnet))
    assert isinstance(shape, mc.SpatialBentShape) and shape.plane is None
    # moving the cilium and the source together changes nothing
    shift = np.array([-1e-3, 2e-3, 0.5e-3])
    moved = cylinder.replace(position=tuple(np.asarray(cylinder.position) + shift))
    magnet2 = magpylib.magnet.Cuboid(polarization=(0.0, 0.0, 1.0), dimension=(2e-3, 2e-3, 2e-3),
                                     position=(7e-3, 0.0, 2e-3) + shift)
    again = mc.bend(moved, actuation=mc.Actuation.magpylib(magnet2))
    np.testing.assert_allclose(again.points, shape.points, rtol=0, atol=1e-8 * L)
    # the field varies along the cilium: a uniform field equal to the base's bends it otherwise
    base = mc.Actuation.magpylib(magnet).field(cylinder.base_centre)
    uniform = mc.bend(cylinder, actuation=mc.Actuation.uniform(base))
    assert np.linalg.norm(uniform.tip - shape.tip) > 0.01 * L


def test_a_symmetric_source_keeps_the_cilium_in_its_plane(cylinder: mc.Setup) -> None:
    x, y, z = cylinder.base_centre
    magnet = magpylib.magnet.Cylinder(polarization=(0.3, 0.0, -0.8), dimension=(3e-3, 2e-3),
                                      position=(x + 6e-3, y, z + 2e-3))
    shape = mc.bend(cylinder, actuation=mc.Actuation.magpylib(magnet))
    assert abs(shape.tip[1]) < 1e-9 * L and abs(shape.tip[0]) > 1e-3 * L


def test_non_converging_field_reports_the_largest_converged_scale(
        cylinder: mc.Setup, monkeypatch: pytest.MonkeyPatch) -> None:
    real = elastica.newton

    def failing(problem: elastica.Problem, scale: float, guess: np.ndarray,
                **kw: float) -> elastica.Solution | None:
        assert problem.couple is not None
        if np.abs(problem.couple).max() > 0.3 * _mu(cylinder) * _kappa_field(cylinder, 1.0):
            return None
        return real(problem, scale, guess, **kw)

    monkeypatch.setattr(elastica, "newton", failing)
    act = mc.Actuation.uniform((_kappa_field(cylinder, 1.0), 0.0, 0.0))
    with pytest.raises(mc.MagciliaError, match="actuation must be a field the elastica solver "
                       r"converges for .* beyond 0\.[0-9]+ of the given loads") as info:
        mc.bend(cylinder, actuation=act)
    reached = float(str(info.value).split("beyond ")[1].split(" of")[0])
    assert 0.29 <= reached <= 0.3 * (1 + 1e-5)
    assert "mT" in str(info.value) and "\n" not in str(info.value)


def test_a_field_that_is_not_finite_at_the_cilium(cylinder: mc.Setup) -> None:
    def nan_above(field: str, observers: np.ndarray) -> np.ndarray:
        out = np.zeros(observers.shape)
        out[..., 0] = np.where(observers[..., 2] > cylinder.base_centre[2] + 1e-3, np.nan, 1e-3)
        return out

    source = magpylib.misc.CustomSource(field_func=nan_above)
    with pytest.raises(mc.MagciliaError, match=r"actuation must be finite along the cilium") \
            as info:
        mc.bend(cylinder, actuation=mc.Actuation.magpylib(source))
    assert "mm" in str(info.value) and "\n" not in str(info.value)


def test_a_sharp_cone_needs_a_tip_radius_for_a_field() -> None:
    with pytest.raises(mc.MagciliaError, match="tip_radius must be positive for a magnetic field"):
        mc.bend(mc.Setup.paper(), actuation=mc.Actuation.uniform((5e-3, 0.0, 0.0)))
    # with one, the paper's cilium (0.669 MPa) in a 5 mT coil field bends by tens of degrees,
    # converged; the bending depends on the field only through μB/E: a field 5× weaker on a
    # hair 5× softer bends it the same
    setup = mc.Setup.paper(tip_radius=5e-5)
    act = mc.Actuation.uniform((5e-3, 0.0, 0.0))
    shape = mc.bend(setup, actuation=act)
    finer = mc.bend(setup, actuation=act, nodes=80)
    assert 0.3 < shape.tip_angle < 1.0
    stiffer = mc.bend(setup.replace(youngs_modulus=5 * setup.youngs_modulus),
                      actuation=mc.Actuation.uniform((2.5e-2, 0.0, 0.0)))
    assert stiffer.tip_angle == pytest.approx(shape.tip_angle, rel=1e-9)
    assert np.linalg.norm(finer.tip - shape.tip) <= 1e-9 * setup.cilium.height


def test_sweep_while_actuating_stacks_single_bends() -> None:
    setup = mc.Setup.paper(tip_radius=5e-5)
    coil = mc.Actuation.uniform((5e-3, 0.0, 0.0))
    forces = np.linspace(0.0, 1e-4, 4)
    flat = mc.bend_sweep(setup, forces, actuation=coil)
    assert type(flat) is mc.Centreline
    for row, f in enumerate(forces):
        np.testing.assert_array_equal(flat.points[row], mc.bend(setup, f, actuation=coil).points[0])
    across = mc.bend_sweep(setup, forces, azimuth=1.0, actuation=coil)  # force and field: 3-D
    assert isinstance(across, mc.SpatialCentreline) and len(across) == forces.size
    np.testing.assert_allclose(across.points[1], mc.bend(setup, forces[1], azimuth=1.0,
                                                         actuation=coil).points[0], rtol=0,
                               atol=1e-15)
    np.testing.assert_allclose(across.points[0], flat.points[0], rtol=0, atol=1e-18)
    speeds = mc.bend_sweep(setup, speeds=[0.0, 0.2], flow=mc.Flow.uniform(1.0, azimuth=0.5),
                           actuation=coil)
    assert speeds.tip[1, 1] > 0.0 and speeds.tip[0, 1] == 0.0
    with pytest.raises(mc.MagciliaError, match="flow must be a Flow when sweeping speeds"):
        mc.bend_sweep(setup, speeds=[0.1], actuation=coil)
