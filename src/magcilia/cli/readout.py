"""``magcilia readout``: estimate angle, force or flow speed from a voltage recording."""

from __future__ import annotations

import math
from pathlib import Path

import click
import numpy as np

from magcilia._atomic import write_text
from magcilia._validate import fail
from magcilia.calibration import ParameterCovariance
from magcilia.cli._common import (
    RecordingArgs,
    bandwidth_option,
    echo_json,
    load_mechanics_setup,
    mechanics_options,
    parse_bandwidth,
    recording_options,
)
from magcilia.device.parameters import MEASURANDS
from magcilia.io.recordings import read_samples
from magcilia.mechanics import FLUIDS, Flow
from magcilia.readout.inverse import Readout
from magcilia.report.readout import readout_csv
from magcilia.units import UNITS, parse_quantity


def parse_span(text: str, quantity: str) -> tuple[float, float]:
    """``LO:HI`` in the display unit (deg, mN, m/s), or with units on each end -> SI."""
    q = MEASURANDS[quantity]
    unit, factor, dim = q.display, q.display_factor, q.dimension or ""
    parts = text.split(":")
    allowed = f"LO:HI in {unit} (or with units, e.g. 0{unit}:1{unit})"
    if len(parts) != 2:
        raise fail("--span", text, allowed)
    out = []
    for part in parts:
        try:
            out.append(float(part) * factor)
        except ValueError:
            if not any(part.strip().endswith(u) for u in UNITS[dim]):
                raise fail("--span", text, allowed) from None
            out.append(parse_quantity(part, dim, "--span"))
    if not all(math.isfinite(x) for x in out) or out[1] <= out[0]:
        raise fail("--span", text, "LO:HI with HI > LO")
    return out[0], out[1]


def read_recording(path: str, reading: RecordingArgs | None = None
                   ) -> tuple[np.ndarray, np.ndarray | None]:
    """Voltages (V) and optional times (s) of a recording (CSV/.mat/.tdms/.h5 with ``voltage_V``,
    or the columns that ``reading`` maps)."""
    reading = reading or RecordingArgs()
    cols = reading.read(read_samples, path, required=("voltage_V",))
    if cols["voltage_V"].size == 0:
        raise fail("RECORDING", path, "a recording with at least one reading")
    return cols["voltage_V"], cols.get("time_s")


@click.command()
@click.argument("setup_arg", metavar="SETUP")
@click.argument("recording", type=click.Path(dir_okay=False))
@click.option("--quantity", type=click.Choice(["angle", "force", "flow"]), required=True,
              help="What to estimate: tilt angle (deg), tip force (mN) or flow speed (m/s).")
@click.option("--span", "span_text", required=True,
              help="Range LO:HI in deg (angle), mN (force) or m/s (flow); units allowed.")
@click.option("--out", "out_path", required=True, type=click.Path(dir_okay=False),
              help="Output CSV (estimates, 1-sigma, flags), written atomically.")
@bandwidth_option()
@click.option("--fluid", type=click.Choice(sorted(FLUIDS)), default="water", show_default=True,
              help="Fluid for --quantity flow (uniform flow along +x).")
@click.option("--table-size", default=257, show_default=True, help="Read-out table points.")
@click.option("--calibration", "calibration_path", type=click.Path(),
              help="result.json (or the --out folder) of `magcilia calibrate`: its parameter "
                   "covariance adds to each reading's 1-sigma.")
@mechanics_options
@click.option("--json", "as_json", is_flag=True, help="Print a JSON summary instead of a line.")
@recording_options
def command(setup_arg: str, recording: str, quantity: str, span_text: str, out_path: str,
            bandwidth: str, fluid: str, table_size: int, tip_radius: str | None,
            modulus: str | None, calibration_path: str | None, as_json: bool,
            reading: RecordingArgs) -> None:
    """Estimate the tilt angle, tip force or flow speed for each reading of RECORDING (CSV, .mat
    or .tdms with a `voltage_V` column and optional `time_s`; see `magcilia calibrate`).

    Writes one row per reading with the estimate, its 1-sigma uncertainty (sensor noise over the
    bandwidth) and flags (outside_span, fold, saturated); flagged rows have empty estimates.
    """
    setup = load_mechanics_setup(setup_arg, tip_radius, modulus)
    span = parse_span(span_text, quantity)
    volts, times = read_recording(recording, reading)
    flow = Flow.uniform(1.0, FLUIDS[fluid]) if quantity == "flow" else None
    covariance = ParameterCovariance.load(calibration_path) if calibration_path else None
    readout = Readout(setup, quantity=quantity, span=span, calibration=covariance, flow=flow,
                      table_size=table_size)
    result = readout.read(volts, bandwidth=parse_bandwidth(bandwidth))
    write_text(out_path, readout_csv(result, volts, times))
    if as_json:
        echo_json({**readout.to_dict(), "readings": int(volts.size),
                   "estimated": int(result.ok.sum()), "out": out_path})
        return
    click.echo(f"{Path(out_path).name}: {result.report()}; table error ≤ "
               f"{readout.table_error:.2g} {readout.unit}")
