"""Calibration from several experiments at once, with the physical model and priors.

A calibration dataset is a list of experiments (:class:`~magcilia.io.recordings.Measurement`)
sharing the cilium and its placement: rigid tilts toward any azimuth φ, each recorded either with
the single-axis sensor (output, V) or with a 3-axis magnetometer (B_x, B_y, B_z, T), and load
experiments (tip forces, flow). Each is one residual object of :mod:`.experiments`
(:func:`~magcilia.calibration.experiments.experiment` picks its type), with its own bias: one
constant output offset, or one constant offset per axis (a 3-axis magnetometer sees the Earth's
field and its own offsets, comparable to the cilium's ~40 µT); Gaussian priors add
:class:`~magcilia.calibration.experiments.Prior` terms. Their sum is one
:class:`~magcilia.calibration.problem.Problem`:

* coil experiments (:class:`~magcilia.calibration.experiments.CoilExperiment`) add the
  magnetization scale, the Young's modulus and (single-axis output) the sensitivity to the
  search vector; a fit they leave undetermined says which combination (the ``undetermined``
  warning, from the Fisher information: :mod:`.joint_result`);
* ``model="physical"``: n and k held at a converged layout (the ``rms`` ring,
  :func:`~magcilia.calibration.layout.converged_layout`), so that height and base radius are the
  hair's real dimensions; only the continuous parameters height, base radius, x, y, z are fitted
  (the Young's modulus too with load experiments, the magnetization scale with ``fit_scale``);
* the offsets (and the magnetization scale) enter linearly and are solved in closed form inside
  the objective (variable projection), weighted by the standard errors;
* the residuals are ``(measured − model) / s.e.``, the standard errors floored
  (:data:`~magcilia.calibration.experiments.SEM_FLOOR_FRACTION`,
  :data:`~magcilia.calibration.experiments.SEM_FLOOR`) so that a zero s.e. cannot dominate.

The search (:func:`calibrate_joint`): Latin-hypercube starts over the bounds, batched
Levenberg–Marquardt (:mod:`magcilia.fitting`) narrowed by successive halving, a
``least_squares`` polish (:func:`polish`, on :func:`magcilia.fitting.polish`); the result
(:mod:`.joint_result`) with the covariance from the SVD of the column-equilibrated Jacobian (as
:mod:`magcilia.calibration.uncertainty`), scaled by the reduced χ² when that exceeds 1.
"""

from __future__ import annotations

import math
import time
from collections.abc import Mapping, Sequence
from dataclasses import replace

import numpy as np
from numpy.typing import NDArray

from magcilia import _validate as v
from magcilia._errors import MagciliaError
from magcilia.calibration.ambiguity import (
    alternatives,
    ambiguity_warning,
    best_of,
    mirror_starts,
)
from magcilia.calibration.coil_model import coil_bounds
from magcilia.calibration.diagnostics import LENGTHS, placement_remedy
from magcilia.calibration.experiments import (
    SEM_FLOOR,
    SEM_FLOOR_FRACTION,
    Experiment,
    Prior,
    RecordedExperiment,
    experiment,
    fluid_of,
    y_sign_determined,
)
from magcilia.calibration.joint_result import joint_result
from magcilia.calibration.layout import (
    EXACT_SLICES,
    LAYOUT_SLICES,
    PHYSICAL_DIPOLES,
    PHYSICAL_TILTS,
    PHYSICAL_TOLERANCE,
    PhysicalLayout,
    as_layout,
    converged_layout,
    layout_error,
)
from magcilia.calibration.posterior import sample_problem
from magcilia.calibration.problem import (
    COIL_PARAMETERS,
    DEFAULT_BOUNDS,
    GEOMETRY,
    LOAD_PARAMETER,
    Problem,
)
from magcilia.calibration.result import CalibrationResult
from magcilia.device.parameters import PARAMETERS as REGISTRY
from magcilia.device.parameters import check_ranges
from magcilia.device.setup import Setup
from magcilia.fitting import fit_batch, latin_hypercube
from magcilia.fitting import polish as polish_batch
from magcilia.io.recordings import Measurement

