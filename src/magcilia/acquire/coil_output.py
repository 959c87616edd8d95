"""A Helmholtz coil driven through NI-DAQmx analog outputs (``pip install 'magcilia[nidaq]'``).

**Untested on hardware**, like :mod:`magcilia.acquire.nidaq`: tested against a stand-in for the
``nidaqmx`` package. One analog-output channel per coil axis (``Dev1/ao0`` for x, ``ao1`` for y,
``ao2`` for z; fewer channels drive the first axes and a field on an undriven axis is refused)
feeds a voltage-controlled current amplifier; the **coil constant** per axis, in T per volt of
that output (the amplifier's A/V times the coil's T/A, e.g. 1 G/V = 1e-4 T/V), turns the wanted
field into the output voltage ``V = B / constant``, written on demand (a task without a sample
clock) before the step's samples. Optionally an analog-input channel per axis reads a
current-sense voltage (a shunt's or the amplifier's monitor) with its own constant in T/V: the
field recorded is then the measured one, averaged over ``sense_samples`` on-demand reads, instead
of the command.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from magcilia import _validate as v
from magcilia._errors import AcquisitionError
from magcilia.acquire.nidaq import _daq_message, _nidaqmx

F64 = NDArray[np.float64]


def _channels(name: str, spec: str | Sequence[str]) -> tuple[str, ...]:
    """``"Dev1/ao0,ao1"`` or a list -> ("Dev1/ao0", "Dev1/ao1"); at most three."""
    parts = [p.strip() for p in (spec.split(",") if isinstance(spec, str) else spec)]
    if not parts or not parts[0] or "/" not in parts[0] or len(parts) > 3 or not all(parts):
        raise v.fail(name, spec, "one to three NI channels, one per coil axis (x, y, z), e.g. "
                     "'Dev1/ao0,ao1,ao2'")
    device = parts[0].rsplit("/", 1)[0]
    return tuple(p if "/" in p else f"{device}/{p}" for p in parts)


def _constants(name: str, values: float | ArrayLike, axes: int) -> F64:
    arr = np.atleast_1d(v.finite_array(name, values, unit="T/V"))
    if arr.size == 1:
        arr = np.full(axes, float(arr[0]))
    if arr.shape != (axes,) or np.any(arr == 0.0):
        raise v.fail(name, values, f"one non-zero coil constant (T/V) or one per channel "
                     f"({axes})")
    return np.asarray(arr, dtype=np.float64)


class NidaqCoilOutput:
    """A coil's field set through NI analog outputs (see the module docstring).

    Parameters
    ----------
    channels : str or sequence of str
        Analog outputs for x[, y[, z]], e.g. ``"Dev1/ao0,ao1,ao2"``.
    constant : float or array-like, shape (axes,)
        Field per output volt of each axis, T/V (signed: the coil's polarity).
    voltage_range : float
        The outputs' range ±voltage_range, V; a field needing more is refused.
    sense : str or sequence of str, optional
        Analog inputs reading each axis's current-sense voltage, e.g. ``"Dev1/ai1,ai2,ai3"``.
    sense_constant : float or array-like, optional
        Field per sense volt of each axis, T/V (needed with ``sense``).
    sense_samples : int
        On-demand reads averaged per measured field.
    """

    def __init__(self, channels: str | Sequence[str], constant: float | ArrayLike, *,
                 voltage_range: float = 10.0, sense: str | Sequence[str] | None = None,
                 sense_constant: float | ArrayLike | None = None,
                 sense_samples: int = 10) -> None:
        self.channels = _channels("coil output", channels)
        self.constant = _constants("coil constant", constant, len(self.channels))
        self.voltage_range = v.positive("voltage_range", voltage_range, "V", "voltage")
        self.sense = None if sense is None else _channels("coil current sense", sense)
        if self.sense is not None and len(self.sense) != len(self.channels):
            raise v.fail("coil current sense", sense, f"one channel per output "
                         f"({len(self.channels)})")
        if (self.sense is None) != (sense_constant is None):
            raise v.fail("coil sense constant", sense_constant,
                         "given with a current-sense channel (and only then)")
        self.sense_constant = (None if sense_constant is None else
                               _constants("coil sense constant", sense_constant,
                                          len(self.channels)))
        self.sense_samples = v.integer("sense_samples", sense_samples, 1)
        self._out: Any = None
        self._in: Any = None

    def volts(self, field: ArrayLike) -> F64:
        """The output voltages, V, shape (axes,), for the field (3,), T; refuses a field on an
        undriven axis or beyond the outputs' range."""
        b = v.vector3("field", field, "T")
        axes = len(self.channels)
        if np.any(b[axes:] != 0.0):
            raise v.fail("coil field", b.tolist(), f"zero on the axes without an output "
                         f"(this coil drives {'xyz'[:axes]})")
        out = b[:axes] / self.constant
        if np.any(np.abs(out) > self.voltage_range):
            raise v.fail("coil field", b.tolist(), f"within the outputs' ±{self.voltage_range:g}"
                         " V at the coil constant given")
        return np.asarray(out, dtype=np.float64)

    def open(self) -> NidaqCoilOutput:
        """Create the output (and sense) tasks."""
        if self._out is not None:
            return self
        nidaqmx, errors = _nidaqmx(), _nidaqmx("errors")
        try:
            self._out = nidaqmx.Task()
            for ch in self.channels:
                self._out.ao_channels.add_ao_voltage_chan(ch, min_val=-self.voltage_range,
                                                          max_val=self.voltage_range)
            if self.sense is not None:
                self._in = nidaqmx.Task()
                for ch in self.sense:
                    self._in.ai_channels.add_ai_voltage_chan(ch)
        except errors.DaqError as exc:
            self.close()
            raise AcquisitionError(f"coil output {self.channels[0]}: {_daq_message(exc)}"
                                   ) from None
        return self

    def set_field(self, field: ArrayLike) -> F64:
        """Write the outputs for ``field`` (3,), T; the field applied (measured with ``sense``,
        else the command), T, shape (3,)."""
        out = self.volts(field)
        self.open()
        errors = _nidaqmx("errors")
        try:
            self._out.write(out.tolist() if out.size > 1 else float(out[0]), auto_start=True)
            if self._in is None:
                applied = np.zeros(3)
                applied[:out.size] = out * self.constant
                return applied
            raw = np.asarray(self._in.read(number_of_samples_per_channel=self.sense_samples),
                             dtype=np.float64).reshape(len(self.channels), -1)
        except errors.DaqError as exc:
            raise AcquisitionError(f"coil output {self.channels[0]}: {_daq_message(exc)}"
                                   ) from None
        assert self.sense_constant is not None
        measured = np.zeros(3)
        measured[:raw.shape[0]] = raw.mean(axis=1) * self.sense_constant
        return measured

    def close(self) -> None:
        """Close the tasks (the outputs keep their last value: :func:`record_coil` writes zero
        first)."""
        for task in (self._out, self._in):
            if task is not None:
                task.close()
        self._out = self._in = None

    def metadata(self) -> dict[str, Any]:
        """The coil's channels and constants, for the recording."""
        return {"coil_output": ",".join(self.channels),
                "coil_constant_T_per_V": self.constant.tolist(),
                "coil_sense": None if self.sense is None else ",".join(self.sense),
                "coil_sense_constant_T_per_V": None if self.sense_constant is None else
                self.sense_constant.tolist()}
