"""``magcilia approximate``: piecewise-linear read-out approximation, C header and JSON export."""

from __future__ import annotations

import click

from magcilia._atomic import write_json, write_text
from magcilia._validate import fail
from magcilia.approximation import lookup_table, piecewise_linear
from magcilia.cli._common import echo_json, load_setup_arg
from magcilia.io.firmware import to_c_header
from magcilia.units import parse_range


@click.command()
@click.argument("setup_arg", metavar="SETUP")
@click.option("--corners", default=2, show_default=True,
              help="Interior corner points (the paper: 2; 0 = a straight line).")
@click.option("--range", "range_text", default="0:85", show_default=True,
              help="Tilt range START:STOP in degrees.")
@click.option("--grid", default=1001, show_default=True,
              help="Points of the dense fitting grid.")
@click.option("--table-size", default=0, show_default=True,
              help="Also report a V->angle lookup table of this many entries and its error bound.")
@click.option("--c-header", "c_header", type=click.Path(dir_okay=False),
              help="Write a C header with the approximation (and its inverse).")
@click.option("--fixed-point", is_flag=True, help="Q-format int32 C functions instead of float.")
@click.option("--name", default="magcilia_approx", show_default=True,
              help="C identifier prefix in the header.")
@click.option("--json-file", type=click.Path(dir_okay=False), help="Write the JSON to a file.")
@click.option("--json", "as_json", is_flag=True, help="Print JSON instead of the table.")
def command(setup_arg: str, corners: int, range_text: str, grid: int, table_size: int,
            c_header: str | None, fixed_point: bool, name: str, json_file: str | None,
            as_json: bool) -> None:
    """Fit a continuous piecewise-linear function to SETUP's output vs tilt (the paper's Sec. V).

    SETUP is a setup TOML file (e.g. fitted_setup.toml from `magcilia calibrate`) or a preset
    (paper, paper-initial). Prints the corners (degrees), node outputs (mV) and the max/RMS error
    in mV and degrees.
    """
    setup = load_setup_arg(setup_arg)
    lo, hi, step = parse_range(range_text, "--range", "deg")
    if step is not None:
        raise fail("--range", range_text, "START:STOP in degrees (no step), e.g. 0:85")
    approx = piecewise_linear(setup, corners=corners, angle_range=(lo, hi), grid=grid)
    table = None
    if table_size:
        table = lookup_table(setup, table_size, angle_range=(lo, hi))
    header = to_c_header(approx, name=name, fixed_point=fixed_point) if c_header else None
    doc = approx.to_dict()
    if table is not None:
        doc["lookup_table"] = table.to_dict()
    if header is not None and c_header:
        write_text(c_header, header)
    if json_file:
        write_json(json_file, doc)
    if as_json:
        echo_json(doc)
        return
    click.echo(approx.report())
    if table is not None:
        click.echo(table.report())
    if c_header:
        click.echo(f"wrote {c_header} ({'fixed-point' if fixed_point else 'float'})")
