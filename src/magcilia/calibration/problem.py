"""The calibration's least-squares problem: the model at the measured angles with the parameters
that enter linearly (bias polynomial, magnetization scale) projected out in closed form."""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np
from numpy.typing import NDArray

from magcilia.device.parameters import FITTED, INTEGER, default_bounds
from magcilia.device.setup import Setup
from magcilia.io.recordings import Measurement
from magcilia.model.batch import TiltBatch

F64 = NDArray[np.float64]

#: the fitted parameters (the registry's :data:`~magcilia.device.parameters.FITTED`), in the order
#: of the search vector
PARAMETERS = FITTED
CONTINUOUS = tuple(n for n in PARAMETERS if n not in INTEGER)
#: default search bounds (SI), from the registry
DEFAULT_BOUNDS = default_bounds()
#: position of each parameter in the search vector
INDEX = {name: i for i, name in enumerate(PARAMETERS)}
BIASES = ("offset", "polynomial", "none")
#: the cost given to a candidate whose model output is not finite (its element on a dipole, an
#: overflow): worse than any real fit but finite, so that the search's population statistics stay
#: finite and such candidates are simply never chosen; real costs are clipped to it too
NONFINITE_COST = 1e100

class Problem:
    """The least-squares problem with the linear parameters projected out."""

    def __init__(self, data: Measurement, initial: Setup, bias: str, bias_degree: int,
                 fit_scale: bool) -> None:
        self.data = data
        self.y = np.asarray(data.volts)
        self.angles = np.asarray(data.angles)
        self.base = initial.replace(offset=0.0)
        self.batch = TiltBatch(self.base, self.angles)
        self.fit_scale = fit_scale
        degree = -1 if bias == "none" else (0 if bias == "offset" else bias_degree)
        self.basis = np.vander(self.angles, degree + 1, increasing=True) if degree >= 0 else (
            np.zeros((self.angles.size, 0)))
        if self.basis.shape[1]:
            q, _ = np.linalg.qr(self.basis)
            self.q = q
        else:
            self.q = np.zeros((self.angles.size, 0))
        self.ry = self._project(self.y)
        self.evaluations = 0

    def _project(self, arr: F64) -> F64:
        """Remove the bias subspace from the last axis."""
        return arr - (arr @ self.q) @ self.q.T

    def model(self, params: Mapping[str, F64]) -> F64:
        """Unbiased model output, V, shape (N, a) (unchecked: non-finite where a candidate puts the
        element on a dipole; :meth:`cost` treats those as bad candidates)."""
        self.evaluations += int(np.size(next(iter(params.values()))))
        return self.batch.output(params)

    def residuals(self, u: F64) -> tuple[F64, F64]:
        """Projected residuals (N, a) and the fitted scale factors (N,) for model outputs u (rows
        with a non-finite output give non-finite residuals)."""
        with np.errstate(invalid="ignore", over="ignore"):
            return self._residuals(u)

    def _residuals(self, u: F64) -> tuple[F64, F64]:
        ru = self._project(u)
        if self.fit_scale:
            denom = np.einsum("na,na->n", ru, ru)
            a = np.where(denom > 0,
                         np.einsum("na,a->n", ru, self.ry) / np.where(denom > 0, denom, 1.0),
                         0.0)
            a = np.maximum(a, 0.0)
        else:
            a = np.ones(u.shape[0])
        return self.ry - a[:, None] * ru, a

    def cost(self, params: Mapping[str, F64]) -> F64:
        """Sum of squared residuals per candidate, V², shape (N,): :data:`NONFINITE_COST` where
        the model is not finite (or the cost exceeds it)."""
        r, _ = self.residuals(self.model(params))
        with np.errstate(invalid="ignore", over="ignore"):
            c = np.einsum("na,na->n", r, r)
        return np.where(np.isfinite(c), np.minimum(c, NONFINITE_COST), NONFINITE_COST)

    def bias_coefficients(self, u: F64, a: float) -> F64:
        """Least-squares bias polynomial for the scaled model a·u (constant first)."""
        if not self.basis.shape[1]:
            return np.zeros(0)
        coef, *_ = np.linalg.lstsq(self.basis, self.y - a * u, rcond=None)
        return np.asarray(coef)


def named(x: F64) -> dict[str, F64]:
    """Parameter columns by name, each shape (S,), from a search vector (p,) or matrix (p, S) in
    :data:`PARAMETERS` order."""
    x2 = np.asarray(x, dtype=np.float64).reshape(len(PARAMETERS), -1)
    return {name: x2[i] for i, name in enumerate(PARAMETERS)}
