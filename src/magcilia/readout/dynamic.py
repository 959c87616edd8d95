"""The dynamic read-out: the load estimated from the hair's dynamic state, so that a step reads
correctly within about a period instead of ringing (air) or lagging (water).

:class:`DynamicReadout` wraps a single-output :class:`~magcilia.Readout` (angle, force or flow)
and follows the read-out protocol (``inputs``, ``rest``, ``read(samples, noise=)``, ``tare``). Each
reading is first read statically (the :class:`Readout`: the large-deflection inverse, its flags,
its calibration, tare and force-scale σ); its *effective load* (the tip force of the same static
tip deflection, :class:`~magcilia.mechanics.transient.StaticMap`) is then the measurement of a
Kalman filter on the hair's reduced modal model (:mod:`magcilia.mechanics.transient`: the modes
below the samples' Nyquist frequency, the higher modes' share following the load at once) with
the load as a random-walk state:

* state ``s_k = (x_1, ẋ_1, …, x_m, ẋ_m, u_{k−1})``: the modal coordinates (N) and the load over
  the last interval (N); ``s_{k+1} = F s_k + G w_k`` with the modes' exact discretisation (the
  load held over each interval) and the load's increment ``w_k`` of variance
  ``Q = (2π B / rate)² R``: a random walk that the filter follows with a −3 dB bandwidth of about
  ``B`` Hz (``bandwidth``; default :data:`BANDWIDTH_FACTOR` (2) times the first mode's natural
  frequency: a step then settles within about one period, and the noise σ stays below the
  static read-out's, ``benchmarks/bench_dynamics.py``);
* measurement ``z_k = H s_k + v_k`` of variance R: the static read-out's effective load at the
  sample (``averaged=False``: a sample at t_k) or its mean over the interval before it
  (``averaged=True``: the windows of ``magcilia live``, means of many source samples), exact for
  the linear model (the window's mean of the modal response, from one matrix exponential).

Because Q is a fixed multiple of R, the steady-state gain does not depend on the noise level and
the steady-state covariance is R times a fixed number: the filter runs at its steady state from
the first sample (at rest under the first reading), as one linear filter (its eigen-decomposition
as first-order sections through :func:`scipy.signal.lfilter`, the state carried from one
``read`` to the next), and each estimate's noise σ is ``noise_gain`` (√(P_uu / R)) times the
static read-out's noise σ of its reading, carried through the static map's slopes. The result's
σ adds, as the static read-out's, the calibration, tare and force-scale parts at the estimate:
``sigma = hypot(sigma_noise (filtered), sigma_calibration, sigma_edge, sigma_scale)``. A
constant load reads exactly as statically (the filter's static gain is 1).

``noise_gain`` is the price: it grows with ``bandwidth`` (faster settling, more noise); the
report states it. The filter knows only the linear modes of the straight hair: at large
deflections its frequencies drift (:attr:`TransientResponse.stiffening
<magcilia.mechanics.transient.TransientResponse.stiffening>`), and readings at rates at or below
twice the first mode's frequency cannot see it ring (refused: read statically, or sample
faster).
"""

from __future__ import annotations

import copy
import math
from dataclasses import dataclass
from functools import cached_property
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from magcilia import _validate as v
from magcilia._display import Display, Item, number, si
from magcilia.calibration import ParameterCovariance
from magcilia.calibration.posterior import Posterior
from magcilia.device.parameters import MEASURANDS
from magcilia.device.setup import Setup
from magcilia.mechanics.drag import Fluid
from magcilia.mechanics.transient import (
    MODE_COUNT,
    ModalDynamics,
    ModesLike,
    StaticMap,
    discretise,
    hair_modes,
    map_range,
)
from magcilia.readout.inverse import InverseTable, Readout
from magcilia.readout.protocol import FLAG_DTYPE, Flag
from magcilia.readout.result import NO_ESTIMATE, ReadoutResult
from magcilia.readout.tare import Tare

F64 = NDArray[np.float64]
C128 = NDArray[np.complex128]

__all__ = ["BANDWIDTH_FACTOR", "DynamicReadout", "KalmanFilter", "kalman_filter"]

