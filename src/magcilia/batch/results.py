"""What a batch calibration gives: :class:`BatchResult`, its table (:data:`COLUMNS`, SI), the
spread of the fitted values over the recordings and their outliers (:func:`batch_statistics`),
and the summary (:func:`summary_lines`); see :mod:`magcilia.batch.calibration` for the batch."""

from __future__ import annotations

import io
import json
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from magcilia._display import Display, Item, Table, count, dataframe, rows_table
from magcilia.calibration.problem import PARAMETERS
from magcilia.device.parameters import PARAMETERS as REGISTRY

#: the fitted values summarised over the batch (median, IQR, range; outliers)
SUMMARISED = ("height", "base_radius", "x", "y", "z")
#: modified z-score above which a value is an outlier (Iglewicz and Hoaglin)
OUTLIER_Z = 3.5
#: … and its distance from the median, in its own standard errors, above which the recording's
#: data say it differs
OUTLIER_SIGMAS = 3.0
#: the table's columns, SI (:data:`UNITS`): lengths and their standard errors (``*_stderr``;
#: NaN where held or undetermined) m, cost V², rms and offset V, seconds s
COLUMNS = ("recording", "error", "cost", "rms", *PARAMETERS, "offset", "magnetization_scale",
           *(f"{n}_stderr" for n in SUMMARISED), "offset_stderr", "warnings", "warning_text",
           "flagged", "notes", "attempts", "seconds", "worker", "path")
#: the table's text columns (the rest are numbers: NaN where missing)
TEXT_COLUMNS = ("recording", "error", "warning_text", "notes", "worker", "path")
#: the unit of each numeric column of the table (``COLUMNS``; the rest are text or counts)
UNITS: dict[str, str] = {
    "cost": "V^2", "rms": "V", "offset": "V", "offset_stderr": "V", "magnetization_scale": "1",
    "seconds": "s",
    **{n: REGISTRY[n].unit or "1" for n in PARAMETERS},
    **{f"{n}_stderr": REGISTRY[n].unit or "1" for n in SUMMARISED},
}


