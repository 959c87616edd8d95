"""``magcilia modes``: the cilium's bending modes (natural frequencies, damping, modal mass and
stiffness), in vacuum or a fluid, with or without its own weight."""

from __future__ import annotations

from typing import Any

import click

from magcilia._atomic import figure_format, save_figure, write_json
from magcilia.cli._common import (
    echo_json,
    load_mechanics_setup,
    mechanics_options,
    setup_option,
    style_option,
)
from magcilia.cli._outputs import OUTPUT_FILE, writes_files
from magcilia.mechanics import FLUIDS, Modes, modes
from magcilia.mechanics.modal import MAX_COUNT, MAX_ELEMENTS


def modes_record(result: Modes, label: str) -> dict[str, Any]:
    """The JSON record of ``magcilia modes`` (SI: Hz, kg, N/m, N·s/m, m)."""
    return {"setup": label, **result.to_dict()}


@click.command()
@writes_files
@setup_option()
@click.option("--fluid", type=click.Choice(sorted(FLUIDS)), default=None,
              help="The surrounding fluid (20 °C): its added mass and viscous damping (Sader's "
                   "hydrodynamic function); default vacuum.")
@click.option("--gravity", is_flag=True,
              help="Include the upright hair's own weight (less buoyancy): an axial load that "
                   "softens every mode.")
@click.option("--count", default=3, show_default=True, type=click.IntRange(1, MAX_COUNT),
              help="Number of modes.")
@click.option("--elements", default=None, type=click.IntRange(2, MAX_ELEMENTS),
              help="Beam elements (default 24: the first three frequencies to ~1e-5; at most 200).")
@mechanics_options
@click.option("--json", "as_json", is_flag=True,
              help="Print JSON (SI: Hz, kg, N/m, N·s/m, m).")
@click.option("--json-file", type=OUTPUT_FILE, help="Write the JSON to a file.")
@click.option("--plot", "plot_path", type=OUTPUT_FILE,
              help="Write a figure of the mode shapes (PNG/PDF/SVG by suffix).")
@style_option
def command(setup_arg: str, fluid: str | None, gravity: bool, count: int,
            elements: int | None, tip_radius: str | None, modulus: str | None, as_json: bool,
            json_file: str | None, plot_path: str | None, style: str) -> None:
    """Bending modes of the cilium clamped at its base: natural frequency (Hz), damping ratio
    (overdamped where ζ ≥ 1), damped frequency and the modal mass, stiffness and damping
    referred to the tip.

    --setup is a setup TOML file or a preset (paper, paper-initial, force-sensor). The body is
    the setup's frustum or measured profile; Young's modulus the setup's (--modulus overrides
    it); the density the material's (cobalt and polymer by volume fraction).
    """
    setup = load_mechanics_setup(setup_arg, tip_radius, modulus)
    if plot_path:
        figure_format(plot_path)  # a suffix matplotlib cannot write fails before the work
    result = modes(setup, FLUIDS[fluid] if fluid else None, gravity, count=count,
                   elements=elements)
    record = modes_record(result, setup_arg)
    if json_file:
        write_json(json_file, record)
    if plot_path:
        from magcilia.report import style as st
        from magcilia.report.dynamics import modes_figure

        with st.use(style):
            save_figure(modes_figure(result), plot_path, dpi=st.dpi())
    if as_json:
        echo_json(record)
    else:
        click.echo(result.report())
