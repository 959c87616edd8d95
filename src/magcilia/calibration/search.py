"""Calibration: fit the model's parameters to a field-vs-tilt recording (the paper's Sec. III.B).

The paper fits height, base radius, position (x, y, z), n and k with MATLAB's genetic algorithm,
minimising the sum of squared errors (its eq. 6, with the square the text describes). magcilia:

1. searches globally with many local Levenberg–Marquardt fits from a stratified sample of the
   bounds, narrowed by successive halving, then refits every (n, k) from the best few
   (:mod:`magcilia.calibration.multistart`); all candidates of a step are evaluated in one
   vectorised, compiled model call (:func:`magcilia.model.tilt_output_batch`);
2. solves the parameters that enter the output *linearly* in closed form inside the objective:
   the output offset (or a polynomial bias in the angle) and, optionally, the magnetization scale;
3. polishes the best candidate with ``least_squares`` (:func:`magcilia.fitting.polish`),
   optionally repeating the whole search from fresh samples (``restarts``);
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

import logging
import math
import time
from collections.abc import Callable, Iterable, Mapping, Sequence
from dataclasses import replace

import numpy as np
from numpy.typing import NDArray

from magcilia import _validate as v
from magcilia._errors import MagciliaError
from magcilia.calibration.ambiguity import alternatives, ambiguity_warning, mirror_starts
from magcilia.calibration.diagnostics import (
    LENGTHS,
    CalibrationWarning,
    at_bound,
    bias_absorption,
    sensor_field,
)
from magcilia.calibration.joint import STARTS, calibrate_joint
from magcilia.calibration.layout import PhysicalLayout
from magcilia.calibration.multistart import MAXITER, Box, local_fits, search
from magcilia.calibration.parameters import ParameterKey
from magcilia.calibration.problem import (
    BIASES,
    DEFAULT_BOUNDS,
    INDEX,
    INTEGER,
    NONFINITE_COST,
    PARAMETERS,
    Problem,
    named,
)
from magcilia.calibration.reload import path_fit
from magcilia.calibration.result import CalibrationResult, ParameterCovariance
from magcilia.calibration.temperature import with_temperature
from magcilia.calibration.uncertainty import uncertainty
from magcilia.device.parameters import PARAMETERS as REGISTRY
from magcilia.device.parameters import check_dipoles, check_ranges
from magcilia.device.setup import Setup
from magcilia.fitting import polish
from magcilia.io.recordings import Measurement

logger = logging.getLogger(__name__)

F64 = NDArray[np.float64]

#: most dipoles n·k of one candidate the search may try (the product of the n_loops and
#: dipoles_per_loop upper bounds): a calibration evaluates ~10^5 candidates and its time grows with
#: n·k and with the number of (n, k) combinations (about 1.5 s per restart for n, k in 1..30, 33
#: angles, one core; 0.08 s for the default 1..10).
#: A longer search is legitimate: raise it with
#: ``magcilia.calibration.search.MAX_FIT_DIPOLES = ...`` before calling :func:`calibrate`.
MAX_FIT_DIPOLES = 1000
#: most independent global searches of one calibration (``restarts``): each is a whole search
#: (about 0.07 s for the bundled example's 33 angles with 256 starts on one core), so 1000 take
#: about a minute; one search already finds the best fit in more than 99 % of cases
MAX_RESTARTS = 1000
#: most local fits started by one global search (``starts``): they run as one batch
MAX_STARTS = 10_000
#: most starts × angles of one search: the batch's memory grows with both (measured, 10,000
#: starts: +0.1 GB for the bundled example's 33 angles, +2.5 GB and 44 s for 1,000 angles)
MAX_START_ANGLES = 10_000_000


def search_effort(restarts: int, starts: int, angles: int | None = None) -> tuple[int, int]:
    """``restarts`` (1 … :data:`MAX_RESTARTS`) and ``starts`` (1 … :data:`MAX_STARTS`, and
    at most :data:`MAX_START_ANGLES` / ``angles`` for a recording of that many angles),
    checked (one-line errors naming the limit)."""
    restarts = v.integer("restarts", restarts, 1)
    if restarts > MAX_RESTARTS:
        raise v.fail("restarts", restarts, f"at most {MAX_RESTARTS} (MAX_RESTARTS: each restart "
                                           "repeats the whole global search; one usually finds "
                                           "the best fit)")
    starts = v.integer("starts", starts, 1)
    if starts > MAX_STARTS:
        raise v.fail("starts", starts, f"at most {MAX_STARTS} (MAX_STARTS: the starts of one "
                                       "search run as one batch in memory); use restarts for "
                                       "a longer search")
    if angles is not None and starts * angles > MAX_START_ANGLES:
        raise v.fail("starts", starts, f"at most {MAX_START_ANGLES // angles} for {angles} "
                                       "angles (MAX_START_ANGLES: starts × angles of one search "
                                       "held in memory); use restarts for a longer search")
    return restarts, starts


#: local fits started by one global search of the paper's model (``starts``'s default)
STARTS_PAPER = 256

#: the calibration models: the paper's (n, k searched) and the physical (n, k converged)
MODELS = ("paper", "physical")


def _check_data(data: Measurement) -> None:
    """Finite angles and outputs, or a one-line error naming the data, before any search."""
    data.require_single_path("calibrate(..., model='paper')",
                             "use calibrate(..., model='physical')")
    for what, values in (("voltage_V", data.volts), ("angle_rad", data.angles)):
        arr = np.asarray(values, dtype=np.float64)
        bad = ~np.isfinite(arr)
        if bad.any():
            i = int(np.argmax(bad))
            raise MagciliaError(
                f"{v.printable(str(data.source))}: {what} of angle {i + 1} of {arr.size} is "
                f"{arr[i]}; calibration needs finite data: clean the recording or read it with "
                "nan_policy='omit' (CLI: --nan-policy omit)"
            )


def _check_bounds(bounds: Mapping[str, tuple[float, float]] | None,
                  initial: Setup) -> dict[str, tuple[float, float]]:
    merged = v.intervals("bounds", bounds, DEFAULT_BOUNDS)
    check_ranges(merged)
    check_dipoles(merged["n_loops"][1], merged["dipoles_per_loop"][1],
                  "bounds n_loops x dipoles_per_loop (upper ends)", limit=MAX_FIT_DIPOLES,
                  hint="narrow the n_loops or dipoles_per_loop bounds (each of the search's "
                       "~10^5 candidates costs n x k dipoles; see MAX_FIT_DIPOLES)")
    init = initial.params()
    for name in PARAMETERS:
        lo, hi = merged[name]
        tol = 1e-9 * max(abs(lo), abs(hi), 1e-9)  # unit conversions (mm -> m) round off
        if not lo - tol <= init[name] <= hi + tol:
            p = REGISTRY[name]
            raise v.fail(f"initial {name}", p.text(init[name], 6),
                         f"inside its bounds {p.text(lo, 6)}…{p.text(hi, 6)} "
                         "(move the initial value or widen the bounds)")
    return merged


def _check_fixed(fixed: Mapping[str, float] | Iterable[str] | str | None,
                 bounds: Mapping[str, tuple[float, float]] | None,
                 initial: Setup) -> dict[str, float]:
    """The held parameters and their values (SI), checked: known fitted names, values in their
    parameters' domains, no name both held and bounded."""
    if fixed is None:
        return {}
    if isinstance(fixed, str):
        fixed = (fixed,)
    if isinstance(fixed, Mapping):
        items = list(fixed.items())
    else:
        try:
            names = list(fixed)
        except TypeError:
            raise v.fail("fixed", fixed, "a mapping of parameter names to SI values, or a "
                                         "sequence of names to hold at the initial setup's "
                                         "values") from None
        init = initial.params()
        items = [(n, init[n]) if n in init else (n, math.nan) for n in names]
    out: dict[str, float] = {}
    for name, value in items:
        if name not in PARAMETERS:
            hint = (" (magnetization_scale is held unless fit_scale=True; the offset is "
                    "bias='none' with the setup's offset 0)"
                    if name in ("magnetization_scale", "offset") else "")
            raise v.fail("fixed key", name, "one of " + ", ".join(PARAMETERS) + hint)
        if bounds is not None and name in bounds:
            raise MagciliaError(f"{name} is both fixed and given bounds; give one of them "
                                "(fixed holds it, bounds search it)")
        out[name] = REGISTRY[name].check(value, f"fixed[{name!r}]")
    return out


