"""``magcilia plan``: which tilt conditions to measure, D-optimal, next to the paper's sweep."""

from __future__ import annotations

import math
from typing import Any

import click

from magcilia._validate import fail
from magcilia.calibration.plan import PLAN_PARAMETERS, SENSORS, CalibrationPlan, plan_calibration
from magcilia.cli._common import (
    RenamedOption,
    angle_grid,
    echo_json,
    load_setup_arg,
    parse_priors,
    progress_bar,
    setup_option,
    si_option,
)
from magcilia.report.units import output_units
from magcilia.units import OutputUnits, parse_value


def _azimuths(text: str) -> list[float]:
    """``0,90`` (deg, or with an angle unit per item) -> rad."""
    items = [t.strip() for t in text.split(",") if t.strip()]
    if not items:
        raise fail("--azimuths", text, "a comma-separated list of tilt directions in deg, "
                                       "e.g. 0,90")
    return [parse_value(t, "angle", "deg", "--azimuths", "0,90") for t in items]



def _document(plan: CalibrationPlan, units: OutputUnits) -> dict[str, Any]:
    """The plan as JSON in ``units`` (unit suffixes on every dimensional key)."""
    noise_what = "output" if plan.sensor == "output" else "field"

    def design(d: Any) -> dict[str, Any]:
        return {"rank": d.rank, "parameters": len(d.interest),
                "condition": d.condition if math.isfinite(d.condition) else None,
                "log_det": d.log_det if math.isfinite(d.log_det) else None,
                "stderr": {units.key(n, n): (units.value(float(s), n) if math.isfinite(s)
                                             else None)
                           for n, s in zip(d.names, d.stderr, strict=True) if n in d.interest}}

    return {
        "units": units.system, "setup_units": "SI", "sensor": plan.sensor,
        "budget": plan.design.budget,
        units.key("noise", noise_what): units.value(plan.noise, noise_what),
        "conditions": [{units.key("angle", "angle"): units.value(a, "angle"),
                        units.key("azimuth", "angle"): units.value(phi, "angle"),
                        "repeats": n} for a, phi, n in plan.conditions()],
        "plan": design(plan.design),
        "paper": {**design(plan.reference),
                  units.key("angles", "angle"): units.value(plan.reference_angles.tolist(),
                                                            "angle")},
    }


@click.command()
@setup_option()
@click.option("--budget", required=True, type=int,
              help="Number of readings N to plan (at least the number of parameters, 5; at "
                   "most what Fedorov's exchange does in about a minute: 2974 with the default "
                   "angles and azimuths, fewer with more of them).")
@click.option("--measure", "sensor", cls=RenamedOption, old="--sensor",
              type=click.Choice(SENSORS), default="output", show_default=True,
              help="What each reading measures: the AMR output, or the three field components "
                   "of a 3-axis magnetometer.")
@click.option("--azimuths", default="0,90", show_default=True,
              help="Tilt directions on offer, deg (comma-separated; units allowed).")
@click.option("--angles", default="0:85:2.5", show_default=True,
              help="Tilt angles on offer, START:STOP:STEP in deg (units allowed).")
@click.option("--noise", "noise_text", default=None,
              help="σ of one reading: mV for --measure output (default: the sensor's noise model, "
                   "one raw sample at 1 kHz), gauss per component for --measure field (default "
                   "10nT); units allowed (0.01mV, 10nT).")
@click.option("--prior", "prior_items", multiple=True, metavar="NAME=VALUE:SIGMA",
              help="A manual measurement of a parameter as a Gaussian prior, display units "
                   "(height=3.26:0.1 in mm) or with units; VALUE also replaces the setup's. "
                   "Repeatable.")
@click.option("--json", "as_json", is_flag=True,
              help="Print the plan and the comparison as JSON (unit suffixes on the keys).")
@click.option("--quiet", is_flag=True, help="No progress bar.")
@si_option
def command(setup_arg: str, budget: int, sensor: str, azimuths: str, angles: str,
            noise_text: str | None, prior_items: tuple[str, ...], as_json: bool,
            quiet: bool, si: bool) -> None:
    """Plan a tilt-table calibration of SETUP: the BUDGET readings (tilt angles × azimuths) that
    pin down height, base radius and x, y, z best (D-optimal, each azimuth one experiment with
    its own offset), printed next to the paper's equally spaced angles on one path with the same
    budget: rank, condition number and the expected standard error of each parameter."""
    setup = load_setup_arg(setup_arg)
    priors = parse_priors(prior_items, PLAN_PARAMETERS)
    values = {n: mu for n, (mu, _) in priors.items()}
    sds = {n: sd for n, (_, sd) in priors.items()}
    if values:
        setup = setup.replace(**values)
    grid = angle_grid(angles)
    phis = _azimuths(azimuths)
    noise = None
    if noise_text is not None:
        noise = (parse_value(noise_text, "voltage", "mV", "--noise", "0.01mV")
                 if sensor == "output" else
                 parse_value(noise_text, "field", "gauss", "--noise", "10nT"))
        if not noise > 0:
            raise fail("--noise", noise_text, "a positive noise σ, e.g. "
                                              + ("0.01mV" if sensor == "output" else "10nT"))
    if budget < len(PLAN_PARAMETERS) - len(sds):
        raise fail("--budget", budget, f"at least {len(PLAN_PARAMETERS) - len(sds)} readings "
                                       f"to determine {', '.join(PLAN_PARAMETERS)}")
    with progress_bar("planning (starts)", "start", quiet=quiet) as advance:
        plan = plan_calibration(setup, budget, sensor=sensor, azimuths=phis, angles=grid,
                                noise=noise, prior_sd=sds, progress=advance)
    if as_json:
        echo_json(_document(plan, output_units(si)))
    else:
        click.echo(plan.report(si))
