"""``magcilia bend``: the static bent shape under a tip force and/or fluid flow."""

from __future__ import annotations

import math

import click

from magcilia._atomic import save_figure, write_json
from magcilia.cli._common import (
    echo_json,
    load_mechanics_setup,
    make_flow,
    mechanics_options,
    setup_label,
    style_option,
)
from magcilia.mechanics import FLUIDS, bend
from magcilia.report.mechanics import bend_record, bend_text, shape_figure
from magcilia.units import parse_quantity


@click.command()
@click.argument("setup_arg", metavar="SETUP")
@click.option("--force", default=None, help="Dead point force with a unit, e.g. 0.2mN.")
@click.option("--at", "at_text", default=None,
              help="Arc length of the load from the base, with a unit (e.g. 2.5mm); default tip.")
@click.option("--direction", default=90.0, show_default=True,
              help="Force direction in degrees from +z toward +x (90 = +x).")
@click.option("--flow", "flow_text", default=None,
              help="Flow speed along +x with a unit (e.g. 0.1m/s); uniform unless --shear-height.")
@click.option("--shear-height", default=None,
              help="Linear wall shear: --flow is the speed at this height (e.g. 3mm).")
@click.option("--fluid", type=click.Choice(sorted(FLUIDS)), default="water", show_default=True,
              help="Fluid of the flow (20 °C).")
@mechanics_options
@click.option("--json", "as_json", is_flag=True, help="Print JSON (lengths in mm).")
@click.option("--json-file", type=click.Path(dir_okay=False), help="Write the JSON to a file.")
@click.option("--plot", "plot_path", type=click.Path(dir_okay=False),
              help="Write a figure of the shape (PNG/PDF/SVG by suffix).")
@style_option
def command(setup_arg: str, force: str | None, at_text: str | None, direction: float,
            flow_text: str | None, shear_height: str | None, fluid: str,
            tip_radius: str | None, modulus: str | None, as_json: bool, json_file: str | None,
            plot_path: str | None, style: str) -> None:
    """Large-deflection shape of the cilium under a tip force and/or flow: tip position (mm),
    tip angle (deg) and sensor output (V).

    SETUP is a setup TOML file or a preset (paper, paper-initial). The paper's cilium is a sharp
    cone (tip radius 0): a tip force then needs --tip-radius (or --at below the tip).
    """
    setup = load_mechanics_setup(setup_arg, tip_radius, modulus)
    f = parse_quantity(force, "force", "--force") if force is not None else 0.0
    at = parse_quantity(at_text, "length", "--at") if at_text is not None else None
    shape = bend(setup, force=f, at=at, direction=math.radians(direction),
                 flow=make_flow(flow_text, fluid, shear_height))
    record = bend_record(setup, shape, setup_label(setup_arg))
    if json_file:
        write_json(json_file, record)
    if plot_path:
        from magcilia.report import style as st

        with st.use(style):
            save_figure(shape_figure(setup, shape), plot_path, dpi=st.dpi())
    if as_json:
        echo_json(record)
    else:
        click.echo(bend_text(record))
