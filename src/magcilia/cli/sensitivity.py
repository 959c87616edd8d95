"""``magcilia sensitivity``: one-at-a-time sweeps (figs. 9–12), Sobol indices and placement
tolerance."""

from __future__ import annotations

import math
import sys
from pathlib import Path

import click

from magcilia._atomic import staged_directory
from magcilia._errors import MissingDependencyError, require
from magcilia._validate import fail
from magcilia.analysis import STUDY_PARAMETERS, sensitivity_study, sobol_indices
from magcilia.analysis.tolerance import placement_tolerance
from magcilia.cli._common import (
    Physical,
    RecordingArgs,
    RenamedOption,
    bandwidth_option,
    echo_json,
    execution_options,
    load_setup_arg,
    parse_bandwidth,
    parse_named_ranges,
    recording_options,
    setup_option,
    si_option,
    style_option,
)
from magcilia.cli._options import SEED
from magcilia.device.parameters import describe_spans
from magcilia.io.recordings import read_measurements
from magcilia.report.sensitivity import (
    FIGURE_FILES,
    FIGURE_NAMES,
    report_dict,
    tolerance_text,
    write_sensitivity_report,
)
from magcilia.report.units import output_units
from magcilia.units import ascii_unit

#: every file ``magcilia sensitivity --out`` may write (sobol.png only with Sobol indices)
SENSITIVITY_FILES = (*FIGURE_FILES.values(), "xy_map.png", "sobol.png", "sensitivity.json",
                     "summary.md", *FIGURE_NAMES)


@click.command()
@setup_option()
@click.option("--data", type=click.Path(dir_okay=False),
              help="Recording (CSV/.mat/.tdms): adds the calibration cost (offset solved) "
                   "to every sweep.")
@click.option("--out", "out_dir", required=True, type=click.Path(file_okay=False),
              help="Output directory (figures, sensitivity.json, summary.md); must not exist "
                   "yet, or be empty.")
@click.option("--force", is_flag=True,
              help="Replace an existing --out folder (an earlier output of this command) whole.")
@click.option("--sweep", "span_items", cls=RenamedOption, old="--span", multiple=True,
              metavar="NAME=LOW:HIGH",
              help="Sweep span, lengths in mm or with units (x=0.5:2.5, height=2mm:4mm; "
                   "n_loops, dipoles_per_loop whole numbers); repeatable. Defaults: "
                   f"{describe_spans()}.")
@click.option("--points", default=21, show_default=True, help="Values per continuous sweep.")
@click.option("--map-points", default=41, show_default=True,
              help="Grid points per axis of the x-y map.")
@click.option("--sobol-base", default=1024, show_default=True,
              help="Sobol base sample N (power of 2; N*(p+2) evaluations over the calibration "
                   "bounds); 0 skips the global analysis.")
@click.option("--sobol-measure", type=click.Choice(["rms", "shape", "cost"]), default="rms",
              show_default=True,
              help="Sobol output per sample: RMS change of the curve, the offset-free change, or "
                   "the calibration cost (needs --data).")
@click.option("--seed", type=SEED, default=0, show_default=True,
              help="Random seed of the Sobol sampling.")
@click.option("--accuracy", default="1", show_default=True, type=Physical.of("angle", "1deg"),
              help="Target angle accuracy for the placement tolerance: degrees, or with a unit.")
