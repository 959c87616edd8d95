"""The sensor's frequency response: from a tip force or a flow speed to the sensor output, around
a static operating point, through the cilium's bending modes (:func:`frequency_response`).

The model, linearised about the static equilibrium at the operating point (a tip force F₀ along
+x, or a uniform flow U₀ along +x):

    H(ω) = S · [Σ_n g_n Q_n(ω) / D_n(ω)] / [Σ_n g_n Q_n(0) / D_n(0)] · 1 / (1 + iω/ω_s)

* ``S`` is the static sensitivity dV/dF (V/N) or dV/dU (V/(m/s)) at the operating point: the
  slope of the large-deflection map (:func:`~magcilia.mechanics.bend`) through the field model
  (:meth:`magcilia.Setup.output`), by a central difference; so H(0) = S exactly.
* ``g_n`` is the output per unit tip displacement in mode n (V/m): the field model's response to
  the operating shape's tangent angles perturbed by the mode's slope (a central difference).
* ``D_n(ω) = κ k_n − ω² m_n(ω) + iω c_n(ω)``: the modal stiffness (:func:`~magcilia.modes`),
  scaled by κ = (tip compliance at rest)/(tangent tip compliance at the operating point), the
  large deflection's stiffening; in a fluid the modal added mass and damping at each frequency
  from Sader's hydrodynamic function at every section (the mode shapes are those at the
  resonance; the modes' coupling through the fluid is neglected); a material loss as
  ``η k_n / ω_n``.
* ``Q_n`` is the modal load per unit load: 1 for a tip force (every shape is 1 at the tip); for
  a flow ``∫ φ_n(s) [c_s(s) + iω ρ π r² (1 + Γ_r)] ds``: the quasi-steady drag's slope c_s
  (:func:`~magcilia.mechanics.drag.drag_per_length` at U₀, with the slender-body law of a hair on
  the wall) and the unsteady flow's inertia, the pressure gradient that accelerates the fluid
  (``ρ π r² u̇``) and the added mass it drags along (``ρ π r² Γ_r u̇``) — a Morison-type load
  (Morison et al. 1950, J. Petrol. Technol. 2, 149) with Sader's Γ_r for the added-mass
  coefficient.
* ``ω_s`` is the sensor's own bandwidth, a first-order low-pass (HMC1021Z: 5 MHz, the
  datasheet's; NOTES §5).

The step response behind :attr:`FrequencyResponse.settling_time` is that of the same modal
model with each mode's mass, damping and flow inertia frozen at its resonance (a sum of
second-order sections and the low-pass, in closed form by partial fractions).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import cached_property
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from magcilia import _validate as v
from magcilia._display import Display, Item, Table, number, si
from magcilia.device.setup import Setup
from magcilia.mechanics.bend import bend
from magcilia.mechanics.drag import WATER, Fluid, drag_per_length, slender_log
from magcilia.mechanics.flow import Flow
from magcilia.mechanics.hydrodynamic import added_mass_damping, gamma_table, section_reynolds
from magcilia.mechanics.modal import ELEMENTS, ModalModel, Modes, as_fluid, modal_model
from magcilia.mechanics.planar import require_tip_radius
from magcilia.model.centreline import Centreline

F64 = NDArray[np.float64]
C128 = NDArray[np.complex128]

#: the HMC1021Z's bandwidth, Hz (Honeywell HMC1001/1002/1021/1022 datasheet: 5 MHz; NOTES §5)
SENSOR_BANDWIDTH = 5e6
#: a step has settled once it stays within this fraction of its final value
SETTLING_BAND = 0.02
#: modes in the response model
RESPONSE_MODES = 4
_LOADS = ("force", "flow")
_UNITS = {"force": "V/N", "flow": "V/(m/s)"}


@dataclass(frozen=True, repr=False)
class FrequencyResponse(Display):
    """The sensor's small-signal response to a force or a flow (from
    :func:`frequency_response`; SI, arrays read-only).

    Attributes
    ----------
    frequencies : ndarray, shape (f,)
        Hz.
    transfer : ndarray of complex, shape (f,)
        Output per unit load at each frequency: V/N (``load="force"``) or V/(m/s) (``"flow"``).
    load : str
        "force" (a tip force along +x) or "flow" (a uniform flow along +x).
    operating_point : float
        The static load the response is linearised about, N or m/s.
    static_sensitivity : float
        dV/dF (V/N) or dV/dU (V/(m/s)) of the static map at the operating point: ``transfer``
        at 0 Hz.
    bandwidth : float
        The −3 dB bandwidth, Hz: the lowest frequency where |H| falls to |H(0)|/√2.
    settling_time : float
        Time for the output after a step of the load to stay within 2 % of its final value, s.
    sensor_bandwidth : float
        The sensor's own first-order bandwidth used, Hz.
    modes : Modes
        The modes of the model (in the fluid, if any).
    modal_gains : ndarray, shape (modes,)
        Output per unit tip displacement of each mode at the operating point, V/m.
    modal_sensitivity : float
        The modal model's own 0-Hz value before it is scaled to ``static_sensitivity``
        (``Σ g_n Q_n(0) / κk_n``): the two agree to the modes' truncation at rest.
    """

    frequencies: F64
    transfer: C128
    load: str
    operating_point: float
    static_sensitivity: float
    bandwidth: float
    settling_time: float
    sensor_bandwidth: float
    modes: Modes
    modal_gains: F64
    modal_sensitivity: float

    def __post_init__(self) -> None:
        for name in ("frequencies", "transfer", "modal_gains"):
            arr = np.array(getattr(self, name))
            arr.setflags(write=False)
            object.__setattr__(self, name, arr)

    @property
    def unit(self) -> str:
        """The transfer's unit: "V/N" or "V/(m/s)"."""
        return _UNITS[self.load]

    @property
    def magnitude(self) -> F64:
        """|H|, V/N or V/(m/s), shape (f,)."""
        return np.abs(self.transfer)

    @property
    def magnitude_db(self) -> F64:
        """|H| relative to the static sensitivity, dB, shape (f,)."""
        with np.errstate(divide="ignore"):
            return np.asarray(20.0 * np.log10(self.magnitude / abs(self.static_sensitivity)),
                              dtype=np.float64)

    @property
    def phase(self) -> F64:
        """Phase of H relative to the static sensitivity's sign, rad, unwrapped, shape (f,)."""
        return np.asarray(np.unwrap(np.angle(self.transfer * np.sign(self.static_sensitivity))),
                          dtype=np.float64)

    def table(self) -> list[dict[str, Any]]:
        """One row per frequency (SI)."""
        unit = self.unit.replace("/(m/s)", "_per_m_per_s").replace("/", "_per_")
        return [{"frequency_Hz": float(f), f"magnitude_{unit}": float(m),
                 "magnitude_dB": float(d), "phase_rad": float(p)}
                for f, m, d, p in zip(self.frequencies, self.magnitude, self.magnitude_db,
                                      self.phase, strict=True)]

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready content (SI): the load, the figures of merit, the modes and the curve."""
        return {"load": self.load, "unit": self.unit, "operating_point": self.operating_point,
                "static_sensitivity": self.static_sensitivity, "bandwidth_Hz": self.bandwidth,
                "settling_time_s": self.settling_time,
                "sensor_bandwidth_Hz": self.sensor_bandwidth,
                "modal_gains_V_per_m": self.modal_gains.tolist(),
                "modal_sensitivity": self.modal_sensitivity, "modes": self.modes.to_dict(),
                "frequency_Hz": self.frequencies.tolist(),
                "transfer_real": self.transfer.real.tolist(),
                "transfer_imag": self.transfer.imag.tolist()}

    def report(self) -> str:
        """A few lines: static sensitivity, bandwidth, settling time and the first resonance."""
        m = self.modes
        medium = "vacuum" if m.fluid is None else m.fluid.name
        point = si(self.operating_point, "N" if self.load == "force" else "m/s")
        first = (f"mode 1 at {number(m.frequencies[0], 4)} Hz, ζ = "
                 f"{number(m.damping_ratios[0], 3)}"
                 + (" (overdamped)" if m.overdamped[0] else ""))
        return "\n".join([
            f"Frequency response to a {self.load} in {medium} about {point}:",
            f"  static sensitivity {number(self.static_sensitivity, 4)} {self.unit}",
            (f"  −3 dB bandwidth {number(self.bandwidth, 4)} Hz; settling (2 %) "
             + ("never (undamped)" if math.isinf(self.settling_time)
                else si(self.settling_time, "s"))),
            f"  {first}; sensor bandwidth {si(self.sensor_bandwidth, 'Hz')}"])

    def _display_items(self) -> list[Item]:
        return [("load", self.load), ("bandwidth", f"{number(self.bandwidth, 4)} Hz"),
                ("settling_time", si(self.settling_time, "s")),
                ("static_sensitivity", f"{number(self.static_sensitivity, 4)} {self.unit}"),
                ("points", str(self.frequencies.size))]

    def _display_table(self) -> Table | None:
        rows = [[number(f, 4), number(m, 4), number(d, 3), number(math.degrees(p), 4)]
                for f, m, d, p in zip(self.frequencies, self.magnitude, self.magnitude_db,
                                      self.phase, strict=True)]
        return ["f (Hz)", f"|H| ({self.unit})", "dB", "phase (deg)"], rows


@dataclass(frozen=True)
class _Model:
    """The linear model behind a response (internal): modal figures, gains, loads."""

    model: ModalModel
    fluid: Fluid | None
    stiffness: F64       # κ k_n, N/m
    gains: F64           # g_n, V/m
    drag_slope: F64      # c_s at the quadrature points, N·s/m² (flow) or empty
    load: str
    scale: float         # S / Σ g_n Q_n(0) / κk_n
    sensor_omega: float  # rad/s
    sensitivity: float   # S, V per unit load
    modal_static: float  # Σ g_n Q_n(0) / κk_n

    @cached_property
    def shapes_at_points(self) -> F64:
        """The mode shapes at the quadrature points, shape (n, q)."""
        return self.model.grid.at_points(self.model.vectors)

    def loads(self, omega: F64) -> tuple[C128, C128]:
        """Modal loads Q_n(ω) and dynamic stiffnesses D_n(ω), shapes (n, w)."""
        m = self.model
        phi = self.shapes_at_points
        w = m.grid.weight
        mass = np.repeat(m.structural_masses[:, None], omega.size, axis=1).astype(complex)
        damping = np.zeros((phi.shape[0], omega.size))
        modes = m.modes
        damping += (modes.loss_factor * modes.modal_stiffnesses
                    / modes.angular_frequencies)[:, None]
        if self.fluid is not None:
            added, viscous = self._fluid_terms(np.maximum(omega, 1e-300))
            mass = mass + (phi**2 * w) @ added.T
            damping = damping + (phi**2 * w) @ viscous.T
        dyn = self.stiffness[:, None] - omega**2 * mass + 1j * omega * damping
        if self.load == "force":
            q = np.ones_like(dyn)
        else:
            inertia = self._flow_inertia(omega)  # (w, q)
            q = ((phi * w) @ self.drag_slope)[:, None] + 1j * omega * ((phi * w) @ inertia.T)
        return q, dyn

    def _fluid_terms(self, omega: F64) -> tuple[F64, F64]:
        assert self.fluid is not None
        r = self.model.grid.radius
        added, viscous = added_mass_damping(self.fluid.density, self.fluid.viscosity,
                                            r[None, :], omega[:, None])
        return added, viscous

    def _flow_inertia(self, omega: F64) -> F64:
        """ρ π r² (1 + Γ_r) at the quadrature points, kg/m, shape (w, q); Γ_r frozen below the
        frequency where the viscous penetration depth √(2ν/ω) reaches the hair's length (the
        2-D unsteady force's Stokes-paradox tail is screened by the finite body)."""
        assert self.fluid is not None
        r = self.model.grid.radius
        length = float(self.model.grid.nodes[-1])
        nu = self.fluid.viscosity / self.fluid.density
        omega_l = 2.0 * nu / length**2
        re = section_reynolds(self.fluid.density, self.fluid.viscosity, r[None, :],
                              np.maximum(omega, omega_l)[:, None])
        return np.asarray(self.fluid.density * math.pi * r**2 * (1.0 + gamma_table(re).real),
                          dtype=np.float64)

    def transfer(self, omega: F64) -> C128:
        """H(ω), V per unit load, shape (w,)."""
        q, dyn = self.loads(omega)
        low_pass = 1.0 / (1.0 + 1j * omega / self.sensor_omega)
        return np.asarray(self.scale * (self.gains[:, None] * q / dyn).sum(axis=0) * low_pass,
                          dtype=np.complex128)

    def step(self, t: F64) -> F64:
        """The output after a unit step of the load (V per unit load), shape (t,): the modal
        model frozen at each mode's resonance, by partial fractions."""
        modes = self.model.modes
        m, c = modes.modal_masses, modes.modal_dampings
        omega_n = modes.angular_frequencies
        if self.load == "force":
            b0, b1 = np.ones(m.size), np.zeros(m.size)
        else:
            phi = self.shapes_at_points
            w = self.model.grid.weight
            b0 = (phi * w) @ self.drag_slope
            b1 = np.array([(phi[n] * w) @ self._flow_inertia(omega_n[n:n + 1])[0]
                           for n in range(m.size)])
        a = self.sensor_omega
        out = np.zeros_like(t)
        for n in range(m.size):
            disc = np.sqrt(complex(c[n] ** 2 - 4.0 * m[n] * self.stiffness[n]))
            if abs(disc) < 1e-9 * abs(c[n]):  # critically damped: split the double pole
                disc = 1e-9 * abs(c[n])
            poles = np.array([(-c[n] + disc) / (2 * m[n]), (-c[n] - disc) / (2 * m[n]), -a])
            gain = self.scale * self.gains[n]
            out += gain * b0[n] / self.stiffness[n]
            for j, p in enumerate(poles):
                others = np.prod([p - q for k, q in enumerate(poles) if k != j])
                residue = gain * a * (b1[n] * p + b0[n]) / (m[n] * p * others)
                out += np.real(residue * np.exp(p * t))
        return out


