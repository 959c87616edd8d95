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
from dataclasses import replace

import numpy as np
from numpy.typing import NDArray

from magcilia._errors import MagciliaError
from magcilia.device.setup import Setup
from magcilia.io.recordings import Measurement
from magcilia.mechanics.batched import BatchShapes, sweep_batch
from magcilia.mechanics.drag import Fluid, check_reynolds
from magcilia.mechanics.flow import Flow
from magcilia.mechanics.planar import OUTPUT_POINTS, require_tip_radius
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
    setups: list[Setup] = []
    valid: list[int] = []
    for i in range(n):
        try:
            setups.append(base.replace(
                height=float(prm["height"][i]), base_radius=float(prm["base_radius"][i]),
                x=float(prm["x"][i]), y=float(prm["y"][i]), z=float(prm["z"][i]),
                youngs_modulus=float(prm["youngs_modulus"][i])))
            valid.append(i)
        except MagciliaError:
            pass
    sets = np.array(valid, dtype=np.intp)
    col = 0
    for block, (e_i, phi, loads, _) in enumerate(blocks):
        e = measurements[e_i]
        flow = None if e.forces is not None else Flow.uniform(
            float(np.max(np.abs(loads))) or 1.0, fluids[e_i])
        good = _usable(setups, loads, flow)
        field = _block(base, [setups[k] for k in good], loads, flow, phi,
                       None if starts is None else starts.setdefault(block, {}))
        out[sets[good], col:col + 3 * loads.size] = field
        col += 3 * loads.size
    out[~np.isfinite(out).all(axis=1)] = np.nan  # a set is valid in every block or in none
    return out


def _usable(setups: list[Setup], loads: F64, flow: Flow | None) -> NDArray[np.intp]:
    """Positions (in ``setups``) of the setups a block can bend (the checks of
    :func:`magcilia.bend_sweep`: a tip radius for a tip force or a flow, the drag law's
    Reynolds range for the fastest flow past the widest section)."""
    keep = []
    loaded = bool(np.any(loads != 0.0))
    for k, setup in enumerate(setups):
        try:
            if loaded:
                require_tip_radius(setup, "force" if flow is None else "flow")
            if flow is not None:
                check_reynolds(float(np.max(np.abs(loads))), 2.0 * setup.cilium.max_radius,
                               flow.fluid)
            keep.append(k)
        except MagciliaError:
            pass
    return np.array(keep, dtype=np.intp)


def _block(base: Setup, setups: list[Setup], loads: F64, flow: Flow | None,
           phi: float, kept: dict[str, F64] | None) -> F64:
    """The field (T) of ``setups`` (g of them) under one block's loads, (g, 3 a); NaN rows for
    a set whose bend does not converge or whose field is not finite; ``kept``: the block's
    earlier solutions (``key`` (M, 3), ``theta`` (M, a, n), ``inverse`` (M, a, n, n),
    ``nodes`` (n,)), updated."""
    g, a = len(setups), loads.size
    if not g:
        return np.zeros((0, 3 * a))
    height = np.array([s.cilium.height for s in setups])
    radius = np.array([s.cilium.base_radius for s in setups])
    modulus = np.array([s.youngs_modulus for s in setups])
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
    specs = [s.spec for s in setups]
    n_loops, k, ring = specs[0].n_loops, specs[0].dipoles_per_loop, specs[0].ring
    # slice mid-points on each set's shapes: one normalised centreline batch (s / L, points / L)
    unit = Centreline(np.linspace(0.0, 1.0, OUTPUT_POINTS),
                      np.where(shapes.ok[:, None, None], shapes.angles, 0.0).reshape(
                          g * a, OUTPUT_POINTS),
                      np.where(shapes.ok[:, None, None, None], shapes.points, 0.0).reshape(
                          g * a, OUTPUT_POINTS, 3) / np.repeat(height, a)[:, None, None])
    mid, angles = unit.frames((np.arange(n_loops) + 0.5) / n_loops)
    points = mid * np.repeat(height, a)[:, None, None]
    radius, share = body.slice_rings(specs[0].knots, np.stack([sp.radii for sp in specs]),
                                     n_loops, ring)
    x, y = (np.asarray(c, dtype=np.float64) for c in placement_in_tilt_frame(
        np.array([sp.position[0] for sp in specs]), np.array([sp.position[1] for sp in specs]),
        phi))
    lift = np.array([sp.depth + sp.position[2] for sp in specs])
    centre = np.stack([x, y, lift], axis=1)
    r0 = np.array([sp.base_radius for sp in specs])
    pos, mom = pose_dipoles(points, angles, np.repeat(centre, a, axis=0),
                            np.repeat(radius * r0[:, None], a, axis=0),
                            np.repeat(share, a, axis=0),
                            np.repeat(np.array([sp.moment for sp in specs]), a), k)
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):  # checked below
        b = pose_field(np.zeros((1, 3)), pos, mom)[:, 0, :].reshape(g, a, 3)
    if phi != 0.0:
        b = field_from_tilt_frame(b, phi)
    b[~shapes.ok] = np.nan
    turned = np.abs(shapes.angles).max(axis=(1, 2)) > 0.5 * math.pi - TURN_MARGIN
    near = lift <= (1.0 + LIFT_MARGIN) * np.array([sp.max_radius for sp in specs])
    for j in np.flatnonzero(shapes.ok & (turned | near)):  # the element may be inside: check
        sp = replace(specs[j], position=(float(x[j]), float(y[j]), specs[j].position[2]))
        try:
            check_outside(sp, np.zeros((1, 3)), Centreline(shapes.s[j], shapes.angles[j],
                                                           shapes.points[j]))
        except MagciliaError:
            b[j] = np.nan
    return b.reshape(g, 3 * a)


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
