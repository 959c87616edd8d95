"""The damped step of :func:`~magcilia.fitting.fit_batch`, compiled (numba), with the NumPy code in
:mod:`.levenberg_marquardt` as its reference.

One call per iteration does what would otherwise be some twenty small NumPy operations and one or
two batched LAPACK solves over all the problems still running: the normal equations from the
cached Jacobians, Marquardt's scaled damping (the diagonal floored at 1e-12 of its largest entry),
the solve (LU with partial pivoting, as LAPACK's ``gesv``; a singular or non-finite system gives
a zero step, as the NumPy path), and the second solve without the parameters held at a bound
whose step points outward. At calibration sizes (5 parameters, tens of problems) the NumPy path
spent more time in these calls' overhead than the model took.

:func:`kernels` compiles on first use (numba imported then, never at ``import magcilia``; machine
code cached on disk) and returns None where numba cannot be imported or :data:`ENABLED` is False:
the NumPy path then runs.
"""

from __future__ import annotations

from collections.abc import Callable
from functools import cache
from typing import NamedTuple

import numpy as np
from numpy.typing import NDArray

F64 = NDArray[np.float64]

#: use the compiled step when numba can be imported (tests set False to run the NumPy reference)
ENABLED = True


def normal_rows(jac: F64, r: F64, idx: NDArray[np.intp], jtj: F64, jtr: F64) -> None:
    """JᵀJ (m, p, p) and Jᵀr (m, p) of the problems ``idx`` (m,) from Jacobians ``jac``
    (s, a, p) and residuals ``r`` (s, a) of all problems (numba source)."""
    p, a = jac.shape[2], jac.shape[1]
    for i in range(idx.size):
        s = idx[i]
        for u in range(p):
            acc = 0.0
            for t in range(a):
                acc += jac[s, t, u] * r[s, t]
            jtr[i, u] = acc
            for w in range(u + 1):
                acc = 0.0
                for t in range(a):
                    acc += jac[s, t, u] * jac[s, t, w]
                jtj[i, u, w] = acc
                jtj[i, w, u] = acc


def _lu_solve(a: F64, b: F64, out: F64) -> bool:
    """Solve a · out = b (p × p, in place on ``a`` and ``b``) by LU with partial pivoting; False
    (and ``out`` zero) where a pivot is zero (numba source)."""
    p = b.size
    for c in range(p):
        piv, best = c, abs(a[c, c])
        for row in range(c + 1, p):
            if abs(a[row, c]) > best:
                piv, best = row, abs(a[row, c])
        if best == 0.0:
            out[:] = 0.0
            return False
        if piv != c:
            for col in range(p):
                a[c, col], a[piv, col] = a[piv, col], a[c, col]
            b[c], b[piv] = b[piv], b[c]
        for row in range(c + 1, p):
            f = a[row, c] / a[c, c]
            if f != 0.0:
                for col in range(c + 1, p):
                    a[row, col] -= f * a[c, col]
                b[row] -= f * b[c]
    for c in range(p - 1, -1, -1):
        acc = b[c]
        for col in range(c + 1, p):
            acc -= a[c, col] * out[col]
        out[c] = acc / a[c, c]
    return True


def damped_steps(jtj: F64, jtr: F64, lam: F64, x: F64, lo: F64, hi: F64, delta: F64,
                 ok: NDArray[np.bool_]) -> None:
    """Marquardt steps ``delta`` (m, p) of m problems at ``x`` (m, p) from JᵀJ (m, p, p), Jᵀr
    (m, p) and λ (m,), bounds ``lo``, ``hi`` of shape (1, p) (shared) or (m, p); ``ok`` (m,)
    says which systems were finite (numba source)."""
    m, p = jtr.shape
    shared = lo.shape[0] == 1
    a = np.empty((p, p))
    b = np.empty(p)
    held = np.empty(p, dtype=np.bool_)
    d = np.empty(p)
    for i in range(m):
        top = 0.0
        for u in range(p):
            top = max(top, jtj[i, u, u])
        finite = True
        for u in range(p):
            d[u] = max(jtj[i, u, u], 1e-12 * top)
            finite &= np.isfinite(jtr[i, u])
        for u in range(p):
            for w in range(p):
                a[u, w] = jtj[i, u, w]
                finite &= np.isfinite(a[u, w])
            a[u, u] += lam[i] * d[u]
            finite &= np.isfinite(a[u, u])
            b[u] = -jtr[i, u]
        ok[i] = finite
        if not finite:
            delta[i, :] = 0.0
            continue
        _lu_solve(a, b, delta[i])
        j = 0 if shared else i
        again = False
        for u in range(p):
            held[u] = ((x[i, u] <= lo[j, u] and delta[i, u] < 0.0)
                       or (x[i, u] >= hi[j, u] and delta[i, u] > 0.0))
            again |= held[u]
        if not again:
            continue
        for u in range(p):  # the system again, the held parameters' rows and columns removed
            for w in range(p):
                a[u, w] = 0.0 if (held[u] or held[w]) else jtj[i, u, w]
            a[u, u] = 1.0 if held[u] else jtj[i, u, u] + lam[i] * d[u]
            b[u] = 0.0 if held[u] else -jtr[i, u]
        _lu_solve(a, b, delta[i])


