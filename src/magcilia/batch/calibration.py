"""Batch calibration: many recordings, each calibrated as ``magcilia calibrate`` does, through the
execution layer (:func:`magcilia.execution.run_tasks`: a local process pool, or a Dask cluster).

The output folder ``DIR``::

    DIR/manifest.json          what identifies the batch: the options and the initial setup
                               (their hash), and the recordings of the last run
    DIR/<recording>/           one folder per recording (its file name without the suffix):
                               what ``magcilia calibrate --out`` writes (fitted_setup.toml,
                               result.json, report.md, fit.png, residuals.png) and batch.json
                               (its row of the table); a failed recording: batch.json alone
    DIR/results.csv            one row per recording (SI; see :data:`COLUMNS`)
    DIR/results.parquet        the same table (needs pyarrow: ``magcilia[cluster]``)
    DIR/summary.md             the spread of the fitted values over the batch, outliers flagged

Workers only compute: each returns its recording's row and files (as bytes) and this process
publishes the recording's folder with one rename as the result arrives, so a worker killed at
any moment leaves nothing half-written, and no recording is written twice. A rerun with the same
options skips every recording whose folder is complete and whose file has not changed (size and
modification time), and redoes the failed and missing ones; a folder of a batch with other
options is an error (``force`` starts it over).

Outliers: the modified z-score of Iglewicz and Hoaglin, ``z = 0.6745 (v − median) / MAD``
(MAD the median absolute deviation), flagged when ``|z| > 3.5``, for each fitted geometry and
placement value and the cost (high costs only), over the recordings that succeeded. A value is
compared only where its recording's data determine it (a finite standard error), and is flagged
only when it also lies more than :data:`OUTLIER_SIGMAS` of its own standard errors from the
median: a parameter a tilt path leaves undetermined (the size, by the scale symmetry) takes any
value on an equally good fit, and its spread says nothing about the chips. The summary says
which parameters were checked and which were not.
"""

from __future__ import annotations

import glob
import hashlib
import json
import logging
import math
import os
import time
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from magcilia import _validate as v
from magcilia._atomic import (
    check_own,
    clear_output,
    json_text,
    scratch_directory,
    staged_directory,
    write_files,
)
from magcilia._errors import MagciliaError
from magcilia.batch.results import (
    COLUMNS,
    OUTLIER_SIGMAS,
    OUTLIER_Z,
    SUMMARISED,
    TEXT_COLUMNS,
    UNITS,
    BatchResult,
    batch_statistics,
    robust_z,
    summary_lines,
    summary_markdown,
    tables,
)
from magcilia.calibration.problem import PARAMETERS
from magcilia.calibration.search import calibrate, search_effort
from magcilia.device.setup import Setup
from magcilia.execution import TaskResult, resolve_scheduler, run_tasks
from magcilia.io.columns import Columns
from magcilia.io.recordings import read_measurements
from magcilia.io.setup_files import setup_to_dict
from magcilia.report.calibration import CALIBRATION_FILES, CALIBRATION_NAMES

logger = logging.getLogger(__name__)

#: the manifest's ``format`` value (a folder holding another one is not a batch folder)
FORMAT = "magcilia batch calibrate"
#: the per-recording row inside each recording's folder
ROW_FILE = "batch.json"
#: the files of the batch folder itself (the manifest first: ``force`` removes it last)
BATCH_FILES = ("manifest.json", "results.csv", "results.parquet", "summary.md")
#: the files of a recording's folder: those of ``magcilia calibrate --out`` and its row
RECORDING_FILES = (*CALIBRATION_NAMES, ROW_FILE)
_FIGURES = ("fit.png", "residuals.png")


