"""The uncertainty of a calibration: :class:`ParameterCovariance` (standard errors, correlations,
covariance: what read-out needs of a calibration) and :class:`Uncertain`, which shows them as
attributes of a result."""

from __future__ import annotations

import itertools
import math
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from magcilia._display import Display, Item, Table, count, dataframe, number
from magcilia._errors import MagciliaError
from magcilia.device.parameters import PARAMETERS as REGISTRY
from magcilia.io.results import read_json

F64 = NDArray[np.float64]


@dataclass(frozen=True, eq=False, repr=False)
class ParameterCovariance(Display):
    """Standard errors and correlations of calibrated parameters: what read-out needs of a
    calibration (a :class:`~magcilia.calibration.result.CalibrationResult` holds one as
    ``uncertainty``).

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


class Uncertain:
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