def calibrate(
    data: Measurement | Sequence[Measurement],
    initial: Setup | None = None,
    bounds: Mapping[str, tuple[float, float]] | None = None,
    *,
    rng: int | np.random.Generator | None = None,
    bias: str = "offset",
    bias_degree: int = 0,
    fit_scale: bool = False,
    restarts: int = 1,
    starts: int | None = None,
    progress: Callable[[int, int], None] | None = None,
    fixed: Mapping[str, float] | Iterable[str] | None = None,
    model: str = "paper",
    priors: Mapping[str, tuple[float, float]] | None = None,
    layout: PhysicalLayout | tuple[int, int] | None = None,
    posterior: bool | int = False,
) -> CalibrationResult:
    """Fit height, base radius, x, y, z, n and k (plus the bias and optionally the magnetization
    scale) to a recording.

    Parameters
    ----------
    data : Measurement
        Per-angle mean outputs (see :func:`magcilia.read_measurements`); with
        ``model="physical"`` several (experiment objects and priors that add go to
        :func:`~magcilia.calibration.joint.calibrate_joint`).
    initial : Setup, optional
        Starting setup; supplies everything that is not fitted (material, sensor, ring rule).
        Default: Table I's initial values (``Setup.paper_initial()``).
    bounds : mapping of str to (low, high), optional
        Search bounds in SI (m; n and k as whole numbers); missing keys take
        :data:`DEFAULT_BOUNDS`. The initial values must lie inside.
    rng : int, Generator or None
        Seed for the global search; the same seed gives the same result, None (default)
        draws fresh entropy.
    bias : {"offset", "polynomial", "none"}
        How the DC bias is removed (see the module docstring).
    bias_degree : int
        Degree of the polynomial bias (with ``bias="polynomial"``).
    fit_scale : bool
        Also fit the magnetization scale (solved in closed form; ≥ 0).
    restarts : int
        Independent global searches (each from its own sample of starts); the best polished
        result is kept. One finds the best fit of a 33-angle recording in more than 99 % of
        cases; more make a miss rarer still, at proportional cost.
    starts : int, optional
        Local fits started by each global search (see :mod:`magcilia.calibration.multistart`):
        default 256 for the paper's model, 64 for the physical
        (:data:`~magcilia.calibration.joint.STARTS`; five continuous parameters only).
    progress : callable(done, total), optional
        Called after each restart (the CLI draws a progress bar with it).
    fixed : mapping of str to float, or sequence of str, optional
        Parameters to hold instead of fitting (lmfit's ``vary=False``, iminuit's ``fixed``):
        a mapping of names to values (SI: m; n and k whole numbers), e.g.
        ``{"height": 3.1e-3}``, or names to hold at the ``initial`` setup's values, e.g.
        ``("height", "base_radius")``. Names among :data:`PARAMETERS`; a held parameter takes
        no bounds (give one or the other), is not searched, has no standard error and is listed
        in ``result.fixed``. Equal bounds ``(v, v)`` hold a parameter too.

    model : {"paper", "physical"}
        ``"paper"`` (default): the paper's model, n and k searched with the geometry, one output
        recording tilted toward azimuth 0. ``"physical"``: n and k held at a converged layout
        (:func:`~magcilia.calibration.joint.converged_layout`), so that height and base radius
        are the hair's real dimensions; ``data`` may then be several experiments (any azimuth,
        output or 3-axis field) fitted together
        (:func:`~magcilia.calibration.joint.calibrate_joint`, which takes ``starts`` and
        ``fit_scale``; ``bias``, ``restarts`` and ``progress`` are the paper mode's).
    priors : mapping of str to (value, sigma), optional
        Gaussian priors from manual measurements, SI, e.g. ``{"height": (3.0e-3, 0.2e-3)}``
        (``model="physical"``: in the paper's model height and base radius are model
        parameters, not the hair's dimensions).
    layout : PhysicalLayout or (n, k), optional
        The physical model's layout (default: converged at the initial setup).
    posterior : bool or int
        ``model="physical"``: also sample the posterior of the geometry (``result.posterior``,
        1000 effective samples, or this many; see
        :func:`~magcilia.calibration.joint.calibrate_joint`).

    Returns
    -------
    CalibrationResult
        One result class for both models (its ``model`` says which). Its ``warnings`` (and
        ``diagnostics``, with a ``kind`` each) say what the data do not determine: parameters at
        a bound, a bias that absorbed the signal, implausible standard errors, undetermined
        combinations (see :mod:`magcilia.calibration.diagnostics`).

    Examples
    --------
    >>> from magcilia.io import example_path
    >>> from magcilia import read_measurements
    >>> data = read_measurements(example_path())
    >>> fit = calibrate(data, rng=0, starts=32, fixed={"height": 3.2613e-3, "n_loops": 2})
    >>> fit.values["height"], fit.values["n_loops"], fit.fixed
    (0.0032613, 2.0, {'height': 0.0032613, 'n_loops': 2.0})
    """
    t0 = time.perf_counter()
    v.choice("model", model, MODELS)
    if model == "physical":
        if bias != "offset":
            raise v.fail("bias", bias, "'offset' with model='physical' (each experiment has its "
                                       "own constant offsets)")
        if fixed is not None and not isinstance(fixed, Mapping):
            init = (initial or Setup.paper_initial()).params()
            names = [fixed] if isinstance(fixed, str) else list(fixed)
            fixed = {n: init.get(n, math.nan) for n in names}
        search_effort(restarts, STARTS if starts is None else starts)
        result = calibrate_joint(data, initial, bounds, rng=rng, priors=priors,
                                 fit_scale=fit_scale, fixed=fixed, layout=layout,
                                 starts=STARTS if starts is None else starts,
                                 posterior=posterior)
        if progress is not None:
            progress(1, 1)
        return with_temperature(_with_sensor_field(result), data)
    if posterior is not False:
        raise v.fail("posterior", posterior, "given with model='physical' (the posterior of the "
                                             "hair's geometry; the paper's model searches n, k)")
    if priors:
        raise v.fail("priors", ", ".join(priors), "given with model='physical' (in the paper's "
                                                  "model height and base radius are fitted model "
                                                  "parameters, not the hair's dimensions)")
    if layout is not None:
        raise v.fail("layout", layout, "given with model='physical' only (the paper's model "
                                       "searches n and k)")
    if not isinstance(data, Measurement) and isinstance(data, Sequence) and len(data) == 1:
        data = data[0]
    if not isinstance(data, Measurement) and isinstance(data, Sequence):
        raise v.fail("data", f"{len(data)} experiments", "one Measurement with model='paper' "
                                                         "(use model='physical' to fit several)")
    if not isinstance(data, Measurement):
        raise v.fail("data", type(data).__name__, "a magcilia Measurement (use read_measurements)")
    _check_data(data)
    initial = initial if initial is not None else Setup.paper_initial()
    v.choice("bias", bias, BIASES)
    degree = v.integer("bias_degree", bias_degree, 0)
    restarts, starts = search_effort(restarts, STARTS_PAPER if starts is None else starts,
                                     len(data))
    n_lin = (0 if bias == "none" else (1 if bias == "offset" else degree + 1)) + int(fit_scale)
    if len(data) <= n_lin + 1:
        raise MagciliaError(
            f"{data.source}: {len(data)} angles cannot determine {n_lin} linear parameters and the "
            "geometry; record more angles"
        )
    held = _check_fixed(fixed, bounds, initial)
    if held:
        initial = initial.replace(**held)
        bounds = {**(bounds or {}), **{n: (val, val) for n, val in held.items()}}
    box = _check_bounds(bounds, initial)
    problem = Problem.paper(data, initial, bias, degree, fit_scale, box)
    lower = np.array([box[n][0] for n in PARAMETERS])
    upper = np.array([box[n][1] for n in PARAMETERS])
    integrality = np.array([n in INTEGER for n in PARAMETERS])
    space = Box(lower, upper, integrality)
    x_init = np.clip([initial.params()[n] for n in PARAMETERS], lower, upper)
    gen = np.random.default_rng(rng)
    candidates: list[tuple[float, F64]] = []
    logger.info("calibrating %s: %d angles, %d free parameters, %d restart(s) of %d starts",
                data.source, len(data), int(space.free.sum()), restarts, starts)
    for i in range(restarts):
        x_start = search(problem, space, x_init, gen, starts) if space.free.any() else x_init
        candidates.append(_polish(problem, x_start, lower, upper, integrality))
        logger.info("restart %d/%d: cost %.6g V^2", i + 1, restarts, candidates[-1][0])
        if progress is not None:
            progress(i + 1, restarts)
    restart_costs = tuple(c for c, _ in candidates)
    # the mirrored basin (x -> -x) of the best, which a search on one side never looks at:
    # local fits to convergence, polished only if one fits better than the best
    _, x_best = min(candidates, key=lambda c: c[0])
    mirrors = mirror_starts(x_best, PARAMETERS, np.stack([lower, upper], axis=1), y_sign=False)
    if mirrors.size:
        x_mirror, cost_mirror = local_fits(problem, space, mirrors, MAXITER)
        candidates += [(float(c), xm) for c, xm in zip(cost_mirror, x_mirror, strict=True)
                       if np.isfinite(c)]
    cost_best, x_best = min(candidates, key=lambda c: c[0])
    if not any(x_best is x for _, x in candidates[:restarts]):
        candidates.append(_polish(problem, x_best, lower, upper, integrality))
        cost_best, x_best = min(candidates, key=lambda c: c[0])
    x_best = _y_sign_of(x_best, initial.position[1], box["y"])
    logger.info("best cost %.6g V^2 after %.3g s", cost_best, time.perf_counter() - t0)
    return with_temperature(_with_alternatives(_result(
        problem, initial, data, box, x_best, bias, t0, restart_costs), x_best, cost_best,
        candidates), data)


