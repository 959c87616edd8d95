"""D-optimal designs: which rows of a Jacobian pin the parameters down (issue 14, item 5).

:func:`d_optimal` chooses ``budget`` conditions (repeats allowed) from a candidate set, given the
rows each candidate adds to the Jacobian (sensitivities of its observable(s) to the parameters,
divided by the noise σ), to maximise ``log det(JᵀJ + prior precision)`` (D-optimality; with
nuisance parameters such as per-experiment offsets, the D_s criterion: the log det of the
information about the parameters of interest once the nuisances are profiled out). The search is
a greedy start (add the candidate that raises the criterion most, one at a time) followed by
Fedorov's exchange (swap the design point and candidate that raise it most, until no swap does).
Both steps evaluate all candidates at once as a batch of small ``log det``: for the designs here
(tens of candidates, a dozen parameters) a plan takes milliseconds, so NumPy needs no optimiser
package (pyDOE's ``jacobian_optimal_design`` does the same candidate-set D-optimality, without
nuisance parameters or repeats of a multi-row candidate).

:func:`evaluate_design` gives the same figures (log det, rank, condition number, expected standard
errors) for any design, e.g. the paper's equally spaced angles;
:func:`~magcilia.calibration.plan.plan_calibration` builds the candidates of a tilt-table
calibration of a :class:`~magcilia.device.setup.Setup` (tilt angles ×
azimuths, the AMR output or the three field components) and compares the plan with the paper's
single path at the same budget.

Examples
--------
Quadratic regression on [−1, 1]: the exact D-optimal 3-point design is {−1, 0, 1}.

>>> import numpy as np
>>> x = np.linspace(-1.0, 1.0, 21)
>>> design = d_optimal(np.stack([np.ones_like(x), x, x * x], axis=1), 3)
>>> x[design.chosen].tolist()
[-1.0, 0.0, 1.0]
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from magcilia import _validate as v
from magcilia._display import Display, Item, number
from magcilia.calibration.plan_size import check_plan_size
from magcilia.device.parameters import PARAMETERS

F64 = NDArray[np.float64]

#: relative rise of the criterion below which the exchange stops
TOLERANCE = 1e-10
#: most exchanges
MAX_EXCHANGES = 10_000
#: an eigenvalue of the column-scaled information below this fraction of the largest is zero
#: (a condition number of the scaled Jacobian above 1e6)
RANK_TOLERANCE = 1e-12
#: a parameter whose share of an undetermined direction exceeds this has no standard error
NULL_COMPONENT = 1e-4
#: random starting designs of the exchange besides the greedy one
RESTARTS = 10


@dataclass(frozen=True, repr=False, eq=False)
class Design(Display):
    """A design: how often each candidate is measured, and what it is expected to tell.

    Attributes
    ----------
    chosen : ndarray of int, shape (N,)
        Candidate indices of the N conditions, sorted (a repeat is a repeated measurement).
    counts : ndarray of int, shape (c,)
        How often each candidate is measured.
    names : tuple of str
        Parameter names, length p (``interest`` the ones the criterion is about).
    interest : tuple of str
        Parameters of interest; the others are nuisances (profiled out of the criterion).
    log_det : float
        ``log det`` of the information about the parameters of interest (SI units:
        the Schur complement of ``JᵀJ + prior precision``); -inf when singular.
    rank : int
        Rank of the information about the parameters of interest (nuisances profiled out,
        columns scaled to unit size); full rank is ``len(interest)``.
    condition : float
        Condition number of that information's square root (the column-scaled Jacobian's, for
        a design without nuisances); inf when rank-deficient.
    stderr : ndarray, shape (p,)
        Expected standard errors ``sqrt(diag((JᵀJ + P)⁻¹))``, SI; inf for a parameter the
        design cannot determine.
    exchanges : int
        Fedorov exchanges made after the greedy start (0 for an evaluated design).
    """

    chosen: NDArray[np.int_]
    counts: NDArray[np.int_]
    names: tuple[str, ...]
    interest: tuple[str, ...]
    log_det: float
    rank: int
    condition: float
    stderr: F64
    exchanges: int

    @property
    def budget(self) -> int:
        """Number of conditions N."""
        return int(self.chosen.size)

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready, SI."""
        return {"units": "SI", "chosen": self.chosen.tolist(), "names": list(self.names),
                "interest": list(self.interest), "log_det": _finite(self.log_det),
                "rank": self.rank, "condition": _finite(self.condition),
                "stderr": {n: _finite(float(s)) for n, s in zip(self.names, self.stderr,
                                                               strict=True)},
                "exchanges": self.exchanges}

    def report(self) -> str:
        """Rank, condition number and the expected standard errors (display units)."""
        lines = [(f"Design of {self.budget} conditions: rank {self.rank}/{len(self.interest)}, "
                 f"condition number {number(self.condition)}, log det {number(self.log_det, 5)}")]
        lines += [f"  σ({n}) = {value_text(n, float(s))}" for n, s in zip(self.names, self.stderr,
                                                                    strict=True)]
        return "\n".join(lines)

    def _display_items(self) -> list[Item]:
        return [("N", str(self.budget)), ("rank", f"{self.rank}/{len(self.interest)}"),
                ("condition", number(self.condition)),
                *((f"σ {n}", value_text(n, float(s))) for n, s in zip(self.names, self.stderr,
                                                                 strict=True)
                  if n in self.interest)]


