"""``magcilia bend``: the static bent shape under a tip force and/or fluid flow."""

from __future__ import annotations

import math
from typing import Any

import click
import numpy as np

from magcilia._atomic import save_figure, write_json
from magcilia._errors import MagciliaError
from magcilia.cli._common import echo_json, load_setup_arg, setup_label
from magcilia.device.setup import Setup
from magcilia.mechanics import FLUIDS, Flow, bend
from magcilia.units import parse_quantity


def load_mechanics_setup(arg: str, tip_radius: str | None, modulus: str | None) -> Setup:
    """SETUP argument with the optional --tip-radius / --modulus overrides applied."""
    setup = load_setup_arg(arg)
    changes: dict[str, float] = {}
    if tip_radius is not None:
        changes["tip_radius"] = parse_quantity(tip_radius, "length", "--tip-radius")
    if modulus is not None:
        changes["youngs_modulus"] = parse_quantity(modulus, "pressure", "--modulus")
    return setup.replace(**changes) if changes else setup


def require_tip_radius(setup: Setup, arg: str, what: str) -> None:
    """CLI wording of the sharp-cone error (the paper preset has tip_radius 0)."""
    if setup.cilium.tip_radius == 0.0:
        raise MagciliaError(
            f"tip_radius of setup {arg!r} must be positive for {what}: a sharp cone's tip "
            "compliance is infinite (I ∝ r⁴ → 0); pass a setup with a tip radius or add "
            "--tip-radius, e.g. --tip-radius 0.05mm"
        )


def make_flow(speed: str | None, fluid: str, shear_height: str | None) -> Flow | None:
    """A Flow from the CLI options (None without --flow)."""
    if speed is None:
        return None
    u = parse_quantity(speed, "speed", "--flow")
    if shear_height is not None:
        h = parse_quantity(shear_height, "length", "--shear-height")
        return Flow.shear(speed=u, height=h, fluid=FLUIDS[fluid])
    return Flow.uniform(u, FLUIDS[fluid])


def mechanics_options(command: Any) -> Any:
    """``--tip-radius`` and ``--modulus``: override the setup's mechanics on the command line."""
    command = click.option("--modulus", default=None,
                           help="Override Young's modulus, with a unit (e.g. 2MPa).")(command)
    return click.option("--tip-radius", default=None,
                        help="Override the setup's tip radius, with a unit (e.g. 0.05mm).")(command)


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
def command(setup_arg: str, force: str | None, at_text: str | None, direction: float,
            flow_text: str | None, shear_height: str | None, fluid: str,
            tip_radius: str | None, modulus: str | None, as_json: bool, json_file: str | None,
            plot_path: str | None) -> None:
    """Large-deflection shape of the cilium under a tip force and/or flow: tip position (mm),
    tip angle (deg) and sensor output (V).

    SETUP is a setup TOML file or a preset (paper, paper-initial). The paper's cilium is a sharp
    cone (tip radius 0): a tip force then needs --tip-radius (or --at below the tip).
    """
    setup = load_mechanics_setup(setup_arg, tip_radius, modulus)
    f = parse_quantity(force, "force", "--force") if force is not None else 0.0
    at = parse_quantity(at_text, "length", "--at") if at_text is not None else None
    flow = make_flow(flow_text, fluid, shear_height)
    if f != 0.0 and at is None:
        require_tip_radius(setup, setup_arg, "a force at the tip")
    if flow is not None and flow.speed != 0.0:
        require_tip_radius(setup, setup_arg, "a flow load")
    shape = bend(setup, force=f, at=at, direction=math.radians(direction), flow=flow)
    b = setup.field(shape)[0]
    volts = float(setup.sensor.voltage(b[0]))
    tip = shape.tip * 1e3
    doc = {
        "setup": setup_label(setup_arg),
        "units": {"length": "mm", "angle": "deg", "force": "N", "speed": "m/s", "output": "V"},
        "load": {"force": f, "at_mm": (at if at is not None else setup.cilium.height) * 1e3,
                 "direction_deg": direction,
                 "flow": None if flow is None else flow.describe()},
        "tip_mm": tip.tolist(), "tip_angle_deg": math.degrees(shape.tip_angle),
        "output_V": volts, "Bx_gauss": float(b[0]) / 1e-4,
        "in_range": bool(setup.sensor.in_range(b[0])),
        "iterations": shape.iterations, "residual_rad": shape.residual,
        "centreline_mm": {"s": (shape.s * 1e3).tolist(), "x": (shape.points[0, :, 0] * 1e3).tolist(),
                          "z": (shape.points[0, :, 2] * 1e3).tolist()},
    }
    if json_file:
        write_json(json_file, doc)
    if plot_path:
        from magcilia.report.design import plot_shapes
        from magcilia.report.figures import new_figure

        fig, axes = new_figure(size=(4.5, 5.0))
        load = f"{f * 1e3:.4g} mN" if f else ""
        if flow is not None:
            load = (load + ", " if load else "") + flow.describe()
        plot_shapes(shape, axes[0, 0], labels=[load or "no load"])
        axes[0, 0].set_title(f"tip angle {math.degrees(shape.tip_angle):.3g} deg, output "
                             f"{volts:.6g} V", fontsize="small")
        save_figure(fig, plot_path)
    if as_json:
        echo_json(doc)
        return
    flag = "" if doc["in_range"] else "  (beyond the sensor's linear range)"
    click.echo(f"tip position  x {tip[0]:.6g} mm, z {tip[2]:.6g} mm (from the base centre)")
    click.echo(f"tip angle     {math.degrees(shape.tip_angle):.6g} deg")
    click.echo(f"output        {volts:.9g} V (Bx {float(b[0]) / 1e-4:.6g} gauss){flag}")
    if np.isfinite(shape.residual) and shape.iterations:
        click.echo(f"solver        {shape.iterations} Newton iterations, residual "
                   f"{shape.residual:.2g} rad")
