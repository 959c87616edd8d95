"""Design optimisation: the cilium's geometry, material, placement and sensor for a named objective,
with the Pareto front of range against resolution.

Two objectives (:data:`OBJECTIVES`), each a pair of goals and a choice on the pair's front:

* ``"force-range"``: maximise the tip-force range and minimise the minimum detectable force; the
  chosen design has the largest range among those that resolve ``min_force`` (default: the
  given setup's own minimum detectable force, so the choice resolves at least as finely).
* ``"flow-sensitivity"``: minimise the smallest detectable change of flow speed at the speed
  ``speed`` (the noise over the slope dB/dU there, i.e. the best flow sensitivity) and maximise
  the flow range; the chosen design has the finest resolution at ``speed`` among those whose
  range reaches ``speed``.

**Definitions** (the same as :func:`magcilia.design_metrics`, which the exact metrics reproduce
for a single-axis sensor). The *minimum detectable* value is the field noise of one reading over
the field's slope, combined over the sensor's axes as ``1 / sqrt(Σ (s_i / σ_i)²)`` (s: dB/dF or
dB/dU on axis i, σ_i its RMS noise; one axis for the HMC1021Z: ``σ / |s|``, as design_metrics).
The *range* is the measurand's value where the read-out ends (:func:`~magcilia.readout.design.
read_range`, as design_metrics), the first of

1. the sensor's rated range: an axis's |B_i| reaches its full scale (±6 gauss on the HMC1021Z's
   sensitive axis; ±8 gauss per axis on the MMC5983MA), or the total field |B| reaches the rated
   range of the total field (the HMC1021Z's datasheet states its ±6 gauss for the total applied
   field; ``constraints["field"]`` sets another), interpolated between sweep points;
2. a fold: the reading ``Σ w_i B_i`` with the zero-load weights ``w_i = s_i / σ_i²`` (the best
   linear read-out; for one axis the output itself) turns back, so readings become ambiguous.

The sweep runs to the elastica's large-deflection limit, the force ``3 L / C`` whose *linear* tip
deflection would be three cilium heights (C = :func:`magcilia.tip_compliance`), where the cilium
is bent far over; for flow, to the speed whose drag on the upright cilium is that force, or the
drag law's Reynolds limit, whichever is lower. When the sweep ends before the read-out does, the
range is *not reached*: its value is the sweep's end, a lower bound (``Candidate.reached`` is
False, reports print "≥ X"), and a range comparison with it says so.

**Constraints.** Every returned design lies within ``bounds`` (fabrication limits: the registry's
calibration bounds by default, :data:`DEFAULT_BOUNDS`), has ``tip_radius ≤ base_radius``, keeps
the sensing element outside the cilium, starts within the sensor's rated range at zero load
(the total field included: the rated range is the default constraint), keeps |B| below the
single-axis part's flip (disturbing) field over its whole range, and meets any of
``constraints``: ``{"range": lowest range, "minimum": largest minimum detectable value,
"field": the rated range of |B| at the element}`` (SI: N for force, m/s for flow, T; "field"
replaces the sensor's own, e.g. 20 gauss to let the HMC1021Z's total field go up to its flip
field). The Pareto front is that of these feasible designs; the chosen design also meets the
objective's own requirement (``min_force``; for flow, a range that reaches ``speed``): it is
*eligible*.

**Layouts.** Each design's field comes from a layout converged at the sensing element
(:meth:`magcilia.Setup.resolve_layout`): the candidates are new designs, so their layouts are
converged unless the setup asks for the paper's by name (``layout="paper"``: the candidates keep
it); the reference keeps its own rule (a given layout is used as is, warned about above 1 %).

**Algorithm.** A scrambled Sobol' sample (``scipy.stats.qmc``, seeded by ``rng``) of ``n``
designs over the bounds (rounded up to a power of two), screened with cheap, vectorised
metrics: the tilt model of all designs at once (:class:`magcilia.model.TiltBatch`) at the
equivalent rigid tilt ``θ = atan(C F / L)`` (the chord of a tip-loaded cantilever, exact for
small loads), the closed-form tip compliance of each frustum, and for flow the cylinder drag
per length (tip-equivalent force 3/8 of the total). Non-dominated sorting of the screened
designs by the objective's two goals (:func:`pareto_ranks`) picks the fronts' designs (rank by
rank, ``refine`` of them) and the screen's best candidates for the chosen design; each is
then measured with the exact metrics (large-deflection :func:`magcilia.bend_sweep` and the full
field model), as tasks through :mod:`magcilia.execution` (a local pool, or a Dask cluster with
``scheduler``); ``polish`` rounds then measure 16 designs each in a shrinking Sobol' box around
the chosen design, and the exact fronts and the chosen design come from all of those. Screens
of more than :data:`SCREEN_CHUNK` designs run in chunks, as tasks too. NSGA-II (pymoo)
was not used: for two goals a dense quasi-random screen covers the front, and the exact
refinement decides; no heavy dependency is needed.
"""

from __future__ import annotations

import logging
import math
import time
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field, replace
from typing import Any

import numpy as np
from numpy.typing import NDArray

from magcilia import _validate as v
from magcilia._display import Display, Item, Table, dataframe, number, rows_table
from magcilia._errors import MagciliaError
from magcilia.device.magnetometer import MAGNETOMETERS, Magnetometer
from magcilia.device.parameters import MEASURANDS, PARAMETERS
from magcilia.device.sensor import DEFAULT_BANDWIDTH, Sensor
from magcilia.device.setup import Setup
from magcilia.device.stiffness import composite_modulus
from magcilia.execution import run_tasks
from magcilia.mechanics import WATER, Flow, Fluid, bend, bend_sweep, tip_compliance
from magcilia.mechanics.drag import drag_per_length, max_speed
from magcilia.model.batch import TiltBatch
from magcilia.readout.design import SWEEP_ENDS, rated_ratio, read_range, sweep_fields

F64 = NDArray[np.float64]
logger = logging.getLogger(__name__)

#: the objectives :func:`optimise_design` knows
OBJECTIVES = ("force-range", "flow-sensitivity")
#: the design variables (registry names), in table order
VARIABLES = ("height", "base_radius", "tip_radius", "magnetization_scale", "cobalt_mass",
             "x", "y", "z")
#: default search bounds, SI: the registry's calibration bounds of the geometry and placement,
#: and a tip radius of 0.02–0.1 mm (a tip force needs a finite tip); the material stays the
#: setup's unless magnetization_scale or cobalt_mass is given a bound
DEFAULT_BOUNDS: dict[str, tuple[float, float]] = {
    "height": PARAMETERS["height"].bound,  # type: ignore[dict-item]
    "base_radius": PARAMETERS["base_radius"].bound,  # type: ignore[dict-item]
    "tip_radius": (2e-5, 1e-4),
    "x": PARAMETERS["x"].bound,  # type: ignore[dict-item]
    "y": PARAMETERS["y"].bound,  # type: ignore[dict-item]
    "z": PARAMETERS["z"].bound,  # type: ignore[dict-item]
}
#: the single-axis sensor (the setup's own) by name in ``sensors``
SINGLE_AXIS = "HMC1021Z"
#: the large-deflection limit: linear tip deflection in cilium heights (design_metrics' sweep end)
DEFLECTION_LIMIT = 3.0
#: screening grid: equivalent linear deflections C F / L
_SCREEN_U = np.concatenate([np.linspace(0.0, 0.6, 25), np.linspace(0.65, DEFLECTION_LIMIT, 48)])
#: small equivalent tilt of the screen's zero-load slope, rad
_SLOPE_TILT = 1e-4


