"""HDF5 recordings (``.h5``, ``.hdf5``): one 1-D dataset per column, read with h5py.

Layout: the datasets ``angle_deg`` and ``voltage_V`` (optionally ``time_s``, ``setreset``), or
the names of a column mapping (:class:`magcilia.io.columns.Columns`), at the root of the file or
in the group named by ``group`` (``"run3"``, ``"/experiments/run3"``). A mapped name may also be a
path below that group (``daq/Vout[mV]``). Each dataset holds real numbers (any integer or float
type), shape ``(n,)`` or a column or row ``(n, 1)``/``(1, n)``, all of one length. Its unit comes
from the mapping, from its name (``Vout [mV]``), from a ``units`` (or ``unit``) string attribute
(``"mV"``, as many DAQ and h5py scripts write it), or from a unit suffix of its name
(``voltage_V``), in that order; units that disagree are an error.

Nothing outside the file is read: datasets reached through an external link, datasets whose
values are kept in another file (external storage) or gathered from others (virtual datasets),
and datasets decoded by a filter that is not built into HDF5 or h5py (a plugin: the child
process forgets HDF5's plugin paths, so none is loaded) are refused with one line naming the
dataset. A dataset only partly written (a chunked dataset with chunks never allocated, a
contiguous one never written: HDF5 would read the gaps as the fill value, 0.0) is refused too
(:func:`magcilia.io.matfile.h5_dataset_problem`). pandas' HDF files (PyTables tables) are not read:
write the columns as datasets (``h5py``: ``f["voltage_V"] = values``).

Like MATLAB v7.3 files, HDF5 files are parsed in a child process (:mod:`magcilia.io.matfile`
says why: HDF5 is a large C library that can crash on a damaged file), under the same limits
(:data:`~magcilia.io.matfile.MAT_MEMORY_LIMIT`, :data:`~magcilia.io.matfile.MAT_TIMEOUT_S`): a
crash, a kill or a timeout is one error line. Shapes, types and sizes are checked from the
dataset's header before any data is read (h5py reads lazily), each dataset against
``MAX_SAMPLES``; a dataset that declares more values than its file can hold uncompressed is
refused as damaged unless it is chunked (compressed data is bounded by the memory limit).

Example (with h5py)::

    with h5py.File("run.h5", "w") as f:
        g = f.create_group("run3")
        g["Tilt"] = angles_deg
        g["Vout"] = volts_mV
        g["Vout"].attrs["units"] = "mV"
    read_measurements("run.h5", group="run3", columns={"angle": "Tilt[deg]", "voltage": "Vout"})
"""

from __future__ import annotations

import inspect
import json
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from magcilia._errors import MagciliaError, require
from magcilia._validate import printable
from magcilia.io import matfile
from magcilia.io.columns import _TRAILING_UNIT, Columns, scaled
from magcilia.io.csvfile import names_text, too_many_samples
from magcilia.io.matfile import forget_h5_plugins, h5_dataset_problem, h5_reaches_outside

F64 = NDArray[np.float64]

HDF5_SUFFIXES = (".h5", ".hdf5")


