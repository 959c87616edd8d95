"""Derivatives of the batched tilt model: the NumPy reference of
:func:`magcilia.model.compiled.tilt_jacobian_batch`, vectorised over each (n, k) group.

The model's value at one tilt angle is a sum over the n·k ring dipoles of the point-dipole field at
the sensing element. Its derivatives (columns :data:`~magcilia.model.compiled.JACOBIAN_COLUMNS`)
are closed form:

* the gradient of a dipole's field ``B = 3 v (m·v)/|v|⁵ − m/|v|³`` (v = observer − dipole, m along
  the body axis) with respect to v is the symmetric, traceless tensor
  ``T_il = 3 m (δ_lz v_i + v_z δ_il + δ_iz v_l)/|v|⁵ − 15 m v_z v_i v_l/|v|⁷``;
* the base centre (x, y, z) moves the observer by ``−R(θ)ᵀ`` of the tilt;
* the height moves slice j along the axis by ``(j + ½)/n`` per metre and scales every moment
  (∝ h);
* the base radius moves each ring outward and scales the moments (∝ r_b²); for a frustum whose tip
  radius is held, the taper tip / r_b changes as well, and with it the slice volumes and ring
  radii (:func:`magcilia.model.body.frustum_slice_derivatives`);
* the magnetization (A/m, the packed column) scales the field.

Shape letters: ``N`` parameter sets, ``a`` tilt angles, ``d`` dipoles.
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import NDArray

from magcilia.constants import MU0_OVER_4PI
from magcilia.model import body
from magcilia.model.spec import ModelSpec

F64 = NDArray[np.float64]


def jacobian_numpy(spec: ModelSpec, packed: F64, angles: F64, out: F64, jac: F64,
                   measured: bool) -> None:
    """Fill ``out`` (N, a, c) as :func:`magcilia.model.batch.evaluate` does and ``jac``
    (N, a, c, 6) with its derivatives (c = 1: output, V; c = 3: field, T)."""
    h, rb, taper, x, y, z, nl, kd, mag, offset = packed.T
    cos_t, sin_t = np.cos(angles), np.sin(angles)
    keys = nl * 100_003 + kd
    for key in np.unique(keys):
        sel = np.nonzero(keys == key)[0]
        n, k = int(nl[sel[0]]), int(kd[sel[0]])
        _group(spec, n, k, h[sel], rb[sel], taper[sel], -np.stack([x[sel], y[sel], z[sel]], 1),
               mag[sel], offset[sel], cos_t, sin_t, out, jac, sel, measured)


def _group(spec: ModelSpec, n: int, k: int, h: F64, rb: F64, taper: F64, rel: F64, mag: F64,
           offset: F64, cos_t: F64, sin_t: F64, out: F64, jac: F64, sel: NDArray[np.intp],
           measured: bool) -> None:
    """One (n, k) group of sets: values and derivatives in the body frame, then the lab's."""
    size = h.size
    if measured:
        ring, _ = body.slice_rings(spec.knots, spec.radii, n, spec.ring)
        mean2, _ = body.slice_means(spec.knots, spec.radii, n)
        ring, mean2 = np.broadcast_to(ring, (size, n)), np.broadcast_to(mean2, (size, n))
        dring = dmean2 = np.zeros((size, n))
        lam = np.zeros(size)
    else:
        u, rho = body.frustum_shape(taper)
        ring, _ = body.slice_rings(u, rho, n, spec.ring)
        mean2, _ = body.slice_means(u, rho, n)
        dring, dmean2 = body.frustum_slice_derivatives(taper, n, spec.ring)
        lam = taper
    alpha = 2.0 * math.pi * np.arange(k) / k
    ca, sa = np.repeat(np.cos(alpha)[None, :], n, 0).ravel(), np.repeat(
        np.sin(alpha)[None, :], n, 0).ravel()
    radius = rb[:, None] * ring  # (N, n)
    weight = math.pi * h * rb * rb / (n * k)  # per unit magnetization and unit mean2
    mom = np.repeat(weight[:, None] * mean2, k, axis=1)  # (N, d)
    zf = np.repeat((np.arange(n) + 0.5) / n, k)  # (d,)
    dradius = np.repeat(ring - lam[:, None] * dring, k, axis=1)  # ∂(ring radius)/∂r_b
    with np.errstate(divide="ignore", invalid="ignore"):
        fw = np.where(mean2 > 0.0, (2.0 - lam[:, None] * dmean2 / mean2), 2.0) / rb[:, None]
    fw = np.repeat(fw, k, axis=1)  # ∂ ln m_j / ∂ r_b
    r_all = np.repeat(radius, k, axis=1)
    px, py, pz = r_all * ca, r_all * sa, h[:, None] * zf
    rx, ry, rz = rel[:, 0:1], rel[:, 1:2], rel[:, 2:3]
    ox = cos_t * rx - sin_t * rz  # (N, a)
    oz = sin_t * rx + cos_t * rz
    vx = ox[:, :, None] - px[:, None, :]  # (N, a, d)
    vz = oz[:, :, None] - pz[:, None, :]
    vy = np.broadcast_to((ry - py)[:, None, :], vx.shape)
    ir2 = 1.0 / (vx * vx + vy * vy + vz * vz)
    m = mom[:, None, :]
    mr3 = m * ir2 * np.sqrt(ir2)
    tt = 3.0 * mr3 * ir2
    qz = tt * vz
    g = 5.0 * qz * ir2
    b = np.stack([qz * vx, qz * vy, qz * vz - mr3])  # (3, N, a, d)
    txx, txy, txz = qz - g * vx * vx, -g * vx * vy, tt * vx - g * vx * vz
    tyz, tzz = tt * vy - g * vy * vz, 3.0 * qz - g * vz * vz
    tyy = -(txx + tzz)
    tensor = np.stack([np.stack([txx, txy, txz]), np.stack([txy, tyy, tyz]),
                       np.stack([txz, tyz, tzz])])  # (l, i, N, a, d): ∂B_i/∂v_l
    col_x, col_y, col_z = tensor.sum(axis=-1)  # (3, N, a) each
    field = b.sum(axis=-1)
    ct, st = cos_t[None], sin_t[None]
    ring_dir = ca * tensor[0] + sa * tensor[1]  # (i, N, a, d): ∂B_i along the ring's radius
    grads = np.stack([
        -np.einsum("inad,d->ina", tensor[2], zf) + field / h[None, :, None],
        -np.einsum("inad,nd->ina", ring_dir, dradius) + np.einsum("inad,nd->ina", b, fw),
        -ct * col_x - st * col_z,
        -col_y,
        st * col_x - ct * col_z,
        field,
    ], axis=-1)  # (i, N, a, 6), body frame, per unit magnetization
    scale = MU0_OVER_4PI * mag[None, :, None, None] * np.ones(6)
    scale[..., 5] = MU0_OVER_4PI
    grads = grads * scale
    field = MU0_OVER_4PI * mag[None, :, None] * field
    ct4, st4 = cos_t[None, :, None], sin_t[None, :, None]
    if out.shape[2] == 1:
        out[sel, :, 0] = spec.scale * (ct * field[0] + st * field[2]) + offset[:, None]
        jac[sel, :, 0] = spec.scale * (ct4 * grads[0] + st4 * grads[2])
    else:
        out[sel] = np.stack([ct * field[0] + st * field[2], field[1],
                             ct * field[2] - st * field[0]], axis=-1)
        jac[sel] = np.stack([ct4 * grads[0] + st4 * grads[2], grads[1],
                             ct4 * grads[2] - st4 * grads[0]], axis=2)
