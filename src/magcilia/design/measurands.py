"""What a design objective measures, as objects: :data:`FORCE` (the tip force of the
``"force-range"`` objective) and :data:`FLOW` (the flow speed of ``"flow-sensitivity"``).

Each holds what differs between them, so the optimiser dispatches by attribute and never
compares names: the registry's quantity (unit, display unit), how its exact sweep bends the
cilium (tip forces or flow speeds, :mod:`magcilia.design.sweeps`) and where its slope is taken,
its screen curve (:mod:`magcilia.design.proxy`), the objective's own requirement (``min_force``:
a resolution to reach; ``speed``: a range to reach) and how the chosen design is picked.
Names stay at the edges: :data:`BY_OBJECTIVE` maps the objective's name to its measurand.
"""

from __future__ import annotations

import abc
import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any, Protocol, TypeVar

import numpy as np
from numpy.typing import NDArray

from magcilia import _validate as v
from magcilia.design.proxy import SCREEN_U, SLOPE_TILT, flow_curve
from magcilia.design.sensors import SensorChoice
from magcilia.design.sweeps import SWEEP_ENDS, flow_limit, force_limit, sweep_fields
from magcilia.device.parameters import MEASURANDS, Quantity
from magcilia.device.setup import Setup
from magcilia.mechanics import Flow, Fluid, bend, bend_sweep, tip_compliance
from magcilia.units import ascii_unit

F64 = NDArray[np.float64]


class _Design(Protocol):
    """What choosing among designs reads of each (a :class:`~magcilia.design.results.Candidate`)."""

    @property
    def minimum(self) -> float: ...

    @property
    def range(self) -> float: ...

    @property
    def error(self) -> float: ...


D = TypeVar("D", bound=_Design)


@dataclass(frozen=True)
class Sweep:
    """An exact sweep of one design: the loads reached, the fields there and why it ended.

    Attributes
    ----------
    values : ndarray, shape (c,)
        The loads, SI (N or m/s), increasing.
    fields : ndarray, shape (c, 3)
        B at the sensing element, T.
    end : str
        What ended the sweep (a range it does not reach is "not reached: " this).
    limit : float
        The sweep's planned end, SI (:func:`~magcilia.design.sweeps.force_limit` or
        :func:`~magcilia.design.sweeps.flow_limit`).
    flow : Flow or None
        The unit flow whose speed is swept (None for a force).
    """

    values: F64
    fields: F64
    end: str
    limit: float
    flow: Flow | None = None


@dataclass(frozen=True)
class Proxy:
    """A screen's curves of N designs (:meth:`Measurand.proxy`): loads q (N, a), the zero-load
    or at-speed slope of the reading (N, 3, per unit), the reading along q (N, a, 3), the
    sweep's end (N,) and |B| along q (N, a), T."""

    q: F64
    slope: F64
    curve: F64
    end: F64
    magnitude: F64


