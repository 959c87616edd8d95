"""What ``magcilia live`` and ``magcilia dashboard`` share: their options and the read-out they
build from them (how they end: :mod:`magcilia.cli._signals`)."""

from __future__ import annotations

import functools
import logging
import math
from collections.abc import Callable
from pathlib import Path
from typing import Any

import click
import numpy as np

from magcilia._validate import fail
from magcilia.acquire import (
    LoadScript,
    Script,
    SimulatedFieldSource,
    SimulatedSource,
    Source,
    single_cilium,
    source_from_spec,
)
from magcilia.acquire.serial_formats import SerialFormat
from magcilia.acquire.simulated_loads import field_channels
from magcilia.calibration import ParameterCovariance
from magcilia.cli._common import Physical, load_mechanics_setup, mechanics_options, setup_option
from magcilia.cli._options import SEED, serial_format_options
from magcilia.cli._outputs import OUTPUT_FILE
from magcilia.cli._readout_inputs import parse_span
from magcilia.cli._readout_vectors import element_magnetometer, magnitude_span
from magcilia.cli._thermal import setup_temperature, temperature_option, temperature_profile
from magcilia.cli.array import DEFAULT_SPAN
from magcilia.design import design_metrics
from magcilia.device.magnetometer import MAGNETOMETERS
from magcilia.device.setup import Setup
from magcilia.device.temperature import TemperatureProfile
from magcilia.io import presets
from magcilia.io.array_file import is_array_file, load_array
from magcilia.live import LiveReadout
from magcilia.mechanics import AIR, FLUIDS, Flow
from magcilia.readout import (
    ArrayReadout,
    BiaxialReadout,
    DynamicReadout,
    Readout,
    field_for_loads,
)
from magcilia.readout.thermal import ThermalReadout

logger = logging.getLogger(__name__)

#: the simulated cilium's script, as fractions of the range: (seconds, fraction), repeated
DEMO_STEPS = ((3.0, 0.0), (2.0, 0.5), (2.0, 0.0), (2.0, -0.3), (1.0, 0.0), (2.0, 0.8))
#: the simulated field sources' constant field (the Earth's and the lab's, board frame), T, and
#: their slow drift, T/s: 0.4 G, and 1 µG/s (a tenth of an MMC5983MA's noise per minute)
SIM_BIAS = (2e-5, -1e-5, -3.3e-5)
SIM_DRIFT = (1e-10, -0.5e-10, 1e-10)
#: the single-axis defaults of --rate and --source-rate, Hz (a 3-axis part: its own rate)
RATE, SOURCE_RATE = 1000.0, 10000.0
#: the default --rate of an array, Hz (at most its parts' rate): its inverse solves every
#: window (for the 16 cilia of examples/array.toml 1.7 ms median, 3.7 ms p99 on one core:
#: benchmarks/bench_live_vectors.py, the README), so that 50 Hz keeps a core less than half busy
ARRAY_RATE = 50.0


def demo_script(quantity: str, amplitude: float) -> Script:
    """What the simulated cilium does for ``--source sim``: rest, pushes of 50 %, −30 % and 80 %
    of ``amplitude`` (SI) between rests, repeated every 12 s."""
    starts = np.cumsum([0.0] + [s for s, _ in DEMO_STEPS[:-1]])
    period = sum(s for s, _ in DEMO_STEPS)
    levels = np.array([f for _, f in DEMO_STEPS]) * amplitude

    def value(t: np.ndarray) -> np.ndarray:
        return levels[np.searchsorted(starts, np.mod(t, period), side="right") - 1]

    return Script.from_function(value, quantity)


def live_span(setup: Setup, quantity: str, flow: Flow) -> tuple[float, float]:
    """The default span: ± the design range of ``quantity`` (to the sensor's range, a fold or
    the end of the sweep; :func:`magcilia.design_metrics`)."""
    metric = getattr(design_metrics(setup, fluid=flow.fluid), quantity)
    if not (math.isfinite(metric.range) and metric.range > 0):
        raise fail("--span", "the default", f"given explicitly: the {quantity} range of this "
                   f"setup is not available ({metric.limited_by})")
    return -metric.range, metric.range


