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
that LLVM vectorises only when it may reorder them (and fuse multiply-adds), and to ``contract``
in :func:`tilt_jacobian_batch` (fused multiply-adds: 15 % faster, measured): both change results
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

from magcilia._jit import compile_kernel
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


#: the derivative columns of :func:`tilt_jacobian_batch`: height, base radius, base centre x, y, z
#: (m) and the magnetization (A/m, the packed column; × the full magnetization for the scale)
JACOBIAN_COLUMNS = ("height", "base_radius", "x", "y", "z", "magnetization")


def tilt_jacobian_batch(params: F64, angles: F64, knots: F64, radii: F64, measured: bool,
                        rms: bool, scale: float, out: F64, jac: F64) -> bool:
    """:func:`tilt_batch` and the derivatives of what it writes with respect to
    :data:`JACOBIAN_COLUMNS`, in the same pass (numba source).

    The dipole field's gradient with respect to the observer is closed form (the symmetric,
    traceless tensor ``∂B_i/∂v_l`` of ``B = 3 v (m·v)/|v|⁵ − m/|v|³``); it is summed per slice in
    the body frame and chained through the layout: the base centre moves the observer (turned by
    the tilt), the height moves the slices along the axis and scales every moment, the base radius
    moves the rings outward and scales the moments (for a frustum of a held tip radius, the taper
    tip / base radius changes too: its ring radii and slice volumes are differentiated alongside,
    forward mode), and the magnetization scales the field.

    Parameters
    ----------
    params, angles, knots, radii, measured, rms, scale, out
        As :func:`tilt_batch`.
    jac : ndarray, shape (N, a, c, 6)
        Filled with the derivatives of ``out`` (c = ``out.shape[2]``): V or T per m, per A/m.

    Returns
    -------
    bool
        Whether every value and derivative written is finite.
    """
    n_set, n_ang, full = params.shape[0], angles.size, out.shape[2] == 3
    n_max, k_max = 1, 1
    for i in range(n_set):
        n_max = max(n_max, int(params[i, 6]))
        k_max = max(k_max, int(params[i, 7]))
    size = min(n_ang, ANGLE_BLOCK)
    cos_t, sin_t, ox, oz = np.empty(size), np.empty(size), np.empty(size), np.empty(size)
    # per slice, per angle: field (3), gradient tensor (xx, xy, xz, yz, zz) and its ring sums (3)
    loc = np.empty((11, size))
    # totals: field (3), tensor (5), height (3), ring positions (3), ring moments (3)
    tot = np.empty((17, size))
    ring, share, dring, dshare = np.empty(n_max), np.empty(n_max), np.empty(n_max), np.empty(n_max)
    ca, sa = np.empty(k_max), np.empty(k_max)
    u, rho = knots, radii.copy()
    drho = np.zeros(radii.size)  # ∂rho / ∂taper: (0, 1) for a frustum, 0 for a measured shape
    if not measured:
        drho[1] = 1.0
    n_prev, k_prev = -1, -1
    finite = True
    for a0 in range(0, n_ang, ANGLE_BLOCK):
        na = min(ANGLE_BLOCK, n_ang - a0)
        for t in range(na):
            cos_t[t], sin_t[t] = math.cos(angles[a0 + t]), math.sin(angles[a0 + t])
        for i in range(n_set):
            h, rb = params[i, 0], params[i, 1]
            n, k = int(params[i, 6]), int(params[i, 7])
            taper = 0.0
            if not measured:
                taper = params[i, 2]
                rho[1] = taper
            if not measured or n != n_prev:  # as tilt_batch, with ∂/∂taper alongside
                n_prev = n
                step, kk, q = 1.0 / n, 1, u.size
                ta, ra, da = 0.0, rho[0], drho[0]
                for j in range(n):
                    te = 1.0 if j == n - 1 else (j + 1) * step
                    r_start, d_start, s2, s4, d2, d4 = ra, da, 0.0, 0.0, 0.0, 0.0
                    while True:
                        inner = kk < q - 1 and u[kk] < te
                        if inner:
                            tb, rb_, db = u[kk], rho[kk], drho[kk]
                        else:
                            w = (te - u[kk - 1]) / (u[kk] - u[kk - 1])
                            tb = te
                            rb_ = rho[kk - 1] * (1.0 - w) + rho[kk] * w
                            db = drho[kk - 1] * (1.0 - w) + drho[kk] * w
                        a2, b2, ab = ra * ra, rb_ * rb_, ra * rb_
                        s2 += (tb - ta) * (a2 + ab + b2) / 3.0
                        s4 += (tb - ta) * (a2 * a2 + a2 * ab + a2 * b2 + ab * b2 + b2 * b2) / 5.0
                        d2 += (tb - ta) * ((2.0 * ra + rb_) * da + (ra + 2.0 * rb_) * db) / 3.0
                        d4 += (tb - ta) * ((4.0 * a2 * ra + 3.0 * a2 * rb_ + 2.0 * ra * b2
                                            + b2 * rb_) * da
                                           + (a2 * ra + 2.0 * a2 * rb_ + 3.0 * ra * b2
                                              + 4.0 * b2 * rb_) * db) / 5.0
                        ta, ra, da = tb, rb_, db
                        if not inner:
                            break
                        kk += 1
                    if rms:
                        ring[j] = math.sqrt(0.5 * s4 / (s2 if s2 > 0.0 else 1.0))
                        dring[j] = (0.25 * (d4 * s2 - s4 * d2) / (s2 * s2 * ring[j])
                                    if ring[j] > 0.0 and s2 > 0.0 else 0.0)
                    else:
                        ring[j] = 0.5 * (r_start + ra)
                        dring[j] = 0.5 * (d_start + da)
                    share[j], dshare[j] = s2, d2
            if k != k_prev:
                k_prev = k
                for m in range(k):
                    alpha = 2.0 * math.pi * m / k
                    ca[m], sa[m] = math.cos(alpha), math.sin(alpha)
            moment = math.pi * h * rb * rb / k  # per unit magnetization
            rx, ry, rz = -params[i, 3], -params[i, 4], -params[i, 5]
            for t in range(na):
                ox[t] = cos_t[t] * rx - sin_t[t] * rz
                oz[t] = sin_t[t] * rx + cos_t[t] * rz
            if full:
                for c in range(17):
                    for t in range(na):
                        tot[c, t] = 0.0
                for j in range(n):
                    radius, pz, mj = rb * ring[j], h * (j + 0.5) / n, moment * share[j]
                    for c in range(11):
                        for t in range(na):
                            loc[c, t] = 0.0
                    for m in range(k):
                        cm, sm = ca[m], sa[m]
                        px, vy = radius * cm, ry - radius * sm
                        vy2 = vy * vy
                        for t in range(na):
                            vx, vz = ox[t] - px, oz[t] - pz
                            ir2 = 1.0 / (vx * vx + vz * vz + vy2)
                            mr3 = mj * ir2 * math.sqrt(ir2)  # m / r³
                            tt = 3.0 * mr3 * ir2  # 3 m / r⁵
                            qz = tt * vz
                            g = 5.0 * qz * ir2  # 15 m v_z / r⁷
                            txx = qz - g * vx * vx
                            txy = -g * vx * vy
                            txz = tt * vx - g * vx * vz
                            tyz = tt * vy - g * vy * vz
                            tzz = 3.0 * qz - g * vz * vz
                            loc[0, t] += qz * vx
                            loc[1, t] += qz * vy
                            loc[2, t] += qz * vz - mr3
                            loc[3, t] += txx
                            loc[4, t] += txy
                            loc[5, t] += txz
                            loc[6, t] += tyz
                            loc[7, t] += tzz
                            loc[8, t] += cm * txx + sm * txy
                            loc[9, t] += cm * txy - sm * (txx + tzz)  # t_yy = −(t_xx + t_zz)
                            loc[10, t] += cm * txz + sm * tyz
                    # the slice's chain factors: its place along the axis (∝ h), its ring radius
                    # and its moment as functions of the base radius (∂ ln m_j / ∂ r_b)
                    zf = (j + 0.5) / n
                    dradius = ring[j] - taper * dring[j]
                    fw = (2.0 - taper * dshare[j] / share[j]) / rb if share[j] > 0.0 else 2.0 / rb
                    for t in range(na):
                        for c in range(8):
                            tot[c, t] += loc[c, t]
                        tot[8, t] -= zf * loc[5, t]
                        tot[9, t] -= zf * loc[6, t]
                        tot[10, t] -= zf * loc[7, t]
                        for c in range(3):
                            tot[11 + c, t] -= dradius * loc[8 + c, t]
                            tot[14 + c, t] += fw * loc[c, t]
            else:
                for c in range(7):
                    for t in range(na):
                        tot[c, t] = 0.0
                bl, gx, gy, gz, gh, bw, ga = tot[0], tot[1], tot[2], tot[3], tot[4], tot[5], tot[6]
                for j in range(n):
                    radius, pz, mj = rb * ring[j], h * (j + 0.5) / n, moment * share[j]
                    zf = (j + 0.5) / n
                    dradius = ring[j] - taper * dring[j]
                    fw = (2.0 - taper * dshare[j] / share[j]) / rb if share[j] > 0.0 else 2.0 / rb
                    for m in range(k):
                        cm, sm = ca[m], sa[m]
                        px, vy = radius * cm, ry - radius * sm
                        vy2 = vy * vy
                        for t in range(na):
                            ct, st = cos_t[t], sin_t[t]
                            vx, vz = ox[t] - px, oz[t] - pz
                            ir2 = 1.0 / (vx * vx + vz * vz + vy2)
                            mr3 = mj * ir2 * math.sqrt(ir2)  # m / r³
                            tt = 3.0 * mr3 * ir2  # 3 m / r⁵
                            e = ct * vx + st * vz
                            vze = vz * e
                            b = tt * vze - st * mr3
                            kk = st * tt - 5.0 * tt * ir2 * vze
                            dx = kk * vx + tt * vz * ct
                            dy = kk * vy
                            dz = kk * vz + tt * (e + vz * st)
                            bl[t] += b
                            gx[t] += dx
                            gy[t] += dy
                            gz[t] += dz
                            gh[t] -= zf * dz
                            bw[t] += fw * b
                            ga[t] -= dradius * (cm * dx + sm * dy)
            mag, offset = params[i, 8], params[i, 9]
            f = MU0_OVER_4PI * mag
            for t in range(na):
                ct, st = cos_t[t], sin_t[t]
                if not full:  # tot: B_x (lab), its gradient (lab x; body axes), h, r_b sums
                    b_lab = tot[0, t]
                    v = scale * f * b_lab + offset
                    out[i, a0 + t, 0] = v
                    g = (tot[4, t] + b_lab / h, tot[5, t] + tot[6, t],
                         -ct * tot[1, t] - st * tot[3, t], -tot[2, t],
                         st * tot[1, t] - ct * tot[3, t])
                    finite &= math.isfinite(v)
                    for c in range(5):
                        d = scale * f * g[c]
                        jac[i, a0 + t, 0, c] = d
                        finite &= math.isfinite(d)
                    jac[i, a0 + t, 0, 5] = scale * MU0_OVER_4PI * b_lab
                    continue
                bx, by, bz = tot[0, t], tot[1, t], tot[2, t]
                txx, txy, txz, tyz, tzz = tot[3, t], tot[4, t], tot[5, t], tot[6, t], tot[7, t]
                tyy = -(txx + tzz)
                # body-frame derivatives (per unit magnetization), columns JACOBIAN_COLUMNS
                gx = (tot[8, t] + bx / h, tot[11, t] + tot[14, t],
                      -ct * txx - st * txz, -txy, st * txx - ct * txz, bx)
                gy = (tot[9, t] + by / h, tot[12, t] + tot[15, t],
                      -ct * txy - st * tyz, -tyy, st * txy - ct * tyz, by)
                gz = (tot[10, t] + bz / h, tot[13, t] + tot[16, t],
                      -ct * txz - st * tzz, -tyz, st * txz - ct * tzz, bz)
                out[i, a0 + t, 0] = f * (ct * bx + st * bz)
                out[i, a0 + t, 1] = f * by
                out[i, a0 + t, 2] = f * (ct * bz - st * bx)
                for c in range(6):
                    w = MU0_OVER_4PI if c == 5 else f
                    jac[i, a0 + t, 0, c] = w * (ct * gx[c] + st * gz[c])
                    jac[i, a0 + t, 1, c] = w * gy[c]
                    jac[i, a0 + t, 2, c] = w * (ct * gz[c] - st * gx[c])
                    finite &= (math.isfinite(jac[i, a0 + t, 0, c])
                               and math.isfinite(jac[i, a0 + t, 1, c])
                               and math.isfinite(jac[i, a0 + t, 2, c]))
                finite &= (math.isfinite(out[i, a0 + t, 0]) and math.isfinite(out[i, a0 + t, 1])
                           and math.isfinite(out[i, a0 + t, 2]))
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
    tilt_jacobian_batch: Callable[[F64, F64, F64, F64, bool, bool, float, F64, F64], bool]
    dipole_batch: Callable[[F64, F64, F64, F64], None]
    segment_batch: Callable[[F64, F64, F64, NDArray[np.int64], F64], None]


@cache
def _compile() -> Kernels | None:
    tilt = compile_kernel(tilt_batch)
    tilt_jacobian = compile_kernel(tilt_jacobian_batch, fastmath=frozenset({"contract"}))
    dipole = compile_kernel(dipole_batch, fastmath=True)
    segment = compile_kernel(segment_batch, fastmath=True)
    if tilt is None or tilt_jacobian is None or dipole is None or segment is None:
        return None  # numba cannot be imported
    return Kernels(tilt, tilt_jacobian, dipole, segment)


def kernels() -> Kernels | None:
    """The compiled kernels, or None where numba cannot be imported or :data:`ENABLED` is False.

    The first call imports numba (~0.5 s); each kernel compiles on its first call, or loads from
    numba's disk cache."""
    return _compile() if ENABLED else None
