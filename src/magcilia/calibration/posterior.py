"""The posterior of a calibration's continuous parameters, sampled (issue 14, item 4).

:func:`sample_posterior` samples any vectorised log-probability ``log_prob(P: (N, p)) -> (N,)``
(for a weighted least-squares problem with residuals ``r`` already divided by their standard
errors, Gaussian prior terms included: ``−½ Σ r²``, ``−inf`` outside the bounds;
:func:`least_squares_log_prob` builds it) with the affine-invariant ensemble sampler emcee
(optional extra ``posterior``), and returns a frozen :class:`Posterior`: the samples, per-parameter
mean, standard deviation and equal-tailed credible intervals (68 % and 95 %), the effective sample
size (ESS), the acceptance fraction, and the modes with their weights. :func:`sample_problem`
does the same for a least-squares problem object (``names``, ``bounds``, ``residuals(P)``,
``jacobian(x)``: the joint calibration's), with the local covariances from its Jacobian and the
y → −y mirror as a second mode on request.

How it samples
--------------
* **Moves.** A mix of differential-evolution moves (80 %) and the stretch move (20 %): DE moves
  follow the correlated, elongated posteriors of a calibration (height, base radius and z nearly
  degenerate) well, the stretch move keeps the ensemble from collapsing onto a line. The log
  probability is called once per half-ensemble (``vectorize=True``), so the vectorised model pays
  one batched evaluation per step.
* **Start.** The walkers start from the Laplace approximation at each mode (a Gaussian with the
  inverse of the local Hessian of ``−log_prob``, found by finite differences in one batch), so
  little burn-in is spent finding the typical set; the first ``2 τ`` steps are discarded and the
  rest thinned by ``τ / 2``.
* **Stopping.** After every block of steps (:data:`BLOCK_STEPS`; near the end only the steps the
  latest estimate says are left, so the chain does not overshoot the rule by most of a block) the
  integrated autocorrelation time τ of each parameter
  is estimated with emcee's estimator (:func:`emcee.autocorr.integrated_time`); the ESS of a
  parameter is ``steps × walkers / τ``. A mode is done when its smallest ESS reaches its share of
  ``n_effective`` (at least :data:`MIN_MODE_ESS`) and the chain is at least :data:`TAU_FACTOR` τ
  long (emcee's advice for a trustworthy τ). At ``max_seconds`` the sampler stops with a
  :class:`SamplingWarning` saying what it reached.
* **Several modes.** An ensemble sampler does not move between well-separated modes (the y → −y
  mirror of a cilium seen through one field component, distinct optima of a multi-start search):
  walkers that start in two modes stay there in the proportion they started. So each mode is
  sampled on its own and the modes are weighted by their Laplace evidence,
  ``w_k ∝ exp(log_prob(θ_k)) · sqrt(det Σ_k)`` (Σ_k the local covariance); modes closer than
  :data:`MERGE_SIGMAS` σ (Mahalanobis) to a higher one are merged into it. Two mirror-image modes
  have equal log probability and mirror-image Hessians, hence exactly equal weights. The combined
  samples take from each mode a share equal to its weight; the combined ESS of a parameter is
  ``min_k ESS_k / w_k``. Modes below :data:`MIN_WEIGHT` are reported but not sampled.

Examples
--------
>>> import numpy as np
>>> def log_prob(P):
...     return -0.5 * np.sum((P / [1.0, 2.0]) ** 2, axis=1)
>>> post = sample_posterior(log_prob, [0.1, 0.0], names=["a", "b"],
...                         bounds=[(-20, 20), (-40, 40)], n_effective=200, rng=0)
>>> bool(abs(post.sd[1] / post.sd[0] - 2.0) < 0.3), bool(post.ess.min() >= 200)
(True, True)
"""

from __future__ import annotations

import math
import time
import warnings
from collections.abc import Callable, Sequence
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from magcilia import _validate as v
from magcilia._errors import require
from magcilia.calibration.posterior_result import (
    LEVELS,
    Posterior,
    SamplingWarning,
    display_unit,
    intervals,
)

F64 = NDArray[np.float64]
#: a vectorised log-probability: parameter sets (N, p) SI -> log densities (N,)
LogProb = Callable[[F64], ArrayLike]

