"""What the live read-out needs of a read-out: the protocol's view of it, and what the views show.

:class:`~magcilia.live.pipeline.LiveReadout` takes any read-out that follows
:class:`~magcilia.readout.protocol.SensorReadout` (``inputs``, ``rest``, ``read(samples,
noise=)``, ``tare``, ``baseline``): the single-axis :class:`~magcilia.Readout`, the force vector
of a 3-axis sensor (:class:`~magcilia.BiaxialReadout`), every force vector of an array
(:class:`~magcilia.ArrayReadout`), one output compensated for temperature
(:class:`~magcilia.ThermalReadout`, :mod:`magcilia.live.thermal`). :func:`live_sensor`
describes one for the live views (:class:`LiveSensor`): its kind, the channels it reads and their
unit, the shape of one estimate, the channels' saturation rule and model noise, its limits, the
setup to record.

Every read-out passes through unchanged (:func:`protocol_view` checks that it follows the
protocol): the pipeline calls its batched ``read`` once per chunk of readings.

Shape letters: ``n`` readings (windows), ``c`` channels, ``C`` cilia.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace
from typing import Any

import numpy as np
from numpy.typing import NDArray

from magcilia import _validate as v
from magcilia.device.sensor import DEFAULT_BANDWIDTH, beyond_range
from magcilia.io.array_file import array_to_dict
from magcilia.io.recordings import beyond_range as output_beyond_range
from magcilia.io.setup_files import setup_to_dict
from magcilia.live.status import Limits
from magcilia.live.thermal import LiveThermal
from magcilia.readout.array import ArrayReadout
from magcilia.readout.biaxial import BiaxialReadout
from magcilia.readout.dynamic import DynamicReadout
from magcilia.readout.inverse import Readout
from magcilia.readout.protocol import FLAG_DTYPE, Flag, SensorReadout
from magcilia.readout.thermal import ThermalReadout

F64 = NDArray[np.float64]

#: the kinds of read-out the live views know: one value, a force vector, one per cilium
KINDS = ("scalar", "vector", "array")


def protocol_view(readout: Any) -> SensorReadout:
    """``readout`` itself, checked to follow :class:`~magcilia.readout.protocol.SensorReadout`
    (``inputs``, ``rest``, ``read(samples, noise=)``, ``tare``, ``baseline``): the single-axis
    :class:`~magcilia.Readout`, :class:`~magcilia.BiaxialReadout` and
    :class:`~magcilia.ArrayReadout` do.

    Raises
    ------
    MagciliaError
        For anything else.
    """
    if isinstance(readout, SensorReadout):
        return readout
    raise v.fail("readout", type(readout).__name__, "a read-out that follows the SensorReadout "
                 "protocol (magcilia.Readout, BiaxialReadout, ArrayReadout)")


@dataclass(frozen=True, eq=False, repr=False)
class LiveSensor:
    """A read-out as the live views see it (immutable; SI).

    Attributes
    ----------
    readout : object
        The read-out as given.
    view : SensorReadout
        The read-out the pipeline calls (the read-out itself, :func:`protocol_view`).
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
    informs : ndarray of bool, shape (c, C), or None
        An array's channels that inform each cilium (its model field changes by at least the
        channel's noise over the cilium's span, the rule of the array's SATURATED and MISSING
        flags); None for one cilium.
    mode : str
        A dynamic read-out's few words (:meth:`DynamicReadout.mode
        <magcilia.readout.dynamic.DynamicReadout.mode>`); "" for a static one.
    thermal : LiveThermal or None
        A temperature-compensated read-out's view (:mod:`magcilia.live.thermal`; also
        :attr:`view`): its samples are compensated before the averager (:meth:`compensate`).
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
    informs: Any = None
    mode: str = ""
    thermal: LiveThermal | None = None

    def compensate(self, block: Any, raw: F64, zero: Any) -> F64:
        """A block's samples of the read-out's channel (``raw``) as the averager takes them:
        brought to the reference temperature by a temperature-compensated read-out
        (:meth:`LiveThermal.compensate <magcilia.live.thermal.LiveThermal.compensate>`), else
        as they are."""
        return raw if self.thermal is None else self.thermal.compensate(block, raw, zero)

    def temperature_text(self) -> str:
        """The status's words on the temperature ("" without a temperature channel)."""
        return "" if self.thermal is None else self.thermal.text()

    @property
    def channels(self) -> int:
        """Number of channels read (c)."""
        return len(self.inputs)

    def zero_flags(self, channel_flags: NDArray[np.uint16]) -> Any:
        """The flags the zero's channel flags (:attr:`Zero.channel_flags
        <magcilia.live.zero.Zero.channel_flags>`, (c,)) put on one reading's estimates: all of
        them together for one output or a force vector; per cilium of an array, those of the
        channels that inform it (:attr:`informs`), (C,)."""
        bits = np.asarray(channel_flags, dtype=FLAG_DTYPE)
        if self.informs is None:
            return FLAG_DTYPE(np.bitwise_or.reduce(bits)) if bits.size else FLAG_DTYPE(0)
        return np.bitwise_or.reduce(np.where(self.informs, bits[:, None], FLAG_DTYPE(0)), axis=0)

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

    def rest_noise(self, rate: float, factor: int, spread: Any) -> Any:
        """Noise RMS of one reading at rest where no tare at rest measured it: the larger of
        :meth:`model_noise` and ``spread`` (the last second's successive readings',
        :func:`~magcilia.readout.tare.difference_noise`; NaN: none) — V, a float, for one
        output; (c,) in the channels' unit for several."""
        model = self.model_noise(rate, factor)
        seen = np.broadcast_to(np.asarray(spread, dtype=np.float64), model.shape)
        out = np.where(np.isfinite(seen), np.maximum(model, seen), model)
        return float(out[0]) if self.kind == "scalar" else out

    def samples(self, block: Any, channel: str) -> F64:
        """The read-out's channels of a source's ``block``: (n,) for one output (``channel``),
        (n, c) for several (:attr:`inputs`, in order)."""
        if self.kind == "scalar":
            return np.asarray(block[channel], dtype=np.float64)
        return np.stack([block[name] for name in self.inputs], axis=-1)

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
                          float(noise[0]) * rest_slope, limited, r.scale_note, self.mode)
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
    if isinstance(readout, ThermalReadout):  # one output read at the reference temperature
        thermal = LiveThermal(readout)
        inner = live_sensor(readout.readout)
        return replace(inner, readout=readout.readout, view=thermal, inputs=readout.inputs,
                       thermal=thermal)
    view = protocol_view(readout)
    rest = np.asarray(view.rest, dtype=np.float64).reshape(-1)
    inputs = tuple(view.inputs)
    if isinstance(readout, Readout | DynamicReadout):  # one output, read statically or not
        return LiveSensor(readout, view, "scalar", readout.quantity, readout.unit, inputs, "V",
                          rest, np.array([readout.setup.sensor.offset]), (), (), (),
                          np.zeros((1, 2)), float(max(abs(x) for x in readout.span)),
                          setup_to_dict(readout.setup),
                          mode=readout.mode() if isinstance(readout, DynamicReadout) else "")
    if isinstance(readout, BiaxialReadout):
        setup = {**setup_to_dict(readout.setup),
                 "channels": {c.name: c.to_dict() for c in readout.channels}}
        return LiveSensor(readout, view, "vector", "force", "N", inputs, "T", rest,
                          np.zeros(rest.size), (2,), (), (), np.zeros((1, 2)),
                          float(readout.span), setup)
    if isinstance(readout, ArrayReadout):
        arr = readout.array
        c_n = len(arr)
        informs = (np.abs(readout.jacobian / readout.sigma[:, None])
                   * np.repeat(readout.span, 2) >= 1.0).reshape(rest.size, c_n, 2).any(axis=2)
        view = readout.stream()  # each chunk starts warm from the last frame of the one before
        return LiveSensor(readout, view, "array", "force", "N", inputs, "T", rest,
                          np.zeros(rest.size), (c_n, 2), (c_n,), arr.names,
                          np.asarray(arr.bases[:, :2], dtype=np.float64),
                          float(np.max(readout.span)), array_to_dict(arr), informs)
    raise v.fail("readout", type(readout).__name__, "a Readout, BiaxialReadout, ArrayReadout or "
                 "ThermalReadout (the live views know one value, a force vector and an array)")
