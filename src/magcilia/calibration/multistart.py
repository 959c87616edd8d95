"""The calibration's global search: many local fits at once, narrowed by successive halving, then
every combination of the integer parameters (n, k) tried from the best few.

Why this shape. On field-vs-tilt data the continuous parameters (height, base radius, x, y, z)
have a few basins, and each (n, k) moves them: the model with one slice or one dipole per ring
differs in kind from the near-continuous body of many. A vectorised differential evolution
(SciPy's ``best1bin`` scheme) settled on one (n, k) family early and ended above the best cost
on 10 to 15 % of seeded synthetic recordings drawn across the default bounds, one run each; even
with (n, k) held at the truth, on 4 of 60, and on 14 of 200 when restarted until two runs
agreed. Local fits from a stratified sample of the whole box, with every (n, k) refitted from the
best solutions, found the best cost (within 1.05x) on 797 of 800 such recordings, in about 0.08 s
and a few hundred vectorised model calls each (``benchmarks/bench_calibration.py`` checks 200).

Steps:

1. ``starts`` points of a Latin hypercube over the box (integers rounded), the initial setup
   among them;
2. successive halving (:func:`magcilia.fitting.halving`): ``ROUND`` Levenberg–Marquardt
   iterations for all of them (:func:`magcilia.fitting.fit_batch`, analytic Jacobians from the
   compiled model pass: :meth:`Problem.data_residuals_jacobian`), keep the better half, repeat
   until ``SURVIVORS`` remain; these run on for at most ``SEARCH_MAXITER`` iterations (their
   best few only seed step 3);
3. the ``PROFILED`` best distinct solutions are refitted for every (n, k) within the bounds,
   by the same halving (``PROFILE_ROUND`` iterations per round: they start near a solution),
   the survivors run to convergence.

Measured over 200 seeded recordings (``benchmarks/bench_calibration.py``'s): halving the global
stage by 4 instead of 2, or with 6 iterations a round, or from 128 starts, lost 1 to 5 more
recordings than these settings (within 1.05x of a long search's cost on 198 of 200).

Every stage stops when it is done: a local fit ends when its steps stop lowering the cost.
"""

from __future__ import annotations

import logging

import numpy as np
from numpy.typing import NDArray

from magcilia.calibration.problem import Problem, named
from magcilia.fitting import Residuals, fit_batch, halving, latin_hypercube

F64 = NDArray[np.float64]
logger = logging.getLogger(__name__)

#: Levenberg–Marquardt iterations between two halvings
ROUND = 10
#: the same for the (n, k) refits, which start near a solution
PROFILE_ROUND = 4
#: local fits left when the halving stops (they then run to convergence)
SURVIVORS = 8
#: best distinct solutions refitted for every (n, k) (4 until issue 27: 3 kept the 198 of 200
#: and the bundled recording's cubic-bias optimum, for a quarter fewer refits)
PROFILED = 3
#: most iterations of a local fit run to convergence
MAXITER = 60
#: each halving of the global stage keeps the best 1/FACTOR of the fits …
FACTOR = 2
#: … and each of the (n, k) refits the best 1/PROFILE_FACTOR (8 lost the best optimum of the
#: bundled recording with a cubic bias for 3 of 6 seeds)
PROFILE_FACTOR = 2
#: most iterations of the global stage's survivors (their best few are refitted for every
#: (n, k), which runs on to convergence)
SEARCH_MAXITER = 15

__all__ = ["MAXITER", "PROFILED", "PROFILE_ROUND", "ROUND", "SURVIVORS", "Box", "latin_hypercube",
           "local_fits", "search"]


class Box:
    """The search box of one calibration: bounds (p,) in the search vector's order, which
    parameters are integers, and which are free (lower < upper)."""

    def __init__(self, lower: F64, upper: F64, integrality: NDArray[np.bool_]) -> None:
        self.lower, self.upper, self.integrality = lower, upper, integrality
        self.free = lower < upper
        self.continuous = self.free & ~integrality
        self.integers = np.nonzero(self.free & integrality)[0]

    def combinations(self) -> F64:
        """Every combination of the free integers' values, shape (c, i)."""
        grids = [np.arange(self.lower[i], self.upper[i] + 1.0) for i in self.integers]
        return np.stack(np.meshgrid(*grids, indexing="ij"), axis=-1).reshape(-1, len(grids))


def _residuals_of(problem: Problem, x: F64, cont: NDArray[np.bool_]) -> Residuals:
    """The residuals of continuous parameters ``xc`` (m, c) whose other parameters (the
    integers, the fixed ones) are those of the rows ``which`` of ``x`` (s, p); with their
    analytic Jacobian (m, a, c) when the problem has one (:attr:`Problem.analytic`: the fitter's
    ``jacobian=True``)."""

    columns = np.nonzero(cont)[0]

    def residuals(xc: F64, which: NDArray[np.intp]) -> object:
        rows = x[which]
        rows[:, columns] = xc
        if problem.analytic:
            return problem.data_residuals_jacobian(rows, columns)
        return problem.linear(problem.model(named(rows.T)))[0]

    return residuals