#: a chain is trusted when it is at least this many autocorrelation times long (emcee's advice)
TAU_FACTOR = 50
#: fewest effective samples asked of any sampled mode
MIN_MODE_ESS = 100
#: modes whose weight is below this are reported but not sampled
MIN_WEIGHT = 1e-3
#: a mode within this Mahalanobis distance of a better one is the same mode
MERGE_SIGMAS = 3.0
#: most steps between two estimates of the autocorrelation time; once an estimate says fewer
#: are left (the chain's length and ESS rules, with :data:`BLOCK_MARGIN`), that many are run
BLOCK_STEPS = 200
#: the next block is the steps the latest τ says are left, times this (τ tends to grow with the
#: chain), and at least :data:`MIN_BLOCK_STEPS`
BLOCK_MARGIN = 1.1
MIN_BLOCK_STEPS = 20
#: default wall-clock limit of :func:`sample_posterior`, s
MAX_SECONDS = 60.0


# -- sampling -------------------------------------------------------------------------------------

def least_squares_log_prob(residuals: Callable[[F64], ArrayLike],
                           bounds: ArrayLike) -> Callable[[F64], F64]:
    """The log probability ``−½ Σ r²`` of weighted residuals, ``−inf`` outside ``bounds``.

    Parameters
    ----------
    residuals : callable
        ``residuals(P)`` with P of shape (N, p), SI, returning (N, m) residuals divided by their
        standard errors (Gaussian prior terms included as extra residuals).
    bounds : array-like, shape (p, 2)
        Low and high bound of each parameter, SI.

    Returns
    -------
    callable
        ``log_prob(P: (N, p)) -> (N,)``.
    """
    b = np.asarray(bounds, dtype=np.float64).reshape(-1, 2)

    def log_prob(P: F64) -> F64:
        P = np.atleast_2d(np.asarray(P, dtype=np.float64))
        inside = np.all((b[:, 0] <= P) & (b[:, 1] >= P), axis=1)
        out = np.full(P.shape[0], -np.inf)
        if inside.any():
            r = np.asarray(residuals(P[inside]), dtype=np.float64).reshape(int(inside.sum()), -1)
            lp = -0.5 * np.sum(r * r, axis=1)
            out[inside] = np.where(np.isfinite(lp), lp, -np.inf)
        return out

    return log_prob


def _call(log_prob: LogProb, P: F64) -> F64:
    out = np.asarray(log_prob(np.atleast_2d(P)), dtype=np.float64).reshape(-1)
    if out.size != np.atleast_2d(P).shape[0]:
        raise v.fail("log_prob", f"{out.size} values for {np.atleast_2d(P).shape[0]} points",
                     "a vectorised log_prob(P: (N, p)) returning shape (N,)")
    return np.where(np.isnan(out), -np.inf, out)


