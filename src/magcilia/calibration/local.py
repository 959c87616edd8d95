"""Levenberg–Marquardt over many independent least-squares problems at once.

The calibration polishes one candidate for every combination of the integer parameters (n, k):
a hundred small problems of five parameters each. Solving them one by one spends the time in
Python; here every iteration evaluates all the problems' residuals, and their forward-difference
Jacobians, in one vectorised call of the model, and solves all the damped normal equations with
one batched ``numpy.linalg.solve``. Bounds are kept by projecting each step onto the box.
"""

from __future__ import annotations

import contextlib
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

F64 = NDArray[np.float64]
Residuals = Callable[[F64, NDArray[np.intp]], F64]


@dataclass(frozen=True)
class LocalFits:
    """Outcome of :func:`levenberg_marquardt` for ``s`` problems.

    Attributes
    ----------
    x : ndarray, shape (s, p)
        Final parameters.
    cost : ndarray, shape (s,)
        Their sums of squared residuals (inf where the residuals were never finite).
    """

    x: F64
    cost: F64


def _sum_squares(r: F64) -> F64:
    with np.errstate(over="ignore", invalid="ignore"):
        c = np.einsum("sa,sa->s", r, r)
    return np.where(np.isfinite(c), c, np.inf)


def _solve(system: F64, rhs: F64) -> F64:
    """Solutions (s, p) of the systems (s, p, p) · δ = rhs (s, p); zero where one is singular."""
    try:
        return np.asarray(np.linalg.solve(system, rhs[:, :, None])[:, :, 0])
    except np.linalg.LinAlgError:  # one singular system: solve them one at a time
        out = np.zeros_like(rhs)
        for i in range(rhs.shape[0]):
            with contextlib.suppress(np.linalg.LinAlgError):
                out[i] = np.linalg.solve(system[i], rhs[i])
        return out


def levenberg_marquardt(
    residuals: Residuals,
    x0: F64,
    lower: F64,
    upper: F64,
    *,
    maxiter: int = 60,
    ftol: float = 1e-12,
    step: float = 1e-7,
    damping: float = 1e-3,
) -> LocalFits:
    """Minimise ``|residuals(x)|²`` from each row of ``x0`` within [``lower``, ``upper``].

    Parameters
    ----------
    residuals : callable
        ``residuals(x, which)``: residual vectors (m, a) of parameter vectors ``x`` (m, p), row
        i belonging to problem ``which[i]``; rows may be non-finite (a bad point: never
        accepted).
    x0 : ndarray, shape (s, p)
        Starting points, inside the bounds.
    lower, upper : ndarray, shape (p,)
        Bounds (lower < upper).
    maxiter : int
        Most iterations.
    ftol : float
        A problem is done when an accepted step lowers its cost by less than this relative
        amount, or when its damping grows beyond any useful step.
    step : float
        Forward-difference step as a fraction of each bound's width.
    damping : float
        Initial Marquardt damping (relative to the diagonal of JᵀJ).

    Returns
    -------
    LocalFits
    """
    x = np.clip(np.array(x0, dtype=np.float64), lower, upper)
    size, dims = x.shape
    h = step * (upper - lower)
    r = residuals(x, np.arange(size))
    cost = _sum_squares(r)
    lam = np.full(size, damping)
    active = np.isfinite(cost)
    eye = np.eye(dims)
    for _ in range(maxiter):
        idx = np.nonzero(active)[0]
        if idx.size == 0:
            break
        xa, ra = x[idx], r[idx]
        # forward differences, stepping away from the nearer bound
        sign = np.where(xa + h > upper, -1.0, 1.0)
        probes = xa[:, None, :] + (sign[:, :, None] * h[None, :, None]) * eye[None]
        rp = residuals(probes.reshape(-1, dims), np.repeat(idx, dims)).reshape(idx.size, dims, -1)
        jac = (rp - ra[:, None, :]) / (sign * h)[:, :, None]  # (s, p, a)
        jtj = np.einsum("spa,sqa->spq", jac, jac)
        jtr = np.einsum("spa,sa->sp", jac, ra)
        # Marquardt's scaling, floored so that a parameter without effect here (a zero column:
        # B_x is even in y, so d/dy = 0 at y = 0) keeps the system regular and stays put
        diag = np.einsum("spp->sp", jtj)
        diag = np.maximum(diag, 1e-12 * diag.max(axis=1, keepdims=True))
        scaled = jtj + lam[idx, None, None] * (diag[:, :, None] * eye[None])
        ok = np.isfinite(scaled).all(axis=(1, 2)) & np.isfinite(jtr).all(axis=1)
        delta = np.zeros_like(xa)
        blocked = np.zeros(xa.shape, dtype=bool)
        for _ in range(2):  # solve, then again with the parameters a bound stops held fixed
            system, rhs = scaled[ok].copy(), -jtr[ok]
            held = blocked[ok]
            system[held[:, :, None] | held[:, None, :]] = 0.0
            system[held[:, :, None] & eye[None].astype(bool)] = 1.0
            rhs[held] = 0.0
            delta[ok] = _solve(system, rhs)
            blocked |= ((xa <= lower) & (delta < 0.0)) | ((xa >= upper) & (delta > 0.0))
            if not blocked[ok].any():
                break
        trial = np.clip(xa + delta, lower, upper)
        rt = residuals(trial, idx)
        ct = _sum_squares(rt)
        better = ct < cost[idx]
        gain = np.where(better, (cost[idx] - ct) / np.maximum(cost[idx], 1e-300), 0.0)
        acc = idx[better]
        x[acc], r[acc], cost[acc] = trial[better], rt[better], ct[better]
        lam[acc] = np.maximum(lam[acc] / 3.0, 1e-12)
        lam[idx[~better]] *= 4.0
        moved = np.abs(trial - xa).max(axis=1) > 1e-14 * (upper - lower).max()
        done = (better & (gain < ftol)) | (lam[idx] > 1e12) | ~moved | ~ok
        active[idx[done]] = False
    return LocalFits(x=x, cost=cost)
