"""Calibration from several experiments at once, with the physical model and priors.

A calibration dataset is a list of experiments (:class:`~magcilia.io.recordings.Measurement`)
sharing the cilium and its placement: rigid tilts toward any azimuth φ, each recorded either with
the single-axis sensor (output, V) or with a 3-axis magnetometer (B_x, B_y, B_z, T). Each
experiment has its own bias: one constant output offset, or one constant offset per axis (a 3-axis
magnetometer sees the Earth's field and its own offsets, comparable to the cilium's ~40 µT).

The model (:class:`JointProblem`):

* ``model="physical"``: n and k held at a converged layout (the ``rms`` ring,
  :func:`converged_layout`), so that height and base radius are the hair's real dimensions; only
  the continuous parameters height, base radius, x, y, z are fitted (and the magnetization scale
  with ``fit_scale``);
* every condition's field comes from the compiled batch model (:class:`~magcilia.model.TiltBatch`),
  one per distinct azimuth: the base centre turned by −φ, the field turned back by +φ
  (:mod:`magcilia.model.azimuth`);
* the offsets (and the magnetization scale) enter linearly and are solved in closed form inside
  the objective (variable projection), weighted by the standard errors;
* the residuals are ``(measured − model) / s.e.``, the standard errors floored
  (:data:`SEM_FLOOR_FRACTION`, :data:`SEM_FLOOR`) so that a zero s.e. cannot dominate; Gaussian
  priors add the rows ``(p − μ) / σ``.

The search (:func:`calibrate_joint`): Latin-hypercube starts over the bounds, batched
Levenberg–Marquardt (:mod:`magcilia.fitting`) narrowed by successive halving, a
``least_squares`` polish; the covariance from the SVD of the column-equilibrated Jacobian (as
:mod:`magcilia.calibration.uncertainty`), scaled by the reduced χ² when that exceeds 1.
"""

from __future__ import annotations

import math
import time
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, replace

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
from magcilia.calibration.diagnostics import (
    LENGTHS,
    CalibrationWarning,
    at_bound,
    correlated,
    placement_remedy,
    prior_only_warning,
    scale_remedy,
    undetermined_remedy,
    undetermined_warning,
)
from magcilia.calibration.posterior import sample_problem
from magcilia.calibration.problem import DEFAULT_BOUNDS
from magcilia.calibration.result import (
    ExperimentFit,
    JointCalibrationResult,
    ParameterCovariance,
)
from magcilia.calibration.uncertainty import equilibrated_pinv
from magcilia.device.parameters import PARAMETERS as REGISTRY
from magcilia.device.parameters import check_ranges
from magcilia.device.setup import Setup
from magcilia.fitting import fit_batch, latin_hypercube
from magcilia.fitting import polish as polish_batch
from magcilia.io.recordings import Measurement
from magcilia.mechanics.bend import bend_sweep
from magcilia.mechanics.drag import FLUIDS, Fluid
from magcilia.mechanics.flow import Flow
from magcilia.model import convergence
from magcilia.model.azimuth import field_from_tilt_frame, placement_in_tilt_frame
from magcilia.model.batch import TiltBatch
from magcilia.model.convergence import Layout

F64 = NDArray[np.float64]

