"""``magcilia batch calibrate``: calibrate many recordings into one resumable batch folder, on
this machine or a Dask cluster."""

from __future__ import annotations

import click

from magcilia._errors import MagciliaError
from magcilia.batch import calibrate_batch
from magcilia.calibration import PARAMETERS
from magcilia.cli._common import (
    RecordingArgs,
    echo_json,
    execution_options,
    fit_options,
    load_setup_arg,
    parse_named_ranges,
    quiet_requested,
    recording_options,
    setup_option,
    si_option,
    style_option,
    suspect_option,
)
from magcilia.cli._fix import FIX_HELP, parse_fixed
from magcilia.cli._options import SEED
from magcilia.cli._outputs import in_folder
from magcilia.device.parameters import describe_bounds


@click.group()
def command() -> None:
    """Many recordings at once (on this machine, or a Dask cluster with --scheduler)."""


@command.command("calibrate")
@click.argument("patterns", nargs=-1, required=True, metavar="GLOB...")
@click.option("--out", "out_dir", required=True, type=click.Path(file_okay=False),
              help="Batch folder: results.csv, results.parquet, summary.md, manifest.json and "
                   "one report folder per recording. A rerun into it skips what finished.")
@setup_option("Initial setup", default="paper-initial", positional=False)
@click.option("--force", is_flag=True,
              help="Start over a folder that holds a batch with other options (its results "
                   "are removed; a folder holding any other file is refused).")
@click.option("--bound", "bound_items", multiple=True, metavar="NAME=LOW:HIGH",
              help="Search bound, lengths in mm or with units (height=2.5:4, z=0mm:0.8mm); "
                   f"repeatable. Defaults: {describe_bounds()}.")
@click.option("--fix", "fix_items", multiple=True, metavar="NAME=VALUE", help=FIX_HELP)
@click.option("--seed", type=SEED, default=0, show_default=True,
              help="Random seed of every recording's global search.")
@click.option("--restarts", default=1, show_default=True,
              help="Independent global searches per recording, the best kept.")
@click.option("--starts", type=int, default=None,
              help="Local fits started by each global search [default: 256].")
@fit_options
@click.option("--figures/--no-figures", default=True, show_default=True,
              help="fit.png and residuals.png in each recording's folder (most of a quick "
                   "fit's time).")
@click.option("--json", "as_json", is_flag=True,
              help="Print the summary as JSON (mm; SI with --si); the table files are SI.")
@click.option("--quiet", is_flag=True, help="No progress bar.")
@execution_options()
@si_option
@style_option
@suspect_option
@recording_options
def calibrate_command(patterns: tuple[str, ...], out_dir: str, setup_arg: str, force: bool,
                      bound_items: tuple[str, ...], fix_items: tuple[str, ...], seed: int,
                      restarts: int, starts: int | None, bias: str, bias_degree: int,
                      fit_scale: bool, nan_policy: str, saturation: str, figures: bool,
                      as_json: bool, quiet: bool, workers: int | None, scheduler: str | None,
                      timeout: float, si: bool, style: str, reading: RecordingArgs,
                      suspect: str) -> None:
    """Calibrate every recording GLOB matches (quote it: 'recordings/*.tdms'; ** for subfolders),
    each as `magcilia calibrate` does, into the batch folder --out.

    Each recording's report folder (--out/NAME/, NAME its file name without the suffix) is
    published in one rename as its fit finishes; results.csv and results.parquet hold one row
    per recording in SI units (height, base_radius, x, y, z and their *_stderr in m, cost in
    V^2, error empty on success); summary.md the spread over the batch and its outliers. A
    recording that cannot be read or fitted is a row with its error; the batch goes on (exit
    status 0, a warning line); when every recording fails, the exit status is 2 (one error
    line). Run it again after a crash or a failure: only the failed, missing or changed
    recordings run. Each recording's samples are checked before its fit (--suspect): the
    table's `flagged` and `notes` columns and summary.md say what was flagged and what the
    reader said of the file (a recording cut short, damage read past).
    """
    initial = load_setup_arg(setup_arg)
    bounds = parse_named_ranges("--bound", bound_items, PARAMETERS)
    result = calibrate_batch(
        list(patterns), out_dir, setup=initial, workers=workers, scheduler=scheduler,
        timeout=timeout, force=force, figures=figures, style=style,
        progress=not quiet_requested(quiet), nan_policy=nan_policy, saturation=saturation,
        suspect=suspect, **reading.kwargs(), rng=seed, bounds=bounds or None,
        fixed=parse_fixed(fix_items) or None, bias=bias, bias_degree=bias_degree,
        fit_scale=fit_scale, restarts=restarts, starts=starts)
    if as_json:  # then the same exit status and warning lines as the text
        doc = result.to_dict()
        factor, unit = (1.0, "m") if si else (1e3, "mm")
        echo_json({"units": "SI" if si else "display", "out": doc["out"],
                   "recordings": len(result.rows), "computed": doc["computed"],
                   "skipped": doc["skipped"], "failed": doc["failed"],
                   "statistics": {(f"{k}_{unit}" if k != "cost" else "cost_V2"): {
                       s: (val if s == "n" or k == "cost" else val * factor)
                       for s, val in stats.items()} for k, stats in doc["statistics"].items()},
                   "outliers": [{"recording": o["recording"], "parameter": o["parameter"],
                                 ("value_V2" if o["parameter"] == "cost" else f"value_{unit}"):
                                 o["value"] * (1.0 if o["parameter"] == "cost" else factor),
                                 "z": o["z"]} for o in doc["outliers"]],
                   "notes": {r["recording"]: r["notes"] for r in result.rows if r["notes"]},
                   "parquet": result.parquet})
    else:
        click.echo(result.report(si))
        tables = "results.csv" + (", results.parquet" if result.parquet else
                                  " (no results.parquet: it needs pyarrow, magcilia[cluster])")
        click.echo(f"wrote {in_folder(out_dir, tables)}, summary.md and "
                   f"{len(result.computed)} report folder(s)")
    if len(result.failed) == len(result.rows):  # nothing calibrated: an input error, exit 2
        first = next(r for r in result.rows if r["error"])
        raise MagciliaError(
            f"all {len(result.rows)} recordings failed, none calibrated (the first, "
            f"{first['recording']}: {first['error']}); each error is in "
            f"{in_folder(out_dir, 'results.csv')}")
    if result.failed:
        click.echo(f"magcilia: warning: {len(result.failed)} of {len(result.rows)} recordings "
                   "failed (their error in the table); run the command again to retry them",
                   err=True)
