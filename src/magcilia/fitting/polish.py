"""The one polish: SciPy's trust-region reflective ``least_squares`` from a good point.

:func:`~magcilia.fitting.fit_batch` is fast over many problems; a final ``least_squares`` from
the best of them finds the bottom of a narrow valley to SciPy's tight tolerances (its own
scaling and trust region). Every caller goes through :func:`polish`, so its settings (trf, the
scale from the bound widths, a limit on evaluations, non-finite residuals as a finite penalty)
are chosen once.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from magcilia import _validate as v
from magcilia.fitting.levenberg_marquardt import Jacobian, Residuals, bounds_of, sum_squares
from magcilia.fitting.result import BatchFit

F64 = NDArray[np.float64]

#: the cost ``least_squares`` sees at a point whose residuals are not finite (spread over them):
#: worse than any real fit but finite (it refuses non-finite residuals)
NONFINITE_PENALTY = 1e100


def polish(
    residuals: Residuals,
    x0: ArrayLike,
    lower: ArrayLike,
    upper: ArrayLike,
    *,
    jacobian: Jacobian | bool | None = None,
    max_nfev: int = 200,
    xtol: float = 1e-12,
    ftol: float = 1e-14,
    gtol: float = 1e-12,
    penalty: float = NONFINITE_PENALTY,
) -> BatchFit:
    """``scipy.optimize.least_squares`` (trf) from each row of ``x0``, one problem at a time.

    Parameters
    ----------
    residuals, jacobian
        As :func:`~magcilia.fitting.fit_batch` (called with one row at a time; ``jacobian=None``:
        SciPy's two-point differences).
    x0 : array-like, shape (s, p) or (p,)
        Starting points (clipped into the bounds).
    lower, upper : array-like, shape (p,) or (s, p)
        Bounds; parameters with lower = upper are held, and the rest scaled by their widths
        (by SciPy's Jacobian scaling where a bound is infinite).
    max_nfev : int
        Most residual evaluations per problem (Jacobians by differences not counted).
    xtol, ftol, gtol : float
        SciPy's tolerances.
    penalty : float
        Non-finite residuals are replaced by ``sqrt(penalty / a)`` each (an all-non-finite
        vector costs ``penalty``), so that a bad point is merely worse.

    Returns
    -------
    BatchFit
        ``x`` is the polished point, or the (clipped) start where the polish did not lower the
        cost or SciPy refused the problem; ``cost`` the true sum of squares there (inf where not
        finite); ``jtj`` is SciPy's final JᵀJ (zero rows and columns for held parameters; NaN
        where the start was kept); ``iterations`` its Jacobian evaluations; ``converged`` its
        ``status > 0``.
    """
    from scipy.optimize import least_squares  # (SciPy: where first needed)

    x = np.array(x0, dtype=np.float64)
    if x.ndim == 1:
        x = x[None, :]
    if x.ndim != 2:
        raise v.fail("x0", f"an array of shape {x.shape}", "shape (s, p) or (p,)")
    size, dims = x.shape
    lower, upper = bounds_of(lower, upper, size, dims)
    lo_all = np.broadcast_to(lower, (size, dims))
    hi_all = np.broadcast_to(upper, (size, dims))
    x = np.clip(x, lo_all, hi_all)
    out_r: list[F64] = []
    jtj = np.full((size, dims, dims), np.nan)
    iterations = np.zeros(size, dtype=np.int64)
    evaluations = np.zeros(size, dtype=np.int64)
    converged = np.zeros(size, dtype=bool)
    for i in range(size):
        lo, hi = lo_all[i], hi_all[i]
        free = lo < hi
        which = np.array([i])
        fun = _Single(residuals, jacobian, x[i], free, which, penalty)
        start = x[i].copy()
        r0 = fun.raw(start)
        best_r, best_x = r0, start
        if free.any():
            width = hi[free] - lo[free]
            scale: Any = width if np.isfinite(width).all() else "jac"
            try:  # the penalty's huge differences may overflow inside SciPy: no harm, it
                # rejects those steps
                with np.errstate(over="ignore", invalid="ignore", divide="ignore"):
                    sol = least_squares(fun, start[free],
                                        jac=fun.jac if jacobian else "2-point",
                                        bounds=(lo[free], hi[free]), x_scale=scale,
                                        method="trf", xtol=xtol, ftol=ftol, gtol=gtol,
                                        max_nfev=max_nfev)
            except ValueError:  # SciPy refuses the problem (a start it calls infeasible)
                sol = None
            if sol is not None:
                cand = start.copy()
                cand[free] = sol.x
                r1 = fun.raw(cand)
                if _penalised(r1, penalty) <= _penalised(r0, penalty):
                    best_r, best_x = r1, cand
                    jac = np.asarray(sol.jac, dtype=np.float64)
                    jtj[i] = 0.0
                    jtj[i][np.ix_(free, free)] = jac.T @ jac
                iterations[i] = int(sol.njev or 0)
                evaluations[i] = int(sol.nfev) + (0 if jacobian else int(sol.njev or 0)
                                                  * int(free.sum()))
                converged[i] = sol.status > 0
        else:
            converged[i] = True
        x[i] = best_x
        out_r.append(best_r)
    r = np.array(out_r, dtype=np.float64).reshape(size, -1)
    cost = sum_squares(r)
    return BatchFit(x, cost, r, jtj, iterations, evaluations, converged)


def _penalised(r: F64, penalty: float) -> float:
    """The cost ``least_squares`` sees: non-finite entries replaced as :func:`polish` says."""
    return float(sum_squares(_finite(r, penalty)[None, :])[0])


def _finite(r: F64, penalty: float) -> F64:
    return np.where(np.isfinite(r), r, math.sqrt(penalty / max(r.size, 1)))


class _Single:
    """One problem's residuals (and Jacobian) of its free parameters, in SciPy's calling
    convention: vectors in, vectors out, non-finite residuals replaced by the penalty."""

    def __init__(self, residuals: Residuals, jacobian: Jacobian | bool | None, x: F64,
                 free: NDArray[np.bool_], which: NDArray[np.intp], penalty: float) -> None:
        self.residuals, self.jacobian = residuals, jacobian
        self.x, self.free, self.which, self.penalty = x.copy(), free, which, penalty
        self._cached: tuple[bytes, F64] | None = None

    def full(self, z: F64) -> F64:
        out = self.x.copy()
        out[self.free] = z
        return out[None, :]

    def raw(self, x_full: F64) -> F64:
        """The residuals (a,) at a full parameter vector (p,), as the caller gives them."""
        got = self.residuals(x_full[None, :], self.which)
        r = got[0] if self.jacobian is True else got
        return np.asarray(r, dtype=np.float64)[0]

    def __call__(self, z: F64) -> F64:
        got = self.residuals(self.full(z), self.which)
        if self.jacobian is True:
            r, jac = got
            self._cached = (z.tobytes(), np.asarray(jac, dtype=np.float64)[0])
        else:
            r = got
        return _finite(np.asarray(r, dtype=np.float64)[0], self.penalty)

    def jac(self, z: F64) -> F64:
        if self.jacobian is True:
            if self._cached is None or self._cached[0] != z.tobytes():
                self(z)
            assert self._cached is not None
            jac = self._cached[1]
        else:
            assert callable(self.jacobian)
            jac = np.asarray(self.jacobian(self.full(z), self.which), dtype=np.float64)[0]
        return np.asarray(jac[:, self.free])