def _with_alternatives(result: CalibrationResult, x: F64, cost: float,
                       candidates: Sequence[tuple[float, F64]]) -> CalibrationResult:
    """The result with an ``"ambiguous"`` warning when another polished optimum (a restart's,
    the mirrored basin's) fits as well: costs in χ² units of the residual variance
    (cost / degrees of freedom), the y sign folded (the ``"y_sign"`` warning says it)."""
    dof = len(result.path) - len(result.stderr)
    if dof <= 0 or not cost > 0.0:
        return result
    scale = cost / dof
    points = np.array([c[1] for c in candidates])
    chi2 = np.array([c[0] for c in candidates]) / scale
    free = all(result.bounds[n][0] < result.bounds[n][1] for n in LENGTHS)
    found = alternatives(x, cost / scale, points, chi2, PARAMETERS, result.stderr, fold_y=True,
                         depth=result.initial.sensor.depth if free else None)
    note = ambiguity_warning(found, cost / scale, PARAMETERS, (
        "a measured x held with --fix x=VALUE, or --model physical with a tilt toward another "
        "azimuth or 3-axis field data, would decide"))
    if note is None:
        return result
    return replace(result, warnings=(*result.warnings, note.message),
                   diagnostics=(*result.diagnostics, note))


def _with_sensor_field(result: CalibrationResult) -> CalibrationResult:
    """The joint result with a ``"sensor_field"`` warning when the fitted placement overloads the
    element in its tilt experiments (load experiments bend the cilium: their poses are not checked
    here)."""
    tilts = [e for e in result.experiments if e.load_kind is None]
    if not tilts:
        return result
    angles = np.concatenate([e.angles for e in tilts])
    azimuths = np.concatenate([e.azimuths for e in tilts])
    note = sensor_field(result.setup, angles, "fitted", azimuths)
    if note is None:
        return result
    return replace(result, warnings=(*result.warnings, note.message),
                   diagnostics=(*result.diagnostics, note))


