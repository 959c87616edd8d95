"""Planar bends of many cilia under many loads at once: the calibration's load experiments.

A load experiment's model needs the bent shapes of ``N`` parameter sets (height, base radius,
Young's modulus; the cilium's profile otherwise shared) under ``a`` loads each: tip forces along
+x or flow speeds of one profile. :func:`sweep_batch` solves all ``N · a`` equilibria together:
the same elastica as :func:`magcilia.bend` (:mod:`magcilia.mechanics.elastica`: θ = P g(θ), the
same Chebyshev collocation, Newton to the same 1e-12 rad residual), with the Newton steps of
every system in one stacked LAPACK solve a step instead of one Python loop per load and set.

Scaling. Every set of a batch shares the normalised grid (nodes ŝ = s / L on [0, 1]; a frustum's
one piece takes the most nodes :func:`~magcilia.mechanics.sections.piece_nodes` asks of any
set's taper, a profile its own, exactly scaled): ``C = L Ĉ``, ``R = L R̂`` and
``P = (L² / (E I₀)) Ĉ diag(I₀ / I) R̂``, ``I₀ = π r₀⁴ / 4``; a set differs only by its three
numbers and, for a frustum, its taper ``r_tip / r₀``.

Start and fall-back. Each system starts from :func:`magcilia.bend`'s guess (the linear-beam
angles saturated at π/2). A system Newton does not converge for (a load beyond where the
saturated guess leads, rare at a calibration's loads) is solved again by the sweep of that set
(:func:`magcilia.bend_sweep`: load continuation), so every result is the one ``bend`` gives;
a set whose sweep fails too is reported as not converged (``ok`` False).

Jacobians. A point force's is analytic (``I + P diag(F_x sin θ + F_z cos θ)``). The drag of a
flow ``q_j = Q(cos θ_j, z_j)`` is pointwise in the node's normal speed and height
(:mod:`magcilia.mechanics.drag`), and ``z = C cos θ``; so its Jacobian is analytic but for the
two pointwise partial derivatives ``∂Q/∂c`` and ``∂Q/∂z``, taken by one forward difference
each (a whole batch in one drag evaluation; they only steer Newton, the residual is exact).

All SI: lengths in m, forces in N, speeds in m/s, angles in rad, moduli in Pa.
"""

from __future__ import annotations

import contextlib
import math
from dataclasses import dataclass, replace

import numpy as np
from numpy.typing import NDArray

from magcilia._errors import MagciliaError
from magcilia.device.cilium import Cilium
from magcilia.device.setup import Setup
from magcilia.mechanics.drag import drag_per_length, free_log, wall_log
from magcilia.mechanics.elastica import Grid, _uniform_reference
from magcilia.mechanics.flow import Flow
from magcilia.mechanics.planar import OUTPUT_POINTS, _extrapolate, _sweep_plane
from magcilia.mechanics.sections import piece_nodes, sections

F64 = NDArray[np.float64]

#: Newton's residual tolerance, rad (as :func:`magcilia.mechanics.elastica.newton`)
TOLERANCE = 1e-12
#: Newton steps a system is given before it is handed to the sweep (load continuation)
MAX_ITERATIONS = 40
#: a chord step (the inverse Jacobian of an earlier iterate or load reused) must shrink every
#: residual at least by this factor, else the next step forms the Jacobian again: along a sweep
#: (the previous load's inverse; a new Jacobian costs little against the sweep's rounds) …
CHORD_RATE = 0.1
#: … and from a nearby set's solution and inverse, every load at once (each round costs little
#: against a Jacobian of every system: 0.3 halved the time per population against 0.1)
START_CHORD_RATE = 0.3
#: relative step of the forward differences of the drag's pointwise partial derivatives
DRAG_STEP = 1e-7
#: a frustum batch started from an earlier batch's grid keeps that grid's node count when it is
#: at most this many nodes above what its thinnest taper asks (more nodes: at least as accurate);
#: so nearby populations share one grid and its inverse Jacobians (not formed again)
NODE_SLACK = 4


