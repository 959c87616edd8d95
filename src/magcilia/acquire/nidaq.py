"""The paper's DAQ: a National Instruments device through NI-DAQmx (``pip install
'magcilia[nidaq]'`` and NI's driver).

**Untested on hardware**: no NI device or driver was available while this was written. The
adapter is tested at its boundary (a missing driver is a one-line error; the calls it makes are
checked against a stand-in for the ``nidaqmx`` package) and follows NI's documented use: one task
with a voltage channel (range and terminal configuration), a continuous sample clock, and NI's
stream reader filling a preallocated array. Optionally a digital output line drives the HMC1021's
set/reset strap (through the datasheet's driver circuit, a rising edge gives a set pulse and a
falling edge a reset pulse): the source then alternates set and reset every ``set_reset``
samples and marks each sample with its polarity.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from magcilia import _validate as v
from magcilia._errors import AcquisitionError, require
from magcilia.acquire.source import OUTPUT, Block, Channel, Source

TERMINALS = ("default", "diff", "rse", "nrse", "pseudo_diff")


def _nidaqmx(part: str = "") -> Any:
    name = "nidaqmx" + (f".{part}" if part else "")
    return require(name, package="nidaqmx", extra="nidaq", purpose="NI-DAQmx acquisition")


def _daq_message(exc: BaseException) -> str:
    return str(exc).strip().splitlines()[0] if str(exc).strip() else type(exc).__name__


class NidaqSource(Source):
    """Continuous analog input from an NI-DAQmx device (see the module docstring).

    Parameters
    ----------
    channel : str
        Physical channel, e.g. ``"Dev1/ai0"``.
    rate : float
        Sample clock, Hz (the paper: 1000).
    voltage_range : float
        The channel's input range ±voltage_range, V (choose it just above the amplifier's
        output swing for the best resolution).
    terminal : {"default", "diff", "rse", "nrse", "pseudo_diff"}
        Terminal configuration (a bridge amplifier's single output: "rse" or "diff").
    set_reset_line : str, optional
        Digital line that drives the set/reset strap, e.g. ``"Dev1/port0/line0"``.
    set_reset : int
        Samples between set and reset pulses when ``set_reset_line`` is given.
    buffer_seconds : float
        The driver's input buffer, s of samples.
    stall : float
        Seconds a read waits beyond the samples' own duration before giving up.
    """

    def __init__(self, channel: str = "Dev1/ai0", *, rate: float = 1000.0,
                 voltage_range: float = 10.0, terminal: str = "default",
                 set_reset_line: str | None = None, set_reset: int = 1000,
                 buffer_seconds: float = 10.0, stall: float = 5.0) -> None:
        super().__init__()
        if not isinstance(channel, str) or "/" not in channel:
            raise v.fail("channel", channel, "an NI physical channel such as 'Dev1/ai0'")
        self.channel = channel
        self.rate = v.positive("rate", rate, "Hz", "frequency")
        self.voltage_range = v.positive("voltage_range", voltage_range, "V", "voltage")
        self.terminal = v.choice("terminal", terminal, TERMINALS)
        self.set_reset_line = set_reset_line
        self.set_reset = v.integer("set_reset", set_reset, 1)
        self.buffer_seconds = v.positive("buffer_seconds", buffer_seconds, "s", "duration")
        self.stall = v.positive("stall", stall, "s", "duration")
        self.channels = (Channel(OUTPUT, "V"),)
        self.realtime = True
        self.name = f"nidaq:{channel}"
        self._task: Any = None
        self._lines: Any = None
        self._reader: Any = None
        self._index = 0
        self._polarity = 1

    def _open(self) -> None:
        nidaqmx = _nidaqmx()
        constants, readers, errors = (_nidaqmx(p) for p in ("constants", "stream_readers",
                                                            "errors"))
        try:
            task = nidaqmx.Task()
        except errors.DaqNotFoundError:
            raise AcquisitionError(
                "NI-DAQmx driver not found: install NI-DAQmx from ni.com (the Python package "
                "nidaqmx is installed; on Linux: python -m nidaqmx installdriver)") from None
        try:
            task.ai_channels.add_ai_voltage_chan(
                self.channel, terminal_config=getattr(constants.TerminalConfiguration,
                                                      self.terminal.upper()),
                min_val=-self.voltage_range, max_val=self.voltage_range)
            task.timing.cfg_samp_clk_timing(
                self.rate, sample_mode=constants.AcquisitionType.CONTINUOUS,
                samps_per_chan=max(2, round(self.buffer_seconds * self.rate)))
            self._reader = readers.AnalogMultiChannelReader(task.in_stream)
            if self.set_reset_line is not None:
                self._lines = nidaqmx.Task()
                self._lines.do_channels.add_do_chan(self.set_reset_line)
                self._pulse(1)
            task.start()
        except errors.DaqError as exc:
            task.close()
            if self._lines is not None:
                self._lines.close()
                self._lines = None
            raise AcquisitionError(f"{self.name}: {_daq_message(exc)}") from None
        self._task = task
        self._index = 0

    def _close(self) -> None:
        for task in (self._task, self._lines):
            if task is not None:
                task.close()
        self._task = self._lines = self._reader = None

    def _pulse(self, polarity: int) -> None:
        """Drive the strap line: high gives a set pulse, low a reset pulse."""
        self._lines.write(polarity > 0)
        self._polarity = polarity

    def _read_into(self, out: np.ndarray) -> None:
        errors = _nidaqmx("errors")
        n = out.shape[1]
        try:
            self._reader.read_many_sample(out, number_of_samples_per_channel=n,
                                          timeout=self.stall + n / self.rate)
        except errors.DaqError as exc:
            raise AcquisitionError(f"{self.name}: {_daq_message(exc)}") from None

    def _read(self, n: int) -> Block:
        data = np.empty((1, n))
        polarity = None
        if self._lines is None:
            self._read_into(data)
        else:  # alternate set and reset every ``set_reset`` samples
            polarity = np.empty(n, dtype=np.int8)
            done = 0
            while done < n:
                in_half = (self._index + done) % self.set_reset
                if in_half == 0 and self._index + done > 0:
                    self._pulse(-self._polarity)
                take = min(n - done, self.set_reset - in_half)
                part = np.empty((1, take))
                self._read_into(part)
                data[:, done:done + take] = part
                polarity[done:done + take] = self._polarity
                done += take
        index = self._index + np.arange(n)
        self._index += n
        return Block(time=index / self.rate, data=data, channels=self.channels,
                     first=int(index[0]), setreset=polarity)

    def discard(self) -> None:
        """Read and drop what the driver has buffered."""
        if self._task is None:
            return
        waiting = int(self._task.in_stream.avail_samp_per_chan)
        if waiting:
            self._read_into(np.empty((1, waiting)))
            self._index += waiting

    def metadata(self) -> dict[str, Any]:
        """The channel's settings."""
        return {**super().metadata(), "channel": self.channel,
                "voltage_range_V": self.voltage_range, "terminal": self.terminal,
                "set_reset_line": self.set_reset_line,
                "set_reset_samples": self.set_reset if self.set_reset_line else None}