#: the default load bandwidth, in first-mode frequencies (the module's docstring)
BANDWIDTH_FACTOR = 2.0


@dataclass(frozen=True)
class KalmanFilter:
    """The steady-state Kalman filter of the effective load, as first-order sections
    (immutable; SI).

    Attributes
    ----------
    poles : ndarray of complex, shape (d,)
        Eigenvalues of the filter's state update ``(I − K H) F``.
    inputs : ndarray of complex, shape (d,)
        Each section's input gain (the Kalman gain in the eigenbasis).
    outputs : ndarray of complex, shape (d,)
        Each section's share of the load estimate.
    basis : ndarray of complex, shape (d, d)
        From the filter's state to the sections' (the inverse eigenvectors).
    rest : ndarray, shape (d,)
        The state at rest under a unit load.
    gain : ndarray, shape (d,)
        The steady-state Kalman gain K.
    noise_gain : float
        √(P_uu / R): the load estimate's σ per unit σ of a reading's effective load.
    """

    poles: C128
    inputs: C128
    outputs: C128
    basis: C128
    rest: F64
    gain: F64
    noise_gain: float

    def start(self, load: float) -> C128:
        """The sections' states at rest under ``load`` (N), shape (d,) (lfilter's ``zi``)."""
        return np.asarray(self.poles * (self.basis @ (self.rest * load)), dtype=np.complex128)

    def run(self, z: F64, state: C128) -> tuple[F64, C128]:
        """Load estimates (N, (n,)) of measurements ``z`` (N, (n,)) from ``state``; the new
        state."""
        from scipy.signal import lfilter
        out = np.zeros(z.size)
        new = np.empty_like(state)
        for i in range(self.poles.size):
            y, zf = lfilter([self.inputs[i]], [1.0, -self.poles[i]], z.astype(np.complex128),
                            zi=state[i:i + 1])
            new[i] = zf[0]
            out += (self.outputs[i] * y).real
        return out, new


