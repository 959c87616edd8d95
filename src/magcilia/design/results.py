"""The results of design optimisation: :class:`Candidate` (one design with its exact metrics) and
:class:`DesignOptimum` (the Pareto front, the chosen design and the reference), all SI.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

from magcilia._display import Display, Item, Table, dataframe, number, rows_table
from magcilia.design.measurands import Measurand
from magcilia.design.robust import RobustSpec
from magcilia.device.parameters import PARAMETERS, Quantity
from magcilia.device.setup import Setup
from magcilia.units import ascii_unit


@dataclass(frozen=True, eq=False, repr=False)
class Candidate(Display):
    """One design with its exact metrics (SI).

    Attributes
    ----------
    params : dict of str to float
        The design variables (:data:`~magcilia.design.optimise.VARIABLES` searched or fixed), SI.
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
    bandwidth : float
        −3 dB bandwidth of the output's response to the measurand (a tip force about rest, a
        flow about ``speed``) in the fluid, Hz (:func:`magcilia.frequency_response`; NaN where
        not known).
    settling_time : float
        Time for a step of it to settle within 2 %, s.
    error, error_p95 : float
        The ``"robust"`` objective's calibration-free read-out error over the range: RMS and
        95th percentile of ``|F_read − F|`` as fractions of the range
        (:mod:`magcilia.design.robust`; NaN for the other objectives).
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
    bandwidth: float = math.nan
    settling_time: float = math.nan
    error: float = math.nan
    error_p95: float = math.nan

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
            suffix = f"_{ascii_unit(p.unit)}" if p.unit else ""
            row[f"{name}{suffix}"] = value
        row["sensor"] = self.sensor
        row[f"minimum_{unit}"] = self.minimum
        row[f"range_{unit}"] = self.range
        row["range_reached"] = self.reached
        row["limited_by"] = self.limited_by
        row["peak_field_T"] = self.peak_field
        row["bandwidth_Hz"] = self.bandwidth
        row["settling_time_s"] = self.settling_time
        row["calibration_free_error"] = self.error
        row["calibration_free_error_p95"] = self.error_p95
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
                "violated": self.violated, "rank": self.rank, "eligible": self.eligible,
                "bandwidth_Hz": self.bandwidth, "settling_time_s": self.settling_time,
                "calibration_free_error": self.error,
                "calibration_free_error_p95": self.error_p95}

    def report(self) -> str:
        """One line in display units."""
        return ", ".join(f"{k} {t}" for k, t in self._display_items())

    def _display_items(self) -> list[Item]:
        items = [(n, PARAMETERS[n].text(val)) for n, val in self.params.items()]
        error = [] if math.isnan(self.error) else [("error", f"{self.error * 100:.3g} %")]
        return [("minimum", number(self.minimum)),
                ("range", ("" if self.reached else "≥ ") + number(self.range)),
                *error, ("sensor", self.sensor), *items]


