"""Global search by many local fits: starts spread over the box (:func:`latin_hypercube`), all
fitted at once by :func:`~magcilia.fitting.fit_batch`, narrowed by successive halving
(:func:`halving`), the survivors run to convergence; :func:`multistart` does the three.

Why halving: a few iterations already tell the starts in a good basin from the rest, so the
iterations go to the starts still worth them; the batched fit makes a round over hundreds of
starts cost about as many model calls as one over a few.
"""

from __future__ import annotations

import logging

import numpy as np
from numpy.typing import ArrayLike, NDArray

from magcilia import _validate as v
from magcilia.fitting.levenberg_marquardt import Jacobian, Residuals, bounds_of, fit_batch
from magcilia.fitting.result import BatchFit

logger = logging.getLogger(__name__)

F64 = NDArray[np.float64]

#: iterations of every start between two halvings
ROUND = 10
#: fits left when the halving stops (they then run to convergence)
SURVIVORS = 8
#: most iterations of a fit run to convergence
MAXITER = 60


def latin_hypercube(size: int, lower: F64, upper: F64, rng: np.random.Generator) -> F64:
    """``size`` points, shape (size, p), stratified in each coordinate between ``lower`` and
    ``upper`` (p,): one point in each of ``size`` equal slabs of every axis, slabs paired at
    random."""
    strata = rng.permuted(np.tile(np.arange(size), (lower.size, 1)), axis=1).T
    return lower + (strata + rng.random(strata.shape)) / size * (upper - lower)


def halving(
    residuals: Residuals,
    x0: ArrayLike,
    lower: ArrayLike,
    upper: ArrayLike,
    *,
    jacobian: Jacobian | bool | None = None,
    round_iterations: int = ROUND,
    survivors: int = SURVIVORS,
    maxiter: int = MAXITER,
    factor: int = 2,
) -> tuple[BatchFit, NDArray[np.intp]]:
    """Successive halving of fits from the rows of ``x0`` (s, p): ``round_iterations`` of
    :func:`~magcilia.fitting.fit_batch` for all, keep the better half (at least
    ``survivors``), repeat until ``survivors`` remain, which then run to convergence (at most
    ``maxiter`` iterations). Every round starts afresh from the points reached (λ reset).
    ``factor`` > 2 keeps the best 1/``factor`` after each round instead (fewer rounds).

    ``residuals(x, which)`` sees ``which`` as rows of ``x0`` throughout; ``lower``, ``upper``
    are (p,) or one row per row of ``x0``.

    Returns
    -------
    fits : BatchFit
        The survivors' fits (m ≤ ``survivors`` problems), in the order of their rows.
    rows : ndarray of int, shape (m,)
        Each survivor's row of ``x0``.
    """
    x = np.array(x0, dtype=np.float64)
    size, dims = x.shape
    lo, hi = bounds_of(lower, upper, size, dims)
    rows = np.arange(size)
    survivors = v.integer("survivors", survivors)
    factor = v.integer("factor", factor, 2)

    def sub(xs: F64, which: NDArray[np.intp]) -> object:
        return residuals(xs, rows[which])

    def sub_jacobian(xs: F64, which: NDArray[np.intp]) -> F64:
        assert callable(jacobian)
        return jacobian(xs, rows[which])

    jac = sub_jacobian if callable(jacobian) else jacobian
    while True:
        bl, bh = (lo, hi) if lo.ndim == 1 else (lo[rows], hi[rows])
        fits = fit_batch(sub, x, bl, bh, jacobian=jac, maxiter=round_iterations)
        logger.debug("halving round: %d fits, best cost %.6g", x.shape[0],
                     float(fits.cost.min()))
        if x.shape[0] <= survivors:
            break
        keep = np.argsort(fits.cost, kind="stable")[:max(survivors, x.shape[0] // factor)]
        x, rows = fits.x[keep], rows[keep]
    bl, bh = (lo, hi) if lo.ndim == 1 else (lo[rows], hi[rows])
    return fit_batch(sub, fits.x, bl, bh, jacobian=jac, maxiter=maxiter), rows


def multistart(
    residuals: Residuals,
    lower: ArrayLike,
    upper: ArrayLike,
    *,
    starts: int,
    rng: int | np.random.Generator | None = None,
    x0: ArrayLike | None = None,
    jacobian: Jacobian | bool | None = None,
    round_iterations: int = ROUND,
    survivors: int = SURVIVORS,
    maxiter: int = MAXITER,
) -> BatchFit:
    """The minima found from ``starts`` points of a Latin hypercube over the bounds, by
    :func:`halving`.

    Parameters
    ----------
    residuals, jacobian
        As :func:`~magcilia.fitting.fit_batch` for one problem (``which`` is the start's index
        and may be ignored).
    lower, upper : array-like, shape (p,)
        Finite bounds: the box the starts fill.
    starts : int
        Starting points.
    rng : int, Generator or None
        Randomness of the sample of starts.
    x0 : array-like, shape (k, p) or (p,), optional
        Points to start from besides the sample (they replace its first rows).
    round_iterations, survivors, maxiter
        As :func:`halving`.

    Returns
    -------
    BatchFit
        The survivors' fits, best (lowest cost) first.
    """
    starts = v.integer("starts", starts)
    lo = np.asarray(lower, dtype=np.float64)
    hi = np.asarray(upper, dtype=np.float64)
    if lo.ndim != 1 or lo.shape != hi.shape or not (np.isfinite(lo).all()
                                                    and np.isfinite(hi).all()):
        raise v.fail("lower, upper", f"arrays of shapes {lo.shape}, {hi.shape}",
                     "finite bounds of one shape (p,)")
    x = latin_hypercube(starts, lo, hi, np.random.default_rng(rng))
    if x0 is not None:
        given = np.atleast_2d(np.asarray(x0, dtype=np.float64))[:starts]
        x[:given.shape[0]] = np.clip(given, lo, hi)
    fits, _ = halving(residuals, x, lo, hi, jacobian=jacobian,
                      round_iterations=round_iterations, survivors=survivors, maxiter=maxiter)
    return fits.take(np.argsort(fits.cost, kind="stable"))
