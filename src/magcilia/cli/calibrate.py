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
)
from magcilia.device.parameters import describe_bounds
from magcilia.io.recordings import read_measurements
from magcilia.report.calibration import CALIBRATION_FILES, write_calibration_files


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
              help="Search bound, lengths in mm (n_loops, dipoles_per_loop as whole numbers); "
                   f"repeatable. Defaults: {describe_bounds()}.")
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
@click.option("--json", "as_json", is_flag=True, help="Print the result as JSON.")
@click.option("--quiet", is_flag=True, help="No progress bar.")
@recording_options
def command(data: str, setup_arg: str, out_dir: str, bound_items: tuple[str, ...], seed: int,
            restarts: int, starts: int, bias: str, bias_degree: int, fit_scale: bool,
            nan_policy: str, saturation: str, as_json: bool, quiet: bool, force: bool,
            reading: RecordingArgs) -> None:
    """Calibrate the model to the recording DATA (CSV, .mat, .tdms or .h5).

    Writes fitted_setup.toml (usable by every other command), result.json, report.md, fit.png
    and residuals.png into --out, a new folder published in one rename when everything is
    written: nothing is written if anything fails, and a killed run leaves no partial folder.
    """
    with staged_directory(out_dir, force=force, names=CALIBRATION_FILES) as tmp:
        initial = load_setup_arg(setup_arg)
        measurement = reading.read(read_measurements, data, quiet=quiet, sensor=initial.sensor,
                                   nan_policy=nan_policy, saturation=saturation)
        bounds = parse_named_ranges("--bound", bound_items, PARAMETERS)
        result = calibrate_with_progress(measurement, initial, quiet=quiet, bounds=bounds,
                                         rng=seed, bias=bias, bias_degree=bias_degree,
                                         fit_scale=fit_scale, restarts=restarts,
                                         starts=starts)
        write_calibration_files(result, tmp)
    if as_json:
        echo_json(result.to_dict())
    else:
        click.echo(result.report())
        click.echo(f"wrote {out_dir}/fitted_setup.toml, result.json, report.md, fit.png, "
                   "residuals.png")
