"""Bends of many magnetized cilia under many uniform fields at once: the coil calibration's model.

A coil experiment (:class:`~magcilia.calibration.experiments.CoilExperiment`) needs the bent
shapes of ``N`` parameter sets (height, base radius, Young's modulus, magnetization) under ``a``
applied uniform fields each. :func:`field_batch` solves all ``N · a`` equilibria together: the
same elastica as :func:`magcilia.bend` with ``actuation=Actuation.uniform(B)``
(:mod:`magcilia.mechanics.elastica`: the cilium magnetized along its tangent, the field's couple
per length ``μ(s) t × B`` with ``μ(s) = M π r(s)²``), the same Chebyshev collocation on the
normalised grid of :func:`~magcilia.mechanics.batched.sweep_batch`, Newton to the same 1e-12 rad
residual, every system's step in one stacked LAPACK solve.

A uniform field's couple bends the cilium in the vertical plane of ``e_z`` and the field's
horizontal part (azimuth ``ψ = atan2(B_y, B_x)``): in that plane the field is
``(b_h, b_z) = (|B_xy|, B_z)`` and the problem is the planar elastica
``θ = P g(θ)``, ``g = μ (b_h cos θ − b_z sin θ)`` (a couple: pointwise in g, not through the
internal force), ``P = (L² / (E I₀)) Ĉ diag(I₀ / I) R̂``. Its Jacobian is
``I + P diag(μ (b_h sin θ + b_z cos θ))``. A field along the axis (``b_h = 0``) leaves the
straight rod in equilibrium; beyond :func:`~magcilia.mechanics.spatial.flip_field` against the
magnetization that equilibrium is unstable: callers drop such fields (the coil readers flag
them), this solver returns the straight rod for them as for any axial field.

Start and fall-back. Each system starts from :func:`magcilia.bend`'s guess (the linear-beam
angles saturated at the field's direction); a system Newton does not converge for is solved
again by load continuation (the field scaled up in eighths, each step started from the last),
and a set whose continuation fails too is reported as not converged (``ok`` False).

All SI: lengths in m, fields in T, moments per length in A·m, moduli in Pa, angles in rad.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np
from numpy.typing import NDArray

from magcilia.device.setup import Setup
from magcilia.mechanics.batched import _inverses, _Normalised
from magcilia.mechanics.planar import OUTPUT_POINTS

F64 = NDArray[np.float64]

#: Newton's residual tolerance, rad (as :func:`magcilia.mechanics.elastica.newton`)
TOLERANCE = 1e-12
#: Newton steps a system is given from one start
MAX_ITERATIONS = 40
#: load-continuation steps of a system Newton does not converge for from the guess
CONTINUATION_STEPS = 8


@dataclass(frozen=True)
class FieldShapes:
    """Bent shapes of ``N`` magnetized cilia under ``a`` uniform fields (:func:`field_batch`).

    Attributes
    ----------
    s : ndarray, shape (N, m)
        Arc lengths of each set's output grid (m = :data:`OUTPUT_POINTS`), m.
    angles : ndarray, shape (N, a, m)
        Tangent angles in the field's vertical plane, from +z toward the field's horizontal
        direction, rad (NaN where ``ok`` is False).
    points : ndarray, shape (N, a, m, 3)
        Points relative to the base centre in that plane's frame (x along the field's
        horizontal direction, y = 0), m (NaN where ``ok`` is False).
    planes : ndarray, shape (a,)
        Each field's plane azimuth ψ = atan2(B_y, B_x), rad (0 for a field along the axis).
    ok : ndarray of bool, shape (N,)
        Whether every field of the set converged.
    continued : int
        Systems Newton did not converge for from the guess, solved by continuation instead.
    """

    s: F64
    angles: F64
    points: F64
    planes: F64
    ok: NDArray[np.bool_]
    continued: int


def in_plane(fields: F64) -> tuple[F64, F64, F64]:
    """Each field's plane azimuth ψ (a,), rad, horizontal magnitude b_h ≥ 0 and vertical part
    b_z (a,), T, for fields (a, 3), T, board frame."""
    b = np.asarray(fields, dtype=np.float64).reshape(-1, 3)
    horizontal = np.hypot(b[:, 0], b[:, 1])
    planes = np.where(horizontal > 0.0, np.arctan2(b[:, 1], b[:, 0]), 0.0)
    return planes, horizontal, b[:, 2].copy()


def field_batch(setup: Setup, heights: F64, base_radii: F64, moduli: F64, magnetizations: F64,
                fields: F64) -> FieldShapes:
    """Bent shapes of ``N`` cilia magnetized along their tangent under ``a`` uniform fields, as
    :func:`magcilia.bend` gives them with ``actuation=Actuation.uniform(B)`` (to Newton's
    tolerance).

    Parameters
    ----------
    setup : Setup
        Supplies the cilium's shape (a frustum's tip radius, m, or a profile's normalised
        shape); its height, base radius, modulus and magnetization are replaced by each set's.
    heights, base_radii, moduli : ndarray, shape (N,)
        Each set's height (m), base radius (m) and Young's modulus (Pa), each a valid setup (the
        caller checks: a frustum's base radius above a positive tip radius).
    magnetizations : ndarray, shape (N,)
        Each set's magnetization M along the tangent, A/m (``setup.spec.magnetization`` at its
        magnetization scale).
    fields : ndarray, shape (a, 3)
        The applied uniform fields, T, board frame.

    Returns
    -------
    FieldShapes
        Shapes (N, a, m) in each field's plane; a set's rows NaN and ``ok`` False where a bend
        does not converge.
    """
    heights, base_radii, moduli, mags = (np.asarray(x, dtype=np.float64).ravel()
                                         for x in (heights, base_radii, moduli, magnetizations))
    planes, bh, bz = in_plane(fields)
    n_set, n_field = heights.size, planes.size
    cilium = setup.cilium
    tapers = cilium.tip_radius / base_radii if cilium.profile is None else np.ones(n_set)
    thin = int(np.argmin(tapers)) if n_set else 0
    norm = _Normalised(replace(cilium, height=float(heights[thin]),
                               base_radius=float(base_radii[thin])), False) if n_set else None
    s_out = heights[:, None] * np.linspace(0.0, 1.0, OUTPUT_POINTS)
    angles = np.full((n_set, n_field, OUTPUT_POINTS), np.nan)
    points = np.full((n_set, n_field, OUTPUT_POINTS, 3), np.nan)
    if norm is None or not n_field:
        return FieldShapes(s_out, angles, points, planes, np.ones(n_set, dtype=bool), 0)
    rho, inertia = norm.shape(tapers)
    scale = heights**2 / (moduli * (0.25 * math.pi) * base_radii**4)
    influence = (norm.C * (scale[:, None] / inertia)[:, None, :]) @ norm.R  # (N, n, n)
    mu = (mags * math.pi * base_radii**2)[:, None] * rho**2  # μ(s) at the nodes, A·m (N, n)
    n = norm.s.size
    sets = np.repeat(np.arange(n_set), n_field)
    fh, fz = np.tile(bh, n_set), np.tile(bz, n_set)
    system = _Couples(influence, mu)
    theta, done = system.newton(sets, fh, fz, system.guess(sets, fh, fz))
    continued = int((~done).sum())
    for j in np.flatnonzero(~done):  # continuation from the straight rod in eighths
        one = np.array([sets[j]])
        th = np.zeros((1, n))
        ok = np.ones(1, dtype=bool)
        for lam in np.arange(1, CONTINUATION_STEPS + 1) / CONTINUATION_STEPS:
            th, ok = system.newton(one, fh[j:j + 1] * lam, fz[j:j + 1] * lam, th)
            if not ok[0]:
                break
        if ok[0]:
            theta[j], done[j] = th[0], True
    done2 = done.reshape(n_set, n_field)
    ok_set = np.asarray(done2.all(axis=1), dtype=bool)
    good = np.flatnonzero(ok_set)
    if good.size:
        rows = (good[:, None] * n_field + np.arange(n_field)).ravel()
        th = theta[rows]
        g = system.moment(sets[rows], fh[rows], fz[rows], th)
        length = heights[sets[rows], None]
        stiff = (0.25 * math.pi) * moduli[sets[rows], None] * base_radii[sets[rows], None] ** 4 \
            * inertia[sets[rows]]
        kappa = length * (g @ norm.R.T) / stiff  # M / EI at the nodes, 1/m
        cum = norm.cum
        ang = (length * (kappa @ cum.T)).reshape(good.size, n_field, OUTPUT_POINTS)
        px = (length * (np.sin(th) @ cum.T)).reshape(good.size, n_field, OUTPUT_POINTS)
        pz = (length * (np.cos(th) @ cum.T)).reshape(good.size, n_field, OUTPUT_POINTS)
        ang[:, :, 0] = 0.0  # clamped base, exactly (as bend)
        px[:, :, 0] = 0.0
        pz[:, :, 0] = 0.0
        angles[good] = ang
        points[good, :, :, 0] = px
        points[good, :, :, 1] = 0.0
        points[good, :, :, 2] = pz
    return FieldShapes(s_out, angles, points, planes, ok_set, continued)


class _Couples:
    """The planar equilibria θ = P g(θ) of a batch under uniform fields' couples: ``N`` sets
    (influence matrices (N, n, n), μ at the nodes (N, n)), systems indexed by their set."""

    def __init__(self, influence: F64, mu: F64) -> None:
        self.influence, self.mu = influence, mu

    def moment(self, sets: NDArray[np.intp], bh: F64, bz: F64, theta: F64) -> F64:
        """g = μ (b_h cos θ − b_z sin θ), N, (b, n)."""
        return np.asarray(self.mu[sets] * (bh[:, None] * np.cos(theta)
                                           - bz[:, None] * np.sin(theta)), dtype=np.float64)

    def guess(self, sets: NDArray[np.intp], bh: F64, bz: F64) -> F64:
        """:func:`magcilia.bend`'s start: the linear-beam angles saturated at the field's
        direction from +z, (b, n)."""
        lin = np.einsum("bij,bj->bi", self.influence[sets], self.mu[sets] * bh[:, None])
        limit = np.arctan2(bh, bz)[:, None]
        safe = np.where(limit > 0.0, limit, 1.0)
        return np.asarray(np.where(limit > 0.0, safe * np.tanh(lin / safe), 0.0),
                          dtype=np.float64)

    def newton(self, sets: NDArray[np.intp], bh: F64, bz: F64, theta: F64
               ) -> tuple[F64, NDArray[np.bool_]]:
        """Newton for the systems ``sets`` (b,) under fields (b_h, b_z) (b,) from ``theta``
        (b, n): the angles and which converged (b,). Steps damped to a radian; a system is given
        up after three rising residuals or a non-finite one."""
        b = sets.size
        theta = np.array(theta, dtype=np.float64)
        done = np.zeros(b, dtype=bool)
        failed = np.zeros(b, dtype=bool)
        prev = np.full(b, np.inf)
        worse = np.zeros(b, dtype=np.int64)
        active = np.arange(b)
        n = theta.shape[1]
        diag = (slice(None), np.arange(n), np.arange(n))
        for _ in range(MAX_ITERATIONS):
            s = sets[active]
            P = self.influence[s]
            th = theta[active]
            g = self.moment(s, bh[active], bz[active], th)
            minus = np.einsum("bij,bj->bi", P, g) - th
            err = np.abs(minus).max(axis=1)
            conv = err < TOLERANCE
            done[active[conv]] = True
            worse[active] = np.where(err > prev[active], worse[active] + 1, 0)
            bad = ~conv & (~np.isfinite(err) | (worse[active] >= 3))
            failed[active[bad]] = True
            keep = ~conv & ~bad
            prev[active] = err
            active, minus, P, th = active[keep], minus[keep], P[keep], th[keep]
            if not active.size:
                break
            mu = self.mu[sets[active]]
            d = mu * (bh[active, None] * np.sin(th) + bz[active, None] * np.cos(th))
            jac = P * d[:, None, :]
            jac[diag] += 1.0
            step = np.einsum("bij,bj->bi", _inverses(jac), minus)
            size = np.abs(step).max(axis=1)
            lost = ~np.isfinite(size)
            step *= np.where(size > 1.0, 1.0 / np.where(size > 1.0, size, 1.0), 1.0)[:, None]
            theta[active] += np.where(lost[:, None], 0.0, step)
            failed[active[lost]] = True
            active = active[~lost]
        return theta, done & ~failed
