"""The hair in time: a load (tip force, flow speed or tilt) over time → hair motion → field →
sensor output, by a reduced modal model around the static large-deflection map.

The model (all SI)
------------------
Each value q of the measurand has a static equilibrium (:func:`magcilia.mechanics.poses_at`: the
elastica for a force or a flow, the rigid tilt for an angle), with a tip displacement δ(q) along
the bending direction and a sensor output V(q) (:meth:`magcilia.Setup.output`). The *effective
load* of q is the tip force that would deflect the straight rod's linear model as far,
``u(q) = δ(q) / C`` (N; C the small-load tip compliance, :func:`tip_compliance`): exactly the
force for small tip forces. The hair's motion is linear in u (:class:`ModalDynamics`)::

    ẍ_j + 2 ζ_j ω_j ẋ_j + ω_j² x_j = ω_j² s_j u(t)     (j = 1 … m, the modes kept)
    u_dyn(t) = Σ_j x_j(t) + r · u(t)                    (s_j = 1 / (k_j C), r = 1 − Σ_j s_j)

with the modes' natural frequencies ω_j, damping ratios ζ_j and tip-referred stiffnesses k_j
(:func:`magcilia.mechanics.modes`: tapered rod, the fluid's added mass and damping): each mode
carries its share s_j of the static tip compliance, and the higher modes' share r follows the load
at once (the mode-acceleration correction; with the load held over each interval, the sample at
t_k sees the load of the interval before it, as the modes' own exact step does), so the static
gain is exactly 1 at any number of modes. The hair then sits where the static map puts the
effective load u_dyn: the quantity ``q_eff = u⁻¹(u_dyn)``, the tip ``δ(q_eff)`` and the output
``V(q_eff)``; a slow load reproduces the static model exactly.

Each mode is discretised exactly at the sample rate (the matrix exponential of its state-space
model with the load held over each sample, ``hold="zoh"``, or linear between samples,
``"foh"``), so the step is unconditionally stable and exact at any rate for such inputs; each mode
is one biquad run by :func:`scipy.signal.lfilter` (the state carried from one block to the next:
:class:`ResponseStream`).

Where the reduction holds
-------------------------
* The modes are those of the straight rod: a large static deflection changes the tangent stiffness
  dF/dδ and so the frequencies (by about half the relative change of the stiffness);
  :attr:`TransientResponse.stiffening` states that change over the loads of a tip-force
  response (the largest |k_tangent / k_0 − 1| over the loads it met). Below a few per cent the
  ringing's frequency is right to about half as much; beyond, read the waveform as qualitative
  (the force-sensor cilium: 1.5 % for a 1 µN step, 25 % for 4 µN, ~900 % for 16 µN, where the
  linear modes overstate the overshoot of a hair that stiffens as it bends over; the static end
  points stay exact).
* A tip force loads the modes as the model says; a flow is taken to load them as a tip force
  with the same static deflection would (its static deflection is exact; the first mode carries
  most of either), with quasi-steady drag: the drag's own dependence on frequency and on the
  hair's velocity (a little extra damping in a mean flow) are left out.
* A rigid tilt (``"angle"``) is followed through the same dynamics (a tilt imposed at the hair's
  tip, the paper's thread).
* The tests check the reduced model against a full finite-element solve of the linear
  Euler–Bernoulli rod (Newmark) for small loads (``tests/mechanics/test_transient.py``).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from functools import cached_property
from typing import Any, Protocol

import numpy as np
from numpy.typing import ArrayLike, NDArray

from magcilia import _validate as v
from magcilia._display import Display, Item, dataframe, number, si
from magcilia.device.parameters import MEASURANDS
from magcilia.device.setup import Setup
from magcilia.mechanics.bend import poses_at
from magcilia.mechanics.compliance import tip_compliance
from magcilia.mechanics.drag import Fluid
from magcilia.mechanics.flow import Flow
from magcilia.mechanics.modal import modes as modes_of

F64 = NDArray[np.float64]

__all__ = ["HOLDS", "STATIC_POINTS", "ModalDynamics", "ResponseStream", "StaticMap",
           "TransientResponse", "map_range", "simulate_response"]

#: how the load is taken between samples: held (zero-order hold) or linear (first-order hold)
HOLDS = ("zoh", "foh")
#: points of a static map (as a read-out table)
STATIC_POINTS = 257
#: modes of the reduced model by default
MODE_COUNT = 3


class ModesLike(Protocol):
    """What the reduced model reads of :func:`magcilia.mechanics.modes`'s result (SI)."""

    @property
    def frequencies(self) -> Any: ...  # Hz, (m,), natural (undamped), added mass included

    @property
    def damping_ratios(self) -> Any: ...  # (m,)

    @property
    def modal_stiffnesses(self) -> Any: ...  # N/m, (m,), referred to the tip


