"""The model of the load experiments for many parameter sets at once: bent shapes and their field.

A :class:`~magcilia.calibration.problem.Problem` with load experiments
(:class:`~magcilia.calibration.experiments.LoadExperiment`) needs, for every parameter set of a
population (a Levenberg–Marquardt batch, a Jacobian's columns, half an ensemble of walkers), the
field at the sensing element of the cilium bent by each load. :func:`load_fields` gives all of
them: the shapes of every set under an experiment's loads in one batched solve
(:func:`magcilia.mechanics.batched.sweep_batch`, the same equilibria as
:func:`magcilia.bend_sweep` to Newton's tolerance), and their dipoles
(:func:`magcilia.model.layout.pose_dipoles`, each set's own base centre, rings and moment) in
one call of the dipole kernel (:func:`magcilia.model.kernels.pose_field`). The result is
:meth:`magcilia.Setup.field` of each set's shapes, as a loop over the sets would give it; a set
whose setup is invalid, whose bend does not converge, whose flow exceeds the drag law or whose
field is not finite gets NaN (the problem's non-finite cost).

The sensing element is checked to lie outside every bent cilium, as :meth:`Setup.field` does; when
the element lies more than the largest radius below the base and no tangent turns past the
horizontal (``|θ| ≤ π/2``: every point of the body then lies above ``−r_max``) it cannot be
inside, and the exact check (:func:`magcilia.model.pose.check_outside`) is skipped.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, replace

import numpy as np
from numpy.typing import NDArray

from magcilia._errors import MagciliaError
from magcilia.device.parameters import PARAMETERS
from magcilia.device.setup import Setup
from magcilia.io.recordings import Measurement
from magcilia.mechanics.batched import BatchShapes, sweep_batch
from magcilia.mechanics.drag import RE_MAX, Fluid
from magcilia.mechanics.flow import Flow
from magcilia.mechanics.planar import OUTPUT_POINTS
from magcilia.model import body
from magcilia.model.azimuth import field_from_tilt_frame, placement_in_tilt_frame
from magcilia.model.centreline import Centreline
from magcilia.model.kernels import pose_field
from magcilia.model.layout import pose_dipoles
from magcilia.model.pose import check_outside

F64 = NDArray[np.float64]

#: margins of the shortcut of the element check (the module notes): the largest tangent angle
#: on the output grid at most π/2 less this (rad; the grid's points are 1/128 of the length
#: apart) …
TURN_MARGIN = 1e-2
#: … and the element at least this fraction beyond the largest radius below the base
LIFT_MARGIN = 1e-2
#: an earlier set's solutions start a new set's Newton when every one of its height, base radius
#: and modulus is within this relative distance (in log) of that set's
NEAR = 0.3
#: the load blocks of a problem's table: (experiment, azimuth rad, sorted loads (a,), column)
Blocks = Sequence[tuple[int, float, F64, int]]


def load_fields(base: Setup, blocks: Blocks, measurements: Sequence[Measurement],
                fluids: Mapping[int, Fluid], prm: Mapping[str, F64],
                starts: dict[int, dict[str, F64]] | None = None) -> F64:
    """The load blocks' fields, (N, 3 · Σ a), T: for each set and block, the field at the
    sensing element (T, (a, 3) flattened) of the cilium bent by each load (the block's
    experiment: tip forces along the block's azimuth, or flow speeds of uniform flow in the
    experiment's fluid); NaN rows for sets whose model fails.

    Parameters
    ----------
    base : Setup
        Supplies everything not in ``prm`` (the cilium's tip radius or profile, the material,
        the sensor, the layout n, k and ring).
    blocks : sequence of (int, float, ndarray, int)
        The problem's load blocks (:attr:`Problem.load_blocks`).
    measurements : sequence of Measurement
        The problem's recordings (a block's experiment indexes them).
    fluids : mapping of int to Fluid
        The fluid of each flow experiment.
    prm : mapping of str to ndarray, shape (N,)
        height, base_radius, x, y, z (m) and youngs_modulus (Pa) of each set.
    starts : dict, optional
        The solutions of the latest call, kept per block and updated here (a problem's own dict):
        once there are some, every load of every set is solved at once, each set started from
        the nearest earlier set's nodal angles when within :data:`NEAR` (a sampler's next
        proposals, a Jacobian's columns), else from :func:`magcilia.bend`'s guess; without, and
        for a set Newton does not converge for, the sweep.
    """
    n = prm["x"].size
    width = sum(3 * b[2].size for b in blocks)
    out = np.full((n, width), np.nan)
    sets = _Sets.valid(base, prm)
    col = 0
    for block, (e_i, phi, loads, _) in enumerate(blocks):
        e = measurements[e_i]
        flow = None if e.forces is not None else Flow.uniform(
            float(np.max(np.abs(loads))) or 1.0, fluids[e_i])
        good = sets.take(_usable(base, sets, loads, flow))
        field = _block(base, good, loads, flow, phi,
                       None if starts is None else starts.setdefault(block, {}))
        out[good.index, col:col + 3 * loads.size] = field
        col += 3 * loads.size
    out[~np.isfinite(out).all(axis=1)] = np.nan  # a set is valid in every block or in none
    return out


@dataclass(frozen=True)
class _Sets:
    """The valid parameter sets of a population as plain arrays, each (g,) (SI): their positions
    ``index`` in the population, height, base radius, x, y, z, modulus, and the normalised
    shape (``knots`` (q,), ``radii`` (g, q): r / r₀) of each set's cilium."""

    index: NDArray[np.intp]
    height: F64
    radius: F64
    x: F64
    y: F64
    z: F64
    modulus: F64
    knots: F64
    radii: F64

    @classmethod
    def valid(cls, base: Setup, prm: Mapping[str, F64]) -> _Sets:
        """The sets of ``prm`` that make a valid setup (``base`` with them replaced, as
        :meth:`Setup.replace` checks it). A frustum's set is shown valid by the checks of
        :meth:`Setup.replace` vectorised (each value in its registry domain
        (:meth:`~magcilia.device.parameters.Parameter.accepts`), the tip radius at most the base
        radius, the sensing element below the base or farther from the axis than the largest
        radius: outside the upright cilium); a set these do not show valid, and every set of a
        measured profile, is checked by :meth:`Setup.replace` itself."""
        names = ("height", "base_radius", "x", "y", "z", "youngs_modulus")
        values = [np.asarray(prm[k], dtype=np.float64).reshape(-1) for k in names]
        height, radius, x, y, z, modulus = values
        cilium, spec = base.cilium, base.spec
        shown = np.ones(height.size, dtype=bool)
        for key, val in zip(names, values, strict=True):
            shown &= PARAMETERS[key].accepts(val)
        if cilium.profile is None:
            with np.errstate(divide="ignore", invalid="ignore"):
                taper = cilium.tip_radius / radius
            shown &= cilium.tip_radius <= radius
            shown &= (spec.depth + z > 0.0) | (np.hypot(x, y) > radius * np.maximum(taper, 1.0))
        else:
            shown[:] = False
        for i in np.flatnonzero(~shown):
            try:
                base.replace(height=float(height[i]), base_radius=float(radius[i]),
                             x=float(x[i]), y=float(y[i]), z=float(z[i]),
                             youngs_modulus=float(modulus[i]))
                shown[i] = True
            except MagciliaError:
                pass
        keep = np.flatnonzero(shown)
        if cilium.profile is None:
            knots, radii = body.frustum_shape(cilium.tip_radius / radius[keep])
        else:
            knots, rho = cilium.shape
            radii = np.broadcast_to(rho, (keep.size, rho.size))
        return cls(keep, height[keep], radius[keep], x[keep], y[keep], z[keep], modulus[keep],
                   knots, radii)

    def take(self, rows: NDArray[np.intp]) -> _Sets:
        """The sets at positions ``rows`` (of these)."""
        return _Sets(self.index[rows], self.height[rows], self.radius[rows], self.x[rows],
                     self.y[rows], self.z[rows], self.modulus[rows], self.knots,
                     self.radii[rows])

    @property
    def max_radius(self) -> F64:
        """Each set's largest radius, m, (g,)."""
        return np.asarray(self.radius * self.radii.max(axis=1), dtype=np.float64)


def _usable(base: Setup, sets: _Sets, loads: F64, flow: Flow | None) -> NDArray[np.intp]:
    """Positions (in ``sets``) of the sets a block can bend (the checks of
    :func:`magcilia.bend_sweep`: a tip radius for a tip force or a flow, the drag law's
    Reynolds range for the fastest flow past the widest section)."""
    keep = np.ones(sets.index.size, dtype=bool)
    if bool(np.any(loads != 0.0)):
        tips = (np.full(keep.size, base.cilium.tip_radius) if base.cilium.profile is None
                else sets.radius * sets.radii[:, -1])
        keep &= tips != 0.0  # require_tip_radius's condition
    if flow is not None:
        fastest = float(np.max(np.abs(loads)))
        keep &= ~(flow.fluid.reynolds(fastest, 2.0 * sets.max_radius) > RE_MAX)  # check_reynolds
    return np.flatnonzero(keep)


def _block(base: Setup, sets: _Sets, loads: F64, flow: Flow | None,
           phi: float, kept: dict[str, F64] | None) -> F64:
    """The field (T) of ``sets`` (g of them) under one block's loads, (g, 3 a); NaN rows for
    a set whose bend does not converge or whose field is not finite; ``kept``: the block's
    earlier solutions (``key`` (M, 3), ``theta`` (M, a, n), ``inverse`` (M, a, n, n),
    ``nodes`` (n,)), updated."""
    g, a = sets.index.size, loads.size
    if not g:
        return np.zeros((0, 3 * a))
    height, radius, modulus = sets.height, sets.radius, sets.modulus
    key = np.log(np.stack([height, radius, modulus], axis=1))
    start = start_inverse = None
    if kept:  # each set from its nearest earlier set, or (none near) from bend's guess
        far = np.abs(key[:, None, :] - kept["key"][None, :, :]).max(axis=2)  # (g, M)
        nearest = np.argmin(far, axis=1)
        start = kept["theta"][nearest]
        start[far[np.arange(g), nearest] > NEAR] = np.nan
        start_inverse = kept["inverse"][nearest]
    shapes = sweep_batch(base, height, radius, modulus, loads, flow=flow, start=start,
                         start_nodes=kept.get("nodes") if kept else None,
                         start_inverse=start_inverse)
    if kept is not None:
        _keep(kept, key, shapes)
    return bent_fields(base, sets, shapes.s, shapes.angles, shapes.points, shapes.ok,
                       np.asarray(phi, dtype=np.float64)).reshape(g, 3 * a)


def bent_fields(base: Setup, sets: _Sets, s: F64, angles: F64, points: F64,
                ok: NDArray[np.bool_], phi: F64, scale: F64 | None = None) -> F64:
    """The field (T) at the sensing element of ``sets`` (g of them) bent into the planar shapes
    ``angles`` (g, a, m), rad, ``points`` (g, a, m, 3), m (arc lengths ``s`` (g, m)), each shape
    in the vertical plane at azimuth ``phi`` (scalar or (a,), rad): (g, a, 3), board frame; NaN
    for a set not ``ok`` (g,), whose field is not finite or whose element lies inside a bent
    cilium. ``scale`` (g,): each set's magnetization scale relative to ``base``'s (default 1)."""
    g, a = sets.index.size, angles.shape[1]
    height, radius = sets.height, sets.radius
    spec = base.spec
    n_loops, k, ring = spec.n_loops, spec.dipoles_per_loop, spec.ring
    # slice mid-points on each set's shapes: one normalised centreline batch (s / L, points / L)
    unit = Centreline(np.linspace(0.0, 1.0, OUTPUT_POINTS),
                      np.where(ok[:, None, None], angles, 0.0).reshape(g * a, OUTPUT_POINTS),
                      np.where(ok[:, None, None, None], points, 0.0).reshape(
                          g * a, OUTPUT_POINTS, 3) / np.repeat(height, a)[:, None, None])
    mid, pose_angles = unit.frames((np.arange(n_loops) + 0.5) / n_loops)
    pts = mid * np.repeat(height, a)[:, None, None]
    rings, share = body.slice_rings(sets.knots, sets.radii, n_loops, ring)
    turn = np.broadcast_to(phi, (g, a))
    x, y = (np.asarray(c, dtype=np.float64) for c in placement_in_tilt_frame(
        sets.x[:, None], sets.y[:, None], turn))
    lift = spec.depth + sets.z
    centre = np.stack([x, y, np.broadcast_to(lift[:, None], (g, a))], axis=2).reshape(g * a, 3)
    # the moment m_c = M V_c of each set (ModelSpec.moment, with body.volume's V_c)
    moment = spec.magnetization * (math.pi * height * radius**2
                                   * body.mean_square_radius(sets.knots, sets.radii))
    if scale is not None:
        moment = moment * scale
    pos, mom = pose_dipoles(pts, pose_angles, centre,
                            np.repeat(rings * radius[:, None], a, axis=0),
                            np.repeat(share, a, axis=0), np.repeat(moment, a), k)
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):  # checked below
        b = pose_field(np.zeros((1, 3)), pos, mom)[:, 0, :].reshape(g, a, 3)
    if np.any(turn != 0.0):
        b = field_from_tilt_frame(b, turn)
    b[~ok] = np.nan
    turned = np.abs(np.where(ok[:, None, None], angles, 0.0)).max(axis=(1, 2)) > (
        0.5 * math.pi - TURN_MARGIN)
    near = lift <= (1.0 + LIFT_MARGIN) * sets.max_radius
    for j in np.flatnonzero(ok & (turned | near)):  # the element may be inside: check
        for c in range(a):
            sp = replace(spec, height=float(height[j]), base_radius=float(radius[j]),
                         tip_radius=float(radius[j] * sets.radii[j, -1]), radii=sets.radii[j],
                         position=(float(x[j, c]), float(y[j, c]), float(sets.z[j])))
            try:
                check_outside(sp, np.zeros((1, 3)), Centreline(s[j], angles[j, c:c + 1],
                                                               points[j, c:c + 1]))
            except MagciliaError:
                b[j] = np.nan
                break
    return b


def _keep(kept: dict[str, F64], key: F64, shapes: BatchShapes) -> None:
    """Keep a block's converged sets in ``kept`` (the latest population replaces the one
    before: a sampler's two half-ensembles, a Jacobian's columns lie close to it): their ``key``
    (log height, base radius, modulus (g, 3)), nodal angles, grid and inverse Jacobians (NaN
    where the sweep solved them)."""
    fine = np.isfinite(shapes.theta).all(axis=(1, 2))
    if not fine.any():
        return
    every = bool(fine.all())
    theta = shapes.theta if every else shapes.theta[fine]
    inverse = shapes.inverse
    if inverse is None:
        inverse = np.full((*theta.shape, theta.shape[2]), np.nan)
    elif not every:
        inverse = inverse[fine]
    kept.update(key=key if every else key[fine], theta=theta, inverse=inverse,
                nodes=shapes.nodes)