def frequency_response(setup: Setup, frequencies: ArrayLike, *, fluid: Fluid | str | None = None,
                       load: str = "force", force: float = 0.0, flow: float = 0.0,
                       gravity: bool = False, sensor_bandwidth: float = SENSOR_BANDWIDTH,
                       elements: int | None = None) -> FrequencyResponse:
    """The sensor's small-signal frequency response to a tip force or a flow (module notes).

    Parameters
    ----------
    setup : Setup
        The sensor (body, modulus, material, placement, sensor). A tip radius > 0 is needed.
    frequencies : array-like, shape (f,)
        Hz (≥ 0).
    fluid : Fluid, str or None
        The surrounding fluid (None: vacuum for a force, water for a flow).
    load : str
        "force": a tip force along +x (transfer in V/N); "flow": a uniform flow along +x
        (V/(m/s)).
    force : float
        The static tip force of the operating point, N (``load="force"``).
    flow : float
        The static flow speed of the operating point, m/s (``load="flow"``; ≥ 0).
    gravity : bool
        Include the hair's own weight in the modes.
    sensor_bandwidth : float
        The sensor's first-order bandwidth, Hz (default the HMC1021Z's 5 MHz).
    elements : int or None
        Beam elements of the modes (default 24).

    Returns
    -------
    FrequencyResponse
        Transfer (complex), static sensitivity, −3 dB bandwidth, settling time and the modes.
    """
    if not isinstance(setup, Setup):
        raise v.fail("setup", type(setup).__name__, "a Setup")
    load = v.choice("load", load, _LOADS)
    freq = v.finite_array("frequencies", frequencies, ndim=1, unit="Hz")
    if freq.size == 0 or np.any(freq < 0.0):
        raise v.fail("frequencies", "an empty or negative array" if freq.size else "[]",
                     "frequencies ≥ 0 in Hz (at least one)")
    medium = as_fluid(fluid)
    if load == "flow" and medium is None:
        medium = WATER
    point = v.real("force", force, "N") if load == "force" else v.non_negative(
        "flow", flow, "m/s", "flow speed")
    if load == "force" and flow != 0.0:
        raise v.fail("flow", flow, "0 for load='force' (the operating point is force=)")
    if load == "flow" and force != 0.0:
        raise v.fail("force", force, "0 for load='flow' (the operating point is flow=)")
    band = v.positive("sensor_bandwidth", sensor_bandwidth, "Hz", "frequency")
    require_tip_radius(setup, load)
    n_el = ELEMENTS if elements is None else v.integer("elements", elements, 2)
    model = _build(setup, medium, bool(gravity), load, point, band, n_el)
    omega = 2.0 * math.pi * freq
    return FrequencyResponse(freq, model.transfer(omega), load, point, model.sensitivity,
                             _bandwidth(model), _settling(model), band, model.model.modes,
                             model.gains, model.modal_static)


