"""Recordings out to the tools labs use: CSV, MATLAB (.mat v5 and v7.3), HDF5 and NetCDF.

:func:`export` reads any recording the readers take (:func:`magcilia.io.read_recording`: CSV,
.mat, .tdms, .h5; a recording cut short too, with its notes) and writes every channel with its
unit, and what the file says of itself, to one file a colleague's script opens:

- the **samples**: every column the readers know (:data:`magcilia.io.recordings.COLUMNS` and the
  temperature), in SI as the readers return them (deg, V, s, T, N, m/s, K; ``setreset`` ±1,
  unit ``"1"``), under the readers' names, which carry the unit (``voltage_V``); for a TDMS
  recording also the ``recording`` group's further channels (a live 3-axis sensor's
  ``NAME.x``) with the unit its ``unit_string`` names;
- the **further tables** of a TDMS recording (a live read-out's ``readout`` values, its
  ``events``, its ``tares``: the groups other than ``recording`` and ``checksums``), each channel
  with its unit where the file names one;
- the **metadata**: the source file, the reader's notes (damage read past, a recording cut short:
  one line each), the file's word on itself (complete, planned angles:
  :class:`~magcilia.io.recording_state.RecordingState`) and its stored properties (the setup
  under ``setup``, the source, rate, sensor, start time: what ``record`` and ``live --record``
  keep; JSON text where a format takes text only).

Per format (:data:`FORMATS`; the format from the suffix unless given):

- **CSV** (``.csv``): one header line of the readers' names (units in the names, as every CSV
  of the project: ``angle_deg,voltage_V,time_s``), one row per sample, numbers as the shortest
  text that reads back as the same float; before the header, as ``#`` comment lines that every
  reader of the project skips (so the file reads back with :func:`magcilia.io.read_samples`): the
  metadata as one JSON line (``# magcilia-export: {...}``), and each further table as a JSON
  line (``# magcilia-table: {"table": ..., "columns": [...], "rows": m, "units": {...}}``)
  followed by its rows (``# readout: v1,v2,...``).
- **MATLAB** (``.mat``): one column vector per channel (a name MATLAB does not take, such as
  ``c1.x``, becomes ``c1_x``; ``metadata.renamed`` says so), a struct ``units`` (channel → unit
  text), a struct ``metadata`` of char arrays (``source``, ``notes`` one per line, ``state``,
  ``properties`` and ``setup`` as JSON text) and a struct ``tables`` of the further tables (each
  a struct of column vectors and its ``units``). Version 5 (``scipy.io.savemat``, compressed)
  for files within v5's 2 GB limit; version 7.3 (HDF5 behind MATLAB's 512-byte header, the
  layout MATLAB itself writes: :mod:`magcilia.io.export_formats`) above it or when asked
  (``mat_version="7.3"``). Both read back with :func:`magcilia.io.read_samples` and open in
  MATLAB, SciPy (v5) and h5py (v7.3).
- **HDF5** (``.h5``, ``.hdf5``; ``h5py``): one dataset per channel at the root with a ``units``
  attribute, the metadata as root attributes (text; JSON for the structured ones), each further
  table as a group of datasets; reads back with :func:`magcilia.io.read_samples`.
- **NetCDF** (``.nc``; ``xarray`` with the ``h5netcdf`` engine): the recording as an
  ``xarray.Dataset`` along ``sample`` (``time_s`` the coordinate where there is one), variables
  with ``units`` attributes, the metadata as attributes; each further table as a NetCDF group.

The output is written atomically (:mod:`magcilia._atomic`): a failure leaves no file, and an
existing file is kept unless ``overwrite`` is given.
"""

from __future__ import annotations

import json
import os
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from magcilia import _validate as v
from magcilia._atomic import exists_message, jsonable, partial_file
from magcilia._errors import MagciliaError
from magcilia._validate import printable
from magcilia.io import export_formats
from magcilia.io.columns import ROLES, Columns
from magcilia.io.export_data import RecordingExport, unit_of
from magcilia.io.recording_state import RecordingState
from magcilia.io.recordings import MAX_SAMPLES, read_recording

F64 = NDArray[np.float64]

#: the export formats and the suffixes that name them
FORMATS: dict[str, tuple[str, ...]] = {"csv": (".csv",), "mat": (".mat",),
                                       "h5": (".h5", ".hdf5"), "nc": (".nc",)}
#: MATLAB versions :func:`export` writes
MAT_VERSIONS = ("5", "7.3")
#: TDMS groups that are not tables of the recording (the chunk checksums)
_SKIPPED_GROUPS = ("checksums",)


