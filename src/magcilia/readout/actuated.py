"""Sensing while actuating: read a force, flow or angle while a known field acts on the cilium.

An actuation field B_ext (:class:`~magcilia.Actuation`: a Helmholtz pair's uniform field, a coil
or a magnet through magpylib) does two things to a reading: it bends the cilium by the couple
μ t × B and the force μ (t·∇)B on its magnetization (:func:`magcilia.bend` with ``actuation=``),
and it adds its own field at the sensing element, the *direct* field. Both are known when the
actuation is: compensation models them and reads the external load alone.

* A constant actuation: ``Readout(setup, "force", span, actuation=act)`` builds the read-out
  table with the actuation's bending and direct field included (:func:`~magcilia.readout.inverse.
  model_output`), so readings taken under it invert to the external load.
* A varying one (a coil current per reading): :class:`ActuatedReadout` holds one such table per
  *level* (the actuation's scale, e.g. the coil current in A for an actuation given per ampere)
  and reads each reading at its own level: the reading is moved to each neighbouring level's
  direct field (exact: the direct field is linear in the level), read there, and the two
  estimates are interpolated linearly in the level. The interpolation error is measured at
  construction, at the mid-levels (:attr:`ActuatedReadout.level_error`).
* In practice (NOTES: "actuation compensation"), the direct coupling is measured rather than
  modelled: with the cilium clamped (or absent), readings against the coil current give the
  slope M (V per unit level, :func:`measure_coupling`); ``ActuatedReadout(..., coupling=M)``
  then subtracts M·I instead of the modelled direct field, while the model still supplies the
  actuation's bending (the field's torque on the cilium is signal, not interference).

All SI: N, m/s, rad, T, V; levels in the actuation's own scale.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from magcilia import _validate as v
from magcilia._display import Display, Item, number
from magcilia.calibration import CalibrationResult, ParameterCovariance
from magcilia.device.actuation import Actuation
from magcilia.device.parameters import MEASURANDS
from magcilia.device.sensor import DEFAULT_BANDWIDTH
from magcilia.device.setup import Setup
from magcilia.mechanics import Flow
from magcilia.readout.forward import direct_field, model_output
from magcilia.readout.inverse import Readout
from magcilia.readout.protocol import FLAG_DTYPE, OUTPUT, Flag, tare_flags
from magcilia.readout.result import NO_ESTIMATE, ReadoutResult
from magcilia.readout.tare import Tare

F64 = NDArray[np.float64]

#: quantities at which the level interpolation is checked at each mid-level
CHECK_POINTS = 9
#: the source channel of the actuation's level (in its own scale), beside the output
LEVEL = "level"


@dataclass(frozen=True, repr=False)
class Coupling(Display):
    """The direct coupling of an actuation into the reading, measured with the cilium clamped:
    ``V = intercept + slope · level`` (SI: V per unit level, V).

    Attributes
    ----------
    slope, intercept : float
        Least-squares line of the readings against the level, V per unit level and V.
    sigma_slope, sigma_intercept : float
        Their standard errors (from the residual scatter), same units.
    residual : float
        RMS residual of the fit, V.
    count : int
        Readings used.
    """

    slope: float
    intercept: float
    sigma_slope: float
    sigma_intercept: float
    residual: float
    count: int

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready content (SI)."""
        return {"slope_V_per_level": self.slope, "intercept_V": self.intercept,
                "sigma_slope_V_per_level": self.sigma_slope,
                "sigma_intercept_V": self.sigma_intercept, "residual_V": self.residual,
                "count": self.count, "units": "SI"}

    def report(self) -> str:
        """One line in mV."""
        return (f"coupling {self.slope * 1e3:.6g} ± {self.sigma_slope * 1e3:.2g} mV per unit "
                f"level (intercept {self.intercept * 1e3:.6g} mV, RMS residual "
                f"{self.residual * 1e6:.3g} µV, {self.count} readings)")

    def _display_items(self) -> list[Item]:
        return [("slope", f"{number(self.slope * 1e3)} mV/level"),
                ("± s.e.", f"{number(self.sigma_slope * 1e3)} mV/level"),
                ("readings", str(self.count))]