def _h5_child() -> None:  # pragma: no cover (runs in the child process)
    """The HDF5 reader's child process (see the module docstring): self-contained, imports
    nothing from magcilia.

    argv: file, output .npz, memory limit (bytes), most samples per dataset, file size, group,
    JSON list of the names wanted, the unit pattern (a regex: a name with a trailing unit).
    Prints one JSON line: ``found`` (dataset names in the group), ``units`` (name -> units
    attribute), ``problems`` (name -> what is wrong), ``saved``, ``error``.
    """
    import json
    import os
    import re
    import sys
    from pathlib import Path

    path, out = sys.argv[1:3]
    memory, max_samples, size = (int(x) for x in sys.argv[3:6])
    group_name, wanted, pattern = sys.argv[6], json.loads(sys.argv[7]), re.compile(sys.argv[8],
                                                                                   re.DOTALL)
    found: list[str] = []
    units: dict[str, str] = {}
    problems: dict[str, str] = {}
    saved: list[str] = []
    error = None

    def matches(name: str) -> bool:
        text = name.strip()
        if text in wanted:
            return True
        m = pattern.match(text)
        return bool(m and m.group(1) and m.group(1) in wanted)

    try:
        import h5py
        import numpy as np

        try:  # Linux: cap the memory
            import resource

            used = int(Path("/proc/self/statm").read_text().split()[0]) * os.sysconf(
                "SC_PAGE_SIZE")
            soft, hard = resource.getrlimit(resource.RLIMIT_AS)
            cap = used + memory if hard == resource.RLIM_INFINITY else min(used + memory, hard)
            if soft == resource.RLIM_INFINITY or soft > cap:
                resource.setrlimit(resource.RLIMIT_AS, (cap, hard))
        except (ImportError, OSError, ValueError):
            pass
        arrays: dict[str, Any] = {}
        forget_h5_plugins(h5py)
        with h5py.File(path, "r") as f:
            group = f
            if group_name not in ("", "/"):
                if h5_reaches_outside(f, "/" + group_name.strip("/")):
                    raise LookupError(f"the group {group_name!r} is reached through an external "
                                      "link to another file; copy the data in")
                obj = f.get(group_name)
                if not isinstance(obj, h5py.Group):
                    groups = [str(k) for k in f if isinstance(f.get(k, getlink=True),
                                                                h5py.HardLink)
                              and isinstance(f[k], h5py.Group)]
                    raise LookupError(f"no group {group_name!r} (groups at the root: "
                                      f"{', '.join(groups[:12]) or 'none'})")
                group = obj

            def external(k: str) -> bool:  # a link on the way to k points into another file
                return h5_reaches_outside(f, f"{group.name.rstrip('/')}/{k.strip('/')}")

            found = [str(k) for k in group]
            for k in wanted:  # paths below the group: the members of the group they name
                parent = k.strip("/").rpartition("/")[0]
                if parent and not external(parent):
                    sub = group.get(parent)
                    if isinstance(sub, h5py.Group):
                        found += [f"{parent}/{m}" for m in sub if f"{parent}/{m}" not in found]
            for k in found:
                if not matches(k):
                    continue
                if external(k):
                    problems[k] = "is an external link to another file; copy the data in"
                    continue
                obj = group.get(k)
                if not isinstance(obj, h5py.Dataset):
                    problems[k] = "is a group, not a dataset"
                    continue
                for attr in ("units", "unit", "Units", "UNITS"):
                    value = obj.attrs.get(attr) if attr in obj.attrs else None
                    if isinstance(value, np.ndarray) and value.size == 1:
                        value = value.reshape(-1)[0]
                    if isinstance(value, (bytes, np.bytes_)):
                        value = bytes(value).decode("utf-8", "replace")
                    if isinstance(value, str):
                        units[k] = value[:40]
                        break
                dtype = obj.dtype
                if dtype.names:
                    problems[k] = "is a compound (table) dataset, not a column of numbers"
                elif dtype.kind not in "biuf":
                    problems[k] = f"holds {dtype} values, not real numbers"
                elif obj.shape is None or obj.ndim == 0:
                    problems[k] = "is a scalar (or empty dataspace), not a column of samples"
                elif obj.ndim > 2 or (obj.ndim == 2 and min(obj.shape) > 1):
                    problems[k] = (f"has shape {'×'.join(map(str, obj.shape))}; store one "
                                   "column of samples, shape (n,)")
                elif obj.size > max_samples:
                    problems[k] = f"too many: {obj.size}"
                elif obj.chunks is None and obj.size * dtype.itemsize > size and not (
                        obj.id.get_create_plist().get_external_count()):
                    problems[k] = (f"declares {obj.size:,} values, more than the file's "
                                   f"{size:,} bytes can hold; the file is damaged")
                elif (problem := h5_dataset_problem(obj)) is not None:
                    problems[k] = problem
                else:
                    arrays[k] = np.asarray(obj[()], dtype=np.float64).reshape(-1)
        if arrays:
            np.savez(out, *arrays.values())
            saved = list(arrays)
    except MemoryError:
        error = "memory"
    except LookupError as exc:
        error = f"group: {exc.args[0] if exc.args else exc}"
    except Exception as exc:  # noqa: BLE001 (the parent turns it into one line)
        error = f"{type(exc).__name__}: {exc}"
    sys.stdout.write(json.dumps({"found": found[:1000], "n_found": len(found), "units": units,
                                 "saved": saved, "problems": problems, "error": error}) + "\n")