@dataclass(frozen=True, eq=False, repr=False)
class BatchResult(Display):
    """What a batch calibration gave (immutable).

    Attributes
    ----------
    out : str
        The batch folder.
    rows : tuple of dict
        One row per recording, in name order, keys :data:`COLUMNS` (SI; ``error`` empty on
        success, NaN values when it failed).
    computed : tuple of str
        Recordings calibrated by this run (the others were complete from an earlier run).
    skipped : tuple of str
        Recordings whose complete results an earlier run left.
    statistics : dict of str to dict
        Per value of :data:`SUMMARISED` (and ``cost``): ``n``, ``median``, ``iqr``, ``min``,
        ``max`` (SI) over the recordings that succeeded.
    outliers : tuple of dict
        ``recording``, ``parameter``, ``value`` (SI) and ``z`` (modified z-score, |z| > 3.5).
    parquet : bool
        Whether ``results.parquet`` was written (pyarrow available).
    elapsed : float
        Wall time of this run, s.
    """

    out: str
    rows: tuple[dict[str, Any], ...]
    computed: tuple[str, ...]
    skipped: tuple[str, ...]
    statistics: dict[str, dict[str, float]]
    outliers: tuple[dict[str, Any], ...]
    parquet: bool
    elapsed: float

    @property
    def failed(self) -> tuple[str, ...]:
        """Recordings whose calibration failed (their ``error``)."""
        return tuple(r["recording"] for r in self.rows if r["error"])

    def table(self) -> list[dict[str, Any]]:
        """The rows (SI), as in ``results.csv``."""
        return [dict(r) for r in self.rows]

    def to_dataframe(self) -> Any:
        """The table as a ``pandas.DataFrame`` (columns :data:`COLUMNS`, SI)."""
        return dataframe({c: [r[c] for r in self.rows] for c in COLUMNS})

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready content (SI; ``units`` names each numeric column's unit)."""
        return {"units": "SI", "column_units": dict(UNITS), "out": self.out,
                "rows": self.table(), "computed": list(self.computed),
                "skipped": list(self.skipped), "failed": list(self.failed),
                "statistics": self.statistics, "outliers": [dict(o) for o in self.outliers],
                "parquet": self.parquet, "elapsed_s": self.elapsed}

    def report(self, si: bool = False) -> str:
        """The summary as text: counts, the spread of the fitted values (mm, or SI with
        ``si``) and the outliers."""
        return "\n".join(summary_lines(self, si))

    def _display_items(self) -> list[Item]:
        return [("recordings", str(len(self.rows))), ("computed", str(len(self.computed))),
                ("skipped", str(len(self.skipped))), ("failed", str(len(self.failed))),
                ("outliers", str(len(self.outliers))), ("folder", self.out)]

    def _display_table(self) -> Table | None:
        return rows_table([{k: r[k] for k in ("recording", "cost", *SUMMARISED, "error")}
                           for r in self.rows], 4)


def robust_z(values: ArrayLike) -> NDArray[np.float64]:
    """The modified z-score ``0.6745 (v − median) / MAD`` of each value (Iglewicz and Hoaglin);
    zeros when the MAD is 0 (more than half the values equal)."""
    x = np.asarray(values, dtype=np.float64)
    med = np.median(x)
    mad = np.median(np.abs(x - med))
    if not mad > 0:
        return np.zeros_like(x)
    return np.asarray(0.6745 * (x - med) / mad, dtype=np.float64)


def batch_statistics(rows: Sequence[Mapping[str, Any]]
                     ) -> tuple[dict[str, dict[str, float]], tuple[dict[str, Any], ...]]:
    """The spread (n, median, IQR, min, max; SI) of :data:`SUMMARISED` and the cost over the
    rows that succeeded, and their outliers (|modified z| > :data:`OUTLIER_Z`, the cost's high
    side only), by recording.

    A parameter's outliers are sought among the rows whose data determine it (``<name>_stderr``
    finite; a row without that column counts as determined), with the median and MAD of those
    rows, and a flagged value must also lie more than :data:`OUTLIER_SIGMAS` of its standard
    errors from that median. Each statistic carries ``"determined"``, the count of those rows;
    ``"checked"`` is 1.0 when the outlier test ran on it (at least 3 determined rows), else 0.0.
    """
    ok = [r for r in rows if not r["error"]]
    stats: dict[str, dict[str, float]] = {}
    outliers: list[dict[str, Any]] = []
    for name in (*SUMMARISED, "cost"):
        x = np.array([float(r[name]) for r in ok], dtype=np.float64)
        if x.size == 0:
            continue
        se = np.array([float(r.get(f"{name}_stderr", 0.0)) for r in ok], dtype=np.float64)
        determined = np.isfinite(se)
        q25, q50, q75 = np.percentile(x, [25.0, 50.0, 75.0])
        checked = int(determined.sum()) >= 3
        stats[name] = {"n": int(x.size), "median": float(q50), "iqr": float(q75 - q25),
                       "min": float(x.min()), "max": float(x.max()),
                       "determined": int(determined.sum()), "checked": float(checked)}
        if not checked:
            continue
        z = np.zeros_like(x)
        z[determined] = robust_z(x[determined])
        centre = float(np.median(x[determined]))
        if name == "cost":
            flagged = determined & (z > OUTLIER_Z)
        else:
            flagged = (determined & (np.abs(z) > OUTLIER_Z)
                       & (np.abs(x - centre) > OUTLIER_SIGMAS * se))
        outliers += [{"recording": ok[i]["recording"], "parameter": name, "value": float(x[i]),
                      "z": float(z[i])} for i in np.flatnonzero(flagged)]
    outliers.sort(key=lambda o: (o["recording"], o["parameter"]))
    return stats, tuple(outliers)


def summary_lines(result: BatchResult, si: bool = False) -> list[str]:
    """The batch summary as lines of text (lengths in mm, SI with ``si``)."""
    failed = result.failed
    lines = [(f"{count(len(result.rows), 'recording')}: {len(result.rows) - len(failed)} "
             f"calibrated, {len(failed)} failed; {len(result.computed)} computed now, "
             f"{len(result.skipped)} complete from an earlier run")]
    if result.statistics:
        lines += ["", (f"{'value':<12} {'unit':>4} {'n':>5} {'median':>11} {'IQR':>11} "
                      f"{'min':>11} {'max':>11}")]
    for name, s in result.statistics.items():
        unit, factor = ("V^2", 1.0) if name == "cost" else (("m", 1.0) if si else ("mm", 1e3))
        lines.append(f"{name:<12} {unit:>4} {s['n']:5d} " + " ".join(
            f"{s[k] * factor:11.5g}" for k in ("median", "iqr", "min", "max")))
    checked = [n for n, st in result.statistics.items() if st.get("checked", 1.0)]
    skipped = [f"{n} ({int(st['n'] - st['determined'])} of {int(st['n'])} undetermined or held)"
               for n, st in result.statistics.items() if not st.get("checked", 1.0)]
    if result.statistics:
        lines += ["", "outlier check on the values the data determine: "
                  + (", ".join(checked) or "none")
                  + ("; not checked (undetermined in too many recordings, e.g. the size by the "
                     "scale symmetry: their spread says nothing about the chips): "
                     + ", ".join(skipped) if skipped else "")]
    if result.outliers:
        lines += ["", (f"outliers (modified z-score |z| > {OUTLIER_Z:g}, Iglewicz-Hoaglin: "
                      "0.6745 (value - median) / MAD, over the recordings that determine the "
                      f"value, and more than {OUTLIER_SIGMAS:g} of its standard errors from the "
                      "median):")]
        for o in result.outliers:
            unit, factor = ("V^2", 1.0) if o["parameter"] == "cost" else (
                ("m", 1.0) if si else ("mm", 1e3))
            lines.append(f"  {o['recording']}: {o['parameter']} = {o['value'] * factor:.5g} "
                         f"{unit} (z = {o['z']:.2f})")
    elif result.statistics:
        lines += ["", f"no outliers (modified z-score |z| > {OUTLIER_Z:g})"]
    for r in result.rows:
        if r["notes"]:
            lines.append(f"note: {r['recording']}: {r['notes']}")
    for r in result.rows:
        if r["error"]:
            lines.append(f"failed: {r['recording']}: {r['error']}")
    return lines


def summary_markdown(result: BatchResult, options: Mapping[str, Any]) -> str:
    shown = {("seed" if k == "rng" else k): val for k, val in options.items()
             if k not in ("setup", "columns") and val not in (None, {}, [])}
    lines = ["# magcilia batch calibration", "",
             "Options (SI; the initial setup and the column names in manifest.json): "
             + ", ".join(f"{k} `{json.dumps(val, sort_keys=True)}`" for k, val in shown.items())
             + ".", "",
             ("The table (results.csv, results.parquet) holds one row per recording in SI units: "
             "height, base_radius, x, y, z and their standard errors (`*_stderr`) in m, cost in "
             "V^2, rms and offset in V, seconds in s; `error` is empty when the calibration "
             "succeeded. Below, lengths in mm."), "", "```",
             *summary_lines(result), "```", ""]
    return "\n".join(lines)


def tables(rows: list[dict[str, Any]]) -> tuple[str, bytes | None]:
    """results.csv text and results.parquet bytes (None without pyarrow)."""
    import pandas as pd

    frame = pd.DataFrame({c: [r[c] for r in rows] for c in COLUMNS}, columns=list(COLUMNS))
    csv_text = frame.to_csv(index=False, float_format="%.17g", lineterminator="\n")
    try:
        import pyarrow as pa
        import pyarrow.parquet as pq
    except ImportError:
        return csv_text, None
    table = pa.Table.from_pandas(frame, preserve_index=False)
    fields = [f.with_metadata({"unit": UNITS[f.name]}) if f.name in UNITS else f
              for f in table.schema]
    table = table.cast(pa.schema(fields, metadata={**(table.schema.metadata or {}),
                                                   b"magcilia.units": b"SI"}))
    buf = io.BytesIO()
    pq.write_table(table, buf)
    return csv_text, buf.getvalue()