def measure_coupling(levels: ArrayLike, volts: ArrayLike) -> Coupling:
    """The direct coupling M from readings ``volts`` (V, shape (n,)) taken at actuation
    ``levels`` (shape (n,), e.g. coil currents in A) with the cilium clamped or absent, so that
    only the actuation's own field changes the reading: the least-squares line
    ``V = intercept + M · level`` with standard errors (at least 3 readings at 2+ levels; NaN
    readings are skipped)."""
    k = v.finite_array("levels", levels, ndim=1)
    y = np.asarray(volts, dtype=np.float64).reshape(-1)
    if y.shape != k.shape:
        raise v.fail("volts", f"{y.size} readings", f"{k.size}, one per level")
    good = np.isfinite(y)
    k, y = k[good], y[good]
    if k.size < 3 or np.ptp(k) == 0.0:
        raise v.fail("levels", f"{k.size} finite readings at {np.unique(k).size} level(s)",
                     "at least 3 readings at 2 or more different levels")
    a = np.stack([np.ones(k.size), k], axis=1)
    coef, *_ = np.linalg.lstsq(a, y, rcond=None)
    res = y - a @ coef
    dof = max(k.size - 2, 1)
    s2 = float(res @ res) / dof
    cov = s2 * np.linalg.inv(a.T @ a)
    return Coupling(slope=float(coef[1]), intercept=float(coef[0]),
                    sigma_slope=math.sqrt(max(cov[1, 1], 0.0)),
                    sigma_intercept=math.sqrt(max(cov[0, 0], 0.0)),
                    residual=math.sqrt(s2), count=int(k.size))