def hair_modes(setup: Setup, fluid: Fluid | None, count: int) -> ModesLike:
    """The hair's lowest ``count`` modes in ``fluid`` (None: vacuum), by
    :func:`magcilia.mechanics.modes`."""
    result: ModesLike = modes_of(setup, fluid, count=count)
    return result


def _second_order(omega: float, zeta: float, gain: float) -> tuple[F64, F64]:
    """A mode's continuous state-space (x, ẋ): A (2, 2) and B (2,) for input u."""
    return (np.array([[0.0, 1.0], [-omega * omega, -2.0 * zeta * omega]]),
            np.array([0.0, omega * omega * gain]))


def discretise(a: F64, b: F64, dt: float, hold: str) -> tuple[F64, F64, F64]:
    """Exact discretisation of ``ẋ = A x + B u`` over a step ``dt`` (s): ``x⁺ = Φ x + Γ₀ u_k +
    Γ₁ u_{k+1}`` with the load held (``"zoh"``: Γ₁ = 0) or linear between samples (``"foh"``),
    from one matrix exponential (Van Loan's block form). Shapes: A (s, s), B (s,) or (s, i) →
    Φ (s, s), Γ₀ and Γ₁ like B."""
    s = a.shape[0]
    bb = b.reshape(s, -1)
    i = bb.shape[1]
    big = np.zeros((s + 2 * i, s + 2 * i))
    big[:s, :s] = a * dt
    big[:s, s:s + i] = bb * dt
    big[s:s + i, s + i:] = np.eye(i)  # the load's slope over the step (foh)
    from scipy.linalg import expm
    e = expm(big)
    phi, g0, g1 = e[:s, :s], e[:s, s:s + i], e[:s, s + i:]
    if hold == "zoh":
        return phi, g0.reshape(b.shape), np.zeros(b.shape)
    return phi, (g0 - g1).reshape(b.shape), g1.reshape(b.shape)