def laplace(log_prob: LogProb, mode: ArrayLike, bounds: ArrayLike) -> tuple[float, F64]:
    """Log probability at ``mode`` and the local covariance (inverse Hessian of ``−log_prob``).

    The Hessian is found by central finite differences, each step a fifth of the local σ along its
    axis (refined twice from a thousandth of the bound width), all points in one batch per pass.
    Directions the data do not curve (a non-positive eigenvalue) get the variance of a uniform
    prior over the bounds, and a :class:`SamplingWarning`.

    Returns
    -------
    (float, ndarray of shape (p, p))
    """
    x = np.asarray(mode, dtype=np.float64)
    b = np.asarray(bounds, dtype=np.float64).reshape(-1, 2)
    p = x.size
    width = b[:, 1] - b[:, 0]
    f0 = float(_call(log_prob, x[None])[0])
    if not math.isfinite(f0):
        raise v.fail("mode", x.tolist(), "a point where log_prob is finite (inside the bounds)")
    h = 1e-3 * width
    for _ in range(3):
        pts = np.concatenate([x + np.diag(h), x - np.diag(h)])
        f = _call(log_prob, pts)
        curv = -(f[:p] + f[p:] - 2.0 * f0) / (h * h)
        sigma = np.where(np.isfinite(curv) & (curv > 0), 1.0 / np.sqrt(np.abs(curv)), 0.1 * width)
        h = np.clip(0.2 * sigma, 1e-9 * width, 1e-2 * width)
    eye = np.diag(h)
    pairs = [(i, j) for i in range(p) for j in range(i + 1, p)]
    batch = [x + eye, x - eye]
    for s1, s2 in ((1, 1), (1, -1), (-1, 1), (-1, -1)):
        batch.append(np.array([x + s1 * eye[i] + s2 * eye[j] for i, j in pairs]).reshape(-1, p))
    f = _call(log_prob, np.concatenate(batch))
    fp, fm = f[:p], f[p:2 * p]
    n = len(pairs)
    fpp, fpm, fmp, fmm = (f[2 * p + k * n:2 * p + (k + 1) * n] for k in range(4))
    hess = np.diag(-(fp + fm - 2.0 * f0) / (h * h))
    for k, (i, j) in enumerate(pairs):
        hess[i, j] = hess[j, i] = -(fpp[k] - fpm[k] - fmp[k] + fmm[k]) / (4.0 * h[i] * h[j])
    if not np.all(np.isfinite(hess)):
        hess = np.where(np.isfinite(hess), hess, 0.0)
    # eigen-decompose in units of the bound widths, clip flat directions to a uniform prior's
    scaled = hess * np.outer(width, width)
    vals, vecs = np.linalg.eigh(0.5 * (scaled + scaled.T))
    floor = 12.0  # precision of a uniform distribution over a unit width
    if np.any(vals < floor):
        if np.any(vals <= 0.0):
            warnings.warn("a direction of the posterior is not curved at the mode; its spread "
                          "is taken as the bounds' (widen the data or add a prior)",
                          SamplingWarning, stacklevel=3)
        vals = np.maximum(vals, floor)
    cov = (vecs / vals) @ vecs.T * np.outer(width, width)
    return f0, 0.5 * (cov + cov.T)


