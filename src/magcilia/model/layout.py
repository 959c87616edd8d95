"""The paper's distributed-dipole layout (eqs. 1–5): n slices × k dipoles per slice.

Slice i of n spans arc length [i L/n, (i+1) L/n]; its k dipoles sit at the slice's mid-arc-length
on a ring (radius "mean" = (r_bottom + r_top)/2 as in the paper, or "rms" = sqrt<rho²>) at azimuths
2πj/k measured from the bending direction, and each carries ``m_s / k`` (eq. 5's ``m_i / n`` is a
typo for ``m_i / k``) along the local tangent, with ``m_s = (V_s / V_c) m_c`` (eq. 2). Ring radii
and moment shares come from :func:`magcilia.model.body.slice_rings` for straight and bent cilia
alike. Pure functions over arrays, no checks.
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import NDArray

from magcilia.model.body import slice_rings

F64 = NDArray[np.float64]


def ring_layout(height: F64, base_radius: F64, u: F64, rho: F64, n: int, k: int,
                ring: str = "mean") -> tuple[F64, F64]:
    """Dipole positions and moment weights of straight cilia in the body frame.

    Parameters
    ----------
    height, base_radius : ndarray, shape (N,)
        Geometry of N cilia, m.
    u : ndarray, shape (q,)
        Knots of the normalised shape (s / height).
    rho : ndarray, shape (q,) or (N, q)
        Normalised radii (r / base_radius): one shape for all N cilia, or one per cilium.
    n, k : int
        Slices and dipoles per slice.
    ring : {"mean", "rms"}
        Ring radius rule.

    Returns
    -------
    positions : ndarray, shape (N, n*k, 3)
        Body frame (axis along z from the base centre, bending direction along x), m.
    weights : ndarray, shape (N, n*k)
        Fraction of the total moment carried by each dipole (sums to 1 per cilium).
    """
    h = np.asarray(height, dtype=np.float64)[:, None]
    rb = np.asarray(base_radius, dtype=np.float64)[:, None]
    radius, share = slice_rings(u, rho, n, ring)
    radius = rb * radius  # (N, n)
    share = np.broadcast_to(share, radius.shape)
    z_mid = h * (np.arange(n) + 0.5)[None, :] / n  # (N, n)
    alpha = 2.0 * math.pi * np.arange(k) / k
    ca, sa = np.cos(alpha), np.sin(alpha)
    pos = np.empty((h.shape[0], n, k, 3))
    pos[..., 0] = radius[:, :, None] * ca
    pos[..., 1] = radius[:, :, None] * sa
    pos[..., 2] = z_mid[:, :, None]
    weights = np.repeat(share / k, k, axis=1)
    return pos.reshape(h.shape[0], n * k, 3), weights


def pose_dipoles(points: F64, angles: F64, base: F64, radius: F64, share: F64,
                 total_moment: float, k: int) -> tuple[F64, F64]:
    """Lab-frame dipoles of cilia whose slices follow (bent) centrelines.

    Each slice's ring lies in the plane normal to the local tangent t = (sin θ, 0, cos θ), with
    azimuth 0 along e1 = (cos θ, 0, −sin θ); its moment is along t.

    Parameters
    ----------
    points : ndarray, shape (a, n, 3)
        Slice mid-points of a poses relative to the base centre, m.
    angles : ndarray, shape (a, n)
        Tangent angles there, rad.
    base : ndarray, shape (3,)
        Base centre, m.
    radius : ndarray, shape (n,)
        Ring radii, m.
    share : ndarray, shape (n,)
        V_s / V_c of each slice.
    total_moment : float
        m_c, A·m².
    k : int
        Dipoles per ring.

    Returns
    -------
    positions, moments : ndarray, shape (a, n*k, 3)
        m and A·m².
    """
    n = radius.size
    st, ct = np.sin(angles), np.cos(angles)
    alpha = 2.0 * math.pi * np.arange(k) / k
    ca, sa = np.cos(alpha), np.sin(alpha)
    a = angles.shape[0]
    pos = np.empty((a, n, k, 3))
    ring_c = radius[None, :, None] * ca  # along e1
    pos[..., 0] = points[:, :, None, 0] + ring_c * ct[:, :, None]
    pos[..., 1] = points[:, :, None, 1] + radius[None, :, None] * sa
    pos[..., 2] = points[:, :, None, 2] - ring_c * st[:, :, None]
    pos += base
    mom = np.empty((a, n, k, 3))
    mk = total_moment * share[None, :, None] / k
    mom[..., 0] = mk * st[:, :, None]
    mom[..., 1] = 0.0
    mom[..., 2] = mk * ct[:, :, None]
    return pos.reshape(a, n * k, 3), mom.reshape(a, n * k, 3)
