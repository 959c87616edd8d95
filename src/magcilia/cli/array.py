"""``magcilia array``: an array of cilia over three-axis sensors: forward map, read-out,
crosstalk and metrics vs pitch."""

from __future__ import annotations

import csv
import io
import math
from pathlib import Path
from typing import Any

import click
import numpy as np

from magcilia._atomic import figure_bytes, figure_format, json_text, write_files
from magcilia._errors import MagciliaError
from magcilia._validate import fail
from magcilia.cli._common import (
    array_file_arg,
    echo_json,
    setup_option,
    si_option,
    style_option,
)
from magcilia.cli._options import SEED
from magcilia.cli._outputs import OUTPUT_FILE, writes_files
from magcilia.io.array_file import MAX_LOAD_SETS, load_array, load_array_grid, read_loads
from magcilia.readout.array import ArrayReadout, array_metrics, field_for_loads
from magcilia.report.array import (
    crosstalk_rows,
    field_rows,
    metrics_rows,
    readout_rows,
    rows_text,
)
from magcilia.report.units import output_units, show
from magcilia.units import parse_range, parse_value

#: most pitches of a ``--pitches`` grid (each builds and checks a whole array)
MAX_PITCHES = 200
#: the span when --span is not given, N
DEFAULT_SPAN = 2e-5


def pitch_grid(text: str) -> np.ndarray:
    """``--pitches START:STOP:STEP`` in mm or with a length unit (stop included when on the
    grid) -> m."""
    start, stop, step = parse_range(text, "--pitches", "mm")
    if step is None or start <= 0.0:
        raise fail("--pitches", text, "START:STOP:STEP with 0 < START < STOP, in mm or with a "
                                      "length unit, e.g. 1.5:6:0.5mm")
    count = (stop - start) / step + 1e-9
    if not count < MAX_PITCHES:
        raise fail("--pitches", text, f"at most {MAX_PITCHES} pitches (MAX_PITCHES); use a "
                                      "larger step")
    return np.asarray(start + step * np.arange(math.floor(count) + 1), dtype=np.float64)


def random_loads(sets: int, cilia: int, span: float, rng: np.random.Generator) -> np.ndarray:
    """``sets`` sets of horizontal loads on ``cilia`` cilia, N, shape (sets, C, 2): uniform over
    the disc of radius 0.9 × span (magnitude 0.9 span √u, direction uniform)."""
    mag = 0.9 * span * np.sqrt(rng.uniform(0.0, 1.0, (sets, cilia)))
    phi = rng.uniform(-np.pi, np.pi, (sets, cilia))
    return np.stack([mag * np.cos(phi), mag * np.sin(phi)], axis=-1)


def _csv(rows: list[dict[str, Any]]) -> str:
    buf = io.StringIO()
    writer = csv.DictWriter(buf, fieldnames=list(rows[0]), lineterminator="\n")
    writer.writeheader()
    writer.writerows(rows)
    return buf.getvalue()


@click.command()
@writes_files
@setup_option("The array: an array setup file ([[cilia]] and [[sensors]], or the [array] "
              "grid), or the array preset")
@click.option("--span", "span_text", default=None,
              help="Largest horizontal tip force per cilium (the read-out's range): mN, or with "
                   "a unit (0.02mN, 20uN).  [default: 0.02 mN]")
@click.option("--loads", "loads_path", type=click.Path(dir_okay=False), default=None,
              help="CSV of tip loads: Fx_<unit>, Fy_<unit> (e.g. Fx_mN), optional cilium and "
                   "set columns.")
@click.option("--random", "random_sets", type=click.IntRange(1, MAX_LOAD_SETS), default=None,
              help="N sets of random loads (uniform over the disc of 0.9 span) instead of "
                   "--loads.")
@click.option("--seed", type=SEED, default=0, show_default=True,
              help="Seed of the random loads and of the sensors' noise.")
