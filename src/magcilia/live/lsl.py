"""A live read-out's values published as a Lab Streaming Layer stream (``magcilia live --lsl``).

LSL (``pylsl``, the ``lsl`` extra) is how lab programs (LabRecorder, OpenViBE, MNE-LSL, BCI2000,
PsychoPy, a MATLAB or Python script) receive time-stamped samples from each other on a network.
:class:`LslPublisher` opens one outlet and, in a thread of its own, pushes every output sample of
a started :class:`~magcilia.live.pipeline.LiveReadout` as it comes (from its own cursor in the
read-out's history: a slow network costs the acquisition nothing).

The stream (:func:`stream_channels` names its channels):

* name: given (default ``magcilia``), type: the quantity (``Force``, ``Angle``, ``Flow``),
  ``double64`` channels, nominal rate: the read-out's rate, source id: the name and the source;
* channels: the estimate (one; Fx, Fy for a 3-axis sensor; Fx, Fy per cilium of an array), then
  its 1-σ uncertainties in the same order, then the flag bits (one; one per cilium:
  :class:`~magcilia.readout.protocol.Flag`, 0 = a good reading). Values and σ are SI (N, rad or
  m/s) and NaN where a flag means "no estimate";
* the XML description: ``<channels>`` with each channel's ``label``, ``unit`` and ``type``
  (``value``, ``sigma``, ``flags``), as the XDF meta-data convention has them, and a
  ``<magcilia>`` block: quantity, sensor kind, the source, whether its samples are verified
  (a serial format without a checksum: "unverified (no checksum)"), the cilia's names.

Time stamps follow the read-out's own sample times (the device's clock), shifted once onto LSL's
clock at the first sample's arrival, so the spacing is the device's and not the network's.
"""

from __future__ import annotations

import contextlib
import math
import re
import threading
import time
from dataclasses import dataclass
from types import TracebackType
from typing import Any, Self

import numpy as np
from numpy.typing import NDArray

from magcilia import _validate as v
from magcilia._errors import require
from magcilia.live.history import LiveSamples
from magcilia.live.pipeline import LiveReadout
from magcilia.live.readouts import LiveSensor

#: the stream's type per quantity (LSL's content types are free text; these are the usual words)
STREAM_TYPES = {"force": "Force", "angle": "Angle", "flow": "Flow"}
#: the default stream name
DEFAULT_NAME = "magcilia"
#: longest wait of the publishing thread, s (how fast it notices stop)
_TICK = 0.1
_STREAM_NAME = re.compile(r"^[A-Za-z0-9_.-]{1,64}$")


def pylsl_module() -> Any:
    """The ``pylsl`` module (the ``lsl`` extra; a one-line error names it when missing)."""
    return require("pylsl", package="pylsl", extra="lsl", purpose="Publishing to the Lab "
                   "Streaming Layer (--lsl)")


def check_name(name: str) -> str:
    """``name`` when it can name a stream (1 to 64 letters, digits, ``-``, ``_``, ``.``)."""
    if not (isinstance(name, str) and _STREAM_NAME.match(name)):
        raise v.fail("--lsl", name, "a stream name of 1 to 64 letters, digits, -, _ or .")
    return name


@dataclass(frozen=True)
class StreamChannel:
    """One channel of the stream (immutable).

    Attributes
    ----------
    label : str
        Its name (``force``, ``sigma_force``, ``c1.fx``, ``flags``, ...).
    unit : str
        SI unit of its values (``N``, ``rad``, ``m/s``), ``bits`` for flags.
    type : str
        ``value``, ``sigma`` or ``flags``.
    """

    label: str
    unit: str
    type: str


def stream_channels(sensor: LiveSensor) -> tuple[StreamChannel, ...]:
    """The stream's channels for a read-out: estimates, their σ, flags (module docstring)."""
    if sensor.kind == "scalar":
        values = [sensor.quantity]
        flags = ["flags"]
    elif sensor.kind == "vector":
        values = ["fx", "fy"]
        flags = ["flags"]
    else:
        values = [f"{name}.{axis}" for name in sensor.names for axis in ("fx", "fy")]
        flags = [f"{name}.flags" for name in sensor.names]
    return (*(StreamChannel(x, sensor.unit, "value") for x in values),
            *(StreamChannel(f"sigma_{x}", sensor.unit, "sigma") for x in values),
            *(StreamChannel(x, "bits", "flags") for x in flags))


def stream_rows(samples: LiveSamples) -> NDArray[np.float64]:
    """The samples as the stream's rows, shape (m, k) in :func:`stream_channels`' order."""
    m = len(samples.time)
    return np.hstack([np.reshape(samples.value, (m, -1)), np.reshape(samples.sigma, (m, -1)),
                      np.reshape(samples.flags, (m, -1)).astype(np.float64)])


