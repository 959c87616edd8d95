"""The physical model's result assembled at the optimum: the closed-form offsets and scale, the
covariance from the full weighted Jacobian (scaled by the reduced χ² when that exceeds 1), each
experiment's fit, and the warnings (:func:`joint_result`)."""

from __future__ import annotations

import math
import time
from collections.abc import Mapping

import numpy as np
from numpy.typing import NDArray

from magcilia._errors import MagciliaError
from magcilia.calibration.covariance import ParameterCovariance
from magcilia.calibration.diagnostics import (
    LOOSE_FRACTION,
    CalibrationWarning,
    at_bound,
    correlated,
    prior_only_warning,
    scale_remedy,
    undetermined_remedy,
    undetermined_warning,
)
from magcilia.calibration.experiment_fit import ExperimentFit
from magcilia.calibration.experiments import y_sign_determined
from magcilia.calibration.layout import PhysicalLayout
from magcilia.calibration.problem import LOAD_PARAMETER, Problem
from magcilia.calibration.result import CalibrationResult
from magcilia.calibration.uncertainty import equilibrated_pinv
from magcilia.device.setup import Setup

F64 = NDArray[np.float64]


def offset_labels(problem: Problem) -> list[str]:
    """The display labels of the problem's bias parameters (``offset``, ``offset_x``…, with
    ``[i]`` per experiment when there are several): keys of ``values``, printed, never parsed."""
    many = len(problem.measurements) > 1
    return [key.label(many) for key in problem.bias_keys]


def _uncertainty(problem: Problem, x: F64, scale: float, chi2: float
                 ) -> tuple[tuple[str, ...], F64, F64, tuple[CalibrationWarning, ...], bool]:
    """Names, covariance (SI), standard errors, warnings and whether the data's standard errors
    were scaled by the reduced χ², from the full weighted Jacobian (continuous parameters, the
    relative scale, the offsets).

    When the reduced χ² exceeds 1 the data's rows are down-weighted by its square root (their
    stated standard errors were too small), the priors' rows are not: a prior is a measurement
    with its own σ, so a direction that only a prior determines keeps that σ."""
    names = list(problem.names)
    cols = [np.zeros((problem.y.size, 0))]  # nothing nonlinear left free: no columns
    if x.size:
        h = 1e-5 * (problem.bounds[:, 1] - problem.bounds[:, 0])
        eye = np.eye(x.size) * h
        u2 = problem.model(np.concatenate([x + eye, x - eye]))
        cols = [scale * (u2[:x.size] - u2[x.size:]).T / (2 * h) * problem.w[:, None]]
    u = problem.model(x)[0]
    if problem.fit_scale:
        cols.append((u * problem.w)[:, None])
        names.append("magnetization_scale")
    cols.append(problem.basis * problem.w[:, None])
    names += offset_labels(problem)
    data_jac = np.concatenate(cols, axis=1)
    p = data_jac.shape[1]
    data_jac = np.where(np.isfinite(data_jac), data_jac, 0.0)
    dof = problem.y.size - p
    factor = max(1.0, chi2 / dof) if dof > 0 else 1.0
    prior_rows = np.zeros((len(problem.priors), p))
    prior_rows[np.arange(len(problem.priors)), problem.prior_index] = 1.0 / problem.prior_sigma
    jac = np.concatenate([data_jac / math.sqrt(factor), prior_rows], axis=0)
    warns: list[CalibrationWarning] = []
    cov, null, undetermined = equilibrated_pinv(jac)
    values = dict(zip(problem.names, x.tolist(), strict=True))
    null_jac, null_names, null_open = jac, names, undetermined
    if problem.table.coils and problem.base.cilium.profile is None and x.size:
        # the null-space test with the held tip radius free: the taper of an assumed tip must
        # not break the scale symmetry (a coil's uniform field bends the cilium alike at any
        # size: NOTES §8), so its direction is judged on the real body's symmetry
        null_jac, tip = _with_tip_column(problem, x, scale, jac, factor)
        _, null, null_open = equilibrated_pinv(null_jac)
        undetermined = null_open[:-1]
        null_names = [*names, "tip_radius"]
        values["tip_radius"] = tip
    units = np.array([problem.base.material.magnetization_scale
                      if n == "magnetization_scale" and problem.fit_scale else 1.0
                      for n in names])
    cov = cov * np.outer(units, units)
    se = np.sqrt(np.clip(np.diag(cov), 0.0, None))
    se[undetermined] = np.inf
    if not null.size and problem.priors:  # determined, but perhaps by the priors alone
        data_rows = null_jac[:problem.y.size]
        _, data_null, data_open = equilibrated_pinv(data_rows)
        if data_null.size:
            warns.append(prior_only_warning(data_rows, data_null, data_open, null_names, values,
                                            problem.base.sensor.depth, tuple(problem.priors)))
    if null.size:
        warns.append(undetermined_warning(
            null_jac, null, null_open, null_names, values, problem.base.sensor.depth,
            "these experiments", scale_remedy(
                frozenset(str(problem.measurements[e].load_kind) for e, *_ in problem.load_blocks),
                LOAD_PARAMETER in problem.names and LOAD_PARAMETER not in problem.priors),
            undetermined_remedy(y_sign_determined(problem.measurements))))
    if problem.table.coils and not null.size and x.size:
        loose = loose_combinations(cov[:x.size, :x.size], problem.bounds, problem.names)
        if loose is not None:
            warns.append(loose)
    if dof <= 0:
        warns.append(CalibrationWarning(
            "no_degrees_of_freedom", f"{problem.y.size} data values for {p} parameters: no "
            "degrees of freedom left; record more conditions"))
    with np.errstate(invalid="ignore", divide="ignore"):
        corr = cov / np.outer(se, se)
    warns += correlated(names, corr)
    return tuple(names), cov, se, tuple(warns), factor > 1.0


