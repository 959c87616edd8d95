"""A calibration result read back from its ``result.json`` (:meth:`CalibrationResult.from_dict
<magcilia.calibration.result.CalibrationResult.from_dict>`): this release's files, and those of
earlier releases (a paper fit's single tilt path, a joint fit's experiments; no setups in
them)."""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping
from typing import Any, TypeVar

import numpy as np

from magcilia._errors import MagciliaError
from magcilia.calibration.covariance import ParameterCovariance
from magcilia.calibration.diagnostics import CalibrationWarning
from magcilia.calibration.experiment_fit import ExperimentFit
from magcilia.calibration.parameters import ParameterKey
from magcilia.calibration.temperature import temperature_fields
from magcilia.device.parameters import PARAMETERS as REGISTRY
from magcilia.device.setup import Setup
from magcilia.io.recordings import Measurement
from magcilia.io.setup_files import setup_from_dict

#: the result class being rebuilt (:class:`~magcilia.calibration.result.CalibrationResult`)
R = TypeVar("R")


def experiment_keys(fits: tuple[ExperimentFit, ...]) -> dict[str, ParameterKey]:
    """The offsets' labels and keys of a physical fit's experiments (one offset per output
    experiment, one per axis per field experiment; ``[i]`` when there are several)."""
    many = len(fits) > 1
    keys = []
    for i, e in enumerate(fits):
        keys += ([ParameterKey("offset", i)] if e.observable == "output"
                 else [ParameterKey("offset", i, axis=c) for c in range(3)])
    return {k.label(many): k for k in keys}


def _registry_setup(values: Mapping[str, float], base: Setup) -> Setup:
    """``base`` with the registry parameters of ``values`` (a file without a setup)."""
    known = {n: float(x) for n, x in values.items() if n in REGISTRY and n in base.params()}
    for n in ("n_loops", "dipoles_per_loop"):
        if n in known:
            known[n] = round(known[n])
    return base.replace(**known)


def _initial_from_table(table: list[dict[str, Any]], setup: Setup) -> Setup:
    """The initial setup of a file without one: the fitted setup with the table's initial
    values (display units in the file)."""
    values = {}
    for row in table:
        name = row.get("parameter")
        if name in REGISTRY and row.get("initial") is not None:
            values[name] = float(row["initial"]) * REGISTRY[name].display_factor
    return _registry_setup(values, setup)


def _measurement(doc: Mapping[str, Any]) -> Measurement:
    """The tilt path of a paper fit: stored whole, or (earlier files) its angles and outputs,
    the standard errors not kept (NaN)."""
    if doc.get("measurement") is not None:
        return Measurement.from_dict(doc["measurement"])
    angles = np.radians(np.asarray(doc["angle_deg"], dtype=np.float64))
    n = angles.size
    return Measurement(angles=angles, volts=np.asarray(doc["measured_V"], dtype=np.float64),
                       sem=np.full(n, math.nan), counts=np.ones(n, dtype=np.int64),
                       saturated=np.zeros(n, dtype=np.int64),
                       nonfinite=np.zeros(n, dtype=np.int64), source=str(doc.get("source", "")))


def rebuild(cls: Callable[..., R], doc: Mapping[str, Any], setup: Setup | None,
            initial: Setup | None, source: str) -> R:
    """:meth:`CalibrationResult.from_dict`: the result ``doc`` holds (see there)."""
    try:
        return _rebuild(cls, doc, setup, initial, source)
    except (KeyError, TypeError, ValueError, AttributeError, IndexError) as exc:
        raise MagciliaError(f"{source}: not a calibration result ({type(exc).__name__}: {exc});"
                            " give the result.json of magcilia calibrate") from None


