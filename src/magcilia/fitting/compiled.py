"""The one compiled Levenberg–Marquardt iteration of :func:`~magcilia.fitting.fit_batch`
(numba), with the NumPy code in :mod:`.levenberg_marquardt` as its reference.

An iteration over many small problems is two compiled passes over the problems still running,
whatever the problems' size and wherever their Jacobians come from:

* :func:`propose_kernel`: the normal equations (from the cached Jacobians of ``jacobian=True``,
  or JᵀJ and Jᵀr formed by the caller from a callable or forward-difference Jacobian),
  Marquardt's scaled damping (the diagonal floored at 1e-12 of its largest entry), the solve
  (the closed form for p = 2, as the NumPy path; otherwise LU with partial pivoting, as LAPACK's
  ``gesv``; a singular or non-finite system gives a zero step), the second solve without the
  parameters held on a bound whose step points outward, and the trial point clipped into the box;
* :func:`accept_kernel`: the trial's cost (inf where not finite), a lower one accepted (point,
  residuals and, when cached, Jacobian), λ divided or multiplied, and which problems end.

In NumPy the same rules take some twenty to eighty small passes over the batch and batched LAPACK
calls, each costing more than the model where the model is a compiled table look-up (the biaxial
read-out) or the problems are few (the calibration's tens of five-parameter fits).

:func:`kernels` compiles both on first use (:func:`magcilia._jit.compile_kernel`: numba imported
then, never at ``import magcilia``; machine code cached on disk) and returns None where numba
cannot be imported or :data:`ENABLED` is False — the one switch the fitter reads; the NumPy
reference then runs, with the same rules (tests hold the two to each other).
"""

from __future__ import annotations

import math
from typing import Any, NamedTuple

import numpy as np
from numpy.typing import NDArray

from magcilia._jit import compile_kernel

F64 = NDArray[np.float64]

#: use the compiled step when numba can be imported (False: the NumPy reference, e.g. in tests)
ENABLED = True


def propose_kernel(idx: NDArray[np.intp], x: F64, lam: F64, lower: F64, upper: F64, jac: F64,
                   r: F64, jtj: F64, jtr: F64, trial: F64, ok: NDArray[np.bool_]) -> None:
    """The damped Gauss–Newton trial point of each running problem ``idx`` (m,) (numba source):
    from its point ``x`` (s, p) and λ ``lam`` (s,) within ``lower``, ``upper`` ((1, p) shared or
    (s, p)); the normal equations from the cached Jacobians ``jac`` (s, a, p) and residuals ``r``
    (s, a) of all problems when ``jac`` has rows, else from ``jtj`` (m, p, p) and ``jtr`` (m, p).
    Writes ``trial`` (m, p) and whether the damped system was finite, ``ok`` (m,)."""
    p = x.shape[1]
    n_a = r.shape[1]
    cached = jac.shape[0] > 0
    shared = lower.shape[0] == 1
    gram = np.empty((p, p))
    system = np.empty((p, p))
    rhs = np.empty(p)
    delta = np.empty(p)
    work = np.empty((p, p + 1))
    held = np.empty(p, dtype=np.bool_)
    for i in range(idx.size):
        s = idx[i]
        b = 0 if shared else s
        if cached:
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
        else:
            for j in range(p):
                rhs[j] = -jtr[i, j]
                for k in range(p):
                    gram[j, k] = jtj[i, j, k]
        top = gram[0, 0]
        for j in range(1, p):  # NaN-propagating, as np.maximum
            d = gram[j, j]
            top = d if (d > top or math.isnan(d)) else top
        floor = 1e-12 * top
        fine = True
        for j in range(p):
            d = gram[j, j]
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
            else:  # LU with partial pivoting (as gesv); an exact zero pivot: no step
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
                    if singular:
                        delta[j] = 0.0
                        continue
                    acc = work[j, p]
                    for k in range(j + 1, p):
                        acc -= work[j, k] * delta[k]
                    delta[j] = acc / work[j, j]
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
                  x: F64, r: F64, cost: F64, jac: F64, lam: F64, width: F64, ftol: float,
                  xtol: float, atol: float, lam_bounds: F64, ending: NDArray[np.bool_]) -> None:
    """Each running problem ``idx`` (m,) at its ``trial`` point (m, p) with residuals ``rt``
    (m, a) (numba source): a lower cost replaces its ``x``, ``r`` and ``cost`` rows and, when
    ``jac`` (s, a, p) has rows, its cached Jacobian by the trial's ``jt`` (m, a, p); ``lam``
    divided or multiplied (``lam_bounds`` = [smallest, largest, down, up]); ``ending`` (m,): the
    step gained less than ``ftol``, changed the cost by less than ``atol``, λ passed its largest,
    no parameter moved by more than ``xtol`` of the problem's widest bound (``width`` (1, p) or
    (s, p); of |x| where infinite), or the damped system was not finite."""
    p, n_a = trial.shape[1], rt.shape[1]
    keep_jac = jac.shape[0] > 0
    shared = width.shape[0] == 1
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
            if keep_jac:
                for a in range(n_a):
                    for j in range(p):
                        jac[s, a, j] = jt[i, a, j]
            la = max(lam[s] / down, lam_min)
        else:
            la = lam[s] * up
        lam[s] = la
        ending[i] = ((better and gain < ftol) or change < atol or la > lam_max or not moved
                     or not ok[i])


class Kernels(NamedTuple):
    """The compiled kernels, with the arguments of the functions of the same name."""

    propose: Any
    accept: Any


def kernels() -> Kernels | None:
    """The compiled kernels (compiled once per process), or None where numba cannot be imported
    or :data:`ENABLED` is False."""
    if not ENABLED:
        return None
    propose, accept = compile_kernel(propose_kernel), compile_kernel(accept_kernel)
    return None if propose is None or accept is None else Kernels(propose, accept)
