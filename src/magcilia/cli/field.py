"""``magcilia field``: field and sensor output vs tilt angle for one or more setups."""

from __future__ import annotations

import csv
import io

import click
import numpy as np

from magcilia._atomic import figure_bytes, figure_format, json_text, write_files
from magcilia.cli._common import angle_grid, echo_json, load_setup_arg, setup_label, style_option
from magcilia.constants import GAUSS


@click.command()
@click.argument("setups", nargs=-1, required=True, metavar="SETUP...")
@click.option("--angles", default="0:85:5", show_default=True,
              help="Tilt angles start:stop:step in degrees (stop included).")
@click.option("--csv", "csv_path", type=click.Path(dir_okay=False), help="Write the table as CSV.")
@click.option("--json", "as_json", is_flag=True, help="Print JSON instead of the table.")
@click.option("--json-file", type=click.Path(dir_okay=False), help="Write the JSON to a file.")
@click.option("--plot", "plot_path", type=click.Path(dir_okay=False),
              help="Write a figure (PNG/PDF/SVG by suffix).")
@style_option
def command(setups: tuple[str, ...], angles: str, csv_path: str | None, as_json: bool,
            json_file: str | None, plot_path: str | None, style: str) -> None:
    """Field at the sensing element (gauss) and sensor output (V) vs tilt angle.

    SETUP is a setup TOML file or a preset name: `paper` (Table I optimized) or `paper-initial`
    (Table I initial). Several SETUPs are compared in one table and figure. Rows beyond the
    sensor's linear range are flagged `range`. The output files are written together once
    everything is computed: a failure leaves none of them changed.
    """
    theta = angle_grid(angles)
    if plot_path:
        figure_format(plot_path)  # an unknown suffix fails before the work
    rows = []
    results = []
    for arg in setups:
        setup = load_setup_arg(arg)
        b = setup.field(theta)
        volts = setup.sensor.voltage(b[:, 0])
        ok = setup.sensor.in_range(b[:, 0])
        label = setup_label(arg)
        results.append((label, setup, b, volts, ok))
        for i, t in enumerate(theta):
            rows.append({
                "setup": label, "angle_deg": float(np.degrees(t)),
                "Bx_gauss": b[i, 0] / GAUSS, "By_gauss": b[i, 1] / GAUSS,
                "Bz_gauss": b[i, 2] / GAUSS, "output_V": float(volts[i]),
                "flag": "" if ok[i] else "range",
            })
    columns = ["setup", "angle_deg", "Bx_gauss", "By_gauss", "Bz_gauss", "output_V", "flag"]
    files: dict[str, str | bytes] = {}
    if csv_path:
        buf = io.StringIO()
        writer = csv.DictWriter(buf, fieldnames=columns, lineterminator="\n")
        writer.writeheader()
        writer.writerows(rows)
        files[csv_path] = buf.getvalue()
    doc = {"units": {"angle": "deg", "B": "gauss", "output": "V"}, "rows": rows}
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
    header = (f"{'setup':<14} {'angle/deg':>9} {'Bx/gauss':>11} {'By/gauss':>11} "
              f"{'Bz/gauss':>11} {'output/V':>11}")
    click.echo(header)
    for r in rows:
        click.echo(f"{r['setup']:<14.14} {r['angle_deg']:9.2f} {r['Bx_gauss']:11.5f} "
                   f"{r['By_gauss']:11.5f} {r['Bz_gauss']:11.5f} {r['output_V']:11.6f} {r['flag']}")
