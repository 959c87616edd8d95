"""``magcilia plan``: which tilt conditions to measure, D-optimal, next to the paper's sweep."""

from __future__ import annotations

import math
from typing import Any

import click
import numpy as np

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



def _noise(text: str | None, sensor: str) -> float | None:
    """``--noise``: V for the output (mV by default), T per component (gauss by default)."""
    if text is None:
        return None
    noise = (parse_value(text, "voltage", "mV", "--noise", "0.01mV") if sensor == "output"
             else parse_value(text, "field", "gauss", "--noise", "10nT"))
    if not noise > 0:
        raise fail("--noise", text, "a positive noise σ, e.g. "
                                    + ("0.01mV" if sensor == "output" else "10nT"))
    return noise


def _note(text: str) -> None:
    click.echo(text, err=True)


def _design(d: Any, units: OutputUnits) -> dict[str, Any]:
    """A design's figures as JSON in ``units``: rank, condition, log det, σ by parameter."""
    return {"rank": d.rank, "parameters": len(d.interest),
            "condition": d.condition if math.isfinite(d.condition) else None,
            "log_det": d.log_det if math.isfinite(d.log_det) else None,
            "stderr": {units.key(n, n): (units.value(float(s), n) if math.isfinite(s)
                                         else None)
                       for n, s in zip(d.names, d.stderr, strict=True) if n in d.interest}}


def _document(plan: CalibrationPlan, units: OutputUnits) -> dict[str, Any]:
    """The plan as JSON in ``units`` (unit suffixes on every dimensional key)."""
    noise_what = "output" if plan.sensor == "output" else "field"

    def design(d: Any) -> dict[str, Any]:
        return _design(d, units)

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


def _coil(setup: Any, budget: int, sensor: str, noise_text: str | None,
          prior_items: tuple[str, ...], fit: str | None, as_json: bool, quiet: bool,
          si: bool) -> None:
    """``plan --stimulus coil``: the D-optimal applied fields next to a naive x sweep."""
    from magcilia.calibration.coil_plan import coil_fit, plan_coil
    from magcilia.calibration.coil_rows import parameters_for

    allowed = parameters_for(sensor)
    names = (coil_fit(sensor) if fit is None
             else tuple(t.strip() for t in fit.split(",") if t.strip()))
    if not names or any(n not in allowed for n in names):
        raise fail("--fit", fit, f"comma-separated names among {', '.join(allowed)} "
                                 f"(--measure {sensor})")
    priors = parse_priors(prior_items, allowed)
    for n in priors:
        if n not in names:
            raise fail("--prior", n, "a prior on a fitted parameter (--fit "
                                     + ",".join(names) + ")")
    values = {n: mu for n, (mu, _) in priors.items() if n != "youngs_modulus"}
    if values:
        setup = setup.replace(**values)
    if "youngs_modulus" in priors:
        setup = setup.replace(youngs_modulus=priors["youngs_modulus"][0],
                              youngs_modulus_sigma=0.0)
    noise = _noise(noise_text, sensor)
    informative = len(names) - len(priors)
    if budget < informative:
        raise fail("--budget", budget, f"at least {informative} readings to determine "
                                       f"{', '.join(names)} (or a prior on some of them)")
    if not setup.params()["tip_radius"] > 0:
        raise fail("--setup", "a sharp tip (tip_radius 0)",
                   "a cilium with a positive tip radius for a coil plan (a field's couple on a "
                   "sharp cone is singular at the tip): e.g. examples/force-sensor.toml")
    with progress_bar("planning (starts)", "start", quiet=quiet) as advance:
        plan = plan_coil(setup, budget, measure=sensor, parameters=names,
                         prior_sd={n: sd for n, (_, sd) in priors.items()}, noise=noise,
                         progress=advance)
    if as_json:
        units = output_units(si)
        what = "output" if sensor == "output" else "field"

        def field(b: Any) -> Any:
            return units.value(np.round(np.asarray(b, dtype=float), 15).tolist(), "field")

        echo_json({
            "units": units.system, "setup_units": "SI", "stimulus": "coil", "measure": sensor,
            "budget": plan.design.budget, units.key("noise", what): units.value(plan.noise, what),
            "conditions": [{units.key("field", "field"): field(b), "repeats": n}
                           for b, n in plan.conditions()],
            "plan": _design(plan.design, units),
            "naive": {**_design(plan.naive, units),
                      units.key("fields", "field"): field(plan.naive_fields)}})
    else:
        click.echo(plan.report(si))