def sample_posterior(log_prob: LogProb, start: ArrayLike, *, names: Sequence[str],
                     bounds: ArrayLike, modes: Sequence[ArrayLike] | None = None,
                     n_effective: int = 1000, rng: int | np.random.Generator | None = None,
                     max_seconds: float = MAX_SECONDS, walkers: int | None = None,
                     covariances: Sequence[ArrayLike] | None = None,
                     progress: Callable[[str], None] | None = None) -> Posterior:
    """Sample the posterior ``log_prob`` until every parameter has ``n_effective`` effective
    samples (or ``max_seconds`` pass).

    Parameters
    ----------
    log_prob : callable
        Vectorised log probability ``log_prob(P: (N, p)) -> (N,)``, SI parameters, ``-inf``
        outside the support (:func:`least_squares_log_prob` builds it from weighted residuals).
    start : array-like, shape (p,)
        The best point found (e.g. the least-squares optimum), SI.
    names : sequence of str, length p
        Parameter names (registry names show in display units in reports).
    bounds : array-like, shape (p, 2)
        Low and high bound of each parameter, SI; the walkers start inside.
    modes : sequence of array-like, shape (p,) each, optional
        Further starting points: other optima of a multi-start search, the y → −y mirror of
        ``start``; each distinct one is sampled and weighted by its Laplace evidence.
    n_effective : int
        Effective sample size asked of every parameter (default 1000).
    rng : int or numpy Generator, optional
        Seed or generator; the same seed gives the same samples.
    max_seconds : float
        Wall-clock limit, s; when reached the sampler stops with a :class:`SamplingWarning`.
    walkers : int, optional
        Walkers per mode (default ``max(32, 4 p)``, even).
    covariances : sequence of array-like, shape (p, p) each, optional
        The local covariance at ``start`` and at each of ``modes`` (same order), SI: for a least
        squares problem ``(JᵀJ)⁻¹`` of the weighted Jacobian, more accurate than the finite
        difference Hessian of :func:`laplace` used without them (:func:`sample_problem` passes
        them). Directions wider than the bounds are clipped to them as in :func:`laplace`.
    progress : callable, optional
        Called with a one-line status after each block of steps.

    Returns
    -------
    Posterior
    """
    emcee: Any = require("emcee", package="emcee", extra="posterior",
                         purpose="Sampling a posterior")
    x0 = np.asarray(start, dtype=np.float64).reshape(-1)
    names = tuple(str(n) for n in names)
    p = x0.size
    if len(names) != p:
        raise v.fail("names", list(names), f"{p} names, one per parameter of start")
    b = np.asarray(bounds, dtype=np.float64)
    if b.shape != (p, 2) or not np.all(np.isfinite(b)) or not np.all(b[:, 1] > b[:, 0]):
        raise v.fail("bounds", np.asarray(bounds).tolist(),
                     f"a ({p}, 2) array of finite (low, high) pairs with high > low")
    n_effective = v.integer("n_effective", n_effective, 1)
    max_seconds = v.real("max_seconds", max_seconds, "s")
    if max_seconds <= 0:
        raise v.fail("max_seconds", max_seconds, "a positive time limit in s")
    gen = rng if isinstance(rng, np.random.Generator) else np.random.default_rng(rng)
    n_walk = max(32, 4 * p) if walkers is None else v.integer("walkers", walkers, 2 * p + 2)
    n_walk += n_walk % 2
    t0 = time.perf_counter()
    deadline = t0 + max_seconds

    points = [x0, *(np.asarray(m, dtype=np.float64).reshape(-1) for m in (modes or []))]
    for m in points:
        if m.size != p or not np.all((m >= b[:, 0]) & (m <= b[:, 1])):
            raise v.fail("modes", m.tolist(), f"points of {p} values inside the bounds")
    if covariances is None:
        found = [(m, *laplace(log_prob, m, b)) for m in points]
    else:
        if len(covariances) != len(points):
            raise v.fail("covariances", f"{len(covariances)} matrices",
                         f"one ({p}, {p}) covariance per point ({len(points)}: start and modes)")
        found = [(m, float(_call(log_prob, m[None])[0]), _clipped(c, b)) for m, c in
                 zip(points, covariances, strict=True)]
        for m, lp, _ in found:
            if not math.isfinite(lp):
                raise v.fail("modes", m.tolist(), "points where log_prob is finite")
    found.sort(key=lambda t: -t[1])
    kept: list[tuple[F64, float, F64]] = []
    for m, lp, cov in found:  # merge a mode into a better one it lies within MERGE_SIGMAS of
        if all(_mahalanobis(m - k[0], k[2]) > MERGE_SIGMAS for k in kept):
            kept.append((m, lp, cov))
    log_ev = np.array([lp + 0.5 * np.linalg.slogdet(cov)[1] for _, lp, cov in kept])
    weights = np.exp(log_ev - log_ev.max())
    weights /= weights.sum()
    order = np.argsort(-weights, kind="stable")
    kept = [kept[i] for i in order]
    weights = weights[order]

    moves = [(emcee.moves.DEMove(), 0.8), (emcee.moves.StretchMove(), 0.2)]
    chains: list[tuple[F64, F64]] = []
    ess_modes: list[tuple[float, F64]] = []
    taus, accept = [], []
    steps_all = 0
    all_done = True
    sampled = [k for k in range(len(kept)) if weights[k] >= MIN_WEIGHT]
    for rank, k in enumerate(sampled):
        mode, _, cov = kept[k]
        # each mode gets an equal share of the time left
        mode_deadline = time.perf_counter() + (deadline - time.perf_counter()) / (
            len(sampled) - rank)
        target = max(MIN_MODE_ESS, math.ceil(weights[k] * n_effective))
        sampler = emcee.EnsembleSampler(n_walk, p, lambda P: _call(log_prob, P),
                                        moves=moves, vectorize=True)
        sampler.random_state = np.random.RandomState(
            int(gen.integers(2**32))).get_state()
        state = _initial(log_prob, mode, cov, b, n_walk, gen)
        tau = np.full(p, np.inf)
        ess = np.zeros(p)
        burn = 0
        block = BLOCK_STEPS
        while True:
            state = sampler.run_mcmc(state, block, progress=False)
            n = sampler.iteration
            tau = np.asarray(emcee.autocorr.integrated_time(
                sampler.get_chain()[n // 4:] if n >= 8 * BLOCK_STEPS else sampler.get_chain(),
                tol=0, quiet=True), dtype=np.float64)
            burn = min(math.ceil(2.0 * float(np.max(tau))), n // 2)
            ess = (n - burn) * n_walk / tau
            done = float(np.min(ess)) >= target and n - burn >= TAU_FACTOR * float(np.max(tau))
            if progress is not None:
                progress(f"mode {len(chains) + 1}/{len(sampled)}: {n} steps, τ ≤ "
                         f"{float(np.max(tau)):.0f}, ESS {float(np.min(ess)):.0f}/{target}")
            if done or time.perf_counter() >= mode_deadline:
                break
            block = _next_block(n, tau, target, n_walk)
        all_done &= done
        if not done:
            short = (f"ESS {float(np.min(ess)):.0f} of {target}"
                     if float(np.min(ess)) < target else
                     f"chain {sampler.iteration - burn} steps, under {TAU_FACTOR} τ "
                     f"(τ = {float(np.max(tau)):.0f}: the estimate is not yet trustworthy)")
            warnings.warn(f"posterior sampling stopped at the time limit ({max_seconds:g} s in "
                          f"all): {short} in mode {len(chains) + 1} after {sampler.iteration} "
                          f"steps, acceptance {float(np.mean(sampler.acceptance_fraction)):.2f};"
                          " raise max_seconds or lower n_effective", SamplingWarning,
                          stacklevel=2)
        thin = max(1, int(0.5 * float(np.min(tau)))) if np.all(np.isfinite(tau)) else 1
        chains.append((sampler.get_chain(discard=burn, thin=thin, flat=True),
                       sampler.get_log_prob(discard=burn, thin=thin, flat=True)))
        ess_modes.append((float(weights[k]), ess))
        taus.append(tau)
        accept.append(float(np.mean(sampler.acceptance_fraction)))
        steps_all += sampler.iteration

    w_sampled = np.array([w for w, _ in ess_modes])
    share = w_sampled / w_sampled.sum()
    total = min(len(c) / s for (c, _), s in zip(chains, share, strict=True))
    samples, logp = [], []
    for (chain, chain_lp), s in zip(chains, share, strict=True):
        count = round(s * total)
        idx = np.sort(gen.choice(len(chain), size=min(count, len(chain)), replace=False))
        samples.append(chain[idx])
        logp.append(chain_lp[idx])
    S = np.concatenate(samples)
    ess_all = np.min([e / s for (_, e), s in zip(ess_modes, share, strict=True)], axis=0)
    return Posterior(
        names=names, samples=S, log_prob=np.concatenate(logp), mean=S.mean(axis=0),
        sd=S.std(axis=0, ddof=1) if S.shape[0] > 1 else np.zeros(p),
        intervals={lv: intervals(S, lv) for lv in LEVELS}, ess=ess_all,
        autocorr_time=np.max(taus, axis=0), acceptance=float(np.mean(accept)),
        modes=np.array([m for m, _, _ in kept]), weights=weights,
        mode_log_prob=np.array([lp for _, lp, _ in kept]), walkers=n_walk, steps=steps_all,
        seconds=time.perf_counter() - t0, target=n_effective, long_enough=all_done)


def sample_problem(problem: Any, start: ArrayLike, *, modes: Sequence[ArrayLike] | None = None,
                   mirror: Sequence[str] = (), n_effective: int = 1000,
                   rng: int | np.random.Generator | None = None,
                   max_seconds: float = MAX_SECONDS,
                   progress: Callable[[str], None] | None = None) -> Posterior:
    """Sample the posterior of a weighted least-squares problem object (the joint calibration's).

    Parameters
    ----------
    problem : object
        With ``names`` (p names), ``bounds`` (array-like (p, 2), SI), ``residuals(P: (N, p)) ->
        (N, m)`` (residuals divided by their standard errors, Gaussian prior terms included) and
        ``jacobian(x: (p,)) -> (m, p)`` (of those residuals). The log probability is
        ``−½ Σ r²`` inside the bounds (:func:`least_squares_log_prob`); the local covariance
        at each mode is ``(JᵀJ)⁻¹`` (directions wider than the bounds clipped to them).
    start : array-like, shape (p,)
        The optimum (SI).
    modes : sequence of array-like, optional
        Other optima (e.g. distinct solutions of a multi-start search).
    mirror : sequence of str
        Parameters whose sign the data may not tell (``("y",)`` for one field component along
        a path at azimuth 0): ``start`` with each of them negated is added as a mode when inside
        the bounds (polish it first if the data can tell the sign: the point is taken as given).
    n_effective, rng, max_seconds, progress
        As :func:`sample_posterior`.

    Returns
    -------
    Posterior
    """
    names = tuple(str(n) for n in problem.names)
    b = np.asarray(problem.bounds, dtype=np.float64)
    x0 = np.asarray(start, dtype=np.float64).reshape(-1)
    points = [x0, *(np.asarray(m, dtype=np.float64).reshape(-1) for m in (modes or []))]
    for name in mirror:
        if name not in names:
            raise v.fail("mirror", name, "parameter names among " + ", ".join(names))
        flipped = x0.copy()
        i = names.index(name)
        flipped[i] = -flipped[i]
        if b[i, 0] <= flipped[i] <= b[i, 1] and flipped[i] != x0[i]:
            points.append(flipped)
    covs = []
    width = b[:, 1] - b[:, 0]
    for m in points:
        J = np.asarray(problem.jacobian(m), dtype=np.float64)
        info = (J.T @ J) * np.outer(width, width)
        vals, vecs = np.linalg.eigh(0.5 * (info + info.T))
        covs.append((vecs / np.maximum(vals, 12.0)) @ vecs.T * np.outer(width, width))
    return sample_posterior(least_squares_log_prob(problem.residuals, b), x0, names=names,
                            bounds=b, modes=points[1:], n_effective=n_effective, rng=rng,
                            max_seconds=max_seconds, covariances=covs, progress=progress)


def _next_block(n: int, tau: F64, target: int, n_walk: int) -> int:
    """Steps to run next after ``n``: what the stopping rule still asks by the latest τ (p,)
    (a chain of ``TAU_FACTOR τ`` after a burn-in of ``2 τ``, and ``target`` effective samples
    from ``n_walk`` walkers), times :data:`BLOCK_MARGIN`, within [:data:`MIN_BLOCK_STEPS`,
    :data:`BLOCK_STEPS`] (the rule itself is checked again after the block)."""
    if not np.all(np.isfinite(tau)):
        return BLOCK_STEPS
    slow = float(np.max(tau))
    need = 2.0 * slow + max(TAU_FACTOR * slow, target * slow / n_walk) - n
    return int(min(BLOCK_STEPS, max(MIN_BLOCK_STEPS, math.ceil(BLOCK_MARGIN * need))))


def _clipped(cov: ArrayLike, b: F64) -> F64:
    """A given covariance, symmetric, with directions wider than the bounds (or not positive)
    clipped to a uniform distribution's over them (as :func:`laplace`)."""
    c = np.asarray(cov, dtype=np.float64)
    p = b.shape[0]
    if c.shape != (p, p) or not np.all(np.isfinite(c)):
        raise v.fail("covariances", f"shape {c.shape}", f"finite ({p}, {p}) matrices")
    width = b[:, 1] - b[:, 0]
    scaled = c / np.outer(width, width)
    vals, vecs = np.linalg.eigh(0.5 * (scaled + scaled.T))
    vals = np.clip(vals, 1e-300, 1.0 / 12.0)
    out = (vecs * vals) @ vecs.T * np.outer(width, width)
    return np.asarray(0.5 * (out + out.T), dtype=np.float64)


def _mahalanobis(d: F64, cov: F64) -> float:
    return math.sqrt(max(float(d @ np.linalg.solve(cov, d)), 0.0))


def _initial(log_prob: LogProb, mode: F64, cov: F64, b: F64, n: int,
             gen: np.random.Generator) -> F64:
    """``n`` walkers drawn from N(mode, cov) inside the bounds with a finite log probability
    (falling back on a shrinking ball around the mode)."""
    chol = np.linalg.cholesky(cov + 1e-300 * np.eye(mode.size))
    out = np.empty((0, mode.size))
    scale = 1.0
    for _ in range(20):
        P = mode + scale * gen.standard_normal((4 * n, mode.size)) @ chol.T
        P = P[np.all((b[:, 0] < P) & (b[:, 1] > P), axis=1)]
        if P.size:
            P = P[np.isfinite(_call(log_prob, P))]
        out = np.concatenate([out, P])[:n]
        if len(out) == n:
            return out
        scale *= 0.5
    raise v.fail("start", mode.tolist(), "a mode with a finite log_prob around it (inside "
                                         "the bounds)")


__all__ = ["BLOCK_STEPS", "LEVELS", "MAX_SECONDS", "MERGE_SIGMAS", "MIN_MODE_ESS", "MIN_WEIGHT",
           "TAU_FACTOR", "LogProb", "Posterior", "SamplingWarning", "display_unit", "laplace",
           "least_squares_log_prob", "sample_posterior", "sample_problem"]
