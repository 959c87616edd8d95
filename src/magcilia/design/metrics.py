"""Design metrics of a cilium sensor: sensitivity, minimum detectable signal and range.

For each measurand (tip force, flow speed, rigid tilt angle) :func:`design_metrics` sweeps the
quantity, evaluates the sensor output and reports

* the sensitivity at zero load (dV/dF in V/N, dV/dθ in V/rad; for flow the secant slope from 0 to
  the speed where the base Reynolds number is 1e-3, because the Oseen drag makes the slope at
  U → 0 vanish logarithmically);
* the minimum detectable value: noise RMS over the bandwidth divided by the slope (force, angle);
  for flow, whose drag grows nonlinearly, the speed that solves ``|V(U) − V(0)| = noise``;
* the range: the value where the read-out ends (:func:`magcilia.design.ranges.read_range`,
  shared with :func:`magcilia.optimise_design`): the first of the sensor leaving its rated range
  (the HMC1021Z's ±6 gauss hold for the sensitive axis and, by its datasheet, for the total
  applied field: :func:`magcilia.design.ranges.rated_ratio`) or a fold of the output
  (non-monotonic: readings become ambiguous). When the sweep ends first (the elastica's
  large-deflection limit, the drag law's Reynolds limit, 90° of tilt; the force and flow sweeps
  are the optimiser's, :mod:`magcilia.design.sweeps`), the read-out has not ended: the range is
  a lower bound,
  ``reached`` is False and reports print it as "≥ X (not reached: …)";
* the dynamics of a tip force in the fluid (:func:`magcilia.frequency_response` about rest):
  the −3 dB bandwidth and the 2 % settling time of a step, the hair's modes with the fluid's
  added mass and damping (NaN without a tip radius);
* the force scale's 1 σ of the minimum and the range: a force scales exactly with the Young's
  modulus at a fixed shape (σ = value · σ_E/E), a flow speed through the drag law (the model's
  derivative at a fixed output, :func:`magcilia.readout.scale.fixed_output_rate`); systematic,
  and said where it comes from (:meth:`magcilia.Modulus.note`).

The layout follows the setup's layout rule at the sensing element
(:meth:`magcilia.Setup.resolve_layout`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import NDArray

from magcilia import _validate as v
from magcilia._display import Display, Item, Table, dataframe, number, rows_table, si
from magcilia._errors import MagciliaError
from magcilia.design.measurands import FLOW, FORCE
from magcilia.design.ranges import single_axis_range
from magcilia.design.sweeps import SWEEP_ENDS
from magcilia.device.parameters import MEASURANDS
from magcilia.device.sensor import DEFAULT_BANDWIDTH
from magcilia.device.setup import Setup
from magcilia.device.stiffness import percent
from magcilia.mechanics import SHARP_TIP, WATER, Flow, Fluid, bend, bend_sweep, output_at
from magcilia.mechanics.response import response_figures
from magcilia.readout.scale import fixed_output_rate

F64 = NDArray[np.float64]



@dataclass(frozen=True, eq=False, repr=False)
class Metric(Display):
    """Metrics of one measurand (SI units in ``unit``).

    Attributes
    ----------
    quantity : str
        ``"force"``, ``"flow"`` or ``"angle"``.
    unit : str
        N, m/s or rad.
    sensitivity : float
        dV/dquantity at zero load, V per unit (NaN if not available).
    minimum : float
        Minimum detectable value, unit (NaN if not available).
    range : float
        Usable range from zero, unit (a lower bound when ``reached`` is False: ``limited_by``
        then starts "not reached: ").
    limited_by : str
        What ends the range (or why the metric is not available); for a range not reached, what
        ended the sweep, as ``"not reached: …"``.
    curve : ndarray, shape (c, 2)
        The swept (quantity, output V) pairs.
    reached : bool
        Whether the read-out ends within the sweep (rated range or fold); False: the sweep ended
        first and ``range`` is a lower bound.
    sigma_minimum, sigma_range : float
        The force scale's 1 σ of ``minimum`` and ``range``, unit: the Young's modulus's relative
        1 σ through the model (``value · σ_E/E`` for a force; 0 for an angle or a modulus taken
        as exact). Systematic: every force or flow figure of the setup shares it.
    """

    quantity: str
    unit: str
    sensitivity: float
    minimum: float
    range: float
    limited_by: str
    curve: F64 = field(repr=False)
    reached: bool = True
    sigma_minimum: float = 0.0
    sigma_range: float = 0.0

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready content (SI units; the swept curve left out)."""
        return {"unit": self.unit, "sensitivity_V_per_unit": self.sensitivity,
                "minimum": self.minimum, "range": self.range, "range_reached": self.reached,
                "limited_by": self.limited_by, "sigma_minimum": self.sigma_minimum,
                "sigma_range": self.sigma_range}

    def report(self) -> str:
        """One line in display units (a range not reached as "≥ X"; the force scale's ± where it
        has one)."""
        q = MEASURANDS[self.quantity]
        at_least = "" if self.reached else "≥ "

        def pm(sigma: float) -> str:
            return f" ± {q.to_display(sigma):.2g}" if sigma > 0.0 else ""

        return (f"{self.quantity}: {self.sensitivity * 1e3 * q.display_factor:.4g} "
                f"mV/{q.display}, "
                f"minimum {q.to_display(self.minimum):.4g}{pm(self.sigma_minimum)} {q.display}, "
                f"range {at_least}{q.to_display(self.range):.4g}{pm(self.sigma_range)} "
                f"{q.display} ({self.limited_by})")

    # -- display --------------------------------------------------------------------------------
    def _display_items(self) -> list[Item]:
        q = MEASURANDS[self.quantity]
        return [("", self.quantity),
                ("sensitivity",
                 f"{number(self.sensitivity * 1e3 * q.display_factor)} mV/{q.display}"),
                ("minimum", q.text(self.minimum)),
                ("range", ("" if self.reached else "≥ ") + q.text(self.range)),
                ("limited by", self.limited_by)]


