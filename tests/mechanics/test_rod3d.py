"""The 3-D rod solver: equal to the planar solver on loads in one plane (any azimuth), and on
loads that leave every plane: unit tangents, no twist, moment balance of the shape it returns
(checked by an independent quadrature of all loads), convergence in the nodes."""

from __future__ import annotations

import math

import magpylib
import numpy as np
import pytest

import magcilia as mc
from magcilia.mechanics import bend_3d
from magcilia.mechanics.planar import _static
from magcilia.mechanics.rod import Rod, RodLoads, RodProblem

L, R, E = 3e-3, 2e-4, 2e6
EI0 = E * math.pi * R**4 / 4.0


@pytest.fixture(scope="module")
def tapered() -> mc.Setup:
    return mc.Setup.paper(height=L, base_radius=R, tip_radius=5e-5, youngs_modulus=E)


def _b1(setup: mc.Setup) -> float:
    """Field (T) with μ₀ B L² / EI₀ = 1 at the base section."""
    return EI0 / (setup.spec.magnetization * math.pi * R**2 * L**2)


def _cases(setup: mc.Setup, phi: float) -> dict[str, dict[str, object]]:
    e = np.array([math.cos(phi), math.sin(phi), 0.0])
    f = EI0 / L**2
    b = _b1(setup)
    return {
        "force": {"force": 1.5 * f, "azimuth": phi},
        "slanted-force-below-tip": {"force": tuple(0.8 * f * e + [0.0, 0.0, -0.3 * f]),
                                    "at": 0.6 * L},
        "field": {"actuation": mc.Actuation.uniform(b * (1.2 * e + [0.0, 0.0, -0.4]))},
        "force-and-field": {"force": tuple(0.5 * f * e),
                            "actuation": mc.Actuation.uniform(-0.7 * b * e)},
        "flow": {"flow": mc.Flow.uniform(0.4, azimuth=phi)},
    }


@pytest.mark.parametrize("phi", [0.0, 0.7, -2.4])
@pytest.mark.parametrize("case", ["force", "slanted-force-below-tip", "field", "force-and-field",
                                  "flow"])
def test_in_plane_loads_equal_the_planar_solver(tapered: mc.Setup, phi: float,
                                                case: str) -> None:
    kwargs = _cases(tapered, phi)[case]
    planar = mc.bend(tapered, **kwargs)  # type: ignore[arg-type]
    rod = bend_3d(tapered, **kwargs)  # type: ignore[arg-type]
    assert rod.plane is None and rod.nodes == planar.nodes
    scale = float(np.linalg.norm(planar.tip))
    assert np.linalg.norm(rod.tip - planar.tip) <= 1e-8 * scale
    assert np.abs(rod.points - planar.points).max() <= 1e-8 * L
    spatial = planar if isinstance(planar, mc.SpatialBentShape) else \
        mc.SpatialCentreline.from_planar(planar, 0.0)
    np.testing.assert_allclose(rod.tangents, spatial.tangents, rtol=0, atol=1e-8)


def _state(setup: mc.Setup, shape: mc.SpatialBentShape,
           loads: RodLoads) -> tuple[Rod, np.ndarray]:
    """The rod and the converged nodal tangents, re-solved (to read the solver's internals)."""
    from magcilia.mechanics.drag import free_log
    from magcilia.mechanics.elastica import solve
    from magcilia.mechanics.rod import linear_guess, straight
    from magcilia.mechanics.spatial import _moment_per_length

    c = setup.cilium
    static = _static(c, setup.youngs_modulus, c.height, bool(np.any(loads.force)), None)
    grid, ei, d, loaded = static.grid, static.ei, static.diameter, static.loaded
    rod = Rod(grid, ei, d, loaded, _moment_per_length(setup, grid.s), setup.base_centre,
              free_log(grid.s, 0.5 * d, c.height))
    start = straight(rod)
    sol = solve(lambda lam: (RodProblem(rod, loads, lam), 1.0), 0.0, 1.0, start.ravel(),
                (linear_guess(rod, loads) - start).ravel(), tol=1e-9)[0]
    return rod, sol.theta.reshape(-1, 3)


def _moment_balance(setup: mc.Setup, shape: mc.SpatialBentShape, act: mc.Actuation,
                    force: np.ndarray, magnetic_force: bool = True) -> tuple[float, float]:
    """Largest mismatch, relative to the largest moment, between EI t × t' of the returned shape
    and the moment of all loads beyond each section (Simpson on the output grid; the field and
    its gradient evaluated afresh by the Actuation), and the largest twist M·t (same scale)."""
    s, p, t = shape.s, shape.points[0], shape.tangents[0]
    board = setup.base_centre + p
    mu = setup.spec.magnetization * math.pi * setup.cilium.radius(s) ** 2
    b = act.field(board)
    couple = mu[:, None] * np.cross(t, b)
    f = mu[:, None] * np.einsum("mij,mj->mi", act.gradient(board), t) if magnetic_force \
        else np.zeros_like(p)
    ei = setup.youngs_modulus * setup.cilium.second_moment(s)
    dt = np.gradient(t, s, axis=0, edge_order=2)
    inner = ei[:, None] * np.cross(t, dt)
    worst, twist = 0.0, 0.0
    moments = []
    for q in range(0, s.size - 1, 8):  # even number of intervals to the tip: Simpson
        arm = p[q:] - p[q]
        integrand = np.cross(arm, f[q:]) + couple[q:]
        h = s[1] - s[0]
        w = np.ones(integrand.shape[0])
        w[1:-1:2], w[2:-1:2] = 4.0, 2.0
        m = h / 3.0 * (w @ integrand) + np.cross(p[-1] - p[q], force)
        moments.append((q, m))
    top = max(float(np.linalg.norm(m)) for _, m in moments)
    for q, m in moments:
        worst = max(worst, float(np.linalg.norm(m - inner[q])) / top)
        twist = max(twist, abs(float(m @ t[q])) / top)
    return worst, twist