# -- the task (runs in a worker) --------------------------------------------------------------
def calibrate_recording(task: Mapping[str, Any]) -> dict[str, Any]:
    """Calibrate one recording (a task of :func:`calibrate_batch`, run in a worker).

    ``task`` holds ``path``, ``setup`` (the initial :class:`~magcilia.Setup`), ``calibrate``
    (keyword arguments of :func:`magcilia.calibrate`), ``read`` (of
    :func:`magcilia.read_measurements`), ``figures`` and ``style``. Returns ``{"row": the
    table's values (SI), "files": {name: bytes}}`` (the files of ``magcilia calibrate --out``);
    raises on a recording that cannot be read or fitted.
    """
    from magcilia.report.calibration import write_calibration_files

    setup: Setup = task["setup"]
    data = read_measurements(task["path"], sensor=setup.sensor, **task["read"])
    result = calibrate(data, setup, **task["calibrate"])
    row: dict[str, Any] = {"cost": result.cost, "rms": result.rms}
    row.update({n: float(result.values[n]) for n in (*PARAMETERS, "offset",
                                                     "magnetization_scale")})
    row.update({f"{n}_stderr": float(result.stderr.get(n, math.nan))
                for n in (*SUMMARISED, "offset")})
    row.update(warnings=len(result.warnings), warning_text="; ".join(result.warnings),
               flagged=int((data.metadata.get("quality") or {}).get("flagged", 0)),
               notes="; ".join(data.notes()))
    with scratch_directory("magcilia-batch") as tmp:  # a killed worker's: removed by the next
        write_calibration_files(result, tmp, task["style"], figures=task["figures"])
        files = {p.name: p.read_bytes() for p in sorted(Path(tmp).iterdir())}
    return {"row": row, "files": files}


# -- the batch ----------------------------------------------------------------------------------
def _recordings(paths_or_glob: str | os.PathLike[str] | Sequence[str | os.PathLike[str]],
                out: Path) -> list[Path]:
    """The recordings a glob (or several globs, or paths) names, sorted, less the files inside
    the batch folder ``out`` (a glob over a parent folder matches its results.csv), checked: at
    least one, no two with the same name (file name without its suffix)."""
    patterns = ([paths_or_glob] if isinstance(paths_or_glob, str | os.PathLike)
                else list(paths_or_glob))
    found: dict[Path, None] = {}
    for pattern in patterns:
        text = os.fspath(pattern)
        matches = (sorted(glob.glob(text, recursive=True))  # noqa: PTH207 (str patterns)
                   if glob.has_magic(text) else [text])
        inside = out.resolve()
        for m in matches:
            if inside in Path(m).resolve().parents:
                continue
            if Path(m).is_file() or not glob.has_magic(text):
                found[Path(m)] = None
    if not found:
        shown = ", ".join(os.fspath(p) for p in patterns) or "(none)"
        raise MagciliaError(f"no recording matches {v.printable(shown)}; check the pattern (quote "
                            "it, e.g. 'recordings/*.csv', and use ** for subfolders)")
    by_name: dict[str, Path] = {}
    for path in sorted(found):
        name = path.stem
        if name in by_name:
            raise MagciliaError(
                f"two recordings are named {v.printable(name)!r}: {v.printable(str(by_name[name]))}"
                f" and {v.printable(str(path))}; each recording's results go to DIR/<name>/: "
                "rename one, or calibrate them in separate batches")
        if name.startswith(".") or name in {Path(f).stem for f in BATCH_FILES}:
            raise MagciliaError(f"{v.printable(str(path))}: a recording may not be named "
                                f"{name!r} (the batch folder's own files); rename it")
        by_name[name] = path
    return [by_name[n] for n in sorted(by_name)]


def _stamp(path: Path) -> dict[str, int]:
    try:
        st = path.stat()
    except OSError:
        return {"size": -1, "mtime_ns": -1}
    return {"size": st.st_size, "mtime_ns": st.st_mtime_ns}


def _options_hash(options: Mapping[str, Any]) -> str:
    return hashlib.sha256(json.dumps(options, sort_keys=True).encode()).hexdigest()[:16]