@dataclass(frozen=True)
class BatchShapes:
    """Bent shapes of ``N`` parameter sets under ``a`` loads (:func:`sweep_batch`).

    Attributes
    ----------
    s : ndarray, shape (N, m)
        Arc lengths of each set's output grid (m = :data:`OUTPUT_POINTS`), m.
    angles : ndarray, shape (N, a, m)
        Tangent angles from +z toward +x, rad (NaN where ``ok`` is False).
    points : ndarray, shape (N, a, m, 3)
        Points relative to the base centre, m (NaN where ``ok`` is False).
    ok : ndarray of bool, shape (N,)
        Whether every load of the set converged.
    swept : int
        Systems Newton did not converge for from the guess, solved by the sweep instead.
    theta : ndarray, shape (N, a, n)
        The nodal angles of the batch's grid (n nodes), rad, NaN for a set solved by the sweep
        or not converged: a start for a nearby batch (:func:`sweep_batch`'s ``start``).
    nodes : ndarray, shape (n,)
        That grid's nodes, s / L (dimensionless, on [0, 1]).
    inverse : ndarray, shape (N, a, n, n), or None
        The inverse Jacobians of the last Newton steps (when every load was solved at once from
        a start; NaN where not formed): :func:`sweep_batch`'s ``start_inverse`` for a nearby
        batch.
    """

    s: F64
    angles: F64
    points: F64
    ok: NDArray[np.bool_]
    swept: int
    theta: F64
    nodes: F64
    inverse: F64 | None = None


class _Normalised:
    """The shared normalised grid of a batch: nodes ŝ (n,), Ĉ, R̂ (n, n), the output map
    ĉum (m, n) (∫₀^ŝ of the interpolant at the uniform output points), all on [0, 1]; and
    :meth:`shape`: r / r₀ and I / I₀ at the nodes of each set."""

    def __init__(self, cilium: Cilium, point_load: bool, nodes: int | None = None) -> None:
        length, r0 = cilium.height, cilium.base_radius
        self.frustum = cilium.profile is None
        if self.frustum:  # the most nodes any set's taper asks for (``cilium``: the thinnest),
            n = piece_nodes(cilium, np.array([0.0, length]))[0]  # or an earlier grid's ``nodes``
            if nodes is not None and n <= nodes <= n + NODE_SLACK:
                n = nodes
            grid = Grid.build(np.array([0.0, 1.0]), (n,))
            self.cum: F64 = 0.5 * _uniform_reference(n, OUTPUT_POINTS)
        else:  # a profile: the shape is shared (normalised), its sections exact or resampled
            sec = sections(cilium, length, point_load, None)
            grid = Grid.build(sec.grid.bounds / length, sec.grid.sizes)
            self.cum = grid.uniform_output(OUTPUT_POINTS)[1]
            self.rho = np.asarray(sec.radius / r0)
            self.inertia = np.asarray(sec.second_moment / (0.25 * math.pi * r0**4))
        self.s, self.C, self.R = grid.s, grid.C, grid.R

    def shape(self, tapers: F64) -> tuple[F64, F64]:
        """r / r₀ (N, n) and I / I₀ (N, n) at the nodes, for a frustum's tapers (N,)."""
        if self.frustum:
            rho = 1.0 - (1.0 - tapers[:, None]) * self.s
            return rho, rho**4
        return (np.broadcast_to(self.rho, (tapers.size, self.s.size)),
                np.broadcast_to(self.inertia, (tapers.size, self.s.size)))


