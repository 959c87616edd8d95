"""``magcilia field``: field and sensor output vs tilt angle for one or more setups."""

from __future__ import annotations

import csv
import io

import click
import numpy as np
from numpy.typing import NDArray

from magcilia._atomic import figure_bytes, figure_format, json_text, write_files
from magcilia.cli._common import (
    angle_grid,
    echo_json,
    load_setup_arg,
    setup_label,
    setup_option,
    si_option,
    style_option,
)
from magcilia.cli._outputs import OUTPUT_FILE, writes_files
from magcilia.constants import GAUSS
from magcilia.device.sensor import SensorFlag
from magcilia.device.setup import Setup
from magcilia.report.units import exact_zeros, output_units

#: the flag words of :class:`~magcilia.device.sensor.SensorFlag` bits, in the table's order
FLAG_WORDS = ((SensorFlag.BEYOND_RANGE, "range"), (SensorFlag.TOTAL_BEYOND_RANGE, "total-range"),
              (SensorFlag.FLIPPED_RISK, "flip"), (SensorFlag.CROSS_FIELD, "cross-axis"))


def _flag_text(flags: int) -> str:
    return ",".join(word for bit, word in FLAG_WORDS if flags & bit)


def _warn_overload(label: str, setup: Setup, b: NDArray[np.float64],
                   flags: NDArray[np.uint8]) -> None:
    """One warning line when the setup overloads its element (range or flip field)."""
    heavy = (flags & np.uint8(SensorFlag.FLIPPED_RISK | SensorFlag.TOTAL_BEYOND_RANGE
                              | SensorFlag.BEYOND_RANGE)) != 0
    if heavy.any():
        s = setup.sensor
        top = float(np.linalg.norm(b, axis=-1).max())
        click.echo(f"magcilia: warning: {label} puts up to {top / GAUSS:.3g} gauss on the "
                   f"{s.name}'s element ({int(heavy.sum())} of {heavy.size} angles beyond its "
                   f"±{s.field_range / GAUSS:.3g} gauss range or {s.flip_field / GAUSS:.3g} gauss "
                   "flip field): a real sensor there saturates or flips; move the cilium off the "
                   "element (x, y, z)", err=True)


@click.command()
@writes_files
@setup_option("A setup to compare (several: one table and figure)", multiple=True, name="setups")
@click.option("--angles", default="0:85:5", show_default=True,
              help="Tilt angles start:stop:step in degrees, or with a unit (0:85:5deg; stop "
                   "included).")
@click.option("--csv", "csv_path", type=OUTPUT_FILE, help="Write the table as CSV.")
@click.option("--json", "as_json", is_flag=True, help="Print JSON instead of the table.")
@click.option("--json-file", type=OUTPUT_FILE, help="Write the JSON to a file.")
@click.option("--plot", "plot_path", type=OUTPUT_FILE,
              help="Write a figure (PNG/PDF/SVG by suffix).")
@si_option
@style_option
def command(setups: tuple[str, ...], angles: str, csv_path: str | None, as_json: bool,
            json_file: str | None, plot_path: str | None, si: bool, style: str) -> None:
    """Field at the sensing element (gauss) and sensor output (mV) vs tilt angle (T, V, rad
    with --si; the console, CSV and JSON agree).

    --setup is a setup TOML file or a preset name: `paper` (Table I optimized) or
    `paper-initial` (Table I initial). Several --setup are compared in one table and figure.
    Rows are flagged with what the element's field does to a real HMC1021-type sensor: `range`
    (|B_x| beyond its linear range), `total-range` (|B| beyond it), `flip` (|B| beyond the flip
    field: a set/reset pulse is needed) and `cross-axis` (the cross-axis error, which the
    model's output leaves out, exceeds one reading's noise); a setup that overloads the element
    also prints a warning. The dipole layout follows the setup's layout rule (paper: as is;
    converged: within 0.5 % of the exact body at the element; given: as is, with a warning where
    it is more than 1 % off). The output files are written together once everything is computed:
    a failure leaves none of them changed.
    """
    theta = angle_grid(angles)
    if plot_path:
        figure_format(plot_path)  # an unknown suffix fails before the work
    u = output_units(si)
    ang, bx, by, bz, out = (u.key("angle", "angle"), u.key("Bx", "field"), u.key("By", "field"),
                            u.key("Bz", "field"), u.key("output", "output"))
    rows = []
    results = []
    for arg in setups:
        setup = load_setup_arg(arg).resolve_layout()  # the layout rule at the element
        b = exact_zeros(setup.field(theta))  # a zero by symmetry prints as 0, not -5.6e-16
        volts = setup.sensor.voltage(b[:, 0])
        ok = setup.sensor.in_range(b[:, 0])
        flags = setup.sensor.check(b)
        label = setup_label(arg)
        results.append((label, setup, b, volts, ok))
        _warn_overload(label, setup, b, flags)
        for i, t in enumerate(theta):
            rows.append({
                "setup": label, ang: u.value(float(t), "angle"),
                bx: u.value(float(b[i, 0]), "field"), by: u.value(float(b[i, 1]), "field"),
                bz: u.value(float(b[i, 2]), "field"), out: u.value(float(volts[i]), "output"),
                "flag": _flag_text(int(flags[i])),
            })
    columns = ["setup", ang, bx, by, bz, out, "flag"]
    files: dict[str, str | bytes] = {}
    if csv_path:
        buf = io.StringIO()
        writer = csv.DictWriter(buf, fieldnames=columns, lineterminator="\n")
        writer.writeheader()
        writer.writerows(rows)
        files[csv_path] = buf.getvalue()
    doc = {"units": u.system, "rows": rows}
    if json_file:
        files[json_file] = json_text(doc)
    if plot_path:
        from magcilia.report import style as st
        from magcilia.report.figures import field_figure

        with st.use(style):
            fig = field_figure(theta, [r[2] for r in results], [r[3] for r in results],
                               [r[0] for r in results], in_range=[r[4] for r in results])
            files[plot_path] = figure_bytes(fig, plot_path, dpi=st.dpi())
    write_files(files)
    if as_json:
        echo_json(doc)
        return
    names = [f"angle/{u.label('angle')}", f"Bx/{u.label('field')}", f"By/{u.label('field')}",
             f"Bz/{u.label('field')}", f"output/{u.label('output')}"]
    click.echo(f"{'setup':<14} {names[0]:>9} " + " ".join(f"{n:>11}" for n in names[1:]))
    for r in rows:
        click.echo(f"{r['setup']:<14.14} {r[ang]:9.4f} {r[bx]:11.6g} {r[by]:11.6g} "
                   f"{r[bz]:11.6g} {r[out]:11.6g} {r['flag']}")
