"""A simulated sensor in a coil: the applied uniform field, the hair it bends, and slow drifts.

:class:`SimulatedCoilSource` is a :class:`~magcilia.acquire.SimulatedSource` whose cilium sits in
a Helmholtz coil's uniform field B (T, board frame): the sensor sees B directly plus the field of
the cilium bent by it (``mc.bend(setup, F, actuation=Actuation.uniform(B))`` and
:meth:`~magcilia.Setup.field`, exact, no linearisation), together with a scripted dead tip force F
along +x (N). The field is set step by step (:meth:`SimulatedCoilSource.set_field`, what
``magcilia record --coil`` does) and/or pulsed (:class:`CoilPulses`: a known ΔB for a few ms every
few seconds, what the in-use re-calibration fires). Every block carries the applied field in the
channels ``actuation_x_T``, ``actuation_y_T``, ``actuation_z_T`` (:data:`ACTUATION_COLUMNS`), so a
recording of it is a coil recording.

Slow drifts (:class:`Drifts`) scale the sensor's sensitivity s, the magnetization m and the
stiffness k linearly in time (the offset drifts with the source's own ``drift``, V/s). With them
the output is, exactly (the elastica depends on the loads over EI only, the body's field is
proportional to M)::

    V = offset + S·s·( m · b_x(F / k, m·B / k) + B_x )

where S is the sensor's scale (V/T) and b_x(F, B) the nominal hair's field at the element bent by
F and B. The drift scales are rounded to 1e-4 per sample, so the distinct (load, field, scales)
are few and each is solved once (cached); the sensor's cross-axis term is left out, as in
:meth:`magcilia.Setup.output`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from magcilia import _validate as v
from magcilia.acquire.simulated import Script, SimulatedSource
from magcilia.acquire.source import OUTPUT, Channel
from magcilia.device.setup import Setup
from magcilia.io.columns import ACTUATION_KEYS

F64 = NDArray[np.float64]

#: the recording channels of the applied uniform field at the cilium, T, board frame (the
#: readers' column keys, :data:`magcilia.io.columns.ACTUATION_KEYS`)
ACTUATION_COLUMNS = ACTUATION_KEYS
#: the axes a pulse may take, in the board frame
AXES = {"x": 0, "y": 1, "z": 2}
#: drift scales are rounded to this step
_SCALE_STEP = 1e-4
#: most cached solutions before the cache is emptied
_CACHE = 512


@dataclass(frozen=True)
class CoilPulses:
    """Short coil pulses for the in-use re-calibration: a field of ``amplitude`` along the next
    axis of ``axes`` for ``duration`` s, every ``every`` s (the first at ``start``, default
    ``every``).

    Attributes
    ----------
    every : float
        Period, s.
    duration : float
        Length of each pulse, s.
    amplitude : float
        Field of each pulse, T (the HMC1021Z's range is 6 gauss = 6e-4 T).
    axes : tuple of str
        The pulses' axes in turn, each ``"x"``, ``"y"`` or ``"z"`` (board frame).
    start : float or None
        Time of the first pulse, s (None: ``every``).
    """

    every: float = 5.0
    duration: float = 0.05
    amplitude: float = 5e-4
    axes: tuple[str, ...] = ("x", "y")
    start: float | None = None

    def __post_init__(self) -> None:
        v.positive("every", self.every, "s", "duration")
        v.positive("duration", self.duration, "s", "duration")
        if self.duration >= self.every:
            raise v.fail("pulse duration", self.duration, f"shorter than the period "
                         f"({self.every:g} s)")
        v.real("amplitude", self.amplitude, "T")
        axes = tuple(self.axes)
        if not axes or any(a not in AXES for a in axes):
            raise v.fail("pulse axes", self.axes, "a list of x, y and z")
        object.__setattr__(self, "axes", axes)
        if self.start is not None:
            v.non_negative("start", self.start, "s", "time")

    @property
    def first(self) -> float:
        """Time of the first pulse, s."""
        return self.every if self.start is None else float(self.start)

    def number(self, t: ArrayLike) -> NDArray[np.int64]:
        """The pulse each time ``t`` (s) falls in (0, 1, …), −1 outside the pulses; shape of t."""
        t = np.asarray(t, dtype=np.float64)
        k = np.floor((t - self.first) / self.every)
        inside = (k >= 0) & (t - self.first - k * self.every < self.duration)
        return np.where(inside, k, -1).astype(np.int64)

    def axis(self, k: int) -> str:
        """The axis of pulse ``k``."""
        return self.axes[k % len(self.axes)]

    def field(self, t: ArrayLike) -> F64:
        """The pulses' field at times ``t`` (s), T, shape (n, 3)."""
        k = self.number(t)
        out = np.zeros((k.size, 3))
        for i, name in enumerate(self.axes):
            on = (k >= 0) & (k % len(self.axes) == i)
            out[on, AXES[name]] = self.amplitude
        return out

    def describe(self) -> str:
        """One line, in gauss and ms."""
        return (f"{self.amplitude * 1e4:g} G pulses of {self.duration * 1e3:g} ms along "
                f"{', '.join(self.axes)} in turn, every {self.every:g} s")


@dataclass(frozen=True)
class Drifts:
    """Linear drifts of the simulated sensor, relative change per second (−0.03/60: −3 % over a
    minute): ``sensitivity`` (the bridge's S), ``magnetization`` (the cilium's M) and ``stiffness``
    (its E, hence EI). The offset's drift is the source's ``drift`` (V/s)."""

    sensitivity: float = 0.0
    magnetization: float = 0.0
    stiffness: float = 0.0

    def __post_init__(self) -> None:
        for name in ("sensitivity", "magnetization", "stiffness"):
            v.real(name, getattr(self, name), "1/s")

    def scales(self, t: ArrayLike) -> F64:
        """(s, m, k) at times ``t`` (n,), s, rounded to 1e-4 (the source's step), shape (n, 3)."""
        t = np.atleast_1d(np.asarray(t, dtype=np.float64))
        rates = np.array([self.sensitivity, self.magnetization, self.stiffness])
        out = np.round((1.0 + t[:, None] * rates) / _SCALE_STEP) * _SCALE_STEP
        if np.any(out <= 0.0):
            raise v.fail("drifts", rates.tolist(), f"drifts that keep every scale positive "
                         f"(they reach {out.min():g} by {t.max():g} s)")
        return np.asarray(out, dtype=np.float64)


class SimulatedCoilSource(SimulatedSource):
    """A simulated sensor in a coil (see the module docstring).

    Parameters
    ----------
    setup : Setup
        The simulated sensor; its cilium needs ``tip_radius > 0`` (a field's couple on a sharp
        tip is singular).
    script : Script or float
        The dead tip force along +x (a ``"force"`` script, N); a number is a constant force.
    field : array-like, shape (3,)
        The coil's field from the start, T (board frame); change it with :meth:`set_field`.
    pulses : CoilPulses, optional
        Pulses added to the field.
    drifts : Drifts, optional
        Slow drifts of sensitivity, magnetization and stiffness.
    **options
        :class:`SimulatedSource`'s (rate, readout_noise, drift, bias, set_reset, realtime,
        speed, rng); ``dynamics`` is not supported here.

    Examples
    --------
    >>> import magcilia as mc
    >>> source = SimulatedCoilSource(mc.Setup.paper(tip_radius=5e-5), rng=1)
    >>> with source:
    ...     source.set_field((2e-4, 0.0, 0.0))
    ...     block = source.read(10)
    >>> float(block["actuation_x_T"][0])
    0.0002
    """

    def __init__(self, setup: Setup, script: Script | float = 0.0, *,
                 field: ArrayLike = (0.0, 0.0, 0.0), pulses: CoilPulses | None = None,
                 drifts: Drifts | None = None, **options: Any) -> None:
        if options.get("dynamics"):
            raise v.fail("dynamics", True, "False for a coil source (the static hair)")
        if not isinstance(script, Script):
            script = Script.constant(v.real("force", script, "N"), "force")
        if script.quantity != "force":
            raise v.fail("script", script.quantity, "a tip force script (quantity 'force')")
        if options.get("temperature") is not None:
            raise v.fail("temperature", options["temperature"],
                         "None for a coil source (its output does not follow a temperature model)")
        super().__init__(setup, script, **options)
        from magcilia.mechanics.planar import require_tip_radius

        require_tip_radius(self.setup, "actuation")
        if pulses is not None and not isinstance(pulses, CoilPulses):
            raise v.fail("pulses", type(pulses).__name__, "a CoilPulses or None")
        if drifts is not None and not isinstance(drifts, Drifts):
            raise v.fail("drifts", type(drifts).__name__, "a Drifts or None")
        self.pulses = pulses
        self.drifts = drifts or Drifts()
        self.channels = (Channel(OUTPUT, "V"), *(Channel(c, "T") for c in ACTUATION_COLUMNS))
        self.name = "sim-coil"
        self._steps: list[tuple[int, F64]] = [(0, v.vector3("field", field, "T"))]
        self._cache: dict[tuple[float, ...], float] = {}

    # -- the coil -------------------------------------------------------------------------------
    def set_field(self, field: ArrayLike) -> None:
        """Apply the uniform ``field`` (3,), T, from the next sample on."""
        b = v.vector3("field", field, "T")
        self._steps = [s for s in self._steps if s[0] < self._index] + [(self._index, b)]

    def applied(self, t: ArrayLike) -> F64:
        """The coil's field (steps and pulses) at sample times ``t`` (s), T, shape (n, 3)."""
        t = np.atleast_1d(np.asarray(t, dtype=np.float64))
        index = np.round(t * self.rate).astype(np.int64)
        starts = np.array([i for i, _ in self._steps])
        fields = np.array([b for _, b in self._steps])
        out = fields[np.searchsorted(starts, index, side="right") - 1]
        if self.pulses is not None:
            out = out + self.pulses.field(t)
        return np.asarray(out, dtype=np.float64)

    # -- the signal -----------------------------------------------------------------------------
    def _open(self) -> None:
        if self._index == 0:  # the first solution loads compiled code: before the pace
            self._clean_at(np.zeros(1))
        self._start_pace()

    def _clean_at(self, t: F64) -> F64:
        rows = np.column_stack([self.script.values(t), self.applied(t), self.drifts.scales(t)])
        distinct, where = np.unique(rows, axis=0, return_inverse=True)
        sensor = self.setup.sensor
        f, b, (s, m, k) = distinct[:, 0], distinct[:, 1:4], distinct[:, 4:].T
        cilium = np.array([self._cilium_bx(f[i] / k[i], [float(x) * m[i] / k[i] for x in b[i]])
                           for i in range(len(distinct))])
        volts = sensor.offset + sensor.scale * s * (m * cilium + b[:, 0])
        return np.asarray(volts[np.ravel(where)], dtype=np.float64)

    def _cilium_bx(self, force: float, field: list[float]) -> float:
        """The nominal hair's field along the sensing axis, T, bent by a tip force (N, +x) and a
        uniform field (3,), T."""
        key = (force, *field)
        if key not in self._cache:
            from magcilia.device.actuation import Actuation
            from magcilia.mechanics import bend

            if len(self._cache) >= _CACHE:
                self._cache.clear()
            act = Actuation.uniform(field) if any(field) else None
            shape = bend(self.setup, force, actuation=act)
            self._cache[key] = float(np.ravel(self.setup.field(shape))[0])
        return self._cache[key]

    def _rows(self, t: F64, volts: F64) -> F64:
        return np.vstack([volts[None, :], self.applied(t).T])

    def metadata(self) -> dict[str, Any]:
        """The source's settings with the coil's pulses and drifts."""
        d = self.drifts
        return {**super().metadata(), "coil": True,
                "coil_pulses": None if self.pulses is None else self.pulses.describe(),
                "drift_sensitivity_per_s": d.sensitivity,
                "drift_magnetization_per_s": d.magnetization,
                "drift_stiffness_per_s": d.stiffness}


def field_text(field: ArrayLike) -> str:
    """A field (3,), T, as ``(Bx, By, Bz) G``."""
    b = np.asarray(field, dtype=np.float64) * 1e4
    return "(" + ", ".join(f"{x:+.4g}" for x in b) + ") G"


def magnitude(field: ArrayLike) -> float:
    """|B| of a field (3,), T."""
    return float(math.sqrt(float(np.sum(np.square(np.asarray(field, dtype=np.float64))))))
