"""An array's field from tabulated planar shapes, and its analytic Jacobian in the tip forces.

The forward map of :class:`magcilia.ArrayReadout` on plain values, fused: for every set of
horizontal tip forces F (b, C, 2) (N), each cilium's planar shape at its slice mid-points from
its cubic table against |F| (x, z, θ and their slopes d/d|F|), turned to the azimuth
φ = atan2(Fy, Fx) with the rings fixed in the board (as
:meth:`magcilia.model.array.ArrayLayout.planar_dipoles`), its dipoles and their field at every
sensor, on the sensors' axes, summed over the cilia; optionally the Jacobian of that field in
each cilium's (Fx, Fy), chained analytically:

* a dipole's position p and moment m in |F| and φ (the table's slopes; the turn), then in
  (Fx, Fy): ∂/∂Fx = cos φ ∂/∂|F| − sin φ (1/|F|) ∂/∂φ, ∂/∂Fy = sin φ ∂/∂|F| + cos φ (1/|F|) ∂/∂φ,
  where (1/|F|) ∂/∂φ is written with x/|F|, sin θ/|F| and (1 − cos θ)/|F| (the shape is odd in
  F through zero load: below :data:`SMALL` of the span these become x', θ' cos θ and θ' sin θ,
  the limits, so that the Jacobian is continuous through F = 0);
* the dipole field B = μ0/4π (3 r (m·r)/r⁵ − m/r³), r = observer − p, changes by
  μ0/4π (3/r⁵ (a dr + b m + (c + e − 5 a b / r²) r) − dm/r³) with a = m·r, b = r·dr,
  c = m·dr, e = r·dm, dr = −dp.

:func:`table_field` runs the numba kernel (:func:`magcilia.model.jit.jit`: compiled on first use,
cached on disk; off with ``compiled.ENABLED = False``) or the NumPy reference
:func:`table_field_numpy` that the tests hold it to.

Shape letters: ``b`` force sets, ``C`` cilia, ``S`` sensors, ``D`` dipoles of the array, ``K``
tables, ``g`` table intervals, ``n`` slices (the most of any cilium).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from magcilia.constants import MU0_OVER_4PI
from magcilia.model.jit import jit

F64 = NDArray[np.float64]
I64 = NDArray[np.int64]

#: below this fraction of its table's span a force's (1/|F|) ∂/∂φ terms take their limits at
#: zero load (x/|F| → x', …): their error there is ~SMALL² of the slope
SMALL = 1e-6


@dataclass(frozen=True, eq=False)
class TabulatedArray:
    """What :func:`table_field` needs of an array read-out, as plain contiguous arrays (SI).

    Attributes
    ----------
    observers : ndarray, shape (S, 3)
        Sensor positions, m, board frame.
    rotations : ndarray, shape (S, 3, 3)
        Each sensor's axes as columns (board frame): the reading is ``B @ R``.
    bases : ndarray, shape (C, 3)
        Base centres, m.
    starts : ndarray, shape (C + 1,)
        Cilium c's dipoles are ``starts[c]:starts[c + 1]``.
    local : ndarray, shape (D,)
        Each dipole's slice within its cilium (0 … n_c − 1).
    ring_cos, ring_sin, moment : ndarray, shape (D,)
        Ring offsets ``r cos α``, ``r sin α`` (m) and moments (A·m²).
    kind : ndarray, shape (C,)
        Each cilium's table.
    slices : ndarray, shape (C,)
        Each cilium's slices n_c.
    coefficients : ndarray, shape (K, 4, g, 3 n)
        The tables' cubic coefficients per interval (highest power first; x, z, θ of n_c slices
        in columns 0, n_c, 2 n_c …; zero padded).
    span, step : ndarray, shape (K,)
        Each table's largest force and grid step, N (the grid is uniform over [−span, span]).
    """

    observers: F64
    rotations: F64
    bases: F64
    starts: I64
    local: I64
    ring_cos: F64
    ring_sin: F64
    moment: F64
    kind: I64
    slices: I64
    coefficients: F64
    span: F64
    step: F64

    @property
    def cilia(self) -> int:
        """C."""
        return int(self.kind.size)

    @property
    def sensors(self) -> int:
        """S."""
        return int(self.observers.shape[0])


def table_field(model: TabulatedArray, forces: F64, jacobian: bool = False
                ) -> tuple[F64, F64 | None]:
    """Field on the sensors' axes at force sets, and optionally its Jacobian.

    Parameters
    ----------
    model : TabulatedArray
    forces : ndarray, shape (b, C, 2)
        Horizontal tip forces (Fx, Fy) per cilium, N, board frame.
    jacobian : bool
        Also the Jacobian.

    Returns
    -------
    field : ndarray, shape (b, 3 S)
        Every sensor's reading (x, y, z on its axes), T, all cilia summed.
    jac : ndarray, shape (b, 3 S, 2 C), or None
        ∂ reading / ∂ (Fx, Fy) of cilium c in columns 2c, 2c + 1, T/N.
    """
    f = np.ascontiguousarray(forces, dtype=np.float64)
    b = f.shape[0]
    field = np.empty((b, 3 * model.sensors))
    jac = np.empty((b, 3 * model.sensors, 2 * model.cilia)) if jacobian else None
    kernel = jit(table_field_kernel, fastmath=True)
    if kernel is None:
        field[:], j = table_field_numpy(model, f, jacobian)
        if jac is not None and j is not None:
            jac[:] = j
        return field, jac
    work = np.empty((18 if jacobian else 6, int(model.starts[-1])))
    kernel(model.observers, model.rotations, model.bases, model.starts, model.local,
           model.ring_cos, model.ring_sin, model.moment, model.kind, model.slices,
           model.coefficients, model.span, model.step, f, field,
           jac if jac is not None else np.empty((0, 0, 0)), jacobian, work)
    return field, jac


# -- the shared pieces (NumPy; the kernel writes the same algebra per dipole) ----------------------

def _frames(model: TabulatedArray, magnitude: F64) -> tuple[F64, ...]:
    """x, z, θ and their slopes d/d|F| (b, D) of every dipole's slice at magnitudes (b, C)."""
    c_of = np.repeat(np.arange(model.cilia), np.diff(model.starts))
    kind = model.kind[c_of]
    n = model.slices[c_of]
    cells = model.coefficients.shape[2]
    mag = magnitude[:, c_of]
    span, step = model.span[kind], model.step[kind]
    idx = np.clip(((mag + span) / step).astype(np.int64), 0, cells - 1)
    u = mag + span - idx * step
    out = []
    for part in range(3):
        col = part * n + model.local
        c0, c1, c2, c3 = (model.coefficients[kind, p, idx, col] for p in range(4))
        out.append(((c0 * u + c1) * u + c2) * u + c3)
        out.append((3.0 * c0 * u + 2.0 * c1) * u + c2)
    x, dx, z, dz, th, dth = out
    return x, z, th, dx, dz, dth


