"""Bending under loads in any direction and under magnetic actuation: the loads resolved into
a common vertical plane (the planar solver, turned into it) or, when they leave every plane, the
3-D rod (:mod:`magcilia.mechanics.rod`); the critical axial loads (:func:`buckling_load`,
:func:`flip_field`).

All SI: forces in N, arc lengths in m, angles in rad, flow speeds in m/s, fields in T.
"""

from __future__ import annotations

import math
import numbers
from dataclasses import dataclass, replace
from functools import cached_property

import numpy as np
from numpy.typing import ArrayLike, NDArray

from magcilia import _validate as v
from magcilia._errors import MagciliaError
from magcilia.device.actuation import Actuation
from magcilia.device.setup import Setup
from magcilia.mechanics.drag import drag_per_length, free_log, wall_log
from magcilia.mechanics.elastica import ContinuationError, Problem, Solution, solve
from magcilia.mechanics.flow import Flow
from magcilia.mechanics.planar import (
    OUTPUT_POINTS,
    _bend_plane,
    _check,
    _static,
    require_tip_radius,
)
from magcilia.mechanics.rod import FieldError, Rod, RodLoads, RodProblem, linear_guess, straight
from magcilia.mechanics.sections import Sections, check_nodes, sections
from magcilia.mechanics.shape import BentShape, Load, SpatialBentShape
from magcilia.model.centreline import Centreline, SpatialCentreline

F64 = NDArray[np.float64]

#: Newton's residual tolerance with a source's field (rad): its central-difference gradient
#: (:data:`magcilia.device.actuation.GRADIENT_STEP`) leaves residuals of ~1e-11 as round-off
SOURCE_TOLERANCE = 1e-9
#: relative size of an out-of-plane load component that is neglected as round-off
_IN_PLANE = 1e-12
#: tilt (rad) of an axial load beyond its critical value that picks the buckled branch
_BUCKLING_TILT = 0.05


def _angle(name: str, value: object) -> float:
    if isinstance(value, numbers.Real) and value == 0.0:
        return 0.0
    return v.real(name, value, "rad")


@dataclass(frozen=True)
class _Resolved:
    """The loads of a bend, checked, with their common vertical plane (if any)."""

    load: Load  # the record kept with the shape
    force: F64  # (3,) N
    at: float  # m
    flow: Flow | None
    actuation: Actuation | None
    plane: float | None  # azimuth of the common vertical plane, rad; None: no common plane
    magnitude: float  # planar force (signed) and its direction in the plane
    direction: float
    planar_flow: Flow | None  # the flow along +x of the plane (signed speed)
    field: F64 | None  # (B_x', B_z) of a uniform field in the plane, T
    axial: bool  # every load along the axis (the straight rod is an equilibrium)