@dataclass(frozen=True)
class ModalDynamics:
    """The hair's linear dynamics from the effective load u to the dynamic one, static gain 1
    (see the module's docstring; immutable).

    Attributes
    ----------
    frequencies : ndarray, shape (m,)
        Natural (undamped) frequencies of the modes kept, Hz.
    damping_ratios : ndarray, shape (m,)
        Their damping ratios ζ (≥ 1: overdamped).
    shares : ndarray, shape (m,)
        Each mode's share of the static tip compliance, ``1 / (k_j C)``.
    residual : float
        The share of the modes left out (``1 − Σ shares``), following the load at once.
    """

    frequencies: F64
    damping_ratios: F64
    shares: F64
    residual: float

    @classmethod
    def from_modes(cls, modes: ModesLike, compliance: float) -> ModalDynamics:
        """From a modal model (frequencies Hz, damping ratios, tip-referred stiffnesses N/m)
        and the static tip compliance ``compliance`` (m/N)."""
        f = np.asarray(modes.frequencies, dtype=np.float64).reshape(-1)
        z = np.asarray(modes.damping_ratios, dtype=np.float64).reshape(-1)
        k = np.asarray(modes.modal_stiffnesses, dtype=np.float64).reshape(-1)
        if not (f.size and f.size == z.size == k.size and np.all(f > 0) and np.all(k > 0)
                and np.all(z >= 0) and np.all(np.isfinite(z))):
            raise v.fail("modes", f"{f.size} frequencies, {z.size} damping ratios, {k.size} "
                         "stiffnesses", "as many positive frequencies (Hz) and stiffnesses "
                         "(N/m) as finite damping ratios ≥ 0")
        c = v.positive("compliance", compliance, "m/N", "compliance")
        shares = 1.0 / (k * c)
        return cls(f, z, shares, float(1.0 - shares.sum()))

    def below(self, frequency: float) -> ModalDynamics:
        """The modes below ``frequency`` (Hz; e.g. a sampler's Nyquist frequency), the others
        moved into the residual (they follow the load at once)."""
        keep = self.frequencies < frequency
        return ModalDynamics(self.frequencies[keep], self.damping_ratios[keep],
                             self.shares[keep], float(1.0 - self.shares[keep].sum()))

    def state_space(self) -> tuple[F64, F64, F64, float]:
        """The continuous model ``ẋ = A x + B u``, ``u_dyn = C x + D u``: A (2m, 2m), B (2m,),
        C (2m,), D (the residual); state (x_1, ẋ_1, x_2, ẋ_2, …) in N."""
        m = self.frequencies.size
        a = np.zeros((2 * m, 2 * m))
        b = np.zeros(2 * m)
        c = np.zeros(2 * m)
        for j in range(m):
            a[2 * j:2 * j + 2, 2 * j:2 * j + 2], b[2 * j:2 * j + 2] = _second_order(
                2.0 * math.pi * self.frequencies[j], self.damping_ratios[j], self.shares[j])
            c[2 * j] = 1.0
        return a, b, c, self.residual

    def biquads(self, rate: float, hold: str = "zoh") -> tuple[F64, F64]:
        """Each mode's exact discrete transfer function at ``rate`` (Hz) from u to its x_j:
        numerators and denominators, shapes (m, 3) (for :func:`scipy.signal.lfilter`)."""
        dt = 1.0 / rate
        m = self.frequencies.size
        num, den = np.zeros((m, 3)), np.zeros((m, 3))
        for j in range(m):
            a, b = _second_order(2.0 * math.pi * self.frequencies[j], self.damping_ratios[j],
                                 self.shares[j])
            phi, g0, g1 = discretise(a, b, dt, hold)
            # x_k = [1, 0]·state: (z I − Φ)⁻¹ (Γ₀ + z Γ₁) through the adjugate of z I − Φ
            (p, q), (r, s) = phi
            den[j] = (1.0, -(p + s), p * s - q * r)
            # [1, 0] adj(zI − Φ) = [z − s, q]
            w0 = g0[0] * -s + q * g0[1]  # constant terms of (z − s) g0[0] + q g0[1]
            w1 = g0[0] + (g1[0] * -s + q * g1[1])
            w2 = g1[0]
            num[j] = (w2, w1, w0)
        return num, den


