"""``magcilia bend``: the static bent shape under a tip force and/or fluid flow."""

from __future__ import annotations

import click

from magcilia._atomic import save_figure, write_json
from magcilia._validate import fail
from magcilia.cli._common import (
    Physical,
    echo_json,
    load_mechanics_setup,
    make_flow,
    mechanics_options,
    setup_label,
    si_option,
    style_option,
)
from magcilia.mechanics import FLUIDS, BentShape, bend
from magcilia.report.mechanics import bend_record, bend_text, shape_figure
from magcilia.report.units import output_units


@click.command()
@click.argument("setup_arg", metavar="SETUP")
@click.option("--force", default=None, type=Physical.of("force", "0.2mN"),
              help="Dead point force: mN, or with a unit (e.g. 0.2mN, 200uN).")
@click.option("--at", "at", default=None, type=Physical.of("height", "2.5mm"),
              help="Arc length of the load from the base: mm, or with a unit (e.g. 2.5mm); "
                   "default tip.")
@click.option("--direction", default="90", show_default=True,
              type=Physical.of("angle", "90deg"),
              help="Force direction from +z toward +x: degrees, or with a unit (90 = +x).")
@click.option("--flow", "flow_text", default=None,
              help="Flow speed along +x: m/s, or with a unit (e.g. 0.1m/s, 100mm/s); uniform "
                   "unless --shear-height.")
@click.option("--shear-height", default=None,
              help="Linear wall shear: --flow is the speed at this height: mm, or with a unit "
                   "(e.g. 3mm).")
@click.option("--fluid", type=click.Choice(sorted(FLUIDS)), default="water", show_default=True,
              help="Fluid of the flow (20 °C).")
@mechanics_options
@click.option("--json", "as_json", is_flag=True,
              help="Print JSON (the console's units: mm, deg, mN, mV, gauss; SI with --si).")
@click.option("--json-file", type=click.Path(dir_okay=False), help="Write the JSON to a file.")
@click.option("--plot", "plot_path", type=click.Path(dir_okay=False),
              help="Write a figure of the shape (PNG/PDF/SVG by suffix).")
@si_option
@style_option
def command(setup_arg: str, force: float | None, at: float | None, direction: float,
            flow_text: str | None, shear_height: str | None, fluid: str,
            tip_radius: str | None, modulus: str | None, as_json: bool, json_file: str | None,
            plot_path: str | None, si: bool, style: str) -> None:
    """Large-deflection shape of the cilium under a tip force and/or flow: tip position (mm),
    tip angle (deg) and sensor output (mV); SI (m, rad, V) with --si.

    SETUP is a setup TOML file or a preset (paper, paper-initial). The paper's cilium is a sharp
    cone (tip radius 0): a tip force then needs --tip-radius (or --at below the tip).
    """
    setup = load_mechanics_setup(setup_arg, tip_radius, modulus)
    if at is not None and not 0.0 < at <= setup.cilium.height:  # echoed in mm, not m
        length = setup.cilium.height * 1e3
        raise fail("--at", f"{at * 1e3:g} mm", f"an arc length in (0, {length:g}] mm (the "
                                               "cilium's length)")
    shape = bend(setup, force=force if force is not None else 0.0, at=at, direction=direction,
                 flow=make_flow(flow_text, fluid, shear_height))
    assert isinstance(shape, BentShape)  # for mypy: loads in the x–z plane give planar shapes
    units = output_units(si)
    record = bend_record(setup, shape, setup_label(setup_arg), units)
    if json_file:
        write_json(json_file, record)
    if plot_path:
        from magcilia.report import style as st

        with st.use(style):
            save_figure(shape_figure(setup, shape), plot_path, dpi=st.dpi())
    if as_json:
        echo_json(record)
    else:
        click.echo(bend_text(record, units))
