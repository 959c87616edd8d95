"""Calibration: fit the model's parameters to a field-vs-tilt recording (the paper's Sec. III.B).

The paper fits height, base radius, position (x, y, z), n and k with MATLAB's genetic algorithm,
minimising the sum of squared errors (its eq. 6, with the square the text describes). magcilia:

1. searches globally with SciPy's ``differential_evolution`` (integer n and k through
   ``integrality``), evaluating the whole population in one vectorised call
   (:func:`magcilia.model.tilt_output_batch`);
2. solves the parameters that enter the output *linearly* in closed form inside the objective:
   the output offset (or a polynomial bias in the angle) and, optionally, the magnetization scale;
3. polishes the best candidates with ``least_squares`` and repeats from several seeds;
4. reports standard errors and correlations from the Jacobian, and says plainly which parameters
   the data do not determine (one field component along one tilt path cannot pin seven
   parameters).

Bias removal: ``bias="offset"`` (default) fits a constant output offset jointly with the model.
``bias="polynomial"`` fits a polynomial of degree ``bias_degree`` in the angle jointly — the
consistent form of the paper's "a polynomial was fit into the measurement data set to remove the
DC bias" (removing it beforehand would also remove signal). Degree 0 equals ``"offset"``; higher
degrees absorb real signal shape and weaken the fit, so use them only for a known drift.
"""

from __future__ import annotations

import json
import math
import time
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, cast

import numpy as np
from numpy.typing import NDArray
from scipy.optimize import Bounds, differential_evolution, least_squares

from magcilia import _validate as v
from magcilia._errors import MagciliaError
from magcilia.measurements import Measurement
from magcilia.model import tilt_output_batch
from magcilia.setup import Setup

F64 = NDArray[np.float64]

CONTINUOUS = ("height", "base_radius", "x", "y", "z")
INTEGER = ("n_loops", "dipoles_per_loop")
PARAMETERS = CONTINUOUS + INTEGER

#: the bounds of the paper's search space used by default (SI; n and k as integers)
DEFAULT_BOUNDS: dict[str, tuple[float, float]] = {
    "height": (2e-3, 4e-3), "base_radius": (1e-4, 4e-4), "x": (-3e-3, 3e-3),
    "y": (-3e-3, 3e-3), "z": (0.0, 1e-3), "n_loops": (1, 10), "dipoles_per_loop": (1, 10),
}
BIASES = ("offset", "polynomial", "none")


@dataclass(frozen=True, eq=False)
class ParameterCovariance:
    """Standard errors and correlations of calibrated parameters: what read-out needs of a
    calibration (a :class:`CalibrationResult` carries the same three attributes).

    Attributes
    ----------
    correlation_names : tuple of str
        Parameter names (continuous ones, ``magnetization_scale``, ``offset``, ``bias_<d>``).
    stderr : dict of str to float
        1-σ standard errors, SI (inf where undetermined).
    correlation : ndarray, shape (p, p)
        Correlation matrix of ``correlation_names`` (NaN where undefined).
    covariance : ndarray, shape (p, p), or None
        The covariance itself (SI), finite along undetermined combinations (see
        :class:`CalibrationResult`); None if only standard errors and correlations are known.
    """

    correlation_names: tuple[str, ...]
    stderr: dict[str, float]
    correlation: F64
    covariance: F64 | None = None

    @classmethod
    def load(cls, path: str | Path) -> ParameterCovariance:
        """Read ``result.json`` written by ``magcilia calibrate`` (or a folder holding one);
        null standard errors (undetermined) become inf."""
        p = Path(path)
        if p.is_dir():
            p = p / "result.json"
        try:
            doc = json.loads(p.read_text(encoding="utf-8"))
            names = tuple(str(n) for n in doc["correlation"]["names"])
            matrix = np.array(doc["correlation"]["matrix"], dtype=np.float64)  # null -> nan
            stderr = {str(k): math.inf if val is None else float(val)
                      for k, val in doc["stderr"].items()}
            stored = (doc.get("covariance") or {}).get("matrix")
            covariance = None if stored is None else np.array(stored, dtype=np.float64)
        except FileNotFoundError:
            raise MagciliaError(f"{p}: no such file; give the result.json (or the --out folder) "
                                "of magcilia calibrate") from None
        except (ValueError, KeyError, TypeError) as exc:
            raise MagciliaError(f"{p}: not a calibration result ({type(exc).__name__}: {exc}); "
                                "give the result.json of magcilia calibrate") from None
        shape = (len(names), len(names))
        if (matrix.shape != shape or not set(names) <= set(stderr)
                or (covariance is not None and covariance.shape != shape)):
            raise MagciliaError(f"{p}: correlation matrix and standard errors do not match the "
                                "parameter names; give an unedited result.json")
        return cls(correlation_names=names, stderr=stderr, correlation=matrix,
                   covariance=covariance)