#: the continuous parameters of the physical model, in the order of the search vector
JOINT_PARAMETERS = ("height", "base_radius", "x", "y", "z")
#: the parameter load experiments add (after :data:`JOINT_PARAMETERS`)
LOAD_PARAMETER = "youngs_modulus"
#: default bounds of the Young's modulus, Pa (soft magnetic composites: the paper's composite
#: reads 0.45–0.84 MPa from its 300 % modulus, 0.669 MPa ± 27 % by default, docs/stiffness.md;
#: small-strain data of stiffer SIS grades reach a few MPa)
YOUNGS_BOUNDS = (1e5, 1e7)
#: log-spaced moduli tried at the tilt fit's geometry before the refinement with the loads
MODULUS_GRID = 17
#: relative error (max over 0–85° of |B_model − B_exact| / |B_exact|) the physical layout must
#: meet against the exact Cylinder stack at the initial setup (see docs/convergence.md)
PHYSICAL_TOLERANCE = 2e-4
#: rings per slice of the physical layout (the rms ring converges for k ≥ 5: docs/convergence.md)
PHYSICAL_DIPOLES = 5
#: slice counts tried by :func:`converged_layout`, smallest first
LAYOUT_SLICES = (8, 12, 16, 24, 32, 48, 64)
#: cylinder slices of the exact reference (converged to ~1e-6)
EXACT_SLICES = 2000
#: tilts of the physical layout's probe (toward +x, at the sensing element), rad
PHYSICAL_TILTS = np.radians(np.arange(0.0, 86.0, 5.0))
#: standard errors are floored at this fraction of the experiment's median positive s.e. …
SEM_FLOOR_FRACTION = 0.1
#: … and at these absolute values (output V, field T): a zero s.e. (noise-free or single-sample
#: data) cannot blow the weight up
SEM_FLOOR = {"output": 1e-7, "field": 1e-10}
#: Latin-hypercube starts of the global search
STARTS = 64
#: Levenberg–Marquardt iterations between halvings, fits left, most iterations at the end
ROUND, SURVIVORS, MAXITER = 8, 6, 100
#: the search keeps distinct basins (more than this fraction of the box apart) to the end (a
#: local minimum within :data:`~magcilia.calibration.ambiguity.AMBIGUITY_CHI2` of the best, more
#: than :data:`~magcilia.calibration.ambiguity.AMBIGUITY_SIGMA` standard errors away, is reported
#: as an equally good alternative: ``ambiguous``)
DIVERSITY = 0.1
#: the cost of a non-finite model (the element on a dipole): worse than any fit, finite
NONFINITE_RESIDUAL = 1e50


@dataclass(frozen=True)
class PhysicalLayout(Layout):
    """The dipole layout of the physical model: a :class:`~magcilia.model.convergence.Layout`
    (n_loops, dipoles_per_loop, ring — ``"rms"`` by default —, error, tolerance) chosen by
    :func:`converged_layout` with the calibration's tolerance, or given by hand (error and
    tolerance NaN)."""


def layout_error(setup: Setup, n_loops: int, dipoles_per_loop: int = PHYSICAL_DIPOLES,
                 angles: F64 | None = None) -> float:
    """Max over ``angles`` (rad, default 0–85° in 5° steps) of |B_model − B_exact| / |B_exact|
    at the sensing element for ``setup`` with the rms ring of ``n_loops`` × ``dipoles_per_loop``
    (dimensionless; :func:`magcilia.model.convergence.layout_error` with the calibration's
    probe: tilts toward +x, :data:`EXACT_SLICES` cylinders)."""
    a = PHYSICAL_TILTS if angles is None else np.asarray(angles, dtype=np.float64)
    return convergence.layout_error(setup, n_loops, dipoles_per_loop, "rms", tilts=a,
                                    azimuths=(0.0,), reference_slices=EXACT_SLICES)


def converged_layout(setup: Setup, tolerance: float = PHYSICAL_TOLERANCE,
                     strict: bool = True) -> PhysicalLayout:
    """The smallest rms-ring layout (n of :data:`LAYOUT_SLICES`, k = :data:`PHYSICAL_DIPOLES`)
    whose field at ``setup`` is within ``tolerance`` of the exact Cylinder stack over 0–85°
    (:func:`magcilia.model.convergence.converged_layout` with the calibration's probe).

    Parameters
    ----------
    setup : Setup
        Geometry and placement (its n, k and ring are not used).
    tolerance : float
        Max relative error |B_model − B_exact| / |B_exact| (dimensionless, > 0).
    strict : bool
        Raise when no layout reaches it; else return the largest one tried, its ``error`` above
        the tolerance (a sensing element very close to the base converges slowly).

    Returns
    -------
    PhysicalLayout

    Examples
    --------
    >>> import magcilia as mc
    >>> lay = converged_layout(mc.Setup.paper(), 1e-3)
    >>> lay.n_loops, lay.dipoles_per_loop, lay.ring, lay.error < 1e-3
    (32, 5, 'rms', True)
    >>> converged_layout(mc.Setup.paper()).n_loops  # the default tolerance, 2e-4
    64
    """
    lay = convergence.converged_layout(
        setup, tolerance, tilts=PHYSICAL_TILTS, azimuths=(0.0,), slices=LAYOUT_SLICES,
        dipoles_per_loop=PHYSICAL_DIPOLES, reference_slices=EXACT_SLICES, strict=strict)
    return PhysicalLayout(lay.n_loops, lay.dipoles_per_loop, lay.ring, lay.error, lay.tolerance)


