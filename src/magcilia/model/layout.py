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
                 total_moment: float | F64, k: int) -> tuple[F64, F64]:
    """Lab-frame dipoles of cilia whose slices follow (bent) centrelines.

    Each slice's ring lies in the plane normal to the local tangent t = (sin θ, 0, cos θ), with
    azimuth 0 along e1 = (cos θ, 0, −sin θ); its moment is along t.

    Parameters
    ----------
    points : ndarray, shape (a, n, 3)
        Slice mid-points of a poses relative to the base centre, m.
    angles : ndarray, shape (a, n)
        Tangent angles there, rad.
    base : ndarray, shape (3,) or (a, 3)
        Base centre, m (one per pose: cilia of several setups at once).
    radius : ndarray, shape (n,) or (a, n)
        Ring radii, m.
    share : ndarray, shape (n,) or (a, n)
        V_s / V_c of each slice.
    total_moment : float or ndarray, shape (a,)
        m_c, A·m².
    k : int
        Dipoles per ring.

    Returns
    -------
    positions, moments : ndarray, shape (a, n*k, 3)
        m and A·m².
    """
    n = radius.shape[-1]
    st, ct = np.sin(angles), np.cos(angles)
    alpha = 2.0 * math.pi * np.arange(k) / k
    ca, sa = np.cos(alpha), np.sin(alpha)
    a = angles.shape[0]
    # each component's plane contiguous ((a, 3, n, k) in memory): the compiled kernel's layout,
    # (a, 3, d), is then a view of the result, not a copy
    pos = np.empty((a, 3, n, k)).transpose(0, 2, 3, 1)
    rad = np.reshape(radius, (-1, n))[:, :, None]  # (1 or a, n, 1)
    ring_c = rad * ca  # along e1
    pos[..., 0] = points[:, :, None, 0] + ring_c * ct[:, :, None]
    pos[..., 1] = points[:, :, None, 1] + rad * sa
    pos[..., 2] = points[:, :, None, 2] - ring_c * st[:, :, None]
    pos += np.reshape(base, (-1, 1, 1, 3))
    mom = np.empty((a, 3, n, k)).transpose(0, 2, 3, 1)
    mk = np.reshape(total_moment, (-1, 1, 1)) * np.reshape(share, (-1, n))[:, :, None] / k
    mom[..., 0] = mk * st[:, :, None]
    mom[..., 1] = 0.0
    mom[..., 2] = mk * ct[:, :, None]
    return pos.reshape(a, n * k, 3), mom.reshape(a, n * k, 3)