# -- sensor choices -------------------------------------------------------------------------------
@dataclass(frozen=True)
class SensorChoice:
    """A sensor a design may use: the setup's single-axis element (``sensor``) or a 3-axis
    :class:`~magcilia.device.magnetometer.Magnetometer` at the same point (the element's place
    below the case top: the setup's depth), its axes turned by the part's rotation.

    Attributes
    ----------
    name : str
    sensor : Sensor or Magnetometer
    """

    name: str
    sensor: Sensor | Magnetometer

    @property
    def axes(self) -> int:
        """1 for the single-axis element, 3 for a magnetometer."""
        return 1 if isinstance(self.sensor, Sensor) else 3

    def sigma(self, bandwidth: tuple[float, float]) -> F64:
        """RMS field noise of one reading per board axis, T, shape (3,) (inf: axis not read).
        A magnetometer's noise at its rate with its LSB's quantisation (LSB/√12) added."""
        s = self.sensor
        if isinstance(s, Sensor):
            return np.array([s.noise_rms(*bandwidth), math.inf, math.inf])
        return np.sqrt(np.asarray(s.noise) ** 2 + np.asarray(s.resolution) ** 2 / 12.0)

    @property
    def full_scale(self) -> F64:
        """Range per read axis, T, shape (3,) (inf: axis not read)."""
        s = self.sensor
        if isinstance(s, Sensor):
            return np.array([s.field_range, math.inf, math.inf])
        return np.asarray(s.field_range, dtype=np.float64)

    @property
    def rated_total(self) -> float:
        """Rated range of the total field |B|, T: the single-axis element's range (its datasheet
        states it for the total applied field), inf for a magnetometer (per-axis ranges)."""
        return self.sensor.field_range if isinstance(self.sensor, Sensor) else math.inf

    def total_limit(self, field: float | None) -> float:
        """The rated range of |B| in force, T: ``field`` (the ``"field"`` constraint) when
        given, else :attr:`rated_total`."""
        return self.rated_total if field is None else float(field)

    @property
    def flip(self) -> float:
        """|B| beyond which the element may flip, T (inf for a magnetometer: not modelled)."""
        return self.sensor.flip_field if isinstance(self.sensor, Sensor) else math.inf

    def reading(self, b: F64) -> F64:
        """Board-frame fields (..., 3), T, on the sensor's axes (the single axis: x, y and z
        of the board; only x is read)."""
        if isinstance(self.sensor, Sensor):
            return b
        return b @ self.sensor.rotation


def sensor_choices(sensors: Sequence[str | Sensor | Magnetometer], setup: Setup
                   ) -> tuple[SensorChoice, ...]:
    """The checked ``sensors`` of :func:`optimise_design`: ``"HMC1021Z"`` (the setup's own
    single-axis sensor, its gain and bridge as given), a name of
    :data:`~magcilia.device.magnetometer.MAGNETOMETERS` (the preset's defaults), a
    :class:`~magcilia.Sensor` or a :class:`~magcilia.device.magnetometer.Magnetometer`."""
    if isinstance(sensors, (str, Sensor, Magnetometer)):
        sensors = (sensors,)
    out: list[SensorChoice] = []
    for item in sensors:
        if isinstance(item, (Sensor, Magnetometer)):
            out.append(SensorChoice(item.name, item))
        elif isinstance(item, str) and item.upper() == SINGLE_AXIS:
            out.append(SensorChoice(setup.sensor.name, setup.sensor))
        elif isinstance(item, str):
            try:
                part = Magnetometer.preset(item)
            except MagciliaError:
                raise v.fail("sensor", item, f"{SINGLE_AXIS} (the setup's single-axis sensor) "
                             "or a 3-axis preset (" + ", ".join(MAGNETOMETERS) + ")") from None
            out.append(SensorChoice(item.upper(), part))
        else:
            raise v.fail("sensor", type(item).__name__, "a name, a Sensor or a Magnetometer")
    if not out:
        raise v.fail("sensors", "none", f"at least one sensor (e.g. {SINGLE_AXIS!r})")
    names = [c.name for c in out]
    if len(set(names)) != len(names):
        raise v.fail("sensors", names, "distinct sensors")
    return tuple(out)


# -- non-dominated sorting ------------------------------------------------------------------------
def pareto_ranks(objectives: Any, limit: int | None = None) -> NDArray[np.int64]:
    """Non-dominated sorting: the Pareto rank of each point (0: the first front), all goals
    minimised.

    Point i dominates j when it is no worse in every goal and better in one. Rank 0 holds the
    points no other dominates; rank r those dominated only by ranks below r.

    Parameters
    ----------
    objectives : array-like, shape (N, m)
        Goal values (minimised; negate a goal to maximise it). Rows with a NaN are never ranked.
    limit : int, optional
        Stop after the fronts that hold at least ``limit`` points (the rest get rank -1).

    Returns
    -------
    ndarray of int, shape (N,)
        Ranks, -1 for rows not ranked.

    Examples
    --------
    >>> pareto_ranks([[1.0, 4.0], [2.0, 2.0], [3.0, 3.0], [4.0, 1.0]]).tolist()
    [0, 0, 1, 0]
    """
    f = np.asarray(objectives, dtype=np.float64)
    if f.ndim != 2:
        raise v.fail("objectives", f"an array of shape {f.shape}", "shape (N, m)")
    ranks = np.full(f.shape[0], -1, dtype=np.int64)
    left = np.nonzero(~np.isnan(f).any(axis=1))[0]
    if f.shape[1] == 2:
        return _ranks_2d(f, left, ranks, limit)
    rank, ranked = 0, 0
    while left.size and (limit is None or ranked < limit):
        g = f[left]
        dominated = np.zeros(left.size, dtype=bool)
        for start in range(0, left.size, 512):  # blocks: 512 × N comparisons at a time
            block = g[start:start + 512]
            le = np.all(g[None, :, :] <= block[:, None, :], axis=2)
            lt = np.any(g[None, :, :] < block[:, None, :], axis=2)
            dominated[start:start + 512] = np.any(le & lt, axis=1)
        front = left[~dominated]
        ranks[front] = rank
        ranked += front.size
        left = left[dominated]
        rank += 1
    return ranks


def _ranks_2d(f: F64, left: NDArray[np.int64], ranks: NDArray[np.int64], limit: int | None
              ) -> NDArray[np.int64]:
    """:func:`pareto_ranks` of two goals in O(N log N) per front: the distinct points sorted by
    the first goal, then the second; a point is dominated exactly when an earlier one is no worse
    in the second goal (equal points share their rank)."""
    points, inverse = np.unique(f[left], axis=0, return_inverse=True)
    inverse = inverse.reshape(-1)
    counts = np.bincount(inverse, minlength=points.shape[0])
    point_rank = np.full(points.shape[0], -1, dtype=np.int64)
    rest = np.arange(points.shape[0])  # lexicographic order, kept by every selection
    rank, ranked = 0, 0
    while rest.size and (limit is None or ranked < limit):
        second = points[rest, 1]
        before = np.concatenate([[np.inf], np.minimum.accumulate(second)[:-1]])
        front = second < before
        point_rank[rest[front]] = rank
        ranked += int(counts[rest[front]].sum())
        rest = rest[~front]
        rank += 1
    ranks[left] = point_rank[inverse]
    return ranks