@dataclass(frozen=True, eq=False)
class CalibrationResult:
    """The outcome of :func:`calibrate` (immutable).

    Attributes
    ----------
    setup : Setup
        The fitted setup (same interface as ``Setup.paper(...)``); its ``output`` includes the
        fitted offset and magnetization scale.
    initial : Setup
        The starting setup.
    cost : float
        Sum over angles of (mean measured − model)², V² (the paper's cost).
    rms : float
        sqrt(cost / number of angles), V.
    residuals : ndarray, shape (a,)
        Measured − fitted model, V.
    data : Measurement
        The data that were fitted.
    values, stderr : dict of str to float
        Fitted parameters (SI) and their 1-σ standard errors from the Jacobian (NaN where not
        defined: integer parameters, or parameters the data do not determine).
    correlation : ndarray, shape (p, p)
        Correlation matrix of ``correlation_names``.
    correlation_names : tuple of str
    bias_coefficients : ndarray
        Polynomial bias coefficients (constant first; V, V/rad, …); the constant is the offset.
    warnings : tuple of str
        Plain-language identifiability warnings.
    bounds : dict
        The search bounds (SI).
    evaluations : int
        Model evaluations (parameter sets × angles counted once per set).
    elapsed : float
        Wall time, s.
    restart_costs : tuple of float
        Final cost of each restart, V².
    covariance : ndarray, shape (p, p), or None
        Parameter covariance of ``correlation_names`` (SI): σ² (JᵀJ)⁺, finite also along
        undetermined combinations, so that J C Jᵀ gives the fitted curve's uncertainty.
    """

    setup: Setup
    initial: Setup
    cost: float
    rms: float
    residuals: F64
    data: Measurement
    values: dict[str, float]
    stderr: dict[str, float]
    correlation: F64
    correlation_names: tuple[str, ...]
    bias_coefficients: F64
    bias: str
    warnings: tuple[str, ...]
    bounds: dict[str, tuple[float, float]]
    evaluations: int
    elapsed: float
    restart_costs: tuple[float, ...] = field(default=())
    covariance: F64 | None = None

    @property
    def fitted(self) -> F64:
        """Fitted model at the measured angles, V, shape (a,) (bias included)."""
        return self.data.volts - self.residuals

    def table(self) -> list[dict[str, Any]]:
        """Table-I-style rows: parameter, unit, initial, fitted, standard error (display units)."""
        scale = {"height": 1e3, "base_radius": 1e3, "x": 1e3, "y": 1e3, "z": 1e3,
                 "n_loops": 1.0, "dipoles_per_loop": 1.0, "magnetization_scale": 1.0,
                 "offset": 1e3}
        unit = {"height": "mm", "base_radius": "mm", "x": "mm", "y": "mm", "z": "mm",
                "n_loops": "", "dipoles_per_loop": "", "magnetization_scale": "", "offset": "mV"}
        init = self.initial.params()
        rows = []
        for name in (*PARAMETERS, "magnetization_scale", "offset"):
            if name not in self.values:
                continue
            f = scale[name]
            rows.append({
                "parameter": name, "unit": unit[name], "initial": init[name] * f,
                "fitted": self.values[name] * f, "stderr": self.stderr.get(name, math.nan) * f,
            })
        return rows

    def report(self) -> str:
        """A plain-text summary: cost, RMS, the parameter table and the warnings."""
        lines = [
            f"calibration of {self.data.source}: {len(self.data)} angles",
            f"cost {self.cost:.6g} V^2 (sum of squared residuals), RMS {self.rms * 1e3:.4g} mV",
            f"{'parameter':<20} {'unit':<4} {'initial':>12} {'fitted':>12} {'std. error':>12}",
        ]
        for r in self.table():
            se = (f"{r['stderr']:.4g}" if math.isfinite(r["stderr"])
                  else "undetermined" if r["stderr"] == math.inf else "-")
            lines.append(f"{r['parameter']:<20} {r['unit']:<4} {r['initial']:12.6g} "
                         f"{r['fitted']:12.6g} {se:>12}")
        lines += [f"warning: {w}" for w in self.warnings]
        return "\n".join(lines)

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready content (SI units, plus the display table)."""
        return {
            "source": self.data.source, "cost_V2": self.cost, "rms_V": self.rms,
            "values": self.values, "stderr": self.stderr,
            "covariance": {"names": list(self.correlation_names),
                           "matrix": None if self.covariance is None else self.covariance.tolist()},
            "correlation": {"names": list(self.correlation_names),
                            "matrix": self.correlation.tolist()},
            "bias": self.bias, "bias_coefficients": self.bias_coefficients.tolist(),
            "warnings": list(self.warnings), "bounds": {k: list(b) for k, b in self.bounds.items()},
            "angle_deg": self.data.angles_deg.tolist(), "measured_V": self.data.volts.tolist(),
            "fitted_V": self.fitted.tolist(), "residual_V": self.residuals.tolist(),
            "table": self.table(), "evaluations": self.evaluations, "elapsed_s": self.elapsed,
            "restart_costs_V2": list(self.restart_costs),
        }


class _Problem:
    """The least-squares problem with the linear parameters projected out."""

    def __init__(self, data: Measurement, initial: Setup, bias: str, bias_degree: int,
                 fit_scale: bool) -> None:
        self.data = data
        self.y = np.asarray(data.volts)
        self.angles = np.asarray(data.angles)
        self.base = initial.replace(offset=0.0)
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
        """Unbiased model output, V, shape (N, a)."""
        self.evaluations += int(np.size(next(iter(params.values()))))
        return tilt_output_batch(self.base, params, self.angles)

    def residuals(self, u: F64) -> tuple[F64, F64]:
        """Projected residuals (N, a) and the fitted scale factors (N,) for model outputs u."""
        ru = self._project(u)
        if self.fit_scale:
            denom = np.einsum("na,na->n", ru, ru)
            a = np.where(denom > 0, np.einsum("na,a->n", ru, self.ry) / np.where(denom > 0, denom, 1.0), 0.0)
            a = np.maximum(a, 0.0)
        else:
            a = np.ones(u.shape[0])
        return self.ry - a[:, None] * ru, a

    def cost(self, params: Mapping[str, F64]) -> F64:
        r, _ = self.residuals(self.model(params))
        return np.einsum("na,na->n", r, r)

    def bias_coefficients(self, u: F64, a: float) -> F64:
        """Least-squares bias polynomial for the scaled model a·u (constant first)."""
        if not self.basis.shape[1]:
            return np.zeros(0)
        coef, *_ = np.linalg.lstsq(self.basis, self.y - a * u, rcond=None)
        return np.asarray(coef)


def check_bound_values(bounds: Mapping[str, Sequence[float]]) -> None:
    """Raise unless the (low, high) bounds present keep n and k whole numbers >= 1 and the height
    and base radius positive."""
    for name in INTEGER:
        if name in bounds:
            lo, hi = bounds[name]
            if lo < 1 or not float(lo).is_integer() or not float(hi).is_integer():
                raise v.fail(f"bounds[{name!r}]", (lo, hi), "whole numbers >= 1")
    for name in ("height", "base_radius"):
        if name in bounds and float(bounds[name][0]) <= 0:
            raise v.fail(f"bounds[{name!r}]", tuple(bounds[name]), "positive lengths in m")


def _check_bounds(bounds: Mapping[str, tuple[float, float]] | None,
                  initial: Setup) -> dict[str, tuple[float, float]]:
    merged = v.intervals("bounds", bounds, DEFAULT_BOUNDS)
    check_bound_values(merged)
    init = initial.params()
    for name in PARAMETERS:
        lo, hi = merged[name]
        tol = 1e-9 * max(abs(lo), abs(hi), 1e-9)  # unit conversions (mm -> m) round off
        if not lo - tol <= init[name] <= hi + tol:
            raise v.fail(f"initial {name}", init[name],
                         f"inside its bounds [{lo:.6g}, {hi:.6g}] (move the initial value or widen the bounds)")
    return merged


def calibrate(
    data: Measurement,
    initial: Setup | None = None,
    bounds: Mapping[str, tuple[float, float]] | None = None,
    *,
    rng: int | np.random.Generator | None = None,
    bias: str = "offset",
    bias_degree: int = 0,
    fit_scale: bool = False,
    restarts: int = 3,
    maxiter: int = 300,
    popsize: int = 12,
    tol: float = 1e-8,
    progress: Callable[[int, int], None] | None = None,
) -> CalibrationResult:
    """Fit height, base radius, x, y, z, n and k (plus the bias and optionally the magnetization
    scale) to a recording.

    Parameters
    ----------
    data : Measurement
        Per-angle mean outputs (see :func:`magcilia.read_measurements`).
    initial : Setup, optional
        Starting setup; supplies everything that is not fitted (material, sensor, ring rule).
        Default: Table I's initial values (``Setup.paper_initial()``).
    bounds : mapping of str to (low, high), optional
        Search bounds in SI (m; n and k as whole numbers); missing keys take
        :data:`DEFAULT_BOUNDS`. The initial values must lie inside.
    rng : int, Generator or None
        Seed for the global search; the same seed gives the same result.
    bias : {"offset", "polynomial", "none"}
        How the DC bias is removed (see the module docstring).
    bias_degree : int
        Degree of the polynomial bias (with ``bias="polynomial"``).
    fit_scale : bool
        Also fit the magnetization scale (solved in closed form; ≥ 0).
    restarts : int
        Independent global searches; the best polished result is kept.
    maxiter, popsize, tol : int, int, float
        ``differential_evolution`` settings per restart.
    progress : callable(done, total), optional
        Called after each restart (the CLI draws a progress bar with it).

    Returns
    -------
    CalibrationResult
    """
    t0 = time.perf_counter()
    if not isinstance(data, Measurement):
        raise v.fail("data", type(data).__name__, "a magcilia Measurement (use read_measurements)")
    initial = initial if initial is not None else Setup.paper_initial()
    v.choice("bias", bias, BIASES)
    degree = v.integer("bias_degree", bias_degree, 0)
    restarts = v.integer("restarts", restarts, 1)
    n_lin = (0 if bias == "none" else (1 if bias == "offset" else degree + 1)) + int(fit_scale)
    if len(data) <= n_lin + 1:
        raise MagciliaError(
            f"{data.source}: {len(data)} angles cannot determine {n_lin} linear parameters and the "
            "geometry; record more angles"
        )
    box = _check_bounds(bounds, initial)
    problem = _Problem(data, initial, bias, degree, fit_scale)
    lower = np.array([box[n][0] for n in PARAMETERS])
    upper = np.array([box[n][1] for n in PARAMETERS])
    integrality = np.array([n in INTEGER for n in PARAMETERS])
    free = lower < upper  # fixed parameters (low == high) are left out of the search
    x_init = np.clip([initial.params()[n] for n in PARAMETERS], lower, upper)

    def full(x_free: F64) -> F64:
        """Complete parameter columns (7, S) from the free ones (f, S)."""
        x2 = np.repeat(x_init[:, None], x_free.shape[1], axis=1)
        x2[free] = x_free
        return x2

    def objective(x: F64) -> F64:
        # vectorized: x has shape (f, S), one column per population member
        x2 = full(x.reshape(int(free.sum()), -1))
        return problem.cost({name: x2[i] for i, name in enumerate(PARAMETERS)})

    seeds = np.random.default_rng(rng).integers(0, 2**32 - 1, size=restarts)
    candidates: list[tuple[float, F64]] = []
    restart_costs = []
    for i, seed in enumerate(seeds):
        if free.any():
            res = differential_evolution(
                cast(Any, objective), bounds=Bounds(lower[free], upper[free]),
                integrality=integrality[free], vectorized=True, updating="deferred",
                seed=int(seed), maxiter=maxiter, popsize=popsize, tol=tol, polish=False,
                init="sobol", x0=x_init[free] if i == 0 else None, mutation=(0.5, 1.0),
                recombination=0.7,
            )
            x_start = full(np.asarray(res.x)[:, None])[:, 0]
        else:
            x_start = x_init
        best = _polish(problem, x_start, lower, upper, integrality)
        candidates.append(best)
        restart_costs.append(best[0])
        if progress is not None:
            progress(i + 1, restarts)
    _, x_best = min(candidates, key=lambda c: c[0])
    x_best = _y_sign_of(x_best, initial.position[1], box["y"])
    return _result(problem, initial, data, box, x_best, bias, t0, tuple(restart_costs))


def _y_sign_of(x: F64, y_initial: float, y_bounds: tuple[float, float]) -> F64:
    """B_x is even in y (mirror symmetry about the x-z plane), so y and -y fit exactly equally
    well: keep the sign of the initial y (positive for 0) when -y is within the bounds."""
    y = float(x[3])
    wanted = -1.0 if y_initial < 0.0 else 1.0
    if y * wanted < 0.0 and y_bounds[0] <= -y <= y_bounds[1]:
        x = x.copy()
        x[3] = -y
    return x


def _polish(problem: _Problem, x: F64, lower: F64, upper: F64,
            integrality: NDArray[np.bool_]) -> tuple[float, F64]:
    """Local least-squares polish of the continuous parameters (n, k fixed)."""
    cont = ~integrality & (lower < upper)
    x = np.array(x, dtype=np.float64)
    x[integrality] = np.rint(x[integrality])
    width = upper - lower

    def resid(xc: F64) -> F64:
        full = x.copy()
        full[cont] = xc
        r, _ = problem.residuals(problem.model({n: full[i:i + 1] for i, n in enumerate(PARAMETERS)}))
        return r[0]

    start = np.clip(x[cont], lower[cont], upper[cont])
    try:
        sol = least_squares(resid, start, bounds=(lower[cont], upper[cont]), x_scale=width[cont],
                            method="trf", xtol=1e-12, ftol=1e-14, gtol=1e-12, max_nfev=400)
        x[cont] = sol.x
    except ValueError:
        pass  # start on a bound face with zero width: keep the global optimum
    r = resid(x[cont])
    return float(r @ r), x


def _result(problem: _Problem, initial: Setup, data: Measurement,
            box: dict[str, tuple[float, float]], x: F64, bias: str, t0: float,
            restart_costs: tuple[float, ...]) -> CalibrationResult:
    params = {n: x[i:i + 1] for i, n in enumerate(PARAMETERS)}
    u = problem.model(params)
    _, a = problem.residuals(u)
    scale = float(a[0])
    coef = problem.bias_coefficients(u[0], scale)
    offset = float(coef[0]) if coef.size else 0.0
    fitted_setup = initial.replace(
        height=float(x[0]), base_radius=float(x[1]), x=float(x[2]), y=float(x[3]), z=float(x[4]),
        n_loops=round(x[5]), dipoles_per_loop=round(x[6]),
        magnetization_scale=initial.material.magnetization_scale * scale, offset=offset,
    )
    model_full = scale * u[0] + (problem.basis @ coef if coef.size else 0.0)
    residuals = problem.y - model_full
    cost = float(residuals @ residuals)
    values: dict[str, float] = {n: float(x[i]) for i, n in enumerate(PARAMETERS)}
    values["n_loops"], values["dipoles_per_loop"] = float(round(x[5])), float(round(x[6]))
    values["magnetization_scale"] = fitted_setup.material.magnetization_scale
    values["offset"] = offset
    names, stderr, corr, cov, warns = _uncertainty(problem, x, scale, cost, box)
    return CalibrationResult(
        setup=fitted_setup, initial=initial, cost=cost, rms=math.sqrt(cost / len(data)),
        residuals=residuals, data=data, values=values, stderr=stderr, correlation=corr,
        correlation_names=names, bias_coefficients=coef, bias=bias, warnings=warns, bounds=box,
        evaluations=problem.evaluations, elapsed=time.perf_counter() - t0,
        restart_costs=restart_costs, covariance=cov,
    )


def _uncertainty(problem: _Problem, x: F64, scale: float, cost: float,
                 box: dict[str, tuple[float, float]]
                 ) -> tuple[tuple[str, ...], dict[str, float], F64, F64, tuple[str, ...]]:
    """Standard errors and correlations from the Jacobian of the full model at the optimum."""
    columns: list[F64] = []
    names: list[str] = []
    free = [i for i, n in enumerate(CONTINUOUS) if box[n][0] < box[n][1]]
    for i in free:
        name = CONTINUOUS[i]
        width = box[name][1] - box[name][0]
        step = 1e-5 * width
        xp, xm = x.copy(), x.copy()
        xp[i] += step
        xm[i] -= step
        up = problem.model({n: xp[j:j + 1] for j, n in enumerate(PARAMETERS)})[0]
        um = problem.model({n: xm[j:j + 1] for j, n in enumerate(PARAMETERS)})[0]
        columns.append(scale * (up - um) / (2 * step))
        names.append(name)
    u = problem.model({n: x[j:j + 1] for j, n in enumerate(PARAMETERS)})[0]
    if problem.fit_scale:
        columns.append(u)  # d model / d scale factor (relative scale)
        names.append("magnetization_scale")
    for d in range(problem.basis.shape[1]):
        columns.append(problem.basis[:, d])
        names.append("offset" if d == 0 else f"bias_{d}")
    jac = np.stack(columns, axis=1)
    m, p = jac.shape
    warns: list[str] = []
    dof = m - p
    sigma2 = cost / dof if dof > 0 else math.nan
    # rank and null space on the column-equilibrated Jacobian (columns have different units)
    norms = np.linalg.norm(jac, axis=0)
    norms = np.where(norms > 0, norms, 1.0)
    _, sv, vt = np.linalg.svd(jac / norms, full_matrices=False)
    null = vt[sv < sv[0] * 1e-7]
    undetermined = np.any(np.abs(null) > 0.1, axis=0) if null.size else np.zeros(p, dtype=bool)
    cov = sigma2 * np.linalg.pinv(jac.T @ jac, rcond=1e-14)
    se = np.sqrt(np.clip(np.diag(cov), 0.0, None))
    se[undetermined] = np.inf
    with np.errstate(invalid="ignore", divide="ignore"):
        corr = cov / np.outer(se, se)
    corr = np.where(np.isfinite(corr), corr, np.nan)
    # in the parameters' own SI units (the scale column is relative to the base scale)
    units = np.array([problem.base.material.magnetization_scale if n == "magnetization_scale"
                      else 1.0 for n in names])
    cov_si = np.asarray(cov * np.outer(units, units), dtype=np.float64)
    stderr = {name: float(se[k] * units[k]) for k, name in enumerate(names)}
    if dof <= 0:
        warns.append(f"{m} angles for {p} continuous parameters: no degrees of freedom left, so "
                     "no standard errors; record more angles")
    if null.size:
        involved = ", ".join(n for n, u in zip(names, undetermined, strict=True) if u)
        warns.append(f"the output is (numerically) unchanged along {len(null)} combination(s) of "
                     f"{involved}: these parameters are not determined by this tilt path and "
                     "their standard errors are infinite")
    for k, name in enumerate(names):
        if name in box:
            width = box[name][1] - box[name][0]
            if math.isfinite(se[k]) and se[k] > 0.25 * width:
                warns.append(f"{name} is not determined by the data (standard error "
                             f"{se[k]:.3g} vs a bound width of {width:.3g}); treat its value as "
                             "arbitrary")
    for i in range(p):
        for j in range(i + 1, p):
            if np.isfinite(corr[i, j]) and abs(corr[i, j]) > 0.99:
                warns.append(f"{names[i]} and {names[j]} are strongly correlated "
                             f"({corr[i, j]:+.3f}): the data determine a combination of them, "
                             "not each one")
    if box["y"][0] < 0.0 < box["y"][1] or box["y"][0] < -x[3] < box["y"][1]:
        warns.append("B_x is symmetric in y, so the sign of y is not determined (y and -y fit "
                     "equally well; the sign of the initial y is kept, + for 0)")
    warns.append("n_loops and dipoles_per_loop are modelling parameters chosen by the search; "
                 "they have no standard error")
    return tuple(names), stderr, corr, cov_si, tuple(warns)