@click.command()
@setup_option(optional=True)
@click.option("--budget", default=None, type=int,
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
                   "10nT; with --stimulus coil the MMC5983MA's 0.4 mG); units allowed (0.01mV, "
                   "10nT).")
@click.option("--prior", "prior_items", multiple=True, metavar="NAME=VALUE:SIGMA",
              help="A manual measurement of a parameter as a Gaussian prior, display units "
                   "(height=3.26:0.1 in mm) or with units; VALUE also replaces the setup's. "
                   "Repeatable.")
@click.option("--stimulus", type=click.Choice(("tilt", "coil")), default="tilt",
              show_default=True,
              help="What moves the cilium: rigid tilts (the paper's rig), or a known uniform "
                   "field from a Helmholtz coil (applied field directions and magnitudes within "
                   "the sensor's range and below the AMR's flip field; needs a tip radius).")
@click.option("--fit", default=None, metavar="NAMES",
              help="--stimulus coil: the fitted parameters, comma-separated (default height, "
                   "base_radius, x, y, z, magnetization_scale and, for --measure output, "
                   "sensitivity; add youngs_modulus with a ring-down's --prior).")
@click.option("--identifiability", is_flag=True,
              help="Print the identifiability table of the coil calibration (coil, coil + "
                   "size, coil + size + ring-down, the paper's rig, rig + coil; paper and "
                   "force-sensor cilium; HMC1021Z and MMC5983MA) instead of a plan; with "
                   "--markdown as docs/coil-calibration.md holds it. SETUP and --budget are "
                   "not used.")
@click.option("--markdown", is_flag=True, help="With --identifiability: the Markdown table.")
@click.option("--json", "as_json", is_flag=True,
              help="Print the plan and the comparison as JSON (unit suffixes on the keys).")
@click.option("--quiet", is_flag=True, help="No progress bar.")
@si_option
def command(setup_arg: str | None, budget: int | None, sensor: str, azimuths: str,
            angles: str, noise_text: str | None, prior_items: tuple[str, ...], stimulus: str,
            fit: str | None, identifiability: bool, markdown: bool, as_json: bool,
            quiet: bool, si: bool) -> None:
    """Plan a tilt-table calibration of SETUP: the BUDGET readings (tilt angles × azimuths) that
    pin down height, base radius and x, y, z best (D-optimal, each azimuth one experiment with
    its own offset), printed next to the paper's equally spaced angles on one path with the same
    budget: rank, condition number and the expected standard error of each parameter.

    With --stimulus coil it plans a coil calibration instead: the applied uniform fields
    (directions and magnitudes, gauss) that pin down the fitted parameters best, next to a naive
    sweep along x of the same budget. --identifiability prints the table of what each
    calibration determines (docs/coil-calibration.md)."""
    if identifiability:
        from magcilia.analysis.identifiability_table import identifiability_table

        table = identifiability_table(progress=None if quiet else _note)
        if as_json:
            echo_json(table.to_dict())
        else:
            click.echo(table.markdown() if markdown else table.report())
        return
    if setup_arg is None:
        raise fail("--setup", "nothing", "the sensor setup to plan for (a preset name or a "
                                         "setup TOML), e.g. --setup force-sensor")
    if budget is None:
        raise fail("--budget", "nothing", "the number of readings N to plan, e.g. --budget 33")
    setup = load_setup_arg(setup_arg)
    if stimulus == "coil":
        _coil(setup, budget, sensor, noise_text, prior_items, fit, as_json, quiet, si)
        return
    if fit is not None:
        raise fail("--fit", fit, "--fit with --stimulus coil (a tilt plan fits "
                                 + ", ".join(PLAN_PARAMETERS) + ")")
    priors = parse_priors(prior_items, PLAN_PARAMETERS)
    values = {n: mu for n, (mu, _) in priors.items()}
    sds = {n: sd for n, (_, sd) in priors.items()}
    if values:
        setup = setup.replace(**values)
    grid = angle_grid(angles)
    phis = _azimuths(azimuths)
    noise = _noise(noise_text, sensor)
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