def _h5_child_code() -> str:
    """The child's program: the shared HDF5 checks, :func:`_h5_child`'s source and a call."""
    return matfile.h5_child_helpers() + inspect.getsource(_h5_child) + "\n_h5_child()\n"


def _run_child(path: Path, group: str, wanted: list[str], max_samples: int
               ) -> tuple[dict[str, Any], dict[str, F64]]:
    """Parse ``path`` in a child process (:func:`magcilia.io.matfile.run_child`): its report and
    arrays (by dataset name)."""
    def load(out: Path, report: dict[str, Any]) -> dict[str, NDArray[Any]]:
        saved = [str(s) for s in report.get("saved") or []]
        if not saved or report.get("error"):
            return {}
        with np.load(out, allow_pickle=False) as npz:
            return {name: np.asarray(npz[f"arr_{i}"], dtype=np.float64)
                    for i, name in enumerate(saved)}

    report, arrays = matfile.run_child(
        path, _h5_child_code(),
        [str(int(max_samples)), str(path.stat().st_size), group, json.dumps(wanted),
         _TRAILING_UNIT.pattern],
        reader="HDF5", what="an HDF5 file", load=load)
    error = report.get("error")
    if isinstance(error, str) and error.startswith("group: "):
        raise MagciliaError(f"{path}: {printable(error[7:300])}; pass the group that holds "
                            "the datasets (CLI: --group NAME)")
    if error:
        raise MagciliaError(f"{path}: cannot read as an HDF5 file "
                            f"({printable(str(error)[:200])}); the file is damaged or not HDF5")
    return report, arrays


def read_hdf5(path: Path, columns: Columns, required: tuple[str, ...], *, group: str = "/",
              max_samples: int) -> dict[str, F64]:
    """The columns of an HDF5 recording (see the module docstring), by key (``angle_deg``,
    ``voltage_V``, ``time_s``, ``setreset``) in deg, V and s.

    Parameters
    ----------
    path : Path
        The ``.h5``/``.hdf5`` file.
    columns : Columns
        Which dataset holds which role, with units.
    required : tuple of str
        Keys that must be found.
    group : str
        The group holding the datasets ("/" or "" for the root).
    max_samples : int
        Most values per dataset.

    Raises
    ------
    MagciliaError
        One line naming the file and what is wrong (the parser's crash included).
    MissingDependencyError
        Without h5py (the ``hdf5`` extra).
    """
    require("h5py", package="h5py", extra="hdf5", purpose="Reading HDF5 recordings")
    with path.open("rb") as f:
        head = f.read(8)
    if head != b"\x89HDF\r\n\x1a\n":
        size = path.stat().st_size
        raise MagciliaError(f"{path}: not an HDF5 file ("
                            + ("empty" if size == 0 else "no HDF5 signature at its start")
                            + "); save the recording with h5py, or as CSV")
    wanted = sorted(set(columns.names().values()))
    report, arrays = _run_child(path, group, wanted, max_samples)
    found = [str(n) for n in report.get("found") or []]
    where = str(path) + ("" if group in ("", "/") else f" (group {printable(group)})")
    located = columns.locate(found, where=where, required=required,
                             units=report.get("units") or {}, kind="dataset")
    problems = report.get("problems") or {}
    out: dict[str, F64] = {}
    for key, (i, factor) in located.items():
        name = found[i]
        problem = problems.get(name)
        if problem is not None and str(problem).startswith("too many"):
            raise too_many_samples(path, f"dataset {printable(name)}", max_samples)
        if problem is not None:
            raise MagciliaError(f"{where}: dataset {printable(name)} {printable(str(problem))}")
        if name not in arrays:
            raise MagciliaError(f"{where}: dataset {printable(name)} could not be read "
                                f"(datasets: {names_text(found)})")
        out[key] = scaled(arrays[name], factor)
    return out