def _check_folder(out: Path, options_hash: str, options: Mapping[str, Any], force: bool) -> None:
    """The batch folder may be (re)used: absent, empty, or a batch with the same options; a
    batch with other options is started over only with ``force``. With ``force`` the folder
    must hold nothing but a batch's own files (:func:`magcilia._atomic.check_own`), and only
    those are removed."""
    if not out.exists():
        return
    if not out.is_dir():
        raise MagciliaError(f"{out} is a file, not a folder; choose another --out")
    manifest = out / "manifest.json"
    if not manifest.exists():
        if any(out.iterdir()):
            raise MagciliaError(f"{out} is not a batch folder (no manifest.json) and is not "
                                "empty; choose a new --out")
        return
    try:
        doc = json.loads(manifest.read_text(encoding="utf-8"))
        ok = doc.get("format") == FORMAT
    except (OSError, ValueError, AttributeError):
        ok = False
    if not ok:
        raise MagciliaError(f"{out}/manifest.json is not a magcilia batch manifest; choose a new "
                            "--out")
    if force:
        check_own(out, BATCH_FILES, RECORDING_FILES)
    if doc.get("options_hash") == options_hash:
        return
    old = doc.get("options", {})
    differ = sorted(k for k in {*old, *options} if old.get(k) != options.get(k)) or ["options"]
    if not force:
        raise MagciliaError(
            f"{out} holds another batch (its {', '.join(differ)} differ); pass --force to start "
            "it over (its results are removed), or choose another --out")
    logger.info("removing the batch in %s (other options: %s)", out, ", ".join(differ))
    clear_output(out, BATCH_FILES, RECORDING_FILES)


def _complete(folder: Path, options_hash: str, stamp: Mapping[str, int],
              figures: bool) -> dict[str, Any] | None:
    """The row of a recording an earlier run finished, or None (missing, failed, changed)."""
    try:
        row = json.loads((folder / ROW_FILE).read_text(encoding="utf-8"))
    except (OSError, ValueError):
        return None
    if (not isinstance(row, dict) or row.get("error") != "" or row.get("options_hash")
            != options_hash or row.get("source") != dict(stamp)):
        return None
    wanted = CALIBRATION_FILES if figures else tuple(
        f for f in CALIBRATION_FILES if f not in _FIGURES)
    if not all((folder / f).is_file() for f in wanted):
        return None
    return row


def _row(name: str, path: Path, values: Mapping[str, Any], error: str, result: TaskResult,
         ) -> dict[str, Any]:
    row: dict[str, Any] = dict.fromkeys(COLUMNS, math.nan)
    row.update(recording=name, error=error, warnings=0, warning_text="", notes="",
               path=str(path),
               attempts=result.attempts, seconds=result.seconds, worker=result.worker)
    row.update(values)
    return row


def _json_row(doc: Mapping[str, Any]) -> dict[str, Any]:
    """A row read back from batch.json (null → NaN in a number column; in a text column it stays
    None, but for ``notes``, which rows of earlier batches lack: "")."""
    row = {c: doc.get(c) for c in COLUMNS}
    for c, value in row.items():
        if value is None:
            row[c] = ("" if c == "notes" else None) if c in TEXT_COLUMNS else math.nan
    return row


def _warm_kernels() -> None:
    """Load the compiled tilt kernel that every fit runs (from numba's disk cache, or compile
    it) in this process, before a local pool forks its workers from it: each worker then starts
    with it loaded instead of loading it for its first fit."""
    Setup.paper().output(np.zeros(1))