def response_figures(setup: Setup, fluid: Fluid | None, load: str = "force",
                     point: float = 0.0) -> tuple[float, float]:
    """The −3 dB bandwidth (Hz) and the 2 % settling time (s) of a design's response to
    ``load`` about ``point`` (N or m/s) in ``fluid``; (NaN, NaN) where the model refuses the
    design (a sharp tip, a hair that buckles): the design metrics' and the optimiser's figures
    of merit."""
    try:
        r = frequency_response(setup, [0.0], fluid=fluid, load=load,
                               force=point if load == "force" else 0.0,
                               flow=point if load == "flow" else 0.0)
    except (ValueError, ArithmeticError):  # MagciliaError included
        return math.nan, math.nan
    return r.bandwidth, r.settling_time


def _build(setup: Setup, medium: Fluid | None, gravity: bool, load: str, point: float,
           band: float, n_el: int) -> _Model:
    """The linear model at the operating point: modes, κ, gains, drag slope, scale."""
    model = modal_model(setup, medium, gravity, RESPONSE_MODES, n_el, 0.0)
    length = setup.cilium.height
    stiff = model.modes.modal_stiffnesses
    step_force = 1e-3 * length * float(np.sum(1.0 / stiff))**-1  # a tip deflection of 1e-3 L
    at_rest = point == 0.0
    base_flow = None if load == "force" or at_rest else Flow.uniform(point, medium or WATER)
    base_force = point if load == "force" else 0.0

    def tip_x(f: float, flow: Flow | None) -> float:
        return float(bend(setup, force=f, flow=flow).tip[0])

    compliance = (tip_x(base_force + step_force, base_flow)
                  - tip_x(base_force - step_force, base_flow)) / (2 * step_force)
    rest = compliance if at_rest else (tip_x(step_force, None)
                                       - tip_x(-step_force, None)) / (2 * step_force)
    kappa = rest / compliance
    operating = bend(setup, force=base_force, flow=base_flow)
    assert isinstance(operating, Centreline)  # a load along +x bends in the x–z plane
    gains = _gains(setup, model, operating)
    slope = np.empty(0)
    if load == "flow":
        assert medium is not None
        slope = _drag_slope(setup, model, medium, point)
        # a step that deflects the tip by ≤ 1e-3 L and stays within 1 % of the speed, or of the
        # slender-body law's end (Re = 0.02 at the base: the drag law bends there)
        creeping = 0.02 * medium.viscosity / (medium.density * 2.0 * setup.cilium.base_radius)
        speed_step = min(step_force / max(float(model.grid.weight @ slope), 1e-300),
                         0.01 * max(point, creeping))
        sensitivity = _flow_sensitivity(setup, medium, point, speed_step)
    else:
        outputs = [setup.output(bend(setup, force=point + d * step_force))[0]
                   for d in (1.0, -1.0)]
        sensitivity = float(outputs[0] - outputs[1]) / (2 * step_force)
    parts = (model, medium, kappa * stiff, gains, slope, load)
    probe = _Model(*parts, 1.0, 2 * math.pi * band, sensitivity, math.nan)
    q0 = probe.loads(np.zeros(1))[0][:, 0].real
    modal_static = float(np.sum(gains * q0 / probe.stiffness))
    scale = sensitivity / modal_static if modal_static != 0.0 else 0.0
    return _Model(*parts, scale, 2 * math.pi * band, sensitivity, modal_static)