def _resolve(setup: Setup, force: float | ArrayLike, at: float | None, direction: float,
             azimuth: float, flow: Flow | None, actuation: Actuation | None) -> _Resolved:
    az = _angle("azimuth", azimuth)
    if actuation is not None and not isinstance(actuation, Actuation):
        raise v.fail("actuation", type(actuation).__name__,
                     "a magcilia Actuation (Actuation.uniform(b), Actuation.magpylib(source))")
    given_vector = not isinstance(force, numbers.Real) or isinstance(force, bool)
    if given_vector and not isinstance(force, bool):
        vec = v.vector3("force", force, "N")
        if direction != 0.5 * math.pi:
            raise v.fail("direction", direction, "left at its default with a force vector (the "
                         "vector gives the direction)")
        fh = math.hypot(vec[0], vec[1])
        magnitude = float(math.hypot(fh, vec[2]))
        if fh == 0.0:
            direction, force_plane = math.atan2(0.0, vec[2]), None
        elif vec[1] == 0.0:  # in the x–z plane: a signed direction, today's convention
            if az != 0.0:
                raise v.fail("azimuth", az, "0 with a horizontal force vector (the vector "
                             "gives the azimuth)")
            direction, force_plane = math.atan2(vec[0], vec[2]), 0.0
        else:
            if az != 0.0:
                raise v.fail("azimuth", az, "0 with a horizontal force vector (the vector "
                             "gives the azimuth)")
            force_plane = math.atan2(vec[1], vec[0])
            direction = math.atan2(fh, vec[2])
        load_azimuth = az if force_plane is None else force_plane
    else:
        magnitude = v.real("force", force, "N")
        direction = v.real("direction", direction, "rad")
        force_plane = az if magnitude != 0.0 else None
        load_azimuth = az
    # at, tip radius, flow and Reynolds checks as for the planar path
    magnitude, at_s, direction = _check(setup, magnitude, at, direction, flow)
    if actuation is not None and setup.spec.magnetization != 0.0:
        require_tip_radius(setup, "actuation")
    load = Load(magnitude, direction, at_s, flow, load_azimuth, actuation)
    if not given_vector:
        vec = load.vector
    speed = 0.0 if flow is None else flow.speed
    uniform = None if actuation is None or not actuation.is_uniform else actuation.uniform_field
    if uniform is not None and not np.all(np.isfinite(uniform)):
        raise v.fail("actuation", "a field that is not finite", "a finite field in T")
    candidates = [force_plane,
                  flow.azimuth if flow is not None and speed != 0.0 else None,
                  (0.0 if uniform[1] == 0.0 else math.atan2(uniform[1], uniform[0]))
                  if uniform is not None and math.hypot(uniform[0], uniform[1]) > 0.0 else None]
    plane = next((c for c in candidates if c is not None), load_azimuth)
    e = np.array([math.cos(plane), math.sin(plane), 0.0])
    n = np.array([-math.sin(plane), math.cos(plane), 0.0])
    coplanar = actuation is None or uniform is not None
    if force_plane is None or force_plane != plane:
        coplanar &= abs(float(vec @ n)) <= _IN_PLANE * float(np.linalg.norm(vec))
    planar_flow = flow
    if flow is not None:
        if speed != 0.0:
            coplanar &= abs(math.sin(flow.azimuth - plane)) <= _IN_PLANE
        sign = 1.0 if math.cos(flow.azimuth - plane) >= 0.0 else -1.0
        planar_flow = replace(flow, azimuth=0.0, speed=sign * speed)
    field = None
    if uniform is not None:
        coplanar &= abs(float(uniform @ n)) <= _IN_PLANE * float(np.linalg.norm(uniform))
        field = np.array([float(uniform @ e), float(uniform[2])])
    if force_plane is not None and force_plane == plane:
        mag, dirn = magnitude, direction  # exactly as given: the x–z result turned
    else:
        mag, dirn = float(math.hypot(vec @ e, vec[2])), math.atan2(float(vec @ e), vec[2])
    # a force magnitude along the axis keeps today's behaviour (solved as given, not buckled)
    force_axial = magnitude == 0.0 or (given_vector and math.hypot(vec[0], vec[1]) == 0.0)
    axial = (force_axial and speed == 0.0 and (field is None or field[0] == 0.0) and coplanar
             and (magnitude != 0.0 or field is not None))
    return _Resolved(load, vec, at_s, flow, actuation, plane if coplanar else None, mag, dirn,
                     planar_flow, field, axial)


def _moment_per_length(setup: Setup, at: F64 | Sections) -> F64:
    """μ(s) = M π r(s)², A·m, at arc lengths ``at`` (m), or at the nodes of a grid's
    :class:`~magcilia.mechanics.sections.Sections` (the cell means of r² on a resampled grid):
    the moment per length of the cilium magnetized along its tangent (M =
    ``setup.spec.magnetization``)."""
    if isinstance(at, Sections) and at.resampled:
        return np.asarray(setup.spec.magnetization * math.pi * at.radius_squared,
                          dtype=np.float64)
    r = at.radius if isinstance(at, Sections) else setup.cilium.radius(at)
    return np.asarray(setup.spec.magnetization * math.pi * r * r, dtype=np.float64)