def _as_layout(layout: PhysicalLayout | tuple[int, int] | None, initial: Setup,
               tolerance: float) -> PhysicalLayout:
    if layout is None:
        return converged_layout(initial, tolerance, strict=False)
    if isinstance(layout, Layout):
        return layout if isinstance(layout, PhysicalLayout) else PhysicalLayout(
            layout.n_loops, layout.dipoles_per_loop, layout.ring, layout.error, layout.tolerance)
    try:
        n, k = (int(layout[0]), int(layout[1]))
    except (TypeError, ValueError, IndexError):
        raise v.fail("layout", layout, "(n_loops, dipoles_per_loop), a PhysicalLayout or None "
                                       "(chosen by converged_layout)") from None
    if n < 1 or k < 1:
        raise v.fail("layout", layout, "two whole numbers ≥ 1")
    return PhysicalLayout(n, k)


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


def _sigma(values: F64, observable: str) -> F64:
    """Standard errors with the floors of :data:`SEM_FLOOR_FRACTION` and :data:`SEM_FLOOR`."""
    s = np.where(np.isfinite(values), values, 0.0)
    positive = s[s > 0]
    floor = SEM_FLOOR[observable]
    if positive.size:
        floor = max(floor, SEM_FLOOR_FRACTION * float(np.median(positive)))
    return np.maximum(s, floor)


def _fluid(e: Measurement) -> Fluid:
    """The fluid of a flow experiment (``metadata["fluid"]``: a name of
    :data:`~magcilia.mechanics.drag.FLUIDS`, default water)."""
    name = e.fluid.strip().lower()
    if name not in FLUIDS:
        raise v.fail(f"{v.printable(str(e.source))}: fluid", e.fluid,
                     "one of " + ", ".join(sorted(FLUIDS)) + " (metadata 'fluid')")
    return FLUIDS[name]


def _check_experiment(i: int, data: object) -> Measurement:
    if not isinstance(data, Measurement):
        raise v.fail(f"data[{i}]", type(data).__name__,
                     "a magcilia Measurement (use read_measurements)")
    arrays = [("angle_rad", data.angles), ("azimuth_rad", data.azimuths)]
    arrays += ([("field_T", data.fields)] if data.fields is not None
               else [("voltage_V", data.volts)])
    if data.loads is not None:
        arrays.append(("force_N" if data.forces is not None else "speed_m_per_s", data.loads))
    if data.speeds is not None:
        _fluid(data)
    for what, values in arrays:
        arr = np.asarray(values, dtype=np.float64)
        if not np.isfinite(arr).all():
            raise MagciliaError(f"{v.printable(str(data.source))}: {what} is not finite everywhere;"
                                " clean the recording or read it with nan_policy='omit'")
    return data


