"""``magcilia ringdown``: the modulus and damping ratio of a flicked cilium from its ring-down."""

from __future__ import annotations

import click

from magcilia._errors import MagciliaError
from magcilia._validate import fail
from magcilia.analysis.ringdown import SIZE, ringdown
from magcilia.cli._common import (
    Physical,
    RecordingArgs,
    echo_json,
    load_setup_arg,
    recording_options,
    setup_option,
)
from magcilia.device.parameters import PARAMETERS
from magcilia.io.setup_files import load_priors
from magcilia.mechanics.drag import FLUIDS
from magcilia.units import dimension_words, parse_values


def _size_sigma(items: tuple[str, ...]) -> dict[str, float]:
    """``--size-sigma NAME=SIGMA`` items (mm, or with units) -> SI σ by name."""
    out: dict[str, float] = {}
    for item in items:
        name, _, text = item.partition("=")
        name = name.strip()
        if name not in SIZE:
            raise fail("--size-sigma", item, "NAME=SIGMA with NAME one of " + ", ".join(SIZE))
        p = PARAMETERS[name]
        try:
            (sigma,) = parse_values(text, p.dimension, p.display, "--size-sigma", (1,))
        except MagciliaError:
            sigma = -1.0
        if not sigma > 0:
            raise fail("--size-sigma", item, f"NAME=SIGMA with SIGMA a positive "
                                             f"{dimension_words(p.dimension, p.display)}, e.g. "
                                             f"{name}=0.02")
        out[name] = sigma
    return out


@click.command()
@click.argument("recording", type=click.Path(dir_okay=False))
@setup_option("The cilium whose size turns the frequency into a modulus (without it: frequency, "
              "decay and damping ratio only)", positional=False, optional=True)
@click.option("--fluid", type=click.Choice(sorted(FLUIDS)), default=None,
              help="The fluid around the hair: its added mass lowers the frequency (the modal "
                   "model, Sader's hydrodynamic function) [default: vacuum; a flick in air reads "
                   "~0.5 % softer without --fluid air].")
@click.option("--gravity", is_flag=True, help="The modal model with the hair's own weight.")
@click.option("--source-rate", "rate", type=Physical.of("frequency"), default=None,
              help="The recording's sample rate, Hz (default: from its time_s column).")
@click.option("--channel", default=None, metavar="NAME",
              help="The channel that rings: voltage, field_x, field_y or field_z [default: the "
                   "output voltage_V, else field_x].")
@click.option("--start", type=Physical.of("time"), default=None,
              help="Where the free oscillation starts, s from the first sample (default: at the "
                   "flick's largest deviation, or where a held deflection is released).")
@click.option("--second-mode", is_flag=True,
              help="Fit a second mode beside the first (a flick that rang two).")
@click.option("--size-sigma", "size_items", multiple=True, metavar="NAME=SIGMA",
              help="1 σ of height, base_radius or tip_radius, mm or with units (height=0.05, "
                   "base_radius=5um); repeatable. A setup file's [priors] table gives the size "
                   "with its σ too (these override it).")
@click.option("--json", "as_json", is_flag=True,
              help="Print the result as JSON (SI; with a modulus, the prior that `magcilia "
                   "calibrate --prior-from FILE` reads).")
@recording_options
def command(recording: str, setup_arg: str | None, fluid: str | None, gravity: bool,
            rate: float | None, channel: str | None, start: float | None, second_mode: bool,
            size_items: tuple[str, ...], as_json: bool, reading: RecordingArgs) -> None:
    """Young's modulus and damping ratio from the ring-down of a flicked cilium.

    Finds the free oscillation in RECORDING (CSV, .tdms of `magcilia record` or `live
    --record`, .mat, .h5: a time series of the output or a field channel) after a flick or a
    coil pulse, and fits its damped frequency and decay with σ.

    With --setup, the Young's modulus at which the modal model rings at the measured frequency
    (MPa, with σ from the frequency and the size's σ, and which dominates) and the calibration
    prior it gives (--prior youngs_modulus=VALUE:SIGMA, or --prior-from the --json output).
    """
    setup = None if setup_arg is None else load_setup_arg(setup_arg)
    sizes: dict[str, float] = {}
    if setup is not None and setup_arg is not None and setup_arg.lower().endswith(".toml"):
        priors = {k: p for k, p in load_priors(setup_arg).items() if k in SIZE}
        if priors:
            setup = setup.replace(**{k: p[0] for k, p in priors.items()})
            sizes = {k: p[1] for k, p in priors.items()}
    sizes |= _size_sigma(size_items)
    if sizes and setup is None:
        raise fail("--size-sigma", size_items[0], "given with --setup (the size it is the σ of)")
    result = ringdown(recording, rate, setup=setup, fluid=fluid,
                      gravity=gravity, channel=channel, start=start, second_mode=second_mode,
                      size_sigma=sizes, **reading.kwargs())
    if as_json:
        echo_json(result.to_dict())
        return
    click.echo(result.report())
