"""``magcilia readout --biaxial`` (force vectors from a 3-axis part's field columns) and the
options of a 3-axis part at the element that ``live`` shares (``--sensor``, ``--sensor-noise``,
a force-magnitude ``--span``)."""

from __future__ import annotations

from pathlib import Path

import click
import numpy as np

from magcilia._atomic import write_text
from magcilia._validate import fail
from magcilia.cli._common import RecordingArgs, echo_json, parse_vector, quiet_requested
from magcilia.cli._readout_inputs import parse_span, read_checked, tare_readings
from magcilia.device.actuation import Actuation
from magcilia.device.magnetometer import MAGNETOMETERS, Magnetometer
from magcilia.device.parameters import MEASURANDS, PARAMETERS
from magcilia.device.setup import Setup
from magcilia.io.columns import FIELD_KEYS
from magcilia.units import parse_value


def element_magnetometer(name: str, noise: str | None) -> Magnetometer:
    """``--sensor`` (a 3-axis magnetometer preset at the element, its axes along the board's)
    with ``--sensor-noise`` (its RMS noise per axis, required where the preset does not know
    it)."""
    key = next((k for k in MAGNETOMETERS if k.lower() == name.lower()), None)
    if key is None:
        raise fail("--sensor", name, "a 3-axis magnetometer preset: one of "
                   + ", ".join(sorted(MAGNETOMETERS)))
    overrides = {} if noise is None else {"noise": _sensor_noise(noise)}
    if noise is None and key in ("MLX90393", "TLV493D-A1B6"):
        raise fail("--sensor-noise", None, f"the RMS noise per axis of the {key} at your "
                   "settings, gauss or with a unit (e.g. 5mG or 5mG,5mG,8mG): magcilia does "
                   "not guess it")
    return Magnetometer.preset(key, **overrides)


def magnitude_span(text: str, what: str) -> float:
    """``--span`` of a force vector: HIGH or 0:HIGH (mN or with a unit) -> the largest
    magnitude, N (``what`` names the mode in the message)."""
    if ":" in text:
        lo, hi = parse_span(text, "force")
        if lo != 0.0:
            raise fail("--span", text, f"0:HIGH or HIGH with {what} (the force magnitude's "
                       "range starts at 0)")
        return hi
    q = MEASURANDS["force"]
    hi = parse_value(text, q.dimension, q.display, "--span", "0.2mN")
    if not hi > 0.0:
        raise fail("--span", text, "a positive force magnitude, mN or with a unit (0.02mN)")
    return hi


def _sensor_noise(text: str) -> tuple[float, float, float]:
    """``--sensor-noise``: one value or BX,BY,BZ, gauss or with units -> T (3,)."""
    p = PARAMETERS["field_range"]
    if "," in text:
        noise = parse_vector(text, "field", p.display, "--sensor-noise", "2mG,2mG,3mG")
    else:
        one = parse_span_value(text, "--sensor-noise")
        noise = (one, one, one)
    if not all(n > 0.0 for n in noise):
        raise fail("--sensor-noise", text, "a positive RMS noise per axis, gauss or with a unit")
    return noise


def parse_span_value(text: str, key: str) -> float:
    """One field value, gauss or with a unit -> T."""
    p = PARAMETERS["field_range"]
    return parse_value(text, "field", p.display, key, "2mG")


