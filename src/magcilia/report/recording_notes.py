"""What the readers say about the recordings a result was made from, for every output of it: the
console (``note:`` lines), ``report.md`` (a "Data" section) and ``result.json`` (a ``data``
list): a recording cut short and the planned angles it lacks, damage a reader read past, and what
the quality checks flagged and what was done with it (:meth:`magcilia.Measurement.notes`,
:mod:`magcilia.io.quality`)."""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

from magcilia.io.measurement import Measurement
from magcilia.io.quality import quality_counts


def data_doc(measurements: Sequence[Measurement]) -> list[dict[str, Any]]:
    """Per recording: its source, notes (one line each), the quality checks' findings
    (:meth:`magcilia.io.quality.RecordingQuality.to_dict`, SI) and, for magcilia's recordings,
    what the file says of itself (complete, planned and missing angles in deg, as in the file)."""
    return [{"source": m.source, "notes": m.notes(), "quality": m.metadata.get("quality"),
             "recording": m.metadata.get("recording")} for m in measurements]


def notes_lines(measurements: Sequence[Measurement]) -> list[str]:
    """The notes as console lines: ``note: SOURCE: text``."""
    return [f"note: {m.source}: {n}" for m in measurements for n in m.notes()]


def data_markdown(measurements: Sequence[Measurement]) -> list[str]:
    """A "Data" section for ``report.md``: per recording, the quality checks' counts and its
    notes (or that there is nothing to say)."""
    lines = ["## Data", ""]
    for m in measurements:
        counts = quality_counts(m.metadata.get("quality"))
        checked = (f"quality checks: {counts['flagged']} samples flagged ("
                   f"{counts['sparse_conditions']} sparse conditions, {counts['outliers']} "
                   f"outliers, {counts['duplicates']} duplicated rows, {counts['garbled']} "
                   "garbled values)" if m.metadata.get("quality") else "quality not checked")
        lines.append(f"- `{m.source}`: {checked}")
        lines += [f"  - note: {n}" for n in m.notes()]
    return [*lines, ""]
