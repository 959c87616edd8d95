"""The model reading of field channels for horizontal tip forces on a polar grid (T).

A horizontal tip force of magnitude F at azimuth φ bends the cilium in the vertical plane at φ:
the planar shape of :func:`magcilia.bend_sweep` (direction π/2, toward +x) turned by φ about the
vertical axis through the base (:meth:`magcilia.SpatialCentreline.from_planar`). The field of
shape F turned by φ at a point p is ``R(φ) · G_F(R(−φ)(p − b) + b)`` with ``G_F`` the planar
shape's field and ``b`` the base centre (exact: the turned world), so a grid of (F, φ) needs only
the dipoles of the planar shapes, observed on circles (:func:`polar_model`). Under a known
actuation (:func:`actuated_polar_model`) a uniform field along z keeps that symmetry; any other
needs one 3-D bend per node. :class:`~magcilia.BiaxialReadout` tabulates these.

The model's dipole rings turn with the bending direction (the convention of
:mod:`magcilia.model.azimuth`), so even the unloaded cilium's field depends on φ by a trace
(~1e-6 of the field for the paper's k = 5): the read-out's table takes the mean over φ as its
F = 0 row, so that the model is a smooth function of (Fx, Fy) through zero.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
from numpy.typing import NDArray

from magcilia import _validate as v
from magcilia._errors import MagciliaError
from magcilia.device.actuation import Actuation
from magcilia.device.setup import Setup
from magcilia.mechanics import bend, bend_sweep
from magcilia.model.azimuth import turn_about_z
from magcilia.model.centreline import SpatialCentreline
from magcilia.model.kernels import pose_field
from magcilia.readout.channel import Channel
from magcilia.readout.polar_table import evaluate
from magcilia.readout.scale import (
    VECTOR_RATE_GRID,
    least_squares_rate,
    per_ln_modulus,
    to_polar,
)

F64 = NDArray[np.float64]


def polar_model(setup: Setup, chans: tuple[Channel, ...], forces: F64, azimuths: F64) -> F64:
    """Each channel's reading (T) for horizontal tip forces ``forces`` (nF,) toward ``azimuths``
    (nφ,): (nF, nφ, c). The planar shapes' dipoles observed at the channels' points turned by
    −φ about the vertical axis through the base, the field turned back by +φ."""
    return polar_model_of_shapes(setup, chans, forces, azimuths, bend_sweep(setup, forces=forces))


def polar_model_of_shapes(setup: Setup, chans: tuple[Channel, ...], forces: F64, azimuths: F64,
                          shapes: Any) -> F64:
    """:func:`polar_model` of the planar ``shapes`` (a Centreline of nF shapes in the x–z plane)."""
    base = setup.base_centre
    points = np.array([c.position for c in chans])
    unique, which = np.unique(points, axis=0, return_inverse=True)
    which = np.asarray(which).reshape(-1)
    rel = unique - base  # (P, 3)
    obs = turn_about_z(rel[None], azimuths[:, None], inverse=True) + base  # R(−φ)(p − b) + b
    flat = obs.reshape(-1, 3)
    try:
        setup.check_outside(flat, shapes)
    except MagciliaError:
        for i, p in enumerate(unique):
            try:
                setup.check_outside(obs[:, i], shapes)
            except MagciliaError:
                names = ", ".join(c.name for c, w in zip(chans, which, strict=True) if w == i)
                raise v.fail("sensors", f"{names} at ({', '.join(f'{x * 1e3:.4g}' for x in p)})"
                             " mm", f"sensors outside the cilium bent by up to "
                             f"{forces[-1]:.4g} N in any direction (move the sensor or lower "
                             "the span)") from None
        raise
    pos, mom = setup.dipoles(shapes)
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
        b = pose_field(flat, pos, mom).reshape(forces.size, azimuths.size, -1, 3)
    if not np.isfinite(b).all():
        raise v.fail("sensors", "a point on a dipole of the model", "sensors away from the "
                     "model's dipoles")
    board = turn_about_z(b, azimuths[None, :, None])  # R(φ) B
    axes = np.array([c.axis for c in chans])  # (c, 3)
    return np.einsum("fpcx,cx->fpc", board[:, :, which], axes)


def actuated_polar_model(setup: Setup, chans: tuple[Channel, ...], forces: F64,
                          azimuths: F64, actuation: Actuation) -> tuple[F64, F64]:
    """:func:`polar_model` while ``actuation`` acts: each channel's reading (T), (nF, nφ, c), of the
    cilium bent by the force and the actuation plus the actuation's direct field, and the direct
    field's reading per channel (c,). A uniform field along z keeps the axial symmetry (the
    planar sweep under it, turned); any other needs a 3-D bend per (F, φ)."""
    if not isinstance(actuation, Actuation):
        raise v.fail("actuation", type(actuation).__name__,
                     "a magcilia Actuation (Actuation.uniform(b), Actuation.magpylib(source))")
    points = np.array([c.position for c in chans])
    axes = np.array([c.axis for c in chans])
    direct_b = actuation.field(points)  # (c, 3)
    if not np.all(np.isfinite(direct_b)):
        raise v.fail("actuation", "a field that is not finite at a channel",
                     "a source away from the sensors")
    direct = np.einsum("cx,cx->c", direct_b, axes)
    rng = np.array([c.field_range for c in chans])
    beyond = np.flatnonzero(np.abs(direct) > rng)
    if beyond.size:
        i = int(beyond[0])
        raise v.fail("actuation", f"a direct field of {direct[i] / 1e-4:.4g} G on "
                     f"{chans[i].name}", f"within its range ±{rng[i] / 1e-4:.4g} G (lower the "
                     "field or its scale, or pick a wider range)")
    uniform = actuation.uniform_field if actuation.is_uniform else None
    if uniform is not None and uniform[0] == 0.0 and uniform[1] == 0.0:
        # symmetric about the vertical axis: the planar sweep under the field, turned
        bent = polar_model_of_shapes(setup, chans, forces, azimuths,
                             bend_sweep(setup, forces=forces, actuation=actuation))
        return bent + direct, direct
    shapes = [bend(setup, float(f), azimuth=float(p), actuation=actuation)
              for f in forces for p in azimuths]
    spatial = SpatialCentreline(shapes[0].s, *(np.concatenate([
        getattr(sh if isinstance(sh, SpatialCentreline) else SpatialCentreline.from_planar(sh),
                name) for sh in shapes]) for name in ("points", "tangents", "normals")))
    unique, which = np.unique(points, axis=0, return_inverse=True)
    which = np.asarray(which).reshape(-1)
    try:
        b = setup.field_at(unique, spatial)  # (a, P, 3)
    except MagciliaError:
        raise v.fail("sensors", "a point inside the bent cilium", f"sensors outside the "
                     f"cilium bent by up to {forces[-1]:.4g} N and the actuation") from None
    b = b.reshape(forces.size, azimuths.size, -1, 3)[:, :, which]
    return np.einsum("fpcx,cx->fpc", b, axes) + direct, direct


def actuated_scale_rates(setup: Setup, chans: tuple[Channel, ...], actuation: Actuation,
                         f_max: float, coef: F64) -> tuple[F64, F64, F64]:
    """The force's derivative with respect to ln E under ``actuation``, on a
    :data:`~magcilia.readout.scale.VECTOR_RATE_GRID` grid of magnitudes (0 … ``f_max``, N)
    and directions: (magnitudes, directions, components along and across the force
    (m, d, 2), N). The readings' derivative is a central difference of
    :func:`actuated_polar_model` in ln E (:func:`~magcilia.readout.scale.per_ln_modulus`),
    taken through the least squares of the read-out's table (the Hermite coefficients ``coef``
    of its grid from 0 to ``f_max``, :mod:`.polar_table`) with the channels' stated noise."""
    mags = np.linspace(0.0, f_max, VECTOR_RATE_GRID[0])
    step = 2.0 * math.pi / VECTOR_RATE_GRID[1]
    dirs = np.arange(VECTOR_RATE_GRID[1], dtype=np.float64) * step
    g = per_ln_modulus(lambda s: actuated_polar_model(s, chans, mags, dirs, actuation)[0],
                       setup).reshape(-1, len(chans))
    m, d = (a.reshape(-1) for a in np.meshgrid(mags, dirs, indexing="ij"))
    h_f = f_max / coef.shape[0]
    _, jx, jy = evaluate(coef, h_f, m * np.cos(d), m * np.sin(d))
    weight = np.broadcast_to(1.0 / np.array([c.sigma for c in chans]) ** 2, g.shape)
    rates = to_polar(least_squares_rate(jx, jy, g, weight), d)
    return mags, dirs, rates.reshape(mags.size, dirs.size, 2)