def biaxial_readout(setup: Setup, recording: str, span_text: str, sensor_name: str | None,
             sensor_noise: str | None, out_path: str, tare_spec: str | None,
             tare_file: str | None, si: bool, as_json: bool, quiet: bool,
             reading: RecordingArgs, actuation: Actuation | None, suspect: str) -> None:
    """``magcilia readout --biaxial``: force vectors from 3-axis field columns (compensating a
    constant actuation: a uniform field along z keeps the default grid of 65 x 128; any other
    field needs a 3-D bend per node, so the grid is 17 x 32, about half a minute)."""
    from magcilia.readout.biaxial import BiaxialReadout
    from magcilia.report.biaxial import vector_csv

    if sensor_name is None:
        raise fail("--sensor", None, "a 3-axis magnetometer preset with --biaxial: one of "
                   + ", ".join(sorted(MAGNETOMETERS)))
    sensor = element_magnetometer(sensor_name, sensor_noise)
    hi = magnitude_span(span_text, "--biaxial")
    quiet = quiet_requested(quiet)

    checked: list[tuple[list[str], dict[str, object]]] = []

    def fields_of(path: str, option: str) -> tuple[np.ndarray, np.ndarray | None]:
        cols, notes, quality = read_checked(path, reading, FIELD_KEYS, quiet=quiet,
                                            suspect=suspect)
        checked.append((notes, quality))
        b = np.stack([cols[k] for k in FIELD_KEYS], axis=-1)
        if b.shape[0] == 0:
            raise fail(option, path, "a recording with at least one reading")
        return b, cols.get("time_s")

    fields, times = fields_of(recording, "RECORDING")
    axial = actuation is None or (actuation.is_uniform
                                  and not np.any(actuation.uniform_field[:2]))
    readout = BiaxialReadout(setup, sensor, hi, table_size=(65, 128) if axial else (17, 32),
                             actuation=actuation)
    if tare_spec is not None:
        count = tare_readings(tare_spec, fields[:, 0], times).size
        readout = readout.tare(fields[:count])
    elif tare_file is not None:
        readout = readout.tare(fields_of(tare_file, "--tare-file")[0])
    tare = readout.baseline
    if tare is not None and not tare.at_rest:
        checked[0][0].append(f"note: {tare_spec or tare_file}: {tare.report()}")
    result = readout.read(fields)
    write_text(out_path, vector_csv(result, times, si))
    c = result.counts()
    unit, factor = ("N", 1.0) if si else ("mN", 1e-3)
    good = result.estimated
    mags = result.magnitude[good] / factor
    median = float(np.median(result.sigma_magnitude[good])) / factor if good.any() else None
    compensation = None
    if actuation is not None:
        fu, ff = ("T", 1.0) if si else ("gauss", 1e-4)
        direct = [float(d) / ff for d in readout.direct]
        compensation = {"kind": actuation.kind, "scale": actuation.scale,
                        f"direct_{fu}": direct, "grid": [int(readout.forces.size),
                                                         int(readout.azimuths.size)]}
    if as_json:
        echo_json({"quantity": "force vector", "units": "SI" if si else "display",
                   **({} if compensation is None else {"actuation": compensation}),
                   "sensor": sensor.name, f"span_{unit}": hi / factor,
                   f"table_error_{unit}": readout.table_error / factor, **c,
                   f"range_{unit}": [float(mags.min()), float(mags.max())] if mags.size
                   else None, f"median_sigma_magnitude_{unit}": median,
                   "scale_note": result.scale_note,
                   "tared": readout.baseline is not None, "out": out_path,
                   "notes": checked[0][0], "quality": checked[0][1]})
        return
    for line in checked[0][0]:
        click.echo(line)
    flagged = ", ".join(f"{c[k]} {k.replace('_', ' ')}" for k in
                        ("outside_span", "undetermined", "ambiguous", "near_zero", "saturated",
                         "missing", "extrapolated") if c[k])
    text = (f"{c['estimated']}/{c['readings']} force vectors estimated from the {sensor.name}"
            + (f" ({flagged})" if flagged else ""))
    if mags.size:
        text += (f"; |F| {mags.min():.4g}…{mags.max():.4g} {unit}, median 1-sigma {median:.3g} "
                 f"{unit}")
    text += f"; table error ≤ {readout.table_error / factor:.2g} {unit}"
    if readout.baseline is not None:
        text += f"; tared on {int(readout.baseline.count.min())} readings"
    text += f"; {result.scale_note}"
    if compensation is not None:
        click.echo("compensating the actuation: its direct field on the sensor's axes ("
                   + ", ".join(f"{d:.6g}" for d in direct) + f") {fu} and its bending of the "
                   f"cilium, in a {readout.forces.size} x {readout.azimuths.size} grid")
    click.echo(f"{Path(out_path).name}: {text}")
