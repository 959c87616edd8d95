"""``magcilia design``: sensitivity, minimum detectable signal and range of a design."""

from __future__ import annotations

import click

from magcilia._atomic import save_figure, write_json
from magcilia.cli._common import (
    bandwidth_option,
    echo_json,
    load_mechanics_setup,
    mechanics_options,
    parse_bandwidth,
    setup_label,
    style_option,
)
from magcilia.mechanics import FLUIDS
from magcilia.readout.design import design_metrics


@click.command()
@click.argument("setup_arg", metavar="SETUP")
@click.option("--fluid", type=click.Choice(sorted(FLUIDS)), default="water", show_default=True,
              help="Fluid of the flow metrics (20 °C, uniform flow).")
@bandwidth_option()
@mechanics_options
@click.option("--json", "as_json", is_flag=True, help="Print JSON (SI units) instead of the table.")
@click.option("--json-file", type=click.Path(dir_okay=False), help="Write the JSON to a file.")
@click.option("--plot", "plot_path", type=click.Path(dir_okay=False),
              help="Write the figure (PNG/PDF/SVG by suffix).")
@style_option
def command(setup_arg: str, fluid: str, bandwidth: str, tip_radius: str | None,
            modulus: str | None, as_json: bool, json_file: str | None,
            plot_path: str | None, style: str) -> None:
    """Design metrics: dV/dF, dV/dU, dV/dθ, minimum detectable force (mN), flow speed (m/s) and
    angle (deg) from the sensor noise, and the range before ±6 gauss or a fold.

    SETUP is a setup TOML file or a preset. Force and flow metrics need a tip radius (the paper's
    cone has none: add --tip-radius, e.g. 0.05mm).
    """
    setup = load_mechanics_setup(setup_arg, tip_radius, modulus)
    metrics = design_metrics(setup, fluid=FLUIDS[fluid], bandwidth=parse_bandwidth(bandwidth))
    doc = {"setup": setup_label(setup_arg), **metrics.to_dict()}
    if json_file:
        write_json(json_file, doc)
    if plot_path:
        from magcilia.report import style as st
        from magcilia.report.design import design_figure

        with st.use(style):
            save_figure(design_figure(metrics), plot_path, dpi=st.dpi())
    if as_json:
        echo_json(doc)
        return
    click.echo(metrics.report())