class JointProblem:
    """The weighted least-squares problem of several experiments, the linear parameters (offsets,
    magnetization scale) projected out.

    Attributes
    ----------
    names : tuple of str
        The fitted continuous parameters, in the order of the columns of ``P``.
    bounds : ndarray, shape (p, 2)
        Their bounds, SI.
    experiments : tuple of Measurement
    priors : dict of str to (float, float)
        Gaussian priors (value, σ), SI.
    size : int
        Residual rows m: the data values (a per output experiment, 3a per field experiment)
        followed by one row per prior.

    Notes
    -----
    ``residuals(P)`` is vectorised over parameter sets (posterior samplers, design criteria);
    ``jacobian(p)`` is its central-difference Jacobian at one set.
    """

    def __init__(self, experiments: Sequence[Measurement], initial: Setup, layout: PhysicalLayout,
                 bounds: Mapping[str, tuple[float, float]], names: Sequence[str],
                 priors: Mapping[str, tuple[float, float]] | None = None,
                 fit_scale: bool = False) -> None:
        self.experiments = tuple(experiments)
        self.base = initial.replace(offset=0.0, n_loops=layout.n_loops,
                                    dipoles_per_loop=layout.dipoles_per_loop, ring=layout.ring)
        self.layout = layout
        self.names = tuple(names)
        self.bounds = np.array([bounds[n] for n in self.names], dtype=np.float64).reshape(-1, 2)
        self.priors = dict(priors or {})
        self.fit_scale = fit_scale
        self.evaluations = 0
        self.sensor_scale = initial.sensor.scale
        tilts = [e for e in self.experiments if e.loads is None]
        az = np.concatenate([np.zeros(0)] + [np.asarray(e.azimuths, dtype=np.float64)
                                             for e in tilts])
        self.azimuths = np.unique(np.round(np.mod(az, 2 * np.pi), 12))
        self.batches: list[TiltBatch] = []
        starts: list[int] = []
        total = 0
        for phi in self.azimuths:
            angles = np.unique(np.concatenate([
                e.angles[np.isclose(np.round(np.mod(e.azimuths, 2 * np.pi), 12), phi)]
                for e in tilts]))
            self.batches.append(TiltBatch(self.base, angles))
            starts.append(total)
            total += 3 * angles.size
        #: load blocks (experiment, azimuth, sorted distinct loads, first column of the block)
        self.load_blocks: list[tuple[int, float, F64, int]] = []
        index, factor, y, sig, group = [], [], [], [], []
        self.groups: list[tuple[int, int]] = []  # (experiment, component or -1 for output)
        for e_i, e in enumerate(self.experiments):
            phi = np.round(np.mod(e.azimuths, 2 * np.pi), 12)
            loads = e.loads
            if loads is not None:
                cond = np.zeros(len(e), dtype=np.intp)
                for az_b in np.unique(phi):
                    at = phi == az_b
                    values = np.unique(loads[at])
                    self.load_blocks.append((e_i, float(az_b), values, total))
                    cond[at] = total + 3 * np.searchsorted(values, loads[at])
                    total += 3 * values.size
            else:
                j = np.searchsorted(self.azimuths, phi)
                pos = np.array([np.searchsorted(self.batches[jj].angles, a)
                                for jj, a in zip(j, e.angles, strict=True)], dtype=np.intp)
                cond = np.asarray(starts, dtype=np.intp)[j] + 3 * pos
            if e.fields is None:
                index.append(cond)
                factor.append(np.full(cond.size, self.sensor_scale))
                y.append(np.asarray(e.volts, dtype=np.float64))
                sig.append(_sigma(np.asarray(e.sem, dtype=np.float64), "output"))
                group.append(np.full(cond.size, len(self.groups)))
                self.groups.append((e_i, -1))
            else:
                fsem = _sigma(np.asarray(e.field_sem, dtype=np.float64).ravel(), "field")
                fsem = fsem.reshape(-1, 3)
                for c in range(3):
                    index.append(cond + c)
                    factor.append(np.ones(cond.size))
                    y.append(np.asarray(e.fields, dtype=np.float64)[:, c])
                    sig.append(fsem[:, c])
                    group.append(np.full(cond.size, len(self.groups)))
                    self.groups.append((e_i, c))
        self.index = np.concatenate(index)
        self.factor = np.concatenate(factor)
        self.y = np.concatenate(y)
        self.sigma = np.concatenate(sig)
        self.group = np.concatenate(group)
        self.w = 1.0 / self.sigma
        q = np.zeros((self.y.size, len(self.groups)))
        q[np.arange(self.y.size), self.group] = self.w
        self.q = q / np.linalg.norm(q, axis=0)
        self.ry = self._project(self.y)
        self.prior_index = np.array([self.names.index(n) for n in self.priors], dtype=np.intp)
        self.prior_mu = np.array([m for m, _ in self.priors.values()])
        self.prior_sigma = np.array([s for _, s in self.priors.values()])
        self.size = self.y.size + len(self.priors)
        self._defaults = {**self.base.params(), LOAD_PARAMETER: self.base.youngs_modulus}
        self.fluids = {e_i: _fluid(e) for e_i, e in enumerate(self.experiments)
                       if e.speeds is not None}

    @property
    def all_names(self) -> tuple[str, ...]:
        """Every continuous parameter of the model (fitted or held): the geometry, then the
        Young's modulus when there are load experiments."""
        return JOINT_PARAMETERS + ((LOAD_PARAMETER,) if self.load_blocks else ())

    def _project(self, z: F64) -> F64:
        """Weighted values with each group's weighted mean removed (last axis)."""
        zw = z * self.w
        return zw - (zw @ self.q) @ self.q.T

    def params(self, P: F64) -> dict[str, F64]:
        """Parameter columns by name, each (N,), SI, from rows ``P`` (N, p)."""
        P = np.atleast_2d(np.asarray(P, dtype=np.float64))
        out = {n: np.full(P.shape[0], float(self._defaults[n])) for n in self.all_names}
        out.update({n: P[:, i] for i, n in enumerate(self.names)})
        return out

    def model(self, P: F64) -> F64:
        """Unbiased model values at every data row, shape (N, d): output (V, the sensor scale ×
        B_x) or field component (T), magnetization scale of the initial setup."""
        prm = self.params(P)
        n = prm["x"].size
        self.evaluations += n
        parts = [np.zeros((n, 0))]
        geometry = {k: prm[k] for k in JOINT_PARAMETERS}
        for phi, batch in zip(self.azimuths, self.batches, strict=True):
            x, y = placement_in_tilt_frame(prm["x"], prm["y"], phi)
            b = batch.field({**geometry, "x": x, "y": y})
            if phi != 0.0:
                b = field_from_tilt_frame(b, phi)
            parts.append(b.reshape(n, -1))
        if self.load_blocks:
            parts.append(self._load_fields(prm))
        full = np.concatenate(parts, axis=1)
        return full[:, self.index] * self.factor

    def _load_fields(self, prm: Mapping[str, F64]) -> F64:
        """The load blocks' fields, (N, 3 · loads), T: per parameter set, the bent shapes of
        :func:`~magcilia.mechanics.bend.bend_sweep` (sorted loads) and their field; NaN for a set
        whose bend does not converge or whose geometry is invalid."""
        n = prm["x"].size
        width = sum(3 * b[2].size for b in self.load_blocks)
        out = np.full((n, width), np.nan)
        for i in range(n):
            try:
                setup = self.base.replace(
                    height=float(prm["height"][i]), base_radius=float(prm["base_radius"][i]),
                    x=float(prm["x"][i]), y=float(prm["y"][i]), z=float(prm["z"][i]),
                    youngs_modulus=float(prm[LOAD_PARAMETER][i]))
                col = 0
                for e_i, phi, loads, _ in self.load_blocks:
                    e = self.experiments[e_i]
                    if e.forces is not None:
                        shapes = bend_sweep(setup, forces=loads)
                    else:
                        top = float(np.max(np.abs(loads))) or 1.0
                        shapes = bend_sweep(setup, speeds=loads,
                                            flow=Flow.uniform(top, self.fluids[e_i]))
                    out[i, col:col + 3 * loads.size] = setup.field(shapes, azimuth=phi).ravel()
                    col += 3 * loads.size
            except MagciliaError:
                out[i] = np.nan
        return out

    def linear(self, u: F64) -> tuple[F64, F64]:
        """Projected weighted residuals (N, d) and the scale factors (N,) for model values u."""
        with np.errstate(invalid="ignore", over="ignore", divide="ignore"):
            pu = self._project(u)
            if self.fit_scale:
                den = np.einsum("nd,nd->n", pu, pu)
                a = np.where(den > 0, (pu @ self.ry) / np.where(den > 0, den, 1.0), 0.0)
                a = np.maximum(a, 0.0)
            else:
                a = np.ones(u.shape[0])
            return self.ry - a[:, None] * pu, a

    def residuals(self, P: F64) -> F64:
        """Weighted residuals, shape (N, m): the data rows ``(measured − model)/s.e.`` with the
        offsets (and scale) at their best values, then the prior rows ``(p − μ)/σ``; a set whose
        model is not finite gets large finite rows (:data:`NONFINITE_RESIDUAL`)."""
        P = np.atleast_2d(np.asarray(P, dtype=np.float64))
        r, _ = self.linear(self.model(P))
        bad = ~np.isfinite(r).all(axis=1)
        r[bad] = NONFINITE_RESIDUAL
        prior = (P[:, self.prior_index] - self.prior_mu) / self.prior_sigma
        return np.concatenate([r, prior], axis=1)

    def cost(self, P: F64) -> F64:
        """Sum of squared weighted residuals (χ² with the priors), shape (N,)."""
        r = self.residuals(P)
        return np.einsum("nm,nm->n", r, r)

    def jacobian(self, p: F64) -> F64:
        """Central-difference Jacobian of :meth:`residuals` at one set ``p`` (p,), shape (m, p),
        steps 1e-5 of each bound's width (one vectorised call)."""
        p = np.asarray(p, dtype=np.float64)
        h = 1e-5 * (self.bounds[:, 1] - self.bounds[:, 0])
        eye = np.eye(p.size) * h
        r = self.residuals(np.concatenate([p + eye, p - eye]))
        return np.asarray(((r[:p.size] - r[p.size:]) / (2 * h[:, None])).T)

    def offsets(self, u: F64, scale: float) -> F64:
        """Each group's closed-form offset (weighted mean of measured − scale·model), (G,)."""
        w2 = self.w ** 2
        num = np.bincount(self.group, w2 * (self.y - scale * u), minlength=len(self.groups))
        return np.asarray(num / np.bincount(self.group, w2, minlength=len(self.groups)))