@dataclass(frozen=True, eq=False, repr=False)
class DesignMetrics(Display):
    """Result of :func:`design_metrics`: one :class:`Metric` per measurand.

    Attributes
    ----------
    force, flow, angle : Metric
    noise : float
        Output noise RMS over the bandwidth, V.
    bandwidth : (float, float)
        Hz.
    fluid : Fluid
    setup : Setup
    response_bandwidth : float
        −3 dB bandwidth of the output's response to a tip force in ``fluid``, Hz (NaN: no
        tip radius).
    settling_time : float
        Time for a step of tip force to settle within 2 %, s (inf undamped; NaN: no tip
        radius).
    """

    force: Metric
    flow: Metric
    angle: Metric
    noise: float
    bandwidth: tuple[float, float]
    fluid: Fluid
    setup: Setup
    response_bandwidth: float = math.nan
    settling_time: float = math.nan

    @property
    def metrics(self) -> tuple[Metric, Metric, Metric]:
        """(force, flow, angle)."""
        return self.force, self.flow, self.angle

    @property
    def scale_note(self) -> str:
        """Where the force and flow figures' scale comes from, and their share of it: ``"force
        scale from an assumed modulus ±27 % (E 0.669 MPa): force minimum ±27 %, range ±27 %;
        flow minimum ±19 %, range ±15 %"``."""
        note = self.setup.modulus.note()
        parts = [f"{m.quantity} minimum ±{_percent(m.sigma_minimum, m.minimum)}, range "
                 f"±{_percent(m.sigma_range, m.range)}" for m in (self.force, self.flow)
                 if math.isfinite(m.minimum) and (m.sigma_minimum or m.sigma_range)]
        return f"{note}: {'; '.join(parts)}" if parts else note

    def table(self) -> list[dict[str, Any]]:
        """Rows per measurand in display units (mN, m/s, deg; sensitivity in mV per display
        unit); NaN where a metric is not available; ``reached`` False where the range is a
        lower bound."""
        rows = []
        for m in self.metrics:
            q = MEASURANDS[m.quantity]
            rows.append({"quantity": m.quantity, "unit": q.display,
                         "sensitivity": m.sensitivity * 1e3 * q.display_factor,
                         "minimum": q.to_display(m.minimum), "range": q.to_display(m.range),
                         "reached": m.reached, "limited_by": m.limited_by})
        return rows

    def report(self) -> str:
        """Plain-text table in display units (mN, m/s, deg; mV)."""
        lo, hi = self.bandwidth
        lines = [
            f"noise {self.noise * 1e6:.4g} µV RMS over {lo:g}–{hi:g} Hz; flow in {self.fluid.name}",
            (f"{'quantity':<8} {'sensitivity':>22} {'min. detectable':>18} {'range':>14}"
             "  limited by"),
        ]
        for r in self.table():
            unit = r["unit"]
            sens = f"{r['sensitivity']:.4g} mV/{unit}" if math.isfinite(r["sensitivity"]) else "-"
            mini = f"{r['minimum']:.4g} {unit}" if math.isfinite(r["minimum"]) else "-"
            rng = (("" if r["reached"] else "≥ ") + f"{r['range']:.4g} {unit}"
                   if math.isfinite(r["range"]) else "-")
            lines.append(f"{r['quantity']:<8} {sens:>22} {mini:>18} {rng:>14}  {r['limited_by']}")
        if math.isfinite(self.response_bandwidth):
            settle = (f"{self.settling_time * 1e3:.4g} ms" if math.isfinite(self.settling_time)
                      else "never (undamped)")
            lines[0] += (f"; a tip force's −3 dB bandwidth {self.response_bandwidth:.4g} Hz, "
                         f"settling (2 %) {settle}")
        lines.append(self.scale_note)
        return "\n".join(lines)

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready content (SI units)."""
        return {
            "noise_V": self.noise, "bandwidth_Hz": list(self.bandwidth),
            "fluid": self.fluid.name,
            "metrics": {m.quantity: m.to_dict() for m in self.metrics},
            "modulus": self.setup.modulus.to_dict(), "scale_note": self.scale_note,
            "response_bandwidth_Hz": self.response_bandwidth,
            "settling_time_s": self.settling_time,
        }

    # -- display --------------------------------------------------------------------------------
    def _display_items(self) -> list[Item]:
        lo, hi = self.bandwidth
        return [*((f"min {m.quantity}", MEASURANDS[m.quantity].text(m.minimum))
                  for m in self.metrics),
                ("noise", si(self.noise, "V")), ("band", f"{lo:g}–{hi:g} Hz"),
                ("fluid", self.fluid.name),
                ("response_bandwidth", f"{number(self.response_bandwidth, 4)} Hz")]

    def _display_table(self) -> Table | None:
        return rows_table(self.table())

    def to_dataframe(self) -> Any:
        """One row per quantity (force, flow, angle) as a ``pandas.DataFrame``, SI:
        ``quantity``, ``unit`` (its SI unit), ``sensitivity`` (V per unit), ``minimum``
        (detectable), ``range``, ``range_reached`` and ``limited_by``."""
        metrics = list(self.metrics)
        return dataframe({"quantity": [m.quantity for m in metrics],
                          "unit": [MEASURANDS[m.quantity].unit for m in metrics],
                          "sensitivity": [m.sensitivity for m in metrics],
                          "minimum": [m.minimum for m in metrics],
                          "range": [m.range for m in metrics],
                          "range_reached": [m.reached for m in metrics],
                          "limited_by": [m.limited_by for m in metrics]})


def _percent(sigma: float, value: float) -> str:
    """σ relative to ``value`` as ``"27 %"`` (:func:`~magcilia.device.stiffness.percent`)."""
    return percent(sigma / value if value else 0.0)


def _range(q: F64, b: F64, setup: Setup, end_note: str) -> tuple[float, str, bool]:
    """Range from q[0] of the fields ``b`` (c, 3) at the setup's single-axis element
    (:func:`~magcilia.design.ranges.single_axis_range`): its rated range (B_x and |B| within
    ±field_range) or a fold of the output, else the sweep's end (not reached); what ends it;
    whether it was reached."""
    sensor = setup.sensor
    return single_axis_range(q, b, sensor.field_range, sensor.voltage(b[:, 0]), end_note)


def _unavailable(quantity: str, unit: str, why: str) -> Metric:
    return Metric(quantity, unit, math.nan, math.nan, math.nan, why, np.zeros((0, 2)))


def _force_metric(setup: Setup, noise: float, points: int) -> Metric:
    c = setup.cilium
    if c.tip_radius == 0.0:
        return _unavailable("force", "N",
                            f"not available: tip_radius 0 cannot carry {SHARP_TIP['force']}"
                            "; give the setup a tip radius")
    sweep = FORCE.sweep(setup, WATER, points)  # to a linear deflection of 3 L: strongly bent
    delta = 1e-6 * sweep.limit
    v_pm = setup.output(bend_sweep(setup, forces=[-delta, delta]))
    slope = float(v_pm[1] - v_pm[0]) / (2.0 * delta)
    q, b = sweep.values, sweep.fields
    volts = setup.sensor.voltage(b[:, 0])
    rng, why, reached = _range(q, b, setup, sweep.end)
    minimum = noise / abs(slope) if slope else math.inf
    rel = setup.youngs_modulus_uncertainty  # F ∝ E at a fixed shape: exactly
    return Metric("force", "N", slope, minimum, rng, why, np.stack([q, volts], axis=1), reached,
                  rel * minimum, rel * rng)


def _flow_metric(setup: Setup, fluid: Fluid, noise: float, points: int) -> Metric:
    c = setup.cilium
    if c.tip_radius == 0.0:
        return _unavailable("flow", "m/s",
                            f"not available: tip_radius 0 cannot carry {SHARP_TIP['flow']}"
                            "; give the setup a tip radius")
    d = 2.0 * c.max_radius  # the widest section sets the Reynolds limit
    sweep = FLOW.sweep(setup, fluid, points)
    flow = Flow.uniform(1.0, fluid)
    q, b = sweep.values, sweep.fields
    volts = setup.sensor.voltage(b[:, 0])
    rng, why, reached = _range(q, b, setup, sweep.end)
    u_ref = 1e-3 * fluid.viscosity / (fluid.density * d)
    v0 = float(volts[0])
    slope = (float(setup.output(bend(setup, flow=flow.with_speed(u_ref)))[0]) - v0) / u_ref
    # minimum detectable speed: |V(U) - V(0)| = noise, bracketed on the sweep, refined by solves
    dev = np.abs(volts - v0) - noise
    above = np.nonzero(dev >= 0.0)[0]
    if above.size == 0:
        minimum = math.inf
    else:
        from scipy.optimize import brentq

        i = int(above[0])

        def gap(u: float) -> float:
            return abs(float(setup.output(bend(setup, flow=flow.with_speed(u)))[0]) - v0) - noise

        minimum = float(brentq(gap, float(q[i - 1]), float(q[i]), xtol=1e-12, rtol=1e-8)) \
            if i > 0 else 0.0
    return Metric("flow", "m/s", slope, minimum, rng, why, np.stack([q, volts], axis=1),
                  reached, *_flow_scale(setup, flow, minimum, rng))


def _flow_scale(setup: Setup, flow: Flow, minimum: float, rng: float) -> tuple[float, float]:
    """The force scale's 1 σ of a flow minimum and range, m/s: ∂U/∂ln E at a fixed output (the
    model's, :func:`~magcilia.readout.scale.fixed_output_rate`) times σ_E/E (0 where the value
    is 0 or not finite, or the modulus is taken as exact)."""
    rel = setup.youngs_modulus_uncertainty
    speeds = np.array([minimum, rng])
    good = np.isfinite(speeds) & (speeds > 0.0)
    out = np.zeros(2)
    if rel and good.any():
        try:
            rate = fixed_output_rate(lambda s, u: output_at(s, "flow", u, flow), setup,
                                     speeds[good])
        except MagciliaError:  # beyond the solver at the range's end: the minimum's share
            rate = fixed_output_rate(lambda s, u: output_at(s, "flow", u, flow), setup,
                                     speeds[good][:1]) * speeds[good] / speeds[good][0]
        out[good] = np.abs(rate) * rel
    return float(out[0]), float(out[1])


def _angle_metric(setup: Setup, noise: float, points: int) -> Metric:
    h = 1e-6
    v_pm = setup.output([-h, h])
    slope = float(v_pm[1] - v_pm[0]) / (2.0 * h)
    q = np.linspace(0.0, 0.5 * math.pi, 4 * points)
    b = setup.field(q)
    volts = setup.sensor.voltage(b[:, 0])
    rng, why, reached = _range(q, b, setup, SWEEP_ENDS["angle"])
    return Metric("angle", "rad", slope, noise / abs(slope) if slope else math.inf, rng, why,
                  np.stack([q, volts], axis=1), reached)


def design_metrics(setup: Setup, fluid: Fluid = WATER,
                   bandwidth: tuple[float, float] = DEFAULT_BANDWIDTH,
                   points: int = 151) -> DesignMetrics:
    """Sensitivity, minimum detectable force/speed/angle and range of a sensor design.

    Parameters
    ----------
    setup : Setup
        The design. Force and flow metrics need ``tip_radius > 0`` (else they are reported as
        not available). Its layout is resolved at the element (module docstring); the result's
        ``setup`` is the one used.
    fluid : Fluid
        Fluid for the flow metrics (default water at 20 °C; uniform flow along +x).
    bandwidth : (float, float)
        Noise bandwidth (f_low, f_high), Hz.
    points : int
        Sweep points per measurand (≥ 11).

    Returns
    -------
    DesignMetrics
        With ``.report()``, ``.table()`` and ``.to_dict()``; see :mod:`magcilia.report.design`
        for a figure.
    """
    if not isinstance(setup, Setup):
        raise v.fail("setup", type(setup).__name__, "a magcilia.Setup")
    setup = setup.resolve_layout()  # the layout rule at the sensing element
    if not isinstance(fluid, Fluid):
        raise v.fail("fluid", type(fluid).__name__, "a magcilia Fluid (AIR, WATER, …)")
    points = v.integer("points", points, 11)
    noise = setup.sensor.output_noise_rms(*bandwidth)
    band, settle = response_figures(setup, fluid)
    return DesignMetrics(
        force=_force_metric(setup, noise, points),
        flow=_flow_metric(setup, fluid, noise, points),
        angle=_angle_metric(setup, noise, points),
        noise=noise, bandwidth=(float(bandwidth[0]), float(bandwidth[1])), fluid=fluid,
        setup=setup, response_bandwidth=band, settling_time=settle,
    )
