"""``magcilia calibrate``: fit the model to a recording and write setup, result and report."""

from __future__ import annotations

import click

from magcilia._atomic import staged_directory
from magcilia.calibration import PARAMETERS
from magcilia.cli._common import (
    RecordingArgs,
    calibrate_with_progress,
    echo_json,
    load_setup_arg,
    parse_named_ranges,
    recording_options,
    si_option,
    style_option,
)
from magcilia.cli._fix import FIX_HELP, parse_fixed
from magcilia.device.parameters import describe_bounds
from magcilia.io.recordings import read_measurements
from magcilia.report.calibration import (
    CALIBRATION_NAMES,
    calibration_json,
    write_calibration_files,
)


@click.command()
@click.argument("data", type=click.Path(dir_okay=False))
@click.option("--setup", "setup_arg", default="paper-initial", show_default=True,
              help="Initial setup: a TOML file or a preset (paper, paper-initial).")
@click.option("--out", "out_dir", required=True, type=click.Path(file_okay=False),
              help="Output directory (fitted_setup.toml, result.json, report.md, figures); "
                   "must not exist yet, or be empty.")
@click.option("--force", is_flag=True,
              help="Replace an existing --out folder (an earlier output of this command) whole.")
@click.option("--bound", "bound_items", multiple=True, metavar="NAME=LOW:HIGH",
              help="Search bound, lengths in mm or with units (height=2.5:4, z=0mm:0.8mm; n_loops, "
                   f"dipoles_per_loop whole numbers); repeatable. Defaults: {describe_bounds()}.")
@click.option("--fix", "fix_items", multiple=True, metavar="NAME=VALUE", help=FIX_HELP)
@click.option("--seed", default=0, show_default=True, help="Random seed of the global search.")
@click.option("--restarts", default=1, show_default=True,
              help="Independent global searches, the best kept (one finds the best fit of a "
                   "33-angle recording in > 99 % of cases; more make a miss rarer).")
@click.option("--starts", default=256, show_default=True,
              help="Local fits started by each global search.")
@click.option("--bias", type=click.Choice(["offset", "polynomial", "none"]), default="offset",
              show_default=True, help="DC bias model, fitted jointly.")
@click.option("--bias-degree", default=0, show_default=True,
              help="Degree of the polynomial bias in the angle (with --bias polynomial).")
@click.option("--fit-scale", is_flag=True, help="Also fit the magnetization scale.")
@click.option("--nan-policy", type=click.Choice(["raise", "omit"]), default="raise",
              show_default=True, help="NaN/inf samples: error or drop.")
@click.option("--saturation", type=click.Choice(["raise", "omit", "keep"]), default="raise",
              show_default=True, help="Samples beyond the sensor's ±6 gauss range.")
@click.option("--json", "as_json", is_flag=True,
              help="Print the result as JSON, in the units of the console table (mm, mV, deg; SI "
                   "with --si; result.json in --out is always SI).")
@click.option("--quiet", is_flag=True, help="No progress bar.")
@si_option
@style_option
@recording_options
def command(data: str, setup_arg: str, out_dir: str, bound_items: tuple[str, ...], seed: int,
            restarts: int, starts: int, bias: str, bias_degree: int, fit_scale: bool,
            nan_policy: str, saturation: str, as_json: bool, quiet: bool, force: bool,
            fix_items: tuple[str, ...], si: bool, style: str, reading: RecordingArgs) -> None:
    """Calibrate the model to the recording DATA (CSV, .mat, .tdms or .h5).

    Writes fitted_setup.toml (usable by every other command), result.json, report.md, fit.png
    and residuals.png into --out, a new folder published in one rename when everything is
    written: nothing is written if anything fails, and a killed run leaves no partial folder.
    """
    with staged_directory(out_dir, force=force, names=CALIBRATION_NAMES) as tmp:
        initial = load_setup_arg(setup_arg)
        measurement = reading.read(read_measurements, data, quiet=quiet, sensor=initial.sensor,
                                   nan_policy=nan_policy, saturation=saturation)
        bounds = parse_named_ranges("--bound", bound_items, PARAMETERS)
        result = calibrate_with_progress(measurement, initial, quiet=quiet, bounds=bounds,
                                         rng=seed, bias=bias, bias_degree=bias_degree,
                                         fit_scale=fit_scale, restarts=restarts,
                                         starts=starts, fixed=parse_fixed(fix_items))
        write_calibration_files(result, tmp, style)
    if as_json:
        echo_json(calibration_json(result, si))
    else:
        click.echo(result.report(si))
        click.echo(f"wrote {out_dir}/fitted_setup.toml, result.json, report.md, fit.png, "
                   "residuals.png")