def _search(problem: JointProblem, x_init: F64, rng: np.random.Generator,
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
                            y_sign_determined(problem.experiments))
    if mirrors.size:
        more = fit_batch(res, mirrors, lo, hi, maxiter=MAXITER)
        minima, cost = np.concatenate([minima, more.x]), np.concatenate([cost, more.cost])
    i = int(np.argmin(np.where(np.isfinite(cost), cost, np.inf)))
    minima[i] = polish(problem, minima[i])
    cost[i] = problem.cost(minima[i])[0]
    return minima[i].copy(), minima, cost


def polish(problem: JointProblem, x: F64) -> F64:
    """A ``least_squares`` polish of ``x`` (p,) on ``problem`` within its bounds (200 residual
    evaluations at most); ``x`` itself when the polish does not lower the χ²."""
    lo, hi = problem.bounds[:, 0], problem.bounds[:, 1]
    fit = polish_batch(lambda z, _: problem.residuals(z), x, lo, hi, max_nfev=200)
    return fit.x[0]


def _search_loads(problem: JointProblem, experiments: list[Measurement], initial: Setup,
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
    tilts = [e for e in experiments if e.loads is None]
    x = x_init.copy()
    minima = np.zeros((0, len(names)))
    sub_names = tuple(names[i] for i in geo)
    if tilts and sub_names:
        sub = JointProblem(tilts, initial, layout, box, sub_names,
                           {k: p for k, p in priors.items() if k in sub_names}, fit_scale)
        n_lin = len(sub.groups) + int(fit_scale)
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


def y_sign_determined(experiments: Sequence[Measurement]) -> bool:
    """Whether the data fix the sign of y: B_x along tilts toward 0 or π is even in y, so only
    field data (B_y is odd in y) or another azimuth determine it."""
    for e in experiments:
        if e.fields is not None:
            return True
        s = np.sin(np.asarray(e.azimuths))
        if np.any(np.abs(s) > 1e-9):
            return True
    return False


def _uncertainty(problem: JointProblem, x: F64, scale: float, chi2: float
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
    off = np.zeros((problem.y.size, len(problem.groups)))
    off[np.arange(problem.y.size), problem.group] = problem.w
    cols.append(off)
    names += _offset_names(problem)
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
    units = np.array([problem.base.material.magnetization_scale
                      if n == "magnetization_scale" else 1.0 for n in names])
    cov = cov * np.outer(units, units)
    se = np.sqrt(np.clip(np.diag(cov), 0.0, None))
    se[undetermined] = np.inf
    values = dict(zip(problem.names, x.tolist(), strict=True))
    if not null.size and problem.priors:  # determined, but perhaps by the priors alone
        _, data_null, data_open = equilibrated_pinv(data_jac)
        if data_null.size:
            warns.append(prior_only_warning(data_jac, data_null, data_open, names, values,
                                            problem.base.sensor.depth, tuple(problem.priors)))
    if null.size:
        warns.append(undetermined_warning(
            jac, null, undetermined, names, values, problem.base.sensor.depth,
            "these experiments", scale_remedy(
                frozenset(str(problem.experiments[e].load_kind) for e, *_ in problem.load_blocks),
                LOAD_PARAMETER in problem.names and LOAD_PARAMETER not in problem.priors),
            undetermined_remedy(y_sign_determined(problem.experiments))))
    if dof <= 0:
        warns.append(CalibrationWarning(
            "no_degrees_of_freedom", f"{problem.y.size} data values for {p} parameters: no "
            "degrees of freedom left; record more conditions"))
    with np.errstate(invalid="ignore", divide="ignore"):
        corr = cov / np.outer(se, se)
    warns += correlated(names, corr)
    return tuple(names), cov, se, tuple(warns), factor > 1.0


def _offset_names(problem: JointProblem) -> list[str]:
    many = len(problem.experiments) > 1
    out = []
    for e_i, c in problem.groups:
        base = "offset" if c < 0 else f"offset_{'xyz'[c]}"
        out.append(f"{base}[{e_i}]" if many else base)
    return out


def calibrate_joint(
    data: Measurement | Sequence[Measurement],
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
) -> JointCalibrationResult:
    """Fit the physical model to one or several experiments (``calibrate(model="physical")``).

    Parameters
    ----------
    data : Measurement or sequence of Measurement
        The experiments: tilt recordings at any azimuth, output (V) or 3-axis field (T).
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
    JointCalibrationResult
    """
    t0 = time.perf_counter()
    initial = initial if initial is not None else Setup.paper_initial()
    items = [data] if isinstance(data, Measurement) else list(data) if isinstance(
        data, Sequence) else None
    if not items:
        raise v.fail("data", type(data).__name__, "a Measurement or a non-empty sequence of them")
    experiments = [_check_experiment(i, e) for i, e in enumerate(items)]
    has_loads = any(e.loads is not None for e in experiments)
    allowed = JOINT_PARAMETERS + ((LOAD_PARAMETER,) if has_loads else ())
    if any(e.forces is not None for e in experiments) and initial.cilium.tip_radius == 0.0:
        raise v.fail("initial tip_radius", 0.0, "positive for force experiments (a tip force on "
                     "a sharp cone bends it infinitely); give the measured tip radius")
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
        {LOAD_PARAMETER: YOUNGS_BOUNDS} if has_loads else {})})
    box: dict[str, tuple[float, float]] = {
        n: (float(merged[n][0]), float(merged[n][1])) for n in allowed}
    check_ranges(box)
    for n, val in held.items():
        box[n] = (val, val)
    if held:
        initial = initial.replace(**held)
    init = {**initial.params(), LOAD_PARAMETER: initial.youngs_modulus}
    for name in allowed:
        lo, hi = box[name]
        tol = 1e-9 * max(abs(lo), abs(hi), 1e-9)
        if not lo - tol <= init[name] <= hi + tol:
            p = REGISTRY[name]
            raise v.fail(f"initial {name}", p.text(init[name], 6),
                         f"inside its bounds {p.text(lo, 6)}…{p.text(hi, 6)}")
    names = tuple(n for n in allowed if box[n][0] < box[n][1])
    checked = check_priors(priors, names, box)
    lay = _as_layout(layout, initial, tolerance)
    problem = JointProblem(experiments, initial, lay, box, names, checked, fit_scale)
    n_lin = len(problem.groups) + int(fit_scale)
    if problem.y.size <= n_lin + len(names):
        raise MagciliaError(f"{problem.y.size} data values cannot determine {n_lin} linear "
                            f"parameters and {len(names)} geometry parameters; record more "
                            "conditions")
    gen = np.random.default_rng(rng)
    x_init = np.clip([init[n] for n in names], problem.bounds[:, 0], problem.bounds[:, 1])
    minima, minima_cost = np.zeros((0, len(names))), np.zeros(0)
    if names and has_loads:
        x, minima, minima_cost = _search_loads(problem, experiments, initial, lay, box, checked,
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
    result = _joint_result(problem, initial, experiments, box, x, y_free, t0)
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


def _fitted_modulus(problem: JointProblem, initial: Setup, values: Mapping[str, float],
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


def _joint_result(problem: JointProblem, initial: Setup, experiments: list[Measurement],
                  box: dict[str, tuple[float, float]], x: F64, y_free: bool,
                  t0: float) -> JointCalibrationResult:
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
    held_values = {**initial.params(), LOAD_PARAMETER: initial.youngs_modulus}
    values.update({n: float(held_values[n]) for n in problem.all_names if n not in values})
    fitted_scale = initial.material.magnetization_scale * scale
    names, cov, se, found, inflated = _uncertainty(problem, x, scale, chi2_data)
    for k, name in enumerate(_offset_names(problem)):
        values[name] = float(offsets[k])
    if problem.fit_scale:
        values["magnetization_scale"] = fitted_scale
    stderr = {n: float(s) for n, s in zip(names, se, strict=True)}
    with np.errstate(invalid="ignore", divide="ignore"):
        corr = cov / np.outer(se, se)
    corr = np.where(np.isfinite(corr), corr, np.nan)
    dof = problem.y.size - len(names)
    output_offsets = [offsets[g] for g, (_, c) in enumerate(problem.groups) if c < 0]
    fitted_setup = initial.replace(
        **{n: values[n] for n in problem.all_names},
        **_fitted_modulus(problem, initial, values, stderr), n_loops=problem.layout.n_loops,
        dipoles_per_loop=problem.layout.dipoles_per_loop, ring=problem.layout.ring,
        magnetization_scale=fitted_scale,
        offset=float(output_offsets[0]) if len(output_offsets) == 1 else initial.sensor.offset)
    fits = []
    model_full = scale * u[0] + offsets[problem.group]
    for e_i, e in enumerate(experiments):
        rows = np.nonzero(np.isin(problem.group,
                                  [g for g, (ei, _) in enumerate(problem.groups) if ei == e_i]))[0]
        measured, fitted = problem.y[rows], model_full[rows]
        groups = [g for g, (ei, _) in enumerate(problem.groups) if ei == e_i]
        if e.fields is not None:
            measured = measured.reshape(3, -1).T
            fitted = fitted.reshape(3, -1).T
        weighted = (problem.y[rows] - model_full[rows]) * problem.w[rows]
        fits.append(ExperimentFit(
            source=str(e.source), observable=e.observable, angles=np.asarray(e.angles),
            azimuths=np.asarray(e.azimuths), measured=measured, fitted=fitted,
            residuals=measured - fitted, offsets=np.asarray(offsets[groups]),
            rms=float(np.sqrt(np.mean((problem.y[rows] - model_full[rows]) ** 2))),
            chi2=float(weighted @ weighted), values=int(rows.size), load_kind=e.load_kind,
            loads=None if e.loads is None else np.asarray(e.loads)))
    notes: list[CalibrationWarning] = list(at_bound(
        {n: values[n] for n in problem.names}, {n: box[n] for n in problem.names},
        frozenset(n for w in found if w.kind == "undetermined" for n in w.parameters)))
    notes += list(found)
    if y_free and "y" in problem.names:
        notes.append(CalibrationWarning(
            "y_sign", "B_x along tilts toward azimuth 0 or π is symmetric in y, so the sign of y "
            "is not determined (the sign of the initial y is kept, + for 0); a tilt toward "
            "another azimuth or 3-axis field data determine it", ("y",)))
    lay = problem.layout
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
    return JointCalibrationResult(
        setup=fitted_setup, initial=initial, model="physical", n_loops=problem.layout.n_loops,
        dipoles_per_loop=problem.layout.dipoles_per_loop, layout_error=problem.layout.error,
        chi2=chi2, dof=dof,
        values=values, uncertainty=ParameterCovariance(names, stderr, corr, cov),
        experiments=tuple(fits), priors=dict(problem.priors),
        warnings=tuple(w.message for w in notes), diagnostics=tuple(notes),
        bounds={n: box[n] for n in problem.all_names},
        fixed={n: values[n] for n in problem.all_names if box[n][0] == box[n][1]},
        evaluations=problem.evaluations, elapsed=time.perf_counter() - t0,
    )
