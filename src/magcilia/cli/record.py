"""``magcilia record``: a guided calibration sweep (or a continuous recording) into a crash-safe
TDMS file that ``magcilia calibrate`` reads as it is."""

from __future__ import annotations

from pathlib import Path

import click

from magcilia._errors import MagciliaError
from magcilia._validate import fail
from magcilia.acquire import record_stream, record_sweep, source_from_spec
from magcilia.acquire.serial_formats import SerialFormat
from magcilia.acquire.sweep import AskAngle, SweepPoint
from magcilia.cli._common import (
    Physical,
    RenamedOption,
    angle_grid,
    echo_json,
    load_setup_arg,
    setup_label,
    setup_option,
    si_option,
)
from magcilia.cli._options import SEED, serial_format_options
from magcilia.cli._outputs import OUTPUT_FILE, writes_files
from magcilia.cli._record_coil import CoilOptions, check_record_path, record_coil_command
from magcilia.cli._signals import signals_interrupt
from magcilia.cli._thermal import setup_temperature, temperature_option, temperature_profile
from magcilia.io.recording_file import recording_properties
from magcilia.io.setup_files import setup_to_dict
from magcilia.report.units import output_units
from magcilia.units import OutputUnits, parse_value


def ask_angle() -> AskAngle:
    """Ask at the terminal for each angle: degrees, or a photo to measure; empty to finish."""

    def ask(i: int) -> float | None:
        while True:
            text = click.prompt(f"angle {i + 1}: tilt in degrees, a photo of the holder, or "
                                "Enter to finish", default="", show_default=False).strip()
            if not text:
                return None
            try:  # degrees, or with an angle unit (0.2rad)
                return parse_value(text, "angle", "deg", "angle")
            except MagciliaError:
                pass
            if Path(text).is_file():
                from magcilia.acquire.photo import measure_tilt

                tilt = measure_tilt(text)
                click.echo(f"  photo: {tilt.report()}")
                return float(tilt.angle)
            click.echo(f"  {text!r} is neither a number of degrees nor a photo file; try again",
                       err=True)

    return ask


def point_text(point: SweepPoint, units: OutputUnits) -> str:
    """One recorded angle as ``magcilia record`` prints it: angle, mean ± s.e., samples, flag."""
    flag = f"  SATURATED ({point.saturated} samples beyond range)" if point.saturated else ""
    deg, volt = units.unit("angle"), units.unit("voltage")
    angle, mean, sem = (units.value(point.angle, "angle"), units.value(point.mean, "voltage"),
                        units.value(point.sem, "voltage"))
    # fixed widths: the columns line up whatever the values (6 significant digits at most)
    return (f"{angle:8.4g} {deg}  {mean:+12.6g} ± {sem:<11.5g} {volt}  {point.samples:>7} "
            f"samples{flag}")


@click.command()
@writes_files
@click.option("--source", "source_spec", default="sim", show_default=True,
              help="sim, serial:PORT (magcilia's framed protocol; --format ascii|floats for "
                   "firmware without it) or nidaq:DEV/aiN.")
@serial_format_options
@setup_option("The sensor (the simulated one for --source sim; stored in the recording)",
              default="paper", positional=False)
@click.option("--angles", default=None,
              help="Tilt angles START:STOP:STEP in degrees or with a unit (0:80:2.5deg), "
                   "recorded without questions; without it, each angle is asked for (degrees or "
                   "a photo).")
@click.option("--coil", "coil_text", default=None, metavar="SEQUENCE",
              help="Record a coil calibration instead of tilts: the applied uniform fields "
                   "'BX,BY,BZ;BX,BY,BZ;...' in gauss (or with a unit: 0.5mT,0,0), or a CSV file "
                   "of steps (columns bx_G, by_G, bz_G, optional dwell_s); each step's field is "
                   "recorded in actuation_x_T/_y_T/_z_T. sim: the simulated coil (a cilium with "
                   "a tip radius, e.g. --setup force-sensor); nidaq: needs --coil-output.")
@click.option("--coil-output", "coil_output", default=None, metavar="nidaq:DEV/aoN[,aoN,aoN]",
              help="The NI analog outputs driving the coil's x[, y, z] current amplifiers.")
@click.option("--coil-constant", "coil_constant", default=None, metavar="G/V[,G/V,G/V]",
              help="Field at the cilium per output volt of each --coil-output axis, gauss per "
                   "volt (amplifier A/V times coil G/A; signed).")
@click.option("--coil-sense", "coil_sense", default=None, metavar="nidaq:DEV/aiN[,aiN,aiN]",
              help="Analog inputs reading each axis's current-sense voltage: the recorded field "
                   "is then the measured one.")
@click.option("--coil-sense-constant", "coil_sense_constant", default=None,
              metavar="G/V[,G/V,G/V]", help="Field per --coil-sense volt of each axis, G/V.")
@click.option("--samples", default=2000, show_default=True,
              help="Samples per angle (per coil step without a dwell of its own).")
@click.option("--settle", default="0", show_default=True, type=Physical.of("time", "0.5s"),
              help="Time dropped after each tilt before recording (the hair's ringing): s, or "
                   "with a unit (500ms).")
@click.option("--source-rate", "rate", cls=RenamedOption, old="--rate", default="1000",
              show_default=True, type=Physical.of("frequency", "1kHz"),
              help="Sample rate: Hz, or with a unit (1kHz) (sim, nidaq, and a serial "
                   "device with --format ascii|floats; one speaking magcilia's protocol sends "
                   "its own).")
@click.option("--duration", default=None, type=Physical.of("time", "60s"),
              help="Record continuously for this long instead of a sweep: s, or with a unit.")
@click.option("--set-reset", "set_reset", default=None, type=int,
              help="Alternate set/reset pulses every N samples (sim), stored per sample.")
