"""One parameter at a time (the paper's Sec. IV.C, figs. 9–12).

* :func:`oat_sweep` — one parameter at a time around a setup: for each value, the RMS change of
  the output curve over an angle range (V), the same with the mean difference removed (the *shape*
  change a fitted offset cannot absorb) and, with measurements, the calibration cost (V², sum over
  the measured angles of squared residuals with the output offset solved in closed form).
  :func:`placement_map` does x and y together on a grid (fig. 9 as a map).
* :func:`sensitivity_study` — all of figs. 9–12 with sensible default spans.

Values that leave the physical domain (the sensing element inside the cilium at some angle) are
skipped with a note; a span that is invalid in itself (a negative height, n < 1, no valid value at
all) is a one-line :class:`~magcilia.MagciliaError`. SI units throughout.
"""

from __future__ import annotations

import logging
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from magcilia import _validate as v
from magcilia._display import Display, Item, Table, column, count, dataframe, rows_table, scaled, si
from magcilia._errors import MagciliaError
from magcilia.analysis.measures import (
    check_angles,
    data_angles,
    offset_cost,
    rms_change,
    shape_change,
)
from magcilia.device.parameters import PARAMETERS, STUDIED, SWEEPABLE
from magcilia.device.parameters import default_spans as registry_spans
from magcilia.device.parameters import parameter as registry_parameter
from magcilia.device.setup import Setup
from magcilia.io.recordings import Measurement
from magcilia.model.batch import tilt_output_batch

logger = logging.getLogger(__name__)

F64 = NDArray[np.float64]

#: parameters that one-at-a-time sweeps accept (keys of ``Setup.params()`` except the offset)
SWEEP_PARAMETERS = SWEEPABLE
#: the sweeps of :func:`sensitivity_study` in figure order (figs. 9, 10, 11, 12)
STUDY_PARAMETERS = STUDIED


# -- one at a time -------------------------------------------------------------------------------
@dataclass(frozen=True, eq=False, repr=False)
class OATResult(Display):
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

    def report(self) -> str:
        """One line: the swept range and the largest changes (display units)."""
        p = PARAMETERS[self.parameter]
        unit = f" {p.display}" if p.display else ""
        lo, hi = (p.to_display(float(x)) for x in (self.values.min(), self.values.max()))
        text = (f"{self.parameter} {lo:.4g}…{hi:.4g}{unit} ({self.values.size} values, "
                f"{len(self.skipped)} skipped): largest RMS change "
                f"{self.rms_change.max() * 1e3:.4g} mV, offset-free "
                f"{self.shape_change.max() * 1e3:.4g} mV")
        if self.cost is not None:
            i = int(np.argmin(self.cost))
            text += (f"; lowest cost {self.cost[i]:.4g} V² at "
                     f"{p.to_display(float(self.values[i])):.4g}{unit}")
        return text

    # -- display --------------------------------------------------------------------------------
    def _display_items(self) -> list[Item]:
        p = PARAMETERS[self.parameter]
        lo, hi = (p.text(float(f(self.values))) for f in (np.min, np.max))
        items = [("", self.parameter), ("values", f"{lo}…{hi} ({self.values.size})"),
                 ("max rms change", si(float(self.rms_change.max()), "V")),
                 ("offset-free", si(float(self.shape_change.max()), "V"))]
        if self.cost is not None:
            i = int(np.argmin(self.cost))
            best = f"{si(float(self.cost[i]), 'V²')} at {p.text(float(self.values[i]))}"
            items.append(("lowest cost", best))
        return [*items, ("skipped", str(len(self.skipped)))]

    def _display_table(self) -> Table | None:
        return rows_table(self.to_dataframe().to_dict("records"))

    def to_dataframe(self) -> Any:
        """The sweep as a ``pandas.DataFrame``, one row per value, SI: the parameter's value
        (``x_m``, ``n_loops``, …: name and SI unit), ``rms_change_V``, ``shape_change_V`` and,
        with data, ``cost_V2``."""
        cols: dict[str, Any] = {column(self.parameter, PARAMETERS[self.parameter].unit):
                                self.values, "rms_change_V": self.rms_change,
                                "shape_change_V": self.shape_change}
        if self.cost is not None:
            cols["cost_V2"] = self.cost
        return dataframe(cols)


def _check_values(parameter: str, values: ArrayLike) -> F64:
    """Swept values: finite, non-empty, inside the parameter's domain (the registry's)."""
    vals = v.finite_array(f"{parameter} values", values).ravel()
    if vals.size == 0:
        raise v.fail(f"{parameter} values", "an empty array", "at least one value")
    p = PARAMETERS[parameter]
    bad = p.outside(vals)
    if bad is not None:
        raise v.fail(f"{parameter} values", bad, p.allowed)
    return vals


def _valid(setup: Setup, changes: Mapping[str, float], angles: F64) -> str | None:
    """None if the changed setup is physical at all angles, else the reason."""
    try:
        setup.replace(**changes).output(angles)
    except MagciliaError as exc:
        return str(exc)
    return None




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
    parameter = registry_parameter(parameter, SWEEP_PARAMETERS).name
    vals = _check_values(parameter, values)
    ang = check_angles(angles)
    d_ang = data_angles(data)
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