def _finite(x: float) -> float | None:
    return float(x) if math.isfinite(x) else None


def value_text(name: str, value: float, digits: int = 3) -> str:
    p = PARAMETERS.get(name.split("[", maxsplit=1)[0])
    if p is None or not p.display:
        return number(value, digits)
    return "inf" if not math.isfinite(value) else p.text(value, digits)


def condition_text(value: float) -> str:
    """A condition number for a table ("undetermined" where infinite)."""
    return "undetermined" if not math.isfinite(value) else f"{value:.3g}"


def _rows(jacobian: ArrayLike) -> F64:
    J = np.asarray(jacobian, dtype=np.float64)
    if J.ndim == 2:
        J = J[:, None, :]
    if J.ndim != 3 or J.shape[0] < 1 or J.shape[2] < 1 or not np.all(np.isfinite(J)):
        raise v.fail("jacobian", f"shape {J.shape}", "finite rows of shape (c, p) or (c, r, p): "
                                                     "candidates × rows × parameters")
    return J


def _setup_problem(J: F64, names: Sequence[str] | None, interest: Sequence[str] | None,
                   prior_precision: ArrayLike | None
                   ) -> tuple[tuple[str, ...], NDArray[np.int_], F64, F64, F64]:
    """Names, indices of interest, per-candidate information (c, p, p), prior (p, p), scale."""
    p = J.shape[2]
    names = tuple(names) if names is not None else tuple(f"p{i}" for i in range(p))
    if len(names) != p:
        raise v.fail("names", list(names), f"{p} names, one per column of the Jacobian")
    interest = tuple(names) if interest is None else tuple(interest)
    for n in interest:
        if n not in names:
            raise v.fail("interest", n, "names among " + ", ".join(names))
    idx = np.array([names.index(n) for n in interest], dtype=np.int_)
    if prior_precision is None:
        prior = np.zeros((p, p))
    else:
        given = np.asarray(prior_precision, dtype=np.float64)
        prior = np.diag(given) if given.ndim == 1 else given
        if prior.shape != (p, p) or not np.all(np.isfinite(prior)):
            raise v.fail("prior_precision", f"shape {prior.shape}",
                         f"a ({p},) vector or ({p}, {p}) matrix of precisions (1/σ²)")
    info = np.einsum("cri,crj->cij", J, J)
    # D-optimality does not depend on the columns' units: work with columns of unit size
    size = np.sqrt(np.einsum("cii->i", info) / J.shape[0] + np.diag(prior))
    scale = np.where(size > 0, 1.0 / np.where(size > 0, size, 1.0), 1.0)
    return names, idx, info * np.outer(scale, scale), prior * np.outer(scale, scale), scale


def _criterion(M: F64, nuis: NDArray[np.int_]) -> F64:
    """log det of the Schur complement of the ``nuis`` block (the information about the other
    parameters; batched over leading axes); -inf if singular."""
    sign, full = np.linalg.slogdet(M)
    out = np.where(sign > 0, full, -np.inf)
    if nuis.size:
        s2, part = np.linalg.slogdet(M[..., nuis[:, None], nuis[None, :]])
        out = np.where(s2 > 0, out - part, -np.inf)
    return np.asarray(out, dtype=np.float64)