def _gains(setup: Setup, model: ModalModel, shape: Centreline) -> F64:
    """Output per unit tip displacement of each mode about ``shape`` (V/m): the tangent angles
    perturbed by ±ε times the mode's slope, through the field model (central difference)."""
    s = np.asarray(shape.s)
    if s.size < 64:  # the rest shape: a grid as fine as the bend's
        s = np.linspace(0.0, setup.cilium.height, 193)
    base = np.interp(s, shape.s, shape.angles[0])
    eps = 1e-4 * setup.cilium.height
    slopes = model.slopes(s)
    angles = np.concatenate([base + eps * slopes, base - eps * slopes])
    out = setup.output(Centreline.from_angles(s, angles))
    n = slopes.shape[0]
    return np.asarray((out[:n] - out[n:]) / (2 * eps), dtype=np.float64)


def _drag_slope(setup: Setup, model: ModalModel, fluid: Fluid, speed: float) -> F64:
    """∂f/∂U of the quasi-steady drag per length at the quadrature points about ``speed``
    (N·s/m²): the straight hair on the wall, the project's drag law (slender body below
    Re 0.02, Lamb / White above)."""
    grid = model.grid
    length = setup.cilium.height
    diameter = 2.0 * grid.radius
    lam = slender_log(grid.s, grid.s, grid.radius, length)
    h = max(1e-6, 1e-4 * speed)
    lo, hi = max(speed - h, 0.0), speed + h
    f_hi = drag_per_length(np.full(grid.s.size, hi), diameter, fluid, lam)
    f_lo = drag_per_length(np.full(grid.s.size, lo), diameter, fluid, lam)
    return np.asarray((f_hi - f_lo) / (hi - lo), dtype=np.float64)


