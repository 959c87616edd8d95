"""The polar table of a force-vector read-out and its bicubic interpolation (no physics).

Each channel's model reading is tabulated on a polar grid of (F, φ): magnitudes ``0 … F_max``
(uniform, nF nodes, the F = 0 row the same for every φ) and directions ``0 … 2π`` (periodic, nφ
nodes). :func:`hermite_coefficients` makes a bicubic Hermite interpolant of it (cubic-spline
derivatives along F, spectral ones along the periodic φ); :func:`evaluate` gives the readings and
their derivatives with respect to (Fx, Fy) anywhere in the disc |F| ≤ F_max, smooth through zero;
:class:`CoarseGrid` is the thinned grid of the coarse search that starts every fit (χ² at its
nodes, one matrix product per block of readings, and the best distinct second minimum).

Units are the caller's (N and T in :class:`~magcilia.BiaxialReadout`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from magcilia.model.azimuth import turn_xy
from magcilia.model.jit import jit

F64 = NDArray[np.float64]

_HERMITE = np.array([[1.0, 0.0, 0.0, 0.0], [0.0, 0.0, 1.0, 0.0],
                     [-3.0, 3.0, -2.0, -1.0], [2.0, -2.0, 1.0, 1.0]])


def _cell_coefficients(f: F64, f_u: F64, f_w: F64, f_uw: F64) -> F64:
    """Bicubic Hermite coefficients a[k, l] (of u^k w^l) per cell: (nF − 1, nφ, c, 4, 4), from
    values and derivatives scaled to unit cells at the nodes (nF, nφ, c), φ periodic."""
    def corners(a: F64) -> tuple[F64, F64, F64, F64]:
        nxt = np.roll(a, -1, axis=1)
        return a[:-1], nxt[:-1], a[1:], nxt[1:]

    f00, f01, f10, f11 = corners(f)
    u00, u01, u10, u11 = corners(f_u)
    w00, w01, w10, w11 = corners(f_w)
    x00, x01, x10, x11 = corners(f_uw)
    g = np.stack([np.stack([f00, f01, w00, w01], -1), np.stack([f10, f11, w10, w11], -1),
                  np.stack([u00, u01, x00, x01], -1), np.stack([u10, u11, x10, x11], -1)], -2)
    return np.einsum("ki,...ij,lj->...kl", _HERMITE, g, _HERMITE)


@dataclass(frozen=True, eq=False)
class CoarseGrid:
    """The coarse search's candidates (the grid's nodes, thinned): magnitudes and azimuths (K,),
    readings (K, c), the rest (F = 0) first and once, then ring after ring of equal magnitude;
    the first ring's node indices, which nodes lie far from which (K, K), and the readings and
    their squares on the padded grid of the compiled search (c, (rings + 2)(nφ + 2))."""

    force: F64
    azimuth: F64
    reading: F64
    square: F64
    ring: NDArray[np.intp]
    far: NDArray[np.bool_]
    pad_reading: F64
    pad_square: F64

    @classmethod
    def build(cls, forces: F64, azimuths: F64, table: F64, span: float) -> CoarseGrid:
        n_r, n_p = forces.size - 1, azimuths.size
        f = np.concatenate([[0.0], np.repeat(forces[1:], n_p)])
        p = np.concatenate([[0.0], np.tile(azimuths, n_r)])
        y = np.concatenate([table[:1, 0], table[1:].reshape(-1, table.shape[-1])])
        idx = 1 + np.arange(n_r * n_p).reshape(n_r, n_p)
        x, yv = f * np.cos(p), f * np.sin(p)
        far = np.hypot(x[:, None] - x[None, :], yv[:, None] - yv[None, :]) > 0.1 * span
        # the padded grid of the compiled search: (c, rings + 2, nφ + 2), row 0 the rest,
        # rows 1… the rings with their ends wrapped, the last row a placeholder (+inf there)
        pad = np.empty((table.shape[-1], n_r + 2, n_p + 2))
        pad[:, 0] = table[0, 0][:, None]
        pad[:, 1:-1, 1:-1] = np.moveaxis(table[1:], -1, 0)
        pad[:, 1:-1, 0], pad[:, 1:-1, -1] = pad[:, 1:-1, -2], pad[:, 1:-1, 1]
        pad[:, -1] = 0.0
        flat = pad.reshape(pad.shape[0], -1)
        return cls(f, p, y, (y * y).T.copy(), idx[0].copy(), far, flat.copy(), flat * flat)

    def search(self, y: F64, w: F64) -> tuple[NDArray[np.intp], NDArray[np.intp]]:
        """For readings ``y`` (b, c) with weights ``w`` (b, c): the best node and the best local
        minimum of χ² at least a tenth of the span from it (−1 where there is none), (b,)
        (compiled, :func:`search_kernel`, or NumPy)."""
        kernel = jit(search_kernel)
        if kernel is not None:
            best = np.empty(y.shape[0], dtype=np.intp)
            second = np.empty(y.shape[0], dtype=np.intp)
            kernel(np.ascontiguousarray(y), np.ascontiguousarray(w), self.pad_reading,
                   self.pad_square, self.ring.size, self.far, best, second)
            return best, second
        return self.search_numpy(y, w)

    def search_numpy(self, y: F64, w: F64) -> tuple[NDArray[np.intp], NDArray[np.intp]]:
        """:meth:`search` in NumPy (the reference)."""
        chi = w @ self.square - 2.0 * (w * y) @ self.reading.T  # χ² − Σ w y² (b, K)
        best = np.argmin(chi, axis=1)
        g = chi[:, 1:].reshape(chi.shape[0], -1, self.ring.size)  # (b, rings, φ)
        loc = np.empty(g.shape, dtype=bool)  # ≤ its four neighbours (slices: no gathers)
        np.less_equal(g[..., 1:], g[..., :-1], out=loc[..., 1:])
        np.less_equal(g[..., :1], g[..., -1:], out=loc[..., :1])
        loc[..., :-1] &= g[..., :-1] <= g[..., 1:]
        loc[..., -1:] &= g[..., -1:] <= g[..., :1]
        loc[:, 1:] &= g[:, 1:] <= g[:, :-1]
        loc[:, :-1] &= g[:, :-1] <= g[:, 1:]
        loc[:, 0] &= g[:, 0] <= chi[:, :1]
        local = np.concatenate([(chi[:, 0] <= g[:, 0].min(axis=1))[:, None],
                                loc.reshape(chi.shape[0], -1)], axis=1)
        local &= self.far[best]
        masked = np.where(local, chi, np.inf)
        second = np.argmin(masked, axis=1)
        found = np.isfinite(masked[np.arange(chi.shape[0]), second])
        return best, np.where(found, second, -1)


def hermite_coefficients(forces: F64, table: F64) -> F64:
    """Bicubic Hermite coefficients of the table (nF, nφ, c): derivatives along F from a cubic
    spline (not-a-knot), along the periodic φ spectrally (FFT), in unit-cell scale."""
    from scipy.interpolate import CubicSpline

    n_phi = table.shape[1]
    h_f = float(forces[1] - forces[0])
    h_phi = 2.0 * math.pi / n_phi
    d_f = CubicSpline(forces, table, axis=0).derivative()(forces)
    k = np.fft.fftfreq(n_phi, d=1.0 / n_phi)
    if n_phi % 2 == 0:
        k[n_phi // 2] = 0.0

    def d_phi(a: F64) -> F64:
        return np.real(np.fft.ifft(1j * k[None, :, None] * np.fft.fft(a, axis=1), axis=1))

    f_u = d_f * h_f
    f_w = d_phi(table) * h_phi
    f_uw = d_phi(d_f) * h_f * h_phi
    f_w[0] = 0.0  # the rest row is the same for every φ
    coef = _cell_coefficients(table, f_u, f_w, f_uw)
    coef = np.ascontiguousarray(coef)
    coef.setflags(write=False)
    return coef


def evaluate(coef: F64, h_f: float, fx: F64, fy: F64, derivatives: bool = True
             ) -> tuple[F64, F64, F64]:
    """The interpolant of :func:`hermite_coefficients` ``coef`` (grid step ``h_f`` in F, N):
    readings (b, c), T, and d/dFx, d/dFy (b, c), T/N, at forces (``fx``, ``fy``, N, (b,)) with
    magnitude ≤ the grid's end (without ``derivatives``: the readings three times); compiled
    (:func:`evaluate_kernel`) or NumPy (:func:`evaluate_numpy`)."""
    kernel = jit(evaluate_kernel)
    if kernel is None:
        return evaluate_numpy(coef, h_f, fx, fy, derivatives)
    b, c = np.size(fx), coef.shape[2]
    val = np.empty((b, c))
    d_x = np.empty((b, c)) if derivatives else val
    d_y = np.empty((b, c)) if derivatives else val
    kernel(coef, float(h_f), np.ascontiguousarray(fx, dtype=np.float64).reshape(-1),
           np.ascontiguousarray(fy, dtype=np.float64).reshape(-1), derivatives, val, d_x, d_y,
           _NONE, _NONE, _NO_ROWS)
    return val, d_x, d_y


_NONE = np.zeros((0, 0))
_NO_ROWS = np.zeros(0, dtype=np.intp)


def whitened(coef: F64, h_f: float, x: F64, y: F64, root_w: F64, which: NDArray[np.intp]
             ) -> tuple[F64, F64]:
    """Whitened residuals and their Jacobian for a least-squares fit of readings to the
    interpolant :func:`evaluate`: at forces ``x`` (m, 2) = (Fx, Fy), N, row i belonging to
    reading ``which[i]`` of ``y`` (b, c), T, with weights ``root_w`` (b, c), 1/T:
    ``root_w[which] (model − y[which])`` (m, c) and its derivatives (m, c, 2), 1/N; one
    compiled pass (:func:`evaluate_kernel`) or NumPy."""
    kernel = jit(evaluate_kernel)
    if kernel is None:
        val, d_x, d_y = evaluate_numpy(coef, h_f, x[:, 0], x[:, 1])
        rw = root_w[which]
        return rw * (val - y[which]), np.stack([d_x, d_y], -1) * rw[..., None]
    m, c = x.shape[0], coef.shape[2]
    res = np.empty((m, c))
    jac = np.empty((m, c, 2))
    kernel(coef, float(h_f), np.ascontiguousarray(x[:, 0]), np.ascontiguousarray(x[:, 1]), True,
           res, jac[:, :, 0], jac[:, :, 1], y, root_w, which)
    return res, jac


def evaluate_numpy(coef: F64, h_f: float, fx: F64, fy: F64, derivatives: bool = True
                   ) -> tuple[F64, F64, F64]:
    """:func:`evaluate` in NumPy (the reference)."""
    n_f, n_phi = coef.shape[0] + 1, coef.shape[1]
    h_phi = 2.0 * math.pi / n_phi
    mag = np.hypot(fx, fy)
    phi = np.arctan2(fy, fx) % (2.0 * math.pi)
    u = mag / h_f
    i = np.minimum(u.astype(np.intp), n_f - 2)
    u -= i
    w = phi / h_phi
    j = np.minimum(w.astype(np.intp), n_phi - 1)
    w -= j
    cell = coef[i, j]  # (b, c, 4, 4)
    one = np.ones_like(u)
    uu = np.stack([one, u, u * u, u * u * u], -1)
    ww = np.stack([one, w, w * w, w * w * w], -1)
    cw = np.einsum("bckl,bl->bck", cell, ww)
    val = np.einsum("bck,bk->bc", cw, uu)
    if not derivatives:
        return val, val, val
    zero = np.zeros_like(u)
    du = np.stack([zero, one, 2 * u, 3 * u * u], -1) / h_f
    dw = np.stack([zero, one, 2 * w, 3 * w * w], -1) / h_phi
    d_f = np.einsum("bck,bk->bc", cw, du)
    # dB/dφ / F: in the first cell the u^0 terms of dB/dφ vanish (the F = 0 row is constant),
    # so divide the polynomial by u exactly there
    first = (i == 0)[:, None]
    safe = np.where(mag > 0.0, mag, 1.0)[:, None]
    uq = np.where(first, np.stack([zero, one, u, u * u], -1) / h_f, uu / safe)
    d_phi_over_f = np.einsum("bckl,bk,bl->bc", cell, uq, dw)
    d_x, d_y = turn_xy(d_f, d_phi_over_f, phi[:, None])  # (∂/∂F, ∂/(F ∂φ)) turned by φ
    return val, d_x, d_y


def onto_disc_rows(x: F64, edge: float) -> F64:
    """Points ``x`` (m, 2) = (Fx, Fy) projected radially onto the disc of radius ``edge``
    (:func:`onto_disc`), (m, 2); compiled (:func:`disc_kernel`) or NumPy."""
    kernel = jit(disc_kernel)
    if kernel is None:
        return np.stack(onto_disc(x[:, 0], x[:, 1], edge)[:2], -1)
    out = np.empty((x.shape[0], 2))
    kernel(np.ascontiguousarray(x, dtype=np.float64), float(edge), out)
    return out


def onto_disc(fx: F64, fy: F64, edge: float) -> tuple[F64, F64, F64]:
    """(Fx, Fy) (b,) projected radially onto the disc of radius ``edge`` (where the table
    lives), and the factor applied (b,), 1 inside."""
    mag = np.hypot(fx, fy)
    shrink = np.where(mag > edge, edge / np.maximum(mag, 1e-300), 1.0)
    return fx * shrink, fy * shrink, shrink


# -- compiled twins (numba source; :func:`magcilia.model.jit.jit`) ---------------------------------

def evaluate_kernel(coef: F64, h_f: float, fx: F64, fy: F64, derivatives: bool, val: F64,
                    d_x: F64, d_y: F64, y: F64, root_w: F64, which: NDArray[np.intp]) -> None:
    """:func:`evaluate_numpy` per reading (numba source): ``val``, ``d_x``, ``d_y`` (b, c); with
    ``which`` non-empty (b,), whitened in the same pass (:func:`whitened`): ``root_w[which]``
    × (``val`` − ``y[which]``) and ``root_w[which]`` × the derivatives."""
    n_f, n_phi, n_c = coef.shape[0] + 1, coef.shape[1], coef.shape[2]
    whiten = which.size > 0
    h_phi = 2.0 * math.pi / n_phi
    to_f, to_phi = 1.0 / h_f, 1.0 / h_phi  # products, not divisions, in the loop
    for b in range(fx.size):
        mag = math.hypot(fx[b], fy[b])
        phi = math.atan2(fy[b], fx[b])  # (−π, π]: … % 2π without the remainder's cost
        if phi < 0.0:
            phi += 2.0 * math.pi
        u = mag / h_f
        i = min(int(u), n_f - 2)
        u -= i
        w = phi / h_phi
        j = min(int(w), n_phi - 1)
        w -= j
        w2, u2 = w * w, u * u
        inv = 1.0 / mag if mag > 0.0 else 1.0
        cs, sn = (fx[b] * inv, fy[b] * inv) if mag > 0.0 else (1.0, 0.0)  # cos φ, sin φ
        for k in range(n_c):
            cw0 = coef[i, j, k, 0, 0] + w * (coef[i, j, k, 0, 1] + w * (
                coef[i, j, k, 0, 2] + w * coef[i, j, k, 0, 3]))
            cw1 = coef[i, j, k, 1, 0] + w * (coef[i, j, k, 1, 1] + w * (
                coef[i, j, k, 1, 2] + w * coef[i, j, k, 1, 3]))
            cw2 = coef[i, j, k, 2, 0] + w * (coef[i, j, k, 2, 1] + w * (
                coef[i, j, k, 2, 2] + w * coef[i, j, k, 2, 3]))
            cw3 = coef[i, j, k, 3, 0] + w * (coef[i, j, k, 3, 1] + w * (
                coef[i, j, k, 3, 2] + w * coef[i, j, k, 3, 3]))
            val[b, k] = cw0 + u * (cw1 + u * (cw2 + u * cw3))
            if derivatives:
                d_f = (cw1 + u * (2.0 * cw2 + 3.0 * u * cw3)) * to_f
                # dB/dφ per row of the cell: Σ_l a[k, l] l w^(l−1) / h_phi
                e0 = (coef[i, j, k, 0, 1] + 2.0 * w * coef[i, j, k, 0, 2]
                      + 3.0 * w2 * coef[i, j, k, 0, 3]) * to_phi
                e1 = (coef[i, j, k, 1, 1] + 2.0 * w * coef[i, j, k, 1, 2]
                      + 3.0 * w2 * coef[i, j, k, 1, 3]) * to_phi
                e2 = (coef[i, j, k, 2, 1] + 2.0 * w * coef[i, j, k, 2, 2]
                      + 3.0 * w2 * coef[i, j, k, 2, 3]) * to_phi
                e3 = (coef[i, j, k, 3, 1] + 2.0 * w * coef[i, j, k, 3, 2]
                      + 3.0 * w2 * coef[i, j, k, 3, 3]) * to_phi
                if i == 0:  # the u⁰ row vanishes: divide by u exactly
                    dpf = (e1 + u * e2 + u2 * e3) * to_f
                else:
                    dpf = (e0 + u * e1 + u2 * e2 + u2 * u * e3) * inv
                d_x[b, k] = cs * d_f - sn * dpf
                d_y[b, k] = sn * d_f + cs * dpf
            if whiten:
                rw = root_w[which[b], k]
                val[b, k] = rw * (val[b, k] - y[which[b], k])
                if derivatives:
                    d_x[b, k] *= rw
                    d_y[b, k] *= rw


def disc_kernel(x: F64, edge: float, out: F64) -> None:
    """:func:`onto_disc` per point (numba source): ``out`` (m, 2)."""
    for i in range(x.shape[0]):
        mag = math.hypot(x[i, 0], x[i, 1])
        shrink = edge / max(mag, 1e-300) if mag > edge else 1.0
        out[i, 0] = x[i, 0] * shrink
        out[i, 1] = x[i, 1] * shrink


def search_kernel(y: F64, w: F64, pad_reading: F64, pad_square: F64, n_phi: int,
                  far: NDArray[np.bool_], best: NDArray[np.intp],
                  second: NDArray[np.intp]) -> None:
    """:meth:`CoarseGrid.search_numpy` per reading (numba source): χ² − Σ w y² at every node,
    the best node, and the best local minimum (≤ its four neighbours on the polar grid, the
    rest's neighbours the first ring) far from it. χ² is formed on the padded grid
    (:attr:`CoarseGrid.pad_reading`: the rest below the first ring, each ring's ends wrapped;
    the row above the last set to +inf) so that the neighbour tests need no wrap-around; the
    best node by eight running minima and a first-match scan; "far" tested at local minima only
    (they are few)."""
    n_c, n_pad = pad_reading.shape
    width = n_phi + 2
    rings = n_pad // width - 2
    chi = np.empty(n_pad)
    grid = chi.reshape((rings + 2, width))  # the same memory, row by row
    lanes = np.empty(8)
    for b in range(y.shape[0]):
        a, q = w[b, 0], -2.0 * w[b, 0] * y[b, 0]
        sq, rd = pad_square[0], pad_reading[0]
        for k in range(n_pad):  # χ² − Σ w y² = Σ_c w (Y² − 2 y Y), node by node (vectorised)
            chi[k] = a * sq[k] + q * rd[k]
        for c in range(1, n_c):
            a, q = w[b, c], -2.0 * w[b, c] * y[b, c]
            sq, rd = pad_square[c], pad_reading[c]
            for k in range(n_pad):
                chi[k] += a * sq[k] + q * rd[k]
        for p in range(width):
            grid[rings + 1, p] = math.inf
        # the best node: the smallest χ² (eight running minima, vectorised), then its first node
        for q in range(8):
            lanes[q] = math.inf
        end = chi.size - chi.size % 8
        for k in range(0, end, 8):
            for q in range(8):
                v = chi[k + q]
                lanes[q] = min(lanes[q], v)
        low = chi[end] if end < chi.size else math.inf
        for k in range(end + 1, chi.size):
            low = min(low, chi[k])
        for q in range(8):
            low = min(low, lanes[q])
        top = 0
        if grid[0, 1] != low:  # node 0 is the rest (padded row 0); then ring after ring
            for r in range(1, rings + 1):
                row = grid[r]
                for p in range(n_phi):
                    if row[p + 1] == low:
                        top = 1 + (r - 1) * n_phi + p
                        break
                if top:
                    break
        best[b] = top
        far_top = far[top]
        rest = grid[0, 1]
        ring1 = grid[1, 1]
        for p in range(1, n_phi):
            ring1 = min(ring1, grid[1, 1 + p])
        # the best far local minimum: local minima are few, so test "far" only at them
        pick, pick_chi = -1, math.inf
        if rest <= ring1 and far_top[0]:
            pick, pick_chi = 0, rest
        for r in range(1, rings + 1):
            row, inner, outer = grid[r], grid[r - 1], grid[r + 1]
            k0 = 1 + (r - 1) * n_phi
            for p in range(n_phi):
                g = row[p + 1]
                if ((g <= row[p]) & (g <= row[p + 2]) & (g <= inner[p + 1])
                        & (g <= outer[p + 1])) and g < pick_chi and far_top[k0 + p]:
                    pick, pick_chi = k0 + p, g
        second[b] = pick