def _rebuild(cls: Callable[..., R], doc: Mapping[str, Any], setup: Setup | None,
             initial: Setup | None, source: str) -> R:
    model = str(doc.get("model", "physical" if "experiments" in doc else "paper"))
    values = {str(k): float(x) for k, x in doc["values"].items()}
    if setup is None:
        setup = (setup_from_dict(doc["setup"], f"{source}: setup") if doc.get("setup")
                 else _registry_setup(values, Setup.paper_initial().replace(
                     **({"n_loops": int(doc["n_loops"]),
                         "dipoles_per_loop": int(doc["dipoles_per_loop"])}
                        if "n_loops" in doc else {}))))
    if initial is None:
        initial = (setup_from_dict(doc["initial"], f"{source}: initial") if doc.get("initial")
                   else _initial_from_table(list(doc.get("table") or []), setup))
    fits = tuple(ExperimentFit.from_dict(e) for e in doc.get("experiments") or [])
    if doc.get("parameters"):
        keys = {str(p["label"]): ParameterKey(str(p["name"]), p.get("experiment"),
                                              p.get("axis"), int(p.get("degree") or 0))
                for p in doc["parameters"]}
    else:
        keys = experiment_keys(fits) if model == "physical" else (
            {"offset": ParameterKey("offset", 0)} if "offset" in values else {})
    common: dict[str, Any] = {
        "setup": setup, "initial": initial, "values": values,
        "uncertainty": ParameterCovariance.from_dict(doc, source),
        "warnings": tuple(str(w) for w in doc.get("warnings") or []),
        "bounds": {str(k): (float(b[0]), float(b[1]))
                   for k, b in (doc.get("bounds") or {}).items()},
        "evaluations": int(doc.get("evaluations") or 0),
        "elapsed": float(doc.get("elapsed_s") or 0.0),
        "diagnostics": tuple(CalibrationWarning(str(w["kind"]), str(w["message"]),
                                                tuple(str(n) for n in w.get("parameters") or ()))
                             for w in doc.get("diagnostics") or []),
        "fixed": {str(k): float(x) for k, x in (doc.get("fixed") or {}).items()},
        "model": model, "keys": {k: key for k, key in keys.items() if k in values},
        **temperature_fields(doc.get("temperature_K"))}
    if model == "physical":
        return cls(**common, experiments=fits, chi2=float(doc["chi2"]), dof=int(doc["dof"]),
                   priors={str(k): (float(p[0]), float(p[1]))
                           for k, p in (doc.get("priors") or {}).items()},
                   layout_error=math.nan if doc.get("layout_error") is None
                   else float(doc["layout_error"]))
    data = _measurement(doc)
    residuals = np.asarray(doc["residual_V"], dtype=np.float64)
    cost = float(doc["cost_V2"])
    truth = doc.get("truth")
    return cls(**common, data=data, cost=cost, rms=float(doc["rms_V"]), residuals=residuals,
               bias_coefficients=np.asarray(doc.get("bias_coefficients") or [],
                                            dtype=np.float64),
               bias=str(doc.get("bias", "offset")),
               restart_costs=tuple(float(c) for c in doc.get("restart_costs_V2") or []),
               truth=None if truth is None else {str(k): float(x) for k, x in truth.items()},
               experiments=(path_fit(data, residuals, np.asarray(
                   doc.get("bias_coefficients") or [], dtype=np.float64)),), chi2=cost,
               dof=len(data) - len(doc.get("stderr") or {}))


def path_fit(data: Measurement, residuals: np.ndarray, coef: np.ndarray) -> ExperimentFit:
    """The :class:`ExperimentFit` of a paper fit's tilt path (unweighted: χ² is the cost, V²)."""
    r = np.asarray(residuals, dtype=np.float64)
    return ExperimentFit(
        source=str(data.source), observable="output", angles=np.asarray(data.angles),
        azimuths=np.asarray(data.azimuths), measured=np.asarray(data.volts),
        fitted=np.asarray(data.volts) - r, residuals=r, offsets=coef[:1].copy(),
        rms=math.sqrt(float(np.mean(r ** 2))) if r.size else math.nan,
        chi2=float(r @ r), values=int(r.size), sem=np.asarray(data.sem, dtype=np.float64))