@dataclass(frozen=True, eq=False, repr=False)
class DesignOptimum(Display):
    """Result of :func:`~magcilia.design.optimise.optimise_design` (all SI).

    Attributes
    ----------
    objective : str
        One of :data:`~magcilia.design.optimise.OBJECTIVES`.
    measurand : Measurand
        What the objective measures (:data:`~magcilia.design.measurands.FORCE` or
        :data:`~magcilia.design.measurands.FLOW`); :attr:`quantity` is its name.
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
    robust : RobustSpec or None
        The ``"robust"`` objective's tolerances and Monte Carlo (None for the others).
    """

    objective: str
    measurand: Measurand
    designs: tuple[Candidate, ...]
    best: Candidate
    reference: Candidate
    best_setup: Setup
    bounds: dict[str, tuple[float, float]]
    fixed: dict[str, float]
    screened: int
    eliminated: dict[str, int]
    seconds: float
    robust: RobustSpec | None = None

    @property
    def quantity(self) -> str:
        """The measurand's name: ``"force"`` or ``"flow"``."""
        return self.measurand.name

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
        q = self.measurand.quantity
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
        return [d.row(self.measurand.unit_token) for d in self.front]

    def to_dataframe(self) -> Any:
        """Every refined design (front first, then by rank) as a ``pandas.DataFrame``, SI
        columns named with their unit."""
        rows = [d.row(self.measurand.unit_token) for d in sorted(
            self.designs, key=lambda d: (d.rank < 0, d.rank, d.minimum))]
        return dataframe({k: [r[k] for r in rows] for k in rows[0]} if rows else {})

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready content (SI)."""
        return {
            "objective": self.objective, "quantity": self.quantity,
            "unit": self.measurand.quantity.unit, "best": self.best.to_dict(),
            "reference": self.reference.to_dict(),
            "beats_reference": self.beats_reference,
            "front": [d.to_dict() for d in self.front],
            "designs": [d.to_dict() for d in self.designs],
            "bounds": {k: list(b) for k, b in self.bounds.items()},
            "constraints": dict(self.fixed), "screened": self.screened,
            "eliminated": dict(self.eliminated), "seconds": self.seconds,
            **({} if self.robust is None else {"robust": self.robust_dict()}),
        }

    def robust_dict(self) -> dict[str, Any]:
        """The robust objective's Monte Carlo (empty for the others): tolerances, devices,
        seed, tare, forces per device."""
        r = self.robust
        if r is None:
            return {}
        return {"tolerances": r.tolerances.to_dict(), "samples": r.samples, "seed": r.seed,
                "tare": r.tare, "points": r.points,
                "self_test": None if r.self_test is None else r.self_test.to_dict()}

    def report(self) -> str:
        """Plain text in display units: the chosen design against the reference, then the
        front."""
        q = self.measurand.quantity
        what = self.measurand.goal(self.fixed)
        lines = [(f"{self.objective}: {self.screened} designs screened, {len(self.designs)} "
                  f"refined, {len(self.front)} on the front ({self.seconds:.3g} s)"),
                 f"{'':<10} {'range':>12} {'minimum':>12}   ({what})"]
        for label, d in (("reference", self.reference), ("best", self.best)):
            lines.append(f"{label:<10} {_range_text(d, q):>12} {q.text(d.minimum, 4):>12}   "
                         f"{d.sensor}; {d.limited_by}")
        lines.append("best design: " + ", ".join(
            f"{n} {PARAMETERS[n].text(val, 4)}" for n, val in self.best.params.items()))
        lines.append(f"compared with the reference: {self.comparison}")
        if self.robust is not None:
            lines.append(f"calibration-free error (RMS, 95th percentile, of the range): "
                         f"reference {_error_text(self.reference)}, best "
                         f"{_error_text(self.best)}; {self.robust.samples} devices, "
                         f"{'tared' if self.robust.tare else 'untared'}, under "
                         f"{self.robust.tolerances.report()}"
                         + ("" if self.robust.self_test is None
                            else f"; read after a {self.robust.self_test.report()}"))
        lines.append("front (minimum, range):")
        lines += [f"  {q.text(d.minimum, 4):>12} {_range_text(d, q):>12}  {d.sensor}"
                  for d in self.front]
        lines.append(f"{self.best_setup.modulus.note()}: every range and minimum above scales "
                     "with it")
        return "\n".join(lines)

    def _display_items(self) -> list[Item]:
        q = self.measurand.quantity
        return [("", self.objective), ("best range", _range_text(self.best, q)),
                ("best minimum", q.text(self.best.minimum)), ("sensor", self.best.sensor),
                ("front", str(len(self.front))), ("screened", str(self.screened))]

    def _display_table(self) -> Table | None:
        return rows_table(self.table())


def _error_text(d: Candidate) -> str:
    """A design's calibration-free error: ``"6.1 %, 13 %"``."""
    return f"{d.error * 100:.3g} %, {d.error_p95 * 100:.3g} %"


def _range_text(d: Candidate, q: Quantity) -> str:
    """A design's range in display units, "≥ X" when not reached."""
    return ("" if d.reached else "≥ ") + q.text(d.range, 4)