def live_options(command: Any) -> Any:
    """The options of a live read-out (source, setup, quantity, span, rates, tare)."""
    options: list[Callable[[Any], Any]] = [
        click.option("--source", "source_spec", default="sim", show_default=True,
                     help="sim (a simulated sensor pushed in a repeating pattern; a 3-axis "
                          "sensor or an array by tip forces in changing directions), "
                          "serial:PORT (magcilia's framed protocol; --format ascii|floats for "
                          "firmware without it), nidaq:DEV/aiN, or "
                          "FILE.tdms: a recording of --record (any sensor), replayed with its "
                          "stored setup, span, calibration, tares and zero tracking (as fast as "
                          "it goes when stdout is not a terminal, in real time otherwise; the "
                          "other read-out options are ignored)."),
        serial_format_options,
        click.option("--record", "record_path", default=None, type=OUTPUT_FILE,
                     help="Record from the first sample into this TDMS file (an existing one "
                          "only with --force): raw samples, read-out values, events, tares and "
                          "what a replay (--source FILE.tdms) needs."),
        click.option("--force", is_flag=True,
                     help="Replace an existing --record file."),
        setup_option("The (fitted) sensor setup (force-sensor: the paper's cilium with a 0.05 mm "
                     "tip radius; an array setup file ([array], or [[cilia]] and [[sensors]]) "
                     "or the array preset reads one force vector per cilium)",
                     default="force-sensor", positional=False),
        click.option("--sensor", "sensor_name", default=None,
                     type=click.Choice(sorted(MAGNETOMETERS), case_sensitive=False),
                     help="A 3-axis magnetometer preset at the element (its axes along the "
                          "board's x, y, z): read the tip force vector (Fx, Fy) instead of one "
                          "output."),
        click.option("--sensor-noise", "sensor_noise", default=None, metavar="B or BX,BY,BZ",
                     help="With --sensor: RMS noise of one reading per axis, gauss or with a "
                          "unit (2mG, or 2mG,2mG,3mG); required for the MLX90393 and TLV493D."),
        click.option("--quantity", type=click.Choice(["angle", "force", "flow"]),
                     default="force", show_default=True,
                     help="What to estimate: tilt angle (deg), tip force (mN) or flow speed "
                          "(m/s)."),
        click.option("--span", "span_text", default=None,
                     help="Read-out range LO:HI in deg, mN or m/s, or with units (0:0.2mN, "
                          "-0.1mN:100uN); default ± the design range (to the sensor's range or a "
                          "fold). A force vector or an array: the largest magnitude, HIGH or "
                          "0:HIGH (default: the design range; an array 0.02 mN)."),
        click.option("--calibration", "calibration_path", type=click.Path(),
                     help="result.json (or folder) of `magcilia calibrate`: adds its parameter "
                          "uncertainty to sigma."),
        click.option("--fluid", type=click.Choice(sorted(FLUIDS)), default="water",
                     show_default=True, help="Fluid for --quantity flow."),
        click.option("--rate", default=None, type=Physical.of("frequency", "1kHz"),
                     help="Read-out samples per second: Hz, or with a unit (1kHz; each averages "
                          "source rate / rate samples). Default 1 kHz; a 3-axis sensor: the "
                          "part's output data rate; an array: 50 Hz (at most its parts' rate)."),
        click.option("--source-rate", default=None, type=Physical.of("frequency", "10kHz"),
                     help="Sample rate of sim and nidaq sources: Hz, or with a unit (a serial "
                          "device sends its own). Default 10 kHz; a simulated 3-axis sensor or "
                          "array: the part's output data rate."),
        click.option("--channel", default="output", show_default=True,
                     help="The source's channel that carries the sensor output."),
        click.option("--set-reset", "set_reset", default=None, type=int,
                     help="sim: alternate set/reset pulses every N samples (demodulated)."),
        click.option("--no-tare", is_flag=True,
                     help="Do not tare on the first 0.5 s (the cilium must be unloaded then)."),
        click.option("--tracking", default="30", show_default=True,
                     type=Physical.of("time", "30s"),
                     help="Zero-tracking time constant after a tare: s, or with a unit (0: off)."),
        click.option("--record-dir", default="recordings", show_default=True,
                     type=click.Path(file_okay=False),
                     help="Where recordings started from the view go (live-DATE-TIME.tdms)."),
        click.option("--seed", type=SEED, default=0, show_default=True,
                     help="Seed of the simulation."),
        click.option("--dynamic", is_flag=True,
                     help="The dynamic read-out (a Kalman filter on the hair's bending modes, "
                          "magcilia.DynamicReadout): a step reads within about a period instead "
                          "of ringing, its noise and sigma stated; one output only (the hair in "
                          "air for a force or an angle, in --fluid for a flow; --rate above "
                          "twice its first mode). With --source sim the simulated hair moves "
                          "too."),
        click.option("--recalibrate", default=None, type=Physical.of("time", "5s"),
                     help="In-use re-calibration every this many s (sim, a force): the "
                          "simulated coil fires a 5 G, 50 ms pulse, along x and y in turn, the "
                          "strap alternates (--set-reset 10 unless given) and the simulated "
                          "sensor drifts (sensitivity and magnetization −0.6 %/min); the pulses "
                          "re-estimate offset, sensitivity and magnetization, their readings "
                          "are flagged COIL PULSE (no value), and the status says when it last "
                          "re-calibrated and what changed."),
        click.option("--sim-dynamics", "sim_dynamics", is_flag=True,
                     help="sim: the simulated hair moves through its bending modes (rings in "
                          "air, lags in water) instead of sitting at each load's equilibrium."),
        temperature_option,
        mechanics_options,
    ]
    for option in reversed(options):
        command = option(command)
    return command


