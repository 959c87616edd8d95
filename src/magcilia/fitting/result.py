"""The outcome of a batch of least-squares fits: :class:`BatchFit`."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from magcilia._display import Display, Item, count, number

F64 = NDArray[np.float64]


@dataclass(frozen=True, eq=False, repr=False)
class BatchFit(Display):
    """``s`` least-squares problems fitted at once (:func:`~magcilia.fitting.fit_batch`,
    :func:`~magcilia.fitting.polish`, :func:`~magcilia.fitting.multistart`); immutable.

    The fitting room knows no units: ``x`` is in the caller's parameter units, ``cost`` in the
    square of its residuals' units.

    Attributes
    ----------
    x : ndarray, shape (s, p)
        Final parameters of each problem.
    cost : ndarray, shape (s,)
        Their sums of squared residuals (inf where the residuals were never finite).
    residuals : ndarray, shape (s, a)
        The residuals at ``x`` (non-finite where they were never finite).
    jtj : ndarray, shape (s, p, p)
        The Gauss–Newton matrix JᵀJ of each problem (for a covariance: σ² (JᵀJ)⁻¹); where it
        was taken is said by the function that made the fit; NaN where no Jacobian was taken.
    iterations : ndarray of int, shape (s,)
        Linearisations (Jacobians) each problem took.
    evaluations : ndarray of int, shape (s,)
        Residual vectors evaluated for each problem (finite-difference probes included).
    converged : ndarray of bool, shape (s,)
        Whether each problem stopped by a convergence test (a small change of the cost or of
        ``x``, or no step lowering the cost), rather than by its iteration limit or a
        non-finite point.
    """

    x: F64
    cost: F64
    residuals: F64
    jtj: F64
    iterations: NDArray[np.int64]
    evaluations: NDArray[np.int64]
    converged: NDArray[np.bool_]

    @property
    def best(self) -> int:
        """Index of the problem with the lowest cost (the first when several tie)."""
        return int(np.argmin(self.cost))

    def take(self, rows: NDArray[np.intp]) -> BatchFit:
        """The fits of the problems ``rows`` (in that order)."""
        return BatchFit(self.x[rows], self.cost[rows], self.residuals[rows], self.jtj[rows],
                        self.iterations[rows], self.evaluations[rows], self.converged[rows])

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready summary: every array as nested lists (non-finite costs as ``inf``)."""
        return {"problems": int(self.x.shape[0]), "parameters": int(self.x.shape[1]),
                "x": self.x.tolist(), "cost": self.cost.tolist(),
                "iterations": self.iterations.tolist(), "evaluations": self.evaluations.tolist(),
                "converged": self.converged.tolist(), "jtj": self.jtj.tolist()}

    def report(self) -> str:
        """One paragraph: how many converged, the best cost and its parameters."""
        s = self.x.shape[0]
        finite = np.isfinite(self.cost)
        head = (f"{count(s, 'least-squares problem')} of {count(self.x.shape[1], 'parameter')}: "
                f"{int(self.converged.sum())} converged, {int(finite.sum())} with a finite cost; "
                f"iterations {int(self.iterations.min(initial=0))} to "
                f"{int(self.iterations.max(initial=0))}")
        if not s or not finite.any():
            return head
        i = self.best
        xs = ", ".join(number(float(v), 6) for v in self.x[i])
        return f"{head}\nbest: problem {i}, cost {number(float(self.cost[i]), 6)} at x = [{xs}]"

    def _display_items(self) -> list[Item]:
        s = self.x.shape[0]
        items: list[Item] = [("problems", str(s)), ("converged", str(int(self.converged.sum())))]
        if s:
            items.append(("best cost", number(float(self.cost[self.best]))))
        return items
