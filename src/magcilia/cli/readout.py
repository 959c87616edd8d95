"""``magcilia readout``: estimate angle, force or flow speed from a voltage recording."""

from __future__ import annotations

import contextlib
import sys
from pathlib import Path
from typing import TYPE_CHECKING

import click
import numpy as np

from magcilia._errors import MagciliaError
from magcilia._validate import fail
from magcilia.calibration import ParameterCovariance
from magcilia.cli import _thermal as thermal
from magcilia.cli._common import (
    RecordingArgs,
    RenamedOption,
    actuation_options,
    bandwidth_option,
    echo_json,
    load_mechanics_setup,
    make_actuation,
    mechanics_options,
    parse_bandwidth,
    quiet_requested,
    recording_options,
    setup_option,
    si_option,
    suspect_option,
)
from magcilia.cli._outputs import OUTPUT_FILE, writes_files
from magcilia.cli._readout_inputs import (
    parse_edge_tolerance,
    parse_span,
    read_recording,
    tare_readings,
)
from magcilia.device.actuation import Actuation
from magcilia.device.magnetometer import MAGNETOMETERS
from magcilia.device.setup import Setup
from magcilia.mechanics import FLUIDS, Flow, Fluid
from magcilia.readout.inverse import EDGES, Readout, direct_field
from magcilia.readout.protocol import Flag
from magcilia.report.readout import readout_line, readout_summary, write_readout_csv

if TYPE_CHECKING:
    from magcilia.readout.dynamic import DynamicReadout

#: readings from which a read-out shows a progress bar (about a second of work)
PROGRESS_READINGS = 2_000_000


@click.command()
@writes_files
@setup_option("The sensor setup (optional for a recording of `magcilia live --record`, which "
              "stores its own)", optional=True)
@click.argument("recording", type=click.Path(dir_okay=False))
@click.option("--quantity", type=click.Choice(["angle", "force", "flow"]), default=None,
              help="What to estimate: tilt angle (deg), tip force (mN) or flow speed (m/s). "
                   "Required, except with --biaxial (a force vector).")
@click.option("--span", "span_text", default=None,
              help="Required: range LO:HI in deg (angle), mN (force) or m/s (flow), units "
                   "allowed; with --biaxial: the largest force magnitude (0.2mN, or 0:0.2mN).")
@click.option("--biaxial", is_flag=True,
              help="Read the horizontal force vector (Fx, Fy) from a 3-axis sensor at the "
                   "element: RECORDING has field columns field_x_T, field_y_T, field_z_T (or "
                   "--columns field_x=Bx[G],...); needs --sensor.")
@click.option("--sensor", "sensor_name", default=None,
              type=click.Choice(sorted(MAGNETOMETERS), case_sensitive=False),
              help="With --biaxial: the 3-axis magnetometer preset at the element (its axes "
                   "along the board's x, y, z).")
@click.option("--sensor-noise", "sensor_noise", default=None, metavar="B or BX,BY,BZ",
              help="With --biaxial: RMS noise of one reading per axis, gauss or with a unit "
                   "(2mG, or 2mG,2mG,3mG); required for the MLX90393 and TLV493D presets.")
@click.option("--csv", "out_path", cls=RenamedOption, old="--out", default=None,
              type=OUTPUT_FILE,
              help="Output CSV (estimates, 1-sigma, flags), written atomically. Required.")
@bandwidth_option("Noise band of each reading, F_LOW:F_HIGH in Hz, for the sensor model's noise "
                  "(with --tare or --tare-file the baseline's measured spread is used instead).")
@click.option("--fluid", type=click.Choice(sorted(FLUIDS)), default=None,
              help="Fluid for --quantity flow (uniform flow along +x) [default: water]; with "
                   "--dynamic, the fluid around the hair [default: air for a force or angle].")
