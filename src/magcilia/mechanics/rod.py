"""Static inextensible rod in 3-D by spectral collocation (pure arrays; :func:`magcilia.bend`
checks its input).

For loads that do not lie in one vertical plane (a field with a component normal to the plane of
the other loads, a non-uniform source field, a force and a flow from different azimuths).

Isotropic, inextensible, unshearable rod clamped at s = 0 along +z, free at s = L, unit tangent
t(s), position ``r(s) = ∫₀ˢ t``. Loads: a dead point force F at arc length a, a distributed force
f(s) (drag, the magnetic force ``μ (t·∇)B``) and a distributed couple c(s) (the magnetic couple
``μ t × B``). The internal force and moment carried across a section are::

    N(s) = ∫ₛᴸ f dσ + F H(a − s),      M(s) = ∫ₛᴸ (t × N + c) dσ.

With no twisting loads (c ⊥ t, so the twist moment M·t stays 0 from the free tip) the bending law
``EI t × t' = M`` gives ``t' = (M × t) / EI``, and the integral form solved here is::

    t = e_z + C[(M × t) / EI],   M = R(t × N + c),   N = R f + F H,

on the planar solver's Chebyshev grid (:class:`magcilia.mechanics.elastica.Grid`: ``C``
integrates from the base, ``R`` to the tip) with the 3N nodal tangent components as unknowns.
|t| = 1 is not imposed: the integral form keeps it to the collocation accuracy (t' ⊥ t), and the
tests check it. Newton's method with a Jacobian by batched central differences (one batched
residual of 6N tangent fields per step, field evaluations included), and load continuation through
:func:`magcilia.mechanics.elastica.solve`. For in-plane loads it reproduces the planar solver
(tip within ~1e-12 relative; ``tests/mechanics/test_rod3d.py``).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass
from typing import NamedTuple

import numpy as np
from numpy.typing import NDArray

from magcilia.mechanics.drag import drag_per_length, wall_log
from magcilia.mechanics.elastica import Grid, dense_solve
from magcilia.mechanics.flow import Flow

F64 = NDArray[np.float64]
_EZ = np.array([0.0, 0.0, 1.0])
#: central-difference step of the Newton Jacobian, in tangent components
_JAC_STEP = 1e-7


@dataclass(frozen=True)
class Rod:
    """What a 3-D load case keeps fixed (all SI).

    Parameters
    ----------
    grid : Grid
        Collocation grid (N nodes).
    ei : ndarray, shape (N,)
        Bending stiffness at the nodes, N·m².
    diameter : ndarray, shape (N,)
        Local diameter, m.
    loaded : ndarray, shape (N,)
        1 where s < a (the point force is carried across the section), else 0.
    moment : ndarray, shape (N,)
        Magnetic moment per length μ(s) = M π r(s)², A·m.
    base : ndarray, shape (3,)
        Board position of the base centre, m (where a source's field is evaluated from).
    free_log : ndarray, shape (N,)
        The free rod's slender-body logarithm at the nodes (drag at low Re).
    """

    grid: Grid
    ei: F64
    diameter: F64
    loaded: F64
    moment: F64
    base: F64
    free_log: F64

    @property
    def length(self) -> float:
        """Rod length L, m."""
        return float(self.grid.bounds[-1])


@dataclass(frozen=True)
class RodLoads:
    """The loads of a 3-D case at full size (a load factor scales them all).

    Parameters
    ----------
    force : ndarray, shape (3,)
        Dead point force, N.
    flow : Flow or None
        Horizontal flow (its own azimuth).
    uniform : ndarray, shape (3,), or None
        A uniform field, T (couple only).
    field : callable or None
        ``field(points (..., 3)) -> B (..., 3)``, T, board frame (a source's field).
    directional : callable or None
        ``directional(points, d) -> (d·∇)B``, T/m, shapes (..., 3).
    """

    force: F64
    flow: Flow | None = None
    uniform: F64 | None = None
    field: Callable[[F64], F64] | None = None
    directional: Callable[[F64, F64], F64] | None = None


class FieldError(ValueError):
    """A source's field is not finite at a point of the rod (``point``: board frame, m)."""

    def __init__(self, point: F64) -> None:
        super().__init__("non-finite field")
        self.point = point


def _cross(a: F64, b: F64) -> F64:
    """Cross product over the last axis (faster than np.cross for small arrays)."""
    out = np.empty(np.broadcast_shapes(a.shape, b.shape))
    out[..., 0] = a[..., 1] * b[..., 2] - a[..., 2] * b[..., 1]
    out[..., 1] = a[..., 2] * b[..., 0] - a[..., 0] * b[..., 2]
    out[..., 2] = a[..., 0] * b[..., 1] - a[..., 1] * b[..., 0]
    return out


class RodState(NamedTuple):
    """Derived fields of a batch of nodal tangents (b, N, 3), SI."""

    points: F64  #: positions from the base centre, m
    torque: F64  #: t × N + c, the moment density, N
    moment: F64  #: M = R(t × N + c), N·m
    curvature: F64  #: t' = (M × t) / EI, 1/m


@dataclass(frozen=True)
class RodProblem:
    """The 3-D case at load factor ``lam`` (unknowns: the nodal tangents, flattened (3N,))."""

    rod: Rod
    loads: RodLoads
    lam: float

    def parts(self, tangents: F64) -> RodState:
        """Positions, moment density, moment and curvature of nodal tangents (b, N, 3)."""
        rod, loads, lam = self.rod, self.loads, self.lam
        grid = rod.grid
        t = tangents
        r = np.matmul(grid.C, t)
        dist = np.zeros(t.shape)
        couple = np.zeros(t.shape)
        mu = rod.moment[:, None]
        if loads.uniform is not None:
            couple = mu * _cross(t, lam * loads.uniform)
        elif loads.field is not None and loads.directional is not None:
            pts = rod.base + r
            b = loads.field(pts)
            if not np.all(np.isfinite(b)):
                raise FieldError(pts[~np.isfinite(b).all(axis=-1)][0])
            couple = lam * mu * _cross(t, b)
            dist = dist + lam * mu * loads.directional(pts, t)
        if loads.flow is not None and loads.flow.speed != 0.0:
            dist = dist + self._drag(t, r[..., 2])
        n = np.matmul(grid.R, dist) + (lam * loads.force) * rod.loaded[:, None]
        torque = _cross(t, n) + couple
        m = np.matmul(grid.R, torque)
        return RodState(r, torque, m, _cross(m, t) / rod.ei[:, None])

    def _drag(self, t: F64, z: F64) -> F64:
        """Drag per length (b, N, 3), N/m, along the normal velocity component: the planar
        solver's law applied to |U_n|, ``U_n = U − (U·t̂) t̂``."""
        rod = self.rod
        flow = self.loads.flow
        assert flow is not None  # for mypy: checked by the caller
        u = (self.lam * flow.speed) * np.asarray(flow.shape(z), dtype=np.float64)
        vel = u[..., None] * flow.direction
        unit = t / np.linalg.norm(t, axis=-1, keepdims=True)
        un_vec = vel - np.sum(vel * unit, axis=-1, keepdims=True) * unit
        un = np.linalg.norm(un_vec, axis=-1)
        d, length = rod.diameter, rod.length
        q = drag_per_length(un, d, flow.fluid,
                            lambda: rod.free_log - wall_log(z, 0.5 * d, length))
        ratio = np.divide(q, un, out=np.zeros_like(q), where=un > 0.0)
        return np.asarray(ratio[..., None] * un_vec, dtype=np.float64)

    def residual(self, theta: F64, scale: float = 1.0) -> F64:  # noqa: ARG002 (Steppable's)
        """``t − e_z − C[(M × t)/EI]`` for flattened tangents (3N,) or a batch (b, 3N); the load
        factor is the problem's ``lam`` (``scale`` is unused)."""
        t = theta.reshape(*theta.shape[:-1], -1, 3)
        batch = t if t.ndim == 3 else t[None]
        res = batch - _EZ - np.matmul(self.rod.grid.C, self.parts(batch).curvature)
        return np.asarray(res.reshape(theta.shape), dtype=np.float64)

    def newton_step(self, theta: F64, scale: float, tol: float) -> tuple[float, F64 | None]:
        """Largest |residual| at ``theta`` (3N,) and the Newton step (3N,) from a central-
        difference Jacobian (one batched residual); the step is None once the residual is below
        ``tol``, if it is not finite, or if the Jacobian is singular."""
        r = self.residual(theta, scale)
        err = float(np.abs(r).max())
        if not tol <= err < math.inf:
            return err, None
        n = theta.size
        eye = np.eye(n) * _JAC_STEP
        res = self.residual(theta + np.concatenate([eye, -eye]), scale)
        jac = (res[:n] - res[n:]).T / (2.0 * _JAC_STEP)
        step = dense_solve(jac, r)
        return err, (None if step is None else -step)


def linear_guess(rod: Rod, loads: RodLoads) -> F64:
    """Start for Newton (N, 3): the small-deflection tangents of the straight rod under the full
    loads, ``e_z + C[(M₀ × e_z)/EI]``, normalised (which saturates them below 90°)."""
    straight = np.broadcast_to(_EZ, (rod.grid.s.size, 3)).copy()
    kappa = RodProblem(rod, loads, 1.0).parts(straight[None]).curvature[0]
    t = straight + rod.grid.C @ kappa
    return np.asarray(t / np.linalg.norm(t, axis=-1, keepdims=True), dtype=np.float64)


def straight(rod: Rod) -> F64:
    """Nodal tangents of the straight rod, (N, 3)."""
    return np.broadcast_to(_EZ, (rod.grid.s.size, 3)).copy()

