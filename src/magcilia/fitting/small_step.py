"""One Levenberg–Marquardt iteration of :func:`~magcilia.fitting.fit_batch` for many small
problems as two compiled passes (numba; ``fit_batch(..., compiled=True)``).

With an analytic Jacobian that comes with the residuals (``jacobian=True``) and at most
:data:`SMALL_PARAMETERS` parameters, NumPy spends an iteration in some eighty passes over the
batch (gathers, the normal equations entry by entry, the damped 2 × 2 solve, the bounds, the
acceptance test), each a few nanoseconds a problem: more than the model itself where the model is
a compiled table look-up. Here :func:`propose_kernel` forms JᵀJ and Jᵀr, Marquardt's damped
system and its solution (the closed form for p = 2, Gaussian elimination with partial pivoting
otherwise; zero where a system is singular, as :func:`~.levenberg_marquardt._solve`), holds the
parameters on a bound whose step points outward and solves again without them, and clips the
trial point into the box; :func:`accept_kernel` takes the cost at the trial, keeps a better
point (and its residuals and Jacobian), updates λ and tells which problems have ended. The rules
are :mod:`.levenberg_marquardt`'s, line for line; tests hold the two paths to each other.
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import NDArray

F64 = NDArray[np.float64]

#: most parameters a problem may have for the compiled step
SMALL_PARAMETERS = 4


def propose_kernel(idx: NDArray[np.intp], x: F64, r: F64, jac: F64, lam: F64, lower: F64,
                   upper: F64, shared: bool, trial: F64, ok: NDArray[np.bool_]) -> None:
    """The damped Gauss–Newton trial point of each running problem ``idx`` (m,) (numba source):
    from its point ``x`` (s, p), residuals ``r`` (s, a), Jacobian ``jac`` (s, a, p) and λ
    ``lam`` (s,) within ``lower``, ``upper`` ((1, p) when ``shared``, else (s, p)): ``trial``
    (m, p) and whether its normal equations were finite, ``ok`` (m,)."""
    p, n_a = x.shape[1], r.shape[1]
    gram = np.empty((p, p))
    system = np.empty((p, p))
    rhs = np.empty(p)
    delta = np.empty(p)
    work = np.empty((p, p + 1))
    held = np.empty(p, dtype=np.bool_)
    for i in range(idx.size):
        s = idx[i]
        b = 0 if shared else s
        for j in range(p):
            acc = 0.0
            for a in range(n_a):
                acc += jac[s, a, j] * r[s, a]
            rhs[j] = -acc
            for k in range(j, p):
                acc = 0.0
                for a in range(n_a):
                    acc += jac[s, a, j] * jac[s, a, k]
                gram[j, k] = acc
                gram[k, j] = acc
        top = gram[0, 0]
        for j in range(1, p):  # NaN-propagating, as np.maximum
            d = gram[j, j]
            top = d if (d > top or math.isnan(d)) else top
        fine = True
        for j in range(p):
            d = gram[j, j]
            floor = 1e-12 * top
            d = d if (d >= floor or math.isnan(d)) else floor
            if math.isnan(floor):
                d = floor
            for k in range(p):
                system[j, k] = gram[j, k]
            system[j, j] += lam[s] * d
            for k in range(p):
                fine = fine and math.isfinite(system[j, k])
            fine = fine and math.isfinite(rhs[j])
        ok[i] = fine
        for j in range(p):
            delta[j] = 0.0
        for attempt in range(2 if fine else 0):
            # δ = system⁻¹ rhs, zero where singular (levenberg_marquardt._solve's rules)
            if p == 2:  # its closed form
                a00, a01, a10, a11 = system[0, 0], system[0, 1], system[1, 0], system[1, 1]
                det = a00 * a11 - a01 * a10
                if det != 0.0 and math.isfinite(det):
                    inv = 1.0 / det
                    delta[0] = (a11 * rhs[0] - a01 * rhs[1]) * inv
                    delta[1] = (a00 * rhs[1] - a10 * rhs[0]) * inv
                else:
                    delta[0] = delta[1] = 0.0
            else:  # Gaussian elimination, partial pivoting; an exact zero pivot: no step
                for j in range(p):
                    for k in range(p):
                        work[j, k] = system[j, k]
                    work[j, p] = rhs[j]
                singular = False
                for col in range(p):
                    piv = col
                    for j in range(col + 1, p):
                        if abs(work[j, col]) > abs(work[piv, col]):
                            piv = j
                    if work[piv, col] == 0.0:
                        singular = True
                        break
                    if piv != col:
                        for k in range(p + 1):
                            work[col, k], work[piv, k] = work[piv, k], work[col, k]
                    for j in range(col + 1, p):
                        f = work[j, col] / work[col, col]
                        for k in range(col, p + 1):
                            work[j, k] -= f * work[col, k]
                for j in range(p - 1, -1, -1):
                    acc = work[j, p]
                    for k in range(j + 1, p):
                        acc -= work[j, k] * delta[k]
                    delta[j] = 0.0 if singular else acc / work[j, j]
            if attempt == 1:
                break
            again = False
            for j in range(p):
                held[j] = ((x[s, j] <= lower[b, j] and delta[j] < 0.0)
                           or (x[s, j] >= upper[b, j] and delta[j] > 0.0))
                again = again or held[j]
            if not again:
                break
            # a parameter on a bound stepping outward is held: solve again without it
            for j in range(p):
                for k in range(p):
                    if held[j] or held[k]:
                        system[j, k] = 1.0 if j == k else 0.0
                if held[j]:
                    rhs[j] = 0.0
        for j in range(p):
            trial[i, j] = min(max(x[s, j] + delta[j], lower[b, j]), upper[b, j])


def accept_kernel(idx: NDArray[np.intp], trial: F64, rt: F64, jt: F64, ok: NDArray[np.bool_],
                  x: F64, r: F64, cost: F64, jac: F64, lam: F64, width: F64, shared: bool,
                  ftol: float, xtol: float, atol: float, lam_bounds: F64,
                  ending: NDArray[np.bool_]) -> None:
    """Each running problem ``idx`` (m,) at its ``trial`` point (m, p) with residuals ``rt``
    (m, a) and Jacobian ``jt`` (m, a, p) (numba source): a lower cost replaces its ``x``, ``r``,
    ``cost`` and ``jac`` rows; ``lam`` divided or multiplied (``lam_bounds`` = [smallest, largest,
    down, up]); ``ending`` (m,): the step gained less than ``ftol``, changed the cost by less than
    ``atol``, λ passed its largest, no parameter moved by more than ``xtol`` of the problem's
    widest bound (of |x| where infinite), or the normal equations were not finite."""
    p, n_a = trial.shape[1], rt.shape[1]
    lam_min, lam_max, down, up = lam_bounds[0], lam_bounds[1], lam_bounds[2], lam_bounds[3]
    for i in range(idx.size):
        s = idx[i]
        b = 0 if shared else s
        ct = 0.0
        for a in range(n_a):
            ct += rt[i, a] * rt[i, a]
        if not math.isfinite(ct):
            ct = math.inf
        ca = cost[s]
        better = ct < ca
        gain = (ca - ct) / max(ca, 1e-300) if better else 0.0
        change = abs(ca - ct) if math.isfinite(ct) else math.inf
        scale = -math.inf
        step = -math.inf
        for j in range(p):
            w = width[b, j]
            v = w if math.isfinite(w) else abs(x[s, j])
            scale = v if (v > scale or math.isnan(v)) else scale
            d = abs(trial[i, j] - x[s, j])
            step = d if (d > step or math.isnan(d)) else step
        moved = step > xtol * scale
        if better:
            cost[s] = ct
            for j in range(p):
                x[s, j] = trial[i, j]
            for a in range(n_a):
                r[s, a] = rt[i, a]
                for j in range(p):
                    jac[s, a, j] = jt[i, a, j]
            la = max(lam[s] / down, lam_min)
        else:
            la = lam[s] * up
        lam[s] = la
        ending[i] = ((better and gain < ftol) or change < atol or la > lam_max or not moved
                     or not ok[i])