LIVE_KEYS = ("source_spec", "setup_arg", "quantity", "span_text", "calibration_path", "fluid",
             "rate", "source_rate", "channel", "set_reset", "no_tare", "tracking", "record_dir",
             "seed", "tip_radius", "modulus", "sensor_name", "sensor_noise", "record_path",
             "dynamic", "sim_dynamics", "recalibrate", "serial", "temperature")


def build_live(*, source_spec: str, setup_arg: str, quantity: str, span_text: str | None,
               calibration_path: str | None, fluid: str, rate: float | None,
               source_rate: float | None, channel: str, set_reset: int | None, no_tare: bool,
               tracking: float, seed: int, tip_radius: str | None, modulus: str | None,
               sensor_name: str | None = None, sensor_noise: str | None = None,
               record_path: str | None = None, replay_realtime: bool | None = None,
               dynamic: bool = False,
               sim_dynamics: bool = False, recalibrate: float | None = None,
               serial: SerialFormat | None = None, temperature: str | None = None,
               duration: float | None = None, **_: Any) -> LiveReadout:
    """The live read-out the options describe (not started): one output of a single-axis
    sensor; the force vector of a 3-axis sensor (``--sensor``); every cilium's force vector of an
    array (an array setup file or preset). A ``.tdms`` source is a replay, in real time with
    ``replay_realtime`` (None: when stdout is a terminal). ``dynamic``: the single output read
    by :class:`~magcilia.readout.dynamic.DynamicReadout` (and a simulated hair that moves);
    ``sim_dynamics``: a simulated hair that moves (:class:`SimulatedSource`'s ``dynamics``);
    ``serial``: what a ``serial:PORT`` device sends (ASCII lines and float frames at
    ``source_rate``, which they do not carry); ``temperature``: the simulated sensor's
    temperature (``--temperature``, a ramp over ``duration``), read by
    :class:`~magcilia.ThermalReadout` with the setup's coefficients."""
    logger.info("setting up the live read-out: setup %s, source %s", setup_arg, source_spec)
    serial = SerialFormat() if serial is None else serial
    if not serial.verified and source_rate is None:
        raise fail("--source-rate", None, f"the device's sample rate (Hz) with --format "
                   f"{serial.format}: the format does not carry it")
    if source_spec.lower().endswith(".tdms"):
        return replay_live(source_spec, record_path, replay_realtime)
    if tracking < 0:
        raise fail("--tracking", tracking, "a time constant ≥ 0 s (0: off)")
    if sensor_noise is not None and sensor_name is None:
        raise fail("--sensor-noise", sensor_noise, "given with --sensor only")
    array_file = presets.file(setup_arg) if setup_arg in presets.NAMES else setup_arg
    array = array_file is not None and is_array_file(array_file)
    if array:
        setup_arg = str(array_file)
    if array or sensor_name is not None:
        for name, value, default in (("--quantity", quantity, "force"),
                                     ("--channel", channel, "output"),
                                     ("--calibration", calibration_path, None),
                                     ("--set-reset", set_reset, None),
                                     ("--dynamic", dynamic, False),
                                     ("--sim-dynamics", sim_dynamics, False),
                                     ("--temperature", temperature, None)):
            if value != default:
                what = "an array" if array else "a 3-axis sensor (--sensor)"
                raise fail(name, value, f"left out for {what}: it reads force vectors from "
                           "its parts' field channels")
        field: tuple[ArrayReadout | BiaxialReadout, Source, float] = (
            _array(setup_arg, span_text, sensor_name, tip_radius, modulus, source_spec,
                   source_rate, seed, serial) if array else
            _vector(setup_arg, span_text, sensor_name or "", sensor_noise, tip_radius, modulus,
                    source_spec, source_rate, seed, serial))
        return LiveReadout(field[1], field[0], rate=field[2] if rate is None else rate,
                           tare_at_start=not no_tare, tracking=tracking or None,
                           record=record_path)
    setup = load_mechanics_setup(setup_arg, tip_radius, modulus)
    flow = Flow.uniform(1.0, FLUIDS[fluid])
    span = parse_span(span_text, quantity) if span_text else live_span(setup, quantity, flow)
    covariance = ParameterCovariance.load(calibration_path) if calibration_path else None
    static = Readout(setup, quantity=quantity, span=span, calibration=covariance,
                     flow=flow if quantity == "flow" else None)
    readout: Readout | DynamicReadout | ThermalReadout = static
    profile = _temperature(temperature, duration, source_spec, dynamic, recalibrate)
    thermal = None if profile is None else setup_temperature(setup_arg)
    source: Source
    source_rate = SOURCE_RATE if source_rate is None else source_rate
    rate = RATE if rate is None else rate
    hair_fluid = flow.fluid if quantity == "flow" else AIR  # around the hair, for its dynamics
    if source_spec != "sim" and sim_dynamics:
        raise fail("--sim-dynamics", True, "given with --source sim only")
    if dynamic:  # each reading: the mean of the source's samples in its window (the
        # pipeline's: source rate / a whole number of samples; a serial device's own rate is
        # known once it sends, so the rate asked for is taken)
        known = not source_spec.startswith("serial")
        factor = max(1, round(source_rate / rate)) if known else 2
        readout = DynamicReadout(static, source_rate / factor if known else rate,
                                 fluid=hair_fluid, averaged=factor > 1)
    if recalibrate is not None:
        source, recal = _recalibrating(setup, quantity, span, source_spec, source_rate, seed,
                                       set_reset, recalibrate, dynamic or sim_dynamics)
        return LiveReadout(source, readout, rate=rate, channel=channel, record=record_path,
                           tare_at_start=not no_tare, tracking=tracking or None,
                           recalibration=recal)
    if source_spec == "sim":
        amplitude = 0.8 * max(abs(span[0]), abs(span[1]))
        source = SimulatedSource(setup, demo_script(quantity, amplitude), rate=source_rate,
                                 realtime=True, rng=seed, set_reset=set_reset, bias=3e-4,
                                 readout_noise=2e-5, drift=2e-7,
                                 flow=flow if quantity == "flow" else None,
                                 dynamics=dynamic or sim_dynamics, fluid=hair_fluid,
                                 temperature=profile, thermal=thermal)
        readout = readout if thermal is None else ThermalReadout(static, thermal)
    else:
        source = source_from_spec(source_spec, setup=setup, rate=source_rate, rng=seed,
                                  set_reset=set_reset, realtime=True, serial=serial)
    return LiveReadout(source, readout, rate=rate, channel=channel,
                       tare_at_start=not no_tare, tracking=tracking or None,
                       record=record_path)


