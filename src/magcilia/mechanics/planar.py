"""The planar elastica route: loads in the x–z plane (a dead force, a flow along ±x), one
equilibrium (:func:`_bend_plane`) or a sweep continued from load to load (:func:`_sweep_plane`),
and the checks every bend shares (the tip radius a tip load needs: :func:`require_tip_radius`).

All SI: forces in N, arc lengths in m, angles in rad, flow speeds in m/s.
:func:`magcilia.mechanics.bend` and :func:`magcilia.mechanics.bend_sweep` are the public faces.
"""

from __future__ import annotations

import logging
import math
from dataclasses import dataclass
from functools import cached_property, lru_cache

import numpy as np
from numpy.typing import ArrayLike, NDArray

from magcilia import _validate as v
from magcilia._errors import MagciliaError
from magcilia.device.cilium import Cilium
from magcilia.device.setup import Setup
from magcilia.mechanics.drag import check_reynolds, drag_per_length, free_log, wall_log
from magcilia.mechanics.elastica import (
    ContinuationError,
    Grid,
    Problem,
    Solution,
    point_influence,
    solve,
)
from magcilia.mechanics.flow import Flow
from magcilia.mechanics.sections import check_nodes, sections
from magcilia.mechanics.shape import BentShape, Load
from magcilia.model.centreline import Centreline

F64 = NDArray[np.float64]
logger = logging.getLogger(__name__)

#: points of the uniform arc-length grid of returned shapes
OUTPUT_POINTS = 129


@dataclass(frozen=True)
class _PointMaps:
    """What a dead point force alone needs beyond :class:`Statics`, once per load case (its
    bends then cost a few array operations a Newton step and two products for the shape).

    Shape letters: ``N`` nodes, ``m`` output points (:data:`OUTPUT_POINTS`).
    """

    point: F64  # (N, N) P diag(loaded), rad per N (Problem.point)
    linear: F64  # (N,) P loaded: the linear-beam angles per unit F_x, rad/N
    s_out: F64  # (m,) the output arc lengths, m
    positions: F64  # (m, N) ∫₀ˢ of the nodal interpolant, m: points = positions (sin θ, 0, cos θ)
    #: (N, N) diag(1/EI) R diag(loaded), 1/(N m): the curvature at the nodes per moment density
    #: g, so that the output angles are positions (curvature g) (two products, no (m, N, N) one)
    curvature: F64


@dataclass(frozen=True)
class Statics:
    """What a load case keeps fixed (:func:`_static`): the grid, EI (N·m², (N,)), diameter
    (m, (N,)), ``loaded`` (1 below the point load, (N,)) and the influence matrix
    ``C diag(1/EI) R`` ((N, N), rad per N), all read-only; and, formed on first use,
    :attr:`maps` for a point force alone."""

    grid: Grid
    ei: F64
    diameter: F64
    loaded: F64
    influence: F64

    @cached_property
    def maps(self) -> _PointMaps:
        """The :class:`_PointMaps` of the point load (``loaded``)."""
        grid, loaded = self.grid, self.loaded
        # a tip load loads every node (``loaded`` falls from 1 to 0 along s: its last entry
        # says): P itself, not a copy of it
        point = self.influence if loaded[-1] == 1.0 else point_influence(self.influence, loaded)
        s_out, positions = grid.uniform_output(OUTPUT_POINTS)
        linear = point @ np.ones(loaded.size)
        curvature = grid.R * loaded / self.ei[:, None]
        for arr in (linear, curvature):
            arr.setflags(write=False)
        return _PointMaps(point, linear, s_out, positions, curvature)


@lru_cache(maxsize=64)
def _static(cilium: Cilium, modulus: float, at: float, point_load: bool,
            nodes: int | None) -> Statics:
    """The :class:`Statics` of a load case (cached: sweeps and repeated bends share them); at
    most :data:`~magcilia.mechanics.sections.MAX_NODES` nodes, whatever the profile's points
    (:func:`magcilia.mechanics.sections.sections`)."""
    sec = sections(cilium, at, point_load, nodes)
    grid = sec.grid
    ei = modulus * sec.second_moment
    diameter = 2.0 * sec.radius
    if not point_load:
        loaded = np.zeros(grid.s.size)
    elif at > grid.s[-1]:  # every node below the load (a tip load: the nodes are interior)
        loaded = np.ones(grid.s.size)
    else:
        loaded = (grid.s < at).astype(np.float64)
    influence = grid.C @ (grid.R / ei[:, None])
    for arr in (ei, diameter, loaded, influence):
        arr.setflags(write=False)
    return Statics(grid, ei, diameter, loaded, influence)


