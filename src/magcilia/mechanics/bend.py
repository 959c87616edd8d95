"""The public bending functions: :func:`bend` (one equilibrium) and :func:`bend_sweep` (a batch).

All SI: forces in N, arc lengths in m, angles in rad, flow speeds in m/s.
"""

from __future__ import annotations

import logging
import math
import numbers
from dataclasses import dataclass, replace
from functools import cached_property, lru_cache

import numpy as np
from numpy.typing import ArrayLike, NDArray

from magcilia import _validate as v
from magcilia._errors import MagciliaError
from magcilia.device.actuation import Actuation
from magcilia.device.cilium import Cilium
from magcilia.device.setup import Setup
from magcilia.mechanics.drag import check_reynolds, drag_per_length, free_log, wall_log
from magcilia.mechanics.elastica import ContinuationError, Grid, Problem, Solution, solve
from magcilia.mechanics.flow import Flow
from magcilia.mechanics.rod import FieldError, Rod, RodLoads, RodProblem, linear_guess, straight
from magcilia.mechanics.sections import Sections, check_nodes, compliance_integral, sections
from magcilia.mechanics.shape import BentShape, Load, SpatialBentShape
from magcilia.model.centreline import Centreline, SpatialCentreline
from magcilia.model.pose import Pose

F64 = NDArray[np.float64]
logger = logging.getLogger(__name__)

#: points of the uniform arc-length grid of returned shapes
OUTPUT_POINTS = 129


@lru_cache(maxsize=64)
def _static(cilium: Cilium, modulus: float, at: float, point_load: bool,
            nodes: int | None) -> tuple[Grid, F64, F64, F64, F64]:
    """What a load case keeps fixed (cached: sweeps and repeated bends share it): the grid,
    EI (N·m², (N,)), diameter (m, (N,)), ``loaded`` (1 below the point load, (N,)) and the
    influence matrix ``C diag(1/EI) R`` ((N, N), rad per N); at most
    :data:`~magcilia.mechanics.sections.MAX_NODES` nodes, whatever the profile's points
    (:func:`magcilia.mechanics.sections.sections`)."""
    sec = sections(cilium, at, point_load, nodes)
    grid = sec.grid
    ei = modulus * sec.second_moment
    diameter = 2.0 * sec.radius
    loaded = (grid.s < at).astype(np.float64) if point_load else np.zeros(grid.s.size)
    influence = grid.C @ (grid.R / ei[:, None])
    for arr in (ei, diameter, loaded, influence):
        arr.setflags(write=False)
    return grid, ei, diameter, loaded, influence


class _Case:
    """Grid, stiffness and load builders shared by the solves of one bend / sweep."""

    def __init__(self, setup: Setup, at: float, direction: float, point_load: bool,
                 flow: Flow | None, nodes: int | None) -> None:
        self.grid, self.ei, self.diameter, self.loaded, self.influence = _static(
            setup.cilium, setup.youngs_modulus, at, point_load, nodes)
        self.unit = np.array([math.sin(direction), math.cos(direction)])
        # the rod turns toward a dead force (or along the flow), never past it: |θ| ≤ limit
        self.limit = abs(math.remainder(direction, 2.0 * math.pi)) if point_load \
            else 0.5 * math.pi
        self.flow = flow
        self.length = setup.cilium.height

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

        return Problem(self.grid, self.ei, self.influence, force * self.unit, self.loaded, drag)

    def guess(self, force: float, speed: float) -> F64:
        """Newton's start from the straight rod, rad (N,): the linear-beam angles θ_lin saturated
        at the load's direction, ``limit · tanh(θ_lin / limit)`` (θ_lin itself overshoots:
        several radians at P L² / EI₀ = 1 on a tapered cilium)."""
        lin = self.problem(force, speed).linear(1.0)
        return self.limit * np.tanh(lin / self.limit) if self.limit > 0.0 else lin

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
        s_out, cum = self.grid.uniform_output(OUTPUT_POINTS)
        kappa = self.problem(force, speed).curvature(sol.theta)
        x, z, th = (cum @ np.stack([np.sin(sol.theta), np.cos(sol.theta), kappa], axis=1)).T
        pts = np.zeros((s_out.size, 3))
        pts[:, 0], pts[:, 2] = x, z
        th = th.copy()
        th[0] = 0.0  # clamped base, exactly (the quadrature gives ~1e-17)
        pts[0] = 0.0
        return s_out, th, pts


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
    """:func:`bend` of loads in the x–z plane given as today (a force magnitude, a flow along
    ±x, no actuation): the planar solver, unchanged."""
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
    return BentShape(s, th[None], pts[None], load=load, residual=sol.residual,
                     iterations=sol.iterations, nodes=int(case.grid.s.size))