def _y_sign_of(x: F64, y_initial: float, y_bounds: tuple[float, float]) -> F64:
    """B_x is even in y (mirror symmetry about the x-z plane), so y and -y fit exactly equally
    well: keep the sign of the initial y (positive for 0) when -y is within the bounds."""
    y = float(x[INDEX["y"]])
    wanted = -1.0 if y_initial < 0.0 else 1.0
    if y * wanted < 0.0 and y_bounds[0] <= -y <= y_bounds[1]:
        x = x.copy()
        x[INDEX["y"]] = -y
    return x


def _polish(problem: Problem, x: F64, lower: F64, upper: F64,
            integrality: NDArray[np.bool_]) -> tuple[float, F64]:
    """Local least-squares polish (:func:`magcilia.fitting.polish`) of the continuous
    parameters, the integers (n, k) held at their rounded values: its cost (V², at most
    :data:`NONFINITE_COST`) and point (p,)."""
    x = np.array(x, dtype=np.float64)
    x[integrality] = np.rint(x[integrality])

    def resid(xs: F64, _: NDArray[np.intp]) -> object:
        # a non-finite model (the element on a dipole) is a bad point (the problem's penalty
        # rows), not a crash; with the analytic Jacobian in the same pass
        if problem.analytic:
            return problem.residuals_jacobian(xs)
        return problem.residuals(named(xs.T))

    fit = polish(resid, x, np.where(integrality, x, lower), np.where(integrality, x, upper),
                 max_nfev=400, penalty=NONFINITE_COST, jacobian=problem.analytic or None)
    return min(float(fit.cost[0]), NONFINITE_COST), fit.x[0]


