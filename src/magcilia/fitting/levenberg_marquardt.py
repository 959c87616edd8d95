"""Levenberg–Marquardt over many independent, bounded least-squares problems at once.

The calibration polishes one candidate for every combination of the integer parameters (n, k):
a hundred small problems of five parameters each; the force-vector read-out fits two parameters
per reading, thousands of readings at once. Solving them one by one spends the time in Python;
here every iteration evaluates all the problems' residuals (and their Jacobians: analytic, or
forward differences in the same vectorised call) at once, and takes all the damped steps and
their acceptance in one compiled step (:mod:`.compiled`, numba) or, without numba, in its NumPy
reference here (batched ``numpy.linalg.solve``, the 2 × 2 systems in closed form).

The one damping rule: Marquardt's, λ times the diagonal of JᵀJ (floored at 1e-12 of its largest
entry, so that a parameter without effect keeps the system regular and stays put), λ divided by
3 after a step that lowers the cost and multiplied by 4 after one that does not. Bounds are kept
by projecting each step onto the box; a parameter on a bound whose step points outward is held
and the step solved again without it.
"""

from __future__ import annotations

import contextlib
from collections.abc import Callable
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from magcilia import _validate as v
from magcilia.fitting import compiled as compiled_step
from magcilia.fitting.result import BatchFit

F64 = NDArray[np.float64]
#: ``residuals(x, which)``: residual vectors (m, a) of parameter vectors ``x`` (m, p), row i
#: belonging to problem ``which[i]``
Residuals = Callable[[F64, NDArray[np.intp]], Any]
#: ``jacobian(x, which)``: the Jacobians (m, a, p) of the residuals at ``x`` (m, p), or the pair
#: (J, JᵀJ) with JᵀJ (m, p, p) when the caller keeps it (a cached Jacobian)
Jacobian = Callable[[F64, NDArray[np.intp]], Any]
#: ``project(x, which)``: points (m, p) mapped onto each problem's feasible set within its box
Projection = Callable[[F64, NDArray[np.intp]], Any]

#: smallest and largest Marquardt λ: a problem whose λ grows beyond the largest has no step that
#: lowers its cost (a minimum, to rounding)
LAMBDA_MIN, LAMBDA_MAX = 1e-12, 1e12
#: λ after a step that lowers the cost (÷) and after one that does not (×)
LAMBDA_DOWN, LAMBDA_UP = 3.0, 4.0


def sum_squares(r: F64) -> F64:
    """Sum of squares of each row of ``r`` (s, a): shape (s,), inf where it is not finite."""
    with np.errstate(over="ignore", invalid="ignore"):
        c = np.einsum("sa,sa->s", r, r)
    return np.where(np.isfinite(c), c, np.inf)


#: rows at most this wide are reduced column by column (:func:`_row_max`, …): NumPy's reduction
#: along a short last axis costs 10–35 ns a row, an elementwise pass over a column ~1 ns
SMALL_ROW = 16


def _row_max(a: F64) -> F64:
    """The largest entry of each row of ``a`` (s, k) (NaN where a row has one)."""
    if a.shape[1] > SMALL_ROW or a.shape[1] == 0:
        return np.asarray(a.max(axis=1) if a.shape[1] else np.full(a.shape[0], -np.inf))
    out = a[:, 0].copy()
    for j in range(1, a.shape[1]):
        np.maximum(out, a[:, j], out=out)
    return out


def _row_all(a: NDArray[np.bool_]) -> NDArray[np.bool_]:
    """Whether every entry of each row of ``a`` (s, k) is True."""
    if a.shape[1] > SMALL_ROW or a.shape[1] == 0:
        return np.asarray(a.all(axis=1))
    out = a[:, 0].copy()
    for j in range(1, a.shape[1]):
        np.logical_and(out, a[:, j], out=out)
    return out


def _row_any(a: NDArray[np.bool_]) -> NDArray[np.bool_]:
    """Whether some entry of each row of ``a`` (s, k) is True."""
    if a.shape[1] > SMALL_ROW or a.shape[1] == 0:
        return np.asarray(a.any(axis=1))
    out = a[:, 0].copy()
    for j in range(1, a.shape[1]):
        np.logical_or(out, a[:, j], out=out)
    return out