def accept_steps(idx: NDArray[np.intp], trial: F64, rt: F64, jt: F64, xa: F64, la: F64,
                 ok: NDArray[np.bool_], scale: F64, x: F64, r: F64, cost: F64, jcache: F64,
                 lam: F64, tol: F64, ending: NDArray[np.bool_]) -> None:
    """The bookkeeping after the trial points (numba source): each trial's cost (inf where not
    finite), accepted where it is lower (``x``, ``r``, ``cost`` and, when ``jcache`` has rows,
    the cached Jacobian of problem ``idx[i]`` take the trial's), λ divided or multiplied, and
    which problems end (``ending``): a relative gain below ``tol[0]`` (ftol), a change below
    ``tol[1]`` (atol), λ beyond ``tol[3]``, a step of at most ``tol[2]`` (xtol) × ``scale``, or a
    non-finite system. ``tol[4]``, ``tol[5]``, ``tol[6]``: λ's floor, its divisor and its
    factor."""
    m, a = rt.shape
    p = trial.shape[1]
    keep_jac = jcache.shape[0] > 0
    for i in range(m):
        c = 0.0
        for t in range(a):
            c += rt[i, t] * rt[i, t]
        if not np.isfinite(c):
            c = np.inf
        better = c < cost[idx[i]]
        ca = cost[idx[i]]
        gain = (ca - c) / max(ca, 1e-300) if better else 0.0
        change = abs(ca - c) if np.isfinite(c) else np.inf
        s = idx[i]
        if better:
            for u in range(p):
                x[s, u] = trial[i, u]
            for t in range(a):
                r[s, t] = rt[i, t]
            cost[s] = c
            if keep_jac:
                for t in range(a):
                    for u in range(p):
                        jcache[s, t, u] = jt[i, t, u]
            la[i] = max(la[i] / tol[5], tol[4])
        else:
            la[i] = la[i] * tol[6]
        lam[s] = la[i]
        step = 0.0
        for u in range(p):
            step = max(step, abs(trial[i, u] - xa[i, u]))
        moved = step > tol[2] * scale[i]
        ending[i] = ((better and gain < tol[0]) or change < tol[1] or la[i] > tol[3]
                     or not moved or not ok[i])


class Kernels(NamedTuple):
    """The compiled functions, with the arguments of the functions of the same name."""

    normal_rows: Callable[[F64, F64, NDArray[np.intp], F64, F64], None]
    damped_steps: Callable[[F64, F64, F64, F64, F64, F64, F64, NDArray[np.bool_]], None]
    accept_steps: Callable[..., None]


@cache
def _compile() -> Kernels | None:
    try:
        import numba
    except ImportError:  # e.g. a Python that numba does not support yet
        return None

    def build(cache: bool) -> Kernels:
        solve = numba.njit(_lu_solve, cache=cache, error_model="numpy", nogil=True)
        steps = numba.njit(_with_solver(damped_steps, solve), cache=cache, error_model="numpy",
                           nogil=True)
        return Kernels(normal_rows=numba.njit(normal_rows, cache=cache, error_model="numpy",
                                              nogil=True),
                       damped_steps=steps,
                       accept_steps=numba.njit(accept_steps, cache=cache, error_model="numpy",
                                               nogil=True))

    try:
        return build(cache=True)
    except RuntimeError:  # no writable cache folder (numba's own or NUMBA_CACHE_DIR)
        return build(cache=False)


def _with_solver(fn: Callable[..., None], solve: Callable[..., bool]) -> Callable[..., None]:
    """``fn`` whose global ``_lu_solve`` is the compiled ``solve`` (numba resolves a function's
    globals when it compiles it)."""
    import types

    glob = dict(fn.__globals__)
    glob["_lu_solve"] = solve
    out = types.FunctionType(fn.__code__, glob, fn.__name__, fn.__defaults__, fn.__closure__)
    out.__module__, out.__qualname__ = fn.__module__, fn.__qualname__
    return out


def kernels() -> Kernels | None:
    """The compiled functions, or None where numba cannot be imported or :data:`ENABLED` is
    False."""
    return _compile() if ENABLED else None