@click.option("--dynamic", is_flag=True,
              help="Read with the dynamic read-out (a Kalman filter on the hair's bending "
                   "modes, magcilia.DynamicReadout): steps read within about a period instead of "
                   "ringing; the readings in order at the uniform rate of their time_s column "
                   "(above twice the hair's first mode).")
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
@actuation_options
@mechanics_options
@si_option
@click.option("--json", "as_json", is_flag=True, help="Print a JSON summary instead of a line.")
@click.option("--quiet", is_flag=True, help="No progress bar.")
@suspect_option
@recording_options
def command(setup_arg: str | None, recording: str, quantity: str | None, span_text: str | None,
            biaxial: bool, sensor_name: str | None, sensor_noise: str | None,
            out_path: str | None,
            bandwidth: str, fluid: str | None, dynamic: bool, table_size: int,
            calibration_path: str | None,
            edge: str, edge_tolerance: str | None, tare_spec: str | None, tare_file: str | None,
            actuation_field: str | None, actuation_file: str | None,
            actuation_scale: float | None,
            tip_radius: str | None, modulus: str | None, si: bool, as_json: bool,
            quiet: bool, reading: RecordingArgs, suspect: str) -> None:
    """Estimate the tilt angle, tip force or flow speed for each reading of RECORDING (CSV, .mat
    or .tdms with a `voltage_V` column and optional `time_s`; see `magcilia calibrate`).

    Writes one row per reading: time_s, voltage_V, the estimate and its 1-sigma (sensor noise
    over the bandwidth, or the tare's measured noise; plus the calibration's covariance and the
    tare's standard error) in mN, deg or m/s (--si: N, rad, m/s), and the flags (outside_span,
    fold, saturated, extrapolated, clipped, below_span, above_span). Readings within the edge
    tolerance beyond the span are extrapolated or clipped; only rows without an estimate
    (outside_span, fold, saturated) have empty fields.

    A recording with a temperature (temperature_K or temperature_degC) is read compensated with
    the setup file's [temperature] coefficients (magcilia.ThermalReadout; their sigma in each
    row's), flagged temperature_outside beyond its calibrated_range (magcilia calibrate writes
    the range its recordings saw; without one the reference temperature) widened by the tare's.

    While actuating (--actuation-field, --actuation FILE or the setup file's [actuation]), the
    table includes the actuation's bending of the cilium and its direct field at the element:
    a constant actuation reads the external load alone.

    With --biaxial, RECORDING holds the three field components of a 3-axis sensor (--sensor)
    and each row gets the horizontal force vector: fx, fy, magnitude (mN), direction (deg from
    +x toward +y), their 1-sigma, chi2 and flags.

    The samples are checked first (--suspect: spikes, duplicated blocks, garbled values); what is
    flagged, and what the reader says of the file (cut short, damage read past), is printed as
    note lines and kept in the --json summary.

    A recording of `magcilia live --record` (or the views' Record button) is read as the view
    read it: its read-out readings (the windows' means) with the view's tare and zero tracking,
    the noise σ used, and the setup, quantity and span it stores — `magcilia readout FILE.tdms
    --csv OUT.csv` needs no --setup. Given, --setup, --quantity and --span replace the stored
    ones, and --tare or --tare-file replaces the view's corrections.
    """
    if dynamic and (biaxial or is_live_recording(recording)):
        raise fail("--dynamic", True, "given for a recording of one output's samples (not "
                   "--biaxial, not a live recording's windows)")
    if not biaxial and is_live_recording(recording):
        if out_path is None:
            raise click.UsageError("Missing option '--csv'.")
        _live_recording(setup_arg or "", recording, quantity, span_text, out_path, tare_spec,
                        tare_file, tip_radius, modulus, si, as_json, reading, suspect, quiet)
        return
    if not setup_arg:
        raise click.UsageError(f"Missing option '--setup' (only a recording of `magcilia live "
                               f"--record` stores its own setup, and {recording} is none).")
    # the required options, in the order of --help (--quantity only without --biaxial)
    if quantity is None and not biaxial:
        raise click.UsageError("Missing option '--quantity' (or --biaxial).")
    if span_text is None:
        raise click.UsageError("Missing option '--span'.")
    if out_path is None:
        raise click.UsageError("Missing option '--csv'.")
    if tare_spec is not None and tare_file is not None:
        raise fail("--tare", tare_spec, "either --tare or --tare-file, not both")
    setup = load_mechanics_setup(setup_arg, tip_radius, modulus)
    actuation = make_actuation(setup_arg, actuation_field, actuation_file, actuation_scale)
    if biaxial:
        if quantity not in (None, "force"):
            raise fail("--quantity", quantity, "force, or left out, with --biaxial (it reads a "
                                               "force vector)")
        from magcilia.cli._readout_vectors import biaxial_readout

        biaxial_readout(setup, recording, span_text, sensor_name, sensor_noise, out_path,
                        tare_spec, tare_file, si, as_json, quiet, reading, actuation, suspect)
        return
    assert quantity is not None  # for mypy: checked above
    for name, value in (("--sensor", sensor_name), ("--sensor-noise", sensor_noise)):
        if value is not None:
            raise fail(name, value, "given with --biaxial only")
    span = parse_span(span_text, quantity)
    tolerance = parse_edge_tolerance(edge_tolerance, quantity, span)
    band = parse_bandwidth(bandwidth)
    quiet = quiet_requested(quiet)
    volts, times, notes, quality, temps = read_recording(recording, reading, quiet=quiet,
                                                         suspect=suspect)
    tared = (read_recording(tare_file, reading, "--tare-file", quiet, suspect)
             if tare_file is not None else None)
    baseline = (tare_readings(tare_spec, volts, times) if tare_spec is not None else
                tared[0] if tared is not None else None)
    flow = Flow.uniform(1.0, FLUIDS[fluid or "water"]) if quantity == "flow" else None
    covariance = ParameterCovariance.load(calibration_path) if calibration_path else None
    readout = Readout(setup, quantity=quantity, span=span, calibration=covariance, flow=flow,
                      table_size=table_size, edge=edge, edge_tolerance=tolerance,
                      actuation=actuation)
    warm = None if temps is None or dynamic or actuation is not None else thermal.compensated(
        readout, setup_arg, volts, temps, baseline, None if baseline is None else
        thermal.tare_temperatures(baseline.size, temps, tared and tared[4], tared is not None),
        band)
    notes += ["note: --dynamic and an actuation read without the temperature compensation"] if (
        temps is not None and warm is None) else [] if warm is None else warm[2]
    readout = readout if warm is None else warm[1].readout
    if baseline is not None and warm is None:
        readout = readout.tare(baseline)
        if readout.baseline is not None and not readout.baseline.at_rest:
            notes.append(f"note: {tare_spec or tare_file}: {readout.baseline.report()}")
    dyn = (_dynamic(readout, times, FLUIDS[fluid or ("water" if quantity == "flow" else "air")])
           if dynamic else None)
    show = not quiet and sys.stderr.isatty() and volts.size > PROGRESS_READINGS
    with contextlib.ExitStack() as stack:
        progress = None
        if show:  # (tqdm imported only to show a bar)
            from tqdm import tqdm

            progress = stack.enter_context(tqdm(total=volts.size, desc="readout",
                                                unit="reading", unit_scale=True,
                                                file=sys.stderr)).update
        result = warm[0] if warm is not None else readout.read(
            volts, bandwidth=band) if dyn is None else dyn.read(
            volts, noise=None if readout.baseline is not None else
            setup.sensor.output_noise_rms(*band))
        write_readout_csv(out_path, result, volts, times, si=si, progress=progress)
    compensation = None if actuation is None else _compensation(setup, actuation,
                                                                 readout.sensor_flags, si)
    if as_json:
        extra = {} if compensation is None else {"actuation": compensation[1]}
        if dyn is not None:
            extra["dynamic"] = dyn.to_dict()["dynamic"]
        if warm is not None:
            extra["temperature"] = warm[3]
        echo_json({**readout_summary(readout, result, si), **extra, "out": out_path,
                   "notes": notes, "quality": quality})
        return
    for line in notes:
        click.echo(line)
    if compensation is not None:
        click.echo(compensation[0])
    if dyn is not None:
        click.echo(dyn.report().splitlines()[-1])
    click.echo(f"{Path(out_path).name}: {readout_line(readout, result, si)}")


