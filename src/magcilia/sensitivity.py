"""Sensitivity of the model's output to its parameters (the paper's Sec. IV.C, figs. 9–12, and global).

* :func:`oat_sweep` — one parameter at a time around a setup (the paper's figs. 9–12): for each
  value, the RMS change of the output curve over an angle range (V), the same with the mean
  difference removed (the *shape* change a fitted offset cannot absorb) and, with measurements, the
  calibration cost (V², sum over the measured angles of squared residuals with the output offset
  solved in closed form). :func:`placement_map` does x and y together on a grid (fig. 9 as a map).
* :func:`sensitivity_study` — all of figs. 9–12 with sensible default spans.
* :func:`sobol_indices` — global first- and total-order Sobol indices over the calibration bounds
  with SALib (Saltelli/Sobol sampling, Jansen/Saltelli estimators, bootstrap confidence intervals)
  and magcilia's batch evaluation (:func:`magcilia.model.tilt_output_batch`).

Values that leave the physical domain (the sensing element inside the cilium at some angle) are
skipped with a note; a span that is invalid in itself (a negative height, n < 1, no valid value at
all) is a one-line :class:`~magcilia.MagciliaError`. SI units throughout.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from magcilia import _validate as v
from magcilia._errors import MagciliaError, require
from magcilia.calibration import DEFAULT_BOUNDS, INTEGER, check_bound_values
from magcilia.measurements import Measurement
from magcilia.model import tilt_output_batch
from magcilia.setup import Setup

F64 = NDArray[np.float64]

#: the paper's 33 tilt angles over 0..85°, rad
DEFAULT_ANGLES = np.radians(np.linspace(0.0, 85.0, 33))
#: parameters that one-at-a-time sweeps accept (keys of ``Setup.params()`` except the offset)
SWEEP_PARAMETERS = ("x", "y", "z", "height", "base_radius", "tip_radius", "n_loops",
                    "dipoles_per_loop", "magnetization_scale")
SWEEP_INTEGER = ("n_loops", "dipoles_per_loop")
MEASURES = ("rms", "shape", "cost")
#: the sweeps of :func:`sensitivity_study` in figure order (figs. 9, 10, 11, 12)
STUDY_PARAMETERS = ("x", "y", "z", "n_loops", "dipoles_per_loop", "height", "base_radius")


# -- measures ------------------------------------------------------------------------------------
def offset_cost(model: ArrayLike, measured: ArrayLike) -> F64:
    """Calibration cost with the output offset solved in closed form, V².

    ``cost = Σ_a (y_a − u_a − c)²`` minimised over the constant c (so c = mean(y − u)): the
    paper's sum of squared errors with the DC bias fitted jointly (``calibrate(bias="offset")``).

    Parameters
    ----------
    model : array-like, shape (..., a)
        Model outputs, V (any offset they carry cancels).
    measured : array-like, shape (a,)
        Measured per-angle means, V.

    Returns
    -------
    ndarray, shape (...)
        Cost per model curve, V².
    """
    r = np.asarray(measured, dtype=np.float64) - np.asarray(model, dtype=np.float64)
    r = r - r.mean(axis=-1, keepdims=True)
    return np.asarray(np.einsum("...a,...a->...", r, r), dtype=np.float64)


def rms_change(curves: ArrayLike, reference: ArrayLike) -> F64:
    """RMS over angles of ``curves − reference``, V, shape (...) for curves (..., a)."""
    d = np.asarray(curves, dtype=np.float64) - np.asarray(reference, dtype=np.float64)
    return np.asarray(np.sqrt(np.mean(d * d, axis=-1)), dtype=np.float64)


def shape_change(curves: ArrayLike, reference: ArrayLike) -> F64:
    """Offset-free RMS change, V, shape (...): RMS over angles of ``curves − reference`` after
    removing its mean, i.e. the part of the change that a fitted output offset cannot absorb
    (``shape² = rms² − mean²``)."""
    d = np.asarray(curves, dtype=np.float64) - np.asarray(reference, dtype=np.float64)
    d = d - d.mean(axis=-1, keepdims=True)
    return np.asarray(np.sqrt(np.mean(d * d, axis=-1)), dtype=np.float64)


# -- one at a time -------------------------------------------------------------------------------
@dataclass(frozen=True, eq=False)
class OATResult:
    """A one-at-a-time sweep of one parameter (immutable).

    Attributes
    ----------
    parameter : str
        Swept parameter (a key of ``Setup.params()``).
    nominal : float
        Its value in the reference setup (SI).
    values : ndarray, shape (v,)
        Valid swept values (SI; skipped ones removed).
    angles : ndarray, shape (a,)
        Tilt angles of the curves, rad.
    reference : ndarray, shape (a,)
        The reference setup's output, V.
    curves : ndarray, shape (v, a)
        Output for each value, V.
    rms_change : ndarray, shape (v,)
        RMS over the angles of (curve − reference), V.
    shape_change : ndarray, shape (v,)
        The same with the mean difference removed (what a fitted offset cannot absorb), V.
    cost : ndarray, shape (v,) or None
        Calibration cost against the measurements (offset solved), V²; None without data.
    skipped : tuple of (float, str)
        Values left out (outside the physical domain) and why.
    """

    parameter: str
    nominal: float
    values: F64
    angles: F64
    reference: F64
    curves: F64
    rms_change: F64
    shape_change: F64
    cost: F64 | None = None
    skipped: tuple[tuple[float, str], ...] = ()

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready content (SI)."""
        return {
            "parameter": self.parameter, "nominal": self.nominal, "values": self.values.tolist(),
            "angles_rad": self.angles.tolist(), "reference_V": self.reference.tolist(),
            "curves_V": self.curves.tolist(), "rms_change_V": self.rms_change.tolist(),
            "shape_change_V": self.shape_change.tolist(),
            "cost_V2": None if self.cost is None else self.cost.tolist(),
            "skipped": [{"value": val, "reason": why} for val, why in self.skipped],
        }