# -- results --------------------------------------------------------------------------------------
@dataclass(frozen=True, eq=False, repr=False)
class Candidate(Display):
    """One design with its exact metrics (SI).

    Attributes
    ----------
    params : dict of str to float
        The design variables (:data:`VARIABLES` searched or fixed), SI.
    sensor : str
        The sensor choice's name.
    sensitivity : float
        Zero-load (force) or at-``speed`` (flow) slope of the field on the read axes, T per N
        or T per m/s (the norm over a 3-axis part's axes; the single axis's |dB_x/dF|).
    minimum : float
        Minimum detectable force (N) or speed change at ``speed`` (m/s).
    range : float
        Force (N) or flow-speed (m/s) range.
    limited_by : str
        What ends the range.
    peak_field : float
        Largest |B| at the element over the range, T.
    violated : str
        The first constraint the design breaks, "" when feasible (the sensor's and the
        cilium's limits, ``constraints``).
    rank : int
        Pareto rank among the feasible refined designs (0: the front; -1 infeasible).
    eligible : bool
        Whether it also meets the objective's own requirement (``min_force``; for flow, a range
        that reaches ``speed``): the chosen design is the best eligible one.
    reached : bool
        Whether the read-out's range ends within the sweep (rated range or fold); False: the
        sweep ended first and ``range`` is a lower bound.
    """

    params: dict[str, float]
    sensor: str
    sensitivity: float
    minimum: float
    range: float
    limited_by: str
    peak_field: float
    violated: str = ""
    rank: int = -1
    eligible: bool = False
    reached: bool = True

    @property
    def feasible(self) -> bool:
        """Whether every constraint holds."""
        return not self.violated

    def row(self, unit: str) -> dict[str, Any]:
        """Flat SI row: each variable with its unit suffix, then the metrics (``unit``: the
        measurand's SI unit token, ``N`` or ``m_per_s``)."""
        row: dict[str, Any] = {}
        for name, value in self.params.items():
            p = PARAMETERS[name]
            suffix = f"_{_token(p.unit)}" if p.unit else ""
            row[f"{name}{suffix}"] = value
        row["sensor"] = self.sensor
        row[f"minimum_{unit}"] = self.minimum
        row[f"range_{unit}"] = self.range
        row["range_reached"] = self.reached
        row["limited_by"] = self.limited_by
        row["peak_field_T"] = self.peak_field
        row["rank"] = self.rank
        row["eligible"] = self.eligible
        row["violated"] = self.violated
        return row

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready content (SI)."""
        return {"params": dict(self.params), "sensor": self.sensor,
                "sensitivity_T_per_unit": self.sensitivity, "minimum": self.minimum,
                "range": self.range, "range_reached": self.reached,
                "limited_by": self.limited_by, "peak_field_T": self.peak_field,
                "violated": self.violated, "rank": self.rank, "eligible": self.eligible}

    def report(self) -> str:
        """One line in display units."""
        return ", ".join(f"{k} {t}" for k, t in self._display_items())

    def _display_items(self) -> list[Item]:
        items = [(n, PARAMETERS[n].text(val)) for n, val in self.params.items()]
        return [("minimum", number(self.minimum)),
                ("range", ("" if self.reached else "≥ ") + number(self.range)),
                ("sensor", self.sensor), *items]


@dataclass(frozen=True, eq=False, repr=False)
class DesignOptimum(Display):
    """Result of :func:`optimise_design` (all SI).

    Attributes
    ----------
    objective : str
        One of :data:`OBJECTIVES`.
    quantity : str
        The measurand: ``"force"`` or ``"flow"``.
    designs : tuple of Candidate
        Every refined design with its exact metrics, rank and constraint verdict.
    best : Candidate
        The chosen design (see the module docstring).
    reference : Candidate
        The given setup's own exact metrics (its sensor: the first choice).
    best_setup : Setup
        The chosen design as a setup (the given setup with the design's variables).
    bounds : dict of str to (float, float)
        The searched bounds.
    fixed : dict of str to float
        Constraints in force: ``min_force`` (N), ``speed`` (m/s), ``range``, ``minimum``.
    screened : int
        Designs screened.
    eliminated : dict of str to int
        Screened designs removed by each constraint (the first each breaks).
    seconds : float
        Wall time of the search.
    """

    objective: str
    quantity: str
    designs: tuple[Candidate, ...]
    best: Candidate
    reference: Candidate
    best_setup: Setup
    bounds: dict[str, tuple[float, float]]
    fixed: dict[str, float]
    screened: int
    eliminated: dict[str, int]
    seconds: float
    _unit: str = field(default="N", repr=False)

    @property
    def front(self) -> tuple[Candidate, ...]:
        """The Pareto front (rank 0) of the feasible refined designs, by increasing minimum."""
        return tuple(sorted((d for d in self.designs if d.rank == 0), key=lambda d: d.minimum))

    @property
    def beats_reference(self) -> bool:
        """Whether the chosen design is known to have both a larger range and a finer resolution
        than the reference: a reference range that was not reached is a lower bound, so no
        range is known to exceed it."""
        return self.reference.reached and self.best.range > self.reference.range and \
            self.best.minimum < self.reference.minimum

    @property
    def comparison(self) -> str:
        """The chosen design against the reference, as a statement: the resolution's ratio
        (``"resolution 1.42× finer"``, ``coarser`` or ``the same``), then the range's as far as it
        is known (a range the sweep did not reach is a lower bound, ``≥ X``), e.g. ``"range 2.1×
        larger"``, ``"range at least 1.3× larger (the chosen design's not reached)"`` or ``"range
        not known to be larger (neither range reached: ≥ 0.3426 mN against ≥ 0.13 mN)"``.
        :attr:`beats_reference` is true when both are known to be better."""
        q = MEASURANDS[self.quantity]
        best, ref = self.best, self.reference
        if best.minimum < ref.minimum:
            parts = [f"resolution {ref.minimum / best.minimum:.3g}× finer"]
        elif best.minimum > ref.minimum:
            parts = [f"resolution {best.minimum / ref.minimum:.3g}× coarser"]
        else:
            parts = ["resolution the same"]
        both = f"{_range_text(best, q)} against {_range_text(ref, q)}"
        if best.reached and ref.reached:
            if best.range == ref.range:
                parts.append("range the same")
            else:
                ratio = max(best.range, ref.range) / min(best.range, ref.range)
                more = "larger" if best.range > ref.range else "smaller"
                parts.append(f"range {ratio:.3g}× {more}")
        elif not ref.reached and best.reached and best.range < ref.range:
            parts.append(f"range at least {ref.range / best.range:.3g}× smaller (the reference's "
                         f"not reached: {both})")
        elif not best.reached and ref.reached and best.range > ref.range:
            parts.append(f"range at least {best.range / ref.range:.3g}× larger (the chosen "
                         f"design's not reached: {both})")
        else:
            which = ("neither range reached" if not (best.reached or ref.reached) else
                     "the reference's range not reached" if best.reached else
                     "the chosen design's range not reached")
            parts.append(f"range not known to be larger ({which}: {both})")
        return "; ".join(parts)

    def table(self) -> list[dict[str, Any]]:
        """The front as rows (SI; keys carry their unit: ``height_m``, ``minimum_N``,
        ``range_N`` or ``minimum_m_per_s``)."""
        return [d.row(self._unit) for d in self.front]

    def to_dataframe(self) -> Any:
        """Every refined design (front first, then by rank) as a ``pandas.DataFrame``, SI
        columns named with their unit."""
        rows = [d.row(self._unit) for d in sorted(
            self.designs, key=lambda d: (d.rank < 0, d.rank, d.minimum))]
        return dataframe({k: [r[k] for r in rows] for k in rows[0]} if rows else {})

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready content (SI)."""
        return {
            "objective": self.objective, "quantity": self.quantity,
            "unit": MEASURANDS[self.quantity].unit, "best": self.best.to_dict(),
            "reference": self.reference.to_dict(),
            "beats_reference": self.beats_reference,
            "front": [d.to_dict() for d in self.front],
            "designs": [d.to_dict() for d in self.designs],
            "bounds": {k: list(b) for k, b in self.bounds.items()},
            "constraints": dict(self.fixed), "screened": self.screened,
            "eliminated": dict(self.eliminated), "seconds": self.seconds,
        }

    def report(self) -> str:
        """Plain text in display units: the chosen design against the reference, then the
        front."""
        q = MEASURANDS[self.quantity]
        what = "minimum detectable force" if self.quantity == "force" else \
            f"minimum detectable speed change at {q.text(self.fixed.get('speed', math.nan))}"
        lines = [(f"{self.objective}: {self.screened} designs screened, {len(self.designs)} "
                  f"refined, {len(self.front)} on the front ({self.seconds:.3g} s)"),
                 f"{'':<10} {'range':>12} {'minimum':>12}   ({what})"]
        for label, d in (("reference", self.reference), ("best", self.best)):
            lines.append(f"{label:<10} {_range_text(d, q):>12} {q.text(d.minimum, 4):>12}   "
                         f"{d.sensor}; {d.limited_by}")
        lines.append("best design: " + ", ".join(
            f"{n} {PARAMETERS[n].text(val, 4)}" for n, val in self.best.params.items()))
        lines.append(f"compared with the reference: {self.comparison}")
        lines.append("front (minimum, range):")
        lines += [f"  {q.text(d.minimum, 4):>12} {_range_text(d, q):>12}  {d.sensor}"
                  for d in self.front]
        lines.append(f"{self.best_setup.modulus.note()}: every range and minimum above scales "
                     "with it")
        return "\n".join(lines)

    def _display_items(self) -> list[Item]:
        q = MEASURANDS[self.quantity]
        return [("", self.objective), ("best range", _range_text(self.best, q)),
                ("best minimum", q.text(self.best.minimum)), ("sensor", self.best.sensor),
                ("front", str(len(self.front))), ("screened", str(self.screened))]

    def _display_table(self) -> Table | None:
        return rows_table(self.table())


def _range_text(d: Candidate, q: Any) -> str:
    """A design's range in display units, "≥ X" when not reached."""
    return ("" if d.reached else "≥ ") + q.text(d.range, 4)


def _token(unit: str) -> str:
    return unit.replace("/", "_per_").replace("^", "").replace("*", "")


# -- exact metrics (one design; run as tasks) -----------------------------------------------------
@dataclass(frozen=True)
class _Task:
    """What one exact evaluation needs (picklable)."""

    setup: Setup
    choice: SensorChoice
    quantity: str
    speed: float
    bandwidth: tuple[float, float]
    fluid: Fluid
    points: int
    total: float = math.inf


def _range(q: F64, b: F64, choice: SensorChoice, weights: F64, end_note: str, total: float
           ) -> tuple[float, str, int, bool]:
    """Range from q[0] (the sensor's rated range on its axes or of |B| ≤ ``total``,
    interpolated, or a fold of the weighted reading; else the end of the sweep: not reached),
    what ends it, the last sweep index within it and whether it was reached."""
    reading = choice.reading(b)
    proj = reading @ np.where(np.isfinite(weights), weights, 0.0)
    return read_range(q, reading, b, choice.full_scale, total, proj, choice.axes, end_note)


def _information(slope: F64, sigma: F64) -> float:
    """Σ (s_i / σ_i)² over the read axes (1/unit²)."""
    return float(np.sum((slope / sigma) ** 2))


def _evaluate(task: _Task) -> dict[str, Any]:
    """The exact metrics of one design (a top-level function: runs in worker processes), its
    layout by the layout rule at the sensing element."""
    setup, choice = task.setup.resolve_layout(), task.choice
    sigma = choice.sigma(task.bandwidth)
    c = setup.cilium
    f_max = DEFLECTION_LIMIT * c.height / tip_compliance(setup)
    if task.quantity == "force":
        delta = 1e-6 * f_max
        b_pm = choice.reading(setup.field(bend_sweep(setup, forces=[-delta, delta])))
        slope = (b_pm[1] - b_pm[0]) / (2.0 * delta)
        q, b, note = sweep_fields(setup, np.linspace(0.0, f_max, task.points), None)
        end = note or SWEEP_ENDS["force"]
    else:
        fluid, u = task.fluid, task.speed
        d = 2.0 * c.max_radius
        u_drag = 2.0 * math.sqrt(f_max / (0.5 * fluid.density * d * c.height))
        u_re = max_speed(d, fluid)
        u_max = min(u_drag, u_re)
        flow = Flow.uniform(1.0, fluid)
        speeds = np.concatenate([[0.0], np.geomspace(u_max * 1e-5, u_max, task.points - 1)])
        q, b, note = sweep_fields(setup, speeds, flow)
        end = note or (SWEEP_ENDS["drag"] if u_re <= u_drag else SWEEP_ENDS["flow"])
        if u * 1.01 >= u_max or (q.size and u * 1.01 >= q[-1]):
            slope = np.full(3, math.nan)
        else:
            h = 0.01 * u
            b_pm = choice.reading(np.concatenate(
                [setup.field(bend(setup, flow=flow.with_speed(s))) for s in (u - h, u + h)]))
            slope = (b_pm[1] - b_pm[0]) / (2.0 * h)
    info = _information(slope, sigma)
    minimum = 1.0 / math.sqrt(info) if info > 0.0 else math.inf
    sensitivity = float(np.linalg.norm(slope[np.isfinite(sigma)]))
    if q.size < 2:
        return {"sensitivity": sensitivity, "minimum": minimum, "range": 0.0,
                "limited_by": note or "no sweep", "peak_field": math.nan, "reached": False}
    weights = np.nan_to_num(slope / sigma**2, nan=0.0, posinf=0.0, neginf=0.0)
    if not np.any(weights):  # no slope at the operating point: read the largest axis
        weights = np.eye(3)[int(np.argmax(np.abs(choice.reading(b[-1]) - choice.reading(b[0]))
                                          / np.where(np.isfinite(sigma), sigma, np.inf)))]
    rng, why, last, reached = _range(q, b, choice, weights, end, task.total)
    peak = float(np.max(np.linalg.norm(b[:last + 1], axis=1)))
    return {"sensitivity": sensitivity, "minimum": minimum, "range": rng, "limited_by": why,
            "peak_field": peak, "reached": reached}


def _evaluate_many(tasks: Sequence[_Task]) -> list[dict[str, Any]]:
    """:func:`_evaluate` of a chunk of designs (one task of the execution layer)."""
    out = []
    for task in tasks:
        try:
            out.append(_evaluate(task))
        except (ValueError, ArithmeticError) as exc:  # MagciliaError, a singular solve: a
            # design the model refuses is infeasible, not the end of the search
            out.append({"sensitivity": math.nan, "minimum": math.inf, "range": 0.0,
                        "limited_by": f"model error ({exc})", "peak_field": math.nan,
                        "reached": False})
    return out


def _run(fn: Callable[[Any], Any], tasks: list[tuple[str, Any]], workers: int | None,
         scheduler: str | None, progress: bool) -> list[Any]:
    """Run ``tasks`` through the execution layer (:func:`magcilia.execution.run_tasks`); the
    values in order, a failed task re-raised."""
    results = run_tasks(fn, tasks, workers=workers, scheduler=scheduler, progress=progress)
    values = []
    for r in results:
        if r.error:
            raise MagciliaError(f"design task {r.key} failed: {r.error}")
        values.append(r.value)
    return values


# -- the screen -----------------------------------------------------------------------------------
@dataclass(frozen=True)
class _Screen:
    """Proxy metrics of the screened designs (arrays over N); ``violated`` indexes
    :data:`_REASONS` (0: none)."""

    minimum: F64
    range: F64
    violated: NDArray[np.int64]


#: why the screen drops a design, by code (0: it does not)
_REASONS = ("", "tip_radius <= base_radius", "element outside the cilium",
            "sensor range at zero load", "flip field")
#: exact evaluations run in process (no pool) when no more than this many designs are measured
#: and no scheduler is given: ~0.5 s of work, less than a process pool's start
SMALL_BATCH = 16
#: with ``workers=None``, a pool (one process per core) measures batches of at least this many
#: designs; smaller ones run in process (measured here: 96 designs took 2.4 s in process, 4.1 s
#: with a pool of 2 that has to start)
POOL_FROM = 256
#: designs per screening chunk: ~30 MB of fields each; more chunks run as tasks through the
#: execution layer
SCREEN_CHUNK = 16384


def _screen_chunk(arg: tuple[Any, ...]) -> _Screen:
    """:func:`_screen` of one chunk (a top-level function: runs in worker processes)."""
    return _screen(*arg)


def _compliance(setup: Setup, values: dict[str, F64]) -> F64:
    """Small-load tip compliance of each design, m/N (frusta in closed form; a measured profile
    scaled from the setup's)."""
    c = setup.cilium
    h, rb, rt = values["height"], values["base_radius"], values["tip_radius"]
    modulus = _modulus(setup, values)
    if c.profile is not None:
        c0 = tip_compliance(setup)
        return np.asarray(c0 * (h / c.height) ** 3 * (c.base_radius / rb) ** 4
                          * setup.youngs_modulus / modulus, dtype=np.float64)
    i0 = math.pi * rb**4 / 4.0
    with np.errstate(divide="ignore"):
        return np.asarray(h**3 / (3.0 * modulus * i0 * (rt / rb)), dtype=np.float64)


def _modulus(setup: Setup, values: dict[str, F64]) -> F64:
    """Young's modulus of each design, Pa (Guth–Gold of its cobalt fraction unless the cilium
    fixes it)."""
    n = values["height"].size
    if setup.cilium.youngs_modulus is not None or "cobalt_mass" not in values:
        return np.full(n, setup.youngs_modulus)
    m = setup.material
    v_co = values["cobalt_mass"] / m.cobalt_density
    phi = v_co / (v_co + m.polymer_mass / m.polymer_density)
    return np.asarray(composite_modulus(m.polymer_modulus, phi), dtype=np.float64)


def _moment_scale(setup: Setup, values: dict[str, F64]) -> F64:
    """Magnetization scale of each design relative to the setup's full magnetization (the
    cobalt fraction folded in)."""
    scale = values["magnetization_scale"]
    if "cobalt_mass" in values:
        m = setup.material
        v_co = values["cobalt_mass"] / m.cobalt_density
        phi = v_co / (v_co + m.polymer_mass / m.polymer_density)
        scale = scale * phi / m.volume_fraction
    return np.asarray(scale, dtype=np.float64)


def _first(mask: NDArray[np.bool_]) -> NDArray[np.int64]:
    """Index of the first True per row, or the row length when none."""
    any_ = mask.any(axis=1)
    return np.where(any_, np.argmax(mask, axis=1), mask.shape[1]).astype(np.int64)


def _curve_range(q: F64, reading: F64, mags: F64, choice: SensorChoice, weights: F64, end: F64,
                 total: float) -> tuple[F64, NDArray[np.int64]]:
    """Vectorised :func:`_range` of N proxy curves: q (N, a), readings (N, a, 3), |B| (N, a),
    weights (N, 3), the sweep's end (N,), the rated range of |B| (T); returns the ranges (N,)
    and the last index within each."""
    scale = choice.full_scale
    ratio = rated_ratio(reading, scale, mags, total)[0]
    i_sat = _first(ratio > 1.0)
    proj = np.einsum("nak,nk->na", reading, weights)
    dp = np.diff(proj, axis=1)
    first = _first(dp != 0.0)
    sign = np.sign(np.take_along_axis(dp, np.minimum(first, dp.shape[1] - 1)[:, None], 1))
    i_fold = _first(np.sign(dp) * sign < 0.0)
    a = q.shape[1]
    out = end.copy()
    last = np.full(q.shape[0], a - 1, dtype=np.int64)
    rows = np.arange(q.shape[0])
    sat = (i_sat < a) & (i_sat <= i_fold)
    lo = np.maximum(i_sat - 1, 0)
    hi = np.minimum(i_sat, a - 1)
    r0, r1 = ratio[rows, lo], ratio[rows, hi]
    with np.errstate(divide="ignore", invalid="ignore"):
        t = np.where(r1 > r0, (1.0 - r0) / (r1 - r0), 0.0)
    at_sat = q[rows, lo] + t * (q[rows, hi] - q[rows, lo])
    out = np.where(sat, np.where(i_sat == 0, 0.0, at_sat), out)
    last = np.where(sat, lo, last)
    fold = ~sat & (i_fold < a - 1)
    out = np.where(fold, q[rows, np.minimum(i_fold, a - 1)], out)
    last = np.where(fold, np.minimum(i_fold, a - 1), last)
    return out, last


def _screen(setup: Setup, values: dict[str, F64], sensor_index: NDArray[np.int64],
            choices: tuple[SensorChoice, ...], quantity: str, speed: float,
            bandwidth: tuple[float, float], fluid: Fluid, field_limit: float | None = None
            ) -> _Screen:
    """Proxy minimum and range of every design (see the module docstring); the range ends where
    a read axis or |B| leaves the rated range (``field_limit``, T, for |B|; None: each sensor's
    own), and designs whose proxy |B| over the range passes 1.2 times the flip field (the
    proxy's margin) are marked."""
    n = values["height"].size
    compliance = _compliance(setup, values)
    length = values["height"]
    minimum = np.full(n, math.inf)
    rng_ = np.zeros(n)
    peak = np.full(n, math.inf)
    flip = np.full(n, math.inf)
    finite = np.zeros(n, dtype=bool)
    u_grid = _SCREEN_U
    angles = np.concatenate([[0.0, _SLOPE_TILT], np.arctan(u_grid[1:])])
    batch = TiltBatch(setup, angles)
    params = {k: values[k] for k in ("height", "base_radius", "tip_radius", "x", "y", "z")}
    params["magnetization_scale"] = _moment_scale(setup, values)
    b_all = batch.field(params)  # (N, a, 3)
    finite = np.all(np.isfinite(b_all), axis=(1, 2))
    b_all = np.where(np.isfinite(b_all), b_all, 0.0)
    b_curve = np.concatenate([b_all[:, :1], b_all[:, 2:]], axis=1)  # at u_grid
    for j, choice in enumerate(choices):
        sel = np.nonzero(sensor_index == j)[0]
        if sel.size == 0:
            continue
        sigma = choice.sigma(bandwidth)
        reading = choice.reading(b_curve[sel])
        c, h = compliance[sel], length[sel]
        f_end = DEFLECTION_LIMIT * h / c
        if quantity == "force":
            q = u_grid[None, :] * (h / c)[:, None]
            slope = (choice.reading(b_all[sel, 1]) - choice.reading(b_all[sel, 0])) \
                / _SLOPE_TILT * (c / h)[:, None]
            curve = reading
            end = f_end
        else:
            d = 2.0 * _mean_radius(values, sel)
            u_drag = 2.0 * np.sqrt(f_end / (0.5 * fluid.density * d * h))
            u_max = np.minimum(u_drag, max_speed(1.0, fluid) / d)
            q = u_max[:, None] * np.geomspace(1e-4, 1.0, 48)[None, :]
            q = np.concatenate([np.zeros((sel.size, 1)), q], axis=1)
            curve = _flow_curve(q, d, h, c, reading, fluid)
            hs = 0.01 * speed
            ends = _flow_curve(np.stack([np.full(sel.size, speed - hs),
                                         np.full(sel.size, speed + hs)], axis=1),
                               d, h, c, reading, fluid)
            slope = (ends[:, 1] - ends[:, 0]) / (2.0 * hs)
            end = u_max
        info = np.sum((slope / sigma) ** 2, axis=1)
        with np.errstate(divide="ignore"):
            minimum[sel] = np.where(info > 0.0, 1.0 / np.sqrt(info), np.inf)
        weights = np.nan_to_num(slope / sigma**2, nan=0.0, posinf=0.0, neginf=0.0)
        mags = np.linalg.norm(b_curve[sel], axis=2) if quantity == "force" else \
            np.linalg.norm(_flow_curve(q, d, h, c, b_curve[sel], fluid), axis=2)
        total = choice.total_limit(field_limit)
        rng_[sel], last = _curve_range(q, curve, mags, choice, weights, end, total)
        idx = np.arange(q.shape[1])[None, :]
        peak[sel] = np.max(np.where(idx <= last[:, None], mags, 0.0), axis=1)
        flip[sel] = choice.flip
    violated = np.select([~finite, rng_ <= 0.0, peak > 1.2 * flip],
                         [2, 3, 4], 0).astype(np.int64)
    return _Screen(minimum, rng_, violated)


def _mean_radius(values: dict[str, F64], sel: NDArray[np.int64]) -> F64:
    return np.asarray(0.5 * (values["base_radius"][sel] + values["tip_radius"][sel]),
                      dtype=np.float64)


def _flow_curve(q: F64, d: F64, h: F64, c: F64, reading: F64, fluid: Fluid) -> F64:
    """Readings (N, s, 3) at speeds q (N, s): the tip-equivalent force of the cylinder drag
    (3/8 of the total on an upright rod) turned into the equivalent tilt, interpolated on the
    screen's curve ``reading`` (N, a, 3) over :data:`_SCREEN_U`."""
    per_length = drag_per_length(q, d[:, None], fluid)
    u_eq = np.clip(0.375 * per_length * h[:, None] * (c / h)[:, None], 0.0, DEFLECTION_LIMIT)
    hi = np.clip(np.searchsorted(_SCREEN_U, u_eq, side="right"), 1, _SCREEN_U.size - 1)
    lo = hi - 1
    t = (u_eq - _SCREEN_U[lo]) / (_SCREEN_U[hi] - _SCREEN_U[lo])  # linear, as np.interp
    r_lo = np.take_along_axis(reading, lo[:, :, None], axis=1)
    r_hi = np.take_along_axis(reading, hi[:, :, None], axis=1)
    return np.asarray(r_lo + t[:, :, None] * (r_hi - r_lo), dtype=np.float64)


# -- the search -----------------------------------------------------------------------------------
def _bounds(setup: Setup, bounds: Mapping[str, Sequence[float]] | None
            ) -> tuple[dict[str, tuple[float, float]], dict[str, float]]:
    """Searched bounds (SI) and the fixed values of the other variables."""
    given = dict(bounds or {})
    for name in given:
        v.choice("bounds key", name, VARIABLES)
        if name == "tip_radius" and setup.cilium.profile is not None:
            raise v.fail("bounds key", name, "left out for a cilium with a measured profile "
                         "(height and base_radius scale the measured shape)")
    out: dict[str, tuple[float, float]] = {}
    for name in VARIABLES:
        if name in given:
            pair = given[name]
            lo, hi = (float(x) for x in pair)
            PARAMETERS[name].check_range(lo, hi, f"bounds[{name!r}]")
            if not lo <= hi:
                raise v.fail(f"bounds[{name!r}]", (lo, hi), "a range with low <= high")
            out[name] = (lo, hi)
        elif name in DEFAULT_BOUNDS and not (name == "tip_radius"
                                             and setup.cilium.profile is not None):
            out[name] = DEFAULT_BOUNDS[name]
    fixed = {n: float(setup.value(n)) for n in VARIABLES if n not in out}
    return out, fixed


def _sample(bounds: dict[str, tuple[float, float]], fixed: dict[str, float], n: int,
            n_sensors: int, gen: np.random.Generator) -> tuple[dict[str, F64], NDArray[np.int64]]:
    """A scrambled Sobol' sample of 2^ceil(log2 n) designs: every variable (SI, (N,) arrays)
    and the sensor index (N,)."""
    from scipy.stats import qmc

    names = list(bounds)
    dims = len(names) + (1 if n_sensors > 1 else 0)
    m = max(1, math.ceil(math.log2(n)))
    u = qmc.Sobol(dims, scramble=True, rng=gen).random_base2(m) if dims else np.zeros((2**m, 0))
    values: dict[str, F64] = {}
    for j, name in enumerate(names):
        lo, hi = bounds[name]
        values[name] = lo + (hi - lo) * u[:, j]
    for name, val in fixed.items():
        values[name] = np.full(u.shape[0], val)
    index = np.minimum((u[:, -1] * n_sensors).astype(np.int64), n_sensors - 1) \
        if n_sensors > 1 else np.zeros(u.shape[0], dtype=np.int64)
    return values, index


def _design_setup(setup: Setup, params: Mapping[str, float]) -> Setup:
    """The setup with a design's variables."""
    changes = {k: val for k, val in params.items()
               if not (k == "tip_radius" and setup.cilium.profile is not None)}
    return setup.replace(**changes)


def optimise_design(setup: Setup | None = None, objective: str = "force-range", *,
                    min_force: float | None = None, speed: float | None = None,
                    constraints: Mapping[str, float] | None = None,
                    bounds: Mapping[str, Sequence[float]] | None = None,
                    sensors: Sequence[str | Sensor | Magnetometer] = (SINGLE_AXIS,),
                    n: int = 1024, refine: int = 32, polish: int = 2,
                    rng: int | np.random.Generator | None = None,
                    workers: int | None = None, scheduler: str | None = None,
                    bandwidth: tuple[float, float] = DEFAULT_BANDWIDTH, fluid: Fluid = WATER,
                    points: int = 151, progress: bool = False) -> DesignOptimum:
    """Search geometry, material, placement and sensor for an objective; return the Pareto
    front of range against resolution and the chosen design (module docstring).

    Parameters
    ----------
    setup : Setup, optional
        The starting design: material, model (n, k, ring), sensor and every variable not
        searched; also the reference the result compares against. Default: the paper's
        Table I cilium with a 0.05 mm tip radius and a converged model (``layout="converged"``).
    objective : {"force-range", "flow-sensitivity"}
    min_force : float, optional
        Force objective: the minimum detectable force the chosen design must reach, N (default:
        the reference's own).
    speed : float, optional
        Flow objective (required there): the flow speed U, m/s, whose sensitivity counts.
    constraints : mapping, optional
        ``{"range": lowest range, "minimum": largest minimum detectable value}`` (SI: N or
        m/s) and ``"field"``: the rated range of |B| at the element, T, where a design's range
        ends (default each sensor's own: the HMC1021Z's 6 gauss, whose datasheet states its
        range for the total field; none for a 3-axis part, rated per axis).
    bounds : mapping of str to (low, high), optional
        Searched variables (:data:`VARIABLES`) and their bounds, SI; the defaults
        (:data:`DEFAULT_BOUNDS`) for the others; pass ``(v, v)`` to fix one.
    sensors : sequence
        Sensor choices (:func:`sensor_choices`): ``"HMC1021Z"`` (the setup's own), 3-axis
        preset names such as ``"MMC5983MA"``, or sensor objects.
    n : int
        Designs screened (rounded up to a power of two, ≥ 16).
    refine : int
        Screened designs measured exactly (≥ 4): the screen's fronts rank by rank, plus the
        screen's best candidates for the choice.
    polish : int
        Rounds of exact polishing (≥ 0): 16 designs in a Sobol' box around the chosen design,
        ±10 % of each bound's width, half that in each further round (the box clipped to the
        bounds); they join the refined designs.
    rng : int, Generator or None
        Seed of the Sobol' sample: an int repeats the result exactly.
    workers, scheduler
        How the exact refinement runs (:func:`magcilia.execution.run_tasks`): worker processes
        (None: in this process below :data:`POOL_FROM` designs measured at once, else one per
        core; 1: in this process) or a Dask scheduler address (every batch goes to it).
    bandwidth : (float, float)
        Noise band of the single-axis sensor, Hz (a magnetometer's noise is at its rate).
    fluid : Fluid
        Fluid of the flow objective.
    points : int
        Sweep points of each exact metric (≥ 11; 151 as design_metrics).
    progress : bool
        Show the execution layer's progress bar.

    Returns
    -------
    DesignOptimum

    Raises
    ------
    MagciliaError
        Bad input, or no design meets the constraints (the message names the constraint that
        eliminated the last designs).
    """
    start = time.perf_counter()
    if setup is None:
        setup = Setup.paper(tip_radius=5e-5, layout="converged")
    if not isinstance(setup, Setup):
        raise v.fail("setup", type(setup).__name__, "a magcilia.Setup")
    objective = v.choice("objective", objective, OBJECTIVES)
    quantity = "force" if objective == "force-range" else "flow"
    n = v.integer("n", n, 16)
    refine = v.integer("refine", refine, 4)
    polish = v.integer("polish", polish, 0)
    points = v.integer("points", points, 11)
    if not isinstance(fluid, Fluid):
        raise v.fail("fluid", type(fluid).__name__, "a magcilia Fluid (AIR, WATER, …)")
    fixed_c: dict[str, float] = {}
    if quantity == "flow":
        if speed is None:
            raise v.fail("speed", None, "a flow speed in m/s for the flow-sensitivity objective "
                         "(CLI: --speed 1mm/s)")
        fixed_c["speed"] = v.positive("speed", speed, "m/s", "speed")
    elif speed is not None:
        raise v.fail("speed", speed, "None for the force-range objective (it counts for "
                     "flow-sensitivity)")
    if min_force is not None:
        if quantity != "force":
            raise v.fail("min_force", min_force, "None for the flow-sensitivity objective")
        fixed_c["min_force"] = v.positive("min_force", min_force, "N", "force")
    for key, value in (constraints or {}).items():
        v.choice("constraints key", key, ("range", "minimum", "field"))
        unit = "T" if key == "field" else MEASURANDS[quantity].unit
        fixed_c[key] = v.positive(f"constraints[{key!r}]", value, unit, "value")
    choices = sensor_choices(sensors, setup)
    searched, fixed = _bounds(setup, bounds)
    gen = np.random.default_rng(rng)

    # the reference: the given setup with the first sensor choice
    base = _task(setup, choices[0], quantity, fixed_c, bandwidth, fluid, points)
    ref_metrics = _evaluate_many([base])[0]
    # a measured profile's tip scales with its base radius: no tip_radius of its own
    shown = [k for k in VARIABLES if not (k == "tip_radius" and setup.cilium.profile is not None)]
    ref_params = {k: float(setup.value(k)) for k in shown}
    reference = _design(ref_params, choices[0].name, ref_metrics, "")
    if quantity == "force" and "min_force" not in fixed_c:
        fixed_c["min_force"] = reference.minimum

    # the screen
    values, index = _sample(searched, fixed, n, len(choices), gen)
    total = values["height"].size
    eliminated: dict[str, int] = {}
    geometry_ok = np.ones(total, dtype=bool)
    if setup.cilium.profile is None:  # a measured profile scales with the base radius
        geometry_ok = (values["tip_radius"] <= values["base_radius"]) & (values["tip_radius"] > 0)
    args = (setup, choices, quantity, fixed_c.get("speed", 0.0), bandwidth, fluid,
            fixed_c.get("field"))
    if total <= SCREEN_CHUNK:
        screen = _screen(setup, values, index, *args[1:])
    else:  # chunks, as tasks through the execution layer
        tasks = [(f"screen-{k:08d}", (setup, {name: a[k:k + SCREEN_CHUNK]
                                               for name, a in values.items()},
                                      index[k:k + SCREEN_CHUNK], *args[1:]))
                 for k in range(0, total, SCREEN_CHUNK)]
        parts = _run(_screen_chunk, tasks, workers, scheduler, progress)
        screen = _Screen(*(np.concatenate([getattr(p, f) for p in parts])
                           for f in ("minimum", "range", "violated")))
    codes = np.where(geometry_ok, screen.violated, 1)
    tally = np.bincount(codes, minlength=len(_REASONS))
    eliminated.update({_REASONS[c]: int(tally[c]) for c in range(1, len(_REASONS)) if tally[c]})
    ok = codes == 0
    if not ok.any():
        worst = max(eliminated, key=lambda k: eliminated[k])
        share = (f"all {total}" if eliminated[worst] == total else
                 f"{eliminated[worst]} of {total} (all: {_counts(eliminated)})")
        raise MagciliaError(f"bounds must leave designs that meet the constraints; the "
                            f"{worst!r} constraint eliminated {share} screened designs; widen "
                            "or move the bounds")
    goals = np.stack([screen.minimum, -screen.range], axis=1)
    goals[~ok] = np.nan
    ranks = pareto_ranks(goals, limit=refine)
    order = np.argsort(np.where(ranks >= 0, ranks, np.iinfo(np.int64).max), kind="stable")
    chosen = [int(i) for i in order[:refine] if ranks[i] >= 0]
    chosen += _candidates(screen, ok, quantity, fixed_c, max(4, refine // 4))
    chosen = list(dict.fromkeys(chosen))
    logger.info("optimise: %d designs screened, %d feasible, %d refined", total,
                int(ok.sum()), len(chosen))

    # the exact refinement, in chunks of designs per task; the candidates are new designs: their
    # layouts converge (each at its element, in the task) unless the paper's is asked for by name
    designs_from = setup if setup.layout != "given" else setup.replace(layout="converged")
    measure = _Measure(designs_from, quantity, fixed_c, (float(bandwidth[0]), float(bandwidth[1])),
                       fluid, points, workers, scheduler, progress)
    designs = measure([({k: float(values[k][i]) for k in shown}, choices[int(index[i])])
                       for i in chosen])
    # polish: small exact Sobol' boxes around the chosen design, each half the last's size
    by_name = {c.name: c for c in choices}
    for level in range(polish):
        if not any(d.eligible for d in designs):
            break
        centre = _best(designs, quantity)
        half = 0.1 / 2**level
        u = _qmc_sample(len(searched), 4, gen)
        entries = []
        for row in u:
            params = dict(centre.params)
            for j, (name, (lo, hi)) in enumerate(searched.items()):
                params[name] = float(np.clip(params[name] + (2.0 * row[j] - 1.0) * half
                                             * (hi - lo), lo, hi))
            if "tip_radius" not in params or 0.0 < params["tip_radius"] <= params["base_radius"]:
                entries.append((params, by_name[centre.sensor]))
        designs += measure(entries)
    feasible = [d for d in designs if d.feasible]
    if not feasible:
        counts: dict[str, int] = {}
        for d in designs:
            counts[d.violated] = counts.get(d.violated, 0) + 1
        worst = max(counts, key=lambda k: counts[k])
        finest = min((d.minimum for d in designs), default=math.inf)
        raise MagciliaError(
            f"constraints must leave a design; {worst!r} eliminated {counts[worst]} of "
            f"{len(designs)} refined designs ({_counts(counts)}; the finest resolves "
            f"{MEASURANDS[quantity].text(finest, 4)}); relax it or widen the bounds")
    if not any(d.eligible for d in designs):
        need = "min_force" if quantity == "force" else "speed"
        q = MEASURANDS[quantity]
        finest_text = q.text(min(d.minimum for d in feasible), 4)
        widest_text = q.text(max(d.range for d in feasible), 4)
        closest = (f"the finest feasible design resolves {finest_text}" if quantity == "force"
                   else f"the widest feasible range is {widest_text}")
        raise MagciliaError(
            f"{need} must be reachable within the bounds; it eliminated all {len(feasible)} "
            f"feasible refined designs ({closest}, {need} {q.text(fixed_c[need], 4)}); relax "
            f"{need} or widen the bounds")
    ranks_exact = pareto_ranks([[d.minimum, -d.range] for d in feasible])
    ranked = {id(d): int(r) for d, r in zip(feasible, ranks_exact, strict=True)}
    designs = [replace(d, rank=ranked.get(id(d), -1)) for d in designs]
    best = _best(designs, quantity)
    best_setup = _design_setup(designs_from, best.params).resolve_layout()
    return DesignOptimum(
        objective=objective, quantity=quantity, designs=tuple(designs), best=best,
        reference=reference, best_setup=best_setup, bounds=searched,
        fixed=fixed_c, screened=total, eliminated=eliminated,
        seconds=time.perf_counter() - start, _unit=_token(MEASURANDS[quantity].unit))


@dataclass(frozen=True)
class _Measure:
    """The exact metrics of designs, as tasks through the execution layer (chunks of designs
    per task), with each design's constraint verdict and eligibility."""

    setup: Setup
    quantity: str
    fixed: dict[str, float]
    bandwidth: tuple[float, float]
    fluid: Fluid
    points: int
    workers: int | None
    scheduler: str | None
    progress: bool

    def __call__(self, entries: Sequence[tuple[dict[str, float], SensorChoice]]
                 ) -> list[Candidate]:
        setups = []
        for params, choice in entries:
            try:
                setups.append((params, choice, _design_setup(self.setup, params)))
            except MagciliaError:  # a design the setup refuses (the element inside): skipped
                continue
        per = max(1, math.ceil(len(setups) / 32))
        tasks: list[tuple[str, Any]] = []
        for k in range(0, len(setups), per):
            chunk = [_task(s, ch, self.quantity, self.fixed, self.bandwidth, self.fluid,
                           self.points) for _, ch, s in setups[k:k + per]]
            tasks.append((f"designs-{k:05d}", chunk))
        # a few designs (a polishing round; up to POOL_FROM by default) cost less in process
        # than starting a pool
        small = len(setups) <= SMALL_BATCH or (self.workers is None
                                               and len(setups) < POOL_FROM)
        workers = 1 if small and self.scheduler is None else self.workers
        chunks = _run(_evaluate_many, tasks, workers, self.scheduler, self.progress) \
            if tasks else []
        measured = [m for chunk in chunks for m in chunk]
        designs = [_design(p, ch.name, m, _violation(m, self.fixed, ch))
                   for (p, ch, _), m in zip(setups, measured, strict=True)]
        return [replace(d, eligible=d.feasible and _eligible(d, self.quantity, self.fixed))
                for d in designs]


def _qmc_sample(dims: int, log2: int, gen: np.random.Generator) -> F64:
    """A scrambled Sobol' sample of 2**log2 points in the unit cube, shape (2**log2, dims)."""
    from scipy.stats import qmc

    if dims == 0:
        return np.zeros((2**log2, 0))
    return np.asarray(qmc.Sobol(dims, scramble=True, rng=gen).random_base2(log2),
                      dtype=np.float64)


def _task(setup: Setup, choice: SensorChoice, quantity: str, fixed: dict[str, float],
          bandwidth: tuple[float, float], fluid: Fluid, points: int) -> _Task:
    return _Task(setup, choice, quantity, fixed.get("speed", 0.0),
                 (float(bandwidth[0]), float(bandwidth[1])), fluid, points,
                 choice.total_limit(fixed.get("field")))


def _design(params: dict[str, float], sensor: str, m: dict[str, Any],
            violated: str) -> Candidate:
    return Candidate(params=params, sensor=sensor, sensitivity=float(m["sensitivity"]),
                     minimum=float(m["minimum"]), range=float(m["range"]),
                     limited_by=str(m["limited_by"]), peak_field=float(m["peak_field"]),
                     violated=violated, reached=bool(m["reached"]))


def _violation(m: dict[str, Any], fixed: dict[str, float], choice: SensorChoice) -> str:
    """The first constraint an exactly measured design breaks ("" for none; the rated range
    ends the range, so a design beyond it at zero load has none)."""
    if str(m["limited_by"]).startswith("model error"):
        return "model error"
    if m["range"] <= 0.0:
        return "sensor range at zero load"
    if not math.isfinite(m["minimum"]):
        return "resolution (no slope)"
    if m["peak_field"] > choice.flip:
        return "flip field"
    if "minimum" in fixed and m["minimum"] > fixed["minimum"]:
        return "minimum"
    if "range" in fixed and m["range"] < fixed["range"]:
        return "range"
    return ""


def _eligible(d: Candidate, quantity: str, fixed: dict[str, float]) -> bool:
    """Whether a design meets the objective's requirement (min_force, or a range reaching the
    speed)."""
    if quantity == "force":
        return d.minimum <= fixed["min_force"]
    return d.range >= fixed["speed"]


def _candidates(screen: _Screen, ok: NDArray[np.bool_], quantity: str,
                fixed: dict[str, float], count: int) -> list[int]:
    """The screen's best candidates for the choice, spread over the proxy's error: for each of
    ``count`` requirements from half to 1.5 times the objective's (``min_force``; for flow,
    from 0.7 to 1.5 times ``speed`` as the range), the best proxy design meeting it."""
    out: list[int] = []
    for factor in np.geomspace(0.5, 1.5, count) if quantity == "force" else \
            np.geomspace(0.7, 1.5, count):
        if quantity == "force":
            good = ok & (screen.minimum <= factor * fixed["min_force"])
            key = -screen.range
        else:
            good = ok & (screen.range >= factor * fixed["speed"])
            key = screen.minimum
        idx = np.nonzero(good)[0]
        if idx.size:
            out.append(int(idx[np.argmin(key[idx])]))
    return out


def _best(designs: list[Candidate], quantity: str) -> Candidate:
    """The chosen design: the largest range (force) or the finest resolution (flow) among the
    eligible ones."""
    feasible = [d for d in designs if d.eligible]
    if quantity == "force":
        return max(feasible, key=lambda d: (d.range, -d.minimum))
    return min(feasible, key=lambda d: (d.minimum, -d.range))


def _counts(counts: Mapping[str, int]) -> str:
    return ", ".join(f"{k}: {c}" for k, c in sorted(counts.items(), key=lambda kv: -kv[1]))