def stream_info(live: LiveReadout, name: str = DEFAULT_NAME, source_id: str | None = None) -> Any:
    """The ``pylsl.StreamInfo`` of a started read-out (name, type, channels, nominal rate and
    the XML description of the module docstring); builds no socket."""
    pylsl = pylsl_module()
    check_name(name)
    sensor = live.sensor
    channels = stream_channels(sensor)
    source = live.source.name
    info = pylsl.StreamInfo(name, STREAM_TYPES.get(sensor.quantity, sensor.quantity.title()),
                            len(channels), float(live.rate), pylsl.cf_double64,
                            source_id or f"{name}@{source}")
    desc = info.desc()
    xml = desc.append_child("channels")
    for ch in channels:
        child = xml.append_child("channel")
        child.append_child_value("label", ch.label)
        child.append_child_value("unit", ch.unit)
        child.append_child_value("type", ch.type)
    desc.append_child("acquisition").append_child_value("manufacturer", "magcilia")
    own = desc.append_child("magcilia")
    own.append_child_value("quantity", sensor.quantity)
    own.append_child_value("kind", sensor.kind)
    own.append_child_value("source", source)
    own.append_child_value("samples_checked", "yes" if live.source.verified
                           else "unverified (no checksum)")
    own.append_child_value("flags", "magcilia.readout.protocol.Flag bits; 0 = a good reading")
    if sensor.names:
        cilia = own.append_child("cilia")
        for cilium in sensor.names:
            cilia.append_child_value("name", cilium)
    return info


class LslPublisher:
    """Push a started read-out's output samples to one LSL outlet, from a thread (see the
    module docstring).

    Parameters
    ----------
    live : LiveReadout
        A started read-out (its rate and channels are known).
    name : str
        The stream's name, what consumers resolve (``name='magcilia'``).
    source_id : str, optional
        LSL's source id (consumers re-connect to the same id after a restart); default
        ``NAME@SOURCE``.

    Attributes
    ----------
    pushed : int
        Samples pushed so far.
    lost : int
        Samples the publisher fell too far behind to push (the history's capacity).
    error : BaseException or None
        What stopped the thread, if anything but :meth:`stop`.

    Examples
    --------
    >>> with LslPublisher(live, "cilium") as outlet:  # doctest: +SKIP
    ...     time.sleep(10)
    """

    def __init__(self, live: LiveReadout, name: str = DEFAULT_NAME, *,
                 source_id: str | None = None) -> None:
        pylsl = pylsl_module()
        self.live = live
        self.info = stream_info(live, name, source_id)
        self.channels = stream_channels(live.sensor)
        self._outlet = pylsl.StreamOutlet(self.info)
        self._clock = pylsl.local_clock
        self._stop = threading.Event()
        self._thread: threading.Thread | None = None
        self._offset: float | None = None
        self.pushed = 0
        self.lost = 0
        self.error: BaseException | None = None

    def describe(self) -> str:
        """The stream in a few words: ``'magcilia' (Force, 3 channels at 1000 Hz)``."""
        info = self.info
        return (f"{info.name()!r} ({info.type()}, {info.channel_count()} channels at "
                f"{info.nominal_srate():g} Hz)")

    def start(self) -> Self:
        """Start the publishing thread (idempotent); returns the publisher."""
        if self._thread is None:
            self._thread = threading.Thread(target=self._run, name="lsl outlet", daemon=True)
            self._thread.start()
        return self

    def stop(self) -> None:
        """Push what is left, stop the thread and close the outlet (idempotent)."""
        self._stop.set()
        if self._thread is not None:
            self._thread.join()
            self._thread = None
        outlet, self._outlet = self._outlet, None
        if outlet is not None:
            with contextlib.suppress(Exception):  # consumers see the stream end
                del outlet

    def __enter__(self) -> Self:
        return self.start()

    def __exit__(self, exc_type: type[BaseException] | None, exc: BaseException | None,
                 tb: TracebackType | None) -> None:
        self.stop()

    def _run(self) -> None:
        cursor = 0
        try:
            while True:
                stopping = self._stop.is_set()
                samples, cursor, lost = self.live.history.since(cursor)
                self.lost += lost
                if len(samples.time):
                    self.push(samples)
                if stopping:
                    return
                self.live.history.wait(cursor, _TICK)
                if not self.live.running and not self._stop.is_set():
                    self._stop.wait(_TICK)
        except BaseException as exc:  # noqa: BLE001 - kept in `error`, the read-out goes on
            self.error = exc

    def push(self, samples: LiveSamples) -> None:
        """Push output samples now, time-stamped on LSL's clock (module docstring)."""
        if self._outlet is None:
            return
        t = np.asarray(samples.time, dtype=np.float64)
        if self._offset is None:
            received = float(samples.received[0]) if len(samples.received) else math.nan
            late = time.time() - received if math.isfinite(received) else 0.0
            self._offset = self._clock() - max(late, 0.0) - float(t[0])
        self._outlet.push_chunk(stream_rows(samples), (t + self._offset).tolist())
        self.pushed += len(t)