def bend(setup: Setup, force: float | ArrayLike = 0.0, *, at: float | None = None,
         direction: float = 0.5 * math.pi, azimuth: float = 0.0, flow: Flow | None = None,
         actuation: Actuation | None = None,
         nodes: int | None = None) -> BentShape | SpatialBentShape:
    """Static large-deflection shape of the cilium under a dead point force, a fluid flow and/or
    a magnetic actuation field, bent in any direction.

    Inextensible, unshearable elastica of the real frustum (``setup.cilium``; E from
    ``setup.youngs_modulus``), clamped at the base along +z, free at the tip; solved as a
    boundary-value problem by Chebyshev collocation and Newton's method, started from the
    linear-beam solution saturated at the load's direction, with load continuation where Newton
    fails (relative tip accuracy ~1e-10 for smooth cases). The equilibrium is the one a slowly
    increased load reaches (all loads grow together).

    When all loads lie in one vertical plane (a force in it, a flow along it, a uniform field in
    it) the planar solver solves the x–z problem and the shape is turned into that plane
    (:meth:`SpatialCentreline.from_planar`, exact); loads in the x–z plane itself give a
    :class:`BentShape`, exactly today's for today's arguments. Loads that leave every single plane
    (a field or flow across the plane of the force, any non-uniform source field) are solved by
    the 3-D rod (:mod:`magcilia.mechanics.rod`).

    Magnetic actuation: the cilium is magnetized along its local tangent t (base to tip) with
    ``setup.spec.magnetization`` M (A/m), so its moment per length is μ(s) = M π r(s)²; a field B
    exerts per length the couple μ t × B (it turns the cilium toward B: a field along +x bends
    it toward +x) and the force μ (t·∇)B. A source's field is evaluated in the board frame at the
    cilium's actual points, ``setup.base_centre + shape.points``. For a uniform rod in a uniform
    field this is the same elastica as a tip force μB (the magnetic poles at the ends),
    :func:`magcilia.mechanics.exact.uniform_field_tip`.

    Axial loads: a force along the axis (a vector (0, 0, F_z)) or a field along it leave the
    straight rod in equilibrium. Below the critical load (:func:`buckling_load`,
    :func:`flip_field`) that is the shape returned; beyond it the straight rod is unstable and the
    returned shape is the buckled one in the vertical plane at ``azimuth`` (tip toward
    ``(cos φ, sin φ)``): the branch that a load tilted infinitesimally toward it reaches. A
    field against the magnetization beyond :func:`flip_field` flips the cilium over toward the
    field in that way. A force given as a magnitude keeps today's behaviour: with ``direction``
    0 or π it is solved as given (the straight rod, stable or not).

    Parameters
    ----------
    setup : Setup
        The sensor setup (geometry, modulus and magnetization).
    force : float or array-like, shape (3,)
        Dead point force: a magnitude, N (with ``direction`` and ``azimuth``; default 0), or the
        vector (F_x, F_y, F_z), N, board frame (then ``direction`` and ``azimuth`` follow from it
        and stay at their defaults, except ``azimuth`` choosing the buckling plane of a vertical
        force).
    at : float, optional
        Arc length of the point of application, m, in (0, L]; default the tip.
    direction : float
        Direction of a force magnitude in its vertical plane, rad from +z toward the plane's
        horizontal direction; default π/2 (horizontal).
    azimuth : float
        Azimuth of that vertical plane, rad from +x toward +y; default 0 (the x–z plane).
    flow : Flow, optional
        Fluid flow (drag from the normal velocity component; see
        :mod:`magcilia.mechanics.drag`), horizontal along ``flow.azimuth``.
    actuation : Actuation, optional
        External magnetic field (:class:`magcilia.device.actuation.Actuation`).
    nodes : int, optional
        Collocation nodes per piece (default: chosen from the taper for ~1e-12 accuracy).

    Returns
    -------
    BentShape or SpatialBentShape
        A :class:`BentShape` (a :class:`~magcilia.Centreline`) for loads in the x–z plane, else
        a :class:`SpatialBentShape` (a :class:`~magcilia.SpatialCentreline`); ``.tip`` has shape
        (3,), m.

    Raises
    ------
    MagciliaError
        A tip point load, a flow or a field on a sharp cone (tip_radius 0: see
        :data:`SHARP_TIP`), ``at`` outside the cilium, a flow faster than the drag law allows, a
        field that is not finite at the cilium, or loads beyond what the solver converges for
        (the message gives the largest converged load or scale).

    Examples
    --------
    >>> import magcilia as mc
    >>> s = mc.Setup.paper(height=3e-3, base_radius=2e-4, tip_radius=5e-5, youngs_modulus=2e6)
    >>> shape = mc.bend(s, force=1e-4)
    >>> shape.tip.shape
    (3,)
    >>> turned = mc.bend(s, force=1e-4, azimuth=np.pi / 2)  # toward +y
    >>> bool(np.allclose(turned.tip, shape.tip[[1, 0, 2]], rtol=0, atol=1e-15))
    True
    """
    if (actuation is None and isinstance(azimuth, numbers.Real) and azimuth == 0.0
            and isinstance(force, numbers.Real) and getattr(flow, "azimuth", 0.0) == 0.0):
        return _bend_plane(setup, force, at=at, direction=direction, flow=flow, nodes=nodes)
    return _bend_any(setup, force, at, direction, azimuth, flow, actuation, nodes, rod=False)


