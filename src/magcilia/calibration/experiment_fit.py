"""One experiment's part of a calibration: :class:`ExperimentFit` (its data, fitted model,
residuals, bias and χ²)."""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from magcilia._display import Display, Item, count, number, si

F64 = NDArray[np.float64]


@dataclass(frozen=True, eq=False, repr=False)
class ExperimentFit(Display):
    """One experiment's part of a calibration (a
    :class:`~magcilia.calibration.result.CalibrationResult` holds one per experiment).

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
    actuation : ndarray, shape (a, 3), or None
        A coil experiment's applied uniform fields, T (the angles are then 0).
    sem : ndarray, shape of ``measured``, or None
        The data's standard errors as recorded (V or T; before the fit's floors), the error
        bars of ``fit.png``; None where unknown (a ``result.json`` written before they were
        kept).
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
    actuation: F64 | None = None
    sem: F64 | None = None

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
        if self.actuation is not None:
            b = np.linalg.norm(self.actuation, axis=1) * 1e4
            what = f"{b.size} applied fields {b.min():.3g}..{b.max():.3g} G"
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
                        self.loads.tolist()}),
                **({} if self.actuation is None else {"actuation_T": self.actuation.tolist()}),
                **({} if self.sem is None else {f"sem_{u}": self.sem.tolist()})}

    @classmethod
    def from_dict(cls, doc: Mapping[str, Any]) -> ExperimentFit:
        """Rebuild from :meth:`to_dict` output (a ``result.json``'s ``experiments`` entry)."""
        u = "V" if doc["observable"] == "output" else "T"
        loads = doc.get("force_N", doc.get("speed_m_per_s"))
        kind = "force" if "force_N" in doc else "flow" if "speed_m_per_s" in doc else None

        def arr(key: str) -> F64:
            return np.asarray(doc[key], dtype=np.float64)

        return cls(source=str(doc["source"]), observable=str(doc["observable"]),
                   angles=arr("angle_rad"), azimuths=arr("azimuth_rad"),
                   measured=arr(f"measured_{u}"), fitted=arr(f"fitted_{u}"),
                   residuals=arr(f"residual_{u}"), offsets=arr(f"offsets_{u}"),
                   rms=float(doc[f"rms_{u}"]), chi2=float(doc["chi2"]),
                   values=int(doc["values"]), load_kind=kind,
                   loads=None if loads is None else np.asarray(loads, dtype=np.float64),
                   actuation=(None if doc.get("actuation_T") is None
                              else np.asarray(doc["actuation_T"], dtype=np.float64)),
                   sem=None if doc.get(f"sem_{u}") is None else arr(f"sem_{u}"))
