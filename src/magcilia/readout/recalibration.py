"""In-use re-calibration: short coil pulses re-estimate the read-out's slow drifts while it runs.

A pulse applies a known uniform field ΔB (T, board frame) for a few ms on top of whatever load the
cilium carries; the output's step between the samples before and during it (a
:class:`PulseWindow`) measures gains, never levels, so the unknown load drops out. With S the
calibrated scale (V/T), the drift scales s (sensitivity), m (magnetization), k (stiffness, EI)
and the offset o (V), the model is, per pulse (a uniform field's couple on the hair is
proportional to M·ΔB over EI, the hair's field to M)::

    ΔV = S·s·( ΔB_x + (m²/k)·r(ΔB; F) )

where r (T) is the calibrated hair's field change at the element along the sensing axis under the
pulse, from the model (:func:`magcilia.bend` with :meth:`Actuation.uniform` and
:meth:`~magcilia.Setup.field`, exact, tabulated over the span of loads F and taken at the pose the
level before the pulse shows; its drift scaling m²/k is the linear one, exact to second order in
the pulse's bend). ``g`` is r per unit field at rest for 1 G pulses. What each kind of window
determines:

* a pulse **along the sensing axis** (x) sees the direct field S·s·ΔB_x — the sensitivity — plus
  the hair's bending, which is small beside it (−0.1 % for the paper's hair);
* a pulse **across it in the element's plane** (y) has no direct part: it sees the hair's bending
  alone, S·s·m²/k·r_y (the sensor sits off the hair's plane of symmetry, so r_y ≠ 0) — with s
  from x pulses, the ratio m²/k;
* a pulse **along the hair** (z) exerts no couple on a straight hair (t × B = 0) and a single-axis
  sensor does not see it: it determines nothing at rest (it does on a bent hair or a 3-axis part);
* no coil pulse sees the **offset**: a rest-level change is offset or magnetization (the rest
  field is proportional to M) and, while the load is unknown, load as well. The AMR's own
  set/reset strap pulse flips the bridge and not its offset: a :class:`StrapWindow` gives the
  offset directly, ``o = (V_set + V_reset)/2``;
* **magnetization and stiffness** enter coil pulses only as m²/k (and a load's reading as m/k):
  separating them needs a second kind — a :class:`RestWindow`, a moment known to be unloaded,
  whose level o + S·s·m·B₀ₓ is proportional to M — else one of them is held (by default the
  stiffness, whose drift is temperature's: hold it at the thermal model's value).

:meth:`Recalibrator.update` fits the windows given (weighted least squares, Gauss–Newton on the
free scales; σ from the Fisher information at the optimum), holds what they do not determine and
says so, and returns a frozen :class:`Recalibration` whose :meth:`~Recalibration.correct` maps
the raw output back to the calibrated read-out's scale: ``V' = o₀ + (V − o)/(s·m)`` and a force
read from it times k (the elastica depends on F/EI only).
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Sequence
from dataclasses import dataclass, field, replace
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from magcilia import _validate as v
from magcilia._display import Display, Item
from magcilia.device.setup import Setup
from magcilia.readout.recalibration_windows import PulseWindow, RestWindow, StrapWindow, Window

F64 = NDArray[np.float64]

#: the read-out parameters a re-calibration estimates, in order
NAMES = ("offset", "sensitivity", "magnetization", "stiffness")
#: a parameter seen for the first time stays held while its σ exceeds this (V; scales: relative)
_LOOSE = {"offset": 1e-3, "sensitivity": 0.1, "magnetization": 0.1, "stiffness": 0.1}
#: each parameter's unit in the test for an undetermined combination (V; scales: 1)
_UNIT = {"offset": 1e-3, "sensitivity": 1.0, "magnetization": 1.0, "stiffness": 1.0}
#: of parameters equally undetermined, the later is held first
_HOLD_FIRST = ("offset", "sensitivity", "magnetization", "stiffness")
#: the default random walk of :meth:`Recalibrator.update`'s tracking, per √s: generous for slow
#: (thermal) drifts — 10 µV and 0.1 % in a second (the HMC1021's sensitivity moves ~0.3 %/K)
WALK = {"offset": 1e-5, "sensitivity": 1e-3, "magnetization": 1e-3, "stiffness": 1e-3}
#: field of the model's finite difference for g, T (1 gauss)
_PROBE = 1e-4


@dataclass(frozen=True, repr=False)
class Recalibration(Display):
    """The read-out parameters after a re-calibration (immutable; see the module docstring).

    Attributes
    ----------
    values : dict
        ``offset`` (V) and the scales ``sensitivity``, ``magnetization``, ``stiffness``
        (dimensionless, 1 at the calibration).
    sigma : dict
        Their standard errors (0 where held at an exact value).
    reference : dict
        The values at the calibration (the offset the read-out was calibrated with).
    determined : tuple of str
        The parameters these windows determined.
    held : dict
        Held parameters -> why.
    time : float
        Time of the last window used, s.
    windows : int
        Windows used.
    chi2 : float
        χ² per degree of freedom of the fit (NaN without spare windows).
    """

    values: dict[str, float]
    sigma: dict[str, float]
    reference: dict[str, float]
    determined: tuple[str, ...] = ()
    held: dict[str, str] = field(default_factory=dict)
    time: float = 0.0
    windows: int = 0
    chi2: float = math.nan

    def change(self, name: str) -> float:
        """The change since the calibration: V for the offset, relative for a scale."""
        if name == "offset":
            return self.values[name] - self.reference[name]
        return self.values[name] / self.reference[name] - 1.0

    @property
    def gain(self) -> float:
        """Factor on the hair's part of the output, s·m."""
        return self.values["sensitivity"] * self.values["magnetization"]

    @property
    def force_scale(self) -> float:
        """Factor on a force read from :meth:`correct`'s output: k (the stiffness scale)."""
        return self.values["stiffness"]

    def correct(self, volts: ArrayLike, offset: float | None = None) -> F64:
        """The output, V, mapped back to the calibrated read-out's scale:
        ``o₀ + (V − o)/(s·m)`` (o the current offset, o₀ the calibrated one; ``offset`` gives
        the level of readings that are already offset-free, e.g. set/reset demodulated: then
        ``offset + (V − offset)/(s·m)``)."""
        x = np.asarray(volts, dtype=np.float64)
        if offset is not None:
            return np.asarray(offset + (x - offset) / self.gain, dtype=np.float64)
        return np.asarray(self.reference["offset"] + (x - self.values["offset"]) / self.gain,
                          dtype=np.float64)

    @property
    def gain_sigma(self) -> float:
        """Relative σ of the gain s·m (the two σ in quadrature: conservative where the pulses
        correlate them)."""
        return math.hypot(self.sigma["sensitivity"] / self.values["sensitivity"],
                          self.sigma["magnetization"] / self.values["magnetization"])

    def read(self, readout: Any, volts: ArrayLike, offset: float | None = None,
             noise: float | None = None) -> tuple[F64, F64]:
        """A force (or any) read-out of the corrected outputs: values and their σ, the noise's
        (``readout.read``'s ``sigma_noise``) with the gain's and stiffness's σ added (readings
        at the gain ±σ). ``volts`` and ``offset`` as :meth:`correct`; shapes as ``volts``."""
        x = np.asarray(volts, dtype=np.float64)
        result = readout.read(self.correct(x, offset), noise=noise)
        k, sk = self.values["stiffness"], self.sigma["stiffness"]
        value = k * np.asarray(result.value, dtype=np.float64)
        spread = []
        for sign in (1.0, -1.0):
            shifted = replace(self, values={**self.values, "sensitivity": self.values[
                "sensitivity"] * (1.0 + sign * self.gain_sigma)})
            spread.append(k * np.asarray(readout.read(shifted.correct(x, offset),
                                                      noise=noise).value, dtype=np.float64))
        sigma = np.sqrt(np.asarray(result.sigma_noise, dtype=np.float64) ** 2 * k * k
                        + (0.5 * (spread[0] - spread[1])) ** 2 + (value * sk / k) ** 2)
        return value, sigma

    def changes_text(self) -> str:
        """What changed, with σ, e.g. ``S −1.8±0.1 %, M −4.9±0.4 %, offset +0.31±0.01 mV``
        (the determined parameters)."""
        parts = []
        for name, short in (("sensitivity", "S"), ("magnetization", "M"), ("stiffness", "E")):
            if name in self.determined:
                sigma = self.sigma[name] / self.reference[name] * 100
                parts.append(f"{short} {self.change(name) * 100:+.1f}±{sigma:.1f} %")
        if "offset" in self.determined:
            parts.append(f"offset {self.change('offset') * 1e3:+.2f}±"
                         f"{self.sigma['offset'] * 1e3:.2f} mV")
        return ", ".join(parts).replace("-", "−") or "nothing determined"

    def status_text(self, now: float) -> str:
        """The live status's words: ``recal 12 s ago: S −1.8±0.1 %, offset +0.30±0.01 mV``."""
        return f"recal {max(0.0, now - self.time):.0f} s ago: {self.changes_text()}"

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready content (SI)."""
        return {"values": dict(self.values), "sigma": dict(self.sigma),
                "reference": dict(self.reference), "determined": list(self.determined),
                "held": dict(self.held), "time_s": self.time, "windows": self.windows,
                "chi2_per_dof": self.chi2}

    def report(self) -> str:
        """One line per parameter: value ± σ, change, and whether it was determined."""
        lines = [f"re-calibration at {self.time:.3f} s from {self.windows} windows"]
        for name in NAMES:
            value, sigma = self.values[name], self.sigma[name]
            if name == "offset":
                text = f"{value * 1e3:+.4f} ± {sigma * 1e3:.4f} mV"
                change = f"{self.change(name) * 1e3:+.4f} mV"
            else:
                text = f"{value:.5f} ± {sigma:.5f}"
                change = f"{self.change(name) * 100:+.3f} %"
            how = ("determined" if name in self.determined else
                   f"held ({self.held.get(name, 'not seen')})")
            lines.append(f"  {name:<13} {text}  change {change}  {how}")
        return "\n".join(lines)

    def _display_items(self) -> list[Item]:
        return [(name, f"{self.values[name]:.6g} ± {self.sigma[name]:.2g}") for name in NAMES]


class Recalibrator:
    """Re-estimates a read-out's drifts from pulse, strap and rest windows (module docstring).

    Parameters
    ----------
    setup : Setup
        The calibrated sensor (its cilium needs ``tip_radius > 0`` for the field's couple).
    hold : iterable of str
        Parameters never fitted (kept at their last value): by default the stiffness (coil
        pulses see only m²/k; give rest windows, or hold the magnetization instead, to fit it).

    Attributes
    ----------
    g : ndarray, shape (3,)
        The hair's field at the element along the sensing axis per unit pulse field along x, y,
        z at rest, dimensionless (1 gauss pulses; :meth:`response` is exact for any pulse).
    rest_field : float
        The unloaded hair's field at the element along the sensing axis, T.
    scale, offset : float
        The calibrated sensor's scale (V/T) and offset (V).
    """

    def __init__(self, setup: Setup, *, hold: Iterable[str] = ("stiffness",),
                 span: tuple[float, float] = (-5e-6, 5e-6), points: int = 21) -> None:
        from magcilia.mechanics.planar import require_tip_radius

        if not isinstance(setup, Setup):
            raise v.fail("setup", type(setup).__name__, "a magcilia.Setup")
        setup = setup.resolve_layout()
        require_tip_radius(setup, "actuation")
        self.hold = tuple(v.choice("hold", h, NAMES) for h in hold)
        self.scale = float(setup.sensor.scale)
        self.offset = float(setup.sensor.offset)
        lo, hi = (v.real("span", x, "N") for x in span)
        if not lo <= 0.0 <= hi or lo == hi:
            raise v.fail("span", span, "loads (low, high), N, around 0")
        self._setup = setup
        self._loads = np.union1d(np.linspace(lo, hi, v.integer("points", points, 3)), [0.0])
        levels = np.array([_hair_bx(setup, float(f)) for f in self._loads])
        i0 = int(np.searchsorted(self._loads, 0.0))
        self.rest_field = float(levels[i0])
        monotonic = bool(np.all(np.diff(levels) > 0) or np.all(np.diff(levels) < 0))
        #: the hair's field at the element (T) at each load of the table; a pulse's response is
        #: interpolated at the pose whose field the level before it shows (at rest when the
        #: field is not monotonic over the span)
        self._levels = levels if monotonic else None
        self._responses: dict[tuple[float, float, float], F64] = {}
        self.g = np.array([self.response(b, self.rest_field) for b in np.eye(3) * _PROBE]
                          ) / _PROBE

    def response(self, field: ArrayLike, level: float) -> float:
        """The calibrated hair's field change at the element along the sensing axis, T, when a
        pulse ``field`` (3,), T, bends it from the pose where its field there is ``level``, T:
        the model's exact response (not linear in the pulse: 3 % less per gauss at 5 G than at
        1 G across the force-sensor hair), tabulated over the span per pulse field."""
        b = v.vector3("field", field, "T")
        key = (float(b[0]), float(b[1]), float(b[2]))
        if key not in self._responses:
            self._responses[key] = np.array([_hair_bx(self._setup, float(f), b)
                                             for f in self._loads]) - (
                self._levels if self._levels is not None else np.full(
                    self._loads.size, _hair_bx(self._setup, 0.0)))
        table = self._responses[key]
        if self._levels is None:
            return float(table[int(np.searchsorted(self._loads, 0.0))])
        order = np.argsort(self._levels)
        return float(np.interp(level, self._levels[order], table[order]))

    def start(self, offset: float | None = None) -> Recalibration:
        """The state at the calibration: scales 1, the offset ``offset`` (V; default the
        calibrated sensor's), nothing determined yet."""
        o = self.offset if offset is None else v.real("offset", offset, "V")
        values = {"offset": o, "sensitivity": 1.0, "magnetization": 1.0, "stiffness": 1.0}
        return Recalibration(values, dict.fromkeys(NAMES, 0.0), dict(values),
                             held=dict.fromkeys(NAMES, "no windows yet"))

    # -- the model --------------------------------------------------------------------------
    def predict(self, windows: Sequence[Window], theta: ArrayLike) -> tuple[F64, F64]:
        """Predicted observations (V) and their Jacobian (w, 4) at ``theta`` = (o, s, m, k)."""
        o, s, m, k = (float(x) for x in np.asarray(theta, dtype=np.float64))
        pred, jac = [], []
        S = self.scale
        for w in windows:
            if isinstance(w, PulseWindow):
                b = np.asarray(w.field)
                level = w.before if w.offset_free else w.before - o
                gb = self.response(b, level / (S * s * m))
                q = m * m / k
                pred.append(S * s * (b[0] + q * gb))
                jac.append([0.0, S * (b[0] + q * gb), S * s * 2.0 * m / k * gb,
                            -S * s * q / k * gb])
            elif isinstance(w, StrapWindow):
                pred.append(o)
                jac.append([1.0, 0.0, 0.0, 0.0])
            else:
                b0 = self.rest_field
                free = 0.0 if w.offset_free else 1.0
                pred.append(free * o + S * s * m * b0)
                jac.append([free, S * m * b0, S * s * b0, 0.0])
        return np.array(pred), np.array(jac).reshape(-1, 4)

    @staticmethod
    def _observed(windows: Sequence[Window]) -> tuple[F64, F64]:
        y, sig = [], []
        for w in windows:
            if isinstance(w, PulseWindow):
                step, sigma = w.step
            elif isinstance(w, StrapWindow):
                step = 0.5 * (w.set_level + w.reset_level)
                sigma = 0.5 * math.hypot(w.set_sem, w.reset_sem)
            elif isinstance(w, RestWindow):
                step, sigma = w.level, w.sem
            else:
                raise v.fail("window", type(w).__name__, "a PulseWindow, StrapWindow or "
                             "RestWindow")
            y.append(step)
            sig.append(sigma)
        sig_arr = np.array(sig)
        if np.any(~(sig_arr > 0.0)):
            raise v.fail("window σ", sig_arr.tolist(), "positive (a window of one repeated "
                         "value has no σ)")
        return np.array(y), sig_arr

    # -- the fit ----------------------------------------------------------------------------
    def update(self, windows: Sequence[Window], previous: Recalibration | None = None, *,
               walk: dict[str, float] | None = None) -> Recalibration:
        """Fit the windows; parameters they leave undetermined keep ``previous``'s values.

        Parameters
        ----------
        windows : sequence of PulseWindow, StrapWindow, RestWindow
            The windows since the last update (with ``walk``), or a set of recent ones.
        previous : Recalibration, optional
            The state before (default :meth:`start`): the starting point, the reference, and
            the values of what stays held.
        walk : dict, optional
            Tracking: each parameter's random walk per √s (offset V/√s, scales 1/√s, e.g.
            :data:`WALK`); ``previous``'s determined values then enter as a prior whose σ grows
            by ``walk·√(time since)`` — a Kalman filter's step (without it, the windows alone).

        Returns
        -------
        Recalibration
        """
        prev = previous if previous is not None else self.start()
        windows = list(windows)
        if not windows:
            return prev
        y, sig = self._observed(windows)
        theta = np.array([prev.values[n] for n in NAMES])
        prior = _prior(prev, walk, max(w.time for w in windows))  # (index, σ) of the priors
        held = dict.fromkeys(self.hold, "held by choice")
        _, jac = self.predict(windows, theta)
        for i, name in enumerate(NAMES):  # nothing in these windows (or before) sees it
            if name not in held and i not in prior and not np.any(jac[:, i] != 0.0):
                held[name] = _UNSEEN[name]
        free = [i for i, n in enumerate(NAMES) if n not in held]
        while free:  # an undetermined combination: hold its largest part until none is left
            a = self._design(jac, sig, prior, free) * np.array([_UNIT[NAMES[i]] for i in free])
            _, sv, vt = np.linalg.svd(a, full_matrices=True)
            rank = int(np.sum(sv > 1e-9 * sv[0])) if sv.size and sv[0] > 0 else 0
            if rank == len(free):
                break
            weight = np.linalg.norm(vt[rank:], axis=0)  # each parameter's share of the null space
            weight += 1e-6 * np.array([_HOLD_FIRST.index(NAMES[i]) for i in free])  # ties
            name = NAMES[free[int(np.argmax(weight))]]
            held[name] = _COMBINED[name]
            free = [i for i in free if NAMES[i] != name]
        start = theta.copy()
        while True:  # a parameter seen for the first time but barely determined stays held
            theta, cov = self._solve(windows, y, sig, start, prior, free)
            loose = [(math.sqrt(max(cov[j, j], 0.0)) / _LOOSE[NAMES[i]], i)
                     for j, i in enumerate(free) if i not in prior]
            worst = max(loose, default=(0.0, -1))
            if worst[0] <= 1.0:
                break
            held[NAMES[worst[1]]] = "too weakly determined by these windows yet"
            free = [i for i in free if i != worst[1]]
        pred, _ = self.predict(windows, theta)
        dof = len(windows) - len([i for i in free if i not in prior])
        chi2 = float(np.sum(((y - pred) / sig) ** 2) / dof) if dof > 0 else math.nan
        sigma = dict(prev.sigma)
        for j, i in enumerate(free):
            sigma[NAMES[i]] = float(math.sqrt(max(cov[j, j], 0.0)))
        values = {n: float(theta[i]) for i, n in enumerate(NAMES)}
        determined = tuple(NAMES[i] for i in free)
        if walk is not None:  # what was determined before stays so
            determined = tuple(n for n in NAMES if n in determined or (
                n in prev.determined and n not in self.hold))
        return Recalibration(values, sigma, dict(prev.reference), determined=determined,
                             held={n: why for n, why in held.items() if n not in determined},
                             time=float(max(w.time for w in windows)),
                             windows=prev.windows * (walk is not None) + len(windows),
                             chi2=chi2)

    def innovation(self, window: Window, state: Recalibration,
                   walk: dict[str, float] | None = None) -> float:
        """How far ``window`` lies from what ``state`` predicts, in σ (its own and the state's,
        grown by ``walk`` since); NaN while a parameter it sees is undetermined (no test)."""
        theta = np.array([state.values[n] for n in NAMES])
        y, sig = self._observed([window])
        pred, jac = self.predict([window], theta)
        prior = _prior(state, walk or {}, window.time)
        var = float(sig[0]) ** 2
        for i, name in enumerate(NAMES):
            if jac[0, i] != 0.0 and name not in self.hold:
                if i not in prior:
                    return math.nan
                var += (jac[0, i] * prior[i]) ** 2
        return float((y[0] - pred[0]) / math.sqrt(var))

    def _solve(self, windows: Sequence[Window], y: F64, sig: F64, start: F64,
               prior: dict[int, float], free: list[int]) -> tuple[F64, F64]:
        """Gauss–Newton on the free parameters from ``start``: (θ, covariance of the free)."""
        theta = start.copy()
        cov: F64 = np.zeros((len(free), len(free)))
        for _ in range(30):
            if not free:
                break
            pred, jac = self.predict(windows, theta)
            a = self._design(jac, sig, prior, free)
            r = np.concatenate([(y - pred) / sig, [(start[i] - theta[i]) / prior[i]
                                                   for i in free if i in prior]])
            step, *_ = np.linalg.lstsq(a, r, rcond=None)
            # a scale moves by at most a third of itself per step (they stay positive)
            limit = min([1.0] + [abs(theta[i]) / (3.0 * abs(d)) for i, d in zip(
                free, step, strict=True) if NAMES[i] != "offset" and d != 0.0])
            theta[free] += limit * step
            cov = np.asarray(np.linalg.pinv(a.T @ a), dtype=np.float64)
            if limit == 1.0 and np.all(np.abs(step) <= 1e-10 * np.maximum(
                    1e-3, np.abs(theta[free]))):
                break
        return theta, cov

    @staticmethod
    def _design(jac: F64, sig: F64, prior: dict[int, float], free: list[int]) -> F64:
        """The weighted Jacobian of the free parameters, prior rows below."""
        rows = [jac[:, free] / sig[:, None]]
        for i in free:
            if i in prior:
                row = np.zeros((1, len(free)))
                row[0, free.index(i)] = 1.0 / prior[i]
                rows.append(row)
        return np.vstack(rows)


#: why a parameter no window sees stays held
_UNSEEN = {"offset": "no strap or rest window: coil pulses never see the offset",
           "sensitivity": "no pulse along the sensing axis, no rest window",
           "magnetization": "no pulse bends the hair (x or y) and no rest window",
           "stiffness": "no pulse bends the hair (x or y)"}
#: why a parameter is held when the windows see it only in a combination
_COMBINED = {"stiffness": "pulses see only magnetization²/stiffness: a rest window (unloaded) "
                          "separates them",
             "sensitivity": "pulses across the sensing axis see sensitivity × magnetization² / "
                            "stiffness only: a pulse along it fixes the sensitivity",
             "magnetization": "seen only in a combination these windows cannot split (a pulse "
                              "across the sensing axis and a rest window each fix one)",
             "offset": "a rest level is offset or magnetization: a strap window separates them"}


def _prior(prev: Recalibration, walk: dict[str, float] | None, now: float) -> dict[int, float]:
    """Index -> σ of the prior on each parameter ``prev`` determined, grown by the walk."""
    if walk is None:
        return {}
    out = {}
    dt = max(0.0, now - prev.time)
    for i, name in enumerate(NAMES):
        if name in prev.determined:
            step = v.non_negative(f"walk[{name}]", walk.get(name, 0.0))
            sigma = math.hypot(prev.sigma[name], step * math.sqrt(dt))
            if sigma > 0.0:
                out[i] = sigma
    return out


def _hair_bx(setup: Setup, force: float, field: F64 | None = None) -> float:
    """The hair's field at the element along the sensing axis, T, under a tip force (N, +x) and a
    uniform field (3,), T (None: none)."""
    from magcilia.device.actuation import Actuation
    from magcilia.mechanics import bend

    act = None if field is None or not np.any(field) else Actuation.uniform(field)
    return float(np.ravel(setup.field(bend(setup, force, actuation=act)))[0])


