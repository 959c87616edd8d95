"""``magcilia show``: a setup or an array in 3-D (the cilia, the sensors, the field), to a file."""

from __future__ import annotations

import math
from pathlib import Path

import click

from magcilia._errors import MagciliaError
from magcilia.cli._common import Physical
from magcilia.cli._options import (
    array_file_arg,
    is_preset_name,
    load_setup_arg,
    setup_label,
    setup_option,
)
from magcilia.cli._outputs import OUTPUT_FILE, writes_files
from magcilia.io.array_file import is_array_file, load_array


@click.command()
@writes_files
@setup_option("A setup (one cilium on its sensor) or an array file (or the array preset)")
@click.option("--out", "out_path", required=True, type=OUTPUT_FILE,
              help="The file: .png/.pdf/.svg (a figure, matplotlib) or .html (an interactive "
                   "page, plotly).")
@click.option("--tilt", default="0", show_default=True, type=Physical.of("angle", "30deg"),
              help="Rigid tilt of the cilium about y through its base toward +x: degrees, or "
                   "with a unit (a setup; an array is drawn upright).")
@click.option("--no-field", "no_field", is_flag=True, help="Leave out the field slice.")
@click.option("--force", is_flag=True, help="Replace an existing --out file.")
def command(setup_arg: str, out_path: str, tilt: float, no_field: bool,
            force: bool) -> None:  # noqa: ARG001 (the output policy, writes_files, reads it)
    """Draw SETUP (a setup TOML file or a preset) or an ARRAY file in 3-D: the cilium as its
    exact body, the sensor with its sensitive axis and the field B on the x–z slice through the
    base, through magpylib's display backends (matplotlib for .png/.pdf/.svg, plotly for .html).

    --out is the one file written (issue 30 names `magcilia show SETUP --out FILE.html|.png`):
    an existing one is replaced only with --force.
    """
    from magcilia.report.show import backend_of, write_show

    out = Path(out_path)
    backend_of(out)  # the suffix first: nothing is computed for a file that cannot be written
    if setup_arg == "array" or (not is_preset_name(setup_arg) and is_array_file(setup_arg)):
        target = load_array(array_file_arg(setup_arg))
        if tilt:
            raise MagciliaError("--tilt applies to one cilium; an array is drawn upright")
        write_show(target, out, field=not no_field, title=f"{setup_label(setup_arg)} (array)")
    else:
        setup = load_setup_arg(setup_arg)
        write_show(setup, out, tilt, field=not no_field,
                   title=f"{setup_label(setup_arg)}, tilt {math.degrees(tilt):.4g} deg")
    click.echo(f"wrote {out}")
