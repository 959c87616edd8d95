"""A simulated 3-axis sensor or array: cilia driven by scripted tip forces, read by magnetometers.

The cilia follow a :class:`LoadScript` (one horizontal tip force vector (Fx, Fy) per cilium over
time); the source computes the field at every magnetometer with an exact forward model — the
elastica (:func:`magcilia.bend`) and the setup's field for one cilium (:func:`single_cilium`), or
an array's exact forward map given by the caller (``magcilia.field_for_loads``: the acquisition
layer does not import the read-outs) — never a read-out's own table, so that a read-out watching
it is tested against the physics, not against itself. Each distinct set of loads is solved once
and kept (:data:`CACHE`). Each part then reports what it would: the field on its axes plus its
white noise, clipped at its range and rounded to its LSB (:meth:`Magnetometer.measure`); a slow
drift and a constant bias (the Earth's and the lab's fields, the part's offset) come on top, in
the board frame. The channels are ``NAME.x``, ``NAME.y``, ``NAME.z`` (T) per part. Deterministic
with ``rng``.

Shape letters: ``n`` samples, ``C`` cilia, ``S`` magnetometers.
"""

from __future__ import annotations

import itertools
import math
from collections import OrderedDict
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from magcilia import _validate as v
from magcilia.acquire.simulated import Paced
from magcilia.acquire.source import Block, Channel, Source
from magcilia.device.magnetometer import Magnetometer
from magcilia.device.setup import Setup
from magcilia.mechanics import bend

F64 = NDArray[np.float64]
#: a forward map: tip forces (C, 2), N -> the board-frame field at every part (S, 3), T
FieldModel = Callable[[F64], F64]

#: distinct load sets whose fields are kept (least recently used dropped first)
CACHE = 256
#: the demo's pattern as fractions of the amplitude: (seconds, fraction), repeated
DEMO_STEPS = ((3.0, 0.0), (2.0, 0.5), (2.0, 0.0), (2.0, 0.3), (1.0, 0.0), (2.0, 0.8))
#: the demo's directions: each push turns by this from the last, each period by the second, and
#: each cilium's by the third from its neighbour's, deg
DEMO_TURNS = (120.0, 45.0, 22.5)


@dataclass(frozen=True)
class LoadScript:
    """What the simulated cilia do: each one's horizontal tip force (Fx, Fy), N, over time, s.

    Build it with :meth:`constant`, :meth:`from_steps`, :meth:`from_function` or :meth:`demo`.

    Attributes
    ----------
    cilia : int
        Number of cilia C.
    steps : tuple of (float, ndarray (C, 2))
        (start time s, loads) pairs, increasing in time: each holds until the next start.
    function : callable or None
        A vectorised ``f(t) -> loads`` (times (n,) s -> (n, C, 2) N); replaces ``steps``.
    """

    cilia: int
    steps: tuple[tuple[float, Any], ...] = ()
    function: Callable[[F64], ArrayLike] | None = None

    def __post_init__(self) -> None:
        v.integer("cilia", self.cilia, 1)
        if self.function is None:
            starts = [t for t, _ in self.steps]
            if not self.steps or starts[0] > 0.0 or any(
                    b <= a for a, b in itertools.pairwise(starts)):
                raise v.fail("steps", f"{len(self.steps)} steps", "(time s, loads) pairs from "
                             "t = 0 with increasing times")

    @classmethod
    def constant(cls, loads: ArrayLike) -> LoadScript:
        """The same loads all the time: (C, 2) or (2,) for one cilium, N."""
        f = _loads(loads)
        return cls(f.shape[0], ((0.0, f),))

    @classmethod
    def from_steps(cls, steps: Sequence[tuple[float, ArrayLike]]) -> LoadScript:
        """Loads ((C, 2) or (2,), N) that hold from their start time (s) to the next; the first
        start must be 0."""
        pairs = tuple((v.real("step time", t, "s"), _loads(f)) for t, f in steps)
        if not pairs:
            raise v.fail("steps", "none", "at least one (time s, loads) pair")
        return cls(pairs[0][1].shape[0], pairs)

    @classmethod
    def from_function(cls, cilia: int, function: Callable[[F64], ArrayLike]) -> LoadScript:
        """A vectorised function of time (s, (n,)) giving every cilium's load ((n, C, 2), N)."""
        if not callable(function):
            raise v.fail("function", type(function).__name__, "a callable f(t) -> loads")
        return cls(v.integer("cilia", cilia, 1), function=function)

    @classmethod
    def demo(cls, cilia: int, amplitude: float) -> LoadScript:
        """Rest, pushes of 50 %, 30 % and 80 % of ``amplitude`` (N) between rests, repeated every
        12 s (:data:`DEMO_STEPS`), each push in another direction: 120° on from the last, 45°
        on each period, each cilium 22.5° on from its neighbour (:data:`DEMO_TURNS`); the pattern
        repeats every 8 periods (96 s), so that its loads are a few dozen distinct sets."""
        c_n = v.integer("cilia", cilia, 1)
        amp = v.positive("amplitude", amplitude, "N", "force")
        starts = np.cumsum([0.0] + [s for s, _ in DEMO_STEPS[:-1]])
        period = sum(s for s, _ in DEMO_STEPS)
        levels = np.array([f for _, f in DEMO_STEPS]) * amp
        turn_push, turn_period, turn_cilium = (math.radians(a) for a in DEMO_TURNS)

        def loads(t: F64) -> F64:
            k = np.searchsorted(starts, np.mod(t, period), side="right") - 1
            p = np.floor_divide(t, period) % round(360.0 / DEMO_TURNS[1])
            theta = (turn_push * k + turn_period * p)[:, None] + turn_cilium * np.arange(c_n)
            mag = levels[k][:, None]
            return np.stack([mag * np.cos(theta), mag * np.sin(theta)], axis=-1)

        return cls.from_function(c_n, loads)

    def loads(self, t: F64) -> F64:
        """Every cilium's load at times ``t`` (s, (n,)): (n, C, 2), N."""
        if self.function is not None:
            out = np.asarray(self.function(t), dtype=np.float64)
            if out.shape != (t.size, self.cilia, 2) or not np.isfinite(out).all():
                raise v.fail("load script", f"output of shape {out.shape}",
                             f"finite loads of shape ({t.size}, {self.cilia}, 2)")
            return out
        starts = np.array([s for s, _ in self.steps])
        table = np.stack([f for _, f in self.steps])
        return np.asarray(table[np.searchsorted(starts, t, side="right") - 1])

    def describe(self) -> str:
        """One line, in SI."""
        if self.function is not None:
            return f"tip forces (N) of {self.cilia} cilia as a function of time"
        shown = ", ".join(f"max |F| {np.hypot(*f.T).max():.3g} N from {t:g} s"
                          for t, f in self.steps[:3])
        return f"tip forces of {self.cilia} cilia: {shown}{', …' if len(self.steps) > 3 else ''}"


