"""The paper's distributed-dipole model (eqs. 1–5): n slices × k dipoles per slice.

Pure functions over arrays; :class:`magcilia.Setup` wraps them with checks. Slice i of n spans arc
length [i L/n, (i+1) L/n]; its k dipoles sit at the slice's mid-arc-length on a ring (radius
"mean" = (r_bottom + r_top)/2 as in the paper, or "rms" = sqrt<rho²>) at azimuths 2πj/k measured
from the bending direction, and each carries ``m_s / k`` (eq. 5's ``m_i / n`` is a typo for
``m_i / k``) along the local tangent, with ``m_s = (V_s / V_c) m_c`` (eq. 2).
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import ArrayLike, NDArray

from magcilia.device.cilium import profile_integrals
from magcilia.model.kernels import dipole_field, dipole_field_batch, tilt_field

if TYPE_CHECKING:
    from magcilia.device.setup import Setup
    from magcilia.model.centreline import Centreline

F64 = NDArray[np.float64]


def ring_layout(
    height: F64, base_radius: F64, tip_radius: F64, n: int, k: int, ring: str = "mean",
    profile: tuple[Sequence[float], Sequence[float]] | None = None,
) -> tuple[F64, F64]:
    """Dipole positions and moment weights of straight cilia in the body frame.

    Parameters
    ----------
    height, base_radius, tip_radius : ndarray, shape (N,)
        Geometry of N cilia, m.
    n, k : int
        Slices and dipoles per slice.
    ring : {"mean", "rms"}
        Ring radius rule.
    profile : (u, rho) or None
        A measured normalised shape shared by all N cilia (:attr:`magcilia.Cilium.profile`),
        scaled by each height and base radius; ``tip_radius`` is then unused.

    Returns
    -------
    positions : ndarray, shape (N, n*k, 3)
        Body frame (axis along z from the base centre, bending direction along x), m.
    weights : ndarray, shape (N, n*k)
        Fraction of the total moment carried by each dipole (sums to 1 per cilium).
    """
    h = np.asarray(height, dtype=np.float64)[:, None]
    rb = np.asarray(base_radius, dtype=np.float64)[:, None]
    rt = np.asarray(tip_radius, dtype=np.float64)[:, None]
    u = np.linspace(0.0, 1.0, n + 1)[None, :]
    if profile is None:
        r = rb + (rt - rb) * u  # (N, n+1)
        r1, r2 = r[:, :-1], r[:, 1:]
        int2 = (r1 * r1 + r1 * r2 + r2 * r2) / 3.0  # slice volume / (pi dh)
        int4 = (r1**4 + r1**3 * r2 + r1**2 * r2**2 + r1 * r2**3 + r2**4) / 5.0
    else:
        knots, shape = np.asarray(profile[0]), np.asarray(profile[1])
        r = rb * np.interp(u, knots, shape)
        r1, r2 = r[:, :-1], r[:, 1:]
        mean2, mean4 = profile_integrals(knots, shape, n)
        int2, int4 = rb**2 * mean2, rb**4 * mean4
    if ring == "mean":
        rho = 0.5 * (r1 + r2)
    else:
        rho = np.sqrt(0.5 * int4 / np.where(int2 > 0.0, int2, 1.0))
    frac = int2 / int2.sum(axis=1, keepdims=True)  # V_s / V_c  (N, n)
    z_mid = h * (np.arange(n) + 0.5)[None, :] / n  # (N, n)
    alpha = 2.0 * math.pi * np.arange(k) / k
    ca, sa = np.cos(alpha), np.sin(alpha)
    pos = np.empty((h.shape[0], n, k, 3))
    pos[..., 0] = rho[:, :, None] * ca
    pos[..., 1] = rho[:, :, None] * sa
    pos[..., 2] = z_mid[:, :, None]
    weights = np.repeat(frac / k, k, axis=1)
    return pos.reshape(h.shape[0], n * k, 3), weights


def tilt_fields(
    angles: F64, rel: F64, body_positions: F64, body_moments: F64, x_only: bool = False
) -> tuple[F64, F64, F64]:
    """Lab-frame B (T) at one observer of rigidly tilted cilia, components each (..., a).

    ``angles`` (a,) rad; ``rel`` (..., 3) observer minus base centre, m; ``body_positions``
    (..., d, 3) m and ``body_moments`` (..., d) A·m² from :func:`ring_layout`. With ``x_only``
    only B_x is computed (the others come back empty).
    """
    return tilt_field(np.cos(angles), np.sin(angles), rel, body_positions, body_moments, x_only)


def pose_dipoles(
    centreline: Centreline,
    base: F64,
    rho: F64,
    fractions: F64,
    total_moment: float,
    k: int,
) -> tuple[F64, F64]:
    """Lab-frame dipoles of cilia whose slices follow a (bent) centreline.

    Each slice's ring lies in the plane normal to the local tangent t = (sin θ, 0, cos θ), with
    azimuth 0 along e1 = (cos θ, 0, −sin θ); its moment is along t.

    Parameters
    ----------
    centreline : Centreline
        a poses; n = ``rho.size`` slices of equal arc length.
    base : ndarray, shape (3,)
        Base centre, m.
    rho : ndarray, shape (n,)
        Ring radii, m.
    fractions : ndarray, shape (n,)
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
    n = rho.size
    s_mid = centreline.length * (np.arange(n) + 0.5) / n
    pts, th = centreline.frames(s_mid)  # (a, n, 3), (a, n)
    st, ct = np.sin(th), np.cos(th)
    alpha = 2.0 * math.pi * np.arange(k) / k
    ca, sa = np.cos(alpha), np.sin(alpha)
    a = th.shape[0]
    pos = np.empty((a, n, k, 3))
    ring_c = rho[None, :, None] * ca  # along e1
    pos[..., 0] = pts[:, :, None, 0] + ring_c * ct[:, :, None]
    pos[..., 1] = pts[:, :, None, 1] + rho[None, :, None] * sa
    pos[..., 2] = pts[:, :, None, 2] - ring_c * st[:, :, None]
    pos += base
    mom = np.empty((a, n, k, 3))
    mk = total_moment * fractions[None, :, None] / k
    mom[..., 0] = mk * st[:, :, None]
    mom[..., 1] = 0.0
    mom[..., 2] = mk * ct[:, :, None]
    return pos.reshape(a, n * k, 3), mom.reshape(a, n * k, 3)