def test_loads_across_planes_keep_unit_tangents_and_no_twist(tapered: mc.Setup) -> None:
    f = np.array([1.0, 0.0, 0.0]) * EI0 / L**2
    act = mc.Actuation.uniform((0.0, 1.5 * _b1(tapered), 0.3 * _b1(tapered)))
    shape = mc.bend(tapered, force=tuple(f), actuation=act)
    assert isinstance(shape, mc.SpatialBentShape) and shape.plane is None
    assert shape.tip[0] > 0.05 * L and shape.tip[1] > 0.05 * L
    rod, tangents = _state(tapered, shape, RodLoads(f, uniform=act.uniform_field))
    np.testing.assert_allclose(np.linalg.norm(tangents, axis=1), 1.0, rtol=0, atol=1e-10)
    state = RodProblem(rod, RodLoads(f, uniform=act.uniform_field), 1.0).parts(tangents[None])
    twist = np.abs(np.einsum("ni,ni->n", state.moment[0], tangents)).max()
    assert twist <= 1e-10 * np.abs(state.moment).max()
    worst, twist_out = _moment_balance(tapered, shape, act, f)
    assert worst < 2e-4 and twist_out < 1e-6
    # the normals: unit, perpendicular, starting along the base's bending direction
    e1 = shape.normals[0]
    np.testing.assert_allclose(np.linalg.norm(e1, axis=1), 1.0, atol=1e-12)
    np.testing.assert_allclose(np.einsum("mi,mi->m", e1, shape.tangents[0]), 0.0, atol=1e-12)
    assert e1[0, 2] == 0.0 and e1[0, :2] @ shape.tip[:2] > 0.0


def test_loads_across_planes_converge_in_the_nodes(tapered: mc.Setup) -> None:
    act = mc.Actuation.uniform((0.0, 1.5 * _b1(tapered), 0.0))
    kwargs = {"force": (EI0 / L**2, 0.0, 0.0), "actuation": act}
    default = mc.bend(tapered, **kwargs)  # type: ignore[arg-type]
    finer = mc.bend(tapered, nodes=96, **kwargs)  # type: ignore[arg-type]
    coarse = mc.bend(tapered, nodes=12, **kwargs)  # type: ignore[arg-type]
    assert np.linalg.norm(finer.tip - default.tip) <= 1e-9 * L
    assert np.linalg.norm(coarse.tip - default.tip) > 1e-9 * L  # the check can see an error


def test_a_mirrored_field_mirrors_the_shape(tapered: mc.Setup) -> None:
    f = (EI0 / L**2, 0.0, 0.0)
    b = 1.5 * _b1(tapered)
    up = mc.bend(tapered, force=f, actuation=mc.Actuation.uniform((0.0, b, 0.0)))
    down = mc.bend(tapered, force=f, actuation=mc.Actuation.uniform((0.0, -b, 0.0)))
    np.testing.assert_allclose(down.points, up.points * [1, -1, 1], rtol=0, atol=1e-14 * L)


def test_a_source_s_gradient_force_balances_the_shape() -> None:
    # a uniform rod near a magnet: the magnetic force μ (t·∇)B matters, and the shape balances
    # the moment of couple and force, evaluated afresh along the returned shape
    setup = mc.Setup.paper(height=L, base_radius=R, tip_radius=R, youngs_modulus=E)
    x, y, z = setup.base_centre
    magnet = magpylib.magnet.Cuboid(polarization=(0.0, 0.4, 1.0), dimension=(2e-3, 2e-3, 2e-3),
                                    position=(x + 4.5e-3, y - 1.5e-3, z + 2.5e-3))
    act = mc.Actuation.magpylib(magnet)
    shape = mc.bend(setup, actuation=act)
    assert isinstance(shape, mc.SpatialBentShape) and shape.plane is None
    assert shape.deflection > 0.02 * L and shape.residual < 1e-9
    worst, twist = _moment_balance(setup, shape, act, np.zeros(3))
    without_force, _ = _moment_balance(setup, shape, act, np.zeros(3), magnetic_force=False)
    assert worst < 2e-4 and twist < 1e-5
    assert without_force > 20 * worst  # the gradient force is part of the balance
    np.testing.assert_allclose(np.linalg.norm(shape.tangents[0], axis=1), 1.0, atol=1e-12)
