"""Bare field kernels: arrays in, arrays out, SI units, no input checks.

:func:`dipole_field` and :func:`pose_field` run the compiled kernel of
:mod:`magcilia.model.compiled` when numba is available; the NumPy code here is their fallback and
the reference the tests hold them to.

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
from magcilia.model import compiled

F64 = NDArray[np.float64]

#: dipole·observer pairs per block (the block's work arrays stay in L2 cache while Python
#: call overhead stays small)
CHUNK_PAIRS = 16384


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
    Compiled: each observer–dipole vector is formed directly (relative error a few ε per pair).
    NumPy fallback: coordinates are first centred on the dipoles' mean position. Per block of
    observers, |r|² is formed component-wise, while m·r = o·m − p·m and Σ_d q r = o Σ_d q − q P
    are matrix products (BLAS). The split products cost a relative error of about 3 ε (1 + R/|r|),
    with R the radius of the dipole cloud: ~1e-15 in ordinary use, 5e-13 one micrometre from a
    dipole of a millimetre-sized cloud.
    """
    if compiled.kernels() is not None:
        return pose_field(observers, positions[None], moments[None])[0]
    return _dipole_field_numpy(observers, positions, moments)


def _dipole_field_numpy(observers: F64, positions: F64, moments: F64) -> F64:
    """:func:`dipole_field` in NumPy, in blocks of :data:`CHUNK_PAIRS`."""
    centre = positions.mean(axis=0) if positions.shape[0] else np.zeros(3)
    pos = np.ascontiguousarray(positions - centre, dtype=np.float64)
    obs_all = np.ascontiguousarray(observers - centre, dtype=np.float64)
    mom = np.ascontiguousarray(moments, dtype=np.float64)
    n_obs, n_dip = obs_all.shape[0], pos.shape[0]
    out = np.zeros((n_obs, 3))
    if n_obs == 0 or n_dip == 0:
        return out
    px, py, pz = (np.ascontiguousarray(pos[:, i]) for i in range(3))
    mom_t = np.ascontiguousarray(mom.T)
    p_dot_m = np.einsum("di,di->d", pos, mom)
    block = max(1, CHUNK_PAIRS // n_dip)
    shape = (min(block, n_obs), n_dip)
    work = [np.empty(shape) for _ in range(4)]
    for start in range(0, n_obs, block):
        stop = min(start + block, n_obs)
        c = stop - start
        comp, ir2, ir3, q = (w[:c] for w in work)
        obs = obs_all[start:stop]
        np.subtract(obs[:, 0:1], px, out=comp)
        np.multiply(comp, comp, out=ir2)
        np.subtract(obs[:, 1:2], py, out=comp)
        np.multiply(comp, comp, out=q)
        ir2 += q
        np.subtract(obs[:, 2:3], pz, out=comp)
        np.multiply(comp, comp, out=q)
        ir2 += q
        np.reciprocal(ir2, out=ir2)  # 1/r²
        np.sqrt(ir2, out=ir3)
        ir3 *= ir2  # 1/r³
        np.matmul(obs, mom_t, out=q)
        q -= p_dot_m  # m·r
        q *= ir3
        q *= ir2  # (m·r)/r⁵
        res = out[start:stop]
        np.multiply(obs, q.sum(axis=1)[:, None], out=res)
        res -= q @ pos  # Σ q r
        res *= 3.0
        res -= ir3 @ mom  # Σ m / r³
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
    ir3 = 1.0 / (r2 * np.sqrt(r2))
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


def tilt_fields(
    angles: F64, rel: F64, body_positions: F64, body_moments: F64, x_only: bool = False
) -> tuple[F64, F64, F64]:
    """Lab-frame B (T) at one observer of rigidly tilted cilia, components each (..., a).

    ``angles`` (a,) rad; ``rel`` (..., 3) observer minus base centre, m; ``body_positions``
    (..., d, 3) m and ``body_moments`` (..., d) A·m² from
    :func:`magcilia.model.layout.ring_layout`. With ``x_only`` only B_x is computed (the others
    come back empty).
    """
    return tilt_field(np.cos(angles), np.sin(angles), rel, body_positions, body_moments, x_only)


def pose_field(observers: F64, positions: F64, moments: F64) -> F64:
    """B (T), shape (a, o, 3), of ``a`` dipole sets (a, d, 3) at observers (o, 3).

    Compiled: one call of :func:`magcilia.model.compiled.dipole_batch` for all poses. NumPy
    fallback: few observers (read-out at the element) vectorised over poses in chunks; many
    observers (field maps) the blocked kernel, pose by pose.
    """
    n_pose, n_dip = positions.shape[:2]
    n_obs = observers.shape[0]
    out = np.zeros((n_pose, n_obs, 3))
    jit = compiled.kernels()
    if jit is not None:
        pos = np.ascontiguousarray(np.swapaxes(positions, 1, 2), dtype=np.float64)
        mom = np.ascontiguousarray(np.swapaxes(moments, 1, 2), dtype=np.float64)
        jit.dipole_batch(np.ascontiguousarray(observers, dtype=np.float64), pos, mom, out)
        return out
    if n_obs * n_dip > 4096:
        for i in range(n_pose):
            out[i] = _dipole_field_numpy(observers, positions[i], moments[i])
        return out
    chunk = max(1, 65536 // max(1, n_obs * n_dip))
    for start in range(0, n_pose, chunk):
        stop = start + chunk
        out[start:stop] = dipole_field_batch(observers, positions[start:stop], moments[start:stop])
    return out
