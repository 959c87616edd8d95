"""What the live read-out needs of a read-out: the protocol's view of it, and what the views show.

:class:`~magcilia.live.pipeline.LiveReadout` takes any read-out that follows
:class:`~magcilia.readout.protocol.SensorReadout` (``inputs``, ``rest``, ``read(samples,
noise=)``, ``tare``, ``baseline``): the single-axis :class:`~magcilia.Readout`, the force vector
of a 3-axis sensor (:class:`~magcilia.BiaxialReadout`), every force vector of an array
(:class:`~magcilia.ArrayReadout`). :func:`live_sensor` describes one for the live views
(:class:`LiveSensor`): its kind, the channels it reads and their unit, the shape of one estimate,
the channels' saturation rule and model noise, its limits, the setup to record.

Where a read-out class does not offer the protocol yet, :func:`protocol_view` wraps it in a thin
adapter (:class:`_ScalarView`, :class:`_VectorView`, :class:`_ArrayView`) that gives it; a
read-out that offers it passes through unchanged.

Shape letters: ``n`` readings (windows), ``c`` channels, ``C`` cilia.
"""

from __future__ import annotations

import copy
import dataclasses
import math
from dataclasses import dataclass, field
from typing import Any, Self

import numpy as np
from numpy.typing import ArrayLike, NDArray

from magcilia import _validate as v
from magcilia._display import Display, Item
from magcilia.device.sensor import DEFAULT_BANDWIDTH, beyond_range
from magcilia.io.array_file import array_to_dict
from magcilia.io.recordings import beyond_range as output_beyond_range
from magcilia.io.setup_files import setup_to_dict
from magcilia.live.status import Limits
from magcilia.mechanics import output_at
from magcilia.readout.array import ArrayFlag, ArrayReadout
from magcilia.readout.biaxial import BiaxialReadout
from magcilia.readout.inverse import Readout
from magcilia.readout.protocol import FLAG_DTYPE, Flag, SensorReadout
from magcilia.readout.tare import Tare

F64 = NDArray[np.float64]

#: the kinds of read-out the live views know: one value, a force vector, one per cilium
KINDS = ("scalar", "vector", "array")
#: the flags that leave an estimate without a value (every kind)
NO_VALUE = Flag.OUTSIDE_SPAN | Flag.FOLD | Flag.UNDETERMINED


@dataclass(frozen=True, eq=False, repr=False)
class Values(Display):
    """A protocol result (:class:`~magcilia.readout.protocol.ReadoutValues`) of an adapted
    read-out (immutable): ``value``, ``sigma`` (SI, (n,), (n, 2) or (n, C, 2)), ``flags``
    (:class:`Flag`, (n,) or (n, C)), ``unit``."""

    value: F64
    sigma: F64
    flags: NDArray[np.uint16]
    unit: str

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready content (SI; NaN as None)."""
        def plain(a: F64) -> Any:
            return np.where(np.isfinite(a), a.astype(object), None).tolist()  # type: ignore[call-overload]
        return {"value": plain(self.value), "sigma": plain(self.sigma),
                "flags": self.flags.tolist(), "unit": self.unit}

    def report(self) -> str:
        """One line."""
        good = int(np.count_nonzero(self.flags == 0))
        return f"{self.flags.size} estimates in {self.unit}, {good} unflagged"

    def _display_items(self) -> list[Item]:
        return [("estimates", str(self.flags.size)), ("shape", str(self.value.shape)),
                ("unflagged", str(int(np.count_nonzero(self.flags == 0)))), ("unit", self.unit)]


@dataclass(frozen=True, eq=False, repr=False)
class _View(Display):
    """What the adapters share (immutable): the read-out, its inputs and rest, the tare the
    protocol asks for (added to every reading), its report."""

    readout: Any
    inputs: tuple[str, ...]
    rest: F64
    unit: str = "T"
    baseline: Tare | None = None

    def tare(self, baseline: ArrayLike, /) -> Self:
        """A copy whose zero is the mean of unloaded samples ``baseline`` ((n, c))."""
        tare = Tare.from_readings(np.asarray(baseline, dtype=np.float64).reshape(
            -1, self.rest.size), self.rest, unit=self.unit, names=self.inputs)
        return dataclasses.replace(self, baseline=tare)

    def _samples(self, samples: ArrayLike) -> F64:
        x = np.asarray(samples, dtype=np.float64)
        c = self.rest.size
        if x.ndim == 1 and c == 1:
            x = x[:, None]
        if x.ndim != 2 or x.shape[1] != c:
            raise v.fail("samples", f"an array of shape {x.shape}",
                         f"shape (n, {c}): one column per input ({', '.join(self.inputs)})")
        if self.baseline is not None:
            x = x + np.asarray(self.baseline.correction)
        return x

    def _noise(self, noise: ArrayLike | None) -> F64 | None:
        if noise is not None:
            return np.broadcast_to(np.asarray(noise, dtype=np.float64), self.rest.shape).copy()
        if self.baseline is not None:
            return np.broadcast_to(np.asarray(self.baseline.noise), self.rest.shape).copy()
        return None

    def _readout_dict(self) -> dict[str, Any]:
        """JSON-ready content (SI): the read-out's (each adapter's ``to_dict``)."""
        return dict(self.readout.to_dict())

    def report(self) -> str:
        """Text for people: the read-out's report."""
        return str(self.readout.report())

    def _display_items(self) -> list[Item]:
        return [("", type(self.readout).__name__), ("inputs", str(len(self.inputs))),
                ("tared", "yes" if self.baseline is not None else "no")]


