"""The writers of :func:`magcilia.io.export_recording.export`: CSV, MATLAB v5 and v7.3, HDF5 and
NetCDF.

Each takes a :class:`~magcilia.io.export_data.RecordingExport` and a path (the temporary file that
:mod:`magcilia._atomic` renames into place); :data:`WRITERS` names them by format.

MATLAB v7.3 is HDF5 behind a 512-byte user block that starts with MATLAB's text header
(``MATLAB 7.3 MAT-file, Platform: …, Created on: … HDF5 schema 1.00 .``, then the version
0x0200 and the endian mark ``IM`` at bytes 124–127), the layout MATLAB writes: each variable a
dataset with a ``MATLAB_class`` attribute, MATLAB's dimensions reversed (a column vector n×1 is
the HDF5 shape (1, n)); text a ``char`` dataset of UTF-16 code units (``MATLAB_int_decode`` 2);
a struct a group of class ``struct`` listing its fields in ``MATLAB_fields``; an empty array
its dimensions with ``MATLAB_empty`` 1. (The same layout as the ``hdf5storage`` package writes,
and as :mod:`magcilia.io.matfile` reads back.)
"""

from __future__ import annotations

import datetime as dt
import json
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from magcilia._errors import require
from magcilia.io.export_data import RecordingExport, matlab_names
from magcilia.io.export_xarray import dataset, xarray_module

F64 = NDArray[np.float64]
#: the numbers above which a MATLAB export is written as v7.3: v5/v7 files hold variables below
#: 2 GB (MATLAB's ``save`` documentation: "-v7.3 ... variables larger than 2 GB"; the v5 format's
#: element sizes are 32-bit), less a MiB for the structs beside them
MAT_V5_LIMIT = 2**31 - 2**20
#: rows per block of CSV text
CSV_BLOCK = 100_000
#: the start of MATLAB 7.3's 116-byte header text
MAT73_TEXT = "MATLAB 7.3 MAT-file"


# -- CSV -------------------------------------------------------------------------------------------
def _texts(values: F64, key: str) -> NDArray[np.str_]:
    """A column as text: the shortest that reads back as the same float (NumPy's ``str``),
    ``setreset`` as ``1``/``-1``."""
    if key == "setreset" and np.all(np.isin(values, (-1.0, 1.0))):
        return np.where(values > 0, "1", "-1")
    return values.astype(str)


def write_csv(data: RecordingExport, path: Path) -> None:
    """The samples as CSV; before the header, as ``#`` lines: the metadata (one JSON line), and
    each further table as a JSON line naming its columns, rows and units followed by one line per
    row (``# NAME: v1,v2,…``; every line stays short, within the readers' line limit)."""
    meta = {**data.metadata, "units": data.units,
            "exported_by": data.attributes()["exported_by"]}
    with path.open("w", encoding="utf-8", newline="\n") as fh:
        fh.write(f"# magcilia-export: {json.dumps(meta)}\n")
        for name, table in data.tables.items():  # a header, then one comment line per row
            names = list(table)
            m = max((a.size for a in table.values()), default=0)
            doc = {"table": name, "columns": names, "rows": m,
                   "units": data.table_units.get(name, {})}
            fh.write(f"# magcilia-table: {json.dumps(doc)}\n")
            cols = [_texts(np.pad(table[k], (0, m - table[k].size), constant_values=np.nan), k)
                    for k in names]
            fh.write("".join(f"# {name}: " + ",".join(row) + "\n"
                             for row in zip(*cols, strict=True)))
        fh.write(",".join(data.columns) + "\n")
        for start in range(0, data.samples, CSV_BLOCK):
            cols = [_texts(a[start:start + CSV_BLOCK], k) for k, a in data.columns.items()]
            fh.write("".join(",".join(row) + "\n" for row in zip(*cols, strict=True)))


# -- MATLAB v5 -------------------------------------------------------------------------------------
def _struct(mapping: Mapping[str, Any]) -> dict[str, Any]:
    """A mapping as a MATLAB struct's fields (names made MATLAB's)."""
    names = matlab_names(list(mapping))
    return {names[k]: x for k, x in mapping.items()}


def _mat_content(data: RecordingExport) -> tuple[dict[str, F64], dict[str, Any]]:
    """The variables (column vectors) and the structs ``units``, ``metadata``, ``tables``."""
    names = matlab_names([*data.columns, "units", "metadata", "tables"])
    renamed = {k: names[k] for k in data.columns if names[k] != k}
    meta = data.attributes()
    if renamed:
        meta["renamed"] = json.dumps(renamed)
    structs: dict[str, Any] = {
        names["units"]: {names[k]: u for k, u in data.units.items()},
        names["metadata"]: meta}
    if data.tables:
        structs[names["tables"]] = _struct({
            g: {**_struct(t), "units": _struct(data.table_units.get(g, {}))}
            for g, t in data.tables.items()})
    return {names[k]: a for k, a in data.columns.items()}, structs


def check_none() -> None:
    """CSV and MATLAB v5 (SciPy, a core dependency) need no optional package."""


def write_mat5(data: RecordingExport, path: Path) -> None:
    """MATLAB v5 (``scipy.io.savemat``, compressed): column vectors and structs."""
    from scipy.io import savemat

    arrays, structs = _mat_content(data)
    savemat(path, {**{k: a.reshape(-1, 1) for k, a in arrays.items()}, **structs},
            format="5", do_compression=True, long_field_names=True, oned_as="column")