def table_field_numpy(model: TabulatedArray, forces: F64, jacobian: bool = False
                      ) -> tuple[F64, F64 | None]:
    """:func:`table_field` in NumPy (the reference; all pairs (b, S, D) at once)."""
    b_n, c_n, s_n = forces.shape[0], model.cilia, model.sensors
    mag = np.hypot(forces[..., 0], forces[..., 1])  # (b, C)
    phi = np.arctan2(forces[..., 1], forces[..., 0])
    c_of = np.repeat(np.arange(c_n), np.diff(model.starts))
    x, z, th, dx, dz, dth = _frames(model, mag)
    cp, sp = np.cos(phi)[:, c_of], np.sin(phi)[:, c_of]
    ct, st = np.cos(th), np.sin(th)
    rc = model.ring_cos * cp + model.ring_sin * sp
    rs = model.ring_sin * cp - model.ring_cos * sp
    lx = x + rc * ct
    pos = np.stack([cp * lx - sp * rs, sp * lx + cp * rs, z - rc * st], axis=-1)
    pos += model.bases[c_of]
    mom = model.moment[:, None] * np.stack([cp * st, sp * st, ct], axis=-1)
    r = model.observers[None, :, None, :] - pos[:, None]  # (b, S, D, 3)
    ir2 = 1.0 / np.einsum("bsdi,bsdi->bsd", r, r)
    ir3 = ir2 * np.sqrt(ir2)
    ir5 = ir3 * ir2
    a = np.einsum("bsdi,bdi->bsd", r, mom)
    field_d = MU0_OVER_4PI * (3.0 * (a * ir5)[..., None] * r - ir3[..., None] * mom[:, None])
    to_axes = model.rotations  # (S, 3, 3): reading_k = Σ_i B_i R[i, k]
    field = np.einsum("bsi,sik->bsk", field_d.sum(axis=2), to_axes).reshape(b_n, -1)
    if not jacobian:
        return field, None
    # slopes of the dipoles in |F| and (1/|F|) in φ
    lxm = dx - rc * st * dth
    pm = np.stack([cp * lxm, sp * lxm, dz - rc * ct * dth], axis=-1)
    mm = model.moment[:, None] * dth[..., None] * np.stack([cp * ct, sp * ct, -st], axis=-1)
    small = mag[:, c_of] < SMALL * model.span[model.kind[c_of]]
    safe = np.where(small, 1.0, mag[:, c_of])
    gx = np.where(small, dx, x / safe)
    gs = np.where(small, ct * dth, st / safe)
    gc = np.where(small, st * dth, (1.0 - ct) / safe)
    pf = np.stack([-sp * gx + gc * (sp * rc - cp * rs), cp * gx - gc * (cp * rc + sp * rs),
                   -rs * gs], axis=-1)
    mf = model.moment[:, None] * gs[..., None] * np.stack([-sp, cp, np.zeros_like(sp)], axis=-1)
    jac_d = np.empty((b_n, s_n, len(c_of), 3, 2))
    for k, (u_m, u_f) in enumerate(((cp, -sp), (sp, cp))):
        dp = u_m[..., None] * pm + u_f[..., None] * pf  # (b, D, 3)
        dm = u_m[..., None] * mm + u_f[..., None] * mf
        dr = -dp[:, None]
        bb = np.einsum("bsdi,bsdi->bsd", r, dr)
        cc = np.einsum("bdi,bsdi->bsd", mom, dr)
        ee = np.einsum("bsdi,bdi->bsd", r, dm)
        inner = (a[..., None] * dr + bb[..., None] * mom[:, None]
                 + (cc + ee - 5.0 * a * bb * ir2)[..., None] * r)
        jac_d[..., k] = MU0_OVER_4PI * (3.0 * ir5[..., None] * inner
                                        - ir3[..., None] * dm[:, None])
    per_cilium = np.add.reduceat(jac_d, model.starts[:-1], axis=2)  # (b, S, C, 3, 2)
    jac = np.einsum("bsCik,sil->bslCk", per_cilium, to_axes).reshape(b_n, 3 * s_n, 2 * c_n)
    return field, jac