class _Case:
    """Grid, stiffness and load builders shared by the solves of one bend / sweep."""

    def __init__(self, setup: Setup, at: float, direction: float, point_load: bool,
                 flow: Flow | None, nodes: int | None) -> None:
        static = _static(setup.cilium, setup.youngs_modulus, at, point_load, nodes)
        self.grid, self.ei, self.diameter = static.grid, static.ei, static.diameter
        self.loaded, self.influence = static.loaded, static.influence
        self.unit = np.array(direction_unit(direction))
        # the rod turns toward a dead force (or along the flow), never past it: |θ| ≤ limit
        self.limit = abs(math.remainder(direction, 2.0 * math.pi)) if point_load \
            else 0.5 * math.pi
        self.flow = flow
        self.length = setup.cilium.height
        self.maps = static.maps if point_load else None

    @cached_property
    def free_log(self) -> F64:
        """The free rod's slender-body logarithm at the nodes (the wall's part is subtracted at
        each node's current height), dimensionless (N,)."""
        return free_log(self.grid.s, 0.5 * self.diameter, self.length)

    def problem(self, force: float, speed: float) -> Problem:
        drag = None
        if self.flow is not None and speed != 0.0:
            flow = self.flow.with_speed(speed)
            d, length = self.diameter, self.length

            def drag(cos_t: F64, z: F64) -> F64:  # a slender body on the wall below Re 0.5
                return drag_per_length(flow.velocity(z) * cos_t, d, flow.fluid,
                                       lambda: self.free_log - wall_log(z, 0.5 * d, length))

        return Problem(self.grid, self.ei, self.influence, force * self.unit, self.loaded, drag,
                       point=None if self.maps is None else self.maps.point)

    def guess(self, force: float, speed: float) -> F64:
        """Newton's start from the straight rod, rad (N,): the linear-beam angles θ_lin saturated
        at the load's direction, ``limit · tanh(θ_lin / limit)`` (θ_lin itself overshoots:
        several radians at P L² / EI₀ = 1 on a tapered cilium)."""
        if self.maps is not None and (self.flow is None or speed == 0.0):
            lin = (force * float(self.unit[0])) * self.maps.linear  # g(0) = F_x below the load
        else:
            lin = self.problem(force, speed).linear(1.0)
        if self.limit > 0.0:
            return np.asarray(self.limit * np.tanh(lin * (1.0 / self.limit)), dtype=np.float64)
        return lin

    def solve(self, start: tuple[float, float], end: tuple[float, float], theta: F64,
              slope: F64) -> Solution:
        """Continue from the solution ``theta`` at load ``start`` (force N, speed m/s) to
        ``end``; ``slope`` is the predicted change of θ (rad, (N,)) over the whole step."""
        (f0, u0), (f1, u1) = start, end

        def at(lam: float) -> tuple[Problem, float]:
            return self.problem(f0 + lam * (f1 - f0), u0 + lam * (u1 - u0)), 1.0

        return solve(at, 0.0, 1.0, theta, slope)[0]

    def shape_data(self, sol: Solution, force: float, speed: float) -> tuple[F64, F64, F64]:
        """Arc lengths (m,), angles (m,) and points (m, 3) on the output grid."""
        if self.maps is not None and (self.flow is None or speed == 0.0):
            return _point_shape(self.maps, sol.theta, force * self.unit)
        s_out, cum = self.grid.uniform_output(OUTPUT_POINTS)
        kappa = self.problem(force, speed).curvature(sol.theta)
        x, z, th = (cum @ np.stack([np.sin(sol.theta), np.cos(sol.theta), kappa], axis=1)).T
        pts = np.zeros((s_out.size, 3))
        pts[:, 0], pts[:, 2] = x, z
        th = th.copy()
        th[0] = 0.0  # clamped base, exactly (the quadrature gives ~1e-17)
        pts[0] = 0.0
        return s_out, th, pts


def direction_unit(direction: float) -> tuple[float, float]:
    """(sin, cos) of a force's ``direction`` (rad from +z toward +x), a component below 1e-15
    made exactly 0: in floating point cos(π/2) is 6e-17, which gave the default horizontal force
    a vertical part of 6e-17 F (and made it miss the fused Newton loop's horizontal case)."""
    sin, cos = math.sin(direction), math.cos(direction)
    return (0.0 if abs(sin) < 1e-15 else sin), (0.0 if abs(cos) < 1e-15 else cos)