# -- MATLAB v7.3 and HDF5 --------------------------------------------------------------------------
def h5py_module(purpose: str) -> Any:
    """h5py, or one line naming the ``hdf5`` extra."""
    return require("h5py", package="h5py", extra="hdf5", purpose=purpose)


def check_h5() -> None:
    """h5py is there (else one line naming the extra)."""
    h5py_module("Exporting to HDF5 or MATLAB 7.3")


def _mat73_value(h5py: Any, parent: Any, name: str, value: Any) -> None:
    """``value`` (numbers, text or a mapping) as MATLAB 7.3 variable ``name`` of ``parent``."""
    if isinstance(value, Mapping):
        group = parent.create_group(name)
        group.attrs["MATLAB_class"] = np.bytes_("struct")
        fields = list(value)
        vlen = h5py.vlen_dtype(np.dtype("S1"))
        listed = np.empty(len(fields), dtype=object)
        for i, f in enumerate(fields):
            listed[i] = np.array(list(f), dtype="S1")
        group.attrs.create("MATLAB_fields", listed, dtype=vlen)
        for f in fields:
            _mat73_value(h5py, group, f, value[f])
        return
    if isinstance(value, str):
        codes = np.frombuffer(value.encode("utf-16-le"), dtype="<u2")
        cls = "char"
    else:
        codes = np.asarray(value, dtype=np.float64).ravel()
        cls = "double"
    if codes.size == 0:  # MATLAB stores an empty array as its dimensions
        dset = parent.create_dataset(name, data=np.array([0, 1] if cls == "double" else [0, 0],
                                                         dtype=np.uint64))
        dset.attrs["MATLAB_empty"] = np.uint8(1)
    else:  # a column vector n×1 (numbers) or a row 1×n (text): dimensions reversed
        dset = parent.create_dataset(name, data=codes.reshape(1, -1) if cls == "double"
                                     else codes.reshape(-1, 1))
    dset.attrs["MATLAB_class"] = np.bytes_(cls)
    if cls == "char":
        dset.attrs["MATLAB_int_decode"] = np.int32(2)


def mat73_header() -> bytes:
    """MATLAB 7.3's 128-byte header (the first bytes of the 512-byte user block)."""
    now = dt.datetime.now(dt.UTC).strftime("%a %b %d %H:%M:%S %Y")
    text = f"{MAT73_TEXT}, Platform: GLNXA64, Created on: {now} HDF5 schema 1.00 ."
    return text.encode("ascii").ljust(116, b" ") + b" " * 8 + b"\x00\x02" + b"IM"


def write_mat73(data: RecordingExport, path: Path) -> None:
    """MATLAB v7.3: HDF5 behind MATLAB's header (see the module docstring)."""
    h5py = h5py_module("Exporting to MATLAB 7.3")
    arrays, structs = _mat_content(data)
    with h5py.File(path, "w", userblock_size=512, libver="earliest") as f:
        for name, values in {**arrays, **structs}.items():
            _mat73_value(h5py, f, name, values)
    with path.open("r+b") as fh:
        fh.write(mat73_header().ljust(512, b"\x00"))


def _h5_attrs(target: Any, attrs: Mapping[str, str]) -> None:
    for k, text in attrs.items():
        target.attrs[k] = text


def write_h5(data: RecordingExport, path: Path) -> None:
    """HDF5: root datasets with ``units``, the metadata as root attributes, a group per table."""
    h5py = h5py_module("Exporting to HDF5")
    with h5py.File(path, "w") as f:
        for name, values in data.columns.items():
            f.create_dataset(name, data=values)
            if data.units.get(name):
                f[name].attrs["units"] = data.units[name]
        _h5_attrs(f, data.attributes())
        for group, table in data.tables.items():
            g = f.create_group(group)
            for name, values in table.items():
                g.create_dataset(name, data=values)
                unit = data.table_units.get(group, {}).get(name)
                if unit:
                    g[name].attrs["units"] = unit


# -- NetCDF ----------------------------------------------------------------------------------------
def check_nc() -> None:
    """xarray and its h5netcdf engine are there (else one line naming the ``export`` extra)."""
    xarray_module("Exporting to NetCDF")
    require("h5netcdf", package="h5netcdf", extra="export", purpose="Exporting to NetCDF")


def recording_dataset(data: RecordingExport) -> Any:
    """The samples as an ``xarray.Dataset`` along ``sample`` (``time_s`` its coordinate)."""
    return dataset(data.columns, data.units, dim="sample",
                   coords=("time_s",) if "time_s" in data.columns else (),
                   attrs=data.attributes())


def write_nc(data: RecordingExport, path: Path) -> None:
    """NetCDF-4 (h5netcdf): the recording's dataset at the root, each table as a group."""
    recording_dataset(data).to_netcdf(path, engine="h5netcdf")
    for name, table in data.tables.items():
        dataset(table, data.table_units.get(name, {}), dim=f"{name}_row").to_netcdf(
            path, mode="a", group=name, engine="h5netcdf")


@dataclass(frozen=True)
class Writer:
    """A format's writer and the check of its packages (run before any file is made)."""

    write: Callable[[RecordingExport, Path], None]
    check: Callable[[], None]
    #: HDF5 underneath: HDF5 locks the file itself while it writes (so the partial file's own
    #: lock is dropped first: a second lock on it from this process would fail)
    hdf5: bool = False


WRITERS = {"csv": Writer(write_csv, check_none), "mat5": Writer(write_mat5, check_none),
           "mat7.3": Writer(write_mat73, check_h5, hdf5=True),
           "h5": Writer(write_h5, check_h5, hdf5=True), "nc": Writer(write_nc, check_nc, hdf5=True)}