def _check_parameter(parameter: str) -> str:
    return v.choice("parameter", parameter, SWEEP_PARAMETERS)


def _check_values(parameter: str, values: ArrayLike) -> F64:
    """Swept values: finite, non-empty, inside the parameter's basic domain."""
    vals = v.finite_array(f"{parameter} values", values).ravel()
    if vals.size == 0:
        raise v.fail(f"{parameter} values", "an empty array", "at least one value")
    if parameter in SWEEP_INTEGER:
        if np.any(vals < 1) or np.any(vals != np.round(vals)):
            bad = float(vals[(vals < 1) | (vals != np.round(vals))][0])
            raise v.fail(f"{parameter} values", bad, "whole numbers >= 1")
    elif parameter in ("height", "base_radius") and np.any(vals <= 0):
        raise v.fail(f"{parameter} values", float(vals[vals <= 0][0]), "positive lengths in m")
    elif parameter in ("tip_radius", "magnetization_scale") and np.any(vals < 0):
        raise v.fail(f"{parameter} values", float(vals[vals < 0][0]), "non-negative numbers")
    return vals


def _valid(setup: Setup, changes: Mapping[str, float], angles: F64) -> str | None:
    """None if the changed setup is physical at all angles, else the reason."""
    try:
        setup.replace(**changes).output(angles)
    except MagciliaError as exc:
        return str(exc)
    return None


def _data_angles(data: Measurement | None) -> F64 | None:
    if data is None:
        return None
    if not isinstance(data, Measurement):
        raise v.fail("data", type(data).__name__, "a magcilia Measurement (use read_measurements)")
    if len(data) < 2:
        raise v.fail("data", f"{len(data)} angle(s)", "a recording with at least 2 angles")
    return np.asarray(data.angles, dtype=np.float64)


