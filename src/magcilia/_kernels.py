"""Bare vectorised field kernels: arrays in, arrays out, SI units, no input checks.

Shape letters: ``o`` observers, ``d`` dipoles, ``a`` poses (angles / shapes), ``N`` parameter sets.
The point-dipole field (the paper's eq. 3, with its brackets restored) is

    B(r) = μ0/(4π) · (3 r (m·r) / |r|⁵ − m / |r|³),   r = observer − dipole position.

At r = 0 the field is undefined: callers must keep observers off the dipoles (the public layer
checks that the sensing element lies outside the cilium).
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from magcilia.constants import MU0_OVER_4PI

F64 = NDArray[np.float64]

#: target number of dipole·observer pairs per chunk (keeps ~10 work arrays in L2 cache)
CHUNK_PAIRS = 4096


def dipole_field(observers: F64, positions: F64, moments: F64) -> F64:
    """Total field of ``d`` point dipoles at ``o`` observers.

    Parameters
    ----------
    observers : ndarray, shape (o, 3)
        Observer positions, m.
    positions : ndarray, shape (d, 3)
        Dipole positions, m.
    moments : ndarray, shape (d, 3)
        Dipole moments, A·m².

    Returns
    -------
    ndarray, shape (o, 3)
        Flux density B summed over the dipoles, T.

    Notes
    -----
    Component-wise arithmetic on cache-sized blocks of observers, with in-place ufuncs and the
    moment sums done as matrix–vector products. Single-threaded apart from BLAS.
    """
    observers = np.ascontiguousarray(observers, dtype=np.float64)
    n_obs = observers.shape[0]
    n_dip = positions.shape[0]
    out = np.empty((n_obs, 3))
    if n_obs == 0:
        return out
    if n_dip == 0:
        out.fill(0.0)
        return out
    px, py, pz = (np.ascontiguousarray(positions[:, i]) for i in range(3))
    mx, my, mz = (np.ascontiguousarray(moments[:, i]) for i in range(3))
    m_mat = np.ascontiguousarray(moments)  # (d, 3)
    block = max(1, CHUNK_PAIRS // n_dip)
    shape = (min(block, n_obs), n_dip)
    rx, ry, rz = np.empty(shape), np.empty(shape), np.empty(shape)
    r2, ir3, q, tmp = np.empty(shape), np.empty(shape), np.empty(shape), np.empty(shape)
    for start in range(0, n_obs, block):
        stop = min(start + block, n_obs)
        c = stop - start
        bx, by, bz = rx[:c], ry[:c], rz[:c]
        b_r2, b_ir3, b_q, b_tmp = r2[:c], ir3[:c], q[:c], tmp[:c]
        obs = observers[start:stop]
        np.subtract(obs[:, 0:1], px, out=bx)
        np.subtract(obs[:, 1:2], py, out=by)
        np.subtract(obs[:, 2:3], pz, out=bz)
        np.multiply(bx, bx, out=b_r2)
        np.multiply(by, by, out=b_tmp)
        b_r2 += b_tmp
        np.multiply(bz, bz, out=b_tmp)
        b_r2 += b_tmp
        # ir3 = r^-3, q = 3 (m.r) r^-5
        np.sqrt(b_r2, out=b_tmp)
        b_tmp *= b_r2
        np.divide(1.0, b_tmp, out=b_ir3)
        np.multiply(bx, mx, out=b_q)
        np.multiply(by, my, out=b_tmp)
        b_q += b_tmp
        np.multiply(bz, mz, out=b_tmp)
        b_q += b_tmp
        b_q *= b_ir3
        np.divide(b_q, b_r2, out=b_q)
        res = out[start:stop]
        # sum_d q r - sum_d ir3 m  (the factor 3 applied once at the end)
        res[:, 0] = np.einsum("ij,ij->i", b_q, bx)
        res[:, 1] = np.einsum("ij,ij->i", b_q, by)
        res[:, 2] = np.einsum("ij,ij->i", b_q, bz)
        res *= 3.0
        res -= b_ir3 @ m_mat
    out *= MU0_OVER_4PI
    return out


def dipole_field_batch(observers: F64, positions: F64, moments: F64) -> F64:
    """Field of ``a`` independent dipole sets at common observers.

    Parameters
    ----------
    observers : ndarray, shape (o, 3)
        m.
    positions, moments : ndarray, shape (a, d, 3)
        Dipole positions (m) and moments (A·m²) of each set.

    Returns
    -------
    ndarray, shape (a, o, 3)
        B of each set summed over its dipoles, T.
    """
    r = observers[None, :, None, :] - positions[:, None, :, :]  # (a, o, d, 3)
    r2 = np.einsum("aodi,aodi->aod", r, r)
    ir3 = 1.0 / (r2 * np.sqrt(r2))
    mr = np.einsum("aodi,adi->aod", r, moments)
    q = 3.0 * mr * ir3 / r2
    b = np.einsum("aod,aodi->aoi", q, r) - np.einsum("aod,adi->aoi", ir3, moments)
    return MU0_OVER_4PI * b


def tilt_field(
    cos_t: F64,
    sin_t: F64,
    rel: F64,
    body_positions: F64,
    body_moments: F64,
    x_only: bool = False,
) -> tuple[F64, F64, F64]:
    """Field of rigidly tilted dipole sets at one observer, computed in the body frame.

    The body frame has the cilium axis along z and the tilt direction along x; tilting by theta
    about y maps body (x, y, z) to lab (x cos θ + z sin θ, y, −x sin θ + z cos θ). Instead of moving
    the dipoles, the observer is rotated into the body frame (cheaper for many angles).

    Parameters
    ----------
    cos_t, sin_t : ndarray, shape (a,)
        cos and sin of the tilt angles.
    rel : ndarray, shape (..., 3)
        Observer minus base centre, lab frame, m.
    body_positions : ndarray, shape (..., d, 3)
        Dipole positions in the body frame (relative to the base centre), m.
    body_moments : ndarray, shape (..., d)
        Moments along the body z axis, A·m².
    x_only : bool
        Compute only B_x (the sensor's axis); B_y and B_z are then returned as empty arrays.

    Returns
    -------
    bx, by, bz : ndarray, shape (..., a)
        Lab-frame field components at the observer, T.
    """
    rx, rz = rel[..., 0:1], rel[..., 2:3]
    # observer in the body frame; its y is unchanged by the tilt, shape (..., a)
    ox = cos_t * rx - sin_t * rz
    oz = sin_t * rx + cos_t * rz
    vx = ox[..., None] - body_positions[..., None, :, 0]
    vz = oz[..., None] - body_positions[..., None, :, 2]
    vy = rel[..., 1:2] - body_positions[..., :, 1]  # (..., d), angle independent
    r2 = vx * vx
    r2 += vz * vz
    r2 += (vy * vy)[..., None, :]
    ir3 = np.power(r2, -1.5)
    m = body_moments[..., None, :]
    q = (3.0 * vz) * ir3
    q /= r2
    q *= m  # 3 (m.v) / r^5, m along body z
    bbx = np.vecdot(q, vx)
    bbz = np.vecdot(q, vz) - np.vecdot(ir3, m)
    bx = MU0_OVER_4PI * (cos_t * bbx + sin_t * bbz)
    if x_only:
        empty = np.empty(0)
        return bx, empty, empty
    by = MU0_OVER_4PI * np.vecdot(q, vy[..., None, :])
    bz = MU0_OVER_4PI * (cos_t * bbz - sin_t * bbx)
    return bx, by, bz