def bend_3d(setup: Setup, force: float | ArrayLike = 0.0, *, at: float | None = None,
            direction: float = 0.5 * math.pi, azimuth: float = 0.0, flow: Flow | None = None,
            actuation: Actuation | None = None, nodes: int | None = None) -> SpatialBentShape:
    """:func:`bend` by the 3-D rod solver whatever the loads (in one plane or not).

    :func:`bend` uses it for loads that leave every single plane; called directly it checks the
    3-D solver against the planar one (same arguments, same units). Axial loads beyond
    :func:`buckling_load` are not followed onto a buckled branch here.
    """
    shape = _bend_any(setup, force, at, direction, azimuth, flow, actuation, nodes, rod=True)
    assert isinstance(shape, SpatialBentShape)  # for mypy: the rod always gives one
    return shape


# -- the general path: loads in any direction, actuation -------------------------------------

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
        self.grid, self.ei, self.diameter, self.loaded, self.influence = _static(
            setup.cilium, setup.youngs_modulus, res.at, point_load, nodes)
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
    grid, ei, diameter, loaded, _ = _static(c, setup.youngs_modulus, res.at, point_load, nodes)
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
    _, _, _, loaded, influence = _static(setup.cilium, setup.youngs_modulus, at_s, True, count)
    return 1.0 / float(np.max(np.linalg.eigvals(influence * loaded).real))


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
    _, _, _, _, influence = _static(setup.cilium, setup.youngs_modulus, setup.cilium.height,
                                    False, count)
    mu = np.abs(_moment_per_length(setup, sections(setup.cilium, setup.cilium.height, False,
                                                   count)))
    return 1.0 / float(np.max(np.linalg.eigvals(influence * mu).real))