def d_optimal(jacobian: ArrayLike, budget: int, *, names: Sequence[str] | None = None,
              interest: Sequence[str] | None = None, prior_precision: ArrayLike | None = None,
              initial: ArrayLike | None = None, restarts: int = RESTARTS,
              rng: int | np.random.Generator | None = 0,
              progress: Callable[[int, int], None] | None = None) -> Design:
    """The D-optimal choice of ``budget`` conditions from a candidate set (repeats allowed).

    A greedy start and ``restarts`` random starts are each improved by Fedorov's exchange; the
    best design is returned (random starts escape what one swap cannot: a new experiment whose
    offset needs two readings before it tells anything).

    Parameters
    ----------
    jacobian : array-like, shape (c, p) or (c, r, p)
        For each of ``c`` candidates, the ``r`` rows it adds to the Jacobian: the sensitivity of
        each of its observables to the ``p`` parameters (SI), divided by that observable's noise
        σ (e.g. r = 3 for the three components of a 3-axis magnetometer).
    budget : int
        Number of conditions N to choose (``N·r`` at least the number of parameters without a
        prior).
    names : sequence of str, optional
        Parameter names (default ``p0, p1, …``).
    interest : sequence of str, optional
        Parameters the criterion is about (default all); the others (offsets) are nuisances.
    prior_precision : array-like, shape (p,) or (p, p), optional
        Prior information (1/σ² of Gaussian priors, SI), added to ``JᵀJ``.
    initial : array-like of int, shape (N,), optional
        A further starting design for the exchange.
    restarts : int
        Random starting designs besides the greedy one (default :data:`RESTARTS`).
    rng : int or numpy Generator, optional
        Seed of the random starts (default 0: the same plan every time).
    progress : callable(done, total), optional
        Called after each start's exchange (the CLI draws a progress bar with it).

    Returns
    -------
    Design

    Raises
    ------
    MagciliaError
        A budget too small to determine the parameters, or a plan beyond
        :data:`~magcilia.calibration.plan_size.MAX_WORK` or
        :data:`~magcilia.calibration.plan_size.MAX_INFORMATION`
        (:func:`~magcilia.calibration.plan_size.check_plan_size`), before any work.
    """
    J = _rows(jacobian)
    c, _, p = J.shape
    names_t, idx, info, prior, scale = _setup_problem(J, names, interest, prior_precision)
    budget = v.integer("budget", budget, 1)
    informative = int(np.sum(np.diag(prior) == 0.0))
    if budget * J.shape[1] < informative:
        raise v.fail("budget", budget, f"at least {math.ceil(informative / J.shape[1])} "
                                       f"conditions to determine {informative} parameters "
                                       f"({', '.join(names_t)})")
    restarts = v.integer("restarts", restarts, 0)
    check_plan_size(budget, c, p, restarts)
    gen = rng if isinstance(rng, np.random.Generator) else np.random.default_rng(rng)
    nuis = np.array([i for i in range(p) if i not in set(idx.tolist())], dtype=np.int_)
    ridge = 1e-13 * budget * np.eye(p)  # keeps log det finite while a design is singular
    starts = [_greedy(info, prior + ridge, budget, nuis)]
    if initial is not None:
        chosen0 = np.asarray(initial, dtype=np.int_).reshape(-1)
        if chosen0.size != budget or np.any((chosen0 < 0) | (chosen0 >= c)):
            raise v.fail("initial", chosen0.tolist(), f"{budget} candidate indices in 0..{c - 1}")
        starts.append(np.bincount(chosen0, minlength=c).astype(np.int_))
    starts += [np.bincount(gen.integers(c, size=budget), minlength=c).astype(np.int_)
               for _ in range(restarts)]
    best: tuple[float, NDArray[np.int_], int] | None = None
    for done, start in enumerate(starts, 1):
        crit, counts, swaps = _exchange(start, info, prior + ridge, nuis)
        if best is None or crit > best[0] + TOLERANCE * max(1.0, abs(best[0])):
            best = (crit, counts, swaps)
        if progress is not None:
            progress(done, len(starts))
    assert best is not None
    return _summary(best[1], names_t, idx, info, prior, scale, best[2])


def _greedy(info: F64, base: F64, budget: int, nuis: NDArray[np.int_]) -> NDArray[np.int_]:
    """Add, one at a time, the candidate that raises the criterion most."""
    counts = np.zeros(info.shape[0], dtype=np.int_)
    M = base.copy()
    for _ in range(budget):
        best = int(np.argmax(_criterion(M[None] + info, nuis)))
        counts[best] += 1
        M = M + info[best]
    return counts