@dataclass(frozen=True)
class StaticMap:
    """The static large-deflection map of a measurand over a range (immutable table).

    Attributes
    ----------
    quantity : str
        ``"angle"`` (rad), ``"force"`` (N) or ``"flow"`` (m/s).
    values : ndarray, shape (t,)
        The measurand at the table's points, SI, increasing.
    tip : ndarray, shape (t,)
        The static tip displacement along the bending direction, m, increasing.
    output : ndarray, shape (t,)
        The sensor output, V.
    compliance : float
        The small-load tip compliance C, m/N (the effective load is ``tip / C``).
    """

    quantity: str
    values: F64
    tip: F64
    output: F64
    compliance: float

    @classmethod
    def build(cls, setup: Setup, quantity: str, low: float, high: float,
              flow: Flow | None = None, points: int = STATIC_POINTS) -> StaticMap:
        """The map over [``low``, ``high``] (SI) at ``points`` equally spaced values."""
        values = np.linspace(low, high, points)
        pose, azimuth = poses_at(setup, quantity, values, flow)
        if quantity == "angle":
            tip = setup.cilium.height * np.sin(values)
        else:
            tip = np.asarray(pose.points[:, -1, 0], dtype=np.float64)  # type: ignore[union-attr]
        if not np.all(np.diff(tip) > 0.0):
            unit = MEASURANDS[quantity].unit
            raise v.fail(f"{quantity} range", f"{low:.6g}…{high:.6g} {unit}", "one where the tip "
                         "moves on with the load (a smaller load, below a fold of the bending)")
        output = np.asarray(setup.output(pose, azimuth=azimuth), dtype=np.float64)
        return cls(quantity, values, tip, output, tip_compliance(setup))

    @cached_property
    def effective(self) -> F64:
        """The effective load at the table's points, N, shape (t,)."""
        return np.asarray(self.tip / self.compliance, dtype=np.float64)

    def covers(self, low: float, high: float) -> bool:
        """Whether the table spans [``low``, ``high``] (SI)."""
        return bool(self.values[0] <= low and high <= self.values[-1])

    def load(self, values: F64) -> F64:
        """The effective load (N) of measurand ``values`` (SI), same shape."""
        return np.asarray(np.interp(values, self.values, self.effective), dtype=np.float64)

    def at_load(self, load: F64) -> tuple[F64, F64, F64]:
        """The measurand (SI), tip displacement (m) and output (V) where the effective load is
        ``load`` (N), each the shape of ``load`` (within the table's range)."""
        q = np.interp(load, self.effective, self.values)
        return (np.asarray(q, dtype=np.float64), np.asarray(load * self.compliance),
                np.asarray(np.interp(q, self.values, self.output), dtype=np.float64))

    def stiffening(self, low: float, high: float) -> float:
        """The largest relative change of a tip force's tangent stiffness dF/dδ against the
        small-load one, ``max |k C − 1|``, over the loads [``low``, ``high``] (N) of the table
        (dimensionless; 0 for a linear hair); NaN for a flow or a tilt (not computed)."""
        if self.quantity != "force":
            return math.nan
        k = np.gradient(self.values, self.tip)
        inside = (self.values >= low) & (self.values <= high)
        if not inside.any():
            inside = np.abs(self.values - 0.5 * (low + high)) == np.min(
                np.abs(self.values - 0.5 * (low + high)))
        return float(np.max(np.abs(k[inside] * self.compliance - 1.0)))


def map_range(values: F64, quantity: str) -> tuple[float, float]:
    """A static map's range for loads ``values``: the loads and as far again beyond (a step's
    overshoot), through 0 (rest), within ±80° for a tilt."""
    lo, hi = float(min(values.min(), 0.0)), float(max(values.max(), 0.0))
    width = max(hi - lo, 1e-12 if quantity != "angle" else 1e-6)
    lo, hi = lo - (width if lo < 0 else 0.25 * width), hi + (width if hi > 0 else 0.25 * width)
    if quantity == "angle":
        lo, hi = max(lo, -math.radians(80.0)), min(hi, math.radians(80.0))
    return lo, hi


