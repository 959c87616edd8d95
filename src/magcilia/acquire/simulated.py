"""A simulated sensor: a :class:`~magcilia.Setup` driven by a scripted pose, with a bench's noise.

The cilium follows a :class:`Script` (a tilt angle, a tip force or a flow speed over time); the
source samples the model's output and adds what a real bench adds: the sensor's white + 1/f noise
(``Sensor.noise``, generated in records of at least 65 536 samples, 65 s at 1 kHz: reads within a
record share its low frequencies, successive records are independent), white read-out noise of
the amplifier and ADC, a slow linear drift and a DC bias. With
``set_reset`` it alternates the AMR strap's set and reset pulses like a device would: the bridge's
sign flips, its offset does not. With ``temperature`` it emits a second channel, ``temperature_K``
(K), and its output follows the temperature model (:class:`~magcilia.TemperatureModel`:
sensitivity, offset, magnetization, and the modulus through the load). Deterministic with
``rng``. It is the source the tests, the demo and every command without a device use.
"""

from __future__ import annotations

import itertools
import math
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from magcilia import _validate as v
from magcilia.acquire.source import OUTPUT, Block, Channel, Source
from magcilia.device.parameters import MEASURANDS
from magcilia.device.setup import Setup
from magcilia.device.temperature import TEMPERATURE_CHANNEL, TemperatureModel, TemperatureProfile
from magcilia.mechanics import Flow, output_at
from magcilia.mechanics.drag import Fluid
from magcilia.mechanics.transient import ResponseStream

F64 = NDArray[np.float64]

#: distinct values above which force and flow outputs come from an interpolated table
_EXACT_VALUES = 8
#: points of that table over the values met so far (the error of a read-out table of the same size)
_TABLE_POINTS = 257


@dataclass(frozen=True)
class Script:
    """What the simulated cilium does: a measurand's value (SI) as a function of time (s).

    Build it with :meth:`constant`, :meth:`steps` or :meth:`function`.

    Attributes
    ----------
    quantity : {"angle", "force", "flow"}
        Rigid tilt angle (rad), dead tip force along +x (N) or flow speed (m/s).
    steps : tuple of (float, float)
        (start time s, value) pairs, increasing in time: each value holds until the next start.
    function : callable or None
        A vectorised ``f(t) -> value`` (ndarray of times in s -> same shape); replaces ``steps``.
    """

    quantity: str = "angle"
    steps: tuple[tuple[float, float], ...] = ((0.0, 0.0),)
    function: Callable[[F64], ArrayLike] | None = None

    def __post_init__(self) -> None:
        v.choice("quantity", self.quantity, tuple(MEASURANDS))
        if self.function is None:
            starts = [t for t, _ in self.steps]
            if not self.steps or starts[0] > 0.0 or any(
                    b <= a for a, b in itertools.pairwise(starts)):
                raise v.fail("steps", self.steps, "(time s, value) pairs from t = 0 with "
                             "increasing times")

    @classmethod
    def constant(cls, value: float, quantity: str = "angle") -> Script:
        """The same value all the time (SI)."""
        return cls(quantity, ((0.0, v.real("value", value, MEASURANDS[quantity].unit)),))

    @classmethod
    def from_steps(cls, steps: Sequence[tuple[float, float]], quantity: str = "angle") -> Script:
        """Values that hold from their start time (s) to the next one, e.g.
        ``[(0, 0.0), (2, 0.3), (4, 0.0)]``; the first start must be 0."""
        pairs = tuple((v.real("step time", t, "s"), v.real("step value", x)) for t, x in steps)
        return cls(quantity, pairs)

    @classmethod
    def from_function(cls, function: Callable[[F64], ArrayLike],
                      quantity: str = "angle") -> Script:
        """A vectorised function of time (s) giving the value (SI)."""
        if not callable(function):
            raise v.fail("function", type(function).__name__, "a callable f(t) -> value")
        return cls(quantity, function=function)

    def values(self, t: F64) -> F64:
        """The value (SI) at times ``t`` (s), same shape."""
        if self.function is not None:
            out = np.asarray(self.function(t), dtype=np.float64)
            if out.shape != t.shape or not np.isfinite(out).all():
                raise v.fail("script function", f"output of shape {out.shape}",
                             "finite values, one per time")
            return out
        starts = np.array([s for s, _ in self.steps])
        values = np.array([x for _, x in self.steps])
        return np.asarray(values[np.searchsorted(starts, t, side="right") - 1], dtype=np.float64)

    def then(self, at: float, value: float) -> Script:
        """This script with ``value`` from time ``at`` (s) on (a step script; a function script
        becomes a constant from then on)."""
        if self.function is not None:
            raise v.fail("script", "a function of time", "a step script to add steps to")
        kept = tuple(s for s in self.steps if s[0] < at)
        return Script(self.quantity, (*kept, (at, value)) if kept else ((0.0, value),))

    def describe(self) -> str:
        """One line, in SI."""
        unit = MEASURANDS[self.quantity].unit
        if self.function is not None:
            return f"{self.quantity} ({unit}) as a function of time"
        shown = ", ".join(f"{x:.6g} from {t:g} s" for t, x in self.steps[:4])
        more = ", …" if len(self.steps) > 4 else ""
        return f"{self.quantity} ({unit}): {shown}{more}"


