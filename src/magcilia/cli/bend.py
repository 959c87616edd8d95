"""``magcilia bend``: the static bent shape under a tip force, a fluid flow and/or an actuation
field, in any direction."""

from __future__ import annotations

import math

import click

from magcilia._atomic import save_figure, write_json
from magcilia._validate import fail
from magcilia.cli._common import (
    Physical,
    RenamedOption,
    actuation_options,
    echo_json,
    load_mechanics_setup,
    make_actuation,
    make_flow,
    mechanics_options,
    parse_vector,
    setup_label,
    setup_option,
    si_option,
    style_option,
)
from magcilia.cli._outputs import FORCE_KEY, OUTPUT_FILE, writes_files
from magcilia.device.parameters import MEASURANDS
from magcilia.mechanics import FLUIDS, BentShape, bend
from magcilia.report.mechanics import (
    bend_record,
    bend_text,
    shape_figure,
    spatial_figure,
    spatial_record,
    spatial_text,
)
from magcilia.report.units import output_units


@click.command()
@writes_files
@setup_option()
@click.option("--tip-force", "force", cls=RenamedOption, old="--force", alone=FORCE_KEY,
              default=None,
              type=Physical.of("force", "0.2mN"),
              help="Dead point force, at the tip unless --at: mN, or with a unit (e.g. 0.2mN, "
                   "200uN).")
@click.option("--at", "at", default=None, type=Physical.of("height", "2.5mm"),
              help="Arc length of the load from the base: mm, or with a unit (e.g. 2.5mm); "
                   "default tip.")
@click.option("--direction", default="90", show_default=True,
              type=Physical.of("angle", "90deg"),
              help="Force direction from +z toward +x (or toward --azimuth): degrees, or with "
                   "a unit (90 = horizontal).")
@click.option("--azimuth", default=None, type=Physical.of("angle", "30deg"),
              help="Azimuth of the force's vertical plane from +x toward +y: degrees, or with a "
                   "unit (e.g. 30deg); default 0 (the x–z plane).")
@click.option("--force-vector", "force_vector", default=None, metavar="FX,FY,FZ",
              help="Dead point force as a vector in the board frame: mN, or with a unit "
                   "(e.g. 0.1,0.05,0mN); instead of --tip-force/--direction/--azimuth.")
@click.option("--flow", "flow_text", default=None,
              help="Flow speed along +x (or --flow-azimuth): m/s, or with a unit (e.g. 0.1m/s, "
                   "100mm/s); uniform unless --shear-height.")
@click.option("--shear-height", default=None,
              help="Linear wall shear: --flow is the speed at this height: mm, or with a unit "
                   "(e.g. 3mm).")
@click.option("--fluid", type=click.Choice(sorted(FLUIDS)), default="water", show_default=True,
              help="Fluid of the flow (20 °C).")
@click.option("--flow-azimuth", "flow_azimuth", default=None,
              type=Physical.of("angle", "45deg"),
              help="Direction the flow blows toward, from +x toward +y: degrees, or with a "
                   "unit; default 0 (+x).")
@actuation_options
@mechanics_options
@click.option("--json", "as_json", is_flag=True,
              help="Print JSON (the console's units: mm, deg, mN, mV, gauss; SI with --si).")
@click.option("--json-file", type=OUTPUT_FILE, help="Write the JSON to a file.")
@click.option("--plot", "plot_path", type=OUTPUT_FILE,
              help="Write a figure of the shape (PNG/PDF/SVG by suffix).")
@si_option
@style_option
def command(setup_arg: str, force: float | None, at: float | None, direction: float,
            azimuth: float | None, force_vector: str | None,
            flow_text: str | None, shear_height: str | None, fluid: str,
            flow_azimuth: float | None, actuation_field: str | None,
            actuation_file: str | None, actuation_scale: float | None,
            tip_radius: str | None, modulus: str | None, as_json: bool, json_file: str | None,
            plot_path: str | None, si: bool, style: str) -> None:
    """Large-deflection shape of the cilium under a tip force, a flow and/or a magnetic
    actuation field, in any direction: tip position (mm), tip angle (deg) and sensor output (mV);
    SI (m, rad, V) with --si.

    --setup is a setup TOML file or a preset (paper, paper-initial, force-sensor). The paper's
    cilium is a sharp cone (tip radius 0): a tip force then needs --tip-radius (or --at below
    the tip).

    A force toward any azimuth (--azimuth, or --force-vector), a flow from any direction
    (--flow-azimuth) or an actuation (--actuation-field, --actuation FILE or the setup file's
    [actuation] table) print the tip's x, y, z, its azimuth and deflection, the 3-axis field at
    the element (the actuation's direct field included) and the sensor's flags.
    """
    # the layout rule at the sensing element (the bent shape's field and output)
    setup = load_mechanics_setup(setup_arg, tip_radius, modulus).resolve_layout()
    actuation = make_actuation(setup_arg, actuation_field, actuation_file, actuation_scale)
    vector = None
    if force_vector is not None:
        if force is not None:
            raise fail("--force-vector", force_vector, "either --tip-force or --force-vector, not "
                                                       "both")
        if azimuth is not None:
            raise fail("--azimuth", f"{azimuth * 180.0 / math.pi:g} deg", "left out with "
                       "--force-vector (the vector gives the direction)")
        if direction != 0.5 * math.pi:
            raise fail("--direction", f"{direction * 180.0 / math.pi:g} deg", "left out with "
                       "--force-vector (the vector gives the direction)")
        q = MEASURANDS["force"]
        vector = parse_vector(force_vector, "force", q.display, "--force-vector",
                              "0.1,0.05,0 or 0.1,0,0mN")
    if at is not None and not 0.0 < at <= setup.cilium.height:  # echoed in mm, not m
        length = setup.cilium.height * 1e3
        raise fail("--at", f"{at * 1e3:g} mm", f"an arc length in (0, {length:g}] mm (the "
                                               "cilium's length)")
    flow = make_flow(flow_text, fluid, shear_height)
    if flow_azimuth is not None:
        if flow is None:
            raise fail("--flow-azimuth", f"{flow_azimuth * 180.0 / math.pi:g} deg",
                       "given with --flow")
        flow = flow.with_azimuth(flow_azimuth)
    spatial = (vector is not None or azimuth is not None or flow_azimuth is not None
               or actuation is not None)
    units = output_units(si)
    if not spatial:  # today's planar command, unchanged
        any_shape = bend(setup, force=force if force is not None else 0.0, at=at,
                         direction=direction, flow=flow)
        assert isinstance(any_shape, BentShape)  # for mypy: loads in the x–z plane are planar
        record = bend_record(setup, any_shape, setup_label(setup_arg), units)
        text = bend_text(record, units)
    else:
        load = vector if vector is not None else (force if force is not None else 0.0)
        any_shape = bend(setup, force=load, at=at,
                         direction=direction if vector is None else 0.5 * math.pi,
                         azimuth=azimuth or 0.0, flow=flow, actuation=actuation)
        record = spatial_record(setup, any_shape, setup_label(setup_arg), units)
        text = spatial_text(record, units)
    if json_file:
        write_json(json_file, record)
    if plot_path:
        from magcilia.report import style as st

        with st.use(style):
            fig = (shape_figure(setup, any_shape)
                   if not spatial and isinstance(any_shape, BentShape)
                   else spatial_figure(setup, any_shape))
            save_figure(fig, plot_path, dpi=st.dpi())
    if as_json:
        echo_json(record)
    else:
        click.echo(text)