@dataclass(frozen=True, eq=False, repr=False)
class _ScalarView(_View):
    """The protocol's view of a single-axis :class:`~magcilia.Readout`: input ``output`` (V)."""

    to_dict = _View._readout_dict

    @classmethod
    def of(cls, readout: Readout) -> _ScalarView:
        """The view of ``readout``."""
        flow = readout.flow if readout.quantity == "flow" else None
        rest = np.array([float(output_at(readout.setup, readout.quantity, np.zeros(1),
                                         flow)[0])])
        return cls(readout, ("output",), rest, "V")

    def read(self, samples: ArrayLike, /, *, noise: ArrayLike | None = None) -> Values:
        """Estimates (n,) of samples (n, 1) or (n,), V."""
        x = np.asarray(samples, dtype=np.float64)
        if x.ndim == 2 and x.shape[1] == 1:
            x = x[:, 0]
        elif x.ndim != 1:
            self._samples(x)  # the one-line error of a wrong shape
        if self.baseline is not None:
            x = x + float(self.baseline.correction)
        if noise is None and self.baseline is not None:
            noise = self.baseline.noise
        r = self.readout.read(x, noise=None if noise is None else float(np.ravel(noise)[0]))
        return Values(np.asarray(r.value), np.asarray(r.sigma),
                      np.asarray(r.flags, dtype=FLAG_DTYPE), r.unit)


@dataclass(frozen=True, eq=False, repr=False)
class _VectorView(_View):
    """The protocol's view of a :class:`~magcilia.BiaxialReadout`: its channels (T) in, (n, 2)
    force vectors out."""

    to_dict = _View._readout_dict

    @classmethod
    def of(cls, readout: BiaxialReadout) -> _VectorView:
        """The view of ``readout``."""
        return cls(readout, tuple(c.name for c in readout.channels),
                   np.asarray(readout.rest, dtype=np.float64))

    def read(self, samples: ArrayLike, /, *, noise: ArrayLike | None = None) -> Values:
        """Force vectors (n, 2), N, of samples (n, c), T."""
        x = self._samples(samples)
        r = self.readout.read(x, noise=self._noise(noise))
        value = np.stack([r.fx, r.fy], axis=-1)
        sigma = np.stack([r.sigma_fx, r.sigma_fy], axis=-1)
        return Values(value, sigma, np.asarray(r.flags, dtype=FLAG_DTYPE), "N")


#: ArrayFlag bits -> Flag bits (same names)
_ARRAY_FLAGS = tuple((int(f), int(Flag[str(f.name)])) for f in ArrayFlag if f.value)