def _solve(system: F64, rhs: F64) -> F64:
    """Solutions (s, p) of the systems (s, p, p) · δ = rhs (s, p); zero where one is singular."""
    if system.shape[1] == 2:  # closed form: LAPACK's cost per call dominates 2 × 2 systems
        a, b = system[:, 0, 0], system[:, 0, 1]
        c, d = system[:, 1, 0], system[:, 1, 1]
        det = a * d - b * c
        good = (det != 0.0) & np.isfinite(det)
        inv = np.where(good, 1.0 / np.where(good, det, 1.0), 0.0)
        return np.stack([(d * rhs[:, 0] - b * rhs[:, 1]) * inv,
                         (a * rhs[:, 1] - c * rhs[:, 0]) * inv], axis=1)
    try:
        return np.asarray(np.linalg.solve(system, rhs[:, :, None])[:, :, 0])
    except np.linalg.LinAlgError:  # one singular system: solve them one at a time
        out = np.zeros_like(rhs)
        for i in range(rhs.shape[0]):
            with contextlib.suppress(np.linalg.LinAlgError):
                out[i] = np.linalg.solve(system[i], rhs[i])
        return out


def bounds_of(lower: ArrayLike, upper: ArrayLike, size: int, dims: int) -> tuple[F64, F64]:
    """Checked bounds: both shape (p,) when shared by all problems, else both (s, p)."""
    lo = np.asarray(lower, dtype=np.float64)
    hi = np.asarray(upper, dtype=np.float64)
    for name, b in (("lower", lo), ("upper", hi)):
        if b.shape not in ((dims,), (size, dims)) or np.isnan(b).any():
            raise v.fail(name, f"an array of shape {b.shape}",
                         f"bounds of shape ({dims},) or ({size}, {dims}) without NaN")
    if not np.all(lo <= hi):
        raise v.fail("lower", "bounds above upper", "lower <= upper")
    if lo.ndim != hi.ndim:  # one per problem, the other shared: both per problem
        lo = np.broadcast_to(lo, (size, dims)).copy()
        hi = np.broadcast_to(hi, (size, dims)).copy()
    return lo, hi