def _dynamic(readout: Readout, times: np.ndarray | None, fluid: Fluid) -> DynamicReadout:
    """``--dynamic``: the dynamic read-out at the recording's rate (its ``time_s`` uniform
    within 1 %)."""
    from magcilia.readout.dynamic import DynamicReadout

    if times is None or times.size < 2:
        raise fail("--dynamic", True, "given for a recording with a time_s column (the rate of "
                   "its readings)")
    steps = np.diff(times)
    step = float(np.median(steps))
    if not (step > 0 and np.all(np.abs(steps - step) <= 0.01 * step)):
        raise fail("--dynamic", True, "given for readings at a uniform rate (time_s steps "
                   f"within 1 %; they range {steps.min():.6g}…{steps.max():.6g} s)")
    try:
        return DynamicReadout(readout, 1.0 / step, fluid=fluid)
    except MagciliaError as exc:  # the rate: name where it comes from
        raise MagciliaError(str(exc).replace("rate must", "the recording's rate (time_s) must",
                                             1)) from None


def _compensation(setup: Setup, actuation: Actuation, flags: int,
                  si: bool) -> tuple[str, dict[str, object]]:
    """The compensation used, as a line and a JSON entry (gauss and mV; T and V with si)."""
    from magcilia.device.sensor import flag_names

    b = direct_field(actuation)
    volts = float(setup.sensor.scale * b[0])
    (fu, ff), (vu, vf) = ((("T", 1.0), ("V", 1.0)) if si else (("gauss", 1e-4), ("mV", 1e-3)))
    what = "uniform field" if actuation.is_uniform else actuation.source_name
    if actuation.scale != 1.0:
        what += f" x {actuation.scale:.6g}"
    line = (f"compensating the actuation ({what}): direct field ("
            + ", ".join(f"{c / ff:.6g}" for c in b) + f") {fu} at the element ({volts / vf:+.6g} "
            f"{vu}) and its bending of the cilium, in the read-out table")
    if flags:
        line += f"; sensor flags under it: {flag_names(flags)}"
    return line, {"kind": actuation.kind, "scale": actuation.scale,
                  f"direct_field_{fu}": [float(c) / ff for c in b],
                  f"direct_output_{vu}": volts / vf, "sensor_flags": flags,
                  "sensor_flag_names": flag_names(flags)}


