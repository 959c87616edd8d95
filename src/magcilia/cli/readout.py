"""``magcilia readout``: estimate angle, force or flow speed from a voltage recording."""

from __future__ import annotations

import sys
from pathlib import Path

import click
import numpy as np
from tqdm import tqdm

from magcilia._errors import MagciliaError
from magcilia._validate import fail
from magcilia.calibration import ParameterCovariance
from magcilia.cli._common import (
    RecordingArgs,
    bandwidth_option,
    echo_json,
    load_mechanics_setup,
    mechanics_options,
    parse_bandwidth,
    quiet_requested,
    recording_options,
    si_option,
)
from magcilia.device.parameters import MEASURANDS
from magcilia.io.recordings import read_samples
from magcilia.mechanics import FLUIDS, Flow
from magcilia.readout.inverse import EDGES, Readout
from magcilia.report.readout import readout_line, readout_summary, write_readout_csv
from magcilia.units import parse_quantity, parse_value, parse_values

#: readings from which a read-out shows a progress bar (about a second of work)
PROGRESS_READINGS = 2_000_000


def parse_span(text: str, quantity: str) -> tuple[float, float]:
    """``LO:HI`` in the display unit (deg, mN, m/s), or with units on each end or the last
    (``0:0.2mN``, ``0mN:200uN``) -> SI."""
    q = MEASURANDS[quantity]
    lo, hi = parse_values(text, q.dimension, q.display, "--span", (2,), f"0:1{q.display}")
    if hi <= lo:
        raise fail("--span", text, "LO:HI with HI > LO")
    return lo, hi


def read_recording(path: str, reading: RecordingArgs | None = None, option: str = "RECORDING",
                   quiet: bool = False) -> tuple[np.ndarray, np.ndarray | None]:
    """Voltages (V) and optional times (s) of a recording (CSV/.mat/.tdms/.h5 with ``voltage_V``,
    or the columns that ``reading`` maps)."""
    reading = reading or RecordingArgs()
    cols = reading.read(read_samples, path, quiet=quiet, required=("voltage_V",))
    if cols["voltage_V"].size == 0:
        raise fail(option, path, "a recording with at least one reading")
    return cols["voltage_V"], cols.get("time_s")


def parse_edge_tolerance(text: str | None, quantity: str,
                         span: tuple[float, float]) -> float | None:
    """``--edge-tolerance``: a percentage of the span (``5%``), a value with a unit (``0.01mN``)
    or a bare number in the display unit -> SI (None: the library's default)."""
    if text is None:
        return None
    q = MEASURANDS[quantity]
    allowed = f"a percentage of the span (5%) or a value in {q.display} (or with a unit)"
    t = text.strip()
    try:
        value = (parse_value(t[:-1], None, "", "--edge-tolerance") / 100.0 * (span[1] - span[0])
                 if t.endswith("%") else parse_value(t, q.dimension, q.display, "--edge-tolerance"))
    except MagciliaError:
        raise fail("--edge-tolerance", text, allowed) from None
    if not value >= 0.0:
        raise fail("--edge-tolerance", text, allowed.replace("a percentage", "a non-negative "
                                                              "percentage"))
    return value


def tare_readings(spec: str, volts: np.ndarray, times: np.ndarray | None) -> np.ndarray:
    """``--tare SPEC``: the first readings of the recording, a duration with a unit from its
    start (``0.5s``, ``200ms``; needs ``time_s``) or a sample count (``500``)."""
    allowed = "a duration from the start with a unit (0.5s) or a number of readings (500)"
    t = spec.strip()
    if t.isdigit():
        count = int(t)
    else:
        try:
            seconds = parse_quantity(t, "time", "--tare")
        except MagciliaError:
            raise fail("--tare", spec, allowed) from None
        if not seconds > 0.0:
            raise fail("--tare", spec, allowed)
        if times is None:
            raise fail("--tare", spec, "a number of readings (500): the recording has no "
                       "time_s column")
        count = int(np.count_nonzero(times - times[0] < seconds))
    if count < 2:
        raise fail("--tare", spec, f"{allowed}, covering at least 2 readings")
    if count > volts.size:
        raise fail("--tare", spec, f"at most the recording's {volts.size} readings")
    return volts[:count]


@click.command()
@click.argument("setup_arg", metavar="SETUP")
@click.argument("recording", type=click.Path(dir_okay=False))
@click.option("--quantity", type=click.Choice(["angle", "force", "flow"]), required=True,
              help="What to estimate: tilt angle (deg), tip force (mN) or flow speed (m/s).")
@click.option("--span", "span_text", required=True,
              help="Range LO:HI in deg (angle), mN (force) or m/s (flow); units allowed.")
