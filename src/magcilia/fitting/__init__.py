"""Least squares, once: the batched bounded Levenberg–Marquardt that calibration and the
read-outs use, its multistart, and the one SciPy polish (no physics; units are the caller's).

* :func:`fit_batch` (:mod:`.levenberg_marquardt`): ``s`` independent problems of ``p``
  parameters at once, each with ``a`` residuals, within bounds; one damping rule (Marquardt's
  scaled λ, ÷3 on a step that lowers the cost, ×4 on one that does not); Jacobians analytic
  (``jacobian=callable``, or ``jacobian=True`` when the residual function returns them too) or by
  forward differences in the same vectorised call; each iteration, for every problem size and
  Jacobian source, is one compiled step (:mod:`.compiled`, numba: the normal equations, the
  scaled system, its solve — the closed form for two parameters —, the bound-held parameters,
  then the acceptance, λ and the stopping tests), with the NumPy step in
  :mod:`.levenberg_marquardt` as its reference, run without numba or with
  ``compiled.ENABLED = False`` (the fitter's one switch).
* :func:`multistart`, :func:`halving`, :func:`latin_hypercube` (:mod:`.multistart`): starts
  spread over the box, narrowed by successive halving, the survivors run to convergence.
* :func:`polish` (:mod:`.polish`): ``scipy.optimize.least_squares`` (trf) from a good point.
* :class:`BatchFit` (:mod:`.result`): what they return (x, cost, residuals, JᵀJ, iterations,
  evaluations, converged), frozen.

How to use
----------
Write the residuals of many parameter vectors at once: ``residuals(x, which)`` takes ``x``
(m, p), the rows of several problems mixed, and ``which`` (m,), the problem each row belongs to
(to look up that problem's data), and returns (m, a). A bad point may return NaN (it is never
accepted). Problems with fewer residuals pad with zeros; a regularisation (Tikhonov) is extra
residual rows ``sqrt(α) x``. Weights multiply the residuals.

>>> import numpy as np
>>> from magcilia.fitting import fit_batch
>>> t = np.linspace(0.0, 1.0, 20)
>>> truth = np.array([[2.0, 3.0], [1.0, 0.5]])  # two decays: amplitude, rate
>>> data = truth[:, :1] * np.exp(-truth[:, 1:] * t)  # (s, a)
>>> def residuals(x, which):
...     return x[:, :1] * np.exp(-x[:, 1:] * t) - data[which]
>>> fit = fit_batch(residuals, [[1.0, 1.0], [1.0, 1.0]], [0.0, 0.0], [10.0, 10.0])
>>> np.round(fit.x, 6).tolist(), fit.converged.tolist()
([[2.0, 3.0], [1.0, 0.5]], [True, True])

An analytic Jacobian (m, a, p) goes in as ``jacobian=`` (called once per iteration at the
current points, so a caller may return a cached one while the steps are small: chord steps);
with bounds (p,) shared or (s, p) per problem, infinite where there are none:

>>> def jacobian(x, which):
...     e = np.exp(-x[:, 1:] * t)
...     return np.stack([e, -x[:, :1] * t * e], axis=-1)
>>> fit = fit_batch(residuals, [[1.0, 1.0]] * 2, [-np.inf] * 2, [np.inf] * 2,
...                 jacobian=jacobian, final_jacobian=True)
>>> np.round(fit.x, 6).tolist()
[[2.0, 3.0], [1.0, 0.5]]
>>> fit.jtj.shape  # at the fitted points: σ² (JᵀJ)⁻¹ is the covariance
(2, 2, 2)

:func:`multistart` fits one problem from many starts (``which`` is then the start's index) and
returns the minima found, best first; :func:`polish` takes the same residual function and
hands each row to SciPy.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from magcilia._lazy import attach

if TYPE_CHECKING:
    from magcilia.fitting.levenberg_marquardt import Jacobian, Residuals, fit_batch, sum_squares
    from magcilia.fitting.multistart import halving, latin_hypercube, multistart
    from magcilia.fitting.polish import NONFINITE_PENALTY, polish
    from magcilia.fitting.result import BatchFit

__all__ = [
    "NONFINITE_PENALTY",
    "BatchFit",
    "Jacobian",
    "Residuals",
    "fit_batch",
    "halving",
    "latin_hypercube",
    "multistart",
    "polish",
    "sum_squares",
]

__getattr__, __dir__ = attach(__name__)