F64 = NDArray[np.float64]

#: the continuous parameters of the physical model, in the order of the search vector
JOINT_PARAMETERS = GEOMETRY
#: default bounds of the Young's modulus, Pa (soft magnetic composites: the paper's composite
#: reads 0.45–0.84 MPa from its 300 % modulus, 0.669 MPa ± 27 % by default, docs/stiffness.md;
#: small-strain data of stiffer SIS grades reach a few MPa)
YOUNGS_BOUNDS = (1e5, 1e7)
#: log-spaced moduli tried at the tilt fit's geometry before the refinement with the loads
MODULUS_GRID = 17
#: Latin-hypercube starts of the global search
STARTS = 64
#: Levenberg–Marquardt iterations between halvings, fits left, most iterations at the end
ROUND, SURVIVORS, MAXITER = 8, 6, 100
#: the search keeps distinct basins (more than this fraction of the box apart) to the end (a
#: local minimum within :data:`~magcilia.calibration.ambiguity.AMBIGUITY_CHI2` of the best, more
#: than :data:`~magcilia.calibration.ambiguity.AMBIGUITY_SIGMA` standard errors away, is reported
#: as an equally good alternative: ``ambiguous``)
DIVERSITY = 0.1

__all__ = ["EXACT_SLICES", "JOINT_PARAMETERS", "LAYOUT_SLICES", "LOAD_PARAMETER", "MODULUS_GRID",
           "PHYSICAL_DIPOLES", "PHYSICAL_TILTS", "PHYSICAL_TOLERANCE", "SEM_FLOOR",
           "SEM_FLOOR_FRACTION", "STARTS", "YOUNGS_BOUNDS", "JointProblem", "PhysicalLayout",
           "calibrate_joint", "check_priors", "converged_layout", "joint_problem", "layout_error",
           "polish", "y_sign_determined"]


def joint_problem(experiments: Sequence[Measurement | Experiment], initial: Setup,
                  layout: PhysicalLayout,
                  bounds: Mapping[str, tuple[float, float]], names: Sequence[str],
                  priors: Mapping[str, tuple[float, float]] | None = None,
                  fit_scale: bool = False) -> Problem:
    """The :class:`~magcilia.calibration.problem.Problem` of the physical model: each recording
    its experiment (:func:`~magcilia.calibration.experiments.experiment`, weighted; an experiment
    object as given), each prior a
    :class:`~magcilia.calibration.experiments.Prior`, n and k held at ``layout``, the search
    vector ``names`` within ``bounds`` (SI)."""
    terms: list[Experiment] = [e if isinstance(e, Experiment) else experiment(e)
                               for e in experiments]
    terms += [Prior(n, mu, s) for n, (mu, s) in (priors or {}).items()]
    base = initial.replace(n_loops=layout.n_loops, dipoles_per_loop=layout.dipoles_per_loop,
                           ring=layout.ring)
    return Problem(terms, base, names, bounds, fit_scale)


#: the physical model's problem under its earlier name (a function now: the one problem class
#: is :class:`~magcilia.calibration.problem.Problem`)
JointProblem = joint_problem


def check_priors(priors: Mapping[str, tuple[float, float]] | None, names: Sequence[str],
                 bounds: Mapping[str, tuple[float, float]]) -> dict[str, tuple[float, float]]:
    """Priors (value, σ), SI, checked: known fitted names, σ > 0, the value inside its bounds;
    a one-line error naming the parameter otherwise."""
    out: dict[str, tuple[float, float]] = {}
    for name, spec in (priors or {}).items():
        if name not in names:
            raise v.fail("prior", name, "one of the fitted parameters " + ", ".join(names))
        try:
            mu, sigma = (float(spec[0]), float(spec[1]))
        except (TypeError, ValueError, IndexError):
            raise v.fail(f"prior {name}", spec, "(value, sigma) in SI") from None
        p = REGISTRY[name]
        if not (math.isfinite(mu) and math.isfinite(sigma)):
            raise v.fail(f"prior {name}", spec, "finite (value, sigma)")
        if sigma <= 0.0:
            raise MagciliaError(f"prior {name}: zero-width prior (sigma {p.text(sigma, 4)}); give "
                                "a positive sigma, or hold the parameter with fixed=")
        lo, hi = bounds[name]
        if not lo <= mu <= hi:
            raise MagciliaError(f"prior {name}: value {p.text(mu, 6)} is outside its bounds "
                                f"{p.text(lo, 6)}…{p.text(hi, 6)}; move the prior or widen the "
                                "bounds")
        out[name] = (mu, sigma)
    return out