class _PlaneCase:
    """Planar loads of the general path: a dead force, a flow along x, a uniform field in the
    x–z plane (couple only), all scaled together by a load factor λ."""

    def __init__(self, setup: Setup, res: _Resolved, nodes: int | None) -> None:
        point_load = res.magnitude != 0.0
        static = _static(setup.cilium, setup.youngs_modulus, res.at, point_load, nodes)
        self.grid, self.ei, self.diameter = static.grid, static.ei, static.diameter
        self.loaded, self.influence = static.loaded, static.influence
        self.force = res.magnitude * np.array([math.sin(res.direction), math.cos(res.direction)])
        flow = res.planar_flow
        self.flow = flow if flow is not None and flow.speed != 0.0 else None
        self.field = res.field
        self.mu = _moment_per_length(setup, sections(setup.cilium, res.at, point_load, nodes))
        self.length = setup.cilium.height
        limits = [abs(math.remainder(res.direction, 2.0 * math.pi))] if point_load else []
        if self.flow is not None:
            limits.append(0.5 * math.pi)
        if self.field is not None and np.any(self.field != 0.0):
            limits.append(abs(math.atan2(self.field[0], self.field[1])))
        self.limit = max(limits, default=0.0)

    @cached_property
    def free_log(self) -> F64:
        return free_log(self.grid.s, 0.5 * self.diameter, self.length)

    def problem(self, lam: float, tilt: float = 0.0) -> Problem:
        """The problem at load factor ``lam`` with every load turned by ``tilt`` (rad) about y
        toward +x from −z (an imperfection that picks a buckled branch)."""
        c, s = math.cos(tilt), math.sin(tilt)
        fx, fz = self.force.tolist()
        force = lam * np.array([fx * c - fz * s, fz * c + fx * s])
        couple = None
        if self.field is not None:
            bx, bz = self.field.tolist()
            couple = lam * np.outer([bx * c - bz * s, bz * c + bx * s], self.mu)
        drag = None
        if self.flow is not None:
            flow = self.flow.with_speed(lam * self.flow.speed)
            d, length = self.diameter, self.length

            def drag(cos_t: F64, z: F64) -> F64:
                return drag_per_length(flow.velocity(z) * cos_t, d, flow.fluid,
                                       lambda: self.free_log - wall_log(z, 0.5 * d, length))

        return Problem(self.grid, self.ei, self.influence, force, self.loaded, drag, couple)

    def guess(self, tilt: float = 0.0) -> F64:
        lin = self.problem(1.0, tilt).linear(1.0)
        return self.limit * np.tanh(lin / self.limit) if self.limit > 0.0 else lin

    def solve(self) -> Solution:
        zero = np.zeros(self.grid.s.size)
        return solve(lambda lam: (self.problem(lam), 1.0), 0.0, 1.0, zero, self.guess())[0]

    def critical(self) -> float:
        """Load factor at which the straight rod (an equilibrium under axial loads) turns
        unstable (inf if never): the residual's Jacobian there, ``I + λ P diag(F_z H + μ B_z)``,
        turns singular at λ = 1 / (the largest eigenvalue of −P diag(F_z H + μ B_z))."""
        d = self.force[1] * self.loaded
        if self.field is not None:
            d = d + self.mu * self.field[1]
        top = float(np.max(np.linalg.eigvals(-self.influence * d).real))
        return 1.0 / top if top > 0.0 else math.inf

    def buckled(self, critical: float) -> Solution:
        """The buckled branch toward +x of an unstable axial load (``critical``: the load factor
        at which the straight rod turns unstable): the load tilted by :data:`_BUCKLING_TILT`
        followed from the straight rod in steps of a quarter of the critical load up to twice it,
        then of 25 % (so that Newton cannot jump to another equilibrium), then the tilt
        continued to 0."""
        theta = np.zeros(self.grid.s.size)
        iterations = 0
        steady = np.arange(0.25, 2.0 + 1e-9, 0.25) * critical  # a quarter of it up to twice it
        beyond = 2.0 * critical * 1.25 ** np.arange(1, 1 + max(0, math.ceil(
            math.log(1.0 / (2.0 * critical)) / math.log(1.25))))  # then 25 % steps
        stops = np.unique(np.append(np.concatenate([steady, beyond])[
            np.concatenate([steady, beyond]) < 1.0], 1.0))
        last = 0.0
        slope: F64 | None = self.guess(_BUCKLING_TILT) * stops[0]
        for stop in stops.tolist():
            sol = solve(lambda lam: (self.problem(lam, _BUCKLING_TILT), 1.0), last, stop, theta,
                        None if slope is None else slope / max(stop - last, 1e-300))[0]
            slope = sol.theta - theta
            theta, last, iterations = sol.theta, stop, iterations + sol.iterations
        tilted = Solution(theta, 0.0, iterations)
        sol = solve(lambda p: (self.problem(1.0, _BUCKLING_TILT * (1.0 - p)), 1.0), 0.0, 1.0,
                    tilted.theta)[0]
        tip = float(self.grid.w @ np.sin(sol.theta))
        if tip < 0.0:  # the mirror image is the same equilibrium (axial loads)
            sol = Solution(-sol.theta, sol.residual, sol.iterations)
        return Solution(sol.theta, sol.residual, sol.iterations + tilted.iterations)

    def shape_data(self, sol: Solution) -> tuple[F64, F64, F64]:
        """Arc lengths (m,), angles (m,) and points (m, 3) on the output grid."""
        s_out, cum = self.grid.uniform_output(OUTPUT_POINTS)
        kappa = self.problem(1.0).curvature(sol.theta)
        x, z, th = (cum @ np.stack([np.sin(sol.theta), np.cos(sol.theta), kappa], axis=1)).T
        pts = np.zeros((s_out.size, 3))
        pts[:, 0], pts[:, 2] = x, z
        th = th.copy()
        th[0] = 0.0
        pts[0] = 0.0
        return s_out, th, pts


