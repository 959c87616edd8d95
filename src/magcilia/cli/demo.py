"""``magcilia demo``: the whole pipeline on the bundled (synthetic) example recording."""

from __future__ import annotations

import json
from pathlib import Path

import click

from magcilia._atomic import staged_directory
from magcilia.calibration import PARAMETERS
from magcilia.cli._common import calibrate_with_progress, style_option
from magcilia.cli._fix import FIX_HELP, parse_fixed
from magcilia.cli._options import SEED
from magcilia.device.setup import Setup
from magcilia.io.recordings import example_path, read_measurements
from magcilia.report.calibration import CALIBRATION_NAMES, write_calibration_files
from magcilia.report.figure_process import figure_writer


@click.command()
@click.option("--out", "out_dir", default="magcilia-demo", show_default=True,
              type=click.Path(file_okay=False),
              help="Output directory; must not exist yet, or be empty.")
@click.option("--force", is_flag=True,
              help="Replace an existing --out folder (an earlier output of this command) whole.")
@click.option("--fix", "fix_items", multiple=True, metavar="NAME=VALUE",
              help=FIX_HELP + " Try --fix height=3.2613 to see what a known height pins down.")
@click.option("--seed", type=SEED, default=0, show_default=True,
              help="Random seed of the global search.")
@click.option("--quiet", is_flag=True, help="No progress bar.")
@style_option
def command(out_dir: str, seed: int, quiet: bool, force: bool, fix_items: tuple[str, ...],
            style: str) -> None:
    """Calibrate the paper's model to the bundled SYNTHETIC recording and write a report.

    The recording (33 angles, 2000 samples at 1 kHz each) was generated from the paper's Table I
    cilium as an exact body (a stack of magpylib cylinders, not the model's dipoles) with the
    sensor's noise, drift and a DC bias (scripts/make_example_recording.py). The fit starts from
    Table I's initial values, as in the paper, and is shown beside the recording's known truth,
    with what the data determine and what they leave open: the paper's model meets its own model
    error here, so its lengths are effective values (calibrate --model physical fits the hair's).
    The --out folder is published in one rename when everything is written (see `magcilia
    calibrate --help`).
    """
    with staged_directory(out_dir, force=force, names=CALIBRATION_NAMES) as tmp, \
            figure_writer(style) as writer:  # (readies matplotlib while the demo fits)
        path = example_path()
        initial = Setup.paper_initial()
        data = read_measurements(path, sensor=initial.sensor)
        click.echo(f"bundled synthetic recording: {path.name}, {len(data)} angles, "
                   f"{int(data.counts.sum())} samples")
        result = calibrate_with_progress(data, initial, quiet=quiet, rng=seed,
                                         fixed=parse_fixed(fix_items))
        result = result.with_truth(example_truth(path))
        write_calibration_files(result, tmp, style, writer=writer)
        writer.wait()
    click.echo(result.report())
    click.echo(f"report written to {Path(out_dir) / 'report.md'} (figures fit.png, residuals.png; "
               "fitted setup fitted_setup.toml)")


def example_truth(path: Path) -> dict[str, float]:
    """The true parameters (SI) of the bundled synthetic recording, from its JSON sidecar: the
    fitted ones, the magnetization scale, and the offset with the recording's DC bias in it."""
    meta = json.loads(path.with_suffix(".json").read_text(encoding="utf-8"))
    truth = meta["truth"]
    out = {n: float(truth[n]) for n in (*PARAMETERS, "magnetization_scale") if n in truth}
    out["offset"] = float(truth.get("offset", 0.0)) + float(meta["noise"].get("bias", 0.0))
    return out