@dataclass(frozen=True, eq=False, init=False, repr=False)
class ActuatedReadout(Display):
    """Read-out while an actuation of varying strength acts (immutable).

    Parameters
    ----------
    setup : Setup
        The (calibrated) sensor setup (its layout resolved at the element, as
        :class:`~magcilia.Readout`'s).
    quantity : {"angle", "force", "flow"}
        What to read (as :class:`~magcilia.Readout`).
    span : (float, float)
        Range of the quantity, SI, low < high.
    actuation : Actuation
        The actuation at level 1 (e.g. the field of 1 A in the coil); level k is
        ``actuation.scaled(k)``.
    levels : array-like, shape (n,)
        The levels tabulated (n ≥ 2, increasing, distinct), covering the levels of the readings;
        finer where the actuation bends the cilium strongly (the interpolation between them is
        linear; :attr:`level_error` says how well it does).
    coupling : float or Coupling, optional
        The measured direct coupling M (V per unit level, :func:`measure_coupling`): subtracted
        as ``M · level`` instead of the modelled direct field. Default: the model's,
        ``sensor.scale · B_direct,x`` of the actuation at level 1.
    calibration, flow, table_size, edge, edge_tolerance
        As for :class:`~magcilia.Readout`, for every level's table.

    Attributes
    ----------
    readouts : tuple of Readout
        One compensated read-out per level (``Readout(..., actuation=actuation.scaled(k))``).
    model_coupling : float
        The modelled direct coupling, V per unit level.
    coupling : float
        The coupling used, V per unit level (the measured one if given, else the model's).
    level_error : float
        Largest error (SI) of the level interpolation at the mid-levels, over
        :data:`CHECK_POINTS` values of the quantity across the span, noise-free.
    baseline : Tare or None
        The zero of :meth:`tare` (raw volts).

    Examples
    --------
    >>> import numpy as np, magcilia as mc
    >>> s = mc.Setup.paper(tip_radius=5e-5)
    >>> coil = mc.Actuation.uniform((1e-4, 0.0, 0.0))       # 1 G along x per ampere
    >>> r = ActuatedReadout(s, "force", (0.0, 1e-4), coil, levels=[-1.0, 0.0, 1.0],
    ...                     table_size=33)
    >>> volts = model_output(s, "force", [5e-5], actuation=coil.scaled(0.5))
    >>> round(float(r.estimate(volts, level=0.5)[0]) * 1e3, 4)   # mN
    0.05
    """

    setup: Setup
    quantity: str
    unit: str
    span: tuple[float, float]
    actuation: Actuation
    levels: F64
    readouts: tuple[Readout, ...]
    model_coupling: float
    coupling: float
    measured: Coupling | None
    level_error: float
    baseline: Tare | None

    def __init__(self, setup: Setup, quantity: str, span: tuple[float, float],
                 actuation: Actuation, levels: ArrayLike, *,
                 coupling: float | Coupling | None = None,
                 calibration: CalibrationResult | ParameterCovariance | None = None,
                 flow: Flow | None = None, table_size: int = 257, edge: str = "extrapolate",
                 edge_tolerance: float | None = None) -> None:
        if not isinstance(actuation, Actuation):
            raise v.fail("actuation", type(actuation).__name__,
                         "a magcilia Actuation (Actuation.uniform(b), Actuation.magpylib(source))")
        if isinstance(setup, Setup):
            setup = setup.resolve_layout()  # the layout rule at the sensing element
        k = v.finite_array("levels", levels, ndim=1)
        if k.size < 2 or np.any(np.diff(k) <= 0.0):
            raise v.fail("levels", v.short(k.tolist()), "at least 2 increasing, distinct levels")
        measured = coupling if isinstance(coupling, Coupling) else None
        readouts = tuple(Readout(setup, quantity, span, calibration=calibration, flow=flow,
                                 table_size=table_size, edge=edge, edge_tolerance=edge_tolerance,
                                 actuation=actuation.scaled(float(level)))
                         for level in k)
        model_c = float(setup.sensor.scale * direct_field(actuation)[0])
        used = model_c if coupling is None else (
            measured.slope if measured is not None else v.real("coupling", coupling, "V"))
        first = readouts[0]
        for name, value in (("setup", setup), ("quantity", first.quantity),
                            ("unit", first.unit), ("span", first.span),
                            ("actuation", actuation), ("levels", k), ("readouts", readouts),
                            ("model_coupling", model_c), ("coupling", used),
                            ("measured", measured), ("level_error", 0.0), ("baseline", None)):
            object.__setattr__(self, name, value)
        k.setflags(write=False)
        object.__setattr__(self, "level_error", self._level_error(flow))

    def _level_error(self, flow: Flow | None) -> float:
        """The interpolation's largest error at the mid-levels (noise-free, model readings)."""
        lo, hi = self.span
        q = np.linspace(lo, hi, CHECK_POINTS)
        worst = 0.0
        for a, b in zip(self.levels[:-1], self.levels[1:], strict=True):
            mid = 0.5 * (float(a) + float(b))
            volts = model_output(self.setup, self.quantity, q, flow, self.actuation.scaled(mid))
            volts = volts + (self.coupling - self.model_coupling) * mid  # as measured
            est = self._read(volts, np.full(q.size, mid), None)
            good = np.isfinite(est.value)
            if good.any():
                worst = max(worst, float(np.max(np.abs(est.value[good] - q[good]))))
        return worst

    # -- use ------------------------------------------------------------------------------------
    def _levels(self, volts: ArrayLike, level: ArrayLike) -> tuple[F64, F64, tuple[int, ...]]:
        x = np.asarray(volts, dtype=np.float64)
        try:
            k = np.asarray(level, dtype=np.float64)
        except (TypeError, ValueError):
            raise v.fail("level", v.short(level), "numbers (the actuation's scale)") from None
        try:
            x, k = np.broadcast_arrays(x, k)
        except ValueError:
            raise v.fail("level", f"an array of shape {np.shape(k)}", f"one level per reading "
                         f"(shape {np.shape(x)}) or one for all") from None
        return x.reshape(-1), k.reshape(-1), x.shape

    def _read(self, x: F64, k: F64, noise: float | None,
              bandwidth: tuple[float, float] = DEFAULT_BANDWIDTH) -> ReadoutResult:
        """Read raw readings ``x`` (V, (b,)) at levels ``k`` ((b,)), tare applied here."""
        n = self.levels.size
        tare_se = 0.0
        if self.baseline is not None:
            x = x + self.baseline.correction
            tare_se = self.baseline.standard_error
            if noise is None:
                noise = self.baseline.noise
        inside = (k >= self.levels[0]) & (k <= self.levels[-1])
        lo = np.clip(np.searchsorted(self.levels, k, side="right") - 1, 0, n - 2)
        w = (k - self.levels[lo]) / (self.levels[lo + 1] - self.levels[lo])
        out = {name: np.full(x.size, np.nan) for name in
               ("value", "sigma_noise", "sigma_calibration", "sigma_edge", "sigma_scale")}
        flags = np.full(x.size, FLAG_DTYPE(Flag.OUTSIDE_SPAN))
        for i in np.unique(lo[inside]).tolist():
            idx = np.flatnonzero(inside & (lo == i))
            parts = []
            for j in (i, i + 1):
                # move the readings to level j's direct field (linear in the level: exact)
                shifted = x[idx] - self.coupling * k[idx] + self.model_coupling * self.levels[j]
                parts.append(self.readouts[j].read(shifted, bandwidth, noise))
            a, b = parts
            wi = w[idx]
            for name, arr in out.items():
                arr[idx] = (1.0 - wi) * getattr(a, name) + wi * getattr(b, name)
            flags[idx] = a.flags | b.flags
        if tare_se:
            with np.errstate(invalid="ignore", divide="ignore"):
                noise_v = noise if noise else 1.0
                slope = out["sigma_noise"] / noise_v
            out["sigma_calibration"] = np.hypot(out["sigma_calibration"], slope * tare_se)
        sigma = np.sqrt(out["sigma_noise"] ** 2 + out["sigma_calibration"] ** 2
                        + out["sigma_edge"] ** 2 + out["sigma_scale"] ** 2)
        flags |= FLAG_DTYPE(tare_flags(self.baseline))  # a tare taken under load
        none = (flags & FLAG_DTYPE(NO_ESTIMATE)) != 0
        for arr in (*out.values(), sigma):
            arr[none] = np.nan
        return ReadoutResult(
            quantity=self.quantity, unit=self.unit, value=out["value"], sigma=sigma,
            sigma_noise=out["sigma_noise"], sigma_calibration=out["sigma_calibration"],
            sigma_edge=out["sigma_edge"], sigma_scale=out["sigma_scale"], flags=flags,
            table_error=max(r.table_error for r in self.readouts) + self.level_error,
            scale_note=self.readouts[0].scale_note)

    def read(self, volts: ArrayLike, level: ArrayLike | None = None,
             bandwidth: tuple[float, float] = DEFAULT_BANDWIDTH,
             noise: ArrayLike | None = None) -> ReadoutResult:
        """Estimates with 1-σ and flags of readings ``volts`` (V, any shape) taken at actuation
        ``level`` (the same shape, or one level for all): each level's neighbours' tables,
        interpolated linearly in the level (never raises for a reading's value; a level outside
        :attr:`levels` is flagged OUTSIDE_SPAN). ``bandwidth`` and ``noise`` as for
        :meth:`Readout.read`; ``table_error`` of the result includes :attr:`level_error`.
        Without ``level``, ``volts`` are the protocol's samples, shape (n, 2): the output (V)
        and the level of each (:attr:`inputs`)."""
        volts, level = self._split(volts, level)
        x, k, shape = self._levels(volts, level)
        if noise is not None:
            if np.size(noise) != 1:
                raise v.fail("noise", v.short(noise), "one noise RMS in V (the output's)")
            noise = v.non_negative("noise", np.ravel(noise)[0], "V", "noise")
        res = self._read(x, k, noise, bandwidth)
        return ReadoutResult(
            quantity=res.quantity, unit=res.unit, value=res.value.reshape(shape),
            sigma=res.sigma.reshape(shape), sigma_noise=res.sigma_noise.reshape(shape),
            sigma_calibration=res.sigma_calibration.reshape(shape),
            sigma_edge=res.sigma_edge.reshape(shape), sigma_scale=res.sigma_scale.reshape(shape),
            flags=res.flags.reshape(shape), table_error=res.table_error,
            scale_note=res.scale_note)

    def estimate(self, volts: ArrayLike, level: ArrayLike) -> F64:
        """The quantity (SI) for each reading at its level, same shape as ``volts``; raises a
        one-line error for a reading without an estimate (use :meth:`read` to flag instead)."""
        x, k, shape = self._levels(volts, level)
        outside = np.flatnonzero((k < self.levels[0]) | (k > self.levels[-1]))
        if outside.size:
            raise v.fail("level", f"{k[outside[0]]:.6g}", f"within the tabulated levels "
                         f"{self.levels[0]:.6g}…{self.levels[-1]:.6g}")
        res = self._read(x, k, None)
        bad = np.flatnonzero(~np.isfinite(res.value))
        if bad.size:
            i = int(bad[0])
            raise v.fail(f"volts[{i}]", f"{x[i]:.6g} V at level {k[i]:.6g}",
                         f"a reading within the span's output range at its level "
                         f"({Flag(int(res.flags[i])).name}; use read() for flags)")
        return res.value.reshape(shape)

    def tare(self, baseline_volts: ArrayLike, level: float | None = None) -> ActuatedReadout:
        """A copy whose zero is the mean of unloaded readings ``baseline_volts`` (V) taken at
        actuation ``level`` (default 0): every reading then gets ``V_rest(level) − mean`` added
        (an offset that does not depend on the level: bridge offset, the earth's field), the
        baseline's spread is the noise of one reading and its standard error adds to
        ``sigma_calibration``, as :meth:`Readout.tare`. Without ``level``, a baseline of shape
        (n, 2) is the protocol's samples (output, level), all at one level."""
        if level is None and np.ndim(baseline_volts) == 2 and np.shape(baseline_volts)[1] == 2:
            pairs = np.asarray(baseline_volts, dtype=np.float64)
            if np.ptp(pairs[:, 1]) > 0.0:
                raise v.fail("level", f"{pairs[:, 1].min():.6g}…{pairs[:, 1].max():.6g}",
                             "one level for the whole tare (tare at a constant actuation)")
            baseline_volts, level = pairs[:, 0], float(pairs[0, 1])
        k0 = v.real("level", 0.0 if level is None else level)
        rest = float(model_output(self.setup, self.quantity, np.zeros(1),
                                  self.readouts[0].flow, self.actuation.scaled(k0))[0])
        rest += (self.coupling - self.model_coupling) * k0
        new = object.__new__(ActuatedReadout)
        for f in self.__dataclass_fields__:
            object.__setattr__(new, f, getattr(self, f))
        object.__setattr__(new, "baseline", Tare.from_readings(baseline_volts, rest))
        return new

    # -- the read-out protocol (:mod:`magcilia.readout.protocol`) ------------------------------
    @property
    def inputs(self) -> tuple[str, ...]:
        """What one sample holds: the sensor output (V) and the actuation's level."""
        return (OUTPUT, LEVEL)

    @property
    def rest(self) -> F64:
        """The model's output at rest at level 0 (V), and level 0: shape (2,)."""
        return np.array([float(model_output(self.setup, self.quantity, np.zeros(1),
                                            self.readouts[0].flow, self.actuation.scaled(0.0))[0]
                               ), 0.0])

    def _split(self, volts: ArrayLike, level: ArrayLike | None) -> tuple[ArrayLike, ArrayLike]:
        """(volts, level) of a call with both, or of the protocol's samples (n, 2)."""
        if level is not None:
            return volts, level
        pairs = np.asarray(volts, dtype=np.float64)
        if pairs.ndim != 2 or pairs.shape[1] != 2:
            raise v.fail("samples", f"an array of shape {pairs.shape}",
                         "shape (n, 2): output (V) and level per sample, or give level=")
        return pairs[:, 0], pairs[:, 1]

    # -- protocol -------------------------------------------------------------------------------
    def to_dict(self) -> dict[str, Any]:
        """JSON-ready description (SI)."""
        return {"quantity": self.quantity, "unit": self.unit, "span": list(self.span),
                "actuation": self.actuation.to_dict(), "levels": self.levels.tolist(),
                "direct_field_T": direct_field(self.actuation).tolist(),
                "model_coupling_V": self.model_coupling, "coupling_V": self.coupling,
                "measured_coupling": None if self.measured is None else self.measured.to_dict(),
                "level_error": self.level_error,
                "table_error": max(r.table_error for r in self.readouts),
                "sensor_flags": [r.sensor_flags for r in self.readouts],
                "tare": None if self.baseline is None else self.baseline.to_dict(),
                "units": "SI"}

    def report(self) -> str:
        """One line: span, levels, the coupling used, the errors (display units) and the force
        scale's note."""
        q = MEASURANDS[self.quantity]
        lo, hi = (q.to_display(x) for x in self.span)
        source = "measured" if self.coupling != self.model_coupling else "modelled"
        text = (f"{q.label} read-out over {lo:.4g}…{hi:.4g} {q.display} while actuating with "
                f"{self.actuation.describe()} × level {self.levels[0]:.4g}…{self.levels[-1]:.4g}"
                f" ({self.levels.size} levels); direct coupling {self.coupling * 1e3:.6g} mV per "
                f"level ({source}); table error ≤ "
                f"{q.to_display(max(r.table_error for r in self.readouts)):.2g} {q.display}, "
                f"level interpolation ≤ {q.to_display(self.level_error):.2g} {q.display}")
        if self.baseline is not None:
            text += f"; {self.baseline.report()}"
        if self.readouts[0].scale_note:
            text += f"; {self.readouts[0].scale_note}"
        return text

    def _display_items(self) -> list[Item]:
        q = MEASURANDS[self.quantity]
        return [("", self.quantity), ("span", f"{q.text(self.span[0])}…{q.text(self.span[1])}"),
                ("levels", (f"{self.levels.size} ({number(float(self.levels[0]))}…"
                           f"{number(float(self.levels[-1]))})")),
                ("coupling", f"{number(self.coupling * 1e3)} mV/level"),
                ("level error", q.text(self.level_error))]
