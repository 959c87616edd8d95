"""Acquisition: sources of samples, background reading, recordings and the calibration sweep.

* :mod:`.source`: the protocol every source follows (:class:`Source`, :class:`Block`);
* :mod:`.simulated`: a simulated sensor driven by a scripted pose (:class:`SimulatedSource`);
* :mod:`.simulated_loads`: a simulated 3-axis sensor or array driven by scripted tip forces
  (:class:`SimulatedFieldSource`, :class:`LoadScript`);
* :mod:`.buffer`: a reader thread filling a bounded ring buffer (:class:`BackgroundReader`);
* :mod:`.serial`: a microcontroller streaming magcilia's framed protocol (:class:`SerialSource`);
  :mod:`.serial_unverified`: firmware printing ASCII lines or bare float32 frames without a
  checksum (:class:`UnverifiedSerialSource`, the formats in :mod:`.serial_formats`);
  :mod:`.protocol` the frames, :mod:`.emulator` a device on a pseudo-terminal for tests;
* :mod:`.replay`: a magcilia TDMS recording played back as a source (:class:`ReplaySource`);
* :mod:`.nidaq`: the paper's NI DAQ through NI-DAQmx (:class:`NidaqSource`; untested on hardware);
* :mod:`.photo`: tilt angles from photos of the holder (:func:`measure_tilt`), with
  :mod:`.stripes` finding the tape and the case edge;
* :mod:`.sweep`: the guided calibration sweep into a crash-safe recording (:func:`record_sweep`);
* :mod:`.coil`: the coil calibration sweep (:func:`record_coil`, :class:`CoilSequence`) on
  :mod:`.simulated_coil` (:class:`SimulatedCoilSource`: the applied field, pulses, drifts) or an
  NI analog output per axis (:mod:`.coil_output`, :class:`NidaqCoilOutput`);
* :mod:`.stream`: continuous recording through the ring buffer (:func:`record_stream`);
* :mod:`.connect`: sources by name (``sim``, ``serial:PORT``, ``nidaq:DEV/ai0``);
* :mod:`.synthetic`: whole synthetic recordings of the paper's experiment in one call.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from magcilia._lazy import attach

if TYPE_CHECKING:
    from magcilia.acquire.buffer import BackgroundReader, RingBuffer
    from magcilia.acquire.coil import CoilPoint, CoilResult, CoilSequence, record_coil
    from magcilia.acquire.coil_output import NidaqCoilOutput
    from magcilia.acquire.connect import source_from_spec
    from magcilia.acquire.emulator import DeviceEmulator
    from magcilia.acquire.nidaq import NidaqSource
    from magcilia.acquire.photo import TiltMeasurement, measure_tilt, read_photo
    from magcilia.acquire.replay import ReplaySource
    from magcilia.acquire.serial import SerialSource
    from magcilia.acquire.serial_formats import SerialFormat
    from magcilia.acquire.serial_unverified import UnverifiedSerialSource
    from magcilia.acquire.simulated import Script, SimulatedSource
    from magcilia.acquire.simulated_coil import CoilPulses, Drifts, SimulatedCoilSource
    from magcilia.acquire.simulated_loads import LoadScript, SimulatedFieldSource, single_cilium
    from magcilia.acquire.source import OUTPUT, Block, Channel, Counters, Source
    from magcilia.acquire.stream import StreamResult, record_stream
    from magcilia.acquire.sweep import SweepPoint, SweepResult, record_sweep
    from magcilia.acquire.synthetic import Recording, synthetic_recording

__all__ = [
    "OUTPUT",
    "BackgroundReader",
    "Block",
    "Channel",
    "CoilPoint",
    "CoilPulses",
    "CoilResult",
    "CoilSequence",
    "Counters",
    "DeviceEmulator",
    "Drifts",
    "LoadScript",
    "NidaqCoilOutput",
    "NidaqSource",
    "Recording",
    "ReplaySource",
    "RingBuffer",
    "Script",
    "SerialFormat",
    "SerialSource",
    "SimulatedCoilSource",
    "SimulatedFieldSource",
    "SimulatedSource",
    "Source",
    "StreamResult",
    "SweepPoint",
    "SweepResult",
    "TiltMeasurement",
    "UnverifiedSerialSource",
    "measure_tilt",
    "read_photo",
    "record_coil",
    "record_stream",
    "record_sweep",
    "single_cilium",
    "source_from_spec",
    "synthetic_recording",
]

__getattr__, __dir__ = attach(__name__)