@dataclass(frozen=True, eq=False, repr=False)
class _ArrayView(_View):
    """The protocol's view of an :class:`~magcilia.ArrayReadout`: every sensor's three axes (T,
    in the array's sensor order) in, (n, C, 2) force vectors out (one solve per reading set)."""

    #: the read-out weighting by the last noise asked for (noise bytes -> read-out)
    noisy: dict[bytes, ArrayReadout] = dataclasses.field(default_factory=dict)

    to_dict = _View._readout_dict

    @classmethod
    def of(cls, readout: ArrayReadout) -> _ArrayView:
        """The view of ``readout``."""
        arr = readout.array
        return cls(readout, tuple(f"{s.name}.{a}" for s in arr.sensors for a in "xyz"),
                   np.asarray(readout.rest, dtype=np.float64).reshape(-1))

    def _with_noise(self, noise: F64 | None) -> ArrayReadout:
        """The read-out weighting the readings by ``noise`` (3S,) instead of the parts' own."""
        if noise is None:
            return self.readout
        key = noise.tobytes()
        if key not in self.noisy:
            arr = copy.copy(self.readout.array)
            arr.__dict__["sigma"] = noise.reshape(-1, 3).copy()  # (the cached property's slot)
            noisy = copy.copy(self.readout)
            object.__setattr__(noisy, "array", arr)
            self.noisy.clear()
            self.noisy[key] = noisy
        return self.noisy[key]

    def read(self, samples: ArrayLike, /, *, noise: ArrayLike | None = None) -> Values:
        """Force vectors (n, C, 2), N, of samples (n, 3S), T."""
        x = self._samples(samples)
        readout = self._with_noise(self._noise(noise))
        c_n = len(readout.array)
        value = np.full((x.shape[0], c_n, 2), np.nan)
        sigma = np.full_like(value, np.nan)
        flags = np.zeros((x.shape[0], c_n), dtype=FLAG_DTYPE)
        for k, row in enumerate(x):
            if not np.isfinite(row).all():
                flags[k] = Flag.MISSING | Flag.OUTSIDE_SPAN
                continue
            est = readout.read(row.reshape(-1, 3))
            value[k], sigma[k] = est.force, est.sigma
            for bit, to in _ARRAY_FLAGS:
                flags[k] |= np.where(est.flags & bit, to, 0).astype(FLAG_DTYPE)
        return Values(value, sigma, flags, "N")


def protocol_view(readout: Any) -> SensorReadout:
    """``readout`` as a :class:`~magcilia.readout.protocol.SensorReadout`: itself when it offers
    the protocol, else a thin adapter of a :class:`~magcilia.Readout`,
    :class:`~magcilia.BiaxialReadout` or :class:`~magcilia.ArrayReadout`.

    Raises
    ------
    MagciliaError
        For anything else.
    """
    if isinstance(readout, SensorReadout):
        return readout
    if isinstance(readout, Readout):
        return _ScalarView.of(readout)
    if isinstance(readout, BiaxialReadout):
        return _VectorView.of(readout)
    if isinstance(readout, ArrayReadout):
        return _ArrayView.of(readout)
    raise v.fail("readout", type(readout).__name__, "a read-out: magcilia.Readout, "
                 "BiaxialReadout, ArrayReadout or one that follows the SensorReadout protocol")