def fit_batch(
    residuals: Residuals,
    x0: ArrayLike,
    lower: ArrayLike,
    upper: ArrayLike,
    *,
    jacobian: Jacobian | bool | None = None,
    maxiter: int = 60,
    ftol: float = 1e-12,
    xtol: float = 1e-14,
    atol: float = 0.0,
    step: float = 1e-7,
    damping: float = 1e-3,
    final_jacobian: bool = False,
    project: Projection | None = None,
) -> BatchFit:
    """Minimise ``|residuals(x)|²`` from each row of ``x0`` within [``lower``, ``upper``].

    Parameters
    ----------
    residuals : callable
        ``residuals(x, which)``: residual vectors (m, a) of parameter vectors ``x`` (m, p), row
        i belonging to problem ``which[i]`` (an index into the rows of ``x0``); every problem
        has the same ``a`` (pad shorter ones with zeros). Rows may be non-finite (a bad point:
        never accepted). With ``jacobian=True`` it returns ``(r, J)``: the residuals and their
        Jacobians (m, a, p).
    x0 : array-like, shape (s, p) or (p,)
        Starting points (clipped into the bounds); (p,) is one problem.
    lower, upper : array-like, shape (p,) or (s, p)
        Bounds shared by all problems or one row per problem (lower ≤ upper; a parameter
        with lower = upper is held). Infinite bounds need a ``jacobian``.
    jacobian : callable, True or None
        ``jacobian(x, which)`` → (m, a, p), the analytic Jacobian (called once per iteration
        at the problems' current points: a caller may return a cached one for chord steps, and
        then the pair (J, JᵀJ) with the JᵀJ (m, p, p) it keeps with it);
        True: ``residuals`` returns it with the residuals; None (or False): forward
        differences of ``step`` times each bound's width, stepping back from the upper bound.
    maxiter : int
        Most iterations (linearisations) per problem.
    ftol : float
        A problem has converged when a step lowers its cost by less than this fraction.
    xtol : float
        … or when its step moves no parameter by more than this fraction of its problem's
        widest bound (or of its largest ``|x|`` where the bounds are infinite).
    atol : float
        … or when a step changes its cost by less than this amount, up or down (the
        residuals' units squared; 0: never): a tolerance on χ² itself where the residuals are
        whitened (the better of the two points is kept).
    step : float
        Forward-difference step as a fraction of each bound's width.
    damping : float
        Initial Marquardt λ (relative to the diagonal of JᵀJ); 1e-12 is Gauss–Newton's step
        first.
    final_jacobian : bool
        Take the Jacobian once more at the final points (one more batched call) so that
        ``jtj`` is exactly at ``x``. Without it, ``jtj`` is that of the last linearisation:
        at ``x`` itself, or one accepted step before it when the fit stopped on a small change
        of the cost; with ``jacobian=True`` it is always at ``x``.
    project : callable, optional
        ``project(x, which)`` → (m, p): a feasible set within the box that is not a box (a
        disc, say), as the nearest feasible points; applied to the starts and to every trial
        point after the bounds' clip. A step it maps back onto the current point ends the fit
        (converged: the minimum over the set lies on its edge).

    Returns
    -------
    BatchFit
        ``converged`` is False for a problem that hit ``maxiter``, or whose cost or normal
        equations were never finite.
    """
    # (C order: the compiled step's kernels are typed, and loaded from numba's cache, once)
    x = np.array(x0, dtype=np.float64, order="C")
    if x.ndim == 1:
        x = x[None, :]
    if x.ndim != 2:
        raise v.fail("x0", f"an array of shape {x.shape}", "shape (s, p) or (p,)")
    size, dims = x.shape
    lower, upper = bounds_of(lower, upper, size, dims)
    jacobian = None if jacobian is False else jacobian
    shared = lower.ndim == 1
    width = upper - lower
    if jacobian is None and not np.isfinite(width).all():
        raise v.fail("lower, upper", "infinite bounds",
                     "finite bounds with finite-difference Jacobians (the step is a fraction "
                     "of their width); or give a jacobian")
    with_jac = jacobian is True
    jac_fn = jacobian if callable(jacobian) else None
    x = np.clip(x, lower, upper)
    if project is not None:
        x = np.array(project(x, np.arange(size)), dtype=np.float64)
    diff = _Differences(residuals, step * width, upper, shared)
    # the xtol test's scale: the widest bound of each problem (None: some are infinite)
    span = width.max(axis=-1) if np.isfinite(width).all() and dims else None
    every = np.arange(size)
    r, jcache = _evaluate(residuals, x, every, with_jac)
    r = r.copy()  # updated in place below: never the caller's own array
    jcache = None if jcache is None else jcache.copy()
    cost = sum_squares(r)
    lam = np.full(size, float(damping))
    iterations = np.zeros(size, dtype=np.int64)
    converged = np.zeros(size, dtype=bool)
    jtj_out = np.full((size, dims, dims), np.nan)
    # the one compiled iteration (fitting.compiled) where numba is available and switched on;
    # otherwise its NumPy reference below, the same rules
    fast = compiled_step.kernels()
    idx = np.nonzero(np.isfinite(cost))[0] if dims else every[:0]  # the problems still running
    if fast is not None:
        none3, none2 = np.zeros((0, 0, 0)), np.zeros((0, 0))
        lo_k, hi_k, wd_k = ((lower[None], upper[None], width[None]) if shared
                            else (lower, upper, width))
        lam_bounds = np.array([LAMBDA_MIN, LAMBDA_MAX, LAMBDA_DOWN, LAMBDA_UP])
    jtj: F64 | None = None
    ending = np.zeros(0, dtype=bool)
    for k in range(maxiter):
        if idx.size == 0:
            break
        m = idx.size
        if fast is None or jcache is None:  # the normal equations here (cached ones: compiled)
            xa, ra = x[idx], r[idx]
            if jac_fn is not None:
                jtj, jtr = _normal(jac_fn(xa, idx), ra)
            elif jcache is not None:
                jtj, jtr = _normal(jcache[idx], ra)
            else:
                jac = diff(xa, ra, idx)  # (s, p, a)
                jtj = jac @ jac.transpose(0, 2, 1)
                jtr = (jac @ ra[:, :, None])[:, :, 0]
        if fast is not None:
            trial, ok = np.empty((m, dims)), np.empty(m, dtype=bool)
            fast.propose(idx, x, lam, lo_k, hi_k, none3 if jcache is None else jcache, r,
                         none3 if jtj is None else np.ascontiguousarray(jtj),
                         none2 if jtj is None else np.ascontiguousarray(jtr), trial, ok)
        else:
            assert jtj is not None  # formed above
            lo, hi = (lower, upper) if shared else (lower[idx], upper[idx])
            delta, ok = _damped_steps(jtj, jtr, lam[idx], xa, lo, hi)
            trial = np.minimum(np.maximum(xa + delta, lo), hi)
        if project is not None:
            trial = np.ascontiguousarray(project(trial, idx), dtype=np.float64)
        rt, jt = _evaluate(residuals, trial, idx, with_jac)
        if fast is not None:
            ending = np.empty(m, dtype=bool)
            fast.accept(idx, trial, np.ascontiguousarray(rt),
                        none3 if jt is None else np.ascontiguousarray(jt), ok, x, r, cost,
                        none3 if jcache is None else jcache, lam, wd_k, float(ftol),
                        float(xtol), float(atol), lam_bounds, ending)
        else:
            ending = _accept(idx, trial, rt, jt, ok, x, r, cost, jcache, lam, span, width,
                             shared, ftol, xtol, atol)
        if ending.any():
            ended = idx[ending]
            converged[ended] = ok[ending]
            iterations[ended] = k + 1
            if jtj is not None:
                jtj_out[ended] = jtj[ending]
            idx = idx[~ending]
    else:  # the iteration limit: the problems still running took maxiter iterations
        if maxiter > 0 and idx.size:
            iterations[idx] = maxiter
            if jtj is not None:
                jtj_out[idx] = jtj[~ending]
    evaluations = 1 + iterations * (1 if jacobian is not None else 1 + dims)
    done = np.nonzero(np.isfinite(cost) & (dims > 0))[0]
    if jcache is not None:
        jtj_out[done] = _normal(jcache[done], r[done])[0]
    elif final_jacobian and done.size:
        if jac_fn is not None:
            jtj_out[done] = _normal(jac_fn(x[done], done), r[done])[0]
        else:
            jac = diff(x[done], r[done], done)
            jtj_out[done] = jac @ jac.transpose(0, 2, 1)
            evaluations[done] += dims
    return BatchFit(x, cost, r, jtj_out, iterations, evaluations, converged)