def _temperature(text: str | None, duration: float | None, source_spec: str, dynamic: bool,
                 recalibrate: float | None) -> TemperatureProfile | None:
    """``--temperature``: the simulated sensor's temperature (None without), checked against
    the options it cannot go with."""
    profile = temperature_profile(text, duration)
    if profile is None:
        return None
    if source_spec != "sim":
        raise fail("--temperature", text, "given with --source sim only (a device's temperature "
                                          "comes from its own channel)")
    for name, value in (("--dynamic", dynamic), ("--recalibrate", recalibrate)):
        if value:
            raise fail("--temperature", text, f"left out with {name} (the temperature "
                       "compensation reads one static output)")
    return profile


def _recalibrating(setup: Setup, quantity: str, span: tuple[float, float], spec: str,
                   source_rate: float, seed: int, set_reset: int | None, every: float,
                   moving: bool) -> tuple[Source, Any]:
    """``--recalibrate EVERY``: the simulated coil's source (pulses, strap, drifts) and the
    read-out's re-calibration (:mod:`magcilia.live.recalibrating`)."""
    from magcilia.acquire.simulated_coil import CoilPulses, Drifts, SimulatedCoilSource
    from magcilia.live.recalibrating import LiveRecalibration
    from magcilia.readout.recalibration import Recalibrator
    from magcilia.readout.recalibration_stream import PulseTracker

    for name, value, allowed in (("--source", spec, "sim"), ("--quantity", quantity, "force"),
                                 ("--dynamic/--sim-dynamics", moving, False)):
        if value != allowed:
            raise fail(name, value, f"{allowed} with --recalibrate (the simulated coil pulses a "
                       "static hair under a tip force)")
    if not every > 0.1:
        raise fail("--recalibrate", every, "a period above 0.1 s (a pulse and its brackets)")
    amplitude = 0.8 * max(abs(span[0]), abs(span[1]))
    source = SimulatedCoilSource(
        setup, demo_script("force", amplitude), rate=source_rate, realtime=True, rng=seed,
        set_reset=10 if set_reset is None else set_reset, readout_noise=2e-5,
        pulses=CoilPulses(every=every, duration=min(0.05, every / 4), start=every + 0.5),
        drifts=Drifts(sensitivity=-1e-4, magnetization=-1e-4))
    tracker = PulseTracker(Recalibrator(setup, span=span), before=min(0.05, every / 4))
    return source, LiveRecalibration(tracker)