def loose_combinations(cov: F64, bounds: F64, names: tuple[str, ...]
                       ) -> CalibrationWarning | None:
    """The ``"undetermined"`` warning for combinations of the search parameters that the data
    leave open in practice though not numerically: the covariance ``cov`` (p, p), SI, in units of
    each parameter's bound width (``bounds`` (p, 2)) has eigen-directions whose standard error
    exceeds :data:`~magcilia.calibration.diagnostics.LOOSE_FRACTION` of the box (the Fisher
    information along them is too small for the bounds not to decide; e.g. coil fields along one
    axis only); None when there are none."""
    width = bounds[:, 1] - bounds[:, 0]
    scaled = cov / np.outer(width, width)
    if not np.isfinite(scaled).all():
        return None
    value, vector = np.linalg.eigh(0.5 * (scaled + scaled.T))
    open_ = value > LOOSE_FRACTION**2
    if not open_.any():
        return None
    involved = tuple(n for n, w in zip(names, np.abs(vector[:, open_]).max(axis=1), strict=True)
                     if w > 0.3)
    worst = float(np.sqrt(value.max()))
    return CalibrationWarning("undetermined", (
        f"the data leave {int(open_.sum())} combination(s) of {', '.join(involved)} "
        f"practically undetermined: along it the standard error is {worst:.2g} of the search "
        "bounds (the bounds, not the data, confine it); apply fields along more directions and "
        "at more magnitudes, or give a prior or another experiment (a load, a tilt) for them"),
        involved)


def _with_tip_column(problem: Problem, x: F64, scale: float, jac: F64, factor: float
                     ) -> tuple[F64, float]:
    """``jac`` (data rows then prior rows) with a last column for the held tip radius (its
    central difference, the data rows weighted as ``jac``'s, zero prior rows), and the tip radius,
    m."""
    tip = problem.base.cilium.tip_radius
    h = 1e-4 * tip
    cols = problem.params(x[None, :])
    u = problem.model({**{k: np.repeat(v, 2) for k, v in cols.items()},
                       "tip_radius": np.array([tip + h, tip - h])})
    column = np.zeros(jac.shape[0])
    column[:problem.y.size] = (scale * (u[0] - u[1]) / (2.0 * h) * problem.w
                               / math.sqrt(factor))
    column = np.where(np.isfinite(column), column, 0.0)
    return np.concatenate([jac, column[:, None]], axis=1), float(tip)


def _fitted_modulus(problem: Problem, initial: Setup, values: Mapping[str, float],
                    stderr: Mapping[str, float]) -> dict[str, float]:
    """The fitted setup's modulus σ: the fit's standard error where load data determined E (a
    later read-out takes it as measured), else the initial setup's relative σ carried over to
    the fitted value (held or undetermined: still an assumption); nothing without load data."""
    if LOAD_PARAMETER not in problem.all_names:
        return {}
    se = stderr.get(LOAD_PARAMETER, math.nan)
    if math.isfinite(se) and se > 0.0:
        return {"youngs_modulus_sigma": se}
    return {"youngs_modulus_sigma": initial.youngs_modulus_uncertainty * values[LOAD_PARAMETER]}