def kalman_filter(dynamics: ModalDynamics, rate: float, bandwidth: float,
                  averaged: bool) -> KalmanFilter:
    """The steady-state Kalman filter of :mod:`magcilia.readout.dynamic` for the modes of
    ``dynamics`` at ``rate`` (Hz), a load bandwidth ``bandwidth`` (Hz) and measurements that are
    samples (``averaged`` False) or means over each interval (True)."""
    a, b, c, d = dynamics.state_space()
    import scipy.linalg
    from scipy.linalg import expm
    n = a.shape[0]
    dt = 1.0 / rate
    if n:
        phi, gamma, _ = discretise(a, b, dt, "zoh")
    else:
        phi, gamma = np.zeros((0, 0)), np.zeros(0)
    f = np.eye(n + 1)
    f[:n, :n], f[:n, n] = phi, gamma
    g = np.append(gamma, 1.0)  # the load's increment enters the next interval's load
    h = np.append(c, d)
    if averaged and n:  # the mean over the interval before t_k, from x_{k-1} = Φ⁻¹(x_k − Γ u)
        aug = np.zeros((n + 1, n + 1))
        aug[:n, :n], aug[:n, n] = a, b
        big = np.zeros((2 * (n + 1), 2 * (n + 1)))
        big[:n + 1, :n + 1] = aug * dt
        big[:n + 1, n + 1:] = np.eye(n + 1)
        mean = expm(big)[:n + 1, n + 1:]  # (1/T)∫₀ᵀ e^{Āτ} dτ
        m1, m2 = mean[:n, :n], mean[:n, n]
        back = np.linalg.solve(phi, np.eye(n))
        h = np.append(c @ m1 @ back, c @ m2 + d - c @ m1 @ back @ gamma)
    q = (2.0 * math.pi * bandwidth / rate) ** 2 * np.outer(g, g)
    prior = scipy.linalg.solve_discrete_are(f.T, h[:, None], q, np.ones((1, 1)))
    s = float(h @ prior @ h) + 1.0
    k = prior @ h / s
    post = prior - np.outer(k, h @ prior)
    update = (np.eye(n + 1) - np.outer(k, h)) @ f
    poles, vectors = np.linalg.eig(update)
    basis = np.linalg.inv(vectors)
    rest = np.append(np.column_stack([dynamics.shares, np.zeros(n // 2)]).reshape(-1), 1.0) \
        if n else np.ones(1)
    return KalmanFilter(poles=poles.astype(np.complex128),
                        inputs=np.asarray(basis @ k, dtype=np.complex128),
                        outputs=np.asarray(vectors[n, :], dtype=np.complex128),
                        basis=basis.astype(np.complex128), rest=rest, gain=k,
                        noise_gain=math.sqrt(max(float(post[n, n]), 0.0)))


class _State:
    """The filter's running state (the one mutable part of a :class:`DynamicReadout`)."""

    def __init__(self) -> None:
        self.sections: C128 | None = None
        self.last = 0.0  # the last finite measurement, N (held over readings without one)


@dataclass(frozen=True, eq=False, init=False, repr=False)
class DynamicReadout(Display):
    """A single-output read-out that undoes the hair's dynamics (see the module's docstring).

    :meth:`read` continues from where the last call left off (the filter's state: the one
    mutable part; :meth:`reset` starts over, at rest under the next reading).

    Examples
    --------
    >>> import magcilia as mc
    >>> setup = mc.presets.load("force-sensor")
    >>> static = mc.Readout(setup, quantity="force", span=(-4e-5, 4e-5))
    >>> dynamic = mc.DynamicReadout(static, 10e3, fluid=mc.AIR)
    >>> load = np.r_[np.zeros(10), np.full(990, 4e-6)]             # a 4 µN step at 10 kHz
    >>> volts = mc.simulate_response(setup, load, 10e3, fluid=mc.AIR).output
    >>> ringing = static.read(volts, noise=2e-5).value[80:]          # from one period on
    >>> steady = dynamic.read(volts, noise=2e-5).value[80:]
    >>> float(np.abs(ringing - 4e-6).max()) > 3e-6       # the static read-out rings ±4 µN
    True
    >>> float(np.abs(steady - 4e-6).max()) < 0.5e-6      # the dynamic one is on the step
    True

    Parameters
    ----------
    readout : Readout
        The static read-out (span, calibration, tare, flags and σ parts come from it).
    rate : float
        Readings per second given to :meth:`read`, Hz; above twice the first mode's frequency.
    fluid : Fluid, optional
        The fluid around the hair (:data:`~magcilia.AIR`, :data:`~magcilia.WATER`); None: vacuum,
        or the read-out's flow's fluid for a flow.
    bandwidth : float, optional
        The load's bandwidth B, Hz (the random walk's per-reading variance (2π B / rate)² R);
        default :data:`BANDWIDTH_FACTOR` times the first mode's natural frequency.
    averaged : bool
        Readings are means over their interval (``magcilia live``'s windows) rather than samples.
    count : int
        Modes of the model (those below rate / 2 are kept).
    modes : optional
        A precomputed :func:`magcilia.mechanics.modes` result instead of computing it.

    Attributes
    ----------
    static : Readout
        The static read-out.
    dynamics : ModalDynamics
        The modes kept (below rate / 2) and the higher modes' share.
    filter : KalmanFilter
        The steady-state filter (its ``noise_gain``: the σ it passes per σ of a reading).
    map : StaticMap
        The static map over the read-out's span (its effective load ↔ the quantity).
    """

    static: Readout
    rate: float
    bandwidth: float
    averaged: bool
    fluid: str
    dynamics: ModalDynamics
    filter: KalmanFilter
    map: StaticMap
    _state: _State

    def __init__(self, readout: Readout, rate: float, *, fluid: Fluid | None = None,
                 bandwidth: float | None = None, averaged: bool = False,
                 count: int = MODE_COUNT, modes: ModesLike | None = None) -> None:
        if not isinstance(readout, Readout):
            raise v.fail("readout", type(readout).__name__, "a magcilia.Readout (one output)")
        if readout.actuation is not None:
            raise v.fail("readout", "a read-out while actuating", "one without an actuation "
                         "(the hair's dynamics under a field are not modelled)")
        rate = v.positive("rate", rate, "Hz", "frequency")
        if fluid is None and readout.quantity == "flow":
            fluid = readout.flow.fluid
        if fluid is not None and not isinstance(fluid, Fluid):
            raise v.fail("fluid", type(fluid).__name__, "a magcilia.Fluid (AIR, WATER) or None")
        if modes is None:
            modes = hair_modes(readout.setup, fluid, v.integer("count", count, 1))
        smap = StaticMap.build(readout.setup, readout.quantity,
                               *map_range(np.asarray(readout.span), readout.quantity),
                               readout.flow if readout.quantity == "flow" else None)
        full = ModalDynamics.from_modes(modes, smap.compliance)
        first = float(full.frequencies[0])
        if not rate > 2.0 * first:
            raise v.fail("rate", rate, f"above twice the hair's first mode "
                         f"(2 × {first:.4g} Hz = {2.0 * first:.4g} Hz) for a dynamic read-out: "
                         "read faster, or read statically")
        dynamics = full.below(0.5 * rate)
        band = (BANDWIDTH_FACTOR * first if bandwidth is None else
                v.positive("bandwidth", bandwidth, "Hz", "frequency"))
        for name, value in (("static", readout), ("rate", rate), ("bandwidth", band),
                            ("averaged", bool(averaged)),
                            ("fluid", "vacuum" if fluid is None else fluid.name),
                            ("dynamics", dynamics),
                            ("filter", kalman_filter(dynamics, rate, band, bool(averaged))),
                            ("map", smap), ("_state", _State())):
            object.__setattr__(self, name, value)

    # -- the protocol ---------------------------------------------------------------------------
    @property
    def inputs(self) -> tuple[str, ...]:
        """The static read-out's: ``("output",)`` (V)."""
        return self.static.inputs

    @property
    def rest(self) -> F64:
        """The model's output at rest, V, shape (1,)."""
        return self.static.rest

    @property
    def baseline(self) -> Tare | None:
        """The static read-out's tare, or None."""
        return self.static.baseline

    def tare(self, baseline_volts: ArrayLike) -> DynamicReadout:
        """A copy over the static read-out tared on ``baseline_volts`` (:meth:`Readout.tare`),
        its filter starting over."""
        new = copy.copy(self)
        object.__setattr__(new, "static", self.static.tare(baseline_volts))
        object.__setattr__(new, "_state", _State())
        return new

    def reset(self) -> None:
        """Start the filter over: at rest under the next reading."""
        object.__setattr__(self, "_state", _State())

    # -- what the static read-out says (for the views) ------------------------------------------
    @property
    def quantity(self) -> str:
        """The static read-out's: ``"angle"``, ``"force"`` or ``"flow"``."""
        return self.static.quantity

    @property
    def unit(self) -> str:
        """The static read-out's SI unit."""
        return self.static.unit

    @property
    def span(self) -> tuple[float, float]:
        """The static read-out's span, SI."""
        return self.static.span

    @property
    def setup(self) -> Setup:
        """The static read-out's setup."""
        return self.static.setup

    @property
    def table(self) -> InverseTable:
        """The static read-out's table."""
        return self.static.table

    @property
    def fold(self) -> float | None:
        """The static read-out's fold (SI), or None."""
        return self.static.fold

    @property
    def calibration(self) -> ParameterCovariance | Posterior | None:
        """The static read-out's calibration uncertainty."""
        return self.static.calibration

    @property
    def scale_note(self) -> str:
        """The static read-out's force-scale note."""
        return self.static.scale_note

    # -- use ------------------------------------------------------------------------------------
    def read(self, volts: ArrayLike, /, *, noise: ArrayLike | None = None) -> ReadoutResult:
        """Estimates of the load behind readings ``volts`` (V, (n,), consecutive at
        :attr:`rate`, continuing the last call's), with 1-σ parts and flags
        (:class:`ReadoutResult`: ``sigma_noise`` is the filtered noise; calibration, tare, edge
        and force-scale parts at the estimate, as the static read-out's).

        A reading is measured through the static map over the read-out's span continued as far
        as the output stays monotone (a step's overshoot may leave the span while the load does
        not); a reading beyond it, saturated or NaN adds nothing (the filter predicts over it)
        and keeps its flags (no estimate there). The estimate's own flags are the static
        read-out's at the estimate (beyond the span, a fold).

        Parameters
        ----------
        volts : array-like, shape (n,)
            Sensor outputs, V (a tare's correction is added first).
        noise : float, optional
            Output noise RMS of each reading, V (default: the static read-out's rule: the
            tare's spread, else the sensor model's over its default bandwidth).
        """
        static = self.static.read(volts, noise=noise)  # the readings' own flags
        x = np.asarray(volts, dtype=np.float64).reshape(-1)
        if x.size == 0:
            return static
        correction = 0.0 if self.static.baseline is None else self.static.baseline.correction
        x = x + correction
        noise_v = self.static.reading_noise(noise)
        branch_v, branch_u = self._branch
        raw_flags = np.asarray(static.flags, dtype=FLAG_DTYPE).reshape(-1)
        ok = (np.isfinite(x) & (x >= branch_v[0]) & (x <= branch_v[-1])
              & ((raw_flags & FLAG_DTYPE(Flag.SATURATED)) == 0)) \
            | np.isfinite(np.asarray(static.value, dtype=np.float64).reshape(-1))
        q_static = np.asarray(static.value, dtype=np.float64).reshape(-1)
        read = np.isfinite(q_static)  # the static estimate where there is one (a constant load
        # then reads exactly as statically), the map's continuation beyond the span
        z = np.where(read, smap_load(self.map, np.where(read, q_static, 0.0)),
                     np.interp(np.where(ok, x, branch_v[0]), branch_v, branch_u))
        state = self._state
        if not ok.all():  # the filter's measurement is held over readings without one
            idx = np.where(ok, np.arange(z.size), -1)
            np.maximum.accumulate(idx, out=idx)
            z = np.where(idx >= 0, z[np.maximum(idx, 0)], state.last)
        if state.sections is None:
            state.sections = self.filter.start(float(z[0]))
        u, state.sections = self.filter.run(z, state.sections)
        state.last = float(z[-1])
        smap = self.map
        value = _continued(u, smap.effective, smap.values)
        # noise: the reading's σ in effective load (through dV/du there), filtered, in the
        # quantity at the estimate (through dq/du there)
        du_dv_branch, dq_du_map = self._slopes
        du_dv = np.abs(np.interp(np.where(ok, x, branch_v[0]), branch_v, du_dv_branch))
        dq_du = np.interp(u, smap.effective, dq_du_map)
        s_noise = self.filter.noise_gain * noise_v * du_dv * np.abs(dq_du)
        # calibration, tare, edge and scale parts at the estimate: the static read-out of the
        # model's output there, without noise
        at = self.static.read(_continued(value, smap.values, smap.output) - correction,
                              noise=0.0)
        keep = FLAG_DTYPE(Flag.SATURATED | Flag.MISSING | Flag.TARE_UNDER_LOAD)
        flags = np.asarray(np.asarray(at.flags, dtype=FLAG_DTYPE) | (raw_flags & keep)
                           | np.where(ok, FLAG_DTYPE(0), FLAG_DTYPE(Flag.OUTSIDE_SPAN)),
                           dtype=FLAG_DTYPE)
        nan = np.where((flags & FLAG_DTYPE(NO_ESTIMATE)) != 0, np.nan, 1.0)
        parts = (s_noise, np.asarray(at.sigma_calibration), np.asarray(at.sigma_edge),
                 np.asarray(at.sigma_scale))
        sigma = np.sqrt(np.nansum(np.square(np.stack(parts)), axis=0))
        shape = np.shape(volts)
        return ReadoutResult(
            quantity=static.quantity, unit=static.unit, value=(value * nan).reshape(shape),
            sigma=(sigma * nan).reshape(shape), sigma_noise=(s_noise * nan).reshape(shape),
            sigma_calibration=(parts[1] * nan).reshape(shape),
            sigma_edge=(parts[2] * nan).reshape(shape),
            sigma_scale=(parts[3] * nan).reshape(shape), flags=flags.reshape(shape),
            table_error=static.table_error, scale_note=static.scale_note)

    @cached_property
    def _slopes(self) -> tuple[F64, F64]:
        """du/dV on the measurable branch and dq/du on the static map, at their points."""
        volts, load = self._branch
        return np.gradient(load, volts), np.gradient(self.map.values, self.map.effective)

    @cached_property
    def _branch(self) -> tuple[F64, F64]:
        """The static map's output (V, increasing) and effective load (N) over the span
        continued while the output stays monotone: the readings the filter can measure."""
        smap = self.map
        out = smap.output
        lo, hi = self.static.span
        inside = np.flatnonzero((smap.values >= lo) & (smap.values <= hi))
        i, j = int(inside[0]), int(inside[-1])
        sign = np.sign(out[j] - out[i])
        step = np.sign(np.diff(out)) == sign
        while i > 0 and step[i - 1]:
            i -= 1
        while j < out.size - 1 and step[j]:
            j += 1
        volts, load = out[i:j + 1], smap.effective[i:j + 1]
        if sign < 0:
            volts, load = volts[::-1], load[::-1]
        return np.ascontiguousarray(volts), np.ascontiguousarray(load)

    # -- description ----------------------------------------------------------------------------
    def mode(self) -> str:
        """A few words for the views: the filter, its bandwidth and noise gain."""
        return (f"dynamic read-out (Kalman, {number(self.bandwidth)} Hz, noise × "
                f"{self.filter.noise_gain:.2g})")

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready description (SI): the static read-out's, the modes and the filter."""
        return {**self.static.to_dict(), "dynamic": {
            "rate_Hz": self.rate, "bandwidth_Hz": self.bandwidth, "averaged": self.averaged,
            "fluid": self.fluid, "frequencies_Hz": self.dynamics.frequencies.tolist(),
            "damping_ratios": self.dynamics.damping_ratios.tolist(),
            "residual": self.dynamics.residual, "noise_gain": self.filter.noise_gain}}

    def report(self) -> str:
        """The static read-out's line and one on the filter: modes, bandwidth, noise gain."""
        modes = ", ".join(f"{f:.4g} Hz (ζ {z:.3g})" for f, z in zip(
            self.dynamics.frequencies, self.dynamics.damping_ratios, strict=True))
        what = "means over each interval" if self.averaged else "samples"
        return (f"{self.static.report()}\n{self.mode()}: readings at {self.rate:g} Hz "
                f"({what}) in {self.fluid}, modes {modes or 'none below rate / 2'}; the load "
                f"followed as a random walk of {self.bandwidth:.4g} Hz bandwidth; noise σ × "
                f"{self.filter.noise_gain:.3g} of the static read-out's")

    def _display_items(self) -> list[Item]:
        q = MEASURANDS[self.static.quantity]
        return [("", f"dynamic {self.static.quantity}"),
                ("span", f"{q.text(self.span[0])}…{q.text(self.span[1])}"),
                ("rate", si(self.rate, "Hz")), ("bandwidth", si(self.bandwidth, "Hz")),
                ("noise gain", number(self.filter.noise_gain)), ("fluid", self.fluid)]


def smap_load(smap: StaticMap, values: F64) -> F64:
    """The effective load (N) of measurand ``values`` (SI) on ``smap``, continued linearly
    beyond its ends."""
    return _continued(values, smap.values, smap.effective)


def _continued(x: F64, xp: F64, fp: F64) -> F64:
    """``np.interp`` continued linearly beyond both ends (``xp`` increasing)."""
    y = np.interp(x, xp, fp)
    low = (fp[1] - fp[0]) / (xp[1] - xp[0])
    high = (fp[-1] - fp[-2]) / (xp[-1] - xp[-2])
    y = np.where(x < xp[0], fp[0] + (x - xp[0]) * low, y)
    return np.asarray(np.where(x > xp[-1], fp[-1] + (x - xp[-1]) * high, y), dtype=np.float64)