def spatial_dipoles(points: F64, tangents: F64, normals: F64, base: F64, radius: F64,
                    share: F64, total_moment: float, k: int) -> tuple[F64, F64]:
    """Lab-frame dipoles of cilia whose slices follow centrelines in space.

    Ring dipole j of slice i sits at ``p_i + r_i (cos α_j e1_i + sin α_j e2_i)``, α_j = 2πj/k,
    ``e2 = t × e1``, and carries ``m_c · share_i / k`` along the tangent ``t_i`` (the contract of
    :class:`~magcilia.model.centreline.SpatialCentreline`; for a planar frame, e1 =
    (cos θ, 0, −sin θ), it is :func:`pose_dipoles`).

    Parameters
    ----------
    points, tangents, normals : ndarray, shape (a, n, 3)
        Slice mid-points relative to the base centre (m), unit tangents t and unit normals e1 there.
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
    a = points.shape[0]
    alpha = 2.0 * math.pi * np.arange(k) / k
    ca, sa = np.cos(alpha), np.sin(alpha)
    e2 = cross(tangents, normals)
    rc = radius[None, :, None, None] * ca[None, None, :, None]  # (1, n, k, 1)
    rs = radius[None, :, None, None] * sa[None, None, :, None]
    pos = points[:, :, None, :] + rc * normals[:, :, None, :] + rs * e2[:, :, None, :]
    pos += base
    mk = total_moment * share / k  # (n,)
    mom = np.broadcast_to((mk[None, :, None] * tangents)[:, :, None, :], (a, n, k, 3))
    return pos.reshape(a, n * k, 3), np.ascontiguousarray(mom).reshape(a, n * k, 3)


def cross(a: F64, b: F64) -> F64:
    """Cross products of vectors (..., 3) (``numpy.cross`` without its overhead)."""
    a0, a1, a2 = a[..., 0], a[..., 1], a[..., 2]
    b0, b1, b2 = b[..., 0], b[..., 1], b[..., 2]
    return np.stack([a1 * b2 - a2 * b1, a2 * b0 - a0 * b2, a0 * b1 - a1 * b0], axis=-1)


def _dot(a: F64, b: F64) -> F64:
    """Dot products of vectors (..., 3), shape (...)."""
    return np.asarray(a[..., 0] * b[..., 0] + a[..., 1] * b[..., 1] + a[..., 2] * b[..., 2])


def _rotate(vec: F64, axis: F64, cos: F64, sin: F64) -> F64:
    """Vectors (..., 3) perpendicular to the unit ``axis`` (..., 3), turned about it."""
    return vec * cos[..., None] + cross(axis, vec) * sin[..., None]


def spatial_frames(s: F64, points: F64, tangents: F64, normals: F64,
                   s_query: F64) -> tuple[F64, F64, F64]:
    """Positions, tangents and normals of centrelines in space at arc lengths ``s_query``.

    Positions: the cubic Hermite interpolant with the tangents as derivatives (as
    :meth:`~magcilia.model.centreline.SpatialCentreline.frames`). Tangents: spherical linear
    interpolation between the grid's (the rotation about ``t0 × t1`` by a share of the angle
    between them), so that a planar shape turned by :meth:`SpatialCentreline.from_planar` gives
    exactly the planar model's frames (whose tangent angle is interpolated linearly) at any
    arc length, not only at the grid points. Normals: e1 of the interval's start carried by the
    same rotation, then turned about the tangent by the share of the rest angle that closes the
    interval on the next normal (zero for planar shapes).

    Parameters
    ----------
    s : ndarray, shape (m,)
        Arc-length grid, m.
    points, tangents, normals : ndarray, shape (a, m, 3)
        The centrelines' grid values (m, unit vectors).
    s_query : ndarray, shape (q,)
        Arc lengths in [0, L], m.

    Returns
    -------
    points, tangents, normals : ndarray, shape (a, q, 3)
    """
    idx = np.clip(np.searchsorted(s, s_query, side="right") - 1, 0, s.size - 2)
    h = (s[idx + 1] - s[idx])[:, None]
    tau = (s_query - s[idx]) / h[:, 0]
    t0, t1 = tangents[:, idx], tangents[:, idx + 1]
    p0, p1 = points[:, idx], points[:, idx + 1]
    t = tau[:, None]
    t2, t3 = t * t, t * t * t
    pts = ((2 * t3 - 3 * t2 + 1) * p0 + (t3 - 2 * t2 + t) * h * t0
           + (-2 * t3 + 3 * t2) * p1 + (t3 - t2) * h * t1)
    axis = cross(t0, t1)
    sin_w = np.sqrt(_dot(axis, axis))
    omega = np.arctan2(sin_w, _dot(t0, t1))
    safe = np.where(sin_w > 0.0, sin_w, 1.0)[..., None]
    axis = np.where(sin_w[..., None] > 0.0, axis / safe, 0.0)
    turn = tau * omega
    cos_t, sin_t = np.cos(turn), np.sin(turn)
    tan = _rotate(t0, axis, cos_t, sin_t)
    e0, e1_next = normals[:, idx], normals[:, idx + 1]
    # e0 turned with the tangent (the axis is perpendicular to t0 but not always to e0)
    along = _dot(axis, e0)[..., None] * axis
    e_mid = along + _rotate(e0 - along, axis, cos_t, sin_t)
    e_end = along + _rotate(e0 - along, axis, np.cos(omega), np.sin(omega))
    delta = np.arctan2(_dot(cross(e_end, e1_next), t1), _dot(e_end, e1_next))
    rest = tau * delta
    nor = _rotate(e_mid, tan, np.cos(rest), np.sin(rest))
    return pts, tan, nor