def bend_sweep(setup: Setup, forces: ArrayLike | None = None, *,
               speeds: ArrayLike | None = None, flow: Flow | None = None,
               at: float | None = None, direction: float = 0.5 * math.pi,
               azimuth: float = 0.0, actuation: Actuation | None = None,
               nodes: int | None = None) -> Centreline | SpatialCentreline:
    """Shapes for a sequence of loads, each solve continued from the previous one.

    Give ``forces`` (N, shape (a,)) for point loads, or ``speeds`` (m/s, shape (a,)) together
    with ``flow`` (whose profile is scaled to each speed). Each solve starts from the polynomial
    through the last (up to three) solutions, so ordered, finely spaced sweeps (e.g. a read-out
    table's) are cheapest: one Newton step per load. For building read-out tables.

    The loads act in the vertical plane at ``azimuth`` (rad from +x toward +y; default 0: the
    x–z plane); a swept flow blows along its own ``Flow.azimuth``, which sets the plane
    (``azimuth`` must then be 0 or the same). The x–z solutions are turned into that plane
    (:meth:`SpatialCentreline.from_planar`, exact).

    With an ``actuation`` (:class:`~magcilia.Actuation`) every shape carries the field at full
    strength besides its swept load (a read-out table while actuating); each load is then solved
    on its own by :func:`bend` (no warm start: ~0.2 ms a shape in one plane, ~10 ms on the 3-D
    rod, more for a magpylib source).

    Returns
    -------
    Centreline or SpatialCentreline
        a shapes on the common grid of :data:`OUTPUT_POINTS` arc lengths: a Centreline in the
        x–z plane, a SpatialCentreline in any other plane.
    """
    plane = _angle("azimuth", azimuth)
    if actuation is not None:
        return _sweep_each(setup, forces, speeds, flow, at, direction, plane, actuation, nodes)
    if speeds is not None and isinstance(flow, Flow) and flow.azimuth != 0.0:
        if plane not in (0.0, flow.azimuth):
            raise v.fail("azimuth", plane, f"0 or the swept flow's azimuth ({flow.azimuth:.6g} "
                         "rad): a flow sets its own plane")
        plane, flow = flow.azimuth, flow.with_azimuth(0.0)
    shapes = _sweep_plane(setup, forces, speeds=speeds, flow=flow, at=at, direction=direction,
                          nodes=nodes)
    return shapes if plane == 0.0 else SpatialCentreline.from_planar(shapes, plane)


def _sweep_each(setup: Setup, forces: ArrayLike | None, speeds: ArrayLike | None,
                flow: Flow | None, at: float | None, direction: float, azimuth: float,
                actuation: Actuation, nodes: int | None) -> Centreline | SpatialCentreline:
    """:func:`bend_sweep` with an actuation: one :func:`bend` per load, stacked."""
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
    shapes = []
    for value in values.tolist():
        if forces is not None:
            shape = bend(setup, value, at=at, direction=direction, azimuth=azimuth, flow=flow,
                         actuation=actuation, nodes=nodes)
        else:
            assert flow is not None  # for mypy: checked above
            shape = bend(setup, at=at, azimuth=azimuth, flow=flow.with_speed(value),
                         actuation=actuation, nodes=nodes)
        shapes.append(shape)
    s = shapes[0].s
    planar = [sh for sh in shapes if isinstance(sh, BentShape)]
    if len(planar) == len(shapes):
        return Centreline(s, np.concatenate([sh.angles for sh in planar]),
                          np.concatenate([sh.points for sh in planar]))
    spatial = [sh if isinstance(sh, SpatialBentShape) else SpatialCentreline.from_planar(sh)
               for sh in shapes]
    return SpatialCentreline(s, *(np.concatenate([getattr(sh, name) for sh in spatial])
                                  for name in ("points", "tangents", "normals")))