@dataclass(frozen=True, eq=False, repr=False)
class LiveSensor:
    """A read-out as the live views see it (immutable; SI).

    Attributes
    ----------
    readout : object
        The read-out as given.
    view : SensorReadout
        Its protocol view (:func:`protocol_view`): what the pipeline calls.
    kind : {"scalar", "vector", "array"}
        One value per reading, a force vector (Fx, Fy), or one force vector per cilium.
    quantity, unit : str
        What is estimated and its SI unit.
    inputs : tuple of str
        The source channels read, in order.
    channel_unit : str
        Their unit: ``"V"`` (a sensor output) or ``"T"`` (field channels).
    rest : ndarray, shape (c,)
        The model's reading of each channel at rest.
    offset : ndarray, shape (c,)
        What set/reset demodulation adds back per channel (a bridge output's offset; 0 for field
        channels).
    value_shape, flags_shape : tuple of int
        Shape of one estimate (``()``, ``(2,)`` or ``(C, 2)``) and of its flags (``()`` or
        ``(C,)``).
    names : tuple of str
        The cilia, in the array's order (() otherwise).
    positions : ndarray, shape (C, 2)
        Each cilium's base (x, y) on the board, m (the origin for one cilium).
    span : float
        Largest |value| the read-out covers (SI; an array: its largest cilium span).
    setup : dict
        The setup as a setup or array file holds it (for recordings and the dashboard).
    """

    readout: Any
    view: Any
    kind: str
    quantity: str
    unit: str
    inputs: tuple[str, ...]
    channel_unit: str
    rest: F64
    offset: F64
    value_shape: tuple[int, ...]
    flags_shape: tuple[int, ...]
    names: tuple[str, ...]
    positions: F64
    span: float
    setup: dict[str, Any] = field(default_factory=dict)

    @property
    def channels(self) -> int:
        """Number of channels read (c)."""
        return len(self.inputs)

    def no_estimates(self, m: int) -> tuple[F64, F64, NDArray[np.uint16]]:
        """Value, σ (NaN) and flags (OUTSIDE_SPAN) of ``m`` readings without an estimate: force
        vectors before their first tare, whose readings still hold the Earth's field and the
        parts' offsets (beyond the model's reach: an array's inverse would spend tens of ms on
        each)."""
        nan = np.full((m, *self.value_shape), np.nan)
        return nan, nan.copy(), np.full((m, *self.flags_shape), Flag.OUTSIDE_SPAN, FLAG_DTYPE)

    def beyond(self, raw: F64) -> NDArray[np.bool_]:
        """Raw samples (n, c) beyond their channel's range (the one saturation rule), (n,):
        whether any channel of a sample is."""
        r = self.readout
        if self.kind == "scalar":
            return np.asarray(output_beyond_range(raw[:, 0], r.setup.sensor))
        if self.kind == "vector":
            lsb = [c.resolution for c in r.channels]
            return np.asarray(beyond_range(np.nan_to_num(raw), r.field_range, lsb).any(axis=1))
        sat = r.array.saturated(np.nan_to_num(raw).reshape(raw.shape[0], -1, 3))
        return np.asarray(sat.reshape(raw.shape[0], -1).any(axis=1))

    def model_noise(self, rate: float, factor: int) -> F64:
        """Noise RMS of one reading (the mean of ``factor`` samples, at output ``rate`` Hz) per
        channel, (c,), channel units: the sensor model's (an AMR output's over half the output
        rate; a field part's noise per sample over √factor)."""
        r = self.readout
        if self.kind == "scalar":
            band = (DEFAULT_BANDWIDTH[0], max(rate / 2.0, DEFAULT_BANDWIDTH[0] * 2.0))
            return np.array([r.setup.sensor.output_noise_rms(*band)])
        if self.kind == "vector":
            sigma = np.array([c.sigma for c in r.channels])
        else:
            sigma = np.asarray(r.array.sigma, dtype=np.float64).reshape(-1)
        return np.asarray(sigma / math.sqrt(max(1, factor)))

    def limits(self, noise: F64) -> Limits:
        """The span, the usable range and the minimum detectable change at rest, with channel
        noise ``noise`` (c,)."""
        r = self.readout
        if self.kind == "scalar":
            table = r.table
            sensor = r.setup.sensor
            ok = sensor.in_range(sensor.field(table.output))
            q = table.quantity
            limited = "fold" if r.fold is not None else "span"
            if not ok.all():
                limited = "sensor range"
            inside = q[ok] if ok.any() else q[:1]
            rest_slope = abs(float(np.interp(self.rest[0], table.volts, table.slope)))
            return Limits(r.quantity, r.unit, r.span, (float(inside.min()), float(inside.max())),
                          float(noise[0]) * rest_slope, limited, r.scale_note)
        at_rest = self.view.read(self.rest[None, :], noise=noise)
        sig = np.asarray(at_rest.sigma)[0]
        minimum = float(np.nanmedian(np.max(sig.reshape(-1, 2), axis=-1)))
        note = r.setup.modulus.note() if self.kind == "vector" else ""
        return Limits("force", "N", (0.0, self.span), (0.0, self.span), minimum, "span", note)

    def report(self) -> str:
        """The read-out's report."""
        return str(self.readout.report())


def live_sensor(readout: Any) -> LiveSensor:
    """Describe ``readout`` for the live views (see :class:`LiveSensor`).

    Raises
    ------
    MagciliaError
        If it is not a read-out the live views know.
    """
    view = protocol_view(readout)
    rest = np.asarray(view.rest, dtype=np.float64).reshape(-1)
    inputs = tuple(view.inputs)
    if isinstance(readout, Readout):
        return LiveSensor(readout, view, "scalar", readout.quantity, readout.unit, inputs, "V",
                          rest, np.array([readout.setup.sensor.offset]), (), (), (),
                          np.zeros((1, 2)), float(max(abs(x) for x in readout.span)),
                          setup_to_dict(readout.setup))
    if isinstance(readout, BiaxialReadout):
        setup = {**setup_to_dict(readout.setup),
                 "channels": {c.name: c.to_dict() for c in readout.channels}}
        return LiveSensor(readout, view, "vector", "force", "N", inputs, "T", rest,
                          np.zeros(rest.size), (2,), (), (), np.zeros((1, 2)),
                          float(readout.span), setup)
    if isinstance(readout, ArrayReadout):
        arr = readout.array
        c_n = len(arr)
        return LiveSensor(readout, view, "array", "force", "N", inputs, "T", rest,
                          np.zeros(rest.size), (c_n, 2), (c_n,), arr.names,
                          np.asarray(arr.bases[:, :2], dtype=np.float64),
                          float(np.max(readout.span)), array_to_dict(arr))
    raise v.fail("readout", type(readout).__name__, "a Readout, BiaxialReadout or ArrayReadout "
                 "(the live views know one value, a force vector and an array)")