@dataclass(frozen=True)
class Measurand(abc.ABC):
    """A measurand of design optimisation (see the module docstring).

    Attributes
    ----------
    name : str
        The registry's name (:data:`~magcilia.device.parameters.MEASURANDS`): ``"force"`` or
        ``"flow"``.
    objective : str
        The objective that optimises it (:data:`magcilia.design.optimise.OBJECTIVES`).
    requirement : str
        The constraint key of the objective's own requirement (``"min_force"``, ``"speed"``).
    spread : (float, float)
        The screen's candidates meet the requirement scaled from ``spread[0]`` to ``spread[1]``
        times (the proxy's error: :meth:`candidates`).
    """

    name: str
    objective: str
    requirement: str
    spread: tuple[float, float]

    @property
    def quantity(self) -> Quantity:
        """The registry's entry: SI unit, display unit, label."""
        return MEASURANDS[self.name]

    @property
    def unit_token(self) -> str:
        """The SI unit as a key suffix: ``N``, ``m_per_s``."""
        return ascii_unit(self.quantity.unit)

    # -- the objective's arguments (the edges name them) ------------------------------------------
    @abc.abstractmethod
    def requirements(self, min_force: float | None, speed: float | None) -> dict[str, float]:
        """The checked ``min_force`` (N) and ``speed`` (m/s) of :func:`~magcilia.optimise_design`
        that count for this measurand, by constraint key."""

    def default_requirements(  # noqa: B027 (none by default: only the force has one)
            self, fixed: dict[str, float], reference: _Design) -> None:
        """Fill in a requirement that defaults to the reference design's own (none here)."""

    # -- the exact metrics -------------------------------------------------------------------------
    @abc.abstractmethod
    def sweep(self, setup: Setup, fluid: Fluid, points: int) -> Sweep:
        """The exact sweep of ``points`` loads from zero to the sweep's end (large deflections
        and the full field model)."""

    @abc.abstractmethod
    def field_slope(self, setup: Setup, choice: SensorChoice, sweep: Sweep, speed: float) -> F64:
        """The reading's slope on the sensor's axes where the objective counts it, T per unit,
        shape (3,) (NaN where it cannot be taken)."""

    # -- the screen --------------------------------------------------------------------------------
    @abc.abstractmethod
    def proxy(self, b_all: F64, reading: F64, choice: SensorChoice, compliance: F64,
              height: F64, mean_radius: F64, speed: float, fluid: Fluid) -> Proxy:
        """The screen's curves (:class:`Proxy`) of N designs from their tilt-model fields:
        ``b_all`` (N, 2 + a − 1, 3), T (zero load, the slope's small tilt, then
        :data:`~magcilia.design.proxy.SCREEN_U` after 0), ``reading`` (N, a, 3) on the sensor's
        axes along the grid, their compliance (m/N), height and mean radius (m)."""

    # -- the choice --------------------------------------------------------------------------------
    @abc.abstractmethod
    def meets(self, minimum: Any, range_: Any, required: float) -> Any:
        """Whether designs of ``minimum`` and ``range_`` (SI; arrays broadcast) meet the
        requirement's value ``required``."""

    @abc.abstractmethod
    def order(self, minimum: Any, range_: Any) -> Any:
        """The choice's sort key of designs (SI; arrays broadcast): the chosen design has the
        smallest, ties broken by :meth:`tie`."""

    @abc.abstractmethod
    def tie(self, minimum: Any, range_: Any) -> Any:
        """The second sort key of the choice (:meth:`order`)."""

    def eligible(self, design: _Design, fixed: dict[str, float]) -> bool:
        """Whether a design meets the objective's own requirement."""
        return bool(self.meets(design.minimum, design.range, fixed[self.requirement]))

    def best(self, designs: Sequence[D]) -> D:
        """The chosen design among eligible ``designs`` (the first of the smallest
        :meth:`order`, then :meth:`tie`)."""
        return min(designs, key=lambda d: (self.order(d.minimum, d.range),
                                           self.tie(d.minimum, d.range)))

    def candidate_count(self, refine: int) -> int:
        """How many of the screen's :meth:`candidates` join the fronts' designs (of ``refine``
        refined)."""
        return max(4, refine // 4)

    def candidates(self, minimum: F64, range_: F64, ok: NDArray[np.bool_],
                   fixed: dict[str, float], count: int) -> list[int]:
        """The screen's best candidates for the choice, spread over the proxy's error: for each
        of ``count`` requirements from ``spread[0]`` to ``spread[1]`` times the objective's, the
        proxy design of the smallest :meth:`order` that meets it."""
        out: list[int] = []
        key = self.order(minimum, range_)
        for factor in np.geomspace(*self.spread, count):
            idx = np.nonzero(ok & self.meets(minimum, range_,
                                             factor * fixed[self.requirement]))[0]
            if idx.size:
                out.append(int(idx[np.argmin(key[idx])]))
        return out

    @abc.abstractmethod
    def goal(self, fixed: dict[str, float]) -> str:
        """What the minimum means, for reports."""

    @abc.abstractmethod
    def closest(self, designs: Sequence[_Design]) -> str:
        """How close the feasible ``designs`` come to the requirement, for an error."""


@dataclass(frozen=True)
class ForceMeasurand(Measurand):
    """The tip force: the range is maximised among designs that resolve ``min_force``."""

    def requirements(self, min_force: float | None, speed: float | None) -> dict[str, float]:
        if speed is not None:
            raise v.fail("speed", speed, "None for the force-range objective (it counts for "
                         "flow-sensitivity)")
        if min_force is None:
            return {}
        return {"min_force": v.positive("min_force", min_force, "N", "force")}

    def default_requirements(self, fixed: dict[str, float], reference: _Design) -> None:
        if "min_force" not in fixed:
            fixed["min_force"] = reference.minimum

    def sweep(self, setup: Setup, fluid: Fluid,  # noqa: ARG002 (Measurand's signature)
              points: int) -> Sweep:
        f_max = force_limit(setup.cilium.height, tip_compliance(setup))
        q, b, note = sweep_fields(setup, np.linspace(0.0, f_max, points), None)
        return Sweep(q, b, note or SWEEP_ENDS["force"], f_max)

    def field_slope(self, setup: Setup, choice: SensorChoice, sweep: Sweep,
                    speed: float) -> F64:  # noqa: ARG002 (Measurand's signature)
        """The zero-load slope dB/dF (a central difference of ±1e-6 of the sweep's end)."""
        delta = 1e-6 * sweep.limit
        b_pm = choice.reading(setup.field(bend_sweep(setup, forces=[-delta, delta])))
        return np.asarray((b_pm[1] - b_pm[0]) / (2.0 * delta), dtype=np.float64)

    def proxy(self, b_all: F64, reading: F64, choice: SensorChoice, compliance: F64,
              height: F64, mean_radius: F64, speed: float,  # noqa: ARG002 (Measurand's)
              fluid: Fluid) -> Proxy:  # noqa: ARG002 (Measurand's signature)
        c, h = compliance, height
        q = SCREEN_U[None, :] * (h / c)[:, None]
        slope = (choice.reading(b_all[:, 1]) - choice.reading(b_all[:, 0])) \
            / SLOPE_TILT * (c / h)[:, None]
        b_curve = np.concatenate([b_all[:, :1], b_all[:, 2:]], axis=1)
        return Proxy(q, slope, reading, force_limit(h, c), np.linalg.norm(b_curve, axis=2))

    def meets(self, minimum: Any, range_: Any,  # noqa: ARG002 (Measurand's signature)
              required: float) -> Any:
        """A resolution at least as fine as ``min_force``."""
        return minimum <= required

    def order(self, minimum: Any, range_: Any) -> Any:  # noqa: ARG002 (Measurand's signature)
        """The largest range first."""
        return -range_

    def tie(self, minimum: Any, range_: Any) -> Any:  # noqa: ARG002 (Measurand's signature)
        """Then the finest resolution."""
        return minimum

    def goal(self, fixed: dict[str, float]) -> str:  # noqa: ARG002 (Measurand's signature)
        return "minimum detectable force"

    def closest(self, designs: Sequence[_Design]) -> str:
        finest = self.quantity.text(min(d.minimum for d in designs), 4)
        return f"the finest feasible design resolves {finest}"


@dataclass(frozen=True)
class FlowMeasurand(Measurand):
    """The flow speed: the resolution at ``speed`` is minimised among designs whose range
    reaches it."""

    def requirements(self, min_force: float | None, speed: float | None) -> dict[str, float]:
        if speed is None:
            raise v.fail("speed", None, "a flow speed in m/s for the flow-sensitivity objective "
                         "(CLI: --speed 1mm/s)")
        out = {"speed": v.positive("speed", speed, "m/s", "speed")}
        if min_force is not None:
            raise v.fail("min_force", min_force, "None for the flow-sensitivity objective")
        return out

    def sweep(self, setup: Setup, fluid: Fluid, points: int) -> Sweep:
        c = setup.cilium
        d = 2.0 * c.max_radius  # the widest section sets the Reynolds limit
        u_max, drag_ends = flow_limit(force_limit(c.height, tip_compliance(setup)), d, c.height,
                                      fluid)
        flow = Flow.uniform(1.0, fluid)
        speeds = np.concatenate([[0.0], np.geomspace(u_max * 1e-5, u_max, points - 1)])
        q, b, note = sweep_fields(setup, speeds, flow)
        end = SWEEP_ENDS["drag"] if drag_ends else SWEEP_ENDS["flow"]
        return Sweep(q, b, note or end, float(u_max), flow)

    def field_slope(self, setup: Setup, choice: SensorChoice, sweep: Sweep, speed: float) -> F64:
        """The slope dB/dU at ``speed`` (a central difference of ±1 %; NaN where ``speed`` is
        within 1 % of the sweep's end)."""
        u, flow = speed, sweep.flow
        assert flow is not None  # for mypy: a flow sweep carries its flow
        if u * 1.01 >= sweep.limit or (sweep.values.size and u * 1.01 >= sweep.values[-1]):
            return np.full(3, math.nan)
        h = 0.01 * u
        b_pm = choice.reading(np.concatenate(
            [setup.field(bend(setup, flow=flow.with_speed(s))) for s in (u - h, u + h)]))
        return np.asarray((b_pm[1] - b_pm[0]) / (2.0 * h), dtype=np.float64)

    def proxy(self, b_all: F64, reading: F64,
              choice: SensorChoice,  # noqa: ARG002 (Measurand's signature)
              compliance: F64, height: F64, mean_radius: F64, speed: float,
              fluid: Fluid) -> Proxy:
        c, h = compliance, height
        d = 2.0 * mean_radius
        u_max = flow_limit(force_limit(h, c), d, h, fluid)[0]
        q = u_max[:, None] * np.geomspace(1e-4, 1.0, 48)[None, :]
        q = np.concatenate([np.zeros((h.size, 1)), q], axis=1)
        hs = 0.01 * speed
        ends = flow_curve(np.stack([np.full(h.size, speed - hs), np.full(h.size, speed + hs)],
                                   axis=1), d, h, c, reading, fluid)
        slope = (ends[:, 1] - ends[:, 0]) / (2.0 * hs)
        b_curve = np.concatenate([b_all[:, :1], b_all[:, 2:]], axis=1)
        return Proxy(q, slope, flow_curve(q, d, h, c, reading, fluid), u_max,
                     np.linalg.norm(flow_curve(q, d, h, c, b_curve, fluid), axis=2))

    def meets(self, minimum: Any,  # noqa: ARG002 (Measurand's signature)
              range_: Any, required: float) -> Any:
        """A range that reaches ``speed``."""
        return range_ >= required

    def order(self, minimum: Any, range_: Any) -> Any:  # noqa: ARG002 (Measurand's signature)
        """The finest resolution first."""
        return minimum

    def tie(self, minimum: Any, range_: Any) -> Any:  # noqa: ARG002 (Measurand's signature)
        """Then the largest range."""
        return -range_

    def goal(self, fixed: dict[str, float]) -> str:
        return (f"minimum detectable speed change at "
                f"{self.quantity.text(fixed.get('speed', math.nan))}")

    def closest(self, designs: Sequence[_Design]) -> str:
        widest = self.quantity.text(max(d.range for d in designs), 4)
        return f"the widest feasible range is {widest}"


@dataclass(frozen=True)
class RobustForceMeasurand(ForceMeasurand):
    """The tip force read without calibration: among designs that resolve ``min_force``, the
    smallest calibration-free read-out error under the tolerances
    (:mod:`magcilia.design.robust`; the exact refinement measures it, the screen cannot), ties
    broken by the finer resolution. The screen's candidates are the feasible designs that meet
    the requirement (up to ``spread[1]`` times it: the proxy's error), taken in the Sobol'
    sample's order, so that they spread over the bounds."""

    def candidate_count(self, refine: int) -> int:
        return refine

    def candidates(self, minimum: F64, range_: F64, ok: NDArray[np.bool_],
                   fixed: dict[str, float], count: int) -> list[int]:
        idx = np.nonzero(ok & self.meets(minimum, range_,
                                         self.spread[1] * fixed[self.requirement]))[0]
        return [int(i) for i in idx[:count]]

    def best(self, designs: Sequence[D]) -> D:
        """The smallest calibration-free error (NaN: last), then the finest resolution."""
        return min(designs, key=lambda d: (d.error if d.error == d.error else math.inf,
                                           d.minimum))

    def goal(self, fixed: dict[str, float]) -> str:  # noqa: ARG002 (Measurand's signature)
        return "minimum detectable force; chosen by the calibration-free error"


#: the tip force (objective "force-range")
FORCE = ForceMeasurand("force", "force-range", "min_force", (0.5, 1.5))
#: the tip force read without a per-device calibration (objective "robust")
ROBUST = RobustForceMeasurand("force", "robust", "min_force", (0.5, 1.5))
#: the flow speed (objective "flow-sensitivity")
FLOW = FlowMeasurand("flow", "flow-sensitivity", "speed", (0.7, 1.5))
#: the measurand of each objective, by its name (the edges' strings end here)
BY_OBJECTIVE: dict[str, Measurand] = {m.objective: m for m in (FORCE, FLOW, ROBUST)}
#: the measurand by its registry name (``DesignOptimum.to_dict()``'s ``quantity``)
BY_NAME: dict[str, Measurand] = {m.name: m for m in (FORCE, FLOW)}