def local_fits(problem: Problem, box: Box, x: F64, maxiter: int) -> tuple[F64, F64]:
    """Levenberg–Marquardt fits of the continuous parameters from each row of ``x`` (s, p), the
    integers held at each row's values: the fitted rows (s, p) and their costs (s,), V²."""
    cont = box.continuous
    out = x.copy()
    if not cont.any():
        return out, problem.cost(named(x.T))
    fits = fit_batch(_residuals_of(problem, x, cont), x[:, cont], box.lower[cont],
                     box.upper[cont], maxiter=maxiter, jacobian=problem.analytic or None)
    out[:, cont] = fits.x
    return out, fits.cost


def _distinct(x: F64, cost: F64, box: Box, count: int) -> F64:
    """The ``count`` best rows of ``x`` that differ from each better one by more than 1e-3 of the
    box in some parameter (integers: by a whole number)."""
    width = np.where(box.free, box.upper - box.lower, 1.0)
    chosen: list[F64] = []
    for i in np.argsort(cost, kind="stable"):
        if not np.isfinite(cost[i]):
            break
        if all((np.abs(x[i] - c) / width).max() > 1e-3 for c in chosen):
            chosen.append(x[i])
        if len(chosen) == count:
            break
    return np.array(chosen).reshape(-1, x.shape[1])


def search(problem: Problem, box: Box, x_init: F64, rng: np.random.Generator,
           starts: int) -> F64:
    """The best parameter vector (p,) found from ``starts`` local fits and the (n, k) refits.

    Parameters
    ----------
    problem : Problem
        The least-squares problem.
    box : Box
        Bounds; fixed parameters keep their ``x_init`` values.
    x_init : ndarray, shape (p,)
        The initial setup's parameters (one of the starts).
    rng : Generator
        Randomness of the sample of starts.
    starts : int
        Local fits started.
    """
    lo = np.where(box.integrality, box.lower - 0.4999, box.lower)
    hi = np.where(box.integrality, box.upper + 0.4999, box.upper)
    x = np.repeat(x_init[None, :], starts, axis=0)
    x[:, box.free] = latin_hypercube(starts, lo, hi, rng)[:, box.free]
    x[:, box.integrality] = np.rint(x[:, box.integrality])
    x[0] = x_init
    x, cost = _halving(problem, box, x, ROUND, SEARCH_MAXITER, FACTOR)
    logger.debug("global search: %d starts, best cost %.6g V^2", starts, float(cost.min()))
    best = _distinct(x, cost, box, PROFILED)
    if box.integers.size == 0 or best.shape[0] == 0:
        return x[int(np.argmin(cost))]
    combos = box.combinations()
    trial = np.repeat(best, combos.shape[0], axis=0)
    trial[:, box.integers] = np.tile(combos, (best.shape[0], 1))
    logger.debug("(n, k) refits: %d solutions x %d combinations", best.shape[0], combos.shape[0])
    trial, cost = _halving(problem, box, trial, PROFILE_ROUND, MAXITER, PROFILE_FACTOR)
    logger.debug("(n, k) refits: best cost %.6g V^2", float(cost.min()))
    return trial[int(np.argmin(cost))]


def _halving(problem: Problem, box: Box, x: F64, iterations: int, maxiter: int,
             factor: int) -> tuple[F64, F64]:
    """Successive halving of local fits from the rows of ``x`` (s, p)
    (:func:`magcilia.fitting.halving`): ``iterations`` for all, keep the better half, …, until
    ``SURVIVORS`` remain, which run to convergence. Returns the survivors (m, p) and their
    costs (m,)."""
    cont = box.continuous
    if not cont.any():  # nothing to fit: the halving keeps the best by cost
        cost = problem.cost(named(x.T))
        if x.shape[0] > SURVIVORS:
            x = x[np.argsort(cost, kind="stable")[:SURVIVORS]]
        return local_fits(problem, box, x, maxiter)
    fits, kept = halving(_residuals_of(problem, x, cont), x[:, cont], box.lower[cont],
                         box.upper[cont], round_iterations=iterations, survivors=SURVIVORS,
                         maxiter=maxiter, jacobian=problem.analytic or None, factor=factor)
    logger.debug("halving: %d fits kept of %d, best cost %.6g V^2", kept.size, x.shape[0],
                 float(fits.cost.min()))
    out = x[kept]
    out[:, cont] = fits.x
    return out, fits.cost
