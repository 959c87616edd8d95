"""Results of a calibration: :class:`CalibrationResult` and the :class:`ParameterCovariance` that
read-out needs of it."""

from __future__ import annotations

import itertools
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
from magcilia.calibration.diagnostics import CalibrationWarning
from magcilia.calibration.problem import INTEGER, PARAMETERS
from magcilia.device.parameters import PARAMETERS as REGISTRY
from magcilia.device.setup import Setup
from magcilia.io.recordings import Measurement
from magcilia.io.results import read_json

if TYPE_CHECKING:
    from magcilia.calibration.posterior import Posterior

F64 = NDArray[np.float64]
#: the parameters that carry the size (undetermined together by the scale symmetry)
SIZES = frozenset(("height", "base_radius"))


@dataclass(frozen=True, eq=False, repr=False)
class ParameterCovariance(Display):
    """Standard errors and correlations of calibrated parameters: what read-out needs of a
    calibration (a :class:`CalibrationResult` holds one as ``uncertainty``).

    Attributes
    ----------
    correlation_names : tuple of str
        Parameter names (continuous ones, ``magnetization_scale``, ``offset``, ``bias_<d>``).
    stderr : dict of str to float
        1-σ standard errors, SI (inf where undetermined).
    correlation : ndarray, shape (p, p)
        Correlation matrix of ``correlation_names`` (NaN where undefined).
    covariance : ndarray, shape (p, p), or None
        σ² (JᵀJ)⁺ (SI): the covariance of the combinations the data determine, zero along the
        undetermined ones, so that J C Jᵀ gives the uncertainty of anything that does not change
        along them (the fitted tilt curve); None if only standard errors and correlations are
        known. Where a parameter is undetermined (standard error inf) its row and column are not
        that parameter's variance: :meth:`to_dict` writes them as null under ``"covariance"``
        (the matrix for propagation under ``"propagation_covariance"``).
    """

    correlation_names: tuple[str, ...]
    stderr: dict[str, float]
    correlation: F64
    covariance: F64 | None = None

    def matrix(self) -> F64:
        """The covariance (SI), shape (p, p): the stored one when there is one (it keeps the
        cancellations along combinations the data do not determine), else standard errors ×
        correlations (NaN where a standard error is undetermined or missing)."""
        if self.covariance is not None:
            return np.asarray(self.covariance, dtype=np.float64)
        se = np.array([self.stderr.get(n, math.nan) for n in self.correlation_names])
        corr = np.array(self.correlation, dtype=np.float64)
        np.fill_diagonal(corr, 1.0)
        with np.errstate(invalid="ignore"):
            return np.asarray(np.nan_to_num(corr) * np.outer(se, se), dtype=np.float64)

    def undetermined(self) -> tuple[str, ...]:
        """The parameters whose standard error is infinite (the data do not determine them)."""
        return tuple(n for n in self.correlation_names if self.stderr.get(n) == math.inf)

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready content (SI; inf and NaN become null when written). ``"covariance"`` has
        null rows and columns for the undetermined parameters (they have no variance); when
        there are any, ``"propagation_covariance"`` holds σ² (JᵀJ)⁺ whole (see
        :attr:`covariance`), which :meth:`from_dict` reads back."""
        names = list(self.correlation_names)
        doc: dict[str, Any] = {"stderr": dict(self.stderr)}
        if self.covariance is None:
            doc["covariance"] = {"names": names, "matrix": None}
        else:
            undetermined = set(self.undetermined())
            gone = np.array([n in undetermined for n in names], dtype=bool)
            shown = np.where(gone[:, None] | gone[None, :], np.nan, self.covariance)
            doc["covariance"] = {"names": names, "matrix": shown.tolist()}
            if gone.any():
                doc["propagation_covariance"] = {
                    "names": names, "matrix": self.covariance.tolist(),
                    "note": ("sigma^2 (J^T J)^+: the covariance of the combinations the data "
                             "determine, zero along the undetermined ones; propagate it only "
                             "through quantities that do not change along them (the tilt "
                             "output), never read an undetermined parameter's variance from it")}
        doc["correlation"] = {"names": names, "matrix": self.correlation.tolist()}
        return doc

    @classmethod
    def from_dict(cls, doc: Mapping[str, Any], source: str = "calibration") -> ParameterCovariance:
        """Rebuild from :meth:`to_dict` output (or a whole ``result.json``); null standard errors
        (undetermined) become inf."""
        hint = "give the result.json of magcilia calibrate"
        try:
            names = tuple(str(n) for n in doc["correlation"]["names"])
            matrix = np.array(doc["correlation"]["matrix"], dtype=np.float64)  # null -> nan
            stderr = {str(k): math.inf if val is None else float(val)
                      for k, val in doc["stderr"].items()}
            stored = (doc.get("propagation_covariance") or doc.get("covariance") or {}).get(
                "matrix")
            covariance = None if stored is None else np.array(stored, dtype=np.float64)
        except (ValueError, KeyError, TypeError, AttributeError) as exc:
            raise MagciliaError(f"{source}: not a calibration result ({type(exc).__name__}: "
                                f"{exc}); {hint}") from None
        shape = (len(names), len(names))
        if (matrix.shape != shape or not set(names) <= set(stderr)
                or (covariance is not None and covariance.shape != shape)):
            raise MagciliaError(f"{source}: correlation matrix and standard errors do not match "
                                "the parameter names; give an unedited result.json")
        return cls(correlation_names=names, stderr=stderr, correlation=matrix,
                   covariance=covariance)

    @classmethod
    def load(cls, path: str | Path) -> ParameterCovariance:
        """Read ``result.json`` written by ``magcilia calibrate`` (or a folder holding one)."""
        p, doc = read_json(path, default_name="result.json",
                           hint="give the result.json (or the --out folder) of magcilia calibrate")
        return cls.from_dict(doc, source=str(p))

    def report(self) -> str:
        """Standard errors (display units) and the strong correlations, one per line."""
        lines = []
        for name in self.correlation_names:
            se = self.stderr.get(name, math.nan)
            unit = REGISTRY[name].display if name in REGISTRY else ""
            shown = REGISTRY[name].to_display(se) if name in REGISTRY else se
            text = "undetermined" if se == math.inf else f"± {shown:.4g} {unit}".rstrip()
            lines.append(f"{name}: {text}")
        names = self.correlation_names
        for i, j in itertools.combinations(range(len(names)), 2):
            c = self.correlation[i, j]
            if np.isfinite(c) and abs(c) > 0.9:
                lines.append(f"{names[i]} and {names[j]} correlated {c:+.3f}")
        return "\n".join(lines)

    # -- display --------------------------------------------------------------------------------
    def _display_items(self) -> list[Item]:
        corr = np.abs(self.correlation - np.eye(len(self.correlation_names)))
        worst = float(np.nanmax(corr)) if corr.size else math.nan
        undetermined = sum(1 for s in self.stderr.values() if s == math.inf)
        return [("", count(len(self.correlation_names), "parameter")),
                ("undetermined", str(undetermined)), ("max |correlation|", number(worst)),
                ("parameters", " ".join(self.correlation_names))]

    def _display_table(self) -> Table:
        rows = [(n, REGISTRY[n].text(s) if n in REGISTRY else number(s))
                for n, s in self.stderr.items()]
        return ("parameter", "standard error"), rows

    def to_dataframe(self) -> Any:
        """The correlation matrix as a ``pandas.DataFrame`` indexed and labelled by parameter
        name (dimensionless)."""
        names = list(self.correlation_names)
        frame = dataframe({n: self.correlation[:, i] for i, n in enumerate(names)})
        frame.index = names
        return frame


class _Uncertain:
    """The standard errors, correlations and covariance of a fit's :class:`ParameterCovariance`
    (``self.uncertainty``) as attributes of the result."""

    __slots__ = ()
    uncertainty: ParameterCovariance

    @property
    def stderr(self) -> dict[str, float]:
        """1-σ standard errors, SI (inf where the data do not determine the parameter; NaN where
        not defined)."""
        return self.uncertainty.stderr

    @property
    def correlation(self) -> F64:
        """Correlation matrix of :attr:`correlation_names`, shape (p, p)."""
        return self.uncertainty.correlation

    @property
    def correlation_names(self) -> tuple[str, ...]:
        """Names of the rows of :attr:`correlation` and :attr:`covariance`."""
        return self.uncertainty.correlation_names

    @property
    def covariance(self) -> F64 | None:
        """Parameter covariance (SI), shape (p, p): σ² (JᵀJ)⁺, zero along undetermined
        combinations, so that J C Jᵀ gives the fitted curve's uncertainty (an undetermined
        parameter's row is not its variance: see :class:`ParameterCovariance`)."""
        return self.uncertainty.covariance