@dataclass(frozen=True, eq=False, repr=False)
class PlacementMap(Display):
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

    def report(self) -> str:
        """One line: the grid and the largest change (display units)."""
        x, y = PARAMETERS["x"], PARAMETERS["y"]
        valid = np.isfinite(self.rms_change)
        return (f"x-y map {x.to_display(self.x[0]):.4g}…{x.to_display(self.x[-1]):.4g} x "
                f"{y.to_display(self.y[0]):.4g}…{y.to_display(self.y[-1]):.4g} {x.display}: "
                f"{int(valid.sum())} of {valid.size} placements physical, largest RMS change "
                f"{np.nanmax(self.rms_change) * 1e3:.4g} mV")

    # -- display --------------------------------------------------------------------------------
    def _display_items(self) -> list[Item]:
        items = [("grid", f"{self.x.size}×{self.y.size}"),
                 ("x", f"{scaled(self.x.min(), 1e-3, 'mm')}…{scaled(self.x.max(), 1e-3, 'mm')}"),
                 ("y", f"{scaled(self.y.min(), 1e-3, 'mm')}…{scaled(self.y.max(), 1e-3, 'mm')}"),
                 ("nominal", f"{self.nominal[0] * 1e3:.3g}, {self.nominal[1] * 1e3:.3g} mm"),
                 ("max rms change", si(float(np.nanmax(self.rms_change)), "V")
                  if np.isfinite(self.rms_change).any() else "-")]
        if self.cost is not None and np.isfinite(self.cost).any():
            items.append(("lowest cost", si(float(np.nanmin(self.cost)), "V²")))
        return items

    def to_dataframe(self) -> Any:
        """The map in long form as a ``pandas.DataFrame``, one row per grid point, SI: ``x_m``,
        ``y_m``, ``rms_change_V`` and, with data, ``cost_V2`` (NaN where not physical)."""
        gx, gy = np.meshgrid(self.x, self.y)
        cols: dict[str, Any] = {"x_m": gx.ravel(), "y_m": gy.ravel(),
                                "rms_change_V": self.rms_change.ravel()}
        if self.cost is not None:
            cols["cost_V2"] = self.cost.ravel()
        return dataframe(cols)


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
    d_ang = data_angles(data)
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
@dataclass(frozen=True, eq=False, repr=False)
class SensitivityStudy(Display):
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
        """The same as :meth:`table` (the name of magcilia 0.1)."""
        return self.table()

    def report(self) -> str:
        """Plain text: one line per sweep, the map and the notes."""
        lines = [r.report() for r in self.sweeps.values()]
        lines.append(self.xy_map.report())
        lines += [f"note: {n}" for n in self.notes]
        return "\n".join(lines)

    def table(self) -> list[dict[str, Any]]:
        """Per sweep: span, largest RMS and offset-free change (V) and, with data, the best cost
        and the value where it is reached (SI)."""
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
            "summary": self.table(), "notes": list(self.notes),
            "sweeps": {k: r.to_dict() for k, r in self.sweeps.items()},
            "xy_map": self.xy_map.to_dict(),
        }

    # -- display --------------------------------------------------------------------------------
    def _display_items(self) -> list[Item]:
        rms = {n: float(r.rms_change.max()) for n, r in self.sweeps.items()}
        top = max(rms, key=lambda n: rms[n]) if rms else "-"
        return [("", count(len(self.sweeps), "sweep")),
                ("largest effect", f"{top} ({si(rms[top], 'V')})" if rms else "-"),
                ("map", f"{self.xy_map.x.size}×{self.xy_map.y.size}"),
                ("data", self.data_source or "none"), ("", count(len(self.notes), "note")),
                ("parameters", ", ".join(self.sweeps))]

    def _display_table(self) -> Table | None:
        return rows_table(self.to_dataframe().to_dict("records"))

    def to_dataframe(self) -> Any:
        """One row per sweep as a ``pandas.DataFrame``, SI: ``parameter``, ``unit`` (its SI
        unit), ``nominal``, ``low``, ``high`` (the span), ``max_rms_change_V``,
        ``max_shape_change_V``, ``skipped`` and, with data, ``min_cost_V2`` and ``argmin``."""
        rows = self.table()
        cols: dict[str, Any] = {
            "parameter": [r["parameter"] for r in rows],
            "unit": [PARAMETERS[r["parameter"]].unit for r in rows],
            "nominal": [r["nominal"] for r in rows],
            "low": [r["span"][0] for r in rows], "high": [r["span"][1] for r in rows]}
        for key in ("max_rms_change_V", "max_shape_change_V", "skipped", "min_cost_V2", "argmin"):
            if rows and key in rows[0]:
                cols[key] = [r[key] for r in rows]
        return dataframe(cols)


def default_spans(setup: Setup) -> dict[str, tuple[float, float]]:
    """The default sweep spans around ``setup`` (SI, from the registry): x, y ±1 mm, z 0..1 mm,
    n and k 1..10, height and base radius ±20 %."""
    return registry_spans(setup.params())


def _span_values(name: str, span: tuple[float, float], nominal: float, points: int) -> F64:
    lo, hi = span
    if PARAMETERS[name].domain == "integer":
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
        logger.info("sensitivity: %s swept over %d values", name, vals.size)
        sweeps[name] = res
        if res.skipped:
            shown = ", ".join(f"{s:.4g}" for s, _ in res.skipped[:5])
            more = ", …" if len(res.skipped) > 5 else ""
            notes.append(f"{name}: {len(res.skipped)} of {vals.size} values skipped (outside the "
                         f"physical domain: {res.skipped[0][1]}): {shown}{more}")
    xs = np.linspace(*merged["x"], map_points)
    ys = np.linspace(*merged["y"], map_points)
    xy = placement_map(setup, xs, ys, angles=angles, data=data)
    logger.info("sensitivity: x-y map of %d x %d placements", map_points, map_points)
    n_bad = int(np.isnan(xy.rms_change).sum())
    if n_bad:
        notes.append(f"x-y map: {n_bad} of {xy.rms_change.size} placements skipped (sensing "
                     "element inside the cilium)")
    return SensitivityStudy(setup=setup, sweeps=sweeps, xy_map=xy, spans=merged,
                            notes=tuple(notes), data_source=None if data is None else data.source)