@click.option("--crosstalk", "show_crosstalk", is_flag=True,
              help="Print the crosstalk table (each cilium's site, response, worst other sensor, "
                   "ratio).")
@click.option("--metrics", "show_metrics", is_flag=True,
              help="Crosstalk ratio and minimum detectable force vs pitch (needs --pitches and "
                   "a file with the [array] grid).")
@click.option("--pitches", default=None,
              help="Pitches of --metrics, START:STOP:STEP in mm or with a unit (1.5:6:0.5mm).")
@click.option("--plot", "plot_path", type=OUTPUT_FILE,
              help="Write the array map (cilia, sensors, loads and field change of the first "
                   "load set; PNG/PDF/SVG by suffix).")
@click.option("--crosstalk-plot", "crosstalk_path", type=OUTPUT_FILE,
              help="Write the crosstalk image (sensor × cilium response).")
@click.option("--csv", "csv_path", type=OUTPUT_FILE,
              help="Write the forward map as CSV: per load set and sensor, the field (board "
                   "frame) and the noisy reading (sensor axes).")
@click.option("--readout-csv", "readout_path", type=OUTPUT_FILE,
              help="Write the read-out as CSV: per load set and cilium, truth, estimate, sigma, "
                   "error and flags.")
@click.option("--json", "as_json", is_flag=True, help="Print JSON instead of the tables.")
@click.option("--json-file", type=OUTPUT_FILE, help="Write the JSON to a file.")
@si_option
@style_option
def command(setup_arg: str, span_text: str | None, loads_path: str | None,
            random_sets: int | None, seed: int, show_crosstalk: bool, show_metrics: bool,
            pitches: str | None, plot_path: str | None, crosstalk_path: str | None,
            csv_path: str | None, readout_path: str | None, as_json: bool,
            json_file: str | None, si: bool, style: str) -> None:
    """An array of cilia over three-axis magnetometers (--setup: an array setup file
    with [[cilia]] and [[sensors]] or an [array] grid, e.g. examples/array.toml, or the array
    preset, a copy of it).

    The forward map: the field at every sensor (gauss; board frame) for the loads (--loads, or
    --random N sets; none: the rest field), the sensors' seeded noisy readings (their axes,
    range and LSB), and the inverse read-out of every cilium's force vector from all sensors at
    once, compared with the truth (Fx, Fy, |F|, direction, sigma with the force scale, flags,
    error over the noise's sigma: the simulated truth shares the model's modulus). With
    --crosstalk the crosstalk table, with --metrics the metrics vs pitch. Display units (mm, deg,
    mN, gauss) or SI with --si in the console, CSV and JSON alike; the files are written together
    once everything is computed.
    """
    for path, option in ((plot_path, "--plot"), (crosstalk_path, "--crosstalk-plot")):
        if path:
            figure_format(path, option)  # an unknown suffix fails before the work
    if loads_path is not None and random_sets is not None:
        raise fail("--random", random_sets, "either --loads or --random, not both")
    if pitches is not None and not show_metrics:
        raise fail("--pitches", pitches, "given with --metrics")
    if show_metrics and pitches is None:
        raise fail("--metrics", "no --pitches", "--metrics with --pitches START:STOP:STEP, "
                                                "e.g. 1.5:6:0.5mm")
    grid_pitches = pitch_grid(pitches) if pitches is not None else None
    span = DEFAULT_SPAN if span_text is None else parse_value(span_text, "force", "mN",
                                                              "--span", "0.02mN")
    if not span > 0.0:
        raise fail("--span", span_text, "a positive force in mN or with a unit, e.g. 0.02mN")
    path = array_file_arg(setup_arg)  # the array preset: its bundled file
    array = load_array(path)
    grid = load_array_grid(path) if show_metrics else None
    if show_metrics and grid is None:
        raise fail("--metrics", setup_arg, "an array file with the [array] grid (rows, cols, "
                                           "pitch, sensor): the metrics vary its pitch")
    rng = np.random.default_rng(seed)
    c_n = len(array)
    if loads_path is not None:
        loads = read_loads(loads_path, array.names)
    elif random_sets is not None:
        loads = random_loads(random_sets, c_n, span, rng)
    else:
        loads = np.zeros((1, c_n, 2))
    try:
        readout = ArrayReadout(array, span)
    except MagciliaError as exc:  # the array's checks under the span name cilia and sensors
        raise MagciliaError(f"{setup_arg}: {exc}") from None
    rest = array.field()
    fields, sensor_rows, cilium_rows, estimates = [], [], [], []
    for k, forces in enumerate(loads):
        field = field_for_loads(array, forces) if np.any(forces) else rest
        readings = array.readings(field, rng)
        est = readout.read_one(readings)
        fields.append(field)
        estimates.append(est)
        sensor_rows += field_rows(array, field, readings, load_set=k + 1)
        cilium_rows += readout_rows(est, forces, load_set=k + 1)
    crosstalk = readout.crosstalk() if (show_crosstalk or crosstalk_path or json_file
                                        or as_json) else None
    metrics = None
    if grid is not None and grid_pitches is not None:
        try:
            metrics = array_metrics(grid.setup, grid_pitches, sensor=grid.sensor, span=span,
                                    rows=grid.rows, cols=grid.cols, depth=grid.depth)
        except MagciliaError as exc:
            raise MagciliaError(f"--pitches {pitches}: {exc}") from None
    # the truth is simulated through the model with its own modulus: the force scale's share of
    # σ cannot show in the error, so the errors are counted against the noise's σ
    inside = np.concatenate([np.abs(e.force - f) <= 2.0 * e.sigma_noise
                             for e, f in zip(estimates, loads, strict=True)])
    summary = {"sets": len(loads), "cilia": c_n, "sensors": array.n_sensors,
               "within_2sigma": float(np.mean(inside)),
               "flagged": int(sum(int(np.count_nonzero(e.flags)) for e in estimates)),
               "saturated_readings": int(sum(r["saturated"] for r in sensor_rows)),
               "median_sigma_force_N": float(np.median([e.sigma_magnitude for e in estimates])),
               "median_sigma_force_noise_N": float(np.median(
                   [np.hypot(*e.sigma_noise.T) for e in estimates])),
               "largest_error_per_sigma": float(max(r["error_per_sigma"] for r in cilium_rows)),
               "rest_field_max_T": float(np.abs(rest).max())}
    if summary["saturated_readings"]:
        readings_total = len(loads) * array.n_sensors
        click.echo(f"magcilia: warning: {summary['saturated_readings']} of {readings_total} "
                   "sensor readings have an axis at or beyond the sensor's range (saturated: "
                   "flagged "
                   "'saturated' in the forward map, and the cilia they inform flagged in the "
                   "read-out); move the sensors further from the cilia or use a part with a "
                   "larger range", err=True)
    u = output_units(si)
    doc: dict[str, Any] = {
        "units": u.system, "setup": Path(setup_arg).name, "span_N": span, "seed": seed,
        "loads": "file" if loads_path else "random" if random_sets else "none",
        "summary": summary, "scale_note": estimates[0].scale_note, "field": sensor_rows,
        "readout": cilium_rows}
    if crosstalk is not None:
        doc["crosstalk"] = {"ratio_median": float(np.median(crosstalk.ratio)),
                            "ratio_max": float(crosstalk.ratio.max()),
                            "rows": crosstalk_rows(crosstalk)}
    if metrics is not None:
        doc["metrics"] = {"minimum_isolated_N": metrics.isolated, "rows": metrics_rows(metrics)}
    shown: dict[str, Any] = u.convert(doc)  # type: ignore[assignment]
    files: dict[str, str | bytes] = {}
    if csv_path:
        files[csv_path] = _csv(shown["field"])
    if readout_path:
        files[readout_path] = _csv(shown["readout"])
    if json_file:
        files[json_file] = json_text(shown)
    if plot_path or crosstalk_path:
        from magcilia.report import style as st
        from magcilia.report.array import plot_array_map, plot_crosstalk

        with st.use(style):
            if plot_path:
                change = fields[0] - rest if np.any(loads[0]) else rest
                ax = plot_array_map(array, change, loads[0] if np.any(loads[0]) else None)
                files[plot_path] = figure_bytes(ax.get_figure(), plot_path, dpi=st.dpi())
            if crosstalk_path and crosstalk is not None:
                ax = plot_crosstalk(crosstalk)
                files[crosstalk_path] = figure_bytes(ax.get_figure(), crosstalk_path,
                                                     dpi=st.dpi(), option="--crosstalk-plot")
    write_files(files)
    if as_json:
        echo_json(shown)
        return
    click.echo(_text(shown, u.system, len(loads), show_crosstalk))