def _loads(loads: ArrayLike) -> F64:
    f = v.finite_array("loads", loads, unit="N")
    if f.ndim == 1:
        f = f[None, :]
    if f.ndim != 2 or f.shape[1] != 2:
        raise v.fail("loads", f"an array of shape {f.shape}", "(Fx, Fy) per cilium: shape "
                     "(C, 2), or (2,) for one cilium, N")
    return f


def single_cilium(setup: Setup, sensor: Magnetometer) -> FieldModel:
    """The exact forward map of one cilium over one part: a tip force (1, 2) N bends it
    (:func:`magcilia.bend`, the elastica, in the plane of the force) and the setup's dipole model
    gives the field at the part's position (board frame, (1, 3), T)."""
    if not isinstance(setup, Setup):
        raise v.fail("setup", type(setup).__name__, "a magcilia.Setup")
    # the field at the part's point is the field at the element of the cilium moved by −point
    moved = setup.replace(position=tuple(float(a - b) for a, b in zip(
        setup.position, sensor.position, strict=True))).resolve_layout(
        where="the magnetometer")

    def field(loads: F64) -> F64:
        fx, fy = float(loads[0, 0]), float(loads[0, 1])
        magnitude = math.hypot(fx, fy)
        shape = bend(setup, force=magnitude) if magnitude else bend(setup)
        phi = math.atan2(fy, fx) if magnitude else 0.0
        return np.asarray(moved.field(shape, azimuth=phi), dtype=np.float64).reshape(1, 3)

    return field


def field_channels(parts: Any) -> tuple[Channel, ...]:
    """The field channels of 3-axis parts, in order: ``NAME.x``, ``NAME.y``, ``NAME.z`` per
    part, T (what a force-vector or array read-out reads; a serial device's frames are named
    so for it)."""
    parts = parts if isinstance(parts, (list, tuple)) else [parts]
    return tuple(Channel(f"{s.name}.{a}", "T") for s in parts for a in "xyz")


