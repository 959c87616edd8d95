"""``magcilia design``: sensitivity, minimum detectable signal and range of a design."""

from __future__ import annotations

import math
from typing import Any

import click

from magcilia._atomic import save_figure, write_json
from magcilia.cli._common import (
    bandwidth_option,
    echo_json,
    load_mechanics_setup,
    mechanics_options,
    parse_bandwidth,
    setup_label,
    setup_option,
    si_option,
    style_option,
)
from magcilia.cli._outputs import OUTPUT_FILE, writes_files
from magcilia.design import DesignMetrics, design_metrics
from magcilia.mechanics import FLUIDS
from magcilia.report.units import output_units
from magcilia.report.units import show as show_value
from magcilia.units import OutputUnits, ascii_unit


@click.command()
@writes_files
@setup_option()
@click.option("--fluid", type=click.Choice(sorted(FLUIDS)), default="water", show_default=True,
              help="Fluid of the flow metrics (20 °C, uniform flow).")
@bandwidth_option()
@mechanics_options
@click.option("--json", "as_json", is_flag=True,
              help="Print JSON (the table's units; SI with --si) instead of the table.")
@click.option("--json-file", type=OUTPUT_FILE, help="Write the JSON to a file.")
@click.option("--plot", "plot_path", type=OUTPUT_FILE,
              help="Write the figure (PNG/PDF/SVG by suffix).")
@si_option
@style_option
def command(setup_arg: str, fluid: str, bandwidth: str, tip_radius: str | None,
            modulus: str | None, as_json: bool, json_file: str | None,
            plot_path: str | None, si: bool, style: str) -> None:
    """Design metrics: dV/dF, dV/dU, dV/dθ (mV per mN, m/s, deg), minimum detectable force (mN),
    flow speed (m/s) and angle (deg) from the sensor noise, and the range before ±6 gauss or a
    fold (SI with --si; the table and the JSON agree).

    SETUP is a setup TOML file or a preset. Force and flow metrics need a tip radius (the paper's
    cone has none: add --tip-radius, e.g. 0.05mm).
    """
    setup = load_mechanics_setup(setup_arg, tip_radius, modulus)
    metrics = design_metrics(setup, fluid=FLUIDS[fluid], bandwidth=parse_bandwidth(bandwidth))
    units = output_units(si)
    doc = design_doc(metrics, setup_label(setup_arg), units)
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
    click.echo(design_text(doc, units))


def design_doc(metrics: DesignMetrics, label: str, units: OutputUnits) -> dict[str, Any]:
    """The JSON of ``magcilia design`` in ``units``: every number's key names its unit
    (``minimum_mN``, ``sensitivity_mV_per_mN``)."""
    raw = metrics.to_dict()
    for name, entry in raw["metrics"].items():
        unit = ascii_unit(entry.pop("unit"))  # the SI unit of the measurand
        raw["metrics"][name] = {f"sensitivity_V_per_{unit}": entry.pop("sensitivity_V_per_unit"),
                                f"minimum_{unit}": entry.pop("minimum"),
                                f"range_{unit}": entry.pop("range"),
                                f"sigma_minimum_{unit}": entry.pop("sigma_minimum"),
                                f"sigma_range_{unit}": entry.pop("sigma_range"), **entry}
    modulus = raw.pop("modulus")
    raw["modulus"] = {"source": modulus["source"], "relative": modulus["relative"],
                      "value_Pa": modulus["value"], "sigma_Pa": modulus["sigma"]}
    doc = units.convert({"setup": label, **raw})
    return {"units": units.system, **doc}  # type: ignore[dict-item]


def design_text(doc: dict[str, Any], units: OutputUnits) -> str:
    """The table ``magcilia design`` prints, from :func:`design_doc`."""
    volt = units.unit("voltage")
    lo, hi = doc["bandwidth_Hz"]
    noise = doc[units.key("noise", "voltage")]
    lines = [f"noise {noise:.4g} {volt} RMS over {lo:g}-{hi:g} Hz; flow in {doc['fluid']}",
             (f"{'quantity':<8} {'sensitivity':>24} {'min. detectable':>18} {'range':>14}"
              "  limited by")]
    for name, entry in doc["metrics"].items():
        unit = units.unit(name)
        token = ascii_unit(unit)

        def show(value: float | None, text: str) -> str:
            return "-" if value is None or not math.isfinite(value) else f"{value:.4g} {text}"

        def quantity(value: float | None, name: str = name) -> str:  # µN for a µN-scale force
            if value is None or not math.isfinite(value):
                return "-"
            return show_value(value * units.factor(name), name, units)

        sens = show(entry[f"sensitivity_{ascii_unit(volt)}_per_{token}"], f"{volt}/{unit}")
        rng = quantity(entry[f"range_{token}"])
        if rng != "-" and not entry.get("range_reached", True):
            rng = f"≥ {rng}"  # the sweep ended before the read-out: a lower bound
        lines.append(f"{name:<8} {sens:>24} {quantity(entry[f'minimum_{token}']):>18} "
                     f"{rng:>14}  {entry['limited_by']}")
    lines.append(doc["scale_note"])
    return "\n".join(lines)
