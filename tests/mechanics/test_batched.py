"""The batched planar bends (:mod:`magcilia.mechanics.batched`): every set and load as
``bend_sweep`` gives it (the reference: the sweep one set at a time, itself checked against the
exact elastica in test_elastica.py), for tip forces and flows, frustums of different tapers and a
measured profile, loads of both signs; the fall-back to the sweep; the flow's analytic Jacobian
against central differences of the residual."""

from __future__ import annotations

import numpy as np
import pytest

import magcilia as mc
import magcilia.mechanics.batched as batched
from magcilia.mechanics.batched import sweep_batch
from magcilia.mechanics.planar import OUTPUT_POINTS, _sweep_plane

BASE = mc.Setup.paper(ring="rms", tip_radius=5e-5, youngs_modulus=0.5e6)
FORCES = np.linspace(0.0, 2e-5, 9)  # N: tip deflections up to half the length
SPEEDS = np.linspace(0.0, 0.3, 7)  # m/s of water
WATER = mc.Flow.uniform(0.3, mc.WATER)


def _sets(n: int, seed: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    rng = np.random.default_rng(seed)
    return (rng.uniform(2.6e-3, 3.8e-3, n), rng.uniform(1.2e-4, 2.4e-4, n),
            np.exp(rng.uniform(np.log(2e5), np.log(3e6), n)))


def _reference(base: mc.Setup, sets: tuple, loads: np.ndarray, flow: mc.Flow | None) -> list:
    out = []
    for h, r, e in zip(*sets, strict=True):
        s = base.replace(height=float(h), base_radius=float(r), youngs_modulus=float(e))
        out.append(_sweep_plane(s, forces=loads) if flow is None
                   else _sweep_plane(s, speeds=loads, flow=flow))
    return out


def _check(shapes: batched.BatchShapes, ref: list, heights: np.ndarray) -> None:
    assert shapes.ok.all()
    for i, r in enumerate(ref):
        np.testing.assert_allclose(shapes.s[i], r.s, rtol=1e-14, atol=0.0)
        np.testing.assert_allclose(shapes.angles[i], r.angles, rtol=0.0, atol=1e-10)
        np.testing.assert_allclose(shapes.points[i], r.points, rtol=0.0,
                                   atol=1e-10 * heights[i])


@pytest.mark.parametrize(("loads", "flow"), [(FORCES, None), (SPEEDS, WATER),
                                             (np.array([-2e-5, -5e-6, 0.0, 1e-5]), None)],
                         ids=["forces", "flow", "both signs"])
def test_batch_is_the_sweep_of_each_set(loads: np.ndarray, flow: mc.Flow | None) -> None:
    sets = _sets(6, 1)
    shapes = sweep_batch(BASE, *sets, loads, flow=flow)
    assert shapes.angles.shape == (6, loads.size, OUTPUT_POINTS)
    assert shapes.swept == 0  # every system converged from its start
    _check(shapes, _reference(BASE, sets, loads, flow), sets[0])
    tips = shapes.points[:, :, -1, 0]
    assert np.all(np.sign(tips[:, loads != 0]) == np.sign(loads[loads != 0]))
    assert np.abs(tips).max() > 0.2 * sets[0].min()  # large deflections


def test_measured_profile() -> None:
    profile = mc.Cilium.from_profile([0.0, 1.2e-3, 3e-3], [2e-4, 1.5e-4, 6e-5],
                                     youngs_modulus=0.5e6)
    base = BASE.replace(cilium=profile)
    sets = _sets(3, 2)
    for loads, flow in ((FORCES[::2], None), (SPEEDS[::2], WATER)):
        _check(sweep_batch(base, *sets, loads, flow=flow),
               _reference(base, sets, loads, flow), sets[0])


def test_what_newton_does_not_reach_goes_to_the_sweep(monkeypatch: pytest.MonkeyPatch) -> None:
    sets = _sets(3, 3)
    monkeypatch.setattr(batched, "MAX_ITERATIONS", 1)  # no system converges in one step
    shapes = sweep_batch(BASE, *sets, FORCES, flow=None)
    assert shapes.swept == 3 * (FORCES.size - 1)
    _check(shapes, _reference(BASE, sets, FORCES, None), sets[0])


def test_a_set_the_sweep_fails_for_too_is_marked(monkeypatch: pytest.MonkeyPatch) -> None:
    sets = _sets(2, 5)

    def fails(*args: object, **kwargs: object) -> None:
        raise mc.MagciliaError("did not converge")

    monkeypatch.setattr(batched, "MAX_ITERATIONS", 1)
    monkeypatch.setattr(batched, "_sweep_plane", fails)
    shapes = sweep_batch(BASE, *sets, FORCES)
    assert not shapes.ok.any() and np.isnan(shapes.angles).all()


def test_flow_jacobian_is_the_derivative_of_the_residual() -> None:
    heights, radii, moduli = _sets(3, 4)
    norm = batched._Normalised(BASE.cilium.__class__(height=float(heights[0]),
                                                    base_radius=float(radii.min()),
                                                    tip_radius=5e-5), False)
    tapers = 5e-5 / radii
    rho, inertia = norm.shape(tapers)
    scale = heights**2 / (moduli * 0.25 * np.pi * radii**4)
    influence = (norm.C * (scale[:, None] / inertia)[:, None, :]) @ norm.R
    system = batched._Systems(norm, heights, radii, moduli, rho, inertia, influence, WATER)
    sets = np.arange(3)
    theta = 0.6 * np.sin(np.linspace(0.1, 1.4, norm.s.size))[None, :] * np.array([[1.0], [0.5],
                                                                                  [1.3]])
    speed = np.full(3, 0.2)
    _, parts = system.residual(sets, speed, theta)
    jac = system.jacobian(sets, speed, theta, parts)
    h = 1e-6
    for j in (0, norm.s.size // 2, norm.s.size - 1):
        dt = np.zeros_like(theta)
        dt[:, j] = h
        up = system.residual(sets, speed, theta + dt)[0]
        down = system.residual(sets, speed, theta - dt)[0]
        column = -(up - down) / (2 * h)  # residual here is P g − θ: the Jacobian of θ − P g
        np.testing.assert_allclose(jac[:, :, j], column, rtol=0.0, atol=1e-6)


@pytest.mark.parametrize(("loads", "flow"), [(FORCES, None), (SPEEDS, WATER)],
                         ids=["forces", "flow"])
def test_start_from_nearby_sets_gives_the_same_shapes(loads: np.ndarray,
                                                      flow: mc.Flow | None) -> None:
    """All loads at once from the solutions of nearby sets (a sampler's next proposals), with
    or without their inverse Jacobians: the same equilibria; a start far off (every angle 1 rad)
    still ends in them (Newton, or the sweep for what it does not reach); a start on another grid
    is carried over."""
    sets = _sets(4, 6)
    first = sweep_batch(BASE, *sets, loads, flow=flow)
    assert first.theta.shape[:2] == (4, loads.size) and np.isfinite(first.theta).all()
    moved = tuple(x * (1.0 + 0.01 * np.array([1.0, -1.0, 0.5, 2.0])) for x in sets)
    ref = _reference(BASE, moved, loads, flow)
    second = sweep_batch(BASE, *moved, loads, flow=flow, start=first.theta)
    _check(second, ref, moved[0])
    assert first.inverse is None and second.inverse is not None  # the sweep keeps none
    again = tuple(x * (1.0 - 0.005 * np.array([1.0, 2.0, -1.0, 0.5])) for x in moved)
    chord = sweep_batch(BASE, *again, loads, flow=flow, start=second.theta,
                        start_inverse=second.inverse)  # chord steps with the earlier inverses
    _check(chord, _reference(BASE, again, loads, flow), again[0])
    _check(sweep_batch(BASE, *moved, loads, flow=flow, start=np.ones_like(first.theta)), ref,
           moved[0])
    wrong = np.zeros((4, loads.size, 5))  # another grid's angles, without its nodes: unused
    _check(sweep_batch(BASE, *moved, loads, flow=flow, start=wrong), ref, moved[0])
    thinner = (moved[0], moved[1] * np.array([1.0, 1.0, 1.0, 1.6]), moved[2])  # another grid
    regrid = sweep_batch(BASE, *thinner, loads, flow=flow, start=first.theta,
                         start_nodes=first.nodes)
    assert regrid.nodes.size != first.nodes.size and regrid.swept == 0
    _check(regrid, _reference(BASE, thinner, loads, flow), thinner[0])


def test_uniform_cylinders_against_the_exact_elastica() -> None:
    """Cylinders (taper 1) of three lengths, radii and moduli under tip forces up to
    P L² / (E I) = 10: the tips and tip angles of the exact elastica
    (:func:`magcilia.mechanics.cantilever_tip`, elliptic integrals), whatever set or load."""
    heights = np.array([2.5e-3, 3.0e-3, 3.5e-3])
    radii = np.array([1.0e-4, 1.2e-4, 1.5e-4])
    moduli = np.array([4e5, 1e6, 2.5e6])
    cylinder = mc.Cilium.from_profile([0.0, 3e-3], [1e-4, 1e-4], youngs_modulus=1e6)
    base = BASE.replace(cilium=cylinder)  # a profile's shape scales: a cylinder in every set
    stiffness = moduli * 0.25 * np.pi * radii**4
    alphas = np.array([0.1, 1.0, 3.0, 10.0])
    forces = alphas * float(stiffness[0] / heights[0] ** 2)  # α = 0.1 … 10 for the first set
    shapes = sweep_batch(base, heights, radii, moduli, forces)
    assert shapes.ok.all()
    for i in range(3):
        for j, force in enumerate(forces):
            x, z, theta0 = mc.mechanics.cantilever_tip(force * heights[i] ** 2 / stiffness[i])
            tip = shapes.points[i, j, -1] / heights[i]
            np.testing.assert_allclose(tip[[0, 2]], [x, z], rtol=0.0, atol=1e-9)
            assert shapes.angles[i, j, -1] == pytest.approx(theta0, abs=1e-9)


@pytest.mark.parametrize(("loads", "flow"), [(FORCES, None), (SPEEDS, WATER)])
def test_a_nearby_population_keeps_the_earlier_grid(loads: np.ndarray,
                                                    flow: mc.Flow | None) -> None:
    """A population whose thinnest taper asks up to NODE_SLACK nodes fewer than the grid it
    starts from keeps that grid (its inverse Jacobians stay usable) and still gives the sweep's
    shapes; one that asks for more gets its own."""
    sets = _sets(4, 6)
    first = sweep_batch(BASE, *sets, loads, flow=flow)
    n1 = first.nodes.size
    for factor in (0.98, 0.95, 0.9, 0.85):  # thinner bases: blunter tapers, fewer nodes
        moved = (sets[0], sets[1] * factor, sets[2])
        own = sweep_batch(BASE, *moved, loads, flow=flow).nodes.size
        if n1 - batched.NODE_SLACK <= own < n1:
            break
    else:
        pytest.fail(f"no population asking for fewer nodes than {n1} within the slack")
    kept = sweep_batch(BASE, *moved, loads, flow=flow, start=first.theta,
                       start_nodes=first.nodes)
    assert kept.nodes.size == n1 and kept.swept == 0
    _check(kept, _reference(BASE, moved, loads, flow), moved[0])
    thicker = (sets[0], sets[1] * 1.2, sets[2])  # sharper tapers: more nodes than n1
    more = sweep_batch(BASE, *thicker, loads, flow=flow, start=first.theta,
                       start_nodes=first.nodes)
    assert more.nodes.size > n1
    _check(more, _reference(BASE, thicker, loads, flow), thicker[0])