class SimulatedFieldSource(Paced, Source):
    """A simulated 3-axis sensor or array (see the module docstring).

    Parameters
    ----------
    sensors : Magnetometer or sequence of them
        The parts, in the order of the channels (S).
    field : callable
        The exact forward map, tip forces (C, 2) N -> board-frame field at each part (S, 3) T:
        :func:`single_cilium` for one cilium, ``functools.partial(magcilia.field_for_loads,
        array)`` for an array.
    script : LoadScript
        What the cilia do.
    rate : float, optional
        Samples per second, Hz (default: the slowest part's output data rate).
    drift : float or (3,) floats
        A slow drift of the field at every part, T/s, board frame.
    bias : float or (3,) floats, or (S, 3)
        A constant field at the parts, T, board frame (the Earth's and the lab's).
    realtime, speed
        As for :class:`~magcilia.acquire.SimulatedSource`.
    rng : int, Generator or None
        Randomness; an int repeats the samples exactly.

    Examples
    --------
    >>> import magcilia as mc
    >>> part = Magnetometer.preset("MMC5983MA")
    >>> setup = mc.Setup.paper(tip_radius=5e-5)
    >>> script = LoadScript.constant([1e-5, 0.0])
    >>> with SimulatedFieldSource(part, single_cilium(setup, part), script, rng=0) as source:
    ...     block = source.read(10)
    >>> block.data.shape, [c.name for c in source.channels][:2]
    ((3, 10), ['MMC5983MA (18-bit).x', 'MMC5983MA (18-bit).y'])
    """

    def __init__(self, sensors: Magnetometer | Sequence[Magnetometer], field: FieldModel,
                 script: LoadScript, *, rate: float | None = None,
                 drift: ArrayLike = 0.0, bias: ArrayLike = 0.0, realtime: bool = False,
                 speed: float = 1.0, rng: int | np.random.Generator | None = None) -> None:
        super().__init__()
        parts = (sensors,) if isinstance(sensors, Magnetometer) else tuple(sensors)
        for i, s in enumerate(parts):
            if not isinstance(s, Magnetometer):
                raise v.fail(f"sensors[{i}]", type(s).__name__, "a magcilia Magnetometer")
        if not parts:
            raise v.fail("sensors", "none", "at least one Magnetometer")
        if not callable(field):
            raise v.fail("field", type(field).__name__, "a forward map loads (C, 2) -> (S, 3)")
        if not isinstance(script, LoadScript):
            raise v.fail("script", type(script).__name__, "a LoadScript")
        self.sensors = parts
        self.model = field
        self.script = script
        self.rate = min(s.rate for s in parts) if rate is None else v.positive(
            "rate", rate, "Hz", "frequency")
        self.drift = np.broadcast_to(v.finite_array("drift", drift, unit="T/s"), (3,)).copy()
        self.bias = np.broadcast_to(v.finite_array("bias", bias, unit="T"),
                                    (len(parts), 3)).copy()
        self.realtime = bool(realtime)
        self.speed = v.positive("speed", speed, "", "factor")
        self.channels = field_channels(parts)
        self.name = "sim"
        self._seed = rng if isinstance(rng, int) else None
        self._gen = np.random.default_rng(rng)
        self._index = 0
        self._cache: OrderedDict[bytes, F64] = OrderedDict()
        self._started = 0.0

    @property
    def time(self) -> float:
        """Time of the next sample, s."""
        return self._index / self.rate

    def fields(self, loads: F64) -> F64:
        """The noise-free board-frame field at every part (n, S, 3), T, for loads (n, C, 2) N
        (each distinct set solved once)."""
        flat = np.ascontiguousarray(loads.reshape(loads.shape[0], -1))
        distinct, where = np.unique(flat, axis=0, return_inverse=True)
        out = np.empty((distinct.shape[0], len(self.sensors), 3))
        for k, row in enumerate(distinct):
            key = row.tobytes()
            if key not in self._cache:
                b = np.asarray(self.model(row.reshape(-1, 2)), dtype=np.float64)
                if b.shape != (len(self.sensors), 3):
                    raise v.fail("field model", f"output of shape {b.shape}",
                                 f"the field at each of the {len(self.sensors)} parts, "
                                 f"({len(self.sensors)}, 3), T")
                self._cache[key] = b
                if len(self._cache) > CACHE:
                    self._cache.popitem(last=False)
            self._cache.move_to_end(key)
            out[k] = self._cache[key]
        return out[np.asarray(where).reshape(-1)]

    def _open(self) -> None:
        if self._index == 0:  # the first solve loads compiled code: before the pace starts
            self.fields(self.script.loads(np.zeros(1)))
        self._start_pace()

    def _close(self) -> None:
        return

    def _read(self, n: int) -> Block:
        index = self._index + np.arange(n)
        t = index / self.rate
        b = self.fields(self.script.loads(t)) + self.bias + self.drift * t[:, None, None]
        data = np.empty((len(self.sensors), 3, n))
        for s, part in enumerate(self.sensors):
            data[s] = part.measure(b[:, s, :], self._gen).T
        self._index += n
        self._pace()
        return Block(time=t, data=data.reshape(-1, n), channels=self.channels,
                     first=int(index[0]))

    def metadata(self) -> dict[str, Any]:
        """The source's settings, marked simulated."""
        return {**super().metadata(), "simulated": True, "script": self.script.describe(),
                "sensors": [s.name for s in self.sensors], "drift_T_per_s": self.drift.tolist(),
                "bias_T": self.bias.tolist(), "seed": self._seed, "speed": self.speed}