@click.option("--seed", type=SEED, default=0, show_default=True,
              help="Seed of the simulated source.")
@click.option("--sim-dynamics", "sim_dynamics", is_flag=True,
              help="sim: the simulated hair moves through its bending modes in air (rings after "
                   "each tilt; --settle drops the ringing) instead of sitting at each angle.")
@temperature_option
@click.option("--record", "out_path", cls=RenamedOption, old="--out", required=True,
              type=OUTPUT_FILE,
              help="The recording (.tdms), written in flushed chunks (crash-safe).")
@click.option("--force", is_flag=True,
              help="Replace an existing --record: only once the new recording holds its first "
                   "flushed chunk (a source that fails leaves it as it was).")
@click.option("--json", "as_json", is_flag=True,
              help="Print the result as JSON (the console's units: deg, mV; SI with --si).")
@click.option("--quiet", is_flag=True, help="Print only the closing line.")
@si_option
def command(source_spec: str, setup_arg: str, angles: str | None, coil_text: str | None,
            coil_output: str | None, coil_constant: str | None, coil_sense: str | None,
            coil_sense_constant: str | None, samples: int, settle: float,
            rate: float, duration: float | None, set_reset: int | None, seed: int,
            sim_dynamics: bool, temperature: str | None, out_path: str, force: bool,
            as_json: bool, quiet: bool, si: bool, serial: SerialFormat) -> None:
    """Record a calibration sweep: for each tilt angle, samples of the sensor output with the
    angle's mean ± standard error and a saturation flag; the recording ends in the --record
    file, which `magcilia calibrate FILE` fits as it is. With --duration, record continuously
    instead (for `magcilia readout`). A failure keeps the recording made so far and says where it
    stopped. An existing file is refused without --force, and never lost: with --force it is
    replaced only once the new recording holds its first flushed chunk. Ctrl-C, SIGTERM or
    SIGHUP stop it the same way: the file is closed, marked incomplete and saying where it
    stopped, with one line and exit status 1. The recording holds the channels time_s,
    voltage_V and angle_deg (a sweep; the names of a CSV recording); the console and --json are
    in deg and mV (SI with --si). With --coil, the steps are applied fields instead of tilts
    (actuation_x_T, actuation_y_T, actuation_z_T in place of angle_deg: a coil calibration,
    `magcilia calibrate FILE --model physical`); a field beyond the sensor's range or flip field
    is refused before anything runs.
    """
    with signals_interrupt() as stop:
        try:
            if coil_text is not None:
                if not serial.verified:
                    raise fail("--format", serial.format, "magcilia with --coil")
                record_coil_command(source_spec, setup_arg, coil_text, CoilOptions(
                    coil_output, coil_constant, coil_sense, coil_sense_constant), samples,
                    settle, rate, set_reset, seed, out_path, force, as_json, quiet, si,
                    angles=angles, duration=duration, dynamics=sim_dynamics)
                return
            if coil_output is not None:
                raise fail("--coil-output", coil_output, "given with --coil SEQUENCE")
            _record(source_spec, setup_arg, angles, samples, settle, rate, duration, set_reset,
                    seed, out_path, force, as_json, quiet, si, sim_dynamics, temperature, serial)
        except KeyboardInterrupt:  # the writer closed the file, noting where it stopped
            click.echo(f"magcilia: {stop.signal or 'SIGINT'} stopped the recording; "
                       f"{_kept(Path(out_path))}", err=True)
            raise click.exceptions.Exit(1) from None


def _kept(path: Path) -> str:
    """What an interrupted recording left in ``path``, in words."""
    try:
        props = recording_properties(path)
    except MagciliaError:
        props = {}
    if props.get("stopped"):
        return (f"what it holds so far is kept in {path}, marked incomplete "
                f"({props['stopped']})")
    return f"nothing was recorded into {path}"


def _record(source_spec: str, setup_arg: str, angles: str | None, samples: int, settle: float,
            rate: float, duration: float | None, set_reset: int | None, seed: int,
            out_path: str, force: bool, as_json: bool, quiet: bool, si: bool,
            sim_dynamics: bool = False, temperature: str | None = None,
            serial: SerialFormat | None = None) -> None:
    units = output_units(si)
    check_record_path(out_path)
    setup = load_setup_arg(setup_arg)
    source = source_from_spec(source_spec, setup=setup, rate=rate, rng=seed,
                              set_reset=set_reset, realtime=duration is not None,
                              dynamics=sim_dynamics,
                              temperature=temperature_profile(temperature, duration),
                              thermal=None if temperature is None else setup_temperature(setup_arg),
                              serial=serial)
    metadata = {"setup_name": setup_label(setup_arg), "setup": setup_to_dict(setup)}
    if duration is not None:
        if angles is not None:
            raise fail("--duration", duration, "used without --angles (a continuous recording)")
        stream = record_stream(source, out_path, duration, metadata=metadata, overwrite=force)
        if as_json:
            echo_json({"units": units.system, **stream.to_dict()})
        else:
            click.echo(stream.report())
        return

    def show(point: SweepPoint) -> None:
        if not (quiet or as_json):
            click.echo(point_text(point, units))

    plan = None if angles is None else angle_grid(angles)
    result = record_sweep(source, out_path, angles=plan, ask=None if plan is not None else
                          ask_angle(), samples=samples, settle=settle, sensor=setup.sensor,
                          metadata=metadata, overwrite=force, on_point=show)
    if as_json:
        echo_json({"units": units.system, **units.convert(result.to_dict())})  # type: ignore[dict-item]
        return
    click.echo(result.report().splitlines()[-1])
    click.echo(f"fit it with: magcilia calibrate {out_path} --out fit/")