def _text(doc: dict[str, Any], system: str, sets: int, crosstalk: bool) -> str:
    """The console tables of ``magcilia array`` from its (converted) JSON document."""
    s = doc["summary"]
    span_key = next(k for k in doc if k.startswith("span_"))
    sigma_key = next(k for k in s if k.startswith("median_sigma_force_")
                     and not k.startswith("median_sigma_force_noise_"))
    noise_key = next(k for k in s if k.startswith("median_sigma_force_noise_"))
    rest_key = next(k for k in s if k.startswith("rest_field_max_"))
    unit = span_key.removeprefix("span_")
    units = output_units(system == "SI")

    def force(value: float) -> str:  # in the unit of its magnitude (µN for a µN-scale force)
        return show(value * units.factor("force"), "force", units, digits=3)

    lines = [(f"{doc['setup']}: {s['cilia']} cilia over {s['sensors']} sensors, span "
             f"{doc[span_key]:.4g} {unit}, loads: {doc['loads']} ({sets} set"
             f"{'s' if sets != 1 else ''}, seed {doc['seed']}); units: {system}"),
             (f"rest field up to {s[rest_key]:.4g} {rest_key.removeprefix('rest_field_max_')}; "
             f"{s['saturated_readings']} saturated readings; read-out: "
             f"{100 * s['within_2sigma']:.1f}% of Fx, Fy within 2 noise sigma, {s['flagged']} "
             f"flagged, median sigma |F| {force(s[sigma_key])} (noise {force(s[noise_key])}), "
             f"largest error {s['largest_error_per_sigma']:.3g} noise sigma"),
             (f"{doc['scale_note']}: in every sigma; the simulated truth shares the model's "
              "modulus, so errors are counted against the noise's sigma")]
    first = [r for r in doc["field"] if r["set"] == 1]
    keys = [k for k in first[0] if k != "set"]
    lines += ["", "forward map" + (" (load set 1; all sets in --csv / --json)" if sets > 1
                                   else ""), rows_text(first, keys)]
    first = [r for r in doc["readout"] if r["set"] == 1]
    keys = [k for k in first[0] if k != "set" and not k.startswith(("true_direction",
                                                                     "sigma_Fx", "sigma_Fy"))]
    lines += ["", "read-out vs truth" + (" (load set 1; all sets in --readout-csv / --json)"
                                         if sets > 1 else ""), rows_text(first, keys)]
    if crosstalk and "crosstalk" in doc:
        ct = doc["crosstalk"]
        lines += ["", (f"crosstalk: ratio median {ct['ratio_median']:.3g}, largest "
                      f"{ct['ratio_max']:.3g}"), rows_text(ct["rows"])]
    if "metrics" in doc:
        m = doc["metrics"]
        iso = next(k for k in m if k.startswith("minimum_isolated_"))
        lines += ["", (f"metrics vs pitch (one cilium alone: minimum detectable force "
                      f"{m[iso]:.4g} {iso.removeprefix('minimum_isolated_')})"),
                  rows_text(m["rows"], [k for k in m["rows"][0]
                                        if not k.startswith("minimum_isolated")])]
    return "\n".join(lines)
