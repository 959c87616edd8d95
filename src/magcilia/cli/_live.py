"""What ``magcilia live`` and ``magcilia dashboard`` share: their options and the read-out they
build from them (how they end: :mod:`magcilia.cli._signals`)."""

from __future__ import annotations

import logging
import math
from typing import Any

import click
import numpy as np

from magcilia._validate import fail
from magcilia.acquire import Script, SimulatedSource, Source, source_from_spec
from magcilia.calibration import ParameterCovariance
from magcilia.cli._common import Physical, load_mechanics_setup, mechanics_options, setup_option
from magcilia.cli.readout import parse_span
from magcilia.design import design_metrics
from magcilia.device.setup import Setup
from magcilia.live import LiveReadout
from magcilia.mechanics import FLUIDS, Flow
from magcilia.readout import Readout

logger = logging.getLogger(__name__)

#: the simulated cilium's script, as fractions of the range: (seconds, fraction), repeated
DEMO_STEPS = ((3.0, 0.0), (2.0, 0.5), (2.0, 0.0), (2.0, -0.3), (1.0, 0.0), (2.0, 0.8))


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
    options = [
        click.option("--source", "source_spec", default="sim", show_default=True,
                     help="sim (a simulated sensor pushed in a repeating pattern), serial:PORT "
                          "(magcilia's framed protocol), nidaq:DEV/aiN, or FILE.tdms: a "
                          "recording of --record, replayed with its stored setup, span, "
                          "calibration, tares and zero tracking (as fast as it goes when "
                          "stdout is not a terminal, in real time otherwise; the other "
                          "read-out options are ignored)."),
        click.option("--record", "record_path", default=None, type=click.Path(dir_okay=False),
                     help="Record from the first sample into this TDMS file (replaced if it "
                          "exists): raw samples, read-out values, events, tares and what a "
                          "replay (--source FILE.tdms) needs."),
        setup_option("The (fitted) sensor setup (force-sensor: the paper's cilium with a 0.05 mm "
                     "tip radius)", default="force-sensor", positional=False),
        click.option("--quantity", type=click.Choice(["angle", "force", "flow"]),
                     default="force", show_default=True,
                     help="What to estimate: tilt angle (deg), tip force (mN) or flow speed "
                          "(m/s)."),
        click.option("--span", "span_text", default=None,
                     help="Read-out range LO:HI in deg, mN or m/s, or with units (0:0.2mN, "
                          "-0.1mN:100uN); default ± the design range (to the sensor's range or a "
                          "fold)."),
        click.option("--calibration", "calibration_path", type=click.Path(),
                     help="result.json (or folder) of `magcilia calibrate`: adds its parameter "
                          "uncertainty to sigma."),
        click.option("--fluid", type=click.Choice(sorted(FLUIDS)), default="water",
                     show_default=True, help="Fluid for --quantity flow."),
        click.option("--rate", default="1000", show_default=True,
                     type=Physical.of("frequency", "1kHz"),
                     help="Read-out samples per second: Hz, or with a unit (1kHz; each averages "
                          "source rate / rate samples)."),
        click.option("--source-rate", default="10000", show_default=True,
                     type=Physical.of("frequency", "10kHz"),
                     help="Sample rate of sim and nidaq sources: Hz, or with a unit (a serial "
                          "device sends its own)."),
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
        click.option("--seed", default=0, show_default=True, help="Seed of the simulation."),
        mechanics_options,
    ]
    for option in reversed(options):
        command = option(command)
    return command


LIVE_KEYS = ("source_spec", "setup_arg", "quantity", "span_text", "calibration_path", "fluid",
             "rate", "source_rate", "channel", "set_reset", "no_tare", "tracking", "record_dir",
             "seed", "tip_radius", "modulus", "record_path")


def build_live(*, source_spec: str, setup_arg: str, quantity: str, span_text: str | None,
               calibration_path: str | None, fluid: str, rate: float, source_rate: float,
               channel: str, set_reset: int | None, no_tare: bool, tracking: float,
               seed: int, tip_radius: str | None, modulus: str | None,
               record_path: str | None = None, replay_realtime: bool | None = None,
               **_: Any) -> LiveReadout:
    """The live read-out the options describe (not started); a ``.tdms`` source is a replay,
    in real time with ``replay_realtime`` (None: when stdout is a terminal)."""
    logger.info("setting up the live read-out: setup %s, source %s", setup_arg, source_spec)
    if source_spec.lower().endswith(".tdms"):
        return replay_live(source_spec, record_path, replay_realtime)
    setup = load_mechanics_setup(setup_arg, tip_radius, modulus)
    flow = Flow.uniform(1.0, FLUIDS[fluid])
    span = parse_span(span_text, quantity) if span_text else live_span(setup, quantity, flow)
    covariance = ParameterCovariance.load(calibration_path) if calibration_path else None
    readout = Readout(setup, quantity=quantity, span=span, calibration=covariance,
                      flow=flow if quantity == "flow" else None)
    if tracking < 0:
        raise fail("--tracking", tracking, "a time constant ≥ 0 s (0: off)")
    source: Source
    if source_spec == "sim":
        amplitude = 0.8 * max(abs(span[0]), abs(span[1]))
        source = SimulatedSource(setup, demo_script(quantity, amplitude), rate=source_rate,
                                 realtime=True, rng=seed, set_reset=set_reset, bias=3e-4,
                                 readout_noise=2e-5, drift=2e-7,
                                 flow=flow if quantity == "flow" else None)
    else:
        source = source_from_spec(source_spec, setup=setup, rate=source_rate, rng=seed,
                                  set_reset=set_reset, realtime=True)
    return LiveReadout(source, readout, rate=rate, channel=channel, tare_at_start=not no_tare,
                       tracking=tracking or None, record=record_path)


def replay_live(path: str, record_path: str | None, realtime: bool | None) -> LiveReadout:
    """``--source FILE.tdms``: the recording replayed (:func:`magcilia.live.replay.replay`), its
    whole read-out kept for the views when it runs as fast as it goes."""
    import sys
    from pathlib import Path

    from magcilia.live.replay import replay

    if record_path is not None:
        raise fail("--record", record_path, "left out with a recorded --source (the recording "
                   "is there already)")
    if not Path(path).is_file():
        raise fail("--source", path, "an existing recording (.tdms) of magcilia live --record")
    realtime = sys.stdout.isatty() if realtime is None else realtime
    return replay(path, realtime=realtime)

