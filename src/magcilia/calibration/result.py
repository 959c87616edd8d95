"""Results of a calibration: :class:`CalibrationResult` and the :class:`ParameterCovariance` that
read-out needs of it."""

from __future__ import annotations

import itertools
import math
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from magcilia._display import Display, Item, Table, count, dataframe, number, rows_table, si
from magcilia._errors import MagciliaError
from magcilia.calibration.problem import PARAMETERS
from magcilia.device.parameters import PARAMETERS as REGISTRY
from magcilia.device.setup import Setup
from magcilia.io.recordings import Measurement
from magcilia.io.results import read_json

F64 = NDArray[np.float64]


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
        The covariance itself (SI), finite along undetermined combinations (see
        :class:`CalibrationResult`); None if only standard errors and correlations are known.
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

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready content (SI; inf and NaN become null when written)."""
        names = list(self.correlation_names)
        return {
            "stderr": dict(self.stderr),
            "covariance": {"names": names,
                           "matrix": None if self.covariance is None else self.covariance.tolist()},
            "correlation": {"names": names, "matrix": self.correlation.tolist()},
        }

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
            stored = (doc.get("covariance") or {}).get("matrix")
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


@dataclass(frozen=True, eq=False, repr=False)
class CalibrationResult(Display):
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
        Plain-language identifiability warnings.
    bounds : dict
        The search bounds (SI).
    evaluations : int
        Model evaluations (parameter sets × angles counted once per set).
    elapsed : float
        Wall time, s.
    restart_costs : tuple of float
        Final cost of each restart, V².
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
        """Parameter covariance (SI), shape (p, p): σ² (JᵀJ)⁺, finite also along undetermined
        combinations, so that J C Jᵀ gives the fitted curve's uncertainty."""
        return self.uncertainty.covariance

    @property
    def fitted(self) -> F64:
        """Fitted model at the measured angles, V, shape (a,) (bias included)."""
        return self.data.volts - self.residuals

    def table(self) -> list[dict[str, Any]]:
        """Table-I-style rows: parameter, display unit, initial, fitted and standard error in that
        unit (mm, mV; see :data:`magcilia.device.parameters.PARAMETERS`)."""
        init = self.initial.params()
        rows = []
        for name in (*PARAMETERS, "magnetization_scale", "offset"):
            if name not in self.values:
                continue
            p = REGISTRY[name]
            rows.append({
                "parameter": name, "unit": p.display, "initial": p.to_display(init[name]),
                "fitted": p.to_display(self.values[name]),
                "stderr": p.to_display(self.stderr.get(name, math.nan)),
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
            "values": self.values, **self.uncertainty.to_dict(),
            "bias": self.bias, "bias_coefficients": self.bias_coefficients.tolist(),
            "warnings": list(self.warnings), "bounds": {k: list(b) for k, b in self.bounds.items()},
            "angle_deg": self.data.angles_deg.tolist(), "measured_V": self.data.volts.tolist(),
            "fitted_V": self.fitted.tolist(), "residual_V": self.residuals.tolist(),
            "table": self.table(), "evaluations": self.evaluations, "elapsed_s": self.elapsed,
            "restart_costs_V2": list(self.restart_costs),
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
