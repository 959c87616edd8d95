"""The array inverse's solve: every cilium's force vector from the readings of n frames.

:func:`solve` is :meth:`ArrayReadout.read`'s numerical core (see :mod:`magcilia.readout.array`
for the problem): ``Σ ((y − f(F)) w)² + α Σ (F / span)²`` over the 2C components, on the one
batched least squares :func:`magcilia.fitting.fit_batch`, with the model and its analytic
Jacobian from one fused kernel (:func:`magcilia.model.array_tabulated.table_field`).

Starts. Every frame of a block starts from the Gauss–Newton step from one point x_s,
``x_s + (JᵀWJ + α I)⁻¹ (JᵀW (y − f(x_s)) − α x_s)``, J the Jacobian at x_s (one kernel call for
the whole block; one solve per pattern of readings left out): cold (no ``start``) x_s = 0, the
linear solution about rest; warm, x_s = ``start``, the forces of the frame before (scaled by the
spans). Every frame then keeps that J as its cached Jacobian (chord steps) until its estimate
moves more than :data:`REFRESH_STEP` of a span from x_s, or a chord step fails to lower its cost
(the Jacobian is then taken at its point): frames near the last one (a live array at 1 kHz)
converge in a few model evaluations and mostly no Jacobian of their own.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
from numpy.typing import NDArray

from magcilia.fitting import fit_batch
from magcilia.model.array_tabulated import TabulatedArray, table_field

F64 = NDArray[np.float64]

#: the inverse recomputes a sample's Jacobian where its estimate moved farther than this (a
#: fraction of the span in some component) from where the last was taken, else keeps the last
#: one (chord steps: one model evaluation per iteration). Chord steps end where the cached
#: Jacobian is orthogonal to the residuals, off the minimum with noisy readings: ≤ 0.02 σ on
#: an 8 × 8 array at 0.7 span (2e-3: ≤ 0.003 σ, ~15 % slower)
REFRESH_STEP = 1e-2
#: the inverse's box, in spans (the Tikhonov prior's scale: 1/√α = 1000 spans by default)
BOUND = 1e3
#: the inverse has converged when a step moves no component by more than this fraction of
#: the box (1e-7 of a span) …, or lowers χ² by less than the read-out's ``tolerance``
FIT_XTOL = 1e-7 / (2 * BOUND)


def solve(model: TabulatedArray, span: F64, alpha: float, y: F64, w: F64,
          start: F64 | None, maxiter: int, tolerance: float) -> tuple[Any, F64]:
    """Fit readings ``y`` (n, 3 S), T (tare applied), with weights ``w`` (n, 3 S) (1/σ, 0 for
    a reading left out), from ``start`` (2 C,) (forces / span of the frame before) or cold.

    Parameters
    ----------
    model : TabulatedArray
        The read-out's forward map.
    span : ndarray, shape (C,)
        Each cilium's span, N (the unknowns are x = F / span).
    alpha : float
        Tikhonov weight on x².
    start : ndarray, shape (2 C,), or None
        Warm start (see the module), or None: the linear solution about rest.

    Returns
    -------
    fit : BatchFit
        x (n, 2 C) scaled by the spans; ``jtj`` the damped-free JᵀWJ + α I at the last
        linearisation.
    jw : ndarray, shape (n, 3 S, 2 C)
        The whitened Jacobian per unit x that ``jtj`` belongs to (for a tare's gain).
    """
    n, m = y.shape
    c_n = span.size
    p = 2 * c_n
    scale = np.repeat(span, 2)  # x = F / span
    root_alpha = math.sqrt(alpha)
    eye = np.eye(p)
    cache_at = np.full((n, p), np.nan)  # where each sample's Jacobian was taken
    cache = np.zeros((n, m + p, p))  # the whitened Jacobian there, per unit x, with the
    cache[:, m:] = root_alpha * eye  # Tikhonov rows
    gram = np.zeros((n, p, p))  # its JᵀJ + α I
    asked = np.full((n, p), np.nan)  # the point of each sample's last linearisation
    at = np.zeros(p) if start is None else start  # cold: the linear solution about rest
    f_s, j_s = table_field(model, (at * scale).reshape(1, c_n, 2), jacobian=True)
    assert j_s is not None  # for mypy: asked for
    f_at, j_s = f_s[0], j_s[0] * scale
    x0 = np.empty((n, p))
    if np.all(w == w[0]):  # the common case: every reading used in every sample
        patterns, which = w[:1], np.zeros(n, dtype=np.intp)
    else:
        patterns, which = np.unique(w, axis=0, return_inverse=True)
    for k, wk in enumerate(patterns):
        rows = np.flatnonzero(which.reshape(-1) == k)
        jw = j_s * wk[:, None]
        a = jw.T @ jw + alpha * eye
        rhs = jw.T @ ((y[rows] - f_at) * wk).T - (alpha * at)[:, None]
        x0[rows] = at + np.linalg.solve(a, rhs).T
        cache[rows, :m] = jw  # the start's Jacobian is every frame's first
        gram[rows] = a
        cache_at[rows] = at

    def residuals(x: F64, rows: NDArray[np.intp]) -> F64:
        f, _ = table_field(model, (x * scale).reshape(-1, c_n, 2))
        return np.concatenate([w[rows] * (f - y[rows]), root_alpha * x], axis=1)

    def jacobian(x: F64, rows: NDArray[np.intp]) -> tuple[F64, F64]:
        # a fresh Jacobian only where the point moved far from the last one (chord steps), or
        # where a chord step did not lower the cost (the point is the one asked last time)
        stale = ~(np.abs(x - cache_at[rows]).max(axis=1) <= REFRESH_STEP)
        stale |= np.all(x == asked[rows], axis=1) & np.any(x != cache_at[rows], axis=1)
        asked[rows] = x
        if stale.any():
            fresh = rows[stale]
            _, jac = table_field(model, (x[stale] * scale).reshape(-1, c_n, 2), jacobian=True)
            assert jac is not None  # for mypy: asked for
            jw = w[fresh][:, :, None] * (jac * scale)
            cache[fresh, :m] = jw
            gram[fresh] = np.matmul(jw.transpose(0, 2, 1), jw) + alpha * eye
            cache_at[fresh] = x[stale]
        if rows.size == n:  # every sample still active: no copies
            return cache, gram
        return cache[rows], gram[rows]

    # Gauss–Newton first (damping 1e-12); chord steps converge to where the *cached*
    # Jacobian is orthogonal to the residuals (REFRESH_STEP says how far that is)
    fit = fit_batch(residuals, x0, np.full(p, -BOUND), np.full(p, BOUND),
                    jacobian=jacobian, maxiter=maxiter, ftol=0.0, xtol=FIT_XTOL,
                    atol=tolerance, damping=1e-12)
    return fit, cache[:, :m]