def _property(value: Any) -> Any:
    """A stored TDMS property as JSON-ready data (JSON text parsed back where it is JSON)."""
    if isinstance(value, str) and value[:1] in "[{":
        try:
            return json.loads(value)
        except ValueError:
            return value
    return jsonable(value)


def _tdms_extras(path: Path, known: Mapping[str, F64]) -> tuple[
        dict[str, Any], dict[str, F64], dict[str, str], dict[str, dict[str, F64]],
        dict[str, dict[str, str]]]:
    """A TDMS recording's root properties, the ``recording`` group's further channels (those of
    the samples' length that the readers do not know) with units, and its other groups."""
    from magcilia.io.recordings import nptdms_module, quiet_nptdms
    from magcilia.io.tdmsfile import GROUP

    nptdms = nptdms_module("Exporting TDMS recordings")
    n = max((a.size for a in known.values()), default=0)
    extra: dict[str, F64] = {}
    extra_units: dict[str, str] = {}
    tables: dict[str, dict[str, F64]] = {}
    units: dict[str, dict[str, str]] = {}
    with quiet_nptdms(), path.open("rb") as file, nptdms.TdmsFile.open(file) as tdms:
        props = {str(k): _property(x) for k, x in tdms.properties.items()}
        for group in tdms.groups():
            name = printable(str(group.name))
            if name in _SKIPPED_GROUPS:
                continue
            for channel in group.channels():
                cname = printable(str(channel.name))
                if name == GROUP and cname in known:
                    continue
                if len(channel) > MAX_SAMPLES:
                    raise MagciliaError(f"{path}: channel {name}/{cname} holds {len(channel):,} "
                                        f"values, more than MAX_SAMPLES = {MAX_SAMPLES:,}")
                data = channel[:]
                if np.asarray(data).dtype.kind not in "biuf":
                    continue  # (text or time stamps: not a numeric channel)
                values = np.asarray(data, dtype=np.float64)
                unit = str(channel.properties.get("unit_string", ""))
                if name == GROUP:
                    if values.size == n:
                        extra[cname], extra_units[cname] = values, unit
                    continue
                tables.setdefault(name, {})[cname] = values
                units.setdefault(name, {})[cname] = unit
    return props, extra, extra_units, tables, units


def gather(recording: str | os.PathLike[str], *,
           columns: Columns | Mapping[str, str] | str | None = None,
           delimiter: str | None = None, decimal: str = ".",
           group: str | None = None) -> RecordingExport:
    """Everything :func:`export` writes of ``recording``: its samples with their units, its
    further tables and its metadata (see the module docstring).

    Parameters
    ----------
    recording : str or path
        A recording the readers take (CSV, .mat, .tdms, .h5).
    columns, delimiter, decimal, group
        As for :func:`magcilia.io.read_samples` (the file's own names and units).

    Raises
    ------
    MagciliaError
        For a file the readers refuse (one line naming it and what is wrong).
    """
    path = Path(recording)
    mapping = Columns.coerce(columns)
    mapped = tuple(ROLES[r][0] for r in ROLES if r not in ("temperature", "temperature_celsius")
                   and getattr(mapping, r) != getattr(Columns(), r))  # must be there
    raw = read_recording(path, mapped, columns=mapping, delimiter=delimiter, decimal=decimal,
                         group=group, temperature=True)
    cols = dict(raw.columns)
    if not cols:
        raise MagciliaError(f"{path}: no column the readers know (angle_deg, voltage_V, time_s, "
                            "…); map the file's names with --columns ROLE=NAME[unit]")
    units = {k: unit_of(k) for k in cols}
    tables: dict[str, dict[str, F64]] = {}
    table_units: dict[str, dict[str, str]] = {}
    props: dict[str, Any] = {}
    if path.suffix.lower() == ".tdms":
        props, extra, extra_units, tables, table_units = _tdms_extras(path, cols)
        cols.update(extra)
        units.update(extra_units)
    metadata = {"source": str(path), "notes": [*raw.notes, *_state_notes(raw.state, cols, path)],
                "state": raw.state.to_dict(),
                "properties": props}
    return RecordingExport(str(path), cols, units, tables, table_units, metadata)


def _state_notes(state: RecordingState, cols: Mapping[str, F64], path: Path) -> list[str]:
    """What the file's word on itself says against its samples: a recording cut short, the
    planned angles it never reached (:meth:`RecordingState.notes`)."""
    if "angle_deg" not in cols:
        note = state.incomplete_note()
        return [] if note is None else [note]
    finite = cols["angle_deg"][np.isfinite(cols["angle_deg"])]
    angles, counts = np.unique(np.round(finite, 9), return_counts=True)
    return state.notes(angles, counts, str(path))