def _sweep_plane(setup: Setup, forces: ArrayLike | None = None, *,
                 speeds: ArrayLike | None = None, flow: Flow | None = None,
                 at: float | None = None, direction: float = 0.5 * math.pi,
                 nodes: int | None = None) -> Centreline:
    """:func:`bend_sweep` in the x–z plane (today's)."""
    nodes = check_nodes(nodes)
    if (forces is None) == (speeds is None):
        raise v.fail("bend_sweep", "both or neither of forces/speeds", "given forces or speeds")
    if speeds is not None and flow is None:
        raise v.fail("flow", None, "a Flow when sweeping speeds")
    given = forces if forces is not None else speeds
    assert given is not None  # for mypy: exactly one of them is set (checked above)
    values = v.finite_array("forces" if forces is not None else "speeds", given, ndim=1)
    if values.size == 0:
        raise v.fail("forces", "an empty array", "at least one load")
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


def tip_compliance(setup: Setup) -> float:
    """Small-load tip compliance, m/N: ``L³ / (3 E I₀ λ)`` for a frustum (λ = tip/base radius),
    ``∫ (L − s)² / (E I(s)) ds`` for a measured profile.

    Infinite for a sharp cone (λ = 0).
    """
    c = setup.cilium
    if c.tip_radius == 0.0:
        return math.inf
    if c.profile is not None:  # ∫ (L − s)² / (E I(s)) ds, exact for a piecewise-linear r(s)
        return compliance_integral(c) / setup.youngs_modulus
    i0 = float(c.second_moment(0.0))
    return c.height**3 / (3.0 * setup.youngs_modulus * i0 * c.taper)


def poses_at(setup: Setup, quantity: str, values: ArrayLike, flow: Flow | None = None,
             actuation: Actuation | None = None) -> tuple[Pose, float]:
    """The cilium's poses at ``values`` (shape (a,), SI) of a measurand, and the azimuth (rad)
    to evaluate them at (:meth:`magcilia.Setup.field`): rigid tilt angles (``"angle"``, rad; an
    actuation does not bend a rigid tilt), dead tip forces along +x (``"force"``, N) or flow
    speeds (``"flow"``, m/s, the profile of ``flow`` scaled to each speed, from its azimuth;
    default uniform water flow), as sweeps continued from one load to the next (increasing
    values are cheapest), bent by ``actuation`` too when one is given."""
    q = v.finite_array("values", values, ndim=1)
    if quantity == "angle":
        return q, 0.0
    if quantity not in ("force", "flow"):
        raise v.fail("quantity", quantity, "one of 'angle', 'force', 'flow'")
    if quantity == "force":
        if actuation is not None:
            return bend_sweep(setup, forces=q, actuation=actuation), 0.0
        return _sweep_plane(setup, forces=q), 0.0
    flow = flow or Flow.uniform(1.0)
    if actuation is not None:
        return bend_sweep(setup, speeds=q, flow=flow, actuation=actuation), 0.0
    if flow.azimuth != 0.0:  # the x–z sweep turned: the model's azimuth (Setup.output)
        return _sweep_plane(setup, speeds=q, flow=flow.with_azimuth(0.0)), flow.azimuth
    return _sweep_plane(setup, speeds=q, flow=flow), 0.0


def output_at(setup: Setup, quantity: str, values: ArrayLike, flow: Flow | None = None) -> F64:
    """Sensor output (V), shape (a,), at ``values`` (shape (a,), SI) of a measurand: rigid tilt
    angles (``"angle"``, rad), dead tip forces along +x (``"force"``, N; a sweep continued from
    one load to the next, so increasing values are cheapest) or flow speeds (``"flow"``, m/s, the
    profile of ``flow`` scaled to each speed, from its azimuth; default uniform water flow):
    :func:`poses_at` through :meth:`magcilia.Setup.output`."""
    pose, azimuth = poses_at(setup, quantity, values, flow)
    return setup.output(pose, azimuth=azimuth)