def _flow_sensitivity(setup: Setup, fluid: Fluid, speed: float, step: float) -> float:
    """dV/dU of the static map at ``speed`` (V/(m/s)): central, or one-sided second order
    near 0 (a flow is not reversed)."""
    def out(u: float) -> float:
        return float(setup.output(bend(setup, flow=Flow.uniform(u, fluid)))[0])

    if speed >= 2 * step:
        return (out(speed + step) - out(speed - step)) / (2 * step)
    return (-3 * out(speed) + 4 * out(speed + step) - out(speed + 2 * step)) / (2 * step)


def _bandwidth(model: _Model) -> float:
    """The lowest frequency where |H| falls to |H(0)|/√2, Hz."""
    h0 = abs(model.transfer(np.zeros(1))[0])
    f1 = float(model.model.modes.frequencies[0])
    grid = np.geomspace(1e-4 * f1, 1e3 * float(model.model.modes.frequencies[-1]), 100)
    ratio = np.abs(model.transfer(2 * math.pi * grid)) / h0 - 1.0 / math.sqrt(2.0)
    below = np.flatnonzero(ratio < 0.0)
    if below.size == 0:
        return math.inf
    k = int(below[0])
    if k == 0:
        return float(grid[0])

    def f(x: float) -> float:
        return float(abs(model.transfer(np.array([2 * math.pi * x]))[0]) / h0
                     - 1.0 / math.sqrt(2.0))

    from scipy.optimize import brentq
    return float(brentq(f, grid[k - 1], grid[k], rtol=1e-10))