def check_angles(angles: ArrayLike | None) -> F64:
    """Tilt angles, rad, shape (a,): finite, non-empty; None gives :data:`DEFAULT_ANGLES`."""
    if angles is None:
        return DEFAULT_ANGLES.copy()
    ang = v.finite_array("angles", angles, ndim=1, unit="rad")
    if ang.size < 1:
        raise v.fail("angles", "an empty array", "at least one tilt angle in rad")
    return ang


def _batch(setup: Setup, parameter: str, values: F64, angles: F64) -> F64:
    return tilt_output_batch(setup, {parameter: values}, angles)


def oat_sweep(
    setup: Setup,
    parameter: str,
    values: ArrayLike,
    angles: ArrayLike | None = None,
    data: Measurement | None = None,
) -> OATResult:
    """Vary one parameter of ``setup`` over ``values``, all others fixed (figs. 9–12).

    Parameters
    ----------
    setup : Setup
        Reference setup (e.g. a calibration result's ``.setup``).
    parameter : str
        One of :data:`SWEEP_PARAMETERS` (``x``, ``y``, ``z``, ``height``, ``base_radius``,
        ``tip_radius`` in m; ``n_loops``, ``dipoles_per_loop`` whole numbers;
        ``magnetization_scale``).
    values : array-like, shape (v,)
        Values to try, SI. Values where the sensing element would lie inside the cilium at some
        angle are skipped (listed in ``skipped``); a value outside the parameter's own domain
        (height ≤ 0, n < 1, …) is an error.
    angles : array-like, shape (a,), optional
        Tilt angles of the curves and the RMS change, rad; default the paper's 33 over 0..85°.
    data : Measurement, optional
        With measurements the calibration cost (offset solved) is computed at their angles.

    Returns
    -------
    OATResult
    """
    if not isinstance(setup, Setup):
        raise v.fail("setup", type(setup).__name__, "a magcilia Setup")
    parameter = _check_parameter(parameter)
    vals = _check_values(parameter, values)
    ang = check_angles(angles)
    d_ang = _data_angles(data)
    check = ang if d_ang is None else np.concatenate([ang, d_ang])
    keep, skipped = [], []
    for val in vals:
        reason = _valid(setup, {parameter: float(val)}, check)
        if reason is None:
            keep.append(float(val))
        else:
            skipped.append((float(val), reason))
    if not keep:
        raise MagciliaError(
            f"{parameter} values must include at least one physical setup; every value was "
            f"rejected, e.g. {skipped[0][0]:.6g}: {skipped[0][1]}"
        )
    good = np.asarray(keep)
    curves = _batch(setup, parameter, good, ang)
    reference = setup.output(ang)
    cost = None
    if data is not None and d_ang is not None:
        cost = offset_cost(_batch(setup, parameter, good, d_ang), data.volts)
    return OATResult(
        parameter=parameter, nominal=float(setup.params()[parameter]), values=good, angles=ang,
        reference=reference, curves=curves, rms_change=rms_change(curves, reference),
        shape_change=shape_change(curves, reference), cost=cost,
        skipped=tuple(skipped),
    )