def joint_result(problem: Problem, layout: PhysicalLayout, initial: Setup,
                 box: dict[str, tuple[float, float]], x: F64, y_free: bool,
                 t0: float) -> CalibrationResult:
    """The :class:`~magcilia.calibration.result.CalibrationResult` (``model="physical"``) of the
    physical model's ``problem`` at its optimum ``x`` (the search vector, SI): values with the
    closed-form offsets and scale, the covariance, each experiment's fit and the warnings."""
    u = problem.model(x)
    if not np.isfinite(u).all():
        raise MagciliaError("the search found no parameters within the bounds whose model is "
                            "finite at every condition (the sensing element on a dipole); change "
                            "the bounds or the initial setup")
    r, a = problem.linear(u)
    scale = float(a[0])
    prior_r = problem.residuals(x)[0, problem.y.size:]
    chi2_data = float(r[0] @ r[0])
    chi2 = chi2_data + float(prior_r @ prior_r)
    offsets = problem.offsets(u[0], scale)
    values = {n: float(x[i]) if n in problem.names else float(initial.params()[n])
              for i, n in enumerate(problem.names)}
    held_values = {**initial.params(), LOAD_PARAMETER: initial.youngs_modulus,
                   "sensitivity": initial.sensor.sensitivity}
    values.update({n: float(held_values[n]) for n in problem.all_names if n not in values})
    fitted_scale = (values["magnetization_scale"] if "magnetization_scale" in problem.all_names
                    else initial.material.magnetization_scale * scale)
    names, cov, se, found, inflated = _uncertainty(problem, x, scale, chi2_data)
    labels = offset_labels(problem)
    for k, name in enumerate(labels):
        values[name] = float(offsets[k])
    if problem.fit_scale:
        values["magnetization_scale"] = fitted_scale
    stderr = {n: float(s) for n, s in zip(names, se, strict=True)}
    with np.errstate(invalid="ignore", divide="ignore"):
        corr = cov / np.outer(se, se)
    corr = np.where(np.isfinite(corr), corr, np.nan)
    dof = problem.y.size - len(names)
    output_offsets = [offsets[g] for g, key in enumerate(problem.bias_keys) if key.axis is None]
    fitted_setup = initial.replace(
        **{n: values[n] for n in problem.all_names if n != "magnetization_scale"},
        **_fitted_modulus(problem, initial, values, stderr), n_loops=layout.n_loops,
        dipoles_per_loop=layout.dipoles_per_loop, ring=layout.ring,
        magnetization_scale=fitted_scale,
        offset=float(output_offsets[0]) if len(output_offsets) == 1 else initial.sensor.offset)
    fits = []
    model_full = scale * u[0] + problem.basis @ offsets
    for e_i, e in enumerate(problem.measurements):
        rows = problem.experiment_rows[e_i]
        measured, fitted = problem.y[rows], model_full[rows]
        groups = [g for g, key in enumerate(problem.bias_keys) if key.experiment == e_i]
        if e.fields is not None:
            measured = measured.reshape(3, -1).T
            fitted = fitted.reshape(3, -1).T
        weighted = (problem.y[rows] - model_full[rows]) * problem.w[rows]
        fits.append(ExperimentFit(
            source=str(e.source), observable=e.observable, angles=np.asarray(e.angles),
            azimuths=np.asarray(e.azimuths), measured=measured, fitted=fitted,
            residuals=measured - fitted, offsets=np.asarray(offsets[groups]),
            rms=float(np.sqrt(np.mean((problem.y[rows] - model_full[rows]) ** 2))),
            chi2=float(weighted @ weighted), values=int(problem.y[rows].size),
            load_kind=e.load_kind,
            loads=None if e.loads is None else np.asarray(e.loads),
            actuation=None if e.actuation is None else np.asarray(e.actuation),
            sem=np.asarray(e.sem if e.field_sem is None else e.field_sem, dtype=np.float64)))
    notes: list[CalibrationWarning] = list(at_bound(
        {n: values[n] for n in problem.names}, {n: box[n] for n in problem.names},
        frozenset(n for w in found if w.kind == "undetermined" for n in w.parameters)))
    notes += list(found)
    if y_free and "y" in problem.names:
        notes.append(CalibrationWarning(
            "y_sign", "B_x along tilts toward azimuth 0 or π is symmetric in y, so the sign of y "
            "is not determined (the sign of the initial y is kept, + for 0); a tilt toward "
            "another azimuth or 3-axis field data determine it", ("y",)))
    lay = layout
    if math.isfinite(lay.error) and lay.error > lay.tolerance:
        notes.append(CalibrationWarning(
            "layout", f"the physical layout n={lay.n_loops}, k={lay.dipoles_per_loop} is "
            f"{lay.error:.2g} (relative) from the exact body at the initial setup, above the "
            f"tolerance {lay.tolerance:g} (the sensing element close to the base converges "
            "slowly): start from a setup near the real placement or give layout=(n, k)"))
    if inflated:
        notes.append(CalibrationWarning(
            "chi2", f"reduced chi-square {chi2_data / max(dof, 1):.3g} "
                    "> 1: the data's standard errors are scaled up by its square root (the "
                    "noise is larger than stated, or the model lacks something); the priors "
                    "keep their own"))
    return CalibrationResult(
        setup=fitted_setup, initial=initial, model="physical", layout_error=layout.error,
        chi2=chi2, dof=dof, keys=dict(zip(labels, problem.bias_keys, strict=True)),
        values=values, uncertainty=ParameterCovariance(names, stderr, corr, cov),
        experiments=tuple(fits), priors=dict(problem.priors),
        warnings=tuple(w.message for w in notes), diagnostics=tuple(notes),
        bounds={n: box[n] for n in problem.all_names},
        fixed={n: values[n] for n in problem.all_names if box[n][0] == box[n][1]},
        evaluations=problem.evaluations, elapsed=time.perf_counter() - t0,
    )