def _bend_any(setup: Setup, force: float | ArrayLike, at: float | None, direction: float,
              azimuth: float, flow: Flow | None, actuation: Actuation | None,
              nodes: int | None, *, rod: bool) -> BentShape | SpatialBentShape:
    if not isinstance(setup, Setup):
        raise v.fail("setup", type(setup).__name__, "a magcilia.Setup")
    nodes = check_nodes(nodes)
    res = _resolve(setup, force, at, direction, azimuth, flow, actuation)
    if rod or res.plane is None:
        return _bend_rod(setup, res, nodes)
    plane = res.plane
    if res.field is None and not res.axial:  # today's planar solver, turned
        planar = _bend_plane(setup, res.magnitude, at=res.at, direction=res.direction,
                             flow=res.planar_flow, nodes=nodes)
        s, th, pts = planar.s, planar.angles[0], planar.points[0]
        residual, iterations, count = planar.residual, planar.iterations, planar.nodes
    else:
        case = _PlaneCase(setup, res, nodes)
        speed = 0.0 if case.flow is None else case.flow.speed
        if not np.any(case.force) and speed == 0.0 and (case.field is None
                                                         or not np.any(case.field)):
            sol = Solution(np.zeros(case.grid.s.size), 0.0, 0)
        else:
            try:
                critical = case.critical() if res.axial else math.inf
                sol = case.buckled(critical) if critical < 1.0 else case.solve()
            except ContinuationError as exc:
                raise MagciliaError(_scaled_message(res, exc.reached)) from None
        s, th, pts = case.shape_data(sol)
        residual, iterations, count = sol.residual, sol.iterations, int(case.grid.s.size)
    if plane == 0.0:
        return BentShape(s, th[None], pts[None], load=res.load, residual=residual,
                         iterations=iterations, nodes=count)
    turned = SpatialCentreline.from_planar(Centreline(s, th[None], pts[None]), plane)
    return SpatialBentShape(turned.s, turned.points, turned.tangents, turned.normals,
                            load=res.load, residual=residual, iterations=iterations,
                            nodes=count, plane=plane)