def replay_live(path: str, record_path: str | None, realtime: bool | None) -> LiveReadout:
    """``--source FILE.tdms``: the recording replayed (:func:`magcilia.live.replay.replay`), its
    whole read-out kept for the views when it runs as fast as it goes."""
    import sys

    from magcilia.live.replay import replay

    if record_path is not None:
        raise fail("--record", record_path, "left out with a recorded --source (the recording "
                   "is there already)")
    if not Path(path).is_file():
        raise fail("--source", path, "an existing recording (.tdms) of magcilia live --record")
    realtime = sys.stdout.isatty() if realtime is None else realtime
    return replay(path, realtime=realtime)


def _field_source(spec: str, sensors: Any, field: Any, cilia: int, span: float,
                  source_rate: float | None, seed: int, setup: Setup,
                  serial: SerialFormat | None = None) -> Source:
    """``--source`` of a 3-axis sensor or an array: the simulation pushes every cilium to 80 %
    of the span in changing directions (:meth:`LoadScript.demo`)."""
    if spec == "sim":
        return SimulatedFieldSource(sensors, field, LoadScript.demo(cilia, 0.8 * span),
                                    rate=source_rate, drift=SIM_DRIFT, bias=SIM_BIAS,
                                    realtime=True, rng=seed)
    return source_from_spec(spec, setup=setup, rate=source_rate or SOURCE_RATE, rng=seed,
                            realtime=True, serial=serial, names=field_channels(sensors))


def _vector(setup_arg: str, span_text: str | None, sensor_name: str, sensor_noise: str | None,
            tip_radius: str | None, modulus: str | None, spec: str, source_rate: float | None,
            seed: int, serial: SerialFormat | None = None) -> tuple[BiaxialReadout, Source, float]:
    """The force-vector read-out of a 3-axis part at the element, its source and the part's
    rate (Hz)."""
    setup = load_mechanics_setup(setup_arg, tip_radius, modulus)
    part = element_magnetometer(sensor_name, sensor_noise)
    span = magnitude_span(span_text, "--sensor") if span_text else \
        live_span(setup, "force", Flow.uniform(1.0, FLUIDS["water"]))[1]
    readout = BiaxialReadout(setup, part, span)
    return readout, _field_source(spec, part, single_cilium(setup, part), 1, span, source_rate,
                                  seed, setup, serial), part.rate


def _array(setup_arg: str, span_text: str | None, sensor_name: str | None,
           tip_radius: str | None, modulus: str | None, spec: str, source_rate: float | None,
           seed: int, serial: SerialFormat | None = None) -> tuple[ArrayReadout, Source, float]:
    """The array read-out of an array setup file, its source and its slowest part's rate
    (Hz)."""
    for name, value in (("--sensor", sensor_name), ("--tip-radius", tip_radius),
                        ("--modulus", modulus)):
        if value is not None:
            raise fail(name, value, f"left out with an array setup file ({setup_arg} names "
                       "its parts and cilia)")
    array = load_array(setup_arg)
    span = magnitude_span(span_text, "an array") if span_text else DEFAULT_SPAN
    readout = ArrayReadout(array, span)
    source = _field_source(spec, array.sensors, functools.partial(field_for_loads, array),
                           len(array), span, source_rate, seed, array.cilia[0], serial)
    return readout, source, min(ARRAY_RATE, *(s.rate for s in array.sensors))