def sweep_batch(setup: Setup, heights: F64, base_radii: F64, moduli: F64, loads: F64, *,
                flow: Flow | None = None, start: F64 | None = None,
                start_nodes: F64 | None = None,
                start_inverse: F64 | None = None) -> BatchShapes:
    """Bent shapes of ``N`` cilia under ``a`` loads: tip forces along +x (``flow`` None) or
    speeds of ``flow``'s profile, in the x–z plane, as :func:`magcilia.bend_sweep` gives them
    (to Newton's tolerance).

    Parameters
    ----------
    setup : Setup
        Supplies the cilium's shape (a frustum's tip radius, m, or a profile's normalised
        shape); its height, base radius and modulus are replaced by each set's.
    heights, base_radii, moduli : ndarray, shape (N,)
        Each set's height (m), base radius (m) and Young's modulus (Pa); each a valid setup
        (the caller checks: a frustum's base radius above its tip radius).
    loads : ndarray, shape (a,)
        Tip forces, N (along +x), or flow speeds, m/s (scaling ``flow``'s profile).
    flow : Flow, optional
        The flow whose speed is swept (its azimuth is not used: the x–z plane); None: forces.
    start : ndarray, shape (N, a, n), optional
        Nodal angles (rad) to start Newton from, every load at once: the :attr:`BatchShapes.theta`
        of nearby sets (a calibration's next population; a NaN row: :func:`magcilia.bend`'s
        guess for that load); a set that does not converge from it is swept as without it.
    start_nodes : ndarray, shape (n,), optional
        The nodes (s / L) of ``start``'s grid (:attr:`BatchShapes.nodes`), when its node count
        is not this batch's (a batch's grid follows its thinnest taper): ``start`` is then
        carried over to this grid by linear interpolation.
    start_inverse : ndarray, shape (N, a, n, n), optional
        The inverse Jacobians at ``start`` (:attr:`BatchShapes.inverse`): Newton's first steps
        are chord steps with them (no Jacobian formed while the residuals fall tenfold a step).

    Returns
    -------
    BatchShapes
        Shapes (N, a, m); a set's rows NaN and ``ok`` False where its bend does not converge.
    """
    heights, base_radii, moduli = (np.asarray(x, dtype=np.float64).ravel()
                                   for x in (heights, base_radii, moduli))
    loads = np.asarray(loads, dtype=np.float64).ravel()
    n_set, n_load = heights.size, loads.size
    cilium = setup.cilium
    tapers = (cilium.tip_radius / base_radii if cilium.profile is None else np.ones(n_set))
    thin = int(np.argmin(tapers))
    norm = _Normalised(replace(cilium, height=float(heights[thin]),
                               base_radius=float(base_radii[thin])), flow is None,
                       None if start is None or start_nodes is None else np.size(start_nodes))
    rho, inertia = norm.shape(tapers)
    # P = (L² / (E I₀)) Ĉ diag(I₀ / I) R̂, one per set: (N, n, n)
    scale = heights**2 / (moduli * (0.25 * math.pi) * base_radii**4)
    influence = (norm.C * (scale[:, None] / inertia)[:, None, :]) @ norm.R
    system = _Systems(norm, heights, base_radii, moduli, rho, inertia, influence, flow)
    n = norm.s.size
    if start is not None and start_nodes is not None and start.shape[2] != n:
        start = start @ _linear_map(np.asarray(start_nodes, dtype=np.float64), norm.s).T
        start_inverse = None  # another grid's
    inverse = None
    if start is not None and start.shape == (n_set, n_load, n):
        if start_inverse is not None and start_inverse.shape != (n_set, n_load, n, n):
            start_inverse = None
        theta, done, inverse = system.from_start(loads, start, start_inverse)
        redo = np.flatnonzero(~done.all(axis=1))
        if redo.size:
            theta[redo], done[redo] = system.sweep(loads, redo)
    else:
        theta, done = system.sweep(loads)
    ok = np.asarray(done.all(axis=1), dtype=bool)
    s_out = heights[:, None] * np.linspace(0.0, 1.0, OUTPUT_POINTS)
    angles = np.full((n_set, n_load, OUTPUT_POINTS), np.nan)
    points = np.full((n_set, n_load, OUTPUT_POINTS, 3), np.nan)
    points[:, :, :, 1] = 0.0  # the x–z plane
    good = np.flatnonzero(ok)
    if good.size:
        th = theta[good]
        kappa = system.curvature(np.repeat(good, n_load), np.tile(loads, good.size),
                                 th.reshape(-1, n)).reshape(good.size, n_load, n)  # 1/m
        length = heights[good, None, None]
        angles[good] = length * (kappa @ norm.cum.T)
        points[good, :, :, 0] = length * (np.sin(th) @ norm.cum.T)
        points[good, :, :, 2] = length * (np.cos(th) @ norm.cum.T)
        angles[good, :, 0] = 0.0  # clamped base, exactly (as bend)
        points[good, :, 0] = 0.0
    swept = 0
    theta[~ok] = np.nan  # not on this grid's Newton: no start for a later batch
    for i in np.flatnonzero(~ok):  # what Newton did not reach from the guess: the sweep's way
        swept += int((~done[i]).sum())
        one = _one_sweep(setup, float(heights[i]), float(base_radii[i]), float(moduli[i]),
                         loads, flow)
        if one is not None:
            angles[i], points[i] = one
            ok[i] = True
    if inverse is not None:
        inverse[~ok] = np.nan
    return BatchShapes(s_out, angles, points, ok, swept, theta, norm.s, inverse)


def _linear_map(old: F64, new: F64) -> F64:
    """Matrix (q, p): values at the points ``new`` (q,) of the piecewise-linear interpolant of
    values at the increasing points ``old`` (p,) (constant beyond the ends)."""
    x = np.clip(new, old[0], old[-1])
    j = np.clip(np.searchsorted(old, x, side="right") - 1, 0, old.size - 2)
    t = (x - old[j]) / (old[j + 1] - old[j])
    out = np.zeros((new.size, old.size))
    rows = np.arange(new.size)
    out[rows, j] = 1.0 - t
    out[rows, j + 1] += t
    return out