def _bend_rod(setup: Setup, res: _Resolved, nodes: int | None) -> SpatialBentShape:
    """The 3-D rod (:mod:`magcilia.mechanics.rod`) for the resolved loads."""
    c = setup.cilium
    point_load = bool(np.any(res.force != 0.0))
    static = _static(c, setup.youngs_modulus, res.at, point_load, nodes)
    grid, ei, diameter, loaded = static.grid, static.ei, static.diameter, static.loaded
    mu = _moment_per_length(setup, sections(c, res.at, point_load, nodes))
    the_rod = Rod(grid, ei, diameter, loaded, mu,
                  setup.base_centre, free_log(grid.s, 0.5 * diameter, c.height))
    act = res.actuation
    flow = res.flow if res.flow is not None and res.flow.speed != 0.0 else None
    if act is None:
        loads = RodLoads(res.force, flow)
    elif act.is_uniform:
        loads = RodLoads(res.force, flow, uniform=act.uniform_field)
    else:
        loads = RodLoads(res.force, flow, field=act.field_unchecked, directional=act.directional)
    start = straight(the_rod)
    n = grid.s.size
    try:
        if not point_load and flow is None and act is None:
            sol = Solution(start.ravel(), 0.0, 0)
        else:
            guess = linear_guess(the_rod, loads)
            sol = solve(lambda lam: (RodProblem(the_rod, loads, lam), 1.0), 0.0, 1.0,
                        start.ravel(), (guess - start).ravel(),
                        tol=1e-12 if loads.field is None else SOURCE_TOLERANCE)[0]
    except FieldError as exc:
        where = ", ".join(f"{x * 1e3:.4g}" for x in exc.point)
        raise v.fail("actuation", f"a field that is not finite at ({where}) mm",
                     "finite along the cilium (move the source: the cilium reaches its edge or "
                     "surface)") from None
    except ContinuationError as exc:
        raise MagciliaError(_scaled_message(res, exc.reached)) from None
    tangents = sol.theta.reshape(n, 3)
    state = RodProblem(the_rod, loads, 1.0).parts(tangents[None])
    s_out, cum = grid.uniform_output(OUTPUT_POINTS)
    pts = cum @ tangents
    pts[0] = 0.0
    tan = np.array([0.0, 0.0, 1.0]) + cum @ state.curvature[0]
    tan /= np.linalg.norm(tan, axis=-1, keepdims=True)
    tan[0] = (0.0, 0.0, 1.0)
    base_moment = grid.w @ state.torque[0]  # M(0), N·m: the base bends along M(0) × e_z
    side = np.array([base_moment[1], -base_moment[0], 0.0])
    base_normal = side if np.linalg.norm(side) > 1e-14 * max(
        float(np.abs(state.moment).max()), 1e-300) else None
    normals = SpatialCentreline.from_tangents(s_out, tan, base_normal).normals
    return SpatialBentShape(s_out, pts[None], tan[None], normals, load=res.load,
                            residual=sol.residual, iterations=sol.iterations, nodes=int(n),
                            plane=None)


def _scaled_message(res: _Resolved, reached: float) -> str:
    """One line for loads scaled together beyond the solver's reach."""
    parts = []
    if np.any(res.force != 0.0):
        parts.append(f"F = {reached * float(np.linalg.norm(res.force)):.6g} N")
    if res.flow is not None and res.flow.speed != 0.0:
        parts.append(f"{reached * abs(res.flow.speed):.6g} m/s")
    act = res.actuation
    if act is not None:
        scale = f"scale {reached * act.scale:.6g}"
        if act.is_uniform:
            scale += f", |B| = {reached * float(np.linalg.norm(act.uniform_field)) * 1e3:.6g} mT"
        parts.append(scale)
        return (f"actuation must be a field the elastica solver converges for (with the other "
                f"loads, scaled together); it did not converge beyond {reached:.6g} of the given "
                f"loads ({', '.join(parts)}: the largest converged); got scale {act.scale:.6g}")
    return (f"force must be a load the elastica solver converges for (with the other loads, "
            f"scaled together); it did not converge beyond {reached:.6g} of the given loads "
            f"({', '.join(parts)}: the largest converged)")


def buckling_load(setup: Setup, at: float | None = None, nodes: int | None = None) -> float:
    """Critical axial compressive force of the upright cilium, N: the smallest dead force along
    −z at arc length ``at`` (m; default the tip) above which the straight rod is unstable
    (the smallest eigenvalue of the collocation's linearised problem). Euler's
    ``π² E I / (4 L²)`` for a uniform rod loaded at the tip."""
    _, at_s, _ = _check(setup, 1.0, at, math.pi, None)
    count = check_nodes(nodes)
    static = _static(setup.cilium, setup.youngs_modulus, at_s, True, count)
    return 1.0 / float(np.max(np.linalg.eigvals(static.influence * static.loaded).real))


def flip_field(setup: Setup, nodes: int | None = None) -> float:
    """Critical uniform field against the magnetization, T: the smallest field along −z (the
    cilium magnetized toward +z; a field along the magnetization, whichever its sign) above
    which the straight cilium is unstable and flips over (inf for an unmagnetized cilium).
    ``π² E I / (4 μ L²)`` for a uniform rod (μ = M π r², the same as :func:`buckling_load` with
    the tip force μB)."""
    if not isinstance(setup, Setup):
        raise v.fail("setup", type(setup).__name__, "a magcilia.Setup")
    if setup.spec.magnetization == 0.0:
        return math.inf
    count = check_nodes(nodes)
    influence = _static(setup.cilium, setup.youngs_modulus, setup.cilium.height, False,
                        count).influence
    mu = np.abs(_moment_per_length(setup, sections(setup.cilium, setup.cilium.height, False,
                                                   count)))
    return 1.0 / float(np.max(np.linalg.eigvals(influence * mu).real))