def calibrate_batch(
    paths_or_glob: str | os.PathLike[str] | Sequence[str | os.PathLike[str]],
    out_dir: str | os.PathLike[str],
    *,
    setup: Setup | None = None,
    workers: int | None = None,
    scheduler: str | None = None,
    timeout: float = 10.0,
    force: bool = False,
    figures: bool = True,
    style: str = "screen",
    progress: bool = True,
    nan_policy: str = "raise",
    saturation: str = "raise",
    suspect: str = "keep",
    columns: Columns | Mapping[str, str] | str | None = None,
    delimiter: str | None = None,
    decimal: str = ".",
    group: str | None = None,
    rng: int = 0,
    bounds: Mapping[str, tuple[float, float]] | None = None,
    fixed: Mapping[str, float] | None = None,
    bias: str = "offset",
    bias_degree: int = 0,
    fit_scale: bool = False,
    restarts: int = 1,
    starts: int | None = None,
) -> BatchResult:
    """Calibrate every recording a glob matches, each as :func:`magcilia.calibrate` (the paper's
    model) does, into one batch folder (see the module docstring), resumably.

    Parameters
    ----------
    paths_or_glob : str, path or sequence of them
        A glob (``"recordings/*.tdms"``, ``**`` for subfolders) or several globs or paths.
        Recordings are named by their file name without the suffix: two of the same name are
        an error.
    out_dir : path
        The batch folder: new, empty, or one an earlier run of the same batch (same options
        and initial setup) filled: then only the failed, missing or changed recordings run.
    setup : Setup, optional
        The initial setup (default ``Setup.paper_initial()``).
    workers, scheduler, timeout :
        Where the calibrations run (:func:`magcilia.execution.run_tasks`): None one process
        per core, 1 in this process; ``scheduler`` a Dask address or ``"local"``. The
        recordings must be readable by the workers at the same paths (a shared file system);
        the batch folder is written by this process only.
    force : bool
        Start over a folder that holds a batch with other options (its results are removed).
    figures : bool
        Write fit.png and residuals.png per recording (most of a quick fit's time).
    style : {"screen", "paper"}
        The figures' style (``"paper"`` adds PDFs).
    progress : bool
        A progress bar on stderr (when it is a terminal).
    nan_policy, saturation, suspect, columns, delimiter, decimal, group :
        How the recordings are read (:func:`magcilia.read_measurements`); what the quality
        checks flag (``suspect``) and what a reader says of a recording are the table's
        ``flagged`` and ``notes`` columns and summary.md's notes.
    rng : int
        The seed of every recording's global search (each recording's fit equals
        ``calibrate(..., rng=rng)`` alone, whichever backend ran it).
    bounds, fixed, bias, bias_degree, fit_scale, restarts, starts :
        As :func:`magcilia.calibrate` (SI).

    Returns
    -------
    BatchResult
    """
    t0 = time.perf_counter()
    initial = Setup.paper_initial() if setup is None else setup
    if not isinstance(initial, Setup):
        raise v.fail("setup", type(initial).__name__, "a magcilia Setup")
    if isinstance(rng, bool) or not isinstance(rng, int):
        raise v.fail("rng", rng, "an int seed (every recording's search starts from it)")
    v.choice("style", style, ("screen", "paper"))
    search_effort(restarts, 256 if starts is None else starts)  # before any work, not per task
    out = Path(out_dir)
    recordings = _recordings(paths_or_glob, out)
    cols = Columns.coerce(columns)
    read = {"nan_policy": nan_policy, "saturation": saturation, "columns": cols,
            "delimiter": delimiter, "decimal": decimal, "group": group,
            **({} if suspect == "keep" else {"suspect": suspect})}  # (keep: earlier batches')
    cal = {"rng": rng, "bounds": None if bounds is None else dict(bounds),
           "fixed": None if fixed is None else dict(fixed), "bias": bias,
           "bias_degree": bias_degree, "fit_scale": fit_scale, "restarts": restarts,
           "starts": starts}
    options = {**{k: val for k, val in cal.items() if k not in ("bounds", "fixed")},
               "bounds": {k: list(b) for k, b in (bounds or {}).items()},
               "fixed": dict(fixed or {}),
               **{k: val for k, val in read.items() if k != "columns"},
               "columns": cols.names(), "figures": figures, "style": style,
               "setup": setup_to_dict(initial)}
    options = json.loads(json.dumps(options, default=str))
    digest = _options_hash(options)
    _check_folder(out, digest, options, force)
    manifest = {"format": FORMAT, "options_hash": digest, "options": options,
                "recordings": [{"recording": p.stem, "path": str(p.resolve())}
                               for p in recordings]}
    opened: list[bool] = []

    def open_folder() -> None:  # on the first result: a scheduler that fails writes nothing
        if not opened:
            out.mkdir(parents=True, exist_ok=True)
            write_files({out / "manifest.json": json_text(manifest)})
            opened.append(True)

    rows: dict[str, dict[str, Any]] = {}
    stamps = {p.stem: _stamp(p) for p in recordings}
    for p in recordings:
        done = _complete(out / p.stem, digest, stamps[p.stem], figures)
        if done is not None:
            rows[p.stem] = _json_row(done)
    skipped = tuple(sorted(rows))
    todo = [p for p in recordings if p.stem not in rows]
    logger.info("batch: %d recordings, %d complete, %d to calibrate", len(recordings),
                len(skipped), len(todo))
    paths = {p.stem: p for p in recordings}
    for p in todo:  # a recording's folder is replaced as its fit arrives: nothing foreign in it
        check_own(out / p.stem, RECORDING_FILES)

    def publish(result: TaskResult) -> None:
        open_folder()
        name = result.key
        value = result.value or {}
        row = _row(name, paths[name], value.get("row", {}), result.error, result)
        doc = {**row, "options_hash": digest, "source": stamps[name]}
        with staged_directory(out / name, force=True, names=RECORDING_FILES) as tmp:
            for fname, data in value.get("files", {}).items():
                (tmp / fname).write_bytes(data)
            (tmp / ROW_FILE).write_text(json_text(doc), encoding="utf-8")
        rows[name] = _json_row(json.loads(json_text(doc)))

    tasks = [(p.stem, {"path": str(p), "setup": initial, "calibrate": cal, "read": read,
                       "figures": figures, "style": style}) for p in todo]
    if len(tasks) > 1 and workers != 1 and resolve_scheduler(scheduler) is None:
        _warm_kernels()  # forked workers inherit the loaded kernels (execution.start_method)
    run_tasks(calibrate_recording, tasks, workers=workers, scheduler=scheduler,
              progress=progress, timeout=timeout, on_result=publish, label="calibrating")
    open_folder()
    ordered = [rows[p.stem] for p in recordings]
    stats, outliers = batch_statistics(ordered)
    csv_text, parquet = tables(ordered)
    result = BatchResult(out=str(out), rows=tuple(ordered),
                         computed=tuple(p.stem for p in todo), skipped=skipped,
                         statistics=stats, outliers=outliers, parquet=parquet is not None,
                         elapsed=time.perf_counter() - t0)
    files: dict[Path, str | bytes] = {out / "results.csv": csv_text,
                                      out / "summary.md": summary_markdown(result, {
                                          k: val for k, val in options.items() if k != "setup"})}
    if parquet is not None:
        files[out / "results.parquet"] = parquet
    else:
        (out / "results.parquet").unlink(missing_ok=True)
        logger.warning("results.parquet not written: Parquet needs pyarrow "
                       "(pip install 'magcilia[cluster]'); results.csv holds the same table")
    write_files(files)
    return result


__all__ = ["BATCH_FILES", "COLUMNS", "FORMAT", "OUTLIER_SIGMAS", "OUTLIER_Z", "RECORDING_FILES",
           "ROW_FILE", "SUMMARISED", "TEXT_COLUMNS", "UNITS", "BatchResult", "batch_statistics",
           "calibrate_batch", "calibrate_recording", "robust_z", "summary_lines"]
