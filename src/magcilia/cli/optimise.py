"""``magcilia optimise``: design optimisation (geometry, material, placement, sensor) with the
Pareto front of range against resolution."""

from __future__ import annotations

import csv
import io
import math
from typing import Any

import click

from magcilia._atomic import figure_bytes, figure_format, json_text, write_files
from magcilia._validate import fail
from magcilia.cli._common import (
    Physical,
    RenamedOption,
    bandwidth_option,
    echo_json,
    load_mechanics_setup,
    mechanics_options,
    parse_bandwidth,
    parse_named_ranges,
    quiet_requested,
    setup_label,
    setup_option,
    si_option,
    style_option,
)
from magcilia.cli._options import SEED
from magcilia.cli._outputs import OUTPUT_FILE, writes_files
from magcilia.design import (
    DEFAULT_BOUNDS,
    OBJECTIVES,
    VARIABLES,
    Candidate,
    DesignOptimum,
    optimise_design,
)
from magcilia.design.measurands import BY_OBJECTIVE
from magcilia.design.robust import TOLERANCES, Tolerances
from magcilia.design.self_test import CoilSelfTest
from magcilia.mechanics import FLUIDS
from magcilia.report.units import output_units
from magcilia.report.units import show as show_value
from magcilia.units import OutputUnits


def _defaults() -> str:
    from magcilia.device.parameters import PARAMETERS

    return ", ".join(f"{n} {PARAMETERS[n].to_display(lo):g}:{PARAMETERS[n].to_display(hi):g}"
                     for n, (lo, hi) in DEFAULT_BOUNDS.items())


@click.command()
@writes_files
@setup_option(default="force-sensor")
@click.option("--objective", type=click.Choice(OBJECTIVES), default="force-range",
              show_default=True,
              help="force-range: the largest force range with a minimum detectable force <= "
                   "--min-force; flow-sensitivity: the finest speed resolution at --speed; "
                   "robust: the smallest calibration-free read-out error under --tolerance with "
                   "a minimum detectable force <= --min-force.")
@click.option("--tolerance", "tolerance_text", default=None, metavar="NAME=VALUE,...",
              help="Robust objective: 1-sigma fabrication and placement tolerances, e.g. "
                   "placement=50um,height=5%,base_radius=5%,magnetization=10%,modulus=30% "
                   "(those defaults for any not given; placement in mm or with a unit, the "
                   "others in % or as fractions).")
@click.option("--devices", "samples", type=click.IntRange(2, 100000), default=128,
              show_default=True,
              help="Robust objective: devices drawn per design (the same for every design).")
@click.option("--no-tare", is_flag=True,
              help="Robust objective: read each device's raw output (default: tared at rest).")
@click.option("--self-test", "self_test", type=click.Choice(["none", "coil"]), default="none",
              show_default=True,
              help="Robust objective: read each device after a start-up coil self-test (±3 G "
                   "pulses along x and y, a rest and a strap window, 0.25 s each, 4 cycles: "
                   "7 s; its sensitivity, magnetization and stiffness estimated; no rig, no "
                   "known load).")
@click.option("--min-force", type=Physical.of("force", "1uN"),
              help="Minimum detectable force the chosen design must reach, mN or with a unit "
                   "(1uN); default: the SETUP's own.")
@click.option("--speed", type=Physical.of("flow", "1mm/s"),
              help="Flow speed of the flow-sensitivity objective, m/s or with a unit (1mm/s).")
@click.option("--min-range", type=str, default=None,
              help="Constraint: the range at least this (force: mN, flow: m/s; or with a unit).")
@click.option("--max-field", type=Physical.of("field_range", "6gauss"),
              help="The rated range of |B| at the element, gauss: the range ends where the total "
                   "field reaches it (default: the sensor's own, the HMC1021Z's 6 gauss of the "
                   "total field; none for 3-axis parts, whose range is per axis).")
@click.option("--bound", "bound_items", multiple=True, metavar="NAME=LOW:HIGH",
              help="Search bound, lengths in mm or with units (height=2mm:5mm); NAME one of "
                   + ", ".join(VARIABLES) + f"; repeatable; LOW=HIGH fixes it. Defaults: "
                   f"{_defaults()} (mm); the material stays the SETUP's.")
