"""``magcilia demo``: the whole pipeline on the bundled (synthetic) example recording."""

from __future__ import annotations

from importlib import resources
from pathlib import Path

import click

from magcilia.cli.calibrate import run_calibration
from magcilia.device.setup import Setup
from magcilia.io.recordings import read_measurements


def example_path() -> Path:
    """Path of the bundled synthetic example recording (CSV)."""
    return Path(str(resources.files("magcilia") / "data" / "example_recording.csv"))


@click.command()
@click.option("--out", "out_dir", default="magcilia-demo", show_default=True,
              type=click.Path(file_okay=False), help="Output directory.")
@click.option("--seed", default=0, show_default=True, help="Random seed of the global search.")
@click.option("--quiet", is_flag=True, help="No progress bar.")
def command(out_dir: str, seed: int, quiet: bool) -> None:
    """Calibrate the paper's model to the bundled SYNTHETIC recording and write a report.

    The recording (33 angles, 2000 samples at 1 kHz each) was generated from the paper's Table I
    parameters with the sensor's noise, drift and a DC bias (scripts/make_example_recording.py).
    The fit starts from Table I's initial values, as in the paper.
    """
    path = example_path()
    initial = Setup.paper_initial()
    data = read_measurements(path, sensor=initial.sensor)
    click.echo(f"bundled synthetic recording: {path.name}, {len(data)} angles, "
               f"{int(data.counts.sum())} samples")
    result = run_calibration(data, initial, Path(out_dir), seed=seed, restarts=3, bias="offset",
                             bias_degree=0, fit_scale=False, bounds={}, quiet=quiet)
    click.echo(result.report())
    click.echo(f"report written to {Path(out_dir) / 'report.md'} (figures fit.png, residuals.png; "
               "fitted setup fitted_setup.toml)")