def pose_field(observers: F64, positions: F64, moments: F64) -> F64:
    """B (T), shape (a, o, 3), of ``a`` dipole sets (a, d, 3) at observers (o, 3).

    Few observers (read-out at the element): vectorised over poses in chunks. Many observers
    (field maps): the blocked kernel :func:`~magcilia._kernels.dipole_field`, pose by pose.
    """
    n_pose, n_dip = positions.shape[:2]
    n_obs = observers.shape[0]
    out = np.empty((n_pose, n_obs, 3))
    if n_obs * n_dip > 4096:
        for i in range(n_pose):
            out[i] = dipole_field(observers, positions[i], moments[i])
        return out
    chunk = max(1, 65536 // max(1, n_obs * n_dip))
    for start in range(0, n_pose, chunk):
        stop = start + chunk
        out[start:stop] = dipole_field_batch(observers, positions[start:stop], moments[start:stop])
    return out


_BATCH_KEYS = ("height", "base_radius", "x", "y", "z", "n_loops", "dipoles_per_loop")


def tilt_field_batch(
    setup: Setup, params: Mapping[str, ArrayLike], angles: ArrayLike, x_only: bool = False
) -> F64:
    """B (T) at the sensing element for N parameter sets and a tilt angles: shape (N, a, 3).

    Fast path for optimisers and global sensitivity analysis: no input checks.

    Parameters
    ----------
    setup : Setup
        Supplies every parameter not given in ``params`` (material, sensor depth, ring rule…).
    params : mapping of str to array-like, each shape (N,)
        Any of ``height``, ``base_radius``, ``tip_radius`` (m), ``x``, ``y``, ``z`` (m, the
        paper's position), ``n_loops``, ``dipoles_per_loop`` (integers) and
        ``magnetization_scale``. Missing keys take the value of ``setup``.
    angles : array-like, shape (a,)
        Tilt angles, rad.

    Notes
    -----
    Samples are grouped by (n, k); each group is one vectorised kernel call. With ``x_only``
    only B_x is filled in (the other components are zero).
    """
    ang = np.asarray(angles, dtype=np.float64)
    sizes = {np.size(v) for v in params.values()}
    n_set = max(sizes) if sizes else 1
    defaults = setup.params()

    def get(key: str) -> F64:
        val = params.get(key, defaults[key])
        return np.broadcast_to(np.asarray(val, dtype=np.float64), (n_set,))

    h, rb, rt = get("height"), get("base_radius"), get("tip_radius")
    base = np.stack([get("x"), get("y"), get("z") + setup.sensor.depth], axis=-1)
    nl = np.rint(get("n_loops")).astype(np.int64)
    kd = np.rint(get("dipoles_per_loop")).astype(np.int64)
    mat = setup.material
    magnetization = get("magnetization_scale") * mat.volume_fraction * mat.cobalt_magnetization
    profile = setup.cilium.profile
    if profile is None:
        volume = math.pi * h / 3.0 * (rb * rb + rb * rt + rt * rt)
    else:  # the measured shape, scaled by each height and base radius
        mean2 = profile_integrals(np.asarray(profile[0]), np.asarray(profile[1]), 1)[0][0]
        volume = math.pi * h * rb * rb * mean2
    moment = magnetization * volume
    out = np.zeros((n_set, ang.size, 3))
    cos_t, sin_t = np.cos(ang), np.sin(ang)
    keys = nl * 100_003 + kd
    for key in np.unique(keys):
        sel = np.nonzero(keys == key)[0]
        n, k = int(nl[sel[0]]), int(kd[sel[0]])
        pos, w = ring_layout(h[sel], rb[sel], rt[sel], n, k, setup.ring, profile)
        bx, by, bz = tilt_field(cos_t, sin_t, -base[sel], pos, w * moment[sel, None], x_only)
        out[sel, :, 0] = bx
        if not x_only:
            out[sel, :, 1], out[sel, :, 2] = by, bz
    return out


def tilt_output_batch(
    setup: Setup, params: Mapping[str, ArrayLike], angles: ArrayLike
) -> F64:
    """Sensor output (V) for N parameter sets at a tilt angles: shape (N, a).

    As :func:`tilt_field_batch`, plus an optional ``offset`` key (V) in ``params``; the sensor's
    scale (V/T) comes from ``setup.sensor``.
    """
    bx = tilt_field_batch(setup, params, angles, x_only=True)[..., 0]
    offset = np.asarray(params.get("offset", setup.sensor.offset), dtype=np.float64)
    return setup.sensor.scale * bx + np.reshape(offset, (-1, 1))