@click.option("--sensors", "sensor_text", cls=RenamedOption, old="--sensor",
              default="HMC1021Z", show_default=True,
              help="Sensor choices, comma-separated: HMC1021Z (the SETUP's single-axis sensor) "
                   "and 3-axis presets (MMC5983MA, LIS3MDL).")
@click.option("--designs", type=click.IntRange(16, 2**22), default=1024, show_default=True,
              help="Designs screened (rounded up to a power of two).")
@click.option("--refine", type=click.IntRange(4, 4096), default=32, show_default=True,
              help="Screened designs measured with the exact (large-deflection) metrics.")
@click.option("--polish", type=click.IntRange(0, 10), default=2, show_default=True,
              help="Rounds of exact polishing: 16 designs around the chosen one, in a box of "
                   "±10 %% of each bound's width, halved each round.")
@click.option("--seed", type=SEED, default=0, show_default=True,
              help="Seed of the sample.")
@click.option("--workers", type=click.IntRange(1, 1024), default=None,
              help="Worker processes of the exact refinement (default: one per core from 256 "
                   "designs, else none; 1: none).")
@click.option("--scheduler", default=None, metavar="ADDRESS",
              help="Dask scheduler (tcp://HOST:PORT) to run the refinement on.")
@click.option("--fluid", type=click.Choice(sorted(FLUIDS)), default="water", show_default=True,
              help="Fluid of the flow objective (and of every design's dynamics).")
@click.option("--min-bandwidth", default=None, type=Physical.of("frequency", "100Hz"),
              help="Keep designs whose −3 dB bandwidth (the response to the measurand in the "
                   "fluid) is at least this: Hz, or with a unit (e.g. 0.2kHz).")
@click.option("--max-settling", default=None, type=Physical.of("time", "20ms"),
              help="Keep designs whose step settles within 2 % in at most this: s, or with a "
                   "unit (e.g. 20ms).")
@bandwidth_option()
@mechanics_options
@click.option("--plot", "plot_path", type=OUTPUT_FILE,
              help="Write the Pareto figure (PNG/PDF/SVG by suffix).")
@click.option("--csv", "csv_path", type=OUTPUT_FILE,
              help="Write the Pareto front as CSV (columns carry their units).")
@click.option("--json", "as_json", is_flag=True, help="Print JSON instead of the text.")
@click.option("--json-file", type=OUTPUT_FILE, help="Write the JSON to a file.")
@click.option("--setup-out", type=OUTPUT_FILE,
              help="Write the chosen design as a setup TOML file.")