@dataclass(frozen=True, eq=False, repr=False)
class CalibrationResult(_Uncertain, Display):
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
    values : dict of str to float
        Fitted parameters (SI).
    uncertainty : ParameterCovariance
        Their 1-σ standard errors, correlations and covariance from the Jacobian; also as the
        attributes ``stderr``, ``correlation``, ``correlation_names`` and ``covariance``.
    bias_coefficients : ndarray
        Polynomial bias coefficients (constant first; V, V/rad, …); the constant is the offset.
    warnings : tuple of str
        Plain-language warnings: what the data do not determine, parameters at a bound, a bias
        that absorbed the signal, implausible standard errors (the texts of ``diagnostics``).
    bounds : dict
        The search bounds (SI).
    evaluations : int
        Model evaluations (parameter sets × angles counted once per set).
    elapsed : float
        Wall time, s.
    restart_costs : tuple of float
        Final cost of each restart, V².
    diagnostics : tuple of CalibrationWarning
        The warnings as records with a ``kind`` and the ``parameters`` they concern (see
        :mod:`magcilia.calibration.diagnostics`), for code to match.
    fixed : dict of str to float
        Parameters held at a value instead of fitted (``calibrate(fixed=...)`` or equal bounds),
        SI; they have no standard error.
    truth : dict of str to float or None
        Known true values (SI) of a synthetic recording, shown beside the fit (see
        :meth:`with_truth`); None for a measurement.
    """

    setup: Setup
    initial: Setup
    cost: float
    rms: float
    residuals: F64
    data: Measurement
    values: dict[str, float]
    uncertainty: ParameterCovariance
    bias_coefficients: F64
    bias: str
    warnings: tuple[str, ...]
    bounds: dict[str, tuple[float, float]]
    evaluations: int
    elapsed: float
    restart_costs: tuple[float, ...] = field(default=())
    diagnostics: tuple[CalibrationWarning, ...] = field(default=())
    fixed: dict[str, float] = field(default_factory=dict)
    truth: dict[str, float] | None = None

    @property
    def fitted(self) -> F64:
        """Fitted model at the measured angles, V, shape (a,) (bias included)."""
        return self.data.volts - self.residuals

    def table(self, si: bool = False) -> list[dict[str, Any]]:
        """Table-I-style rows: parameter, display unit, initial, fitted and standard error in that
        unit (mm, mV; see :data:`magcilia.device.parameters.PARAMETERS`; SI units with ``si``),
        whether it was held (``fixed``; its standard error is NaN) and, with :attr:`truth`, the
        true value (NaN where not known)."""
        init = self.initial.params()
        rows = []
        for name in (*PARAMETERS, "magnetization_scale", "offset"):
            if name not in self.values:
                continue
            p = REGISTRY[name]
            unit, factor = (p.unit, 1.0) if si else (p.display, p.display_factor)
            row = {
                "parameter": name, "unit": unit, "initial": init[name] / factor,
                "fitted": self.values[name] / factor,
                "stderr": self.stderr.get(name, math.nan) / factor,
                "fixed": name in self.fixed,
            }
            if self.truth is not None:
                row["truth"] = self.truth.get(name, math.nan) / factor
            rows.append(row)
        return rows

    def with_truth(self, truth: Mapping[str, float]) -> CalibrationResult:
        """This result with the known true values (SI) of a synthetic recording, which
        :meth:`table`, :meth:`report` and the markdown report then show beside the fit, with
        :meth:`truth_comparison`'s explanation (``magcilia demo`` does this with the bundled
        recording's truth)."""
        known = (*PARAMETERS, "magnetization_scale", "offset")
        checked: dict[str, float] = {}
        for name, value in truth.items():
            if name not in known:
                raise v.fail("truth key", name, "one of " + ", ".join(known))
            checked[name] = v.real(f"truth[{name!r}]", value, REGISTRY[name].unit)
        return replace(self, truth=checked)

    def truth_comparison(self) -> list[str]:
        """Plain-text lines comparing the fit with :attr:`truth` ([] without one): how well the
        fit and the truth reproduce the data, which parameters agree within 3 standard errors,
        which the data leave undetermined, and what would pin them down."""
        if self.truth is None:
            return []
        data = self.data
        noise = math.sqrt(float(np.mean(data.sem**2)))
        lines = ["fit versus truth (the recording is synthetic, so its true parameters are known):"]
        close = self.rms <= 1.5 * noise
        fit_line = (f"- the fit {'reproduces' if close else 'does not reproduce'} the data to the "
                    f"noise level: RMS residual {self.rms * 1e6:.3g} µV against {noise * 1e6:.3g} "
                    "µV of noise in each angle's mean")
        truth_rms = self._truth_rms(self.truth)
        if truth_rms is not None and truth_rms <= 1.5 * max(self.rms, noise):
            fit_line += (f"; the true parameters give {truth_rms * 1e6:.3g} µV: the data cannot "
                         "tell the two sets apart")
        elif truth_rms is not None:
            fit_line += (f"; the true parameters give {truth_rms * 1e6:.3g} µV, worse than the "
                         "fit: the recording holds effects the model lacks (a slow drift, "
                         "correlated noise) and the free parameters absorbed them")
        lines.append(fit_line)
        undetermined = [n for w in self.diagnostics if w.kind == "undetermined"
                        for n in w.parameters if n in self.truth and n not in self.fixed]
        agree: list[str] = []
        differ: list[str] = []
        for name in (*PARAMETERS, "magnetization_scale", "offset"):
            se = self.stderr.get(name, math.nan)
            if name not in self.truth or name in self.fixed or not math.isfinite(se):
                continue
            z = (self.values[name] - self.truth[name]) / se if se > 0 else math.inf
            (agree if abs(z) <= 3.0 else differ).append(f"{name} ({z:+.1f} s.e.)")
        size = bool(SIZES & set(undetermined))
        if undetermined:
            why = ("every length scaled together leaves the field unchanged (the scale symmetry)"
                   if size else "one field component along one tilt path leaves them "
                   "undetermined (the output does not change along a combination of them)")
            lines.append(f"- {', '.join(undetermined)} differ from the truth yet fit as well: "
                         f"{why}, so the search returned one of many equally good sets")
        if agree:
            lines.append(f"- within 3 standard errors of the truth: {', '.join(agree)}")
        if differ:
            lines.append(f"- beyond 3 standard errors of the truth: {', '.join(differ)} (a "
                         "linearised error understates the spread along poorly determined "
                         "combinations; see the correlations in the warnings)")
        ints = [n for n in INTEGER if n in self.truth and n not in self.fixed]
        if ints:
            pairs = ", ".join(f"{n} {self.values[n]:g} (truth {self.truth[n]:g})" for n in ints)
            lines.append(f"- {pairs}: modelling choices of the search, not measured quantities")
        elif any(n not in self.truth and n not in self.fixed for n in INTEGER):
            lines.append("- the recording comes from a body without a dipole layout (the exact "
                         "body): n_loops and dipoles_per_loop are modelling choices of the search, "
                         "and the paper model's lengths are effective values that absorb its "
                         "model error (calibrate --model physical fits the hair's dimensions)")
        if undetermined and size:
            lines.append("- what pins them down is a size: no second tilt path or field "
                         "component can (the scale symmetry); a measured height held with --fix "
                         "height=VALUE (API fixed=...), or --model physical with it as a prior "
                         "(--prior height=VALUE:SIGMA) or load data; see the README's "
                         "Calibration section")
        elif undetermined:
            lines.append("- what pins them down is information this tilt path lacks: another "
                         "experiment (a second tilt path or field component) or prior knowledge, "
                         f"e.g. a measured {undetermined[0]} held with --fix "
                         f"{undetermined[0]}=VALUE (API fixed=...); see the README's Calibration "
                         "section")
        return lines

    def _truth_rms(self, truth: dict[str, float]) -> float | None:
        """RMS residual of the true parameters with their best bias (and the truth's scale), V;
        None if the truth does not give every fitted parameter."""
        if not all(n in truth for n in PARAMETERS):
            return None
        changes: dict[str, Any] = {n: (round(truth[n]) if n in INTEGER else truth[n])
                                   for n in PARAMETERS}
        if "magnetization_scale" in truth:
            changes["magnetization_scale"] = truth["magnetization_scale"]
        try:
            curve = self.initial.replace(offset=0.0, **changes).output(self.data.angles)
        except MagciliaError:
            return None
        r = self.data.volts - curve
        if self.bias_coefficients.size:
            basis = np.vander(self.data.angles, self.bias_coefficients.size, increasing=True)
            coef, *_ = np.linalg.lstsq(basis, r, rcond=None)
            r = r - basis @ coef
        return math.sqrt(float(np.mean(r**2)))

    def report(self, si: bool = False) -> str:
        """A plain-text summary: cost, RMS, the parameter table (display units, SI with ``si``;
        with the truth when known) and the warnings, then :meth:`truth_comparison`."""
        truth = self.truth is not None
        rms = f"{self.rms:.4g} V" if si else f"{self.rms * 1e3:.4g} mV"
        lines = [
            f"calibration of {self.data.source}: {len(self.data)} angles",
            f"cost {self.cost:.6g} V^2 (sum of squared residuals), RMS {rms}",
            f"{'parameter':<20} {'unit':<4} {'initial':>12} {'fitted':>12} {'std. error':>12}"
            + (f" {'truth':>12}" if truth else ""),
        ]
        for r in self.table(si):
            se = ("fixed" if r["fixed"] else f"{r['stderr']:.4g}" if math.isfinite(r["stderr"])
                  else "undetermined" if r["stderr"] == math.inf else "-")
            known = f"{r['truth']:12.6g}" if truth and math.isfinite(r["truth"]) else f"{'-':>12}"
            lines.append(f"{r['parameter']:<20} {r['unit']:<4} {r['initial']:12.6g} "
                         f"{r['fitted']:12.6g} {se:>12}" + (f" {known}" if truth else ""))
        lines += [f"warning: {w}" for w in self.warnings]
        lines += self.truth_comparison()
        return "\n".join(lines)

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready content (SI units, plus the display table)."""
        return {
            "source": self.data.source, "cost_V2": self.cost, "rms_V": self.rms,
            "values": self.values, **self.uncertainty.to_dict(),
            "bias": self.bias, "bias_coefficients": self.bias_coefficients.tolist(),
            "warnings": list(self.warnings), "bounds": {k: list(b) for k, b in self.bounds.items()},
            "angle_deg": self.data.angles_deg.tolist(), "measured_V": self.data.volts.tolist(),
            "fitted_V": self.fitted.tolist(), "residual_V": self.residuals.tolist(),
            "table": self.table(), "evaluations": self.evaluations, "elapsed_s": self.elapsed,
            "restart_costs_V2": list(self.restart_costs),
            "diagnostics": [{"kind": w.kind, "parameters": list(w.parameters),
                             "message": w.message} for w in self.diagnostics],
            "fixed": dict(self.fixed),
            **({"truth": dict(self.truth)} if self.truth is not None else {}),
        }

    # -- display --------------------------------------------------------------------------------
    def _display_items(self) -> list[Item]:
        return [("cost", si(self.cost, "V²")), ("rms", si(self.rms, "V")),
                ("", count(len(self.data), "angle")), ("", count(len(self.warnings), "warning")),
                ("source", self.data.source), ("bias", self.bias),
                ("evaluations", str(self.evaluations)), ("elapsed", si(self.elapsed, "s")),
                *(("warning", w) for w in self.warnings)]

    def _display_table(self) -> Table | None:
        return rows_table(self.table())

    def to_dataframe(self) -> Any:
        """The parameter table as a ``pandas.DataFrame``, one row per fitted parameter, SI:
        ``parameter``, ``unit`` (its SI unit, "" for numbers), ``initial``, ``fitted``,
        ``stderr`` (inf: undetermined), ``lower``, ``upper`` (the bounds; NaN where fixed by
        the model rather than bounded)."""
        init = self.initial.params()
        names = [n for n in (*PARAMETERS, "magnetization_scale", "offset") if n in self.values]
        bounds = [self.bounds.get(n, (math.nan, math.nan)) for n in names]
        return dataframe({
            "parameter": names, "unit": [REGISTRY[n].unit for n in names],
            "initial": [float(init[n]) for n in names],
            "fitted": [float(self.values[n]) for n in names],
            "stderr": [float(self.stderr.get(n, math.nan)) for n in names],
            "lower": [float(b[0]) for b in bounds], "upper": [float(b[1]) for b in bounds]})


@dataclass(frozen=True, eq=False, repr=False)
class ExperimentFit(Display):
    """One experiment's part of a joint calibration (:class:`JointCalibrationResult`).

    Attributes
    ----------
    source : str
        The recording.
    observable : {"output", "field"}
        Sensor output (V) or 3-axis field (T).
    angles, azimuths : ndarray, shape (a,)
        Tilt angles and directions, rad.
    measured, fitted, residuals : ndarray, shape (a,) (output, V) or (a, 3) (field, T)
        The data, the fitted model with this experiment's offsets, their difference.
    offsets : ndarray, shape (1,) or (3,)
        The fitted constant offset (V), or one per field axis (T).
    rms : float
        RMS residual, V or T.
    chi2 : float
        Sum of squared weighted residuals (÷ the floored standard errors).
    values : int
        Data values (a, or 3a).
    load_kind : {"force", "flow"} or None
        A load experiment's kind (None for a tilt experiment).
    loads : ndarray, shape (a,), or None
        Its loads: tip forces, N, or flow speeds, m/s (the angles are then 0).
    """

    source: str
    observable: str
    angles: F64
    azimuths: F64
    measured: F64
    fitted: F64
    residuals: F64
    offsets: F64
    rms: float
    chi2: float
    values: int
    load_kind: str | None = None
    loads: F64 | None = None

    def unit(self) -> str:
        """The SI unit of the data ("V" or "T")."""
        return "V" if self.observable == "output" else "T"

    def line(self) -> str:
        """One report line: source, conditions, azimuths, RMS, χ² and the offsets (display
        units: mV, µT)."""
        az = ", ".join(f"{d:g}" for d in np.unique(np.round(np.degrees(self.azimuths), 3)))
        if self.observable == "output":
            rms, off = f"{self.rms * 1e3:.4g} mV", f"offset {self.offsets[0] * 1e3:.5g} mV"
        else:
            rms = f"{self.rms * 1e6:.4g} uT"
            off = "offsets " + ", ".join(f"{o * 1e6:.4g}" for o in self.offsets) + " uT (x, y, z)"
        what = f"{self.angles.size} angles"
        if self.loads is not None:
            unit = "mN" if self.load_kind == "force" else "mm/s"
            what = (f"{self.loads.size} {'forces' if self.load_kind == 'force' else 'speeds'} "
                    f"{self.loads.min() * 1e3:.4g}..{self.loads.max() * 1e3:.4g} {unit}")
        return (f"{self.source}: {self.observable}, {what} at azimuth {az} "
                f"deg; RMS {rms}, chi2 {self.chi2:.4g} for {self.values} values; {off}")

    def report(self) -> str:
        """:meth:`line`: the experiment's fit in one line."""
        return self.line()

    def _display_items(self) -> list[Item]:
        return [("source", self.source), ("observable", self.observable),
                ("", count(self.angles.size, "angle")), ("rms", si(self.rms, self.unit())),
                ("chi2", number(self.chi2))]

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready content (SI)."""
        u = self.unit()
        return {"source": self.source, "observable": self.observable,
                "angle_rad": self.angles.tolist(), "azimuth_rad": self.azimuths.tolist(),
                f"measured_{u}": self.measured.tolist(), f"fitted_{u}": self.fitted.tolist(),
                f"residual_{u}": self.residuals.tolist(), f"offsets_{u}": self.offsets.tolist(),
                f"rms_{u}": self.rms, "chi2": self.chi2, "values": self.values,
                **({} if self.loads is None else {
                    "force_N" if self.load_kind == "force" else "speed_m_per_s":
                        self.loads.tolist()})}


@dataclass(frozen=True, eq=False, repr=False)
class JointCalibrationResult(_Uncertain, Display):
    """The outcome of ``calibrate(..., model="physical")`` (immutable): one cilium and placement
    fitted to several experiments (:mod:`magcilia.calibration.joint`).

    Attributes
    ----------
    setup : Setup
        The fitted setup, with the physical layout (n, k, rms ring); its sensor offset is the
        fitted one when there is exactly one output experiment.
    initial : Setup
    model : str
        ``"physical"``.
    n_loops, dipoles_per_loop : int
        The layout held during the fit.
    layout_error : float
        Its max relative field error against the exact body at the initial setup (NaN if given).
    chi2 : float
        Sum of squared weighted residuals, priors included.
    dof : int
        Data values − fitted parameters (offsets included).
    values : dict of str to float
        Fitted values (SI): height, base_radius, x, y, z, the offsets (``offset``, ``offset_x``…,
        with ``[i]`` per experiment when there are several) and, with ``fit_scale``, the
        magnetization scale.
    uncertainty : ParameterCovariance
        Standard errors (inf: undetermined), correlations and covariance.
    experiments : tuple of ExperimentFit
    priors : dict of str to (float, float)
        The Gaussian priors (value, σ), SI.
    warnings : tuple of str
    diagnostics : tuple of CalibrationWarning
    bounds : dict of str to (float, float)
    fixed : dict of str to float
    evaluations : int
        Parameter sets evaluated.
    elapsed : float
        Wall time, s.
    posterior : Posterior or None
        Samples of the posterior of the fitted geometry (``calibrate(..., posterior=True)``;
        the offsets profiled out), else None.
    """

    setup: Setup
    initial: Setup
    model: str
    n_loops: int
    dipoles_per_loop: int
    layout_error: float
    chi2: float
    dof: int
    values: dict[str, float]
    uncertainty: ParameterCovariance
    experiments: tuple[ExperimentFit, ...]
    priors: dict[str, tuple[float, float]]
    warnings: tuple[str, ...]
    diagnostics: tuple[CalibrationWarning, ...]
    bounds: dict[str, tuple[float, float]]
    fixed: dict[str, float]
    evaluations: int
    elapsed: float
    posterior: Posterior | None = None

    def undetermined(self) -> tuple[str, ...]:
        """Parameters the data (and priors) leave undetermined."""
        return tuple(dict.fromkeys(n for w in self.diagnostics if w.kind == "undetermined"
                                   for n in w.parameters))

    def table(self, si: bool = False) -> list[dict[str, Any]]:
        """Rows of the geometry, the Young's modulus (with load experiments) and the magnetization
        scale (with ``fit_scale``): parameter, unit, initial, fitted, stderr (display units; SI
        with ``si``), fixed, and the prior value and σ (NaN without one)."""
        init = {**self.initial.params(), "youngs_modulus": self.initial.youngs_modulus}
        rows = []
        for name in (*GEOMETRY, "youngs_modulus", "magnetization_scale"):
            if name not in self.values:
                continue
            p = REGISTRY[name]
            unit, factor = (p.unit, 1.0) if si else (p.display, p.display_factor)
            mu, sig = self.priors.get(name, (math.nan, math.nan))
            rows.append({"parameter": name, "unit": unit, "initial": init[name] / factor,
                         "fitted": self.values[name] / factor,
                         "stderr": self.stderr.get(name, math.nan) / factor,
                         "fixed": name in self.fixed, "prior": mu / factor,
                         "prior_sigma": sig / factor})
        return rows

    def report(self, si: bool = False) -> str:
        """Plain text: the model and layout, the parameter table with priors, each experiment's
        fit, what is still undetermined, and the warnings."""
        err = ("" if not math.isfinite(self.layout_error)
               else f", {self.layout_error:.2g} max relative field error against the exact body")
        lines = [(f"joint calibration ({self.model} model: n={self.n_loops}, "
                  f"k={self.dipoles_per_loop}, rms ring{err}) of {len(self.experiments)} "
                  "experiment(s)"),
                 (f"chi2 {self.chi2:.6g} for {self.dof} degrees of freedom (reduced "
                  f"{self.chi2 / max(self.dof, 1):.3g})"),
                 (f"{'parameter':<20} {'unit':<4} {'initial':>12} {'fitted':>12} "
                  f"{'std. error':>12} {'prior':>20}")]
        for r in self.table(si):
            se = ("fixed" if r["fixed"] else f"{r['stderr']:.4g}" if math.isfinite(r["stderr"])
                  else "undetermined" if r["stderr"] == math.inf else "-")
            prior = (f"{r['prior']:.4g} ± {r['prior_sigma']:.3g}" if math.isfinite(r["prior"])
                     else "-")
            lines.append(f"{r['parameter']:<20} {r['unit']:<4} {r['initial']:12.6g} "
                         f"{r['fitted']:12.6g} {se:>12} {prior:>20}")
        lines.append("experiments:")
        lines += [f"- {e.line()}" for e in self.experiments]
        und = self.undetermined()
        by_prior = tuple(dict.fromkeys(n for w in self.diagnostics if w.kind == "prior_only"
                                       for n in w.parameters))
        lines.append("still undetermined: " + (", ".join(und) if und else (
            "nothing (every fitted parameter is determined"
            + (f"; {', '.join(by_prior)} through the priors alone)" if by_prior else ")"))))
        lines += [f"warning: {w}" for w in self.warnings]
        if self.posterior is not None:
            lines.append(self.posterior.report())
        return "\n".join(lines)

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready content (SI; the posterior's summary, not its samples)."""
        return {
            "posterior": None if self.posterior is None else self.posterior.to_dict(),
            "model": self.model, "n_loops": self.n_loops,
            "dipoles_per_loop": self.dipoles_per_loop, "layout_error": self.layout_error,
            "chi2": self.chi2, "dof": self.dof, "values": dict(self.values),
            **self.uncertainty.to_dict(),
            "priors": {k: list(p) for k, p in self.priors.items()},
            "experiments": [e.to_dict() for e in self.experiments],
            "warnings": list(self.warnings),
            "diagnostics": [{"kind": w.kind, "parameters": list(w.parameters),
                             "message": w.message} for w in self.diagnostics],
            "bounds": {k: list(b) for k, b in self.bounds.items()}, "fixed": dict(self.fixed),
            "table": self.table(), "evaluations": self.evaluations, "elapsed_s": self.elapsed,
        }

    # -- display --------------------------------------------------------------------------------
    def _display_items(self) -> list[Item]:
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
        """The parameter table as a ``pandas.DataFrame`` (SI): ``parameter``, ``unit``,
        ``initial``, ``fitted``, ``stderr``, ``lower``, ``upper``, ``prior``, ``prior_sigma``."""
        rows = self.table(si=True)
        names = [r["parameter"] for r in rows]
        bounds = [self.bounds.get(n, (math.nan, math.nan)) for n in names]
        return dataframe({
            "parameter": names, "unit": [r["unit"] for r in rows],
            "initial": [float(r["initial"]) for r in rows],
            "fitted": [float(r["fitted"]) for r in rows],
            "stderr": [float(r["stderr"]) for r in rows],
            "lower": [float(b[0]) for b in bounds], "upper": [float(b[1]) for b in bounds],
            "prior": [float(r["prior"]) for r in rows],
            "prior_sigma": [float(r["prior_sigma"]) for r in rows]})


#: the geometry and placement of the physical model (keys of ``values`` and ``stderr``)
GEOMETRY = ("height", "base_radius", "x", "y", "z")