def _exchange(counts: NDArray[np.int_], info: F64, base: F64,
              nuis: NDArray[np.int_]) -> tuple[float, NDArray[np.int_], int]:
    """Fedorov's exchange: swap the design point and candidate that raise the criterion most,
    until no swap raises it (the criterion never falls)."""
    counts = counts.copy()
    M = base + np.einsum("c,cij->ij", counts.astype(float), info)
    current = float(_criterion(M, nuis))
    swaps = 0
    while swaps < MAX_EXCHANGES:
        best_gain, best_pair = 0.0, None
        for j in np.flatnonzero(counts):
            crit = _criterion((M - info[j])[None] + info, nuis)
            i = int(np.argmax(crit))
            gain = float(crit[i]) - current
            if i != j and gain > best_gain and gain > TOLERANCE * max(1.0, abs(current)):
                best_gain, best_pair = gain, (int(j), i)
        if best_pair is None:
            break
        out, into = best_pair
        counts[out] -= 1
        counts[into] += 1
        M = M - info[out] + info[into]
        current = float(_criterion(M, nuis))
        swaps += 1
    return current, counts, swaps


def evaluate_design(jacobian: ArrayLike, chosen: ArrayLike, *, names: Sequence[str] | None = None,
                    interest: Sequence[str] | None = None,
                    prior_precision: ArrayLike | None = None) -> Design:
    """The figures of a given design (:class:`Design`): ``chosen`` candidate indices, shape (N,),
    repeats allowed; the other arguments as :func:`d_optimal`."""
    J = _rows(jacobian)
    names_t, idx, info, prior, scale = _setup_problem(J, names, interest, prior_precision)
    chosen_a = np.asarray(chosen, dtype=np.int_).reshape(-1)
    if chosen_a.size < 1 or np.any((chosen_a < 0) | (chosen_a >= J.shape[0])):
        raise v.fail("chosen", chosen_a.tolist(), f"candidate indices in 0..{J.shape[0] - 1}")
    counts = np.bincount(chosen_a, minlength=J.shape[0]).astype(np.int_)
    return _summary(counts, names_t, idx, info, prior, scale, 0)


def _stderr(vals: F64, vecs: F64, good: NDArray[np.bool_]) -> F64:
    """sqrt(diag) of the pseudo-inverse of an information matrix given by its eigenvalues and
    eigenvectors; inf for a parameter touched by an undetermined direction."""
    var = np.diag((vecs[:, good] / vals[good]) @ vecs[:, good].T)
    null = (np.abs(vecs[:, ~good]).max(axis=1) if (~good).any()
            else np.zeros(vals.size))
    return np.where(null > NULL_COMPONENT, np.inf, np.sqrt(np.clip(var, 0.0, None)))


def _summary(counts: NDArray[np.int_], names: tuple[str, ...], idx: NDArray[np.int_], info: F64,
             prior: F64, scale: F64, exchanges: int) -> Design:
    """Rank, condition and log det of the information about the parameters of interest (the
    Schur complement, nuisances profiled out), and standard errors of all parameters."""
    p = len(names)
    M = prior + np.einsum("c,cij->ij", counts.astype(float), info)  # column-scaled
    nuis = np.array([i for i in range(p) if i not in set(idx.tolist())], dtype=np.int_)
    S = M[np.ix_(idx, idx)]
    if nuis.size:
        S = S - M[np.ix_(idx, nuis)] @ np.linalg.pinv(M[np.ix_(nuis, nuis)]) @ M[np.ix_(nuis, idx)]
    vals, vecs = np.linalg.eigh(0.5 * (S + S.T))
    top = float(vals[-1]) if vals.size else 0.0
    good = vals > RANK_TOLERANCE * top if top > 0 else np.zeros(vals.size, dtype=bool)
    rank = int(good.sum())
    q = idx.size
    condition = math.sqrt(top / float(vals[0])) if rank == q else math.inf
    log_det = (float(np.sum(np.log(vals))) - 2.0 * float(np.sum(np.log(scale[idx])))
               if rank == q else -math.inf)
    stderr = np.full(p, np.inf)
    stderr[idx] = _stderr(vals, vecs, good) * scale[idx]
    if nuis.size:  # the nuisances' own, from the whole information
        lam, vec = np.linalg.eigh(0.5 * (M + M.T))
        whole = _stderr(lam, vec, lam > RANK_TOLERANCE * float(lam[-1])) * scale
        stderr[nuis] = whole[nuis]
    return Design(chosen=np.repeat(np.arange(counts.size), counts), counts=counts, names=names,
                  interest=tuple(names[i] for i in idx), log_det=log_det, rank=rank,
                  condition=condition, stderr=stderr, exchanges=exchanges)