def _settling(model: _Model) -> float:
    """Time after a load step until the output stays within 2 % of its final value, s."""
    modes = model.model.modes
    m, c = modes.modal_masses, modes.modal_dampings
    rates = []  # decay rate of each mode's slowest pole
    for n in range(m.size):
        disc = np.sqrt(complex(c[n] ** 2 - 4.0 * m[n] * model.stiffness[n]))
        rates.append(min(abs(((-c[n] + disc) / (2 * m[n])).real),
                         abs(((-c[n] - disc) / (2 * m[n])).real)))
    slowest = min(rates)
    if slowest <= 1e-9 * float(modes.angular_frequencies[0]):  # undamped: rings for ever
        return math.inf
    period = 2 * math.pi / float(modes.angular_frequencies[0])
    end = max(math.log(1e4) / slowest, 20 * period)
    final = model.sensitivity
    band = SETTLING_BAND * abs(final)
    # coarse: 24 samples a period of the first mode; then the last exit, finely
    t = np.linspace(0.0, end, int(min(max(24 * end / period, 2000), 200_000)))
    outside = np.flatnonzero(np.abs(model.step(t) - final) > band)
    if outside.size == 0:
        return 0.0
    k = int(outside[-1])
    if k + 1 >= t.size:
        return float(t[-1])
    fine = np.linspace(t[max(k - 24, 0)], t[min(k + 24, t.size - 1)], 4001)
    err = np.abs(model.step(fine) - final)
    j = int(np.flatnonzero(err > band)[-1]) if np.any(err > band) else 0
    if j + 1 >= fine.size:
        return float(fine[-1])
    e0, e1 = err[j], err[j + 1]  # linear crossing of the band
    return float(fine[j] + (fine[j + 1] - fine[j]) * (e0 - band) / max(e0 - e1, 1e-300))