@click.option("--quiet", is_flag=True, help="No progress bar.")
@si_option
@style_option
def command(setup_arg: str, objective: str, tolerance_text: str | None, samples: int,
            no_tare: bool, self_test: str, min_force: float | None, speed: float | None,
            min_range: str | None, max_field: float | None, bound_items: tuple[str, ...],
            sensor_text: str, designs: int, refine: int, polish: int, seed: int,
            workers: int | None, scheduler: str | None, fluid: str,
            min_bandwidth: float | None, max_settling: float | None, bandwidth: str,
            tip_radius: str | None, modulus: str | None, plot_path: str | None,
            csv_path: str | None, as_json: bool, json_file: str | None, setup_out: str | None,
            quiet: bool, si: bool, style: str) -> None:
    """Search the cilium's height, base and tip radius (and, given bounds, magnetization scale or
    cobalt mass), its placement and the sensor for the largest force range at a minimum
    detectable force (force-range), the best flow sensitivity at a speed (flow-sensitivity) or
    the smallest read-out error without a per-device calibration under fabrication and
    placement tolerances (robust); print the chosen design against SETUP's own and the Pareto
    front of range against resolution (mN and mm, SI with --si).

    SETUP (default: force-sensor, the paper's cilium with a 0.05 mm tip) supplies the material,
    the model and the sensor, and is the reference the result is compared with.
    """
    from magcilia.units import parse_value

    setup = load_mechanics_setup(setup_arg, tip_radius, modulus)
    if plot_path:
        figure_format(plot_path)  # a suffix matplotlib cannot write fails before the search
    measured = BY_OBJECTIVE[objective].quantity  # the objective's measurand: force or speed
    constraints: dict[str, float] = {}
    if min_range is not None:
        constraints["range"] = parse_value(min_range, measured.dimension, measured.display,
                                           "--min-range")
    if max_field is not None:
        constraints["field"] = max_field
    if min_bandwidth is not None:
        constraints["bandwidth"] = min_bandwidth
    if max_settling is not None:
        constraints["settling"] = max_settling
    sensors = tuple(s.strip() for s in sensor_text.split(",") if s.strip())
    if not sensors:
        raise fail("--sensors", sensor_text, "one or more sensor names, e.g. HMC1021Z,MMC5983MA")
    bounds = parse_named_ranges("--bound", bound_items, VARIABLES)
    tolerances = None
    if tolerance_text is not None:
        if objective != "robust":
            raise fail("--tolerance", tolerance_text, "given with --objective robust only")
        tolerances = parse_tolerances(tolerance_text)
    if self_test != "none" and objective != "robust":
        raise fail("--self-test", self_test, "given with --objective robust only")
    result = optimise_design(
        setup, objective, min_force=min_force, speed=speed, constraints=constraints or None,
        bounds=bounds or None, sensors=sensors, n=designs, refine=refine, polish=polish, rng=seed,
        workers=workers, scheduler=scheduler, bandwidth=parse_bandwidth(bandwidth),
        fluid=FLUIDS[fluid], progress=not quiet_requested(quiet), tolerances=tolerances,
        samples=samples, tare=not no_tare,
        self_test=CoilSelfTest() if self_test == "coil" else None)
    units = output_units(si)
    doc = optimise_doc(result, setup_label(setup_arg), units)
    files: dict[str, str | bytes] = {}  # every file computed first, then written together
    if csv_path:
        files[csv_path] = front_csv(doc)
    if json_file:
        files[json_file] = json_text(doc)
    if plot_path:
        from magcilia.report import style as st
        from magcilia.report.optimise import pareto_figure

        with st.use(style):
            files[plot_path] = figure_bytes(pareto_figure(result), plot_path, dpi=st.dpi())
    if setup_out:  # checked by reading it back before it is written
        from magcilia.io.setup_files import save_setup

        save_setup(result.best_setup, setup_out)
    write_files(files)
    if as_json:
        echo_json(doc)
        return
    click.echo(optimise_text(doc, units))


def parse_tolerances(text: str) -> Tolerances:
    """``--tolerance``'s ``NAME=VALUE,...`` as :class:`Tolerances` (the issue's defaults for
    the names not given): placement a length (mm, or with a unit: ``50um``), the others
    relative (``5%`` or ``0.05``)."""
    from magcilia.units import parse_value

    example = "placement=50um,height=5%"
    given: dict[str, float] = {}
    for item in (t.strip() for t in text.split(",")):
        name, sep, value = item.partition("=")
        name, value = name.strip(), value.strip()
        if not sep or not value:
            raise fail("--tolerance", item, f"NAME=VALUE items, e.g. {example}")
        if name not in TOLERANCES:
            raise fail("--tolerance name", name, "one of " + ", ".join(TOLERANCES))
        if name in given:
            raise fail("--tolerance", text, f"each name once ({name} is repeated)")
        if name == "placement":
            given[name] = parse_value(value, "length", "mm", "--tolerance placement", "50um")
        else:
            percent = value.endswith("%")
            number = value[:-1].strip() if percent else value
            try:
                fraction = float(number) / (100.0 if percent else 1.0)
            except ValueError:
                raise fail(f"--tolerance {name}", value, "a percentage (5%) or a fraction "
                           "(0.05)") from None
            given[name] = fraction
    return Tolerances(**given)


def _row(d: Candidate, quantity: str, units: OutputUnits) -> dict[str, Any]:
    """A design's row in ``units``: the variables, the sensor, the metrics (keys with units)."""
    return {**units.named(dict(d.params)), "sensor": d.sensor,
            units.key("minimum", quantity): units.value(d.minimum, quantity),
            units.key("range", quantity): units.value(d.range, quantity),
            "range_reached": d.reached, "limited_by": d.limited_by,
            units.key("peak_field", "field"): units.value(d.peak_field, "field"),
            "bandwidth_Hz": d.bandwidth, "settling_time_s": d.settling_time,
            "calibration_free_error": d.error, "calibration_free_error_p95": d.error_p95,
            "rank": d.rank, "eligible": d.eligible, "violated": d.violated}