def _scale(span: F64 | None, width: F64, shared: bool, idx: NDArray[np.intp], xa: F64) -> F64:
    """The xtol test's scale of the problems ``idx`` (m,): the widest bound of each (or its
    largest ``|x|`` where a bound is infinite)."""
    if span is None:
        w = width if shared else width[idx]
        return np.asarray(np.where(np.isfinite(w), w, np.abs(xa)).max(axis=-1))
    return np.broadcast_to(span, idx.shape) if shared else span[idx]


def _accept(idx: NDArray[np.intp], trial: F64, rt: F64, jt: F64 | None, ok: NDArray[np.bool_],
            x: F64, r: F64, cost: F64, jcache: F64 | None, lam: F64, span: F64 | None,
            width: F64, shared: bool, ftol: float, xtol: float, atol: float
            ) -> NDArray[np.bool_]:
    """The trial points' bookkeeping (the NumPy reference of
    :func:`magcilia.fitting.compiled.accept_kernel`): a lower cost replaces the problem's
    ``x``, ``r``, ``cost`` (and cached Jacobian) rows, λ divided or multiplied; which problems
    ``idx`` (m,) end (m,)."""
    xa, ca, la = x[idx], cost[idx], lam[idx]
    ct = sum_squares(rt)
    better = ct < ca
    gain = np.where(better, (ca - ct) / np.maximum(ca, 1e-300), 0.0)
    change = np.abs(np.where(np.isfinite(ct), ca - ct, np.inf))
    acc = idx[better]
    x[acc], r[acc], cost[acc] = trial[better], rt[better], ct[better]
    if jcache is not None and jt is not None:
        jcache[acc] = jt[better]
    la = np.where(better, np.maximum(la / LAMBDA_DOWN, LAMBDA_MIN), la * LAMBDA_UP)
    lam[idx] = la
    scale = _scale(span, width, shared, idx, xa)
    moved = _row_max(np.abs(trial - xa)) > xtol * scale
    return np.asarray((better & (gain < ftol)) | (change < atol) | (la > LAMBDA_MAX) | ~moved
                      | ~ok)