def is_live_recording(path: str) -> bool:
    """Whether ``path`` is a TDMS recording of a live read-out (it stores its read-out)."""
    if not path.lower().endswith(".tdms") or not Path(path).is_file():
        return False
    from magcilia.acquire.replay import stored_properties

    try:
        return bool(stored_properties(path).get("live"))
    except MagciliaError:
        return False  # the recording reader says what is wrong with it


def _live_recording(setup_arg: str, path: str, quantity: str | None, span_text: str | None,
                    out_path: str, tare_spec: str | None, tare_file: str | None,
                    tip_radius: str | None, modulus: str | None, si: bool, as_json: bool,
                    reading: RecordingArgs, suspect: str, quiet: bool) -> None:
    """``magcilia readout FILE.tdms [--setup SETUP]`` of a live recording: the readings the view
    read, corrected as it corrected them, through the stored read-out (each part replaced where
    given)."""
    from magcilia.acquire.replay import stored_properties
    from magcilia.live.recorded import (
        read_recorded,
        recorded_kind,
        recorded_readings,
        recorded_readout,
        stored,
    )

    kind = recorded_kind(path)
    if kind != "scalar":  # force vectors: a replay reads them with what the recording stores
        what = "an array's" if kind == "array" else "a 3-axis sensor's"
        raise MagciliaError(f"{path}: a live recording of {what} force vectors; readout reads "
                            f"a single output's: replay it with `magcilia live --source {path} "
                            "--json-lines`")
    setup = load_mechanics_setup(setup_arg, tip_radius, modulus) if setup_arg else None
    spec = stored(stored_properties(path), Path(path))[1]
    q = quantity or str(spec["quantity"])
    span = parse_span(span_text, q) if span_text else None
    if quantity is not None and span is None:
        raise fail("--span", None, f"given with --quantity {quantity} (the recording's span is "
                   "for its own quantity)")
    readout = recorded_readout(path, setup=setup, quantity=q, span=span)
    rec = recorded_readings(path)
    if rec.time.size == 0:
        raise fail("RECORDING", path, "a live recording with at least one read-out reading")
    raw = rec.volts - rec.correction
    notes = [f"note: {path}: a live recording: its {rec.time.size} read-out readings with the "
             "setup, quantity and span it stores" + (" (setup as given)" if setup else "")]
    if spec.get("dynamic"):  # the view's filter is replayed by `live --source FILE`
        notes.append(f"note: {path}: the view read it with the dynamic read-out; read here "
                     "statically (`magcilia live --source FILE` replays the dynamic one)")
    if tare_spec is not None or tare_file is not None:
        if tare_spec is not None and tare_file is not None:
            raise fail("--tare", tare_spec, "either --tare or --tare-file, not both")
        baseline = (tare_readings(tare_spec, raw, rec.time) if tare_spec is not None else
                    read_recording(str(tare_file), reading, "--tare-file", quiet, suspect)[0])
        readout = readout.tare(baseline)
        if readout.baseline is not None and not readout.baseline.at_rest:
            notes.append(f"note: {path}: {readout.baseline.report()}")
        volts = raw
        result = readout.read(volts)
    else:
        notes[0] += " and the view's tare and zero tracking"
        volts = rec.volts
        result = read_recorded(readout, rec)
    seen = int(np.bitwise_or.reduce(rec.flags)) if rec.flags.size else 0
    for bit in (Flag.TARE_UNDER_LOAD, Flag.ZERO_DRIFT):
        count = int(np.count_nonzero(rec.flags & np.uint16(bit)))
        if seen & bit:
            notes.append(f"note: {path}: {count} readings were flagged {bit.name} in the view")
    write_readout_csv(out_path, result, volts, rec.time, si=si)
    if as_json:
        echo_json({**readout_summary(readout, result, si), "out": out_path, "notes": notes,
                   "live_recording": True})
        return
    for line in notes:
        click.echo(line)
    click.echo(f"{Path(out_path).name}: {readout_line(readout, result, si)}")