def _point_shape(maps: _PointMaps, theta: F64, force: F64) -> tuple[F64, F64, F64]:
    """:meth:`_Case.shape_data` of a point force alone (``force``: (F_x, F_z), N; ``theta``:
    the nodal angles, rad (N,)): arc lengths (m,), angles (m,) and points (m, 3), each output
    array by one product with the maps."""
    fx, fz = force.tolist()
    sin, cos = np.sin(theta), np.cos(theta)
    g = cos * fx if fz == 0.0 else fx * cos - fz * sin  # the moment density per loaded node
    th = maps.positions @ (maps.curvature @ g)
    tangents = np.zeros((theta.size, 3))
    tangents[:, 0], tangents[:, 2] = sin, cos
    pts = maps.positions @ tangents
    th[0] = 0.0  # clamped base, exactly (the quadrature gives ~1e-17)
    pts[0] = 0.0
    return maps.s_out, th, pts


#: why a sharp cone (tip_radius 0) cannot carry each kind of load
SHARP_TIP = {
    "force": "a point load at the tip: a sharp cone's tip compliance is infinite (I ∝ r⁴ → 0 at "
             "the tip)",
    "flow": "a flow load: on a sharp cone the drag on the vanishing tip section (EI ∝ r⁴ → 0 while "
            "the drag per length stays finite) makes the tip rotation singular",
    "actuation": "a magnetic field: on a sharp cone the field's couple per length (∝ r²) over EI "
                 "(∝ r⁴) makes the curvature grow as 1/(L − s) toward the tip (the tip rotation is "
                 "singular)",
}


def require_tip_radius(setup: Setup, load: str) -> None:
    """Raise unless the cilium has a tip radius, which a tip ``load`` ("force", "flow" or
    "actuation") needs."""
    if setup.cilium.tip_radius == 0.0:
        below = " or apply the load below the tip (at=, CLI: --at)" if load == "force" else ""
        raise v.fail("tip_radius", 0.0, f"positive for {SHARP_TIP[load]}; set tip_radius > 0 "
                     f"(CLI: --tip-radius, e.g. --tip-radius 0.05mm){below}")


def _check(setup: Setup, force: float, at: float | None, direction: float,
           flow: Flow | None) -> tuple[float, float, float]:
    if not isinstance(setup, Setup):
        raise v.fail("setup", type(setup).__name__, "a magcilia.Setup")
    force = v.real("force", force, "N")
    direction = v.real("direction", direction, "rad")
    c = setup.cilium
    length = c.height
    if at is None:
        at = length
    else:
        at = v.positive("at", at)
        if at > length * (1.0 + 1e-12):
            raise v.fail("at", at, f"an arc length in (0, {length:.6g}] m (the cilium's length)")
        at = min(at, length)
    if force != 0.0 and at >= length * (1.0 - 1e-9):
        require_tip_radius(setup, "force")
    if flow is not None:
        if not isinstance(flow, Flow):
            raise v.fail("flow", type(flow).__name__, "a magcilia.Flow (Flow.uniform, …)")
        if flow.speed != 0.0:
            require_tip_radius(setup, "flow")
        z = np.linspace(0.0, length, 65)
        fastest = float(np.max(np.abs(flow.velocity(z))))
        check_reynolds(fastest, 2.0 * c.max_radius, flow.fluid)  # the widest section
    return force, at, direction


def _bend_plane(setup: Setup, force: float = 0.0, *, at: float | None = None,
                direction: float = 0.5 * math.pi, flow: Flow | None = None,
                nodes: int | None = None) -> BentShape:
    """:func:`~magcilia.mechanics.bend.bend` of loads in the x–z plane given as today (a force
    magnitude, a flow along ±x, no actuation): the planar solver, unchanged."""
    force, at_s, direction = _check(setup, force, at, direction, flow)
    nodes = check_nodes(nodes)
    speed = 0.0 if flow is None else flow.speed
    load = Load(force, direction, at_s, flow)
    length = setup.cilium.height
    if force == 0.0 and speed == 0.0:
        s = np.linspace(0.0, length, OUTPUT_POINTS)
        pts = np.zeros((1, s.size, 3))
        pts[0, :, 2] = s
        return BentShape(s, np.zeros((1, s.size)), pts, load=load)
    case = _Case(setup, at_s, direction, force != 0.0, flow, nodes)
    try:
        sol = case.solve((0.0, 0.0), (force, speed), np.zeros(case.grid.s.size),
                         case.guess(force, speed))
    except ContinuationError as exc:
        by_force = force != 0.0
        value = force if by_force else speed
        raise MagciliaError(_message(by_force, value, exc.reached * value)) from None
    s, th, pts = case.shape_data(sol, force, speed)
    return BentShape._solved(s, th[None], pts[None], load, sol.residual, sol.iterations,
                             int(case.grid.s.size))


