"""Compiled (numba) kernels of the field model, with the NumPy kernels as their reference.

The functions below are plain Python written for numba; :func:`kernels` compiles them on first use
(numba is imported then, never at ``import magcilia``) and caches the machine code on disk
(``cache=True``: later processes load it instead of compiling). Where numba cannot be imported,
:func:`kernels` returns None and the callers (:mod:`.kernels`, :mod:`.batch`, :mod:`.pose`) use the
NumPy implementations, which stay the reference that the tests hold these kernels to (≤ 1e-12
relative).

Compiler options: single-threaded; ``error_model="numpy"`` (a division by zero gives inf or NaN,
as in NumPy, instead of raising: the calibration relies on non-finite rows); fastmath limited to
``reassoc`` and ``contract`` in :func:`dipole_batch`, where the sums over dipoles are reductions
that LLVM vectorises only when it may reorder them (and fuse multiply-adds): both change results
by rounding only (~1e-16 relative per term), while the flags left out (``nnan``, ``ninf``, ``arcp``,
``afn``) could drop the non-finite results or approximate the divide and square root.

Shape letters: ``N`` parameter sets, ``a`` tilt angles (poses), ``o`` observers, ``d`` dipoles.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from functools import cache
from typing import NamedTuple

import numpy as np
from numpy.typing import NDArray

from magcilia.constants import MU0_OVER_4PI

F64 = NDArray[np.float64]

#: use the compiled kernels when numba can be imported (tests set False to run the NumPy reference)
ENABLED = True

#: columns of the packed parameter array that :func:`tilt_batch` reads, one row per set (SI):
#: height and base radius (m), taper (tip / base radius, frustums only), base centre (m, sensor
#: frame), slices n and dipoles per slice k (whole numbers), magnetization (A/m), offset (V)
COLUMNS = ("height", "base_radius", "taper", "x", "y", "z", "n_loops", "dipoles_per_loop",
           "magnetization", "offset")

#: angles per block of :func:`tilt_batch` (its work arrays stay in the cache and memory stays
#: small whatever the number of angles)
ANGLE_BLOCK = 1024

#: dipoles per block of :func:`dipole_batch` (their 48 bytes each, 96 kB, stay in the L2 cache
#: while every observer passes over them: with more than a few thousand dipoles, the pass would
#: otherwise stream them from memory once per observer). Each block is a slice, so that the inner
#: loop runs from 0 over contiguous arrays, which LLVM vectorises; a loop over an index range of
#: the whole arrays (``range(start, stop)``) it did not, at a quarter of the speed.
DIPOLE_BLOCK = 2048


def tilt_batch(params: F64, angles: F64, knots: F64, radii: F64, measured: bool, rms: bool,
               scale: float, out: F64) -> bool:
    """Layout and tilted field at the sensing element of N cilia, fused (numba source).

    Per set: the ring radius and moment share of each slice (exact integrals of the
    piecewise-linear shape, as :func:`magcilia.model.body.slice_rings`), the k dipoles of each
    ring, and their field at the element tilted by each angle, computed in the body frame (the
    observer is rotated, as :func:`magcilia.model.kernels.tilt_field`).

    Parameters
    ----------
    params : ndarray, shape (N, len(COLUMNS))
        One row per set, columns :data:`COLUMNS`.
    angles : ndarray, shape (a,)
        Tilt angles, rad.
    knots, radii : ndarray, shape (q,)
        The shape shared by all sets (s / height, r / base radius), for frustums ``(0, 1)`` and
        ``(1, ·)``.
    measured : bool
        Use ``radii`` as given (True) or each set's frustum, the tip radius ``radii[1]`` replaced
        by the set's ``taper`` (False).
    rms : bool
        Ring radius rule: "rms" (True) or "mean" (False).
    scale : float
        Sensor scale, V/T (with a one-column ``out``).
    out : ndarray, shape (N, a, 1) or (N, a, 3)
        Filled with the output ``scale · B_x + offset`` (V, one column) or the field (T, three).

    Returns
    -------
    bool
        Whether every value written is finite.
    """
    n_set, n_ang, full = params.shape[0], angles.size, out.shape[2] == 3
    n_max, k_max = 1, 1
    for i in range(n_set):
        n_max = max(n_max, int(params[i, 6]))
        k_max = max(k_max, int(params[i, 7]))
    size = min(n_ang, ANGLE_BLOCK)
    cos_t, sin_t, ox, oz = np.empty(size), np.empty(size), np.empty(size), np.empty(size)
    bbx, bby, bbz = np.empty(size), np.empty(size), np.empty(size)
    ring, share = np.empty(n_max), np.empty(n_max)
    ca, sa = np.empty(k_max), np.empty(k_max)
    u, rho = knots, radii.copy()
    n_prev, k_prev = -1, -1
    finite = True
    for a0 in range(0, n_ang, ANGLE_BLOCK):  # blocks of angles: bounded memory
        na = min(ANGLE_BLOCK, n_ang - a0)
        for t in range(na):
            cos_t[t], sin_t[t] = math.cos(angles[a0 + t]), math.sin(angles[a0 + t])
        for i in range(n_set):
            h, rb = params[i, 0], params[i, 1]
            n, k = int(params[i, 6]), int(params[i, 7])
            if not measured:
                rho[1] = params[i, 2]
            if not measured or n != n_prev:  # slice rings (a measured shape's depend on n only)
                n_prev = n
                step, kk, q = 1.0 / n, 1, u.size
                ta, ra = 0.0, rho[0]
                for j in range(n):
                    te = 1.0 if j == n - 1 else (j + 1) * step
                    r_start, s2, s4 = ra, 0.0, 0.0
                    while True:  # pieces of the linear shape within [ta, te]
                        inner = kk < q - 1 and u[kk] < te
                        if inner:
                            tb, rb_ = u[kk], rho[kk]
                        else:
                            w = (te - u[kk - 1]) / (u[kk] - u[kk - 1])
                            tb, rb_ = te, rho[kk - 1] * (1.0 - w) + rho[kk] * w
                        a2, b2, ab = ra * ra, rb_ * rb_, ra * rb_
                        s2 += (tb - ta) * (a2 + ab + b2) / 3.0
                        s4 += (tb - ta) * (a2 * a2 + a2 * ab + a2 * b2 + ab * b2 + b2 * b2) / 5.0
                        ta, ra = tb, rb_
                        if not inner:
                            break
                        kk += 1
                    if rms:
                        ring[j] = math.sqrt(0.5 * s4 / (s2 if s2 > 0.0 else 1.0))
                    else:
                        ring[j] = 0.5 * (r_start + ra)
                    share[j] = s2  # ∫ rho² over the slice: its share times ∫ rho² over the body
            if k != k_prev:
                k_prev = k
                for m in range(k):
                    alpha = 2.0 * math.pi * m / k
                    ca[m], sa[m] = math.cos(alpha), math.sin(alpha)
            moment = params[i, 8] * math.pi * h * rb * rb / k  # M V_c / (k ∫ rho²)
            rx, ry, rz = -params[i, 3], -params[i, 4], -params[i, 5]
            for t in range(na):  # the observer in the body frame (its y is unchanged)
                ox[t] = cos_t[t] * rx - sin_t[t] * rz
                oz[t] = sin_t[t] * rx + cos_t[t] * rz
                bbx[t], bby[t], bbz[t] = 0.0, 0.0, 0.0
            for j in range(n):
                radius, pz, mj = rb * ring[j], h * (j + 0.5) / n, moment * share[j]
                for m in range(k):
                    px, vy = radius * ca[m], ry - radius * sa[m]
                    vy2 = vy * vy
                    for t in range(na):
                        vx, vz = ox[t] - px, oz[t] - pz
                        ir2 = 1.0 / (vx * vx + vz * vz + vy2)
                        mr3 = mj * ir2 * math.sqrt(ir2)  # m / r³
                        q = 3.0 * vz * mr3 * ir2  # 3 (m·v) / r⁵, m along the body z axis
                        bbx[t] += q * vx
                        bby[t] += q * vy
                        bbz[t] += q * vz - mr3
            offset = params[i, 9]
            for t in range(na):
                bx = MU0_OVER_4PI * (cos_t[t] * bbx[t] + sin_t[t] * bbz[t])
                if full:
                    by = MU0_OVER_4PI * bby[t]
                    bz = MU0_OVER_4PI * (cos_t[t] * bbz[t] - sin_t[t] * bbx[t])
                    out[i, a0 + t, 0], out[i, a0 + t, 1], out[i, a0 + t, 2] = bx, by, bz
                    finite &= math.isfinite(bx) and math.isfinite(by) and math.isfinite(bz)
                else:
                    v = scale * bx + offset
                    out[i, a0 + t, 0] = v
                    finite &= math.isfinite(v)
    return finite


def dipole_batch(observers: F64, positions: F64, moments: F64, out: F64) -> None:
    """Field of ``a`` dipole sets at common observers, summed per set (numba source).

    Parameters
    ----------
    observers : ndarray, shape (o, 3)
        m.
    positions, moments : ndarray, shape (a, 3, d)
        Dipole positions (m) and moments (A·m²), components first (contiguous per component).
    out : ndarray, shape (a, o, 3)
        Zeroed on entry; receives B, T.
    """
    n_set, n_obs, n_dip = positions.shape[0], observers.shape[0], positions.shape[2]
    for s in range(n_set):
        for start in range(0, n_dip, DIPOLE_BLOCK):
            stop = min(start + DIPOLE_BLOCK, n_dip)
            px, py, pz = (positions[s, 0, start:stop], positions[s, 1, start:stop],
                          positions[s, 2, start:stop])
            mx, my, mz = (moments[s, 0, start:stop], moments[s, 1, start:stop],
                          moments[s, 2, start:stop])
            for i in range(n_obs):
                x, y, z = observers[i, 0], observers[i, 1], observers[i, 2]
                bx, by, bz = 0.0, 0.0, 0.0
                for j in range(px.size):
                    rx, ry, rz = x - px[j], y - py[j], z - pz[j]
                    ir2 = 1.0 / (rx * rx + ry * ry + rz * rz)
                    ir3 = ir2 * math.sqrt(ir2)
                    q = 3.0 * (mx[j] * rx + my[j] * ry + mz[j] * rz) * ir3 * ir2
                    bx += q * rx - mx[j] * ir3
                    by += q * ry - my[j] * ir3
                    bz += q * rz - mz[j] * ir3
                out[s, i, 0] += MU0_OVER_4PI * bx
                out[s, i, 1] += MU0_OVER_4PI * by
                out[s, i, 2] += MU0_OVER_4PI * bz


def segment_batch(observers: F64, positions: F64, moments: F64, starts: NDArray[np.int64],
                  out: F64) -> None:
    """Field of consecutive segments of one dipole list at common observers, summed per segment
    (numba source): the contribution of each cilium of an array at each sensor.

    Parameters
    ----------
    observers : ndarray, shape (o, 3)
        m.
    positions, moments : ndarray, shape (3, D)
        All dipoles' positions (m) and moments (A·m²), components first.
    starts : ndarray, shape (c + 1,), int64
        Segment c holds dipoles ``starts[c]:starts[c + 1]`` (increasing, ``starts[-1] = D``).
    out : ndarray, shape (c, o, 3)
        Receives B of each segment, T (overwritten).
    """
    n_seg, n_obs = starts.size - 1, observers.shape[0]
    for c in range(n_seg):
        j0, j1 = starts[c], starts[c + 1]
        px, py, pz = positions[0, j0:j1], positions[1, j0:j1], positions[2, j0:j1]
        mx, my, mz = moments[0, j0:j1], moments[1, j0:j1], moments[2, j0:j1]
        for i in range(n_obs):
            x, y, z = observers[i, 0], observers[i, 1], observers[i, 2]
            bx, by, bz = 0.0, 0.0, 0.0
            for j in range(px.size):  # a slice from 0: vectorised (see DIPOLE_BLOCK)
                rx, ry, rz = x - px[j], y - py[j], z - pz[j]
                ir2 = 1.0 / (rx * rx + ry * ry + rz * rz)
                ir3 = ir2 * math.sqrt(ir2)
                q = 3.0 * (mx[j] * rx + my[j] * ry + mz[j] * rz) * ir3 * ir2
                bx += q * rx - mx[j] * ir3
                by += q * ry - my[j] * ir3
                bz += q * rz - mz[j] * ir3
            out[c, i, 0] = MU0_OVER_4PI * bx
            out[c, i, 1] = MU0_OVER_4PI * by
            out[c, i, 2] = MU0_OVER_4PI * bz


class Kernels(NamedTuple):
    """The compiled kernels, with the arguments of the functions of the same name."""

    tilt_batch: Callable[[F64, F64, F64, F64, bool, bool, float, F64], bool]
    dipole_batch: Callable[[F64, F64, F64, F64], None]
    segment_batch: Callable[[F64, F64, F64, NDArray[np.int64], F64], None]


@cache
def _compile() -> Kernels | None:
    try:
        import numba
    except ImportError:  # e.g. a Python that numba does not support yet
        return None

    def build(cache: bool) -> Kernels:
        return Kernels(
            tilt_batch=numba.njit(tilt_batch, cache=cache, error_model="numpy", nogil=True),
            dipole_batch=numba.njit(dipole_batch, cache=cache, error_model="numpy", nogil=True,
                                    fastmath={"reassoc", "contract"}),
            segment_batch=numba.njit(segment_batch, cache=cache, error_model="numpy",
                                     nogil=True, fastmath={"reassoc", "contract"}),
        )

    try:
        return build(cache=True)
    except RuntimeError:  # no writable cache folder (numba's own or NUMBA_CACHE_DIR)
        return build(cache=False)


def kernels() -> Kernels | None:
    """The compiled kernels, or None where numba cannot be imported or :data:`ENABLED` is False.

    The first call imports numba (~0.5 s); each kernel compiles on its first call, or loads from
    numba's disk cache."""
    return _compile() if ENABLED else None