class ResponseStream:
    """The reduced model run block by block (the state carried between calls; mutable).

    Parameters
    ----------
    setup : Setup
        The sensor setup (geometry, modulus, magnetization, sensor).
    quantity : {"force", "flow", "angle"}
        What the loads are: tip forces along +x (N), flow speeds (m/s; ``flow``'s profile scaled)
        or rigid tilt angles (rad).
    rate : float
        Samples per second, Hz.
    fluid : Fluid, optional
        The fluid around the hair (its added mass and damping, :func:`magcilia.mechanics.modes`);
        None: vacuum, or the flow's fluid for ``"flow"``.
    flow : Flow, optional
        The flow profile of ``"flow"`` (default uniform water flow).
    count : int
        Modes kept (the rest follow the load at once).
    modes : modal model, optional
        Precomputed modes (:func:`magcilia.mechanics.modes`'s result) instead of computing them.
    hold : {"zoh", "foh"}
        The load held over each sample or linear between samples.

    The hair starts at rest under the first load it is given.
    """

    def __init__(self, setup: Setup, quantity: str, rate: float, *, fluid: Fluid | None = None,
                 flow: Flow | None = None, count: int = MODE_COUNT,
                 modes: ModesLike | None = None, hold: str = "zoh") -> None:
        if not isinstance(setup, Setup):
            raise v.fail("setup", type(setup).__name__, "a magcilia.Setup")
        self.setup = setup
        self.quantity = v.choice("quantity", quantity, tuple(MEASURANDS))
        self.rate = v.positive("rate", rate, "Hz", "frequency")
        self.hold = v.choice("hold", hold, HOLDS)
        if flow is not None and not isinstance(flow, Flow):
            raise v.fail("flow", type(flow).__name__, "a magcilia.Flow")
        self.flow = flow if flow is not None else (Flow.uniform(1.0) if quantity == "flow"
                                                   else None)
        if fluid is None and self.flow is not None and quantity == "flow":
            fluid = self.flow.fluid
        if fluid is not None and not isinstance(fluid, Fluid):
            raise v.fail("fluid", type(fluid).__name__, "a magcilia.Fluid (AIR, WATER) or None")
        self.fluid = fluid
        if modes is None:
            modes = hair_modes(setup, fluid, v.integer("count", count, 1))
        compliance = tip_compliance(setup)
        if not math.isfinite(compliance):
            raise v.fail("tip_radius", 0.0, "> 0 for the hair's dynamics (a sharp cone has no "
                         "finite tip compliance)")
        self.dynamics = ModalDynamics.from_modes(modes, compliance)
        self.num, self.den = self.dynamics.biquads(self.rate, self.hold)
        self.map: StaticMap | None = None
        self._state: F64 | None = None  # (m, 2) lfilter states
        self._held = 0.0  # the load held over the last interval (N; "zoh")

    def _map_for(self, low: float, high: float) -> StaticMap:
        """The static map, rebuilt wider when [low, high] (SI) leaves it."""
        if self.map is None or not self.map.covers(low, high):
            if self.map is not None:
                low, high = min(low, self.map.values[0]), max(high, self.map.values[-1])
            lo, hi = map_range(np.array([low, high]), self.quantity)
            self.map = StaticMap.build(self.setup, self.quantity, lo, hi, self.flow)
        return self.map

    def prepare(self, values: ArrayLike) -> None:
        """Build the static map for loads ``values`` (SI) ahead of time (the state is not
        touched)."""
        q = v.finite_array("values", values, ndim=1, unit=MEASURANDS[self.quantity].unit)
        if q.size:
            self._map_for(*map_range(q, self.quantity))

    def push(self, values: ArrayLike) -> tuple[F64, F64, F64]:
        """The hair under the next loads ``values`` (SI, (n,)): its effective quantity (SI: the
        load the static model would need to hold it where it is), tip displacement (m) and
        sensor output (V), each (n,)."""
        q = v.finite_array("values", values, ndim=1, unit=MEASURANDS[self.quantity].unit)
        if q.size == 0:
            return np.zeros(0), np.zeros(0), np.zeros(0)
        smap = self._map_for(float(q.min()), float(q.max()))
        u = smap.load(q)
        from scipy.signal import lfilter, lfilter_zi
        if self._state is None:  # at rest under the first load
            self._state = np.stack([lfilter_zi(b, a) for b, a in zip(self.num, self.den,
                                                                     strict=True)]) * u[0]
            self._held = float(u[0])
        # the higher modes follow the load as it is at each sample: held ("zoh") over the
        # interval before it, reached linearly ("foh")
        now = u if self.hold == "foh" else np.concatenate(([self._held], u[:-1]))
        self._held = float(u[-1])
        out = self.dynamics.residual * now
        for j in range(self.num.shape[0]):
            x, self._state[j] = lfilter(self.num[j], self.den[j], u, zi=self._state[j])
            out += x
        low, high = float(out.min()), float(out.max())
        while not smap.effective[0] <= low <= high <= smap.effective[-1]:
            span = smap.values[-1] - smap.values[0]
            slope = span / (smap.effective[-1] - smap.effective[0])
            smap = self._map_for(min(smap.values[0], smap.values[0] + slope * (
                low - smap.effective[0]) * 1.2), max(smap.values[-1], smap.values[-1] + slope * (
                    high - smap.effective[-1]) * 1.2))
        return smap.at_load(out)