def _one_sweep(setup: Setup, height: float, base_radius: float, modulus: float, loads: F64,
               flow: Flow | None) -> tuple[F64, F64] | None:
    """One set's shapes (a, m), (a, m, 3) by the sweep (load continuation), None if it fails."""
    try:
        one = setup.replace(height=height, base_radius=base_radius, youngs_modulus=modulus)
        if flow is None:
            shapes = _sweep_plane(one, forces=loads)
        else:
            shapes = _sweep_plane(one, speeds=loads, flow=flow.with_azimuth(0.0))
    except MagciliaError:
        return None
    return shapes.angles, shapes.points


class _Systems:
    """The equilibria of a batch: ``N`` sets, each under one load value at a time (a sweep)."""

    def __init__(self, norm: _Normalised, heights: F64, base_radii: F64, moduli: F64, rho: F64,
                 inertia: F64, influence: F64, flow: Flow | None) -> None:
        self.norm, self.flow = norm, flow
        self.heights, self.influence = heights, influence
        self.stiff_inv = 1.0 / ((0.25 * math.pi) * moduli[:, None] * base_radii[:, None] ** 4
                                * inertia)  # 1 / EI at the nodes, (N, n)
        if flow is not None:
            length = heights[:, None]
            self.radius = base_radii[:, None] * rho  # (N, n), m
            self.free = free_log(length * norm.s, self.radius, length)  # (N, n)

    # -- the load ----------------------------------------------------------------------------
    def _drag(self, sets: NDArray[np.intp], value: F64, cos: F64, z: F64) -> F64:
        """Drag per length along the normal, N/m, (b, n), of ``sets`` at speeds ``value``
        (b,) and (cos θ, z)."""
        assert self.flow is not None  # for mypy: flow systems only
        radius, length, free = self.radius[sets], self.heights[sets, None], self.free[sets]
        speed = value[:, None] * np.asarray(self.flow.shape(z), dtype=np.float64)
        return drag_per_length(speed * cos, 2.0 * radius, self.flow.fluid,
                               lambda: free - wall_log(z, radius, length))

    def moment(self, sets: NDArray[np.intp], value: F64, theta: F64
               ) -> tuple[F64, tuple[F64, ...] | None]:
        """g (b, n), N, of ``sets`` under loads ``value`` (b,), and what the Jacobian needs of
        the drag (None for a force)."""
        c, s = np.cos(theta), np.sin(theta)
        if self.flow is None:  # a dead force along direction π/2: (F_x, F_z) = F (1, cos π/2)
            f = value[:, None]
            return f * c - (f * math.cos(0.5 * math.pi)) * s, None
        length = self.heights[sets, None]
        z = length * (c @ self.norm.C.T)
        q = self._drag(sets, value, c, z)
        rq_c = length * ((q * c) @ self.norm.R.T)
        rq_s = length * ((q * s) @ self.norm.R.T)
        return c * rq_c + s * rq_s, (c, s, z, q, rq_c, rq_s)

    def residual(self, sets: NDArray[np.intp], value: F64, theta: F64, P: F64 | None = None
                 ) -> tuple[F64, tuple[F64, ...] | None]:
        """P g(θ) − θ (b, n), rad, and the drag's parts (``P``: the sets' influence matrices
        (b, n, n), when the caller gathered them once for many rounds)."""
        g, parts = self.moment(sets, value, theta)
        return np.einsum("bij,bj->bi", self.influence[sets] if P is None else P, g) - theta, parts

    def jacobian(self, sets: NDArray[np.intp], value: F64, theta: F64,
                 parts: tuple[F64, ...] | None, P: F64 | None = None) -> F64:
        """I − P dg/dθ (b, n, n) of ``sets`` (``P``: their influence matrices, if gathered)."""
        if P is None:
            P = self.influence[sets]
        n = theta.shape[1]
        diag = (slice(None), np.arange(n), np.arange(n))
        if parts is None:
            f = value[:, None]
            jac = P * (f * np.sin(theta)
                       + (f * math.cos(0.5 * math.pi)) * np.cos(theta))[:, None, :]
        else:
            c, s, z, q, rq_c, rq_s = parts
            length = self.heights[sets, None]
            q_c = (self._drag(sets, value, c + DRAG_STEP, z) - q) / DRAG_STEP  # ∂Q/∂c
            hz = DRAG_STEP * length
            q_z = (self._drag(sets, value, c, z + hz) - q) / hz  # ∂Q/∂z, pointwise
            R = length[:, :, None] * self.norm.R  # (b, n, n)
            # dq/dθ = −diag(Q_c s) − diag(Q_z) C diag(s)
            dq = -(q_z[:, :, None] * (length[:, :, None] * self.norm.C)) * s[:, None, :]
            dq[diag] -= q_c * s
            # dg = diag(c R(qs) − s R(qc)) + diag(s) R diag(q c) − diag(c) R diag(q s)
            #      + [diag(c) R diag(c) + diag(s) R diag(s)] dq
            mixed = c[:, :, None] * R * c[:, None, :] + s[:, :, None] * R * s[:, None, :]
            dg = mixed @ dq + (s[:, :, None] * R * (q * c)[:, None, :]
                               - c[:, :, None] * R * (q * s)[:, None, :])
            dg[diag] += c * rq_s - s * rq_c
            jac = -(P @ dg)
        jac[diag] += 1.0
        return jac

    def curvature(self, sets: NDArray[np.intp], value: F64, theta: F64) -> F64:
        """Curvature M / EI at the nodes, 1/m, (b, n)."""
        g, _ = self.moment(sets, value, theta)
        m = self.heights[sets, None] * (g @ self.norm.R.T)
        return np.asarray(m * self.stiff_inv[sets], dtype=np.float64)

    # -- Newton along the sweep --------------------------------------------------------------
    def guess(self, sets: NDArray[np.intp], value: F64) -> F64:
        """:func:`magcilia.bend`'s start: the linear-beam angles saturated at π/2, (b, n)."""
        g, _ = self.moment(sets, value, np.zeros((sets.size, self.norm.s.size)))
        lin = np.einsum("bij,bj->bi", self.influence[sets], g)
        limit = 0.5 * math.pi
        return np.asarray(limit * np.tanh(lin * (1.0 / limit)), dtype=np.float64)

    def newton(self, sets: NDArray[np.intp], value: F64, theta: F64, inverse: F64 | None,
               rate: float = CHORD_RATE) -> tuple[F64, NDArray[np.bool_], F64 | None]:
        """Newton at one load for ``sets`` from ``theta`` (b, n): the converged angles, which
        converged (b,), and the last inverse Jacobian (b, n, n), kept for the next load.

        A step reuses the inverse Jacobian of an earlier step (or of the previous load: a chord
        step, one product) while every residual falls by ``rate`` or more a step;
        else the Jacobian is formed and inverted again (a Newton step). Steps are damped to a
        radian; a system is given up after three rising residuals or a non-finite one (as
        :func:`~magcilia.mechanics.elastica.newton`)."""
        b = sets.size
        done = np.zeros(b, dtype=bool)
        failed = np.zeros(b, dtype=bool)
        prev = np.full(b, np.inf)
        worse = np.zeros(b, dtype=np.int64)
        theta = theta.copy()
        active = np.arange(b)
        fresh = False  # whether ``inverse`` was formed at this load's previous iterate
        # the active systems' influence matrices and inverse Jacobians, gathered again only
        # when a system leaves (most rounds keep every one)
        act_p = self.influence[sets]
        act_inv = None if inverse is None else inverse
        for _ in range(MAX_ITERATIONS):
            minus, parts = self.residual(sets[active], value[active], theta[active], act_p)
            err = np.abs(minus).max(axis=1)
            conv = err < TOLERANCE
            done[active[conv]] = True
            worse[active] = np.where(err > prev[active], worse[active] + 1, 0)
            bad = ~conv & (~np.isfinite(err) | (worse[active] >= 3))
            failed[active[bad]] = True
            keep = ~conv & ~bad
            slow = bool(np.any(err[keep] > rate * prev[active][keep]))
            prev[active] = err
            every = bool(keep.all())
            if not every:
                active, minus = active[keep], minus[keep]
                act_p = act_p[keep]
                act_inv = None if act_inv is None else act_inv[keep]
                parts = None if parts is None else tuple(x[keep] for x in parts)
            if not active.size:
                break
            if act_inv is None or (slow and not fresh):
                act_inv = _inverses(self.jacobian(sets[active], value[active], theta[active],
                                                  parts, act_p))
                if inverse is None:
                    inverse = np.full((b, *act_inv.shape[1:]), np.nan)
                inverse[active] = act_inv
                fresh = True
            else:
                fresh = False
            step = np.einsum("bij,bj->bi", act_inv, minus)
            size = np.abs(step).max(axis=1)
            lost = ~np.isfinite(size)
            step *= np.where(size > 1.0, 1.0 / np.where(size > 1.0, size, 1.0), 1.0)[:, None]
            theta[active] += step
            if lost.any():
                failed[active[lost]] = True
                active = active[~lost]
                act_p, act_inv = act_p[~lost], act_inv[~lost]
        return theta, done & ~failed, inverse

    def sweep(self, loads: F64, sets: NDArray[np.intp] | None = None
              ) -> tuple[F64, NDArray[np.bool_]]:
        """Every set (of ``sets``, default all) under every load, θ (S, a, n), and which
        converged (S, a): the loads of each sign in order of size, each started from the
        polynomial through the last (up to three) solutions of its sign
        (:func:`~magcilia.mechanics.planar._extrapolate`, from the straight rod at zero load; the
        first from :meth:`guess`), as :func:`bend_sweep` does."""
        chosen = np.arange(self.heights.size) if sets is None else sets
        n_set, n = chosen.size, self.norm.s.size
        theta = np.zeros((n_set, loads.size, n))
        done = np.zeros((n_set, loads.size), dtype=bool)
        done[:, loads == 0.0] = True
        for sign in (1.0, -1.0):
            order = [int(j) for j in np.argsort(sign * loads) if sign * loads[j] > 0.0]
            rows = np.arange(n_set)
            solved: list[tuple[float, F64]] = [(0.0, np.zeros((n_set, n)))]
            inverse = None
            for j in order:
                value = float(loads[j])
                at = np.full(rows.size, value)
                start = (self.guess(chosen[rows], at) if len(solved) == 1
                         else _extrapolate(solved, value))
                th, ok, inverse = self.newton(chosen[rows], at, start, inverse)
                rows, th = rows[ok], th[ok]
                theta[rows, j] = th
                done[rows, j] = True
                solved = [(val, prev[ok]) for val, prev in solved[-2:]] + [(value, th)]
                if inverse is not None:
                    inverse = inverse[ok]  # a set that failed goes to the sweep
                if not rows.size:
                    break
        return theta, done

    def from_start(self, loads: F64, start: F64, inverse: F64 | None = None
                   ) -> tuple[F64, NDArray[np.bool_], F64 | None]:
        """Every set under every load at once, Newton from ``start`` (N, a, n), rad (the
        solutions of nearby sets; NaN rows: from :meth:`guess`), chord steps first with their
        inverse Jacobians ``inverse`` (N, a, n, n) when given for every loaded system: θ
        (N, a, n), which converged (N, a) and the last inverse Jacobians (N, a, n, n)."""
        n_set, n_load, n = start.shape
        flat = np.repeat(np.arange(n_set), n_load)
        values = np.tile(loads, n_set)
        theta = np.zeros((flat.size, n))
        done = values == 0.0
        todo = np.flatnonzero(~done)
        last: F64 | None = None
        if todo.size:
            first = start.reshape(-1, n)[todo]
            none = np.flatnonzero(~np.isfinite(first).all(axis=1))
            if none.size:  # no start given: bend's guess
                first[none] = self.guess(flat[todo[none]], values[todo[none]])
            given = None if inverse is None else inverse.reshape(-1, n, n)[todo]
            if given is not None and (none.size or not np.isfinite(given).all()):
                given = None
            th, ok, inv = self.newton(flat[todo], values[todo], first, given, START_CHORD_RATE)
            theta[todo] = th
            done[todo] = ok
            if inv is not None:
                every = np.full((flat.size, n, n), np.nan)
                every[todo] = inv
                last = every.reshape(n_set, n_load, n, n)
        return theta.reshape(n_set, n_load, n), done.reshape(n_set, n_load), last


def _inverses(jac: F64) -> F64:
    """The inverses of a stack of matrices (b, n, n); NaN for a singular one."""
    try:
        return np.asarray(np.linalg.inv(jac), dtype=np.float64)
    except np.linalg.LinAlgError:  # a singular system: each on its own
        out = np.full_like(jac, np.nan)
        for j in range(jac.shape[0]):
            with contextlib.suppress(np.linalg.LinAlgError):
                out[j] = np.linalg.inv(jac[j])
        return out