@bandwidth_option("Read-out band for the sensor noise, F_LOW:F_HIGH in Hz.")
@click.option("--json", "as_json", is_flag=True, help="Print sensitivity.json to stdout too.")
@click.option("--quiet", is_flag=True, help="No progress bar.")
@execution_options("the Sobol evaluations in this process")
@si_option
@style_option
@recording_options
def command(setup_arg: str, data: str | None, out_dir: str, span_items: tuple[str, ...],
            points: int, map_points: int, sobol_base: int, sobol_measure: str, seed: int,
            accuracy: float,
            bandwidth: str, as_json: bool, quiet: bool, force: bool, si: bool, style: str,
            reading: RecordingArgs, workers: int | None, scheduler: str | None,
            timeout: float) -> None:
    """Sensitivity of the model around SETUP (a setup TOML file or a preset: paper, paper-initial).

    Writes the paper's figs. 9-12 equivalents (fig09_xy.png ... fig12_geometry.png), an x-y map
    (xy_map.png), Sobol bars (sobol.png), sensitivity.json (the console's units: mm, deg, mV; SI
    with --si; every key names its unit) and summary.md into --out,
    a new folder published in one rename when everything is written: nothing is written if
    anything fails, and a killed run leaves no partial folder.
    """
    out = Path(out_dir)
    with staged_directory(out, force=force, names=SENSITIVITY_FILES) as tmp:
        setup = load_setup_arg(setup_arg)
        spans = parse_named_ranges("--sweep", span_items, STUDY_PARAMETERS)
        band = parse_bandwidth(bandwidth)
        if not accuracy > 0:
            raise fail("--accuracy", f"{math.degrees(accuracy):g} deg", "a positive angle")
        if sobol_base < 0:
            raise fail("--sobol-base", sobol_base, "0 (skip) or a power of 2")
        if sobol_measure == "cost" and data is None and sobol_base:
            raise fail("--sobol-measure", "cost",
                       "used with --data (the cost needs measurements)")
        if sobol_base:  # fail before the sweeps, and say how to do without
            try:
                require("SALib", package="SALib", extra="sensitivity", purpose="Sobol indices")
            except MissingDependencyError as exc:
                raise MissingDependencyError(
                    f"{exc} (or skip them with --sobol-base 0)") from None
        measurement = None if data is None else reading.read(read_measurements, data,
                                                             quiet=quiet, sensor=setup.sensor)
        show = not quiet and sys.stderr.isatty()
        from tqdm import tqdm
        with tqdm(total=3, desc="sensitivity", unit="step", disable=not show,
                  file=sys.stderr) as bar:
            study = sensitivity_study(setup, measurement, spans=spans, points=points,
                                      map_points=map_points)
            bar.update()
            sobol = (sobol_indices(setup, n_base=sobol_base, measure=sobol_measure,
                                   data=measurement, rng=seed, workers=workers,
                                   scheduler=scheduler, timeout=timeout)
                     if sobol_base else None)
            bar.update()
            tolerance = placement_tolerance(setup, accuracy, bandwidth=band)
            bar.update()
        units = output_units(si)
        written = write_sensitivity_report(study, tmp, sobol, tolerance, units, style)
    doc = report_dict(study, sobol, tolerance, units)
    if as_json:
        echo_json(doc)
        return
    volt = units.unit("voltage")
    change, shape = f"max RMS change/{volt}", f"offset-free/{volt}"
    cost = "min cost/V^2"
    click.echo(f"{'parameter':<18} {'span':>22} {change:>18} {shape:>15}"
               + (f" {cost:>13}" if measurement is not None else ""))
    v = ascii_unit(volt)
    for r in doc["summary"]:
        name = r["parameter"]
        unit = units.unit(name)
        lo, hi = r[units.key("span", name)]
        span = f"{lo:.4g}..{hi:.4g} {unit}".rstrip()
        line = (f"{name:<18} {span:>22} {r[f'max_rms_change_{v}']:18.4g} "
                f"{r[f'max_shape_change_{v}']:15.4g}")
        if "min_cost_V2" in r:
            line += f" {r['min_cost_V2']:13.4g}"
        click.echo(line)
    for note in study.notes:
        click.echo(f"note: {note}")
    if sobol is not None:
        click.echo(sobol.report())
    click.echo(tolerance_text(doc["tolerance"], units))
    click.echo(f"wrote {', '.join(sorted(written))} to {out}")