def export_format(path: str | os.PathLike[str], to: str | None = None) -> str:
    """The format to write: ``to`` checked, or the one ``path``'s suffix names."""
    if to is not None:
        return v.choice("format", str(to).lower().lstrip("."), tuple(FORMATS))
    suffix = Path(path).suffix.lower()
    for name, suffixes in FORMATS.items():
        if suffix in suffixes:
            return name
    raise v.fail(f"{os.fspath(path)}: output suffix", suffix or "(none)",
                 "one of " + ", ".join(s for ss in FORMATS.values() for s in ss)
                 + ", or the format given (--to csv|mat|h5|nc)")


def export(recording: str | os.PathLike[str], path: str | os.PathLike[str],
           format: str | None = None, *, mat_version: str | None = None,
           overwrite: bool = False,
           columns: Columns | Mapping[str, str] | str | None = None,
           delimiter: str | None = None, decimal: str = ".",
           group: str | None = None) -> RecordingExport:
    """Write a recording to a CSV, MATLAB, HDF5 or NetCDF file (see the module docstring).

    Parameters
    ----------
    recording : str or path
        A recording the readers take (CSV, .mat, .tdms, .h5), a recording cut short too.
    path : str or path
        The file to write.
    format : {"csv", "mat", "h5", "nc"}, optional
        Default: from ``path``'s suffix (``.csv``, ``.mat``, ``.h5``/``.hdf5``, ``.nc``).
    mat_version : {"5", "7.3"}, optional
        MATLAB only: version 5 (SciPy) or 7.3 (HDF5); default 5, 7.3 where the numbers exceed
        v5's 2 GB.
    overwrite : bool
        Replace an existing ``path`` (False: refuse it, one line).
    columns, delimiter, decimal, group
        How to read ``recording`` (as :func:`magcilia.io.read_samples`).

    Returns
    -------
    RecordingExport
        What was written.

    Raises
    ------
    MagciliaError
        For an unknown format or suffix, an existing ``path`` without ``overwrite``, a folder
        or ``recording`` itself as ``path``, a file that cannot be written, a recording the
        readers refuse.
    MissingDependencyError
        For HDF5 or MATLAB 7.3 without ``h5py``, NetCDF without ``xarray``/``h5netcdf``.

    Examples
    --------
    >>> import magcilia as mc, tempfile, pathlib
    >>> from magcilia.io.recordings import example_path
    >>> out = pathlib.Path(tempfile.mkdtemp()) / "run.mat"
    >>> mc.export(example_path(), out).units["voltage_V"]
    'V'
    """
    kind = export_format(path, format)
    version = None if mat_version is None else v.choice("mat_version", str(mat_version),
                                                        MAT_VERSIONS)
    if version is not None and kind != "mat":
        raise v.fail("mat_version", mat_version, "left out for a non-MATLAB export")
    out = check_output(recording, path, overwrite)
    data = gather(recording, columns=columns, delimiter=delimiter, decimal=decimal, group=group)
    if kind == "mat" and version is None:
        version = "7.3" if data.nbytes >= export_formats.MAT_V5_LIMIT else "5"
    writer = export_formats.WRITERS[kind if kind != "mat" else f"mat{version}"]
    writer.check()  # a missing package: before any file is made
    try:
        with partial_file(out) as part:
            if writer.hdf5:
                part.close()  # HDF5 locks the file itself while it writes
            writer.write(data, part.path)
            part.publish()
    except OSError as exc:
        raise MagciliaError(f"cannot write {out}: {exc.strerror or exc}") from None
    return data


def check_output(recording: str | os.PathLike[str], path: str | os.PathLike[str],
                 overwrite: bool) -> Path:
    """``path`` checked as a new export file before the recording is read: not a folder, not
    ``recording`` itself, not an existing file unless ``overwrite`` (the ``--force`` message),
    and in a folder that can be written (or made)."""
    out = Path(path)
    if out.is_dir():
        raise MagciliaError(f"{out} is a folder, not a file; choose another --out")
    for folder in out.absolute().parents:  # the nearest that exists
        if os.path.lexists(folder):
            if not folder.is_dir():
                raise MagciliaError(f"cannot write {out}: {folder} is a file, not a folder")
            if not os.access(folder, os.W_OK | os.X_OK):
                raise MagciliaError(f"cannot write {out}: {folder}: Permission denied")
            break
    if out.exists():
        src = Path(recording)
        if src.exists() and src.samefile(out):
            raise MagciliaError(f"{out} is the input of RECORDING; an input is never replaced "
                                "(--force neither): choose another --out")
        if not overwrite:
            raise MagciliaError(exists_message(out))
    return out