@click.option("--out", "out_path", required=True, type=click.Path(dir_okay=False),
              help="Output CSV (estimates, 1-sigma, flags), written atomically.")
@bandwidth_option("Noise band of each reading, F_LOW:F_HIGH in Hz, for the sensor model's noise "
                  "(with --tare or --tare-file the baseline's measured spread is used instead).")
@click.option("--fluid", type=click.Choice(sorted(FLUIDS)), default="water", show_default=True,
              help="Fluid for --quantity flow (uniform flow along +x).")
@click.option("--table-size", default=257, show_default=True, help="Read-out table points.")
@click.option("--calibration", "calibration_path", type=click.Path(),
              help="result.json (or the --out folder) of `magcilia calibrate`: its parameter "
                   "covariance adds to each reading's 1-sigma.")
@click.option("--edge", type=click.Choice(list(EDGES)), default="extrapolate",
              show_default=True,
              help="Readings just beyond an end of the span: continue the model past it "
                   "(flag extrapolated), clip to the end (flag clipped), or leave blank.")
@click.option("--edge-tolerance", "edge_tolerance", default=None,
              help="How far beyond the span's ends readings are estimated: a percentage of the "
                   "span or a value (deg, mN, m/s; units allowed). [default: 5% of the span, "
                   "further where the output moves by less than 5 sigma of the noise in it]")
@click.option("--tare", "tare_spec", default=None,
              help="Zero on the recording's first readings (unloaded): a duration with a unit "
                   "(0.5s) or a count (500). Their spread is then the noise of one reading.")
@click.option("--tare-file", "tare_file", type=click.Path(dir_okay=False), default=None,
              help="Zero on a separate recording of the unloaded sensor (voltage_V).")
@mechanics_options
@si_option
@click.option("--json", "as_json", is_flag=True, help="Print a JSON summary instead of a line.")
@click.option("--quiet", is_flag=True, help="No progress bar.")
@recording_options
def command(setup_arg: str, recording: str, quantity: str, span_text: str, out_path: str,
            bandwidth: str, fluid: str, table_size: int, calibration_path: str | None,
            edge: str, edge_tolerance: str | None, tare_spec: str | None, tare_file: str | None,
            tip_radius: str | None, modulus: str | None, si: bool, as_json: bool,
            quiet: bool, reading: RecordingArgs) -> None:
    """Estimate the tilt angle, tip force or flow speed for each reading of RECORDING (CSV, .mat
    or .tdms with a `voltage_V` column and optional `time_s`; see `magcilia calibrate`).

    Writes one row per reading: time_s, voltage_V, the estimate and its 1-sigma (sensor noise
    over the bandwidth, or the tare's measured noise; plus the calibration's covariance and the
    tare's standard error) in mN, deg or m/s (--si: N, rad, m/s), and the flags (outside_span,
    fold, saturated, extrapolated, clipped, below_span, above_span). Readings within the edge
    tolerance beyond the span are extrapolated or clipped; only rows without an estimate
    (outside_span, fold, saturated) have empty fields.
    """
    if tare_spec is not None and tare_file is not None:
        raise fail("--tare", tare_spec, "either --tare or --tare-file, not both")
    setup = load_mechanics_setup(setup_arg, tip_radius, modulus)
    span = parse_span(span_text, quantity)
    tolerance = parse_edge_tolerance(edge_tolerance, quantity, span)
    band = parse_bandwidth(bandwidth)
    quiet = quiet_requested(quiet)
    volts, times = read_recording(recording, reading, quiet=quiet)
    baseline = (tare_readings(tare_spec, volts, times) if tare_spec is not None else
                read_recording(tare_file, reading, "--tare-file", quiet)[0]
                if tare_file is not None else None)
    flow = Flow.uniform(1.0, FLUIDS[fluid]) if quantity == "flow" else None
    covariance = ParameterCovariance.load(calibration_path) if calibration_path else None
    readout = Readout(setup, quantity=quantity, span=span, calibration=covariance, flow=flow,
                      table_size=table_size, edge=edge, edge_tolerance=tolerance)
    if baseline is not None:
        readout = readout.tare(baseline)
    show = not quiet and sys.stderr.isatty() and volts.size > PROGRESS_READINGS
    with tqdm(total=volts.size, desc="readout", unit="reading", unit_scale=True,
              disable=not show, file=sys.stderr) as bar:
        result = readout.read(volts, bandwidth=band)
        write_readout_csv(out_path, result, volts, times, si=si, progress=bar.update)
    if as_json:
        echo_json({**readout_summary(readout, result, si), "out": out_path})
        return
    click.echo(f"{Path(out_path).name}: {readout_line(readout, result, si)}")
