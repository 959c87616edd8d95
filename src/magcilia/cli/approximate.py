"""``magcilia approximate``: piecewise-linear read-out approximation, C header and JSON export."""

from __future__ import annotations

from typing import Any

import click

from magcilia._atomic import write_json, write_text
from magcilia._validate import fail
from magcilia.approximation import lookup_table, piecewise_linear
from magcilia.cli._common import (
    echo_json,
    load_setup_arg,
    setup_option,
    si_option,
)
from magcilia.cli._outputs import OUTPUT_FILE, writes_files
from magcilia.io.firmware import to_c_header
from magcilia.report.units import output_units
from magcilia.units import OutputUnits, ascii_unit, parse_range


@click.command()
@writes_files
@setup_option()
@click.option("--corners", default=2, show_default=True,
              help="Interior corner points (the paper: 2; 0 = a straight line).")
@click.option("--range", "range_text", default="0:85", show_default=True,
              help="Tilt range START:STOP in degrees, or with a unit (0:85deg, 0:1.4rad).")
@click.option("--grid", default=1001, show_default=True,
              help="Points of the dense fitting grid.")
@click.option("--table-size", default=0, show_default=True,
              help="Also report a V->angle lookup table of this many entries and its error bound.")
@click.option("--c-header", "c_header", type=OUTPUT_FILE,
              help="Write a C header with the approximation (and its inverse).")
@click.option("--fixed-point", is_flag=True, help="Q-format int32 C functions instead of float.")
@click.option("--name", default="magcilia_approx", show_default=True,
              help="C identifier prefix in the header.")
@click.option("--json-file", type=OUTPUT_FILE, help="Write the JSON to a file.")
@click.option("--json", "as_json", is_flag=True,
              help="Print JSON (the table's units: deg, mV; SI with --si) instead of the table.")
@si_option
def command(setup_arg: str, corners: int, range_text: str, grid: int, table_size: int,
            c_header: str | None, fixed_point: bool, name: str, json_file: str | None,
            as_json: bool, si: bool) -> None:
    """Fit a continuous piecewise-linear function to SETUP's output vs tilt (the paper's Sec. V).

    SETUP is a setup TOML file (e.g. fitted_setup.toml from `magcilia calibrate`) or a preset
    (paper, paper-initial). Prints the corners (degrees), node outputs (mV) and the max/RMS error
    in mV and degrees (rad and V with --si; the C header is in its own units).
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
    units = output_units(si)
    raw = approx.to_dict()
    if table is not None:
        raw["lookup_table"] = _suffixed_table(table.to_dict())
    doc = {"units": units.system, **units.convert(raw)}  # type: ignore[dict-item]
    if header is not None and c_header:
        write_text(c_header, header)
    if json_file:
        write_json(json_file, doc)
    if as_json:
        echo_json(doc)
        return
    click.echo(approximation_text(doc, units))
    if c_header:
        click.echo(f"wrote {c_header} ({'fixed-point' if fixed_point else 'float'})")


def _suffixed_table(raw: dict[str, Any]) -> dict[str, Any]:
    """A lookup table's dict with its units in the keys (``x_start_V``, ``y_rad``,
    ``error_bound_rad``) instead of ``x_unit``/``y_unit`` entries."""
    x_unit, y_unit = ascii_unit(raw.pop("x_unit")), ascii_unit(raw.pop("y_unit"))
    out: dict[str, Any] = {}
    for key, value in raw.items():
        suffix = x_unit if key in ("x_start", "x_step") else y_unit if key in (
            "y", "error_bound") else ""
        out[f"{key}_{suffix}" if suffix else key] = value
    return out


def approximation_text(doc: dict[str, Any], units: OutputUnits) -> str:
    """The table ``magcilia approximate`` prints, from its JSON document (same units)."""
    deg, volt = units.unit("angle"), units.unit("voltage")
    a, v = ascii_unit(deg), ascii_unit(volt)
    lo, hi = doc[f"angle_range_{a}"]
    lines = [(f"piecewise-linear approximation, {doc['corners']} corner(s) over "
              f"{lo:.4g}..{hi:.4g} {deg}"),
             (f"{'node':>4} {f'angle/{deg}':>10} {f'output/{volt}':>12} "
              f"{f'slope/({volt}/{deg})':>15}")]
    slopes = doc[f"slopes_{v}_per_{a}"]
    for i, (knot, value) in enumerate(zip(doc[f"knots_{a}"], doc[f"values_{v}"], strict=True)):
        slope = f"{slopes[i]:15.6g}" if i < len(slopes) else ""
        lines.append(f"{i:>4} {knot:10.{6 if units.si else 4}f} "
                     f"{value:12.{9 if units.si else 6}f} {slope}".rstrip())
    lines.append(f"max error {doc[f'max_error_{v}']:.4g} {volt}, RMS {doc[f'rms_error_{v}']:.4g} "
                 f"{volt}, max angle error {doc[f'max_angle_error_{a}']:.4g} {deg}")
    if not doc["invertible"]:
        folds = ", ".join(f"{f:.4g}" for f in doc[f"folds_{a}"])
        lines.append(f"note: the output is not monotonic over the range (folds at {folds} "
                     f"{deg}): no inverse")
    table = doc.get("lookup_table")
    if table is not None:
        inverse = table["quantity"] == "inverse"
        unit = deg if inverse else volt
        bound = table[f"error_bound_{ascii_unit(unit)}"]
        lines.append(f"lookup table {'V->angle' if inverse else 'angle->V'}, {table['size']} "
                     f"entries: error bound {bound:.4g} {unit}")
    return "\n".join(lines)