# -- the compiled kernel (numba source) ------------------------------------------------------------

def table_field_kernel(observers: F64, rotations: F64, bases: F64, starts: I64, local: I64,
                       ring_cos: F64, ring_sin: F64, moment: F64, kind: I64, slices: I64,
                       coefficients: F64, span: F64, step: F64, forces: F64, field: F64,
                       jac: F64, with_jac: bool, work: F64) -> None:
    """:func:`table_field` compiled (numba source): per force set, every cilium's dipoles from
    its table's frames (and their slopes in (Fx, Fy)) into ``work`` ((6 or 18), D), then every
    sensor's field as one sum over all dipoles, or with the Jacobian cilium by cilium."""
    n_set, n_cil, n_obs = forces.shape[0], kind.size, observers.shape[0]
    cells = coefficients.shape[2]
    for s in range(n_set):
        for i in range(3 * n_obs):
            field[s, i] = 0.0
        for c in range(n_cil):
            fx, fy = forces[s, c, 0], forces[s, c, 1]
            mag = math.hypot(fx, fy)
            phi = math.atan2(fy, fx)
            cp, sp = math.cos(phi), math.sin(phi)
            t = kind[c]
            n = slices[c]
            idx = int((mag + span[t]) / step[t])
            idx = min(max(idx, 0), cells - 1)
            u = mag + span[t] - idx * step[t]
            small = mag < SMALL * span[t]
            j0, j1 = starts[c], starts[c + 1]
            bx, by, bz = bases[c, 0], bases[c, 1], bases[c, 2]
            last = -1
            x = dx = z = dz = th = dth = ct = st = 0.0
            for j in range(j1 - j0):
                q = local[j0 + j]
                if q != last:  # a new slice: its frame and slopes from the table, once
                    last = q
                    col = q
                    c0, c1 = coefficients[t, 0, idx, col], coefficients[t, 1, idx, col]
                    c2, c3 = coefficients[t, 2, idx, col], coefficients[t, 3, idx, col]
                    x = ((c0 * u + c1) * u + c2) * u + c3
                    dx = (3.0 * c0 * u + 2.0 * c1) * u + c2
                    col = n + q
                    c0, c1 = coefficients[t, 0, idx, col], coefficients[t, 1, idx, col]
                    c2, c3 = coefficients[t, 2, idx, col], coefficients[t, 3, idx, col]
                    z = ((c0 * u + c1) * u + c2) * u + c3
                    dz = (3.0 * c0 * u + 2.0 * c1) * u + c2
                    col = 2 * n + q
                    c0, c1 = coefficients[t, 0, idx, col], coefficients[t, 1, idx, col]
                    c2, c3 = coefficients[t, 2, idx, col], coefficients[t, 3, idx, col]
                    th = ((c0 * u + c1) * u + c2) * u + c3
                    dth = (3.0 * c0 * u + 2.0 * c1) * u + c2
                    ct, st = math.cos(th), math.sin(th)
                r0c, r0s, mo = ring_cos[j0 + j], ring_sin[j0 + j], moment[j0 + j]
                rc = r0c * cp + r0s * sp
                rs = r0s * cp - r0c * sp
                lx = x + rc * ct
                work[0, j0 + j] = cp * lx - sp * rs + bx
                work[1, j0 + j] = sp * lx + cp * rs + by
                work[2, j0 + j] = z - rc * st + bz
                work[3, j0 + j] = mo * cp * st
                work[4, j0 + j] = mo * sp * st
                work[5, j0 + j] = mo * ct
                if with_jac:
                    lxm = dx - rc * st * dth
                    pmx, pmy, pmz = cp * lxm, sp * lxm, dz - rc * ct * dth
                    mmx, mmy, mmz = mo * dth * cp * ct, mo * dth * sp * ct, -mo * dth * st
                    if small:
                        gx, gs, gc = dx, ct * dth, st * dth
                    else:
                        gx, gs, gc = x / mag, st / mag, (1.0 - ct) / mag
                    pfx = -sp * gx + gc * (sp * rc - cp * rs)
                    pfy = cp * gx - gc * (cp * rc + sp * rs)
                    pfz = -rs * gs
                    mfx, mfy = -mo * gs * sp, mo * gs * cp
                    # (Fx, Fy) slopes: dr = −dp, stored negated
                    work[6, j0 + j] = -(cp * pmx - sp * pfx)
                    work[7, j0 + j] = -(cp * pmy - sp * pfy)
                    work[8, j0 + j] = -(cp * pmz - sp * pfz)
                    work[9, j0 + j] = cp * mmx - sp * mfx
                    work[10, j0 + j] = cp * mmy - sp * mfy
                    work[11, j0 + j] = cp * mmz
                    work[12, j0 + j] = -(sp * pmx + cp * pfx)
                    work[13, j0 + j] = -(sp * pmy + cp * pfy)
                    work[14, j0 + j] = -(sp * pmz + cp * pfz)
                    work[15, j0 + j] = sp * mmx + cp * mfx
                    work[16, j0 + j] = sp * mmy + cp * mfy
                    work[17, j0 + j] = sp * mmz
        if not with_jac:  # every dipole at once per sensor (one long vectorised loop)
            px, py, pz = work[0], work[1], work[2]
            mx, my, mz = work[3], work[4], work[5]
            for i in range(n_obs):
                ox, oy, oz = observers[i, 0], observers[i, 1], observers[i, 2]
                b0, b1, b2 = 0.0, 0.0, 0.0
                for j in range(px.size):
                    rx, ry, rz = ox - px[j], oy - py[j], oz - pz[j]
                    ir2 = 1.0 / (rx * rx + ry * ry + rz * rz)
                    ir3 = ir2 * math.sqrt(ir2)
                    qa = 3.0 * (mx[j] * rx + my[j] * ry + mz[j] * rz) * ir3 * ir2
                    b0 += qa * rx - mx[j] * ir3
                    b1 += qa * ry - my[j] * ir3
                    b2 += qa * rz - mz[j] * ir3
                for k in range(3):
                    field[s, 3 * i + k] = MU0_OVER_4PI * (
                        b0 * rotations[i, 0, k] + b1 * rotations[i, 1, k]
                        + b2 * rotations[i, 2, k])
            continue
        for c in range(n_cil):  # cilium by cilium: each has its own Jacobian columns
            j0, j1 = starts[c], starts[c + 1]
            px, py, pz = work[0, j0:j1], work[1, j0:j1], work[2, j0:j1]
            mx, my, mz = work[3, j0:j1], work[4, j0:j1], work[5, j0:j1]
            ax, ay, az = work[6, j0:j1], work[7, j0:j1], work[8, j0:j1]
            dmx, dmy, dmz = work[9, j0:j1], work[10, j0:j1], work[11, j0:j1]
            cx, cy, cz = work[12, j0:j1], work[13, j0:j1], work[14, j0:j1]
            emx, emy, emz = work[15, j0:j1], work[16, j0:j1], work[17, j0:j1]
            for i in range(n_obs):
                ox, oy, oz = observers[i, 0], observers[i, 1], observers[i, 2]
                b0, b1, b2 = 0.0, 0.0, 0.0
                g0, g1, g2, h0, h1, h2 = 0.0, 0.0, 0.0, 0.0, 0.0, 0.0
                for j in range(px.size):
                    rx, ry, rz = ox - px[j], oy - py[j], oz - pz[j]
                    ir2 = 1.0 / (rx * rx + ry * ry + rz * rz)
                    ir3 = ir2 * math.sqrt(ir2)
                    ir5 = ir3 * ir2
                    a = mx[j] * rx + my[j] * ry + mz[j] * rz
                    qa = 3.0 * a * ir5
                    b0 += qa * rx - mx[j] * ir3
                    b1 += qa * ry - my[j] * ir3
                    b2 += qa * rz - mz[j] * ir3
                    # along Fx
                    bb = rx * ax[j] + ry * ay[j] + rz * az[j]
                    cc = mx[j] * ax[j] + my[j] * ay[j] + mz[j] * az[j]
                    ee = rx * dmx[j] + ry * dmy[j] + rz * dmz[j]
                    w = cc + ee - 5.0 * a * bb * ir2
                    g0 += 3.0 * ir5 * (a * ax[j] + bb * mx[j] + w * rx) - ir3 * dmx[j]
                    g1 += 3.0 * ir5 * (a * ay[j] + bb * my[j] + w * ry) - ir3 * dmy[j]
                    g2 += 3.0 * ir5 * (a * az[j] + bb * mz[j] + w * rz) - ir3 * dmz[j]
                    # along Fy
                    bb = rx * cx[j] + ry * cy[j] + rz * cz[j]
                    cc = mx[j] * cx[j] + my[j] * cy[j] + mz[j] * cz[j]
                    ee = rx * emx[j] + ry * emy[j] + rz * emz[j]
                    w = cc + ee - 5.0 * a * bb * ir2
                    h0 += 3.0 * ir5 * (a * cx[j] + bb * mx[j] + w * rx) - ir3 * emx[j]
                    h1 += 3.0 * ir5 * (a * cy[j] + bb * my[j] + w * ry) - ir3 * emy[j]
                    h2 += 3.0 * ir5 * (a * cz[j] + bb * mz[j] + w * rz) - ir3 * emz[j]
                for k in range(3):
                    jac[s, 3 * i + k, 2 * c] = MU0_OVER_4PI * (
                        g0 * rotations[i, 0, k] + g1 * rotations[i, 1, k]
                        + g2 * rotations[i, 2, k])
                    jac[s, 3 * i + k, 2 * c + 1] = MU0_OVER_4PI * (
                        h0 * rotations[i, 0, k] + h1 * rotations[i, 1, k]
                        + h2 * rotations[i, 2, k])
                for k in range(3):
                    field[s, 3 * i + k] += MU0_OVER_4PI * (
                        b0 * rotations[i, 0, k] + b1 * rotations[i, 1, k]
                        + b2 * rotations[i, 2, k])