def optimise_doc(result: DesignOptimum, label: str, units: OutputUnits) -> dict[str, Any]:
    """The JSON of ``magcilia optimise`` in ``units`` (every key of a number names its unit)."""
    q = result.quantity
    limits: dict[str, Any] = {}
    for key, value in result.fixed.items():
        if key in ("bandwidth", "settling"):  # Hz and s in either unit system
            limits[f"{key}_{'Hz' if key == 'bandwidth' else 's'}"] = value
            continue
        what = {"min_force": "force", "speed": "flow", "field": "field"}.get(key, q)
        limits[units.key(key, what)] = units.value(value, what)
    return {
        "units": units.system, "setup": label, "objective": result.objective, "quantity": q,
        "screened": result.screened, "refined": len(result.designs),
        "seconds": result.seconds, "constraints": limits,
        "eliminated_in_screen": dict(result.eliminated),
        "beats_reference": result.beats_reference, "comparison": result.comparison,
        "reference": _row(result.reference, q, units), "best": _row(result.best, q, units),
        "front": [_row(d, q, units) for d in result.front],
        "scale_note": result.best_setup.modulus.note(),
        **({"robust": result.robust_dict()} if result.robust is not None else {}),
    }


def front_csv(doc: dict[str, Any]) -> str:
    """The front's rows as CSV text (one row per design, the JSON's keys as columns)."""
    rows = doc["front"]
    buf = io.StringIO()
    writer = csv.DictWriter(buf, fieldnames=list(rows[0]), lineterminator="\n")
    writer.writeheader()
    for row in rows:
        writer.writerow({k: (repr(float(v)) if isinstance(v, float) else v)
                         for k, v in row.items()})
    return buf.getvalue()


def optimise_text(doc: dict[str, Any], units: OutputUnits) -> str:
    """What ``magcilia optimise`` prints, from :func:`optimise_doc`."""
    q = doc["quantity"]
    k_min, k_rng = units.key("minimum", q), units.key("range", q)

    def show(value: float | None, reached: bool = True) -> str:
        if value is None or not math.isfinite(value):
            return "-"  # a force in the unit of its magnitude (µN for a µN-scale one)
        return ("" if reached else "≥ ") + show_value(value * units.factor(q), q, units)

    what = "minimum detectable force" if q == "force" else "minimum detectable speed change"
    lines = [(f"{doc['objective']} from {doc['setup']}: {doc['screened']} designs screened, "
             f"{doc['refined']} refined, {len(doc['front'])} on the Pareto front"),
             f"{'':<10} {'range':>14} {'minimum':>14}  ({what})"]
    for label in ("reference", "best"):
        r = doc[label]
        lines.append(f"{label:<10} {show(r[k_rng], r['range_reached']):>14} "
                     f"{show(r[k_min]):>14}  {r['sensor']}; {r['limited_by']}")
    best = doc["best"]
    skip = {"sensor", k_min, k_rng, "limited_by", "rank", "eligible", "violated",
            "range_reached", "calibration_free_error", "calibration_free_error_p95"}
    lines.append("chosen design: " + ", ".join(f"{k} {v:.4g}" for k, v in best.items()
                                               if k not in skip and isinstance(v, float)))
    lines.append(f"compared with SETUP's: {doc['comparison']}")
    if "robust" in doc:
        r, tol = doc["robust"], doc["robust"]["tolerances"]

        def err(row: dict[str, Any]) -> str:
            return (f"{row['calibration_free_error'] * 100:.3g} % (95th percentile "
                    f"{row['calibration_free_error_p95'] * 100:.3g} %)")

        lines.append(f"calibration-free error, RMS of the range: reference {err(doc['reference'])}"
                     f", best {err(best)}; {r['samples']} devices, "
                     f"{'tared at rest' if r['tare'] else 'untared'}, under "
                     + Tolerances(tol["placement_m"], tol["height"], tol["base_radius"],
                                  tol["magnetization"], tol["modulus"]).report()
                     + ("" if not r.get("self_test") else
                        f"; read after a coil self-test ({r['self_test']['duration_s']:.3g} s)"))
    lines.append(f"Pareto front ({k_min}, {k_rng}, sensor):")
    lines += [f"  {show(r[k_min]):>14} {show(r[k_rng], r['range_reached']):>14}  {r['sensor']}"
              for r in doc["front"]]
    lines.append(f"{doc['scale_note']}: every range and minimum above scales with it")
    return "\n".join(lines)
