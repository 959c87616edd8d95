"""Uncertainty of a calibration: standard errors, correlations and the covariance from the
Jacobian at the optimum, and plain-language warnings about what the data do not determine
(:mod:`magcilia.calibration.diagnostics`)."""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import NDArray

from magcilia.calibration.diagnostics import (
    PAPER_SCALE_REMEDY,
    CalibrationWarning,
    correlated,
    stderr_checks,
    undetermined_warning,
)
from magcilia.calibration.problem import CONTINUOUS, INDEX, INTEGER, Problem, named

F64 = NDArray[np.float64]

#: singular values of the column-equilibrated Jacobian below this fraction of the largest mark
#: combinations the data do not determine (well above the ~1e-10 relative error of its
#: finite-difference columns)
RANK_TOLERANCE = 1e-7


def equilibrated_pinv(jac: F64) -> tuple[F64, F64, NDArray[np.bool_]]:
    """(JᵀJ)⁺ of a Jacobian (m, p) whose columns have different units, through the SVD of the
    column-equilibrated matrix (each column divided by its norm): rank, null space and covariance
    from one decomposition, so a small column (d/dy near y = 0, where B_x is even in y) is judged
    by its direction, not its size, and is never dropped unseen.

    Returns
    -------
    pinv : ndarray, shape (p, p)
        (JᵀJ)⁺ in the columns' own units (multiply by σ² for a covariance).
    null : ndarray, shape (r, p)
        The combinations (of the equilibrated columns) the data do not determine: singular
        values below :data:`RANK_TOLERANCE` of the largest.
    undetermined : ndarray of bool, shape (p,)
        Parameters taking part in a null combination (weight > 0.1).
    """
    slopes = np.linalg.norm(jac, axis=0)
    norms = np.where(slopes > 0, slopes, 1.0)
    _, sv, vt = np.linalg.svd(jac / norms, full_matrices=False)
    kept = sv >= sv[0] * RANK_TOLERANCE
    null = vt[~kept]
    undetermined = (np.any(np.abs(null) > 0.1, axis=0) if null.size
                    else np.zeros(jac.shape[1], dtype=bool))
    pinv = ((vt[kept].T / sv[kept] ** 2) @ vt[kept]) / np.outer(norms, norms)
    return np.asarray(pinv, dtype=np.float64), null, undetermined


def uncertainty(problem: Problem, x: F64, scale: float, cost: float,
                 box: dict[str, tuple[float, float]], values: dict[str, float] | None = None
                 ) -> tuple[tuple[str, ...], dict[str, float], F64, F64,
                            tuple[CalibrationWarning, ...]]:
    """Standard errors and correlations from the Jacobian of the full model at the optimum, and
    the warnings about them (see :mod:`magcilia.calibration.diagnostics`); ``values`` (SI) are
    the fitted values the implausible-standard-error check compares with (optional)."""
    columns: list[F64] = []
    names: list[str] = []
    for name in (n for n in CONTINUOUS if box[n][0] < box[n][1]):
        step = 1e-5 * (box[name][1] - box[name][0])
        xp, xm = x.copy(), x.copy()
        xp[INDEX[name]] += step
        xm[INDEX[name]] -= step
        up, um = problem.model(named(xp))[0], problem.model(named(xm))[0]
        columns.append(scale * (up - um) / (2 * step))
        names.append(name)
    u = problem.model(named(x))[0]
    if problem.fit_scale:
        columns.append(u)  # d model / d scale factor (relative scale)
        names.append("magnetization_scale")
    for d in range(problem.basis.shape[1]):
        columns.append(problem.basis[:, d])
        names.append("offset" if d == 0 else f"bias_{d}")
    jac = np.stack(columns, axis=1)
    m, p = jac.shape
    warns: list[CalibrationWarning] = []
    broken = [k for k in range(p) if not np.isfinite(jac[:, k]).all()]
    if broken:  # a finite-difference step put the element on a dipole: no slope there
        jac[:, broken] = 0.0
        warns.append(CalibrationWarning(
            "model_not_finite", "the model is not finite next to the optimum along "
            + ", ".join(names[k] for k in broken) + ": their standard errors are undetermined",
            tuple(names[k] for k in broken)))
    dof = m - p
    sigma2 = cost / dof if dof > 0 else math.nan
    pinv, null, undetermined = equilibrated_pinv(jac)
    slopes = np.linalg.norm(jac, axis=0)
    cov = sigma2 * pinv
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
        warns.append(CalibrationWarning(
            "no_degrees_of_freedom",
            f"{m} angles for {p} continuous parameters: no degrees of freedom left, so no "
            "standard errors; record more angles"))
    if null.size:
        warns.append(undetermined_warning(
            jac, null, undetermined, names, {n: float(x[INDEX[n]]) for n in CONTINUOUS},
            problem.base.sensor.depth, "this tilt path", PAPER_SCALE_REMEDY,
            "this tilt path cannot: hold a measured value (--fix NAME=VALUE; API fixed=...), "
            "or calibrate with --model physical and a tilt toward another azimuth or 3-axis "
            "field data"))
    if values is not None and dof > 0:
        warns += stderr_checks(tuple(names), values, se * units, slopes / units,
                               math.sqrt(sigma2), math.sqrt(cost / m),
                               float(np.max(np.abs(problem.y))), box)
    warns += correlated(names, corr)
    if box["y"][0] < 0.0 < box["y"][1] or box["y"][0] < -x[INDEX["y"]] < box["y"][1]:
        warns.append(CalibrationWarning(
            "y_sign", "B_x is symmetric in y, so the sign of y is not determined (y and -y fit "
            "equally well; the sign of the initial y is kept, + for 0)", ("y",)))
    searched = tuple(n for n in INTEGER if box[n][0] < box[n][1])
    if searched:
        are = ("are modelling parameters chosen by the search; they have" if len(searched) > 1
               else "is a modelling parameter chosen by the search; it has")
        warns.append(CalibrationWarning(
            "integer_parameters", f"{' and '.join(searched)} {are} no standard error", searched))
    return tuple(names), stderr, corr, cov_si, tuple(warns)
