"""``magcilia calibrate``: fit the model to a recording and write setup, result and report."""

from __future__ import annotations

import click

from magcilia._atomic import staged_directory
from magcilia._errors import MagciliaError
from magcilia.calibration import PARAMETERS, CalibrationResult, calibrate
from magcilia.calibration.problem import COIL_PARAMETERS, GEOMETRY, LOAD_PARAMETER
from magcilia.cli._common import (
    RecordingArgs,
    calibrate_with_progress,
    echo_json,
    fit_options,
    load_setup_arg,
    parse_named_ranges,
    parse_priors,
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
from magcilia.io.recordings import FLUID_NAMES, Measurement, read_measurements
from magcilia.io.setup_files import load_priors
from magcilia.io.temperature_table import temperature_table
from magcilia.report.calibration import (
    CALIBRATION_NAMES,
    calibration_files,
    calibration_json,
    model_comparison,
    write_calibration_files,
)
from magcilia.report.figure_process import figure_writer
from magcilia.report.recording_notes import notes_lines


def _ringdown_priors(paths: tuple[str, ...]) -> dict[str, tuple[float, float]]:
    """The modulus priors of ring-down JSON files (the last one wins)."""
    if not paths:
        return {}
    from magcilia.analysis.ringdown import ringdown_prior

    out: dict[str, tuple[float, float]] = {}
    for path in paths:
        out |= ringdown_prior(path)
    return out


def refuse_undetermined_coil(result: CalibrationResult, measurements: list[Measurement]) -> None:
    """With coil recordings, a fit that leaves a combination of parameters undetermined (the
    Fisher information's null space: no size information, fields along one axis only) is an
    error on the command line (exit 2, nothing written): the API returns it with the
    ``undetermined`` warning and infinite standard errors instead."""
    if not any(m.is_coil for m in measurements):
        return
    for w in result.diagnostics:
        if w.kind == "undetermined":
            raise MagciliaError(f"coil calibration: {w.message}; nothing written")


@click.command()
@click.argument("data", nargs=-1, required=True, type=click.Path(dir_okay=False))
@setup_option("Initial setup", default="paper-initial", positional=False)
@click.option("--out", "out_dir", required=True, type=click.Path(file_okay=False),
              help="Output directory (fitted_setup.toml, result.json, report.md, figures); "
                   "must not exist yet, or be empty.")
@click.option("--force", is_flag=True,
              help="Replace an existing --out folder (an earlier output of this command) whole.")
@click.option("--bound", "bound_items", multiple=True, metavar="NAME=LOW:HIGH",
              help="Search bound, lengths in mm or with units (height=2.5:4, z=0mm:0.8mm; n_loops, "
                   f"dipoles_per_loop whole numbers); repeatable. Defaults: {describe_bounds()}.")
@click.option("--model", type=click.Choice(["paper", "physical", "both"]), default="paper",
              show_default=True,
              help="paper: n and k searched, one output recording at azimuth 0 (Fig. 8). "
                   "physical: n and k at a converged layout, so height and base radius are the "
                   "hair's dimensions; several recordings (any azimuth, output or 3-axis field) "
                   "fitted together. both: the physical fit written, the paper's model fitted to "
                   "the first recording beside it in the report.")
@click.option("--prior", "prior_items", multiple=True, metavar="NAME=VALUE:SIGMA",
              help="Gaussian prior from a manual measurement (--model physical), lengths in mm "
                   "or with units (height=3.0:0.2, height=3mm:200um); repeatable. A setup "
                   "file's [priors] table gives them too (these override it).")
@click.option("--prior-from", "prior_files", multiple=True, metavar="RINGDOWN.json",
              type=click.Path(dir_okay=False),
              help="The modulus prior of a ring-down (the JSON `magcilia ringdown --setup ... "
                   "--json` prints; --model physical); --prior overrides it.")
@click.option("--fix", "fix_items", multiple=True, metavar="NAME=VALUE", help=FIX_HELP)
@click.option("--fluid", type=click.Choice(sorted(FLUID_NAMES)), default="water", show_default=True,
              help="Fluid of flow recordings (a flow_m_per_s column; --model physical).")
@click.option("--posterior", is_flag=True,
              help="With --model physical: also sample the posterior of the geometry (emcee, "
                   "1000 effective samples, at most a minute): credible intervals in the report, "
                   "pairs.png.")
@click.option("--seed", type=SEED, default=0, show_default=True,
              help="Random seed of the global search.")
@click.option("--restarts", default=1, show_default=True,
              help="Independent global searches, the best kept (one finds the best fit of a "
                   "33-angle recording in > 99 % of cases; more make a miss rarer).")
@click.option("--starts", type=int, default=None,
              help="Local fits started by each global search [default: 256; 64 with --model "
                   "physical].")
@fit_options
@click.option("--json", "as_json", is_flag=True,
              help="Print the result as JSON, in the units of the console table (mm, mV, deg; SI "
                   "with --si; result.json in --out is always SI).")
@click.option("--quiet", is_flag=True, help="No progress bar.")
@si_option
@style_option
@suspect_option
@recording_options
def command(data: tuple[str, ...], setup_arg: str, out_dir: str, bound_items: tuple[str, ...],
            seed: int, restarts: int, starts: int | None, bias: str, bias_degree: int,
            fit_scale: bool, nan_policy: str, saturation: str, as_json: bool, quiet: bool,
            force: bool, fix_items: tuple[str, ...], si: bool, style: str, reading: RecordingArgs,
            model: str, prior_items: tuple[str, ...], posterior: bool, fluid: str,
            suspect: str, prior_files: tuple[str, ...] = ()) -> None:
    """Calibrate the model to the recording DATA (CSV, .mat, .tdms or .h5), or with --model
    physical to several recordings (experiments) at once.

    Writes fitted_setup.toml (usable by every other command), result.json, report.md, fit.png
    and residuals.png into --out, a new folder published in one rename when everything is
    written: nothing is written if anything fails, and a killed run leaves no partial folder.

    Before fitting, each recording's samples are checked (--suspect): what is flagged, and what
    a reader says of the file (a recording cut short and the planned angles it lacks, damage
    read past), is printed as note lines and kept in report.md and result.json ("data").

    Recordings with a temperature column (temperature_K or temperature_degC) give the range of
    temperatures over the samples fitted: printed ("temperature 293.2–296.8 K during
    calibration"), kept in result.json and written into fitted_setup.toml's [temperature] table
    (calibrated_range, and reference their mean), so that readout and live flag readings
    outside it. Without one, the setup file's [temperature] table is written as given.
    """
    # the figures' helper process readies matplotlib while the recordings are read and fitted
    with staged_directory(out_dir, force=force, names=CALIBRATION_NAMES) as tmp, \
            figure_writer(style) as writer:
        initial = load_setup_arg(setup_arg)
        if model == "paper" and len(data) > 1:
            raise MagciliaError(f"{len(data)} recordings given: --model paper fits one; use "
                                "--model physical to fit several together")
        measurements = [reading.read(read_measurements, path, quiet=quiet,
                                     sensor=initial.sensor, nan_policy=nan_policy,
                                     saturation=saturation, fluid=fluid, suspect=suspect)
                        for path in data]
        bounds = parse_named_ranges("--bound", bound_items, PARAMETERS)
        priors = {**(load_priors(setup_arg) if setup_arg.lower().endswith(".toml") else {}),
                  **_ringdown_priors(prior_files),
                  **parse_priors(prior_items, (*GEOMETRY, LOAD_PARAMETER, *COIL_PARAMETERS))}
        if model == "both" and (measurements[0].observable != "output"
                                or not measurements[0].single_azimuth):
            raise MagciliaError(f"{data[0]}: --model both fits the paper's model to the first "
                                "recording, which must be the output tilted toward azimuth 0")
        if model == "paper" and posterior:
            raise MagciliaError("--posterior needs --model physical (the posterior of the hair's "
                                "geometry; the paper's model searches n and k)")
        if model == "paper" and priors:
            raise MagciliaError("priors (--prior, --prior-from, a setup file's [priors]) need "
                                "--model physical "
                                "(in the paper's model height and base radius are model "
                                "parameters, not the hair's dimensions)")
        result: CalibrationResult
        comparison = None
        if model in ("physical", "both"):  # one search (no restarts to show progress over)
            result = calibrate(measurements, initial, bounds, rng=seed, bias=bias,
                               fit_scale=fit_scale, starts=starts, fixed=parse_fixed(fix_items),
                               model="physical", priors=priors or None, posterior=posterior)
            if model == "both":
                paper = calibrate_with_progress(
                    measurements[0], initial, quiet=quiet, rng=seed, restarts=restarts,
                    starts=None, fixed=parse_fixed(fix_items) or None)
                comparison = model_comparison(paper, result)
        else:
            result = calibrate_with_progress(
                measurements[0], initial, quiet=quiet, bounds=bounds, rng=seed, bias=bias,
                bias_degree=bias_degree, fit_scale=fit_scale, restarts=restarts, starts=starts,
                fixed=parse_fixed(fix_items))
        refuse_undetermined_coil(result, measurements)
        write_calibration_files(result, tmp, style, comparison=comparison, data=measurements,
                                writer=writer, temperature=temperature_table(setup_arg)
                                if setup_arg.lower().endswith(".toml") else None)
        writer.wait()  # (the folder is published only with its figures)
    notes = [] if as_json else notes_lines(measurements)
    for line in notes:
        click.echo(line)
    if as_json:
        echo_json(calibration_json(result, si, measurements))
        return
    click.echo(result.report(si))
    if comparison is not None:
        click.echo(comparison)
    click.echo(f"wrote {in_folder(out_dir)}" + ", ".join(calibration_files(result)))