@dataclass(frozen=True, eq=False, repr=False)
class TransientResponse(Display):
    """The hair's response to a load over time (immutable; SI).

    Attributes
    ----------
    quantity : str
        ``"force"`` (N), ``"flow"`` (m/s) or ``"angle"`` (rad).
    rate : float
        Samples per second, Hz.
    time : ndarray, shape (n,)
        Sample times, s (from 0).
    load : ndarray, shape (n,)
        The applied load, SI.
    effective : ndarray, shape (n,)
        The load the static model would need to hold the hair where it is, SI (the static
        read-out's answer without noise).
    tip : ndarray, shape (n,)
        The tip displacement along the bending direction, m.
    output : ndarray, shape (n,)
        The sensor output, V (noise-free).
    frequencies, damping_ratios : ndarray, shape (m,)
        The modes used: natural frequencies (Hz) and damping ratios.
    residual : float
        The static tip compliance's share of the modes left out.
    stiffening : float
        A tip force's largest relative change of the tangent stiffness over the loads met (the
        applied and the effective ones): where the reduction holds, see
        :mod:`magcilia.mechanics.transient`; NaN for a flow or a tilt (not computed).
    hold : str
        ``"zoh"`` or ``"foh"``.
    fluid : str
        The fluid's name, or ``"vacuum"``.
    """

    quantity: str
    rate: float
    time: F64
    load: F64
    effective: F64
    tip: F64
    output: F64
    frequencies: F64
    damping_ratios: F64
    residual: float
    stiffening: float
    hold: str
    fluid: str = field(default="vacuum")

    @property
    def unit(self) -> str:
        """SI unit of the load: ``"N"``, ``"m/s"`` or ``"rad"``."""
        return MEASURANDS[self.quantity].unit

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready content (SI)."""
        return {"quantity": self.quantity, "unit": self.unit, "rate_Hz": self.rate,
                "hold": self.hold, "fluid": self.fluid, "time_s": self.time.tolist(),
                "load": self.load.tolist(), "effective": self.effective.tolist(),
                "tip_m": self.tip.tolist(), "output_V": self.output.tolist(),
                "frequencies_Hz": self.frequencies.tolist(),
                "damping_ratios": self.damping_ratios.tolist(), "residual": self.residual,
                "stiffening": self.stiffening}

    def to_dataframe(self) -> Any:
        """The samples as a ``pandas.DataFrame`` (SI; columns named with their unit)."""
        unit = self.unit.replace("/", "_per_")
        return dataframe({"time_s": self.time, f"load_{unit}": self.load,
                          f"effective_{unit}": self.effective, "tip_m": self.tip,
                          "output_V": self.output})

    def report(self) -> str:
        """Two lines: the modes used and the response's range."""
        q = MEASURANDS[self.quantity]
        modes = ", ".join(f"{f:.4g} Hz (ζ {z:.3g})" for f, z in zip(
            self.frequencies, self.damping_ratios, strict=True))
        peak = q.to_display(float(np.max(np.abs(self.effective)))) if self.time.size else 0.0
        return (f"{q.label} response over {self.time.size} samples at {self.rate:g} Hz in "
                f"{self.fluid}: modes {modes}; higher modes' share {self.residual:.3g}\n"
                f"effective load up to {peak:.4g} {q.display}, tip up to "
                f"{float(np.max(np.abs(self.tip), initial=0.0)) * 1e3:.4g} mm"
                + ("" if math.isnan(self.stiffening) else
                   f"; stiffness change over the loads {self.stiffening:.2%} (where the modal "
                   "reduction holds: a few per cent)"))

    def _display_items(self) -> list[Item]:
        return [("", self.quantity), ("samples", str(self.time.size)),
                ("rate", si(self.rate, "Hz")), ("first mode", si(float(self.frequencies[0]),
                                                                  "Hz")),
                ("ζ", number(float(self.damping_ratios[0]))), ("fluid", self.fluid)]