class Paced:
    """The wall-clock pace of a simulated source: with ``realtime``, sample ``index`` is handed
    over no earlier than ``index / (rate · speed)`` s after the pace started."""

    rate: float
    speed: float
    realtime: bool
    _index: int
    _started: float

    def _start_pace(self) -> None:
        """Start (or resume after a reopening) the pace at the next sample."""
        self._started = time.monotonic() - self._index / (self.rate * self.speed)

    def _pace(self) -> None:
        """Wait, when real time, until the samples read so far are due."""
        if self.realtime:
            wait = self._started + self._index / (self.rate * self.speed) - time.monotonic()
            if wait > 0.0:
                time.sleep(wait)


class SimulatedSource(Paced, Source):
    """A simulated sensor (see the module docstring).

    Parameters
    ----------
    setup : Setup
        The simulated sensor (its ``output`` is the noise-free signal, offset included), its
        dipole layout resolved by the layout rule at the element
        (:meth:`~magcilia.Setup.resolve_layout`): the simulated hair is the exact body within
        0.5 % unless the setup names the paper's layout or gives its own.
    script : Script or float
        What the cilium does; a number is a constant tilt angle, rad.
    rate : float
        Samples per second, Hz.
    readout_noise : float
        White noise of amplifier + ADC per sample, V rms.
    drift : float
        Linear output drift, V/s.
    bias : float
        DC bias added to every sample, V (earth's and lab fields, bridge offset).
    set_reset : int or None
        Alternate set and reset pulses every ``set_reset`` samples (None: never pulse).
    realtime : bool
        Pace the samples by the wall clock at ``rate`` (for live views); False delivers them as
        fast as they are computed (tests, demos, benchmarks).
    speed : float
        With ``realtime``: how many times faster than the wall clock the samples come (1: a
        device's pace). Tests run long paced recordings through the same path at a higher speed;
        sample times stay ``index / rate``.
    flow : Flow, optional
        Flow profile for a ``"flow"`` script (scaled to the scripted speed); default uniform water.
    rng : int, Generator or None
        Randomness; None (default) draws fresh entropy, an int repeats the samples exactly.
    dynamics : bool
        The hair moves through its bending modes (rings, lags) instead of sitting at each
        value's static equilibrium (the module's docstring); needs ``tip_radius > 0``.
    fluid : Fluid, optional
        With ``dynamics``: the fluid around the hair (its added mass and damping); None: the
        flow's fluid for a flow script, else vacuum.
    temperature : TemperatureProfile or float, optional
        The temperature over time (a number: constant, K); None (default): no temperature
        channel and no temperature effect. The setup's parameters are those at the model's
        reference temperature.
    thermal : TemperatureModel, optional
        The coefficients the output follows (default :class:`~magcilia.TemperatureModel`'s).

    Examples
    --------
    >>> import magcilia as mc
    >>> from magcilia.acquire import SimulatedSource
    >>> with SimulatedSource(mc.Setup.paper(), 0.3, rng=1) as source:
    ...     block = source.read(1000)
    >>> block.data.shape
    (1, 1000)
    """

    def __init__(self, setup: Setup, script: Script | float = 0.0, *, rate: float = 1000.0,
                 readout_noise: float = 2e-4, drift: float = 0.0, bias: float = 0.0,
                 set_reset: int | None = None, realtime: bool = False, speed: float = 1.0,
                 flow: Flow | None = None,
                 rng: int | np.random.Generator | None = None, dynamics: bool = False,
                 fluid: Fluid | None = None,
                 temperature: TemperatureProfile | float | None = None,
                 thermal: TemperatureModel | None = None) -> None:
        super().__init__()
        if not isinstance(setup, Setup):
            raise v.fail("setup", type(setup).__name__, "a magcilia.Setup")
        self.setup = setup.resolve_layout()  # the layout rule at the sensing element
        self.script = script if isinstance(script, Script) else Script.constant(script)
        self.rate = v.positive("rate", rate, "Hz", "frequency")
        self.readout_noise = v.non_negative("readout_noise", readout_noise, "V", "noise")
        self.drift = v.real("drift", drift, "V/s")
        self.bias = v.real("bias", bias, "V")
        self.set_reset = None if set_reset is None else v.integer("set_reset", set_reset, 1)
        self.realtime = bool(realtime)
        self.speed = v.positive("speed", speed, "", "factor")
        self.flow = flow
        self.channels = (Channel(OUTPUT, "V"),)
        self.name = "sim"
        self._seed = rng if isinstance(rng, int) else None
        self._gen = np.random.default_rng(rng)
        self._index = 0
        self._noise = np.zeros(0)
        self._table: tuple[F64, F64] | None = None
        self._started = 0.0
        self.dynamics = bool(dynamics)
        if fluid is not None and not isinstance(fluid, Fluid):
            raise v.fail("fluid", type(fluid).__name__, "a magcilia.Fluid (AIR, WATER) or None")
        self.fluid = fluid
        self._stream: ResponseStream | None = None
        self.temperature = (TemperatureProfile.constant(temperature)
                            if isinstance(temperature, (int, float)) else temperature)
        if self.temperature is not None and not isinstance(self.temperature, TemperatureProfile):
            raise v.fail("temperature", type(temperature).__name__,
                         "a TemperatureProfile, a temperature in K, or None")
        self.thermal = TemperatureModel() if thermal is None else thermal
        if self.temperature is not None:
            self.channels = (*self.channels, Channel(TEMPERATURE_CHANNEL, "K"))

    # -- the script -----------------------------------------------------------------------------
    @property
    def time(self) -> float:
        """Time of the next sample, s."""
        return self._index / self.rate

    def set_value(self, value: float) -> None:
        """Hold the scripted quantity at ``value`` (SI) from the next sample on."""
        value = v.real("value", value, MEASURANDS[self.script.quantity].unit)
        if self.script.function is not None:
            self.script = Script.constant(value, self.script.quantity)
        else:
            self.script = self.script.then(self.time, value)

    # -- Source ---------------------------------------------------------------------------------
    def _open(self) -> None:
        if self._index == 0:  # the model's first evaluation loads compiled code: before the pace
            if self.dynamics:
                self._hair().prepare(self._script_values())
            else:
                self._clean(self.script.values(np.zeros(1)))
        self._start_pace()

    def _hair(self) -> ResponseStream:
        """The moving hair (its modes computed on first use)."""
        if self._stream is None:
            self._stream = ResponseStream(self.setup, self.script.quantity, self.rate,
                                          fluid=self.fluid, flow=self.flow)
        return self._stream

    def _script_values(self) -> F64:
        """The values the script goes through: its steps', or a function's over its first
        minute (for the static map's range, built before the pace starts)."""
        if self.script.function is not None:
            return self.script.values(np.linspace(0.0, 60.0, 6001))
        return np.array([x for _, x in self.script.steps])

    def _close(self) -> None:
        return

    def _read(self, n: int) -> Block:
        index = self._index + np.arange(n)
        t = index / self.rate
        temps = None if self.temperature is None else self.temperature.values(t)
        clean = self._clean_at(t)
        offset = self.setup.sensor.offset
        polarity = None
        volts = clean
        if self.set_reset is not None:
            polarity = np.where((index // self.set_reset) % 2 == 0, 1, -1).astype(np.int8)
            volts = polarity * (clean - offset) + offset
        if temps is not None:
            volts = self.thermal.output(volts, temps, offset, self.setup.sensor.scale)
        volts = (volts + self._sensor_noise(n) + self.bias + self.drift * t
                 + self.readout_noise * self._gen.standard_normal(n))
        self._index += n
        self._pace()
        rows = self._rows(t, volts)
        data = rows if temps is None else np.vstack([rows, temps[None, :]])
        return Block(time=t, data=data, channels=self.channels, first=int(index[0]),
                     setreset=polarity)

    def metadata(self) -> dict[str, Any]:
        """The source's settings, marked simulated."""
        return {**super().metadata(), "simulated": True, "script": self.script.describe(),
                "readout_noise_V": self.readout_noise, "drift_V_per_s": self.drift,
                "bias_V": self.bias, "set_reset_samples": self.set_reset, "seed": self._seed,
                "speed": self.speed, "dynamics": self.dynamics,
                **({"fluid": self.fluid.name} if self.dynamics and self.fluid else {}),
                **({} if self.temperature is None else {
                    "temperature": self.temperature.describe(),
                    "temperature_model": self.thermal.to_dict()})}

    # -- the signal -----------------------------------------------------------------------------
    def _clean_at(self, t: F64) -> F64:
        """Noise-free output (V) at sample times ``t`` (s); a subclass that drives more than the
        script (a coil: :class:`~magcilia.acquire.simulated_coil.SimulatedCoilSource`) overrides
        it."""
        values = self.script.values(t)
        if self.temperature is not None and self.script.quantity != "angle":
            values = values / self.thermal.load_factor(self.temperature.values(t))  # F/(E(T)/E_ref)
        return self._clean(values)

    def _rows(self, t: F64, volts: F64) -> F64:  # noqa: ARG002 (a subclass's channels use t)
        """The block's rows, shape (channels, n): the output (and a subclass's channels)."""
        return volts[None, :]

    def _clean(self, values: F64) -> F64:
        """Noise-free output (V) at the scripted values (the moving hair's, with
        ``dynamics``)."""
        if self.dynamics:
            return self._hair().push(values)[2]
        quantity = self.script.quantity
        distinct, where = np.unique(values, return_inverse=True)
        if quantity == "angle" or distinct.size <= _EXACT_VALUES:
            return output_at(self.setup, quantity, distinct, self.flow)[where]
        lo, hi = float(distinct[0]), float(distinct[-1])
        if self._table is None or lo < self._table[0][0] or hi > self._table[0][-1]:
            if self._table is not None:
                lo, hi = min(lo, self._table[0][0]), max(hi, self._table[0][-1])
            grid = np.linspace(lo, hi, _TABLE_POINTS)
            self._table = (grid, output_at(self.setup, quantity, grid, self.flow))
        return np.interp(values, *self._table)

    def _sensor_noise(self, n: int) -> F64:
        """The next n samples of the sensor's white + 1/f output noise, V."""
        sensor = self.setup.sensor
        if sensor.noise_density == 0.0:
            return np.zeros(n)
        while self._noise.size < n:
            record = max(65536, 2 ** math.ceil(math.log2(n)))
            self._noise = np.concatenate([self._noise, sensor.noise(record, self.rate,
                                                                    rng=self._gen)])
        out, self._noise = self._noise[:n], self._noise[n:]
        return out
