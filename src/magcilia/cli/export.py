"""``magcilia export``: a recording out to CSV, MATLAB, HDF5 or NetCDF."""

from __future__ import annotations

import click

from magcilia.cli._common import RecordingArgs, echo_json, recording_options
from magcilia.cli._outputs import OUTPUT_FILE, writes_files
from magcilia.io.export_recording import FORMATS, MAT_VERSIONS, export, export_format


@click.command()
@writes_files
@click.argument("recording", type=click.Path(dir_okay=False))
@click.option("--to", "to", type=click.Choice(list(FORMATS)), default=None,
              help="The format: csv, mat (MATLAB), h5 (HDF5) or nc (NetCDF) [default: from the "
                   "suffix of --out: .csv, .mat, .h5/.hdf5, .nc].")
@click.option("--out", "out", required=True, type=OUTPUT_FILE, metavar="FILE",
              help="The file to write (an existing one only with --force).")
@click.option("--force", is_flag=True, help="Replace an existing --out file.")
@click.option("--mat-version", type=click.Choice(list(MAT_VERSIONS)), default=None,
              help="MATLAB version: 5 (SciPy) or 7.3 (HDF5, needs h5py) [default: 5, 7.3 "
                   "above v5's 2 GB].")
@click.option("--json", "as_json", is_flag=True,
              help="Print what was written as JSON (file, format, samples, channels and their "
                   "units, tables, metadata).")
@recording_options
def command(recording: str, to: str | None, out: str, force: bool, mat_version: str | None,
            as_json: bool, reading: RecordingArgs) -> None:
    """Export RECORDING (CSV, .mat, .tdms, .h5) to CSV, MATLAB, HDF5 or NetCDF for other tools.

    Every channel with its unit (SI, as the readers return them: deg, V, s, T, N, m/s, K), the
    stored setup, the notes on the file (a recording cut short) and a live recording's read-out
    values and events. CSV: units in the header names, metadata in '#' JSON lines before the
    header. MATLAB: one column vector per channel and the structs units, metadata (char
    arrays), tables. HDF5: datasets with a units attribute, the metadata as attributes, a group
    per further table. NetCDF (xarray, h5netcdf): variables along 'sample' with units, the
    metadata as attributes. The file is written atomically.

    Example: magcilia export run.tdms --out run.mat
    """
    kwargs = reading.kwargs()
    data = export(recording, out, to, mat_version=mat_version, overwrite=force, **kwargs)
    if as_json:
        echo_json({"file": out, "format": export_format(out, to), **data.to_dict()})
        return
    click.echo(f"wrote {out} ({data.report()})")
    for note in data.metadata.get("notes", []):
        click.echo(f"note: {note}")