def simulate_response(setup: Setup, load: ArrayLike, rate: float, *, quantity: str = "force",
                      fluid: Fluid | None = None, flow: Flow | None = None,
                      count: int = MODE_COUNT, modes: ModesLike | None = None,
                      hold: str = "zoh") -> TransientResponse:
    """The hair's motion and the sensor's output under a load given over time.

    The reduced modal model around the static large-deflection map (the module's docstring:
    what it is and where it holds); fast (a biquad per mode, :func:`scipy.signal.lfilter`) and
    exact at the samples for the load held (``"zoh"``) or linear (``"foh"``) between them.

    Parameters
    ----------
    setup : Setup
        The sensor setup (needs ``tip_radius > 0`` for a force or a flow).
    load : array-like, shape (n,)
        The load at each sample, SI: tip force along +x (N), flow speed (m/s) or tilt (rad);
        the hair is at rest under ``load[0]`` before the first sample.
    rate : float
        Samples per second, Hz.
    quantity : {"force", "flow", "angle"}
        What ``load`` is.
    fluid : Fluid, optional
        The fluid around the hair (:data:`~magcilia.AIR`, :data:`~magcilia.WATER`); None:
        vacuum, or the flow's fluid for a flow.
    flow : Flow, optional
        The flow profile for ``"flow"`` (default uniform water).
    count : int
        Modes kept (default 3; the others follow the load at once).
    modes : optional
        A precomputed :func:`magcilia.mechanics.modes` result (frequencies, damping ratios and
        tip-referred stiffnesses) to use instead.
    hold : {"zoh", "foh"}
        The load between samples: held, or linear.

    Returns
    -------
    TransientResponse
        Times (s), load, effective load (SI), tip displacement (m), output (V), each (n,).

    Examples
    --------
    >>> import magcilia as mc
    >>> setup = mc.presets.load("force-sensor")
    >>> step = np.r_[0.0, np.full(99, 1e-6)]          # a 1 µN step at 10 kHz
    >>> r = mc.simulate_response(setup, step, 10e3, fluid=mc.AIR)
    >>> round(float(r.frequencies[0]))                 # the first mode in air, Hz
    152
    >>> bool(r.effective.max() > 1.5e-6)               # it overshoots (ζ = 0.003: it rings)
    True
    """
    stream = ResponseStream(setup, quantity, rate, fluid=fluid, flow=flow, count=count,
                            modes=modes, hold=hold)
    q = v.finite_array("load", load, ndim=1, unit=MEASURANDS[stream.quantity].unit)
    stream.prepare(q)  # one table for the whole series
    effective, tip, output = stream.push(q)
    smap = stream.map
    dyn = stream.dynamics
    return TransientResponse(
        quantity=stream.quantity, rate=stream.rate, time=np.arange(q.size) / stream.rate,
        load=q, effective=effective, tip=tip, output=output, frequencies=dyn.frequencies,
        damping_ratios=dyn.damping_ratios, residual=dyn.residual,
        stiffening=math.nan if smap is None or not q.size else smap.stiffening(
            float(min(q.min(), effective.min())), float(max(q.max(), effective.max()))),
        hold=stream.hold,
        fluid="vacuum" if stream.fluid is None else stream.fluid.name)