def _check_experiment(i: int, data: object) -> Measurement:
    if not isinstance(data, Measurement):
        raise v.fail(f"data[{i}]", type(data).__name__,
                     "a magcilia Measurement (use read_measurements)")
    arrays = [("angle_rad", data.angles), ("azimuth_rad", data.azimuths)]
    arrays += ([("field_T", data.fields)] if data.fields is not None
               else [("voltage_V", data.volts)])
    if data.loads is not None:
        arrays.append(("force_N" if data.forces is not None else "speed_m_per_s", data.loads))
    if data.actuation is not None:
        arrays.append(("actuation_T", data.actuation))
    if data.speeds is not None:
        fluid_of(data)
    for what, values in arrays:
        arr = np.asarray(values, dtype=np.float64)
        if not np.isfinite(arr).all():
            raise MagciliaError(f"{v.printable(str(data.source))}: {what} is not finite everywhere;"
                                " clean the recording or read it with nan_policy='omit'")
    return data


def _search(problem: Problem, x_init: F64, rng: np.random.Generator,
            starts: int) -> tuple[F64, F64, F64]:
    """The best parameters (p,) and the search's final local minima (s, p) with their χ² (s,):
    the survivors of the halving and the fits started in the mirrored basins of the best of
    them (:func:`~magcilia.calibration.ambiguity.mirror_starts`), all run to convergence, the
    best of them polished."""
    lo, hi = problem.bounds[:, 0], problem.bounds[:, 1]
    x = latin_hypercube(starts, lo, hi, rng)
    x[0] = x_init

    def res(xs: F64, _: NDArray[np.intp]) -> F64:
        return problem.residuals(xs)

    while True:
        fits = fit_batch(res, x, lo, hi, maxiter=ROUND)
        x, cost = fits.x, fits.cost
        if x.shape[0] <= 4 * SURVIVORS:
            x = x[_diverse(x, cost, hi - lo, SURVIVORS)]
            break
        x = x[np.argsort(cost, kind="stable")[:x.shape[0] // 2]]
    fits = fit_batch(res, x, lo, hi, maxiter=MAXITER)
    minima, cost = fits.x, fits.cost
    mirrors = mirror_starts(best_of(minima, cost)[0], problem.names, problem.bounds,
                            y_sign_determined(problem.measurements))
    if mirrors.size:
        more = fit_batch(res, mirrors, lo, hi, maxiter=MAXITER)
        minima, cost = np.concatenate([minima, more.x]), np.concatenate([cost, more.cost])
    i = int(np.argmin(np.where(np.isfinite(cost), cost, np.inf)))
    minima[i] = polish(problem, minima[i])
    cost[i] = problem.cost(minima[i])[0]
    return minima[i].copy(), minima, cost


def polish(problem: Problem, x: F64) -> F64:
    """A ``least_squares`` polish of ``x`` (p,) on ``problem`` within its bounds (200 residual
    evaluations at most); ``x`` itself when the polish does not lower the χ²."""
    lo, hi = problem.bounds[:, 0], problem.bounds[:, 1]
    fit = polish_batch(lambda z, _: problem.residuals(z), x, lo, hi, max_nfev=200)
    return fit.x[0]


def _search_loads(problem: Problem, experiments: list[Experiment], initial: Setup,
                  layout: PhysicalLayout, box: Mapping[str, tuple[float, float]],
                  priors: Mapping[str, tuple[float, float]], fit_scale: bool, x_init: F64,
                  rng: np.random.Generator, starts: int) -> tuple[F64, F64, F64]:
    """The search with load experiments (whose model is a loop over parameter sets): the global
    search on the tilt experiments alone (when there are any, and enough values), the Young's
    modulus then chosen on a log grid (:data:`MODULUS_GRID`) at that geometry, and a
    ``least_squares`` refinement of everything on all experiments. Returns as :func:`_search`,
    the tilt search's minima re-costed on all experiments at the chosen modulus."""
    names = problem.names
    geo = [i for i, n in enumerate(names) if n != LOAD_PARAMETER]
    tilts = [e for e in experiments if isinstance(e, RecordedExperiment) and e.data.loads is None]
    x = x_init.copy()
    minima = np.zeros((0, len(names)))
    sub_names = tuple(names[i] for i in geo)
    if tilts and sub_names:
        sub = joint_problem(tilts, initial, layout, box, sub_names,
                           {k: p for k, p in priors.items() if k in sub_names}, fit_scale)
        n_lin = len(sub.bias_keys) + int(fit_scale)
        if sub.y.size > n_lin + len(sub_names):
            best, found, _ = _search(sub, x_init[geo], rng, starts)
            problem.evaluations += sub.evaluations
            x[geo] = best
            minima = np.repeat(x[None, :], found.shape[0], axis=0)
            minima[:, geo] = found
    if LOAD_PARAMETER in names:
        k = names.index(LOAD_PARAMETER)
        lo, hi = problem.bounds[k]
        grid = np.geomspace(lo, hi, MODULUS_GRID)
        trial = np.repeat(x[None, :], grid.size, axis=0)
        trial[:, k] = grid
        x = trial[int(np.argmin(problem.cost(trial)))]
        if minima.size:
            minima[:, k] = x[k]
    x = polish(problem, x)
    cost = problem.cost(minima) if minima.size else np.zeros(0)
    return x, minima, cost


def _diverse(x: F64, cost: F64, width: F64, count: int) -> NDArray[np.intp]:
    """Rows of ``x`` (s, p) to keep: the best, then the best of those more than
    :data:`DIVERSITY` of the box from every kept one (other basins: the ambiguity check needs
    them), topped up with the next best; ``count`` at most."""
    order = np.argsort(cost, kind="stable")
    kept: list[int] = []
    for i in order:
        if all(np.abs((x[i] - x[j]) / width).max() > DIVERSITY for j in kept):
            kept.append(int(i))
        if len(kept) == count:
            break
    kept += [int(i) for i in order if int(i) not in kept][:count - len(kept)]
    return np.array(kept, dtype=np.intp)


def calibrate_joint(
    data: Measurement | Sequence[Measurement | Experiment] | Experiment,
    initial: Setup | None = None,
    bounds: Mapping[str, tuple[float, float]] | None = None,
    *,
    rng: int | np.random.Generator | None = None,
    priors: Mapping[str, tuple[float, float]] | None = None,
    fit_scale: bool = False,
    fixed: Mapping[str, float] | None = None,
    layout: PhysicalLayout | tuple[int, int] | None = None,
    tolerance: float = PHYSICAL_TOLERANCE,
    starts: int = STARTS,
    posterior: bool | int = False,
) -> CalibrationResult:
    """Fit the physical model to one or several experiments (``calibrate(model="physical")``).

    Parameters
    ----------
    data : Measurement, sequence of Measurement, or a sum of experiments
        The experiments: tilt recordings at any azimuth, output (V) or 3-axis field (T), load
        recordings, coil recordings (applied uniform fields: the magnetization scale, the
        Young's modulus and, with a single-axis output, the sensitivity are then searched too;
        ``fit_scale`` is implied); or experiment objects and priors that add
        (``TiltPath(a) + FieldPath(b) + Prior("height", 3.2e-3, 0.15e-3)``, :mod:`.experiments`;
        a recording becomes :func:`~magcilia.calibration.experiments.experiment` of it).
    initial : Setup, optional
        Starting setup; supplies the material, sensor and everything not fitted (default
        ``Setup.paper_initial()``).
    bounds : mapping of str to (low, high), optional
        Bounds of height, base_radius, x, y, z (m); missing keys take :data:`DEFAULT_BOUNDS`.
    rng : int, Generator or None
        Seed of the global search.
    priors : mapping of str to (value, sigma), optional
        Gaussian priors, SI, e.g. ``{"height": (3.0e-3, 0.2e-3)}``.
    fit_scale : bool
        Also fit the magnetization scale (closed form, shared by all experiments).
    fixed : mapping of str to float, optional
        Parameters held at values (SI).
    layout : PhysicalLayout or (n, k), optional
        The dipole layout; default :func:`converged_layout` of ``initial`` at ``tolerance``.
    tolerance : float
        Layout tolerance (see :func:`converged_layout`).
    starts : int
        Latin-hypercube starts of the global search.
    posterior : bool or int
        Also sample the posterior of the fitted geometry (the offsets profiled out) with
        :func:`~magcilia.calibration.posterior.sample_problem` until every parameter has 1000
        effective samples (an int: that many), within
        :data:`~magcilia.calibration.posterior.MAX_SECONDS`; the alternatives the ``ambiguous``
        warning names (:mod:`magcilia.calibration.ambiguity`) and, when the data cannot tell the
        sign of y, the mirrors ``y → −y`` of each are sampled as modes and weighted by their
        evidence. Needs the optional ``emcee`` (``pip install 'magcilia[posterior]'``).

    Returns
    -------
    CalibrationResult
        One result class for every calibration (``model == "physical"``).
    """
    t0 = time.perf_counter()
    initial = initial if initial is not None else Setup.paper_initial()
    items: list[object] | None = ([data] if isinstance(data, Measurement) else list(data)
                                  if isinstance(data, Sequence | Experiment) else None)
    given = {e.name: (e.value, e.sigma) for e in items or () if isinstance(e, Prior)}
    items = [e for e in items or () if not isinstance(e, Prior)]
    if not items:
        raise v.fail("data", type(data).__name__, "a Measurement or a non-empty sequence of them "
                                                  "(or a sum of experiments)")
    terms: list[Experiment] = [e if isinstance(e, RecordedExperiment) else experiment(
        _check_experiment(i, e)) for i, e in enumerate(items)]
    experiments = [_check_experiment(i, e.data) for i, e in enumerate(terms)
                   if isinstance(e, RecordedExperiment)]
    priors = {**given, **(priors or {})}
    has_loads = any(e.loads is not None for e in experiments)
    coils = [e for e in experiments if e.actuation is not None]
    allowed = JOINT_PARAMETERS + ((LOAD_PARAMETER,) if has_loads or coils else ())
    if coils:  # the magnetization bends the cilium: a search parameter, not a closed form
        allowed += COIL_PARAMETERS[:1 + any(e.fields is None for e in coils)]
        fit_scale = False
    if any(e.forces is not None for e in experiments) and initial.cilium.tip_radius == 0.0:
        raise v.fail("initial tip_radius", 0.0, "positive for force experiments (a tip force on "
                     "a sharp cone bends it infinitely); give the measured tip radius")
    if coils and initial.cilium.profile is None and initial.cilium.tip_radius == 0.0:
        raise v.fail("initial tip_radius", 0.0, "positive for coil experiments (a field's "
                     "couple on a sharp cone bends it infinitely); give the measured tip radius")
    starts = v.integer("starts", starts, 1)
    held = dict(fixed or {})
    for name, value in held.items():
        if name not in allowed:
            raise v.fail("fixed key", name, "one of " + ", ".join(allowed))
        held[name] = REGISTRY[name].check(value, f"fixed[{name!r}]")
    extra = set(bounds or {}) - set(allowed)
    if extra:
        name = min(extra)
        hint = " (n and k are held by the physical model's layout)" if name in (
            "n_loops", "dipoles_per_loop") else " (only with load experiments)" if (
            name == LOAD_PARAMETER) else ""
        raise v.fail("bounds key", name, "one of " + ", ".join(allowed) + hint)
    merged = v.intervals("bounds", bounds, {**DEFAULT_BOUNDS, **(
        {LOAD_PARAMETER: YOUNGS_BOUNDS} if has_loads or coils else {}),
        **(coil_bounds(initial) if coils else {})})
    box: dict[str, tuple[float, float]] = {
        n: (float(merged[n][0]), float(merged[n][1])) for n in allowed}
    check_ranges(box)
    for n, val in held.items():
        box[n] = (val, val)
    if held:
        initial = initial.replace(**held)
    init = {**initial.params(), LOAD_PARAMETER: initial.youngs_modulus,
            "sensitivity": initial.sensor.sensitivity}
    for name in allowed:
        lo, hi = box[name]
        tol = 1e-9 * max(abs(lo), abs(hi), 1e-9)
        if not lo - tol <= init[name] <= hi + tol:
            p = REGISTRY[name]
            raise v.fail(f"initial {name}", p.text(init[name], 6),
                         f"inside its bounds {p.text(lo, 6)}…{p.text(hi, 6)}")
    names = tuple(n for n in allowed if box[n][0] < box[n][1])
    checked = check_priors(priors, names, box)
    lay = as_layout(layout, initial, tolerance)
    problem = joint_problem(terms, initial, lay, box, names, checked, fit_scale)
    n_lin = len(problem.bias_keys) + int(fit_scale)
    if problem.y.size <= n_lin + len(names):
        raise MagciliaError(f"{problem.y.size} data values cannot determine {n_lin} linear "
                            f"parameters and {len(names)} geometry parameters; record more "
                            "conditions")
    gen = np.random.default_rng(rng)
    x_init = np.clip([init[n] for n in names], problem.bounds[:, 0], problem.bounds[:, 1])
    minima, minima_cost = np.zeros((0, len(names))), np.zeros(0)
    if names and has_loads and not coils:
        x, minima, minima_cost = _search_loads(problem, terms, initial, lay, box, checked,
                                               fit_scale, x_init, gen, starts)
    elif names:
        x, minima, minima_cost = _search(problem, x_init, gen, starts)
    else:
        x = x_init
    y_free = not y_sign_determined(experiments)
    if y_free and "y" in names:
        k = names.index("y")
        if x[k] * (-1.0 if init["y"] < 0 else 1.0) < 0 and box["y"][0] <= -x[k] <= box["y"][1]:
            x = x.copy()
            x[k] = -x[k]
    target = 0 if posterior is False else 1000 if posterior is True else v.integer(
        "posterior", posterior, 100)
    result = joint_result(problem, lay, initial, box, x, y_free, t0)
    free = all(n in names and n not in checked for n in LENGTHS)  # nothing fixes the size
    found = alternatives(x, float(problem.cost(x)[0]), minima, minima_cost, names,
                         result.stderr, fold_y=y_free,
                         depth=initial.sensor.depth if free else None)
    alt = ambiguity_warning(found, float(problem.cost(x)[0]), names,
                            placement_remedy(not y_free))
    if alt is not None:
        result = replace(result, warnings=(*result.warnings, alt.message),
                         diagnostics=(*result.diagnostics, alt))
    if target and names:
        modes = [a.point for a in found]
        if y_free and "y" in names:  # each alternative has its y mirror too
            modes += [a.point * np.where(np.array(names) == "y", -1.0, 1.0) for a in found]
        result = replace(result, posterior=sample_problem(
            problem, x, modes=[m for m in modes if np.all((problem.bounds[:, 0] <= m)
                                                          & (m <= problem.bounds[:, 1]))],
            mirror=["y"] if y_free and "y" in names else (), n_effective=target, rng=gen))
    return result


