"""The one calibration problem: a sum of experiments (:mod:`.experiments`) over one search vector.

:class:`Problem` owns the search vector (the fitted parameters' names and bounds, which of them
are integers), the one cost of a non-finite model (:data:`NONFINITE_COST`), and the residuals of
many parameter vectors at once (the batched Levenberg–Marquardt evaluates whole populations):
every condition's model comes from one compiled batch call per tilt azimuth
(:class:`~magcilia.model.TiltBatch`: the base centre turned by −φ, the field turned back by +φ,
:mod:`magcilia.model.azimuth`), load experiments from the bent shapes, coil experiments from the
shapes bent by each applied uniform field plus that field (:mod:`.coil_model`; their
magnetization scale, modulus and sensitivity are search parameters, their Jacobian differenced).

The linear parameters (each experiment's bias: offsets, a polynomial in the angle; the shared
magnetization scale with ``fit_scale``) are projected out in closed form (variable projection):
the weighted residuals have the weighted bias subspace removed, the scale is then the best
non-negative factor. The paper's single-path model is the problem of one unweighted
:class:`~magcilia.calibration.experiments.TiltPath` with n and k in the search vector
(:meth:`Problem.paper`); the physical model's is any sum of experiments and priors.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence

import numpy as np
from numpy.typing import NDArray

from magcilia._errors import MagciliaError
from magcilia.calibration.experiments import (
    Experiment,
    Experiments,
    Prior,
    Table,
    TiltPath,
    fluid_of,
)
from magcilia.calibration.parameters import ParameterKey
from magcilia.device.parameters import FITTED, INTEGER, default_bounds
from magcilia.device.setup import Setup
from magcilia.fitting import NONFINITE_PENALTY
from magcilia.io.recordings import Measurement
from magcilia.model.azimuth import field_from_tilt_frame, placement_in_tilt_frame
from magcilia.model.batch import JACOBIAN_NAMES, KEYS, TiltBatch

F64 = NDArray[np.float64]

#: the fitted parameters of the paper's model (the registry's
#: :data:`~magcilia.device.parameters.FITTED`), in the order of its search vector
PARAMETERS = FITTED
CONTINUOUS = tuple(n for n in PARAMETERS if n not in INTEGER)
#: default search bounds (SI), from the registry
DEFAULT_BOUNDS = default_bounds()
#: position of each parameter in the paper model's search vector
INDEX = {name: i for i, name in enumerate(PARAMETERS)}
BIASES = ("offset", "polynomial", "none")
#: the continuous parameters of the physical model, in the order of its search vector
GEOMETRY = ("height", "base_radius", "x", "y", "z")
#: the parameter load experiments add (after the geometry)
LOAD_PARAMETER = "youngs_modulus"
#: the parameters coil experiments add after the modulus (the magnetization scale: the
#: cilium's field and its bending; the bridge sensitivity, V/V/T, with a single-axis output)
COIL_PARAMETERS = ("magnetization_scale", "sensitivity")
#: the cost given to a candidate whose model is not finite (its element on a dipole, an
#: overflow, a bend that does not converge): worse than any real fit but finite, so that a
#: search's population statistics stay finite and such candidates are simply never chosen; real
#: costs are clipped to it too. Its residual rows are each ``sqrt(NONFINITE_COST / rows)``. The
#: fitter's own (:data:`magcilia.fitting.NONFINITE_PENALTY`), one number for both.
NONFINITE_COST = NONFINITE_PENALTY


class Problem:
    """The weighted least-squares problem of a sum of experiments, the linear parameters
    projected out.

    Parameters
    ----------
    experiments : Experiment or Experiments
        The data experiments and priors (``TiltPath(a) + FieldPath(b) + Prior(...)``).
    base : Setup
        Supplies every parameter not in the search vector (its offset is not used).
    names : sequence of str
        The search vector: the fitted parameters, in order (registry names; n and k integers).
    bounds : mapping of str to (low, high)
        Their bounds, SI.
    fit_scale : bool
        Also fit the magnetization scale (closed form, ≥ 0, shared by all experiments).

    Attributes
    ----------
    names : tuple of str
    bounds : ndarray, shape (p, 2)
    integer : ndarray of bool, shape (p,)
        Which parameters are whole numbers (n, k).
    measurements : tuple of Measurement
        The data experiments' recordings, in order.
    y, sigma, w : ndarray, shape (d,)
        Data values, their standard errors and weights 1/σ.
    basis : ndarray, shape (d, G)
        The bias columns of all experiments (block-diagonal, unweighted).
    bias_keys : tuple of ParameterKey, length G
        Their names.
    experiment_rows : tuple of slice
        Each data experiment's rows.
    priors : dict of str to (float, float)
    size : int
        Residual rows m: the data values, then one row per prior.
    """

    def __init__(self, experiments: Experiment | Sequence[Experiment], base: Setup,
                 names: Sequence[str], bounds: Mapping[str, tuple[float, float]],
                 fit_scale: bool = False) -> None:
        terms = Experiments(e for item in ([experiments] if isinstance(experiments, Experiment)
                                           else experiments) for e in item)
        self.terms = terms
        recorded = terms.recorded
        if not recorded:
            raise MagciliaError("a calibration problem needs at least one experiment on a "
                                "recording (TiltPath, FieldPath or LoadExperiment), not priors "
                                "alone")
        self.measurements = tuple(e.data for e in recorded)
        self.base = base.replace(offset=0.0)
        self.names = tuple(names)
        self.bounds = np.array([bounds[n] for n in self.names], dtype=np.float64).reshape(-1, 2)
        self.integer = np.array([n in INTEGER for n in self.names], dtype=bool)
        self.priors = terms.priors
        if len(self.priors) != sum(isinstance(e, Prior) for e in terms):
            raise MagciliaError("two priors on one parameter; combine them into one (value, "
                                "sigma)")
        unknown = [n for n in self.priors if n not in self.names]
        if unknown:
            raise MagciliaError(f"prior {unknown[0]}: not a fitted parameter (one of "
                                + ", ".join(self.names) + ")")
        self.fit_scale = fit_scale
        self.evaluations = 0
        tilts = [e.tilts for e in recorded if e.tilts is not None]
        x_only = (len(tilts) == len(recorded) and all(e.data.fields is None for e in recorded)
                  and all(np.all(np.mod(t[0], 2 * np.pi) == 0.0) for t in tilts))
        self.table = Table(x_only)
        if tilts:
            self.table.add_tilts(np.concatenate([t[0] for t in tilts]),
                                 np.concatenate([t[1] for t in tilts]))
        self.batches = [TiltBatch(self.base, a) for a in self.table.angles]
        rows = [e.rows(self.table, i, self.base.sensor.scale) for i, e in enumerate(recorded)]
        self.column = np.concatenate([r.column for r in rows])
        self.factor = np.concatenate([r.factor for r in rows])
        self.y = np.concatenate([r.y for r in rows])
        self.sigma = np.concatenate([r.sigma for r in rows])
        self.w = 1.0 / self.sigma
        self.weighted = not np.all(self.w == 1.0)
        self.identity = bool(np.array_equal(self.column, np.arange(self.table.width))
                             and np.all(self.factor == 1.0))
        widths = [r.basis.shape[1] for r in rows]
        self.basis = np.zeros((self.y.size, sum(widths)))
        self.bias_keys: tuple[ParameterKey, ...] = tuple(k for r in rows for k in r.keys)
        at, col, spans = 0, 0, []
        for r, g in zip(rows, widths, strict=True):
            self.basis[at:at + r.y.size, col:col + g] = r.basis
            spans.append(slice(at, at + r.y.size))
            at, col = at + r.y.size, col + g
        self.experiment_rows = tuple(spans)
        self.q = (np.linalg.qr(self.basis * self.w[:, None])[0] if self.basis.shape[1]
                  else np.zeros((self.y.size, 0)))
        self.ry = self._project(self.y)
        #: the projection is the removal of the mean (the paper's constant offset, unweighted)
        self._centred = bool(not self.weighted and self.q.shape[1] == 1
                             and np.ptp(self.q) <= 1e-15 * np.abs(self.q).max())
        self.prior_index = np.array([self.names.index(n) for n in self.priors], dtype=np.intp)
        self.prior_mu = np.array([m for m, _ in self.priors.values()])
        self.prior_sigma = np.array([s for _, s in self.priors.values()])
        self.size = self.y.size + len(self.priors)
        self._defaults = {**self.base.params(), LOAD_PARAMETER: self.base.youngs_modulus,
                          "sensitivity": self.base.sensor.sensitivity}
        self._model_names = self.all_names
        self.fluids = {i: fluid_of(e.data) for i, e in enumerate(recorded)
                       if e.data.speeds is not None}
        # rows whose value is a model field times the base's sensor scale (outputs of tilt and
        # load experiments): a fitted sensitivity rescales them
        outputs = [np.full(r.y.size, e.data.fields is None and e.data.actuation is None
                           and not self.table.x_only)
                   for e, r in zip(recorded, rows, strict=True)]
        self._output_rows = np.concatenate(outputs)
        #: the load blocks' latest solutions, to start the next population's Newton from
        self._load_starts: dict[int, dict[str, F64]] = {}
        # the analytic Jacobian: each search parameter's column of the model's derivatives
        # (−1: none, n and k), and for one output path toward azimuth 0 the rows' columns of the
        # packed parameters (rows in, no names: the fitter's once-per-iteration call)
        self._jcols = np.array([JACOBIAN_NAMES.index(n) if n in JACOBIAN_NAMES else -1
                                for n in self.names], dtype=np.intp)
        self._jscale = (self._jcols >= 0).astype(np.float64)
        self._keys = (np.array([KEYS.index(n) for n in self.names], dtype=np.intp)
                      if all(n in KEYS for n in self.names) else None)
        self._rows_path = (self._keys is not None and self.table.x_only
                           and len(self.batches) == 1 and self.analytic)

    @classmethod
    def paper(cls, data: Measurement, initial: Setup, bias: str = "offset", bias_degree: int = 0,
              fit_scale: bool = False,
              bounds: Mapping[str, tuple[float, float]] | None = None) -> Problem:
        """The paper's model: one unweighted output tilt path (cost in V²), ``bias`` of
        :data:`BIASES` (``"polynomial"`` of ``bias_degree``), the search vector
        :data:`PARAMETERS` (n and k included)."""
        degree = None if bias == "none" else 0 if bias == "offset" else bias_degree
        return cls(TiltPath(data, weighted=False, bias_degree=degree), initial, PARAMETERS,
                   {**DEFAULT_BOUNDS, **(bounds or {})}, fit_scale)

    # -- the search vector --------------------------------------------------------------------
    @property
    def all_names(self) -> tuple[str, ...]:
        """Every continuous parameter of the physical model (fitted or held): the geometry, then
        the Young's modulus when there are load or coil experiments, then with coil experiments
        the magnetization scale and (a single-axis output among them) the sensitivity."""
        coil: tuple[str, ...] = ()
        if self.table.coils:
            coil = COIL_PARAMETERS if any(
                self.measurements[e].fields is None for e, _, _ in self.table.coils
            ) else COIL_PARAMETERS[:1]
        return GEOMETRY + ((LOAD_PARAMETER,) if self.table.loads or self.table.coils
                           else ()) + coil

    @property
    def load_blocks(self) -> list[tuple[int, float, F64, int]]:
        """The load experiments' blocks (experiment, azimuth, sorted loads, first column)."""
        return self.table.loads

    def params(self, P: F64 | Mapping[str, F64]) -> dict[str, F64]:
        """Parameter columns by name, each (N,), SI: from rows ``P`` (N, p) of search vectors (or
        one vector (p,)), or named columns as given; the model's other parameters at the base
        setup's values."""
        if isinstance(P, Mapping):
            cols = {k: np.asarray(val, dtype=np.float64) for k, val in P.items()}
        else:
            P = np.atleast_2d(np.asarray(P, dtype=np.float64))
            cols = {n: P[:, i] for i, n in enumerate(self.names)}
        missing = [n for n in self._model_names if n not in cols]
        if missing:
            size = max((c.size for c in cols.values()), default=1)
            cols.update({n: np.full(size, float(self._defaults[n])) for n in missing})
        return cols

    # -- the model ----------------------------------------------------------------------------
    def model(self, P: F64 | Mapping[str, F64]) -> F64:
        """Unbiased model values at every data row, shape (N, d): output (V) or field component
        (T), at the base setup's magnetization scale (unchecked: non-finite where a set puts the
        element on a dipole; :meth:`residuals` penalises those)."""
        prm = self.params(P)
        n = prm["x"].size
        self.evaluations += n
        parts = [np.zeros((n, 0))]
        for phi, batch in zip(self.table.azimuths, self.batches, strict=True):
            if self.table.x_only:
                parts.append(batch.output(prm))
                continue
            x, y = placement_in_tilt_frame(prm["x"], prm["y"], phi)
            b = batch.field({**prm, "x": x, "y": y})
            if phi != 0.0:
                b = field_from_tilt_frame(b, phi)
            parts.append(b.reshape(n, -1))
        if self.table.loads or self.table.coils:  # each block at its own columns
            full = np.empty((n, self.table.width))
            tilt = sum(p.shape[1] for p in parts)
            full[:, :tilt] = np.concatenate(parts, axis=1)
            if self.table.loads:
                loads = self._load_fields(prm)
                if "magnetization_scale" in prm:  # (the bend does not depend on it: the field)
                    loads = loads * (prm["magnetization_scale"][:, None]
                                     / self.base.material.magnetization_scale)
                at = 0
                for _, _, values, first in self.table.loads:
                    full[:, first:first + 3 * values.size] = loads[:, at:at + 3 * values.size]
                    at += 3 * values.size
            for (_, first, width), block in zip(self.table.coils, self._coil_values(prm),
                                                strict=True):
                full[:, first:first + width] = block
        else:
            full = parts[1] if len(parts) == 2 else np.concatenate(parts, axis=1)
        out = full if self.identity else full[:, self.column] * self.factor
        if "sensitivity" in prm and self._output_rows.any():
            out = np.where(self._output_rows, out * (prm["sensitivity"][:, None]
                                                     / self.base.sensor.sensitivity), out)
        return out

    @property
    def analytic(self) -> bool:
        """Whether :meth:`model_jacobian` is analytic: every experiment a tilt (load and coil
        experiments bend the cilium; their columns are differenced) and no fitted parameter
        beyond the tilt model's."""
        return not self.table.loads and not self.table.coils and all(
            n in GEOMETRY or n in ("n_loops", "dipoles_per_loop") for n in self.names)

    def model_jacobian(self, P: F64 | Mapping[str, F64],
                       columns: NDArray[np.intp] | None = None) -> tuple[F64, F64]:
        """:meth:`model` (N, d) and its derivatives (N, d, c) with respect to the search vector
        (or its ``columns``, c of them), in the same compiled pass
        (:meth:`~magcilia.model.TiltBatch.output_jacobian`: closed form, no differences); zero
        columns for the integers n and k. Tilt experiments only (:attr:`analytic`)."""
        if not self.analytic:
            raise MagciliaError("model_jacobian: load experiments have no analytic Jacobian; "
                                "use Problem.jacobian")
        cols = self._jcols if columns is None else self._jcols[columns]
        keep = self._jscale if columns is None else self._jscale[columns]
        if self._rows_path and self._keys is not None and isinstance(P, np.ndarray):
            rows = P if P.ndim == 2 else np.atleast_2d(P)
            self.evaluations += rows.shape[0]
            u, ju = self.batches[0].output_jacobian_rows(self._keys, rows)
            jac = ju[:, :, np.maximum(cols, 0)]
            if not keep.all():
                jac *= keep
            if self.identity:
                return u, jac
            return u[:, self.column] * self.factor, jac[:, self.column] * self.factor[:, None]
        prm = self.params(P)
        n = prm["x"].size
        self.evaluations += n
        values, derivs = [], []
        for phi, batch in zip(self.table.azimuths, self.batches, strict=True):
            if self.table.x_only:
                u, ju = batch.output_jacobian(prm)
                values.append(u)
                derivs.append(ju)
                continue
            x, y = placement_in_tilt_frame(prm["x"], prm["y"], phi)
            b, jb = batch.field_jacobian({**prm, "x": x, "y": y})
            if phi != 0.0:  # the placement turned by −φ, the field back by +φ
                c, s = np.cos(phi), np.sin(phi)
                dx, dy = jb[..., 2].copy(), jb[..., 3].copy()
                jb[..., 2], jb[..., 3] = c * dx - s * dy, s * dx + c * dy
                b = field_from_tilt_frame(b, phi)
                jb = np.moveaxis(field_from_tilt_frame(np.moveaxis(jb, -1, -2), phi), -1, -2)
            values.append(b.reshape(n, -1))
            derivs.append(jb.reshape(n, -1, jb.shape[-1]))
        full = values[0] if len(values) == 1 else np.concatenate(values, axis=1)
        jfull = derivs[0] if len(derivs) == 1 else np.concatenate(derivs, axis=1)
        jac = jfull[:, :, np.maximum(cols, 0)] * keep
        if self.identity:
            return full, jac
        return full[:, self.column] * self.factor, jac[:, self.column] * self.factor[:, None]

    def residuals_jacobian(self, P: F64 | Mapping[str, F64]) -> tuple[F64, F64]:
        """:meth:`residuals` (N, m) and their exact Jacobian (N, m, p) with respect to the search
        vector (variable projection: the bias projected out of the model's derivatives, and with
        ``fit_scale`` the scale's own derivative). A set whose model is not finite gets the
        penalty rows and a zero Jacobian. Tilt experiments only (:attr:`analytic`)."""
        r, jac = self.data_residuals_jacobian(P)
        with np.errstate(invalid="ignore", over="ignore"):
            bad = ~(np.isfinite(np.einsum("nd,nd->n", r, r))
                    & np.isfinite(jac).all(axis=(1, 2)))
        r[bad] = np.sqrt(NONFINITE_COST / max(r.shape[1], 1))
        jac[bad] = 0.0
        if not self.priors:
            return r, jac
        cols = self.params(P)
        prior = np.stack([(cols[n] - mu) / s for n, (mu, s) in self.priors.items()], axis=1)
        jp = np.zeros((r.shape[0], len(self.priors), len(self.names)))
        jp[:, np.arange(len(self.priors)), self.prior_index] = 1.0 / self.prior_sigma
        return np.concatenate([r, prior], axis=1), np.concatenate([jac, jp], axis=1)

    def data_residuals_jacobian(self, P: F64 | Mapping[str, F64],
                                columns: NDArray[np.intp] | None = None) -> tuple[F64, F64]:
        """The data rows of :meth:`residuals_jacobian` as the linear step leaves them (N, d),
        non-finite where the model is (the batched fitter's bad points), and their Jacobian
        (N, d, c) with respect to the search vector (or its ``columns``)."""
        u, ju = self.model_jacobian(P, columns)
        with np.errstate(invalid="ignore", over="ignore", divide="ignore"):
            pu = self._project(u)
            pj = self._project_columns(ju)
            if not self.fit_scale:
                return self.ry - pu, np.negative(pj, out=pj)
            den = np.einsum("nd,nd->n", pu, pu)
            safe = np.where(den > 0, den, 1.0)
            a = np.where(den > 0, np.einsum("nd,d->n", pu, self.ry) / safe, 0.0)
            positive = a > 0.0
            a = np.maximum(a, 0.0)
            da = np.where(positive[:, None],
                          (np.einsum("ndp,d->np", pj, self.ry)
                           - 2.0 * a[:, None] * np.einsum("ndp,nd->np", pj, pu))
                          / safe[:, None], 0.0)
            return (self.ry - a[:, None] * pu,
                    -(a[:, None, None] * pj + pu[:, :, None] * da[:, None, :]))

    def _project_columns(self, j: F64) -> F64:
        """:meth:`_project` of each column of ``j`` (N, d, c) along d (a new array)."""
        if self._centred:  # one constant bias column, unweighted: remove the mean
            return np.subtract(j, j.mean(axis=1, keepdims=True), out=np.empty(j.shape))
        jw = j * self.w[:, None] if self.weighted else j
        if not self.q.shape[1]:
            return jw.copy()
        return jw - self.q @ (self.q.T @ jw)

    def _load_fields(self, prm: Mapping[str, F64]) -> F64:
        """The load blocks' fields, (N, 3 · loads), T: every set's bent shapes under each
        block's sorted loads and their field, all sets at once
        (:func:`~magcilia.calibration.load_model.load_fields`: as
        :func:`~magcilia.mechanics.bend.bend_sweep` and :meth:`Setup.field` give them); NaN for a
        set whose bend does not converge or whose geometry is invalid."""
        from magcilia.calibration.load_model import load_fields  # (bending: load data only)

        return load_fields(self.base, self.table.loads, self.measurements, self.fluids, prm,
                           self._load_starts)

    def _coil_values(self, prm: Mapping[str, F64]) -> list[F64]:
        """The coil blocks' model values, each (N, width): each coil experiment's outputs (V) or
        fields (T) with the applied field included
        (:func:`~magcilia.calibration.coil_model.coil_block`); NaN for a set whose model fails."""
        from magcilia.calibration.coil_model import coil_block  # (bending: coil data only)

        return [coil_block(self.base, self.measurements[e], prm) for e, _, _ in self.table.coils]

    # -- residuals ----------------------------------------------------------------------------
    def _project(self, z: F64) -> F64:
        """Weighted values with the weighted bias subspace removed (last axis)."""
        if getattr(self, "_centred", False):  # one constant bias column, unweighted
            return z - z.mean(axis=-1, keepdims=True)
        zw = z * self.w if self.weighted else z
        return zw - (zw @ self.q) @ self.q.T

    def linear(self, u: F64) -> tuple[F64, F64]:
        """Projected weighted residuals (N, d) and the fitted scale factors (N,) for model values
        ``u`` (N, d) (rows with a non-finite model give non-finite residuals)."""
        with np.errstate(invalid="ignore", over="ignore", divide="ignore"):
            pu = self._project(u)
            if self.fit_scale:
                den = np.einsum("nd,nd->n", pu, pu)
                a = np.where(den > 0, np.einsum("nd,d->n", pu, self.ry)
                             / np.where(den > 0, den, 1.0), 0.0)
                a = np.maximum(a, 0.0)
            else:
                a = np.ones(u.shape[0])
            return self.ry - a[:, None] * pu, a

    def _rows(self, P: F64 | Mapping[str, F64]) -> tuple[F64, NDArray[np.bool_], F64]:
        """Data rows (N, d), which sets have a non-finite model (N,), prior rows (N, q)."""
        prm = P if isinstance(P, Mapping) else np.atleast_2d(np.asarray(P, dtype=np.float64))
        r, _ = self.linear(self.model(prm))
        with np.errstate(invalid="ignore", over="ignore"):
            bad = ~np.isfinite(np.einsum("nd,nd->n", r, r))
        cols = self.params(prm) if self.priors else {}
        prior = (np.stack([(cols[n] - mu) / s for n, (mu, s) in self.priors.items()], axis=1)
                 if self.priors else np.zeros((r.shape[0], 0)))
        return r, bad, prior

    def residuals(self, P: F64 | Mapping[str, F64]) -> F64:
        """Weighted residuals, shape (N, m): the data rows ``(measured − model − bias)/s.e.``
        with the linear parameters at their best values, then the prior rows ``(p − μ)/σ``; a set
        whose model is not finite gets data rows ``sqrt(NONFINITE_COST / d)`` (a least-squares
        solver sees a cost of about :data:`NONFINITE_COST`)."""
        r, bad, prior = self._rows(P)
        r[bad] = np.sqrt(NONFINITE_COST / max(r.shape[1], 1))
        return np.concatenate([r, prior], axis=1) if self.priors else r

    def cost(self, P: F64 | Mapping[str, F64]) -> F64:
        """Sum of squared weighted residuals (χ² with the priors; V² for the unweighted paper
        model), shape (N,): :data:`NONFINITE_COST` where the model is not finite (or the cost
        exceeds it)."""
        r, bad, prior = self._rows(P)
        with np.errstate(invalid="ignore", over="ignore"):
            c = np.einsum("nd,nd->n", r, r) + np.einsum("nq,nq->n", prior, prior)
        return np.where(np.isfinite(c) & ~bad, np.minimum(c, NONFINITE_COST), NONFINITE_COST)

    def jacobian(self, p: F64) -> F64:
        """Jacobian of :meth:`residuals` at one set ``p`` (p,), shape (m, p): analytic for tilt
        experiments (:meth:`residuals_jacobian`); with load experiments, the data rows by
        central differences (steps 1e-5 of each bound's width, one vectorised call), the prior
        rows exact (each :class:`~magcilia.calibration.experiments.Prior`'s own)."""
        p = np.asarray(p, dtype=np.float64)
        if self.analytic:
            return np.asarray(self.residuals_jacobian(p[None, :])[1][0])
        h = 1e-5 * (self.bounds[:, 1] - self.bounds[:, 0])
        eye = np.eye(p.size) * h
        r, bad, _ = self._rows(np.concatenate([p + eye, p - eye]))
        r[bad] = np.sqrt(NONFINITE_COST / max(r.shape[1], 1))
        data = ((r[:p.size] - r[p.size:]) / (2 * h[:, None])).T
        priors = [e.jacobian(self.names) for e in self.terms if isinstance(e, Prior)]
        return np.asarray(np.concatenate([data, np.reshape(priors, (-1, p.size))], axis=0))

    # -- the linear parameters ----------------------------------------------------------------
    def bias(self, u: F64, scale: float) -> F64:
        """The bias parameters (:attr:`bias_keys`), (G,): the weighted least-squares fit of
        measured − scale·model (V, V/rad^d, T)."""
        if not self.basis.shape[1]:
            return np.zeros(0)
        coef, *_ = np.linalg.lstsq(self.basis * self.w[:, None], (self.y - scale * u) * self.w,
                                   rcond=None)
        return np.asarray(coef)

    #: the paper model's name of :meth:`bias` (constant first)
    bias_coefficients = bias
    #: the physical model's name of :meth:`bias` (one offset per group)
    offsets = bias


def named(x: F64) -> dict[str, F64]:
    """Parameter columns by name, each shape (S,), from a search vector (p,) or matrix (p, S) in
    :data:`PARAMETERS` order (the paper model's search vector)."""
    x2 = np.asarray(x, dtype=np.float64).reshape(len(PARAMETERS), -1)
    return {name: x2[i] for i, name in enumerate(PARAMETERS)}