@dataclass(frozen=True, eq=False)
class PlacementMap:
    """RMS output change (and cost) over a grid of x, y placements (fig. 9 as a map).

    Attributes
    ----------
    x : ndarray, shape (nx,)
        x positions, m.
    y : ndarray, shape (ny,)
        y positions, m.
    nominal : (float, float)
        The reference setup's (x, y), m.
    rms_change : ndarray, shape (ny, nx)
        V; NaN where the placement is not physical.
    cost : ndarray, shape (ny, nx) or None
        Calibration cost (offset solved), V²; NaN where not physical; None without data.
    """

    x: F64
    y: F64
    nominal: tuple[float, float]
    rms_change: F64
    cost: F64 | None = None

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready content (SI)."""
        return {
            "x_m": self.x.tolist(), "y_m": self.y.tolist(), "nominal_m": list(self.nominal),
            "rms_change_V": self.rms_change.tolist(),
            "cost_V2": None if self.cost is None else self.cost.tolist(),
        }


def placement_map(
    setup: Setup,
    x_values: ArrayLike,
    y_values: ArrayLike,
    angles: ArrayLike | None = None,
    data: Measurement | None = None,
) -> PlacementMap:
    """RMS change of the output curve (and cost) for each (x, y) placement on a grid.

    Parameters
    ----------
    setup : Setup
        Reference setup.
    x_values, y_values : array-like, shapes (nx,), (ny,)
        Grid of the paper's x_f, y_f, m.
    angles : array-like, shape (a,), optional
        Tilt angles, rad (default the paper's 33).
    data : Measurement, optional
        Measurements for the calibration cost.

    Returns
    -------
    PlacementMap
    """
    if not isinstance(setup, Setup):
        raise v.fail("setup", type(setup).__name__, "a magcilia Setup")
    xs = v.finite_array("x values", x_values, ndim=1, unit="m")
    ys = v.finite_array("y values", y_values, ndim=1, unit="m")
    if xs.size == 0 or ys.size == 0:
        raise v.fail("x/y values", f"{xs.size} x {ys.size}", "non-empty grids")
    ang = check_angles(angles)
    d_ang = _data_angles(data)
    check = ang if d_ang is None else np.concatenate([ang, d_ang])
    gx, gy = np.meshgrid(xs, ys)
    valid = np.array([_valid(setup, {"x": float(a), "y": float(b)}, check) is None
                      for a, b in zip(gx.ravel(), gy.ravel(), strict=True)])
    if not valid.any():
        raise MagciliaError("x/y values must include at least one placement with the sensing "
                            "element outside the cilium; none of the grid does")
    params = {"x": gx.ravel()[valid], "y": gy.ravel()[valid]}
    rms = np.full(gx.size, np.nan)
    rms[valid] = rms_change(tilt_output_batch(setup, params, ang), setup.output(ang))
    cost: F64 | None = None
    if data is not None and d_ang is not None:
        flat = np.full(gx.size, np.nan)
        flat[valid] = offset_cost(tilt_output_batch(setup, params, d_ang), data.volts)
        cost = flat.reshape(gx.shape)
    return PlacementMap(x=xs, y=ys, nominal=(setup.position[0], setup.position[1]),
                        rms_change=rms.reshape(gx.shape), cost=cost)


# -- the study of figs. 9–12 ---------------------------------------------------------------------
@dataclass(frozen=True, eq=False)
class SensitivityStudy:
    """All one-at-a-time sweeps of figs. 9–12 around one setup (immutable).

    Attributes
    ----------
    setup : Setup
        The reference setup.
    sweeps : dict of str to OATResult
        One sweep per parameter, in :data:`STUDY_PARAMETERS` order.
    xy_map : PlacementMap
        x–y map of the RMS change (and cost).
    spans : dict of str to (float, float)
        The spans used (SI; n, k whole numbers).
    notes : tuple of str
        Plain-language notes (skipped values).
    data_source : str or None
        The measurements' source, if any.
    """

    setup: Setup
    sweeps: dict[str, OATResult]
    xy_map: PlacementMap
    spans: dict[str, tuple[float, float]]
    notes: tuple[str, ...] = ()
    data_source: str | None = None

    def summary(self) -> list[dict[str, Any]]:
        """Per sweep: span, largest RMS and offset-free change (V) and, with data, the best cost
        and the value where it is reached."""
        rows = []
        for name, res in self.sweeps.items():
            row: dict[str, Any] = {
                "parameter": name, "nominal": res.nominal,
                "span": list(self.spans[name]), "max_rms_change_V": float(res.rms_change.max()),
                "max_shape_change_V": float(res.shape_change.max()),
                "skipped": len(res.skipped),
            }
            if res.cost is not None:
                i = int(np.argmin(res.cost))
                row["min_cost_V2"] = float(res.cost[i])
                row["argmin"] = float(res.values[i])
            rows.append(row)
        return rows

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready content (SI)."""
        return {
            "setup": self.setup.params(), "data": self.data_source,
            "spans": {k: list(s) for k, s in self.spans.items()},
            "summary": self.summary(), "notes": list(self.notes),
            "sweeps": {k: r.to_dict() for k, r in self.sweeps.items()},
            "xy_map": self.xy_map.to_dict(),
        }


def default_spans(setup: Setup) -> dict[str, tuple[float, float]]:
    """The default sweep spans around ``setup`` (SI): x, y ±1 mm, z 0..1 mm, n and k 1..10,
    height and base radius ±20 %."""
    p = setup.params()
    return {
        "x": (p["x"] - 1e-3, p["x"] + 1e-3), "y": (p["y"] - 1e-3, p["y"] + 1e-3),
        "z": (0.0, 1e-3), "n_loops": (1.0, 10.0), "dipoles_per_loop": (1.0, 10.0),
        "height": (0.8 * p["height"], 1.2 * p["height"]),
        "base_radius": (0.8 * p["base_radius"], 1.2 * p["base_radius"]),
    }


def _span_values(name: str, span: tuple[float, float], nominal: float, points: int) -> F64:
    lo, hi = span
    if name in SWEEP_INTEGER:
        return np.arange(round(lo), round(hi) + 1, dtype=np.float64)
    vals = np.linspace(lo, hi, points)
    if lo <= nominal <= hi:
        vals = np.unique(np.append(vals, nominal))
    return vals


def sensitivity_study(
    setup: Setup,
    data: Measurement | None = None,
    *,
    spans: Mapping[str, tuple[float, float]] | None = None,
    angles: ArrayLike | None = None,
    points: int = 21,
    map_points: int = 41,
) -> SensitivityStudy:
    """One-at-a-time sensitivity of figs. 9–12 around ``setup``.

    Parameters
    ----------
    setup : Setup
        Reference setup (typically a calibration result's ``.setup``).
    data : Measurement, optional
        Measurements: adds the calibration cost (offset solved) to every sweep and the map.
    spans : mapping of str to (low, high), optional
        Override spans (SI; ``n_loops``/``dipoles_per_loop`` as whole numbers) of any of
        :data:`STUDY_PARAMETERS`; others take :func:`default_spans`.
    angles : array-like, shape (a,), optional
        Tilt angles of the curves, rad (default the paper's 33 over 0..85°).
    points : int
        Values per continuous sweep (the nominal value is added).
    map_points : int
        Grid points per axis of the x–y map.

    Returns
    -------
    SensitivityStudy
    """
    if not isinstance(setup, Setup):
        raise v.fail("setup", type(setup).__name__, "a magcilia Setup")
    points = v.integer("points", points, 2)
    map_points = v.integer("map_points", map_points, 2)
    merged = v.intervals("spans", spans, default_spans(setup))
    nominal = setup.params()
    sweeps: dict[str, OATResult] = {}
    notes: list[str] = []
    for name in STUDY_PARAMETERS:
        vals = _span_values(name, merged[name], float(nominal[name]), points)
        res = oat_sweep(setup, name, vals, angles=angles, data=data)
        sweeps[name] = res
        if res.skipped:
            shown = ", ".join(f"{s:.4g}" for s, _ in res.skipped[:5])
            more = ", …" if len(res.skipped) > 5 else ""
            notes.append(f"{name}: {len(res.skipped)} of {vals.size} values skipped (outside the "
                         f"physical domain: {res.skipped[0][1]}): {shown}{more}")
    xs = np.linspace(*merged["x"], map_points)
    ys = np.linspace(*merged["y"], map_points)
    xy = placement_map(setup, xs, ys, angles=angles, data=data)
    n_bad = int(np.isnan(xy.rms_change).sum())
    if n_bad:
        notes.append(f"x-y map: {n_bad} of {xy.rms_change.size} placements skipped (sensing "
                     "element inside the cilium)")
    return SensitivityStudy(setup=setup, sweeps=sweeps, xy_map=xy, spans=merged,
                            notes=tuple(notes), data_source=None if data is None else data.source)


# -- global: Sobol indices -----------------------------------------------------------------------
@dataclass(frozen=True, eq=False)
class SobolResult:
    """First- and total-order Sobol indices with bootstrap confidence intervals (immutable).

    Attributes
    ----------
    names : tuple of str
        Input names.
    S1, S1_conf, ST, ST_conf : ndarray, shape (p,)
        First-order and total indices and the half-widths of their confidence intervals.
    bounds : dict of str to (float, float)
        Sampled ranges (SI).
    n_base : int
        Base sample size N (a power of 2).
    n_evaluations : int
        Model evaluations, N · (p + 2).
    measure : str
        ``"rms"`` (RMS change vs the reference curve) or ``"cost"`` (calibration cost), or
        ``"shape"`` (offset-free change), or ``"function"`` for a plain function.
    conf_level : float
        Confidence level of the intervals.
    elapsed : float
        Wall time, s.
    """

    names: tuple[str, ...]
    S1: F64
    S1_conf: F64
    ST: F64
    ST_conf: F64
    bounds: dict[str, tuple[float, float]]
    n_base: int
    n_evaluations: int
    measure: str
    conf_level: float = 0.95
    elapsed: float = 0.0
    output_mean: float = math.nan
    output_std: float = math.nan

    def table(self) -> list[dict[str, Any]]:
        """Rows per input: name, S1 ± conf, ST ± conf."""
        return [
            {"parameter": n, "S1": float(a), "S1_conf": float(b), "ST": float(c), "ST_conf": float(d)}
            for n, a, b, c, d in zip(self.names, self.S1, self.S1_conf, self.ST, self.ST_conf,
                                     strict=True)
        ]

    def report(self) -> str:
        """Plain-text table."""
        lines = [(f"Sobol indices ({self.measure}; N = {self.n_base}, {self.n_evaluations} "
                 f"evaluations, {self.conf_level:.0%} intervals)"),
                 f"{'parameter':<18} {'S1':>8} {'±':>7} {'ST':>8} {'±':>7}"]
        lines += [f"{r['parameter']:<18} {r['S1']:8.3f} {r['S1_conf']:7.3f} {r['ST']:8.3f} "
                  f"{r['ST_conf']:7.3f}" for r in self.table()]
        return "\n".join(lines)

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready content."""
        return {
            "measure": self.measure, "n_base": self.n_base, "n_evaluations": self.n_evaluations,
            "conf_level": self.conf_level, "elapsed_s": self.elapsed,
            "bounds": {k: list(b) for k, b in self.bounds.items()}, "table": self.table(),
            "output_mean": self.output_mean, "output_std": self.output_std,
        }


def _seeds(rng: int | np.random.Generator | None) -> tuple[int, int]:
    # SALib's analyze ignores a seed of 0 (``if seed:``): draw two non-zero seeds
    gen = np.random.default_rng(rng)
    a, b = gen.integers(1, 2**31 - 1, size=2)
    return int(a), int(b)


def sobol_analysis(
    func: Callable[[F64], ArrayLike],
    bounds: Mapping[str, tuple[float, float]],
    n_base: int = 1024,
    *,
    integer: Sequence[str] = (),
    rng: int | np.random.Generator | None = 0,
    conf_level: float = 0.95,
    num_resamples: int = 100,
    chunk: int = 32768,
    measure: str = "function",
) -> SobolResult:
    """Sobol indices of any vectorised function over a box (the routine behind
    :func:`sobol_indices`).

    Parameters
    ----------
    func : callable
        ``func(X)`` with X of shape (m, p) (columns in ``bounds`` order) returning (m,) outputs.
    bounds : mapping of str to (low, high)
        Ranges of the p inputs (uniform).
    n_base : int
        Base sample size N, a power of 2; the function is evaluated N · (p + 2) times.
    integer : sequence of str
        Inputs that take whole values: sampled uniformly on [low − 0.5, high + 0.5] and rounded,
        so each whole value in [low, high] is equally likely.
    rng : int, Generator or None
        Seeds the scrambled Sobol sequence and the bootstrap.
    conf_level : float
        Level of the bootstrap confidence intervals.
    num_resamples : int
        Bootstrap resamples.
    chunk : int
        Samples per call of ``func`` (bounds memory).
    measure : str
        Label stored in the result.

    Returns
    -------
    SobolResult
    """
    t0 = time.perf_counter()
    names = tuple(bounds)
    if len(names) < 1:
        raise v.fail("bounds", "no inputs", "at least one (low, high) range")
    box: dict[str, tuple[float, float]] = {}
    for name in names:
        try:
            lo, hi = (float(b) for b in bounds[name])
        except (TypeError, ValueError):
            raise v.fail(f"bounds[{name!r}]", bounds[name], "a (low, high) pair of numbers") from None
        if not (math.isfinite(lo) and math.isfinite(hi)) or lo >= hi:
            raise v.fail(f"bounds[{name!r}]", (lo, hi), "a finite (low, high) pair with low < high")
        box[name] = (lo, hi)
    for name in integer:
        if name not in box:
            raise v.fail("integer input", name, "a key of bounds")
    n_base = v.integer("n_base", n_base, 2)
    if n_base & (n_base - 1):
        raise v.fail("n_base", n_base, "a power of 2 (Sobol sequences need one), e.g. 1024")
    chunk = v.integer("chunk", chunk, 1)
    if not 0.0 < conf_level < 1.0:
        raise v.fail("conf_level", conf_level, "between 0 and 1")
    salib_sample = require("SALib.sample.sobol", package="SALib", extra="sensitivity",
                           purpose="Sobol indices")
    salib_analyze = require("SALib.analyze.sobol", package="SALib", extra="sensitivity",
                            purpose="Sobol indices")
    ranges = [[lo - 0.5, hi + 0.5] if n in integer else [lo, hi] for n, (lo, hi) in box.items()]
    problem = {"num_vars": len(names), "names": list(names), "bounds": ranges}
    seed_sample, seed_boot = _seeds(rng)
    X = np.asarray(salib_sample.sample(problem, n_base, calc_second_order=False,  # type: ignore[attr-defined]
                                       seed=seed_sample), dtype=np.float64)
    for j, name in enumerate(names):
        if name in integer:
            X[:, j] = np.clip(np.rint(X[:, j]), box[name][0], box[name][1])
    Y = np.empty(X.shape[0])
    for start in range(0, X.shape[0], chunk):
        stop = min(start + chunk, X.shape[0])
        Y[start:stop] = np.asarray(func(X[start:stop]), dtype=np.float64).reshape(-1)
    if not np.isfinite(Y).all():
        bad = X[int(np.argmax(~np.isfinite(Y)))]
        raise MagciliaError(
            "bounds must keep the model finite; it is not at "
            + ", ".join(f"{n}={x:.6g}" for n, x in zip(names, bad, strict=True))
        )
    if np.ptp(Y) == 0:
        raise MagciliaError("the output does not vary over the bounds, so Sobol indices are "
                            "undefined; widen the bounds")
    res = salib_analyze.analyze(problem, Y, calc_second_order=False,  # type: ignore[attr-defined]
                                num_resamples=num_resamples, conf_level=conf_level,
                                print_to_console=False, seed=seed_boot)
    return SobolResult(
        names=names, S1=np.asarray(res["S1"]), S1_conf=np.asarray(res["S1_conf"]),
        ST=np.asarray(res["ST"]), ST_conf=np.asarray(res["ST_conf"]), bounds=box,
        n_base=n_base, n_evaluations=int(X.shape[0]), measure=measure, conf_level=conf_level,
        elapsed=time.perf_counter() - t0, output_mean=float(Y.mean()), output_std=float(Y.std()),
    )


def sobol_indices(
    setup: Setup,
    bounds: Mapping[str, tuple[float, float]] | None = None,
    n_base: int = 1024,
    angles: ArrayLike | None = None,
    measure: str = "rms",
    data: Measurement | None = None,
    rng: int | np.random.Generator | None = 0,
    *,
    conf_level: float = 0.95,
    num_resamples: int = 100,
) -> SobolResult:
    """Global Sobol sensitivity of the output curve to the calibration parameters.

    Each sample is a full parameter set drawn over ``bounds``; its scalar output is the RMS change
    of the output curve over ``angles`` relative to ``setup``'s own curve (``measure="rms"``), or
    the calibration cost against ``data`` with the offset solved (``measure="cost"``). Evaluation
    goes through :func:`magcilia.model.tilt_output_batch` (no per-sample checks: the bounds must
    keep the sensing element outside the cilium — :data:`~magcilia.calibration.DEFAULT_BOUNDS`
    do).

    Parameters
    ----------
    setup : Setup
        Reference setup; supplies the parameters not in ``bounds`` and the reference curve.
    bounds : mapping of str to (low, high), optional
        Ranges (SI) of any of height, base_radius, tip_radius, x, y, z, n_loops,
        dipoles_per_loop, magnetization_scale; default the calibration bounds
        (:data:`magcilia.calibration.DEFAULT_BOUNDS`). ``n_loops`` and ``dipoles_per_loop`` are
        sampled continuously and rounded (each whole value equally likely).
    n_base : int
        Base sample size N (power of 2); N · (p + 2) model evaluations (p inputs).
    angles : array-like, shape (a,), optional
        Tilt angles, rad (default the paper's 33). With ``measure="cost"`` the data's angles.
    measure : {"rms", "shape", "cost"}
        Scalar output per sample: RMS change vs ``setup``'s curve, the offset-free RMS change
        (:func:`shape_change`), or the calibration cost
        against ``data`` (pass ``measure="cost"`` explicitly; data alone do not switch it).
    data : Measurement, optional
        Required for ``measure="cost"``.
    rng : int, Generator or None
        Seed (sampling and bootstrap).
    conf_level, num_resamples : float, int
        Bootstrap confidence intervals.

    Returns
    -------
    SobolResult
    """
    if not isinstance(setup, Setup):
        raise v.fail("setup", type(setup).__name__, "a magcilia Setup")
    v.choice("measure", measure, MEASURES)
    box = dict(DEFAULT_BOUNDS) if bounds is None else dict(bounds)
    for name in box:
        if name not in SWEEP_PARAMETERS:
            raise v.fail("bounds key", name, "one of " + ", ".join(SWEEP_PARAMETERS))
    check_bound_values(box)
    names = list(box)
    if measure == "cost":
        d_ang = _data_angles(data)
        if data is None or d_ang is None:
            raise v.fail("data", None, "a Measurement when measure='cost'")
        ang, target = d_ang, np.asarray(data.volts)
    else:
        ang = check_angles(angles)
        target = setup.output(ang)

    def evaluate(X: F64) -> F64:
        curves = tilt_output_batch(setup, {n: X[:, j] for j, n in enumerate(names)}, ang)
        if measure == "cost":
            return offset_cost(curves, target)
        if measure == "shape":
            return shape_change(curves, target)
        return rms_change(curves, target)

    return sobol_analysis(evaluate, box, n_base, integer=[n for n in names if n in INTEGER],
                          rng=rng, conf_level=conf_level, num_resamples=num_resamples,
                          measure=measure)


__all__ = [
    "DEFAULT_ANGLES",
    "OATResult",
    "PlacementMap",
    "SensitivityStudy",
    "SobolResult",
    "check_angles",
    "default_spans",
    "oat_sweep",
    "offset_cost",
    "placement_map",
    "rms_change",
    "sensitivity_study",
    "shape_change",
    "sobol_analysis",
    "sobol_indices",
]