def _sweep_plane(setup: Setup, forces: ArrayLike | None = None, *,
                 speeds: ArrayLike | None = None, flow: Flow | None = None,
                 at: float | None = None, direction: float = 0.5 * math.pi,
                 nodes: int | None = None) -> Centreline:
    """:func:`~magcilia.mechanics.bend.bend_sweep` in the x–z plane (today's)."""
    nodes = check_nodes(nodes)
    values = sweep_values(forces, speeds, flow)
    is_force = forces is not None
    biggest = float(values[np.argmax(np.abs(values))])
    test_flow = flow.with_speed(biggest) if (flow is not None and not is_force) else flow
    _, at_s, direction = _check(setup, biggest if is_force else 0.0, at, direction, test_flow)
    case = _Case(setup, at_s, direction, is_force, flow if not is_force else None, nodes)
    i = 0 if is_force else 1  # the swept component of a load (force N, speed m/s)
    solved = [(0.0, np.zeros(case.grid.s.size))]  # the last (≤ 3) solutions (value, θ)
    rows_th: list[F64] = []
    rows_pts: list[F64] = []
    s_out = np.linspace(0.0, setup.cilium.height, OUTPUT_POINTS)
    logger.info("bend sweep: %d loads up to %.4g %s", values.size, biggest,
                "N" if is_force else "m/s")
    for value in values.tolist():
        load = (value, 0.0) if is_force else (0.0, value)
        last, theta = solved[-1]
        prev = (last, 0.0) if is_force else (0.0, last)
        if value == 0.0:
            sol = Solution(np.zeros_like(theta), 0.0, 0)
        else:
            guess = case.guess(*load) if len(solved) == 1 else _extrapolate(solved, value)
            try:
                sol = case.solve(prev, load, theta, guess - theta)
            except ContinuationError as exc:
                reached = prev[i] + exc.reached * (load[i] - prev[i])
                raise MagciliaError(_message(is_force, value, reached)) from None
        kept = [e for e in solved if e[0] != value][-2:]  # distinct values for _extrapolate
        solved = [*kept, (value, sol.theta)]
        s_out, th, pts = case.shape_data(sol, *load)
        rows_th.append(th)
        rows_pts.append(pts)
    return Centreline(s_out, np.stack(rows_th), np.stack(rows_pts))


def sweep_values(forces: ArrayLike | None, speeds: ArrayLike | None, flow: Flow | None) -> F64:
    """The loads a sweep runs through, shape (a,): ``forces`` (N) or ``speeds`` (m/s, with a
    :class:`Flow`), exactly one of them, finite and not empty."""
    if (forces is None) == (speeds is None):
        raise v.fail("bend_sweep", "both or neither of forces/speeds", "given forces or speeds")
    if speeds is not None and not isinstance(flow, Flow):
        raise v.fail("flow", None if flow is None else type(flow).__name__,
                     "a Flow when sweeping speeds")
    given = forces if forces is not None else speeds
    assert given is not None  # for mypy: exactly one of them is set (checked above)
    values = v.finite_array("forces" if forces is not None else "speeds", given, ndim=1)
    if values.size == 0:
        raise v.fail("forces", "an empty array", "at least one load")
    return values


def _extrapolate(solved: list[tuple[float, F64]], value: float) -> F64:
    """θ (rad, (N,)) at ``value`` from the polynomial through the solutions ``(value_k, θ_k)``
    (distinct values; 2 or 3 of them: a secant or a parabola, error O(h²) or O(h³) for a sweep
    of step h)."""
    out = np.zeros_like(solved[-1][1])
    for k, (vk, theta) in enumerate(solved):
        weight = math.prod((value - vj) / (vk - vj) for j, (vj, _) in enumerate(solved) if j != k)
        out += weight * theta
    return out


def _message(is_force: bool, value: float, reached: float) -> str:
    if is_force:
        return (f"force must be a load the elastica solver converges for; it did not converge "
                f"beyond F = {reached:.6g} N (the largest converged load); got {value:.6g} N")
    return (f"flow speed must be a load the elastica solver converges for; it did not converge "
            f"beyond {reached:.6g} m/s (the largest converged load); got {value:.6g} m/s")