def _result(problem: Problem, initial: Setup, data: Measurement,
            box: dict[str, tuple[float, float]], x: F64, bias: str, t0: float,
            restart_costs: tuple[float, ...]) -> CalibrationResult:
    u = problem.model(named(x))
    if not np.isfinite(u).all():
        raise MagciliaError(
            f"{v.printable(str(data.source))}: the search found no parameters within the bounds "
            "whose model output is finite at every measured angle (the sensing element sits on "
            "a dipole of the model); change the bounds or the initial setup"
        )
    _, a = problem.linear(u)
    scale = float(a[0])
    coef = problem.bias_coefficients(u[0], scale)
    offset = float(coef[0]) if coef.size else 0.0
    values: dict[str, float] = {
        n: float(round(x[INDEX[n]]) if n in INTEGER else x[INDEX[n]]) for n in PARAMETERS}
    fitted_scale = initial.material.magnetization_scale * scale
    for name, value in (("magnetization_scale", fitted_scale), ("offset", offset)):
        if not REGISTRY[name].within(value):
            raise MagciliaError(
                f"{v.printable(str(data.source))}: the fitted {name} would be {value:.6g}, "
                f"beyond its limits ({REGISTRY[name].limits}): the data do not look like this "
                "sensor's output; check the units (V), the gain and the recording"
            )
    fitted_setup = initial.replace(
        **{n: round(val) if n in INTEGER else val for n, val in values.items()},
        magnetization_scale=fitted_scale, offset=offset,
        # the paper's model fitted as the paper does: its layout by name, used as is
        **({"layout": "paper"} if initial.ring == "mean" else {}),
    )
    model_full = scale * u[0] + (problem.basis @ coef if coef.size else 0.0)
    residuals = problem.y - model_full
    cost = float(residuals @ residuals)
    values["magnetization_scale"] = fitted_setup.material.magnetization_scale
    values["offset"] = offset
    names, stderr, corr, cov, found = uncertainty(problem, x, scale, cost, box, values)
    undetermined = frozenset(n for w in found if w.kind == "undetermined" for n in w.parameters)
    notes: list[CalibrationWarning] = at_bound(values, box, undetermined)
    if problem.fit_scale and scale == 0.0:
        notes.append(CalibrationWarning(
            "at_bound", "magnetization_scale = 0 (its lower limit): the model's signal does not "
            "match the data in any proportion; check the sign of the gain and the recording",
            ("magnetization_scale",)))
    absorbed = bias_absorption(data.angles, coef, scale * u[0]) if bias == "polynomial" else None
    notes += [absorbed] if absorbed is not None else []
    field_note = sensor_field(fitted_setup, data.angles, "fitted")
    notes += [field_note] if field_note is not None else []
    diagnostics = (*notes, *found)
    return CalibrationResult(
        setup=fitted_setup, initial=initial, cost=cost, rms=math.sqrt(cost / len(data)),
        residuals=residuals, data=data, values=values,
        uncertainty=ParameterCovariance(names, stderr, corr, cov), bias_coefficients=coef,
        bias=bias, warnings=tuple(w.message for w in diagnostics), bounds=box,
        evaluations=problem.evaluations, elapsed=time.perf_counter() - t0,
        restart_costs=restart_costs, diagnostics=diagnostics,
        fixed={n: values[n] for n in PARAMETERS if box[n][0] == box[n][1]},
        experiments=(path_fit(data, residuals, coef),), chi2=cost, dof=len(data) - len(names),
        keys={"offset": ParameterKey("offset", 0)},
    )
