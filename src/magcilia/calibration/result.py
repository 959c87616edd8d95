"""The result of every calibration: one :class:`CalibrationResult`, whether the paper's model
fitted to one tilt path or the physical model fitted to several experiments (``model``), with
the :class:`~magcilia.calibration.covariance.ParameterCovariance` that read-out needs of it.

``JointCalibrationResult`` is the same class under its earlier name.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import NDArray

from magcilia import _validate as v
from magcilia._display import Display, Item, Table, count, dataframe, number, rows_table, si
from magcilia._errors import MagciliaError
from magcilia.calibration.covariance import ParameterCovariance, Uncertain
from magcilia.calibration.diagnostics import CalibrationWarning
from magcilia.calibration.experiment_fit import ExperimentFit
from magcilia.calibration.parameters import FitParameter, ParameterKey
from magcilia.calibration.problem import GEOMETRY, LOAD_PARAMETER, PARAMETERS
from magcilia.calibration.reload import rebuild
from magcilia.calibration.temperature import temperature_doc, temperature_lines
from magcilia.calibration.truth import SIZES, truth_comparison
from magcilia.device.parameters import PARAMETERS as REGISTRY
from magcilia.device.setup import Setup
from magcilia.io.recordings import Measurement
from magcilia.io.results import read_json
from magcilia.io.setup_files import load_setup, setup_to_dict
from magcilia.units import converted

if TYPE_CHECKING:
    from magcilia.calibration.posterior import Posterior

F64 = NDArray[np.float64]

__all__ = ["GEOMETRY", "SIZES", "CalibrationResult", "ExperimentFit", "JointCalibrationResult",
           "ParameterCovariance"]

#: the rows of a paper fit's parameter table, and of a physical fit's
PAPER_ROWS = (*PARAMETERS, "magnetization_scale", "offset")
PHYSICAL_ROWS = (*GEOMETRY, LOAD_PARAMETER, "magnetization_scale")


def _empty() -> F64:
    return np.zeros(0)


@dataclass(frozen=True, eq=False, repr=False)
class CalibrationResult(Uncertain, Display):
    """The outcome of :func:`~magcilia.calibration.calibrate` (immutable), for either model.

    Attributes
    ----------
    setup : Setup
        The fitted setup (same interface as ``Setup.paper(...)``); its ``output`` includes the
        fitted offset (one output experiment) and magnetization scale.
    initial : Setup
        The starting setup.
    values : dict of str to float
        Fitted parameters (SI), keyed by display label: the geometry (and n, k for the paper's
        model; the Young's modulus with load experiments), the magnetization scale, the offsets
        (``offset``; ``offset_x``… of a 3-axis experiment, ``[i]`` per experiment when there are
        several: :attr:`keys` names them structurally).
    uncertainty : ParameterCovariance
        Their 1-σ standard errors, correlations and covariance from the Jacobian; also as the
        attributes ``stderr``, ``correlation``, ``correlation_names`` and ``covariance``.
    warnings : tuple of str
        Plain-language warnings (the texts of ``diagnostics``).
    bounds : dict of str to (float, float)
        The search bounds (SI).
    evaluations : int
        Model evaluations (parameter sets).
    elapsed : float
        Wall time, s.
    diagnostics : tuple of CalibrationWarning
        The warnings as records with a ``kind`` and the ``parameters`` they concern.
    fixed : dict of str to float
        Parameters held at a value instead of fitted, SI; they have no standard error.
    model : {"paper", "physical"}
        The paper's model (n, k searched, one tilt path, cost in V²) or the physical one (n, k
        at a converged layout, weighted residuals, several experiments, priors).
    experiments : tuple of ExperimentFit
        Each experiment's data, fitted model and residuals.
    chi2 : float
        Sum of squared weighted residuals, priors included (the paper's model: the cost, V²).
    dof : int
        Data values − fitted parameters (linear ones included).
    priors : dict of str to (float, float)
        The Gaussian priors (value, σ), SI.
    layout_error : float
        The physical layout's max relative field error against the exact body at the initial
        setup (NaN: given by hand, or the paper's model).
    posterior : Posterior or None
        Samples of the posterior of the fitted geometry (``posterior=True``), else None.
    keys : dict of str to ParameterKey
        The structural name of each key of ``values`` (code compares keys, never labels).
    data : Measurement or None
        The tilt path of a paper fit (None for the physical model).
    cost : float
        The paper's cost: Σ (mean measured − model)², V² (NaN for the physical model).
    rms : float
        sqrt(cost / angles), V (NaN for the physical model: each experiment has its ``rms``).
    residuals : ndarray, shape (a,)
        Measured − fitted model, V (paper fit; empty otherwise).
    bias_coefficients : ndarray
        The paper fit's bias polynomial (constant first; V, V/rad, …).
    bias : str
        Its bias model (``"offset"``, ``"polynomial"``, ``"none"``).
    restart_costs : tuple of float
        Final cost of each restart of the paper's search, V².
    truth : dict of str to float or None
        Known true values (SI) of a synthetic recording (see :meth:`with_truth`).
    temperature_range : (float, float) or None
        The lowest and highest temperature of the samples fitted, K, where the recordings carry
        a temperature column (:attr:`~magcilia.Measurement.temperature_range`; over all of
        them), else None: the fitted parameters hold over this range, and a read-out flags
        readings outside it (:mod:`magcilia.calibration.temperature`).
    temperature_mean : float
        The mean temperature of those samples, K (NaN without): the temperature the fitted
        parameters are at, the reference of the temperature compensation.
    """

    setup: Setup
    initial: Setup
    values: dict[str, float]
    uncertainty: ParameterCovariance
    warnings: tuple[str, ...]
    bounds: dict[str, tuple[float, float]]
    evaluations: int
    elapsed: float
    diagnostics: tuple[CalibrationWarning, ...] = field(default=())
    fixed: dict[str, float] = field(default_factory=dict)
    model: str = "paper"
    experiments: tuple[ExperimentFit, ...] = field(default=())
    chi2: float = math.nan
    dof: int = 0
    priors: dict[str, tuple[float, float]] = field(default_factory=dict)
    layout_error: float = math.nan
    posterior: Posterior | None = None
    keys: dict[str, ParameterKey] = field(default_factory=dict)
    data: Measurement | None = None
    cost: float = math.nan
    rms: float = math.nan
    residuals: F64 = field(default_factory=_empty)
    bias_coefficients: F64 = field(default_factory=_empty)
    bias: str = "offset"
    restart_costs: tuple[float, ...] = field(default=())
    truth: dict[str, float] | None = None
    temperature_range: tuple[float, float] | None = None
    temperature_mean: float = math.nan

    # -- what both models have ----------------------------------------------------------------
    @property
    def n_loops(self) -> int:
        """Slices of the fitted setup's dipole layout (searched, or the physical layout's)."""
        return int(self.setup.params()["n_loops"])

    @property
    def dipoles_per_loop(self) -> int:
        """Dipoles per slice of the fitted setup's layout."""
        return int(self.setup.params()["dipoles_per_loop"])

    @property
    def path(self) -> Measurement:
        """The one tilt path a paper fit fitted (:attr:`data`); an error for the physical model,
        whose :attr:`experiments` hold its data."""
        if self.data is None:
            raise MagciliaError(f"this {self.model} calibration fitted {len(self.experiments)} "
                                "experiment(s), not one tilt path: see its experiments")
        return self.data

    @property
    def fitted(self) -> F64:
        """Fitted model at the measured angles, V, shape (a,) (bias included; paper fit)."""
        return self.path.volts - self.residuals

    def key(self, label: str) -> ParameterKey:
        """The structural name of the key ``label`` of :attr:`values` (a registry name is its
        own key)."""
        return self.keys.get(label, ParameterKey(label))

    @property
    def parameters(self) -> tuple[FitParameter, ...]:
        """Every parameter of the fit as an object (lmfit's ``Parameter``): key, value, bounds,
        fixed, prior, standard error, unit; in the order of :attr:`values`."""
        out = []
        for label, value in self.values.items():
            key = self.key(label)
            out.append(FitParameter(
                key=key, label=label, value=float(value),
                bounds=tuple(self.bounds.get(label, (math.nan, math.nan))),  # type: ignore[arg-type]
                fixed=label in self.fixed, prior=self.priors.get(label),
                stderr=float(self.stderr.get(label, math.nan)), unit=key.unit))
        return tuple(out)

    def undetermined(self) -> tuple[str, ...]:
        """Parameters the data (and priors) leave undetermined."""
        return tuple(dict.fromkeys(n for w in self.diagnostics if w.kind == "undetermined"
                                   for n in w.parameters))

    def table(self, si: bool = False) -> list[dict[str, Any]]:
        """Table-I-style rows: parameter, unit, initial, fitted, stderr (display units: mm, mV;
        SI with ``si``), fixed; the physical model's with the prior value and σ (NaN without
        one), a paper fit's with :attr:`truth` (NaN where not known) when it has one."""
        init = {**self.initial.params(), LOAD_PARAMETER: self.initial.youngs_modulus}
        physical = self.model == "physical"
        rows = []
        for name in PHYSICAL_ROWS if physical else PAPER_ROWS:
            if name not in self.values:
                continue
            p = REGISTRY[name]
            unit, factor = (p.unit, 1.0) if si else (p.display, p.display_factor)
            scale = 1.0 / factor  # (converted: 0.1801 mm echoes as 0.1801, not ...998)
            row = {"parameter": name, "unit": unit, "initial": converted(init[name], scale),
                   "fitted": converted(self.values[name], scale),
                   "stderr": converted(self.stderr.get(name, math.nan), scale),
                   "fixed": name in self.fixed}
            if physical:
                mu, sig = self.priors.get(name, (math.nan, math.nan))
                row.update(prior=converted(mu, scale), prior_sigma=converted(sig, scale))
            if self.truth is not None:
                row["truth"] = converted(self.truth.get(name, math.nan), scale)
            rows.append(row)
        return rows

    def with_truth(self, truth: Mapping[str, float]) -> CalibrationResult:
        """This result with the known true values (SI) of a synthetic recording, which
        :meth:`table`, :meth:`report` and the markdown report then show beside the fit, with
        :meth:`truth_comparison`'s explanation (``magcilia demo`` does this with the bundled
        recording's truth)."""
        known = PAPER_ROWS if self.model == "paper" else (*PHYSICAL_ROWS, "offset")
        checked: dict[str, float] = {}
        for name, value in truth.items():
            if name not in known:
                raise v.fail("truth key", name, "one of " + ", ".join(known))
            checked[name] = v.real(f"truth[{name!r}]", value, REGISTRY[name].unit)
        return replace(self, truth=checked)

    def truth_comparison(self) -> list[str]:
        """Plain-text lines comparing a paper fit with :attr:`truth` ([] without one): how well
        the fit and the truth reproduce the data, which parameters agree within 3 standard
        errors, which the data leave undetermined, and what would pin them down."""
        return truth_comparison(self)

    # -- for people ---------------------------------------------------------------------------
    def report(self, si: bool = False) -> str:
        """Plain text: the fit's quality, the temperatures of the samples fitted (where the
        recordings carry one), the parameter table (display units, SI with ``si``; priors or
        the truth where known), each experiment's fit (physical model), what is still
        undetermined, the warnings."""
        return "\n".join(self._head(si) + temperature_lines(self) + self._table_lines(si)
                         + self._tail())

    def _head(self, si: bool) -> list[str]:
        if self.model == "paper":
            rms = f"{self.rms:.4g} V" if si else f"{self.rms * 1e3:.4g} mV"
            return [f"calibration of {self.path.source}: {len(self.path)} angles",
                    f"cost {self.cost:.6g} V^2 (sum of squared residuals), RMS {rms}"]
        err = ("" if not math.isfinite(self.layout_error)
               else f", {self.layout_error:.2g} max relative field error against the exact body")
        return [(f"joint calibration ({self.model} model: n={self.n_loops}, "
                 f"k={self.dipoles_per_loop}, rms ring{err}) of {len(self.experiments)} "
                 "experiment(s)"),
                (f"chi2 {self.chi2:.6g} for {self.dof} degrees of freedom (reduced "
                 f"{self.chi2 / max(self.dof, 1):.3g})")]

    def _table_lines(self, si: bool) -> list[str]:
        physical, truth = self.model == "physical", self.truth is not None
        last = f" {'prior':>20}" if physical else f" {'truth':>12}" if truth else ""
        lines = [f"{'parameter':<20} {'unit':<4} {'initial':>12} {'fitted':>12} "
                 f"{'std. error':>12}" + last]
        for r in self.table(si):
            se = ("fixed" if r["fixed"] else f"{r['stderr']:.4g}" if math.isfinite(r["stderr"])
                  else "undetermined" if r["stderr"] == math.inf else "-")
            if physical:
                extra = " " + (f"{r['prior']:.4g} ± {r['prior_sigma']:.3g}"
                               if math.isfinite(r["prior"]) else "-").rjust(20)
            else:
                extra = (" " + (f"{r['truth']:12.6g}" if math.isfinite(r["truth"])
                                else f"{'-':>12}")) if truth else ""
            lines.append(f"{r['parameter']:<20} {r['unit']:<4} {r['initial']:12.6g} "
                         f"{r['fitted']:12.6g} {se:>12}" + extra)
        return lines

    def _tail(self) -> list[str]:
        if self.model == "paper":
            return [f"warning: {w}" for w in self.warnings] + self.truth_comparison()
        lines = ["experiments:", *(f"- {e.line()}" for e in self.experiments)]
        und = self.undetermined()
        by_prior = tuple(dict.fromkeys(n for w in self.diagnostics if w.kind == "prior_only"
                                       for n in w.parameters))
        lines.append("still undetermined: " + (", ".join(und) if und else (
            "nothing (every fitted parameter is determined"
            + (f"; {', '.join(by_prior)} through the priors alone)" if by_prior else ")"))))
        lines += [f"warning: {w}" for w in self.warnings]
        if self.posterior is not None:
            lines.append(self.posterior.report())
        return lines

    # -- files ----------------------------------------------------------------------------------
    def to_dict(self) -> dict[str, Any]:
        """JSON-ready content (SI; the posterior's summary, not its samples). A paper fit keeps
        the keys of a single tilt path (``cost_V2``, ``angle_deg``, ``measured_V``, …), a
        physical one its experiments; both add ``model``, the setups (``setup``, ``initial``:
        setup-file tables) and the parameters' structural names (``parameters``), which
        :meth:`from_dict` reads back."""
        common = {
            "model": self.model, "values": dict(self.values), **self.uncertainty.to_dict(),
            "warnings": list(self.warnings),
            "diagnostics": [{"kind": w.kind, "parameters": list(w.parameters),
                             "message": w.message} for w in self.diagnostics],
            "bounds": {k: list(b) for k, b in self.bounds.items()}, "fixed": dict(self.fixed),
            "table": self.table(), "evaluations": self.evaluations, "elapsed_s": self.elapsed,
            "parameters": [p.to_dict() for p in self.parameters],
            "setup": setup_to_dict(self.setup), "initial": setup_to_dict(self.initial),
            "temperature_K": temperature_doc(self)}
        if self.model == "paper":
            return {
                "source": self.path.source, "cost_V2": self.cost, "rms_V": self.rms, **common,
                "bias": self.bias, "bias_coefficients": self.bias_coefficients.tolist(),
                "angle_deg": self.path.angles_deg.tolist(), "measured_V": self.path.volts.tolist(),
                "fitted_V": self.fitted.tolist(), "residual_V": self.residuals.tolist(),
                "restart_costs_V2": list(self.restart_costs),
                "measurement": self.path.to_dict(),
                **({"truth": dict(self.truth)} if self.truth is not None else {})}
        return {
            "posterior": None if self.posterior is None else self.posterior.to_dict(),
            "n_loops": self.n_loops, "dipoles_per_loop": self.dipoles_per_loop,
            "layout_error": self.layout_error, "chi2": self.chi2, "dof": self.dof, **common,
            "priors": {k: list(p) for k, p in self.priors.items()},
            "experiments": [e.to_dict() for e in self.experiments]}

    @classmethod
    def from_dict(cls, doc: Mapping[str, Any], setup: Setup | None = None,
                  initial: Setup | None = None, source: str = "calibration") -> CalibrationResult:
        """Rebuild from :meth:`to_dict` output, or from a ``result.json`` of an earlier release
        (paper or joint; their files hold no setups: give the fitted ``setup``, e.g. the
        ``fitted_setup.toml`` beside it, which :meth:`load` reads; the initial setup then has
        the table's initial values). A posterior's samples are not stored: ``posterior`` is
        None."""
        return rebuild(cls, doc, setup, initial, source)

    @classmethod
    def load(cls, path: str | Path) -> CalibrationResult:
        """Read ``result.json`` written by ``magcilia calibrate`` (or its ``--out`` folder), with
        the ``fitted_setup.toml`` beside it when the file holds no setup (earlier releases)."""
        p, doc = read_json(path, default_name="result.json",
                           hint="give the result.json (or the --out folder) of magcilia calibrate")
        setup = None
        if "setup" not in doc and (p.parent / "fitted_setup.toml").is_file():
            setup = load_setup(p.parent / "fitted_setup.toml")
        return cls.from_dict(doc, setup=setup, source=str(p))

    # -- display ------------------------------------------------------------------------------
    def _display_items(self) -> list[Item]:
        if self.model == "paper":
            return [("cost", si(self.cost, "V²")), ("rms", si(self.rms, "V")),
                    ("", count(len(self.path), "angle")),
                    ("", count(len(self.warnings), "warning")),
                    ("source", self.path.source), ("bias", self.bias),
                    ("evaluations", str(self.evaluations)), ("elapsed", si(self.elapsed, "s")),
                    *(("warning", w) for w in self.warnings)]
        return [("model", f"{self.model} (n={self.n_loops}, k={self.dipoles_per_loop})"),
                ("chi2", number(self.chi2)), ("dof", str(self.dof)),
                ("", count(len(self.experiments), "experiment")),
                ("", count(len(self.warnings), "warning")),
                ("elapsed", si(self.elapsed, "s")),
                *(("experiment", e.line()) for e in self.experiments),
                *(("warning", w) for w in self.warnings)]

    def _display_table(self) -> Table | None:
        return rows_table(self.table())

    def to_dataframe(self) -> Any:
        """The parameter table as a ``pandas.DataFrame``, one row per parameter, SI:
        ``parameter``, ``unit`` (its SI unit, "" for numbers), ``initial``, ``fitted``,
        ``stderr`` (inf: undetermined), ``lower``, ``upper`` (the bounds; NaN where fixed by
        the model rather than bounded) and, for the physical model, ``prior``, ``prior_sigma``."""
        rows = self.table(si=True)
        names = [r["parameter"] for r in rows]
        bounds = [self.bounds.get(n, (math.nan, math.nan)) for n in names]
        cols: dict[str, Any] = {
            "parameter": names, "unit": [r["unit"] for r in rows],
            "initial": [float(r["initial"]) for r in rows],
            "fitted": [float(r["fitted"]) for r in rows],
            "stderr": [float(r["stderr"]) for r in rows],
            "lower": [float(b[0]) for b in bounds], "upper": [float(b[1]) for b in bounds]}
        if self.model == "physical":
            cols["prior"] = [float(r["prior"]) for r in rows]
            cols["prior_sigma"] = [float(r["prior_sigma"]) for r in rows]
        return dataframe(cols)


#: the joint calibration's result under its earlier name: the same class (``model``
#: says which model was fitted)
JointCalibrationResult = CalibrationResult