def _damped_steps(jtj: F64, jtr: F64, la: F64, xa: F64, lo: F64, hi: F64
                  ) -> tuple[F64, NDArray[np.bool_]]:
    """Marquardt steps (s, p) from JᵀJ (s, p, p), Jᵀr (s, p), λ (s,) at ``xa`` (s, p) within
    ``lo``, ``hi`` ((p,) or (s, p)), and which systems were finite (s,): the NumPy reference of
    :func:`magcilia.fitting.compiled.propose_kernel`."""
    dims = xa.shape[1]
    eye = np.eye(dims)
    # Marquardt's scaling, floored so that a parameter without effect here (a zero column:
    # B_x is even in y, so d/dy = 0 at y = 0) keeps the system regular and stays put
    diag = jtj.diagonal(axis1=1, axis2=2)
    diag = np.maximum(diag, 1e-12 * _row_max(diag)[:, None])
    scaled = jtj + la[:, None, None] * (diag[:, :, None] * eye[None])
    ok = (_row_all(np.isfinite(scaled.reshape(scaled.shape[0], -1)))
          & _row_all(np.isfinite(jtr)))
    if ok.all():
        delta = _solve(scaled, -jtr)
    else:
        delta = np.zeros_like(xa)
        delta[ok] = _solve(scaled[ok], -jtr[ok])
    # a parameter on a bound whose step points outward is held: solve those again without it
    blocked = ((xa <= lo) & (delta < 0.0)) | ((xa >= hi) & (delta > 0.0))
    again = _row_any(blocked)
    if again.any():
        system, rhs, held = scaled[again], -jtr[again], blocked[again]
        system[held[:, :, None] | held[:, None, :]] = 0.0
        system[held[:, :, None] & eye.astype(bool)[None]] = 1.0
        rhs[held] = 0.0
        delta[again] = _solve(system, rhs)
    return delta, ok


def _evaluate(residuals: Residuals, x: F64, which: NDArray[np.intp], with_jac: bool
              ) -> tuple[F64, F64 | None]:
    """The residuals (m, a) at ``x`` (m, p) and, when they come with them, their Jacobians."""
    if with_jac:
        r, jac = residuals(x, which)
        return np.asarray(r, dtype=np.float64), np.asarray(jac, dtype=np.float64)
    return np.asarray(residuals(x, which), dtype=np.float64), None


#: parameters up to which :func:`_normal` forms JᵀJ entry by entry (one product-sum over the
#: residuals per pair): NumPy's batched matmul costs ~0.3 µs per tiny matrix, ~4× this
SMALL_GRAM = 4


def _normal(jac: Any, r: F64) -> tuple[F64, F64]:
    """JᵀJ (s, p, p) and Jᵀr (s, p) of Jacobians (s, a, p) and residuals (s, a); ``jac`` may be
    a pair (J, JᵀJ) where the caller keeps JᵀJ with a cached Jacobian."""
    gram = None
    if isinstance(jac, tuple):
        jac, gram = jac
    jac = np.asarray(jac, dtype=np.float64)
    dims = jac.shape[2]
    if dims <= SMALL_GRAM:  # small dense problems: entry by entry
        cols = [jac[:, :, i] for i in range(dims)]
        jtr = np.stack([np.einsum("sa,sa->s", col, r) for col in cols], axis=1)
        if gram is None:
            gram = np.empty((jac.shape[0], dims, dims))
            for i in range(dims):
                for j in range(i, dims):
                    gram[:, i, j] = gram[:, j, i] = np.einsum("sa,sa->s", cols[i], cols[j])
        return np.asarray(gram, dtype=np.float64), jtr
    jt = jac.transpose(0, 2, 1)
    jtr = (jt @ r[:, :, None])[:, :, 0]
    return (jt @ jt.transpose(0, 2, 1) if gram is None
            else np.asarray(gram, dtype=np.float64)), jtr


class _Differences:
    """Forward-difference Jacobians of ``residuals``: steps ``h`` (p,) or (s, p), taken back
    from the upper bound where a step forward would pass it; a zero step (a held parameter)
    gives a zero column."""

    def __init__(self, residuals: Residuals, h: F64, upper: F64, shared: bool) -> None:
        self.residuals, self.h, self.upper, self.shared = residuals, h, upper, shared
        self.safe = np.where(h > 0.0, h, 1.0)

    def __call__(self, xa: F64, ra: F64, idx: NDArray[np.intp]) -> F64:
        """Jacobians (m, p, a) — parameters first — at ``xa`` (m, p), residuals ``ra`` (m, a)."""
        h, safe, hi = ((self.h, self.safe, self.upper) if self.shared
                       else (self.h[idx], self.safe[idx], self.upper[idx]))
        dims = xa.shape[1]
        sign = np.where(xa + h > hi, -1.0, 1.0)
        probes = xa[:, None, :] + (sign * h)[:, :, None] * np.eye(dims)[None]
        rp = np.asarray(self.residuals(probes.reshape(-1, dims), np.repeat(idx, dims)),
                        dtype=np.float64).reshape(idx.size, dims, -1)
        return np.asarray((rp - ra[:, None, :]) / (sign * safe)[:, :, None])
