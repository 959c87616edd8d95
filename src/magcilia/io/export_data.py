"""What an export writes (:class:`RecordingExport`), the units of the readers' columns and
MATLAB's names: shared by :mod:`magcilia.io.export_recording` and its writers
(:mod:`magcilia.io.export_formats`)."""

from __future__ import annotations

import json
import re
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import NDArray

from magcilia._display import Display, Item, Table
from magcilia.io.columns import KEY_ROLE, ROLES

F64 = NDArray[np.float64]
#: the unit of a dimensionless channel (``setreset``), as CF conventions spell it
DIMENSIONLESS = "1"
_MATLAB_NAME = re.compile(r"^[A-Za-z][A-Za-z0-9_]{0,62}$")


@dataclass(frozen=True, eq=False, repr=False)
class RecordingExport(Display):
    """What an export writes: a recording's samples, its further tables and its metadata.

    Attributes
    ----------
    source : str
        The recording file read.
    columns : dict of str to ndarray, each shape (s,)
        The samples by channel name (the readers' names: ``angle_deg``, ``voltage_V``, …, SI as
        the names say).
    units : dict of str to str
        The unit of each channel of ``columns`` (``"1"``: dimensionless; ``""``: not known).
    tables : dict of str to dict of str to ndarray
        Further tables (a TDMS recording's groups other than ``recording``), each by channel,
        each channel shape (m,) (the lengths may differ between tables).
    table_units : dict of str to dict of str to str
        The unit of each further table's channels (``""`` where the file names none).
    metadata : dict
        JSON-ready: ``source``, ``notes`` (list of one-line notes), ``state``
        (:meth:`~magcilia.io.recording_state.RecordingState.to_dict`), ``properties`` (the
        file's stored properties: ``setup`` among them for magcilia's recordings).
    """

    source: str
    columns: dict[str, F64]
    units: dict[str, str]
    tables: dict[str, dict[str, F64]] = field(default_factory=dict)
    table_units: dict[str, dict[str, str]] = field(default_factory=dict)
    metadata: dict[str, Any] = field(default_factory=dict)

    @property
    def samples(self) -> int:
        """Number of samples (rows of ``columns``)."""
        return max((a.size for a in self.columns.values()), default=0)

    @property
    def nbytes(self) -> int:
        """Bytes of numbers the export holds (columns and tables)."""
        return (sum(a.nbytes for a in self.columns.values())
                + sum(a.nbytes for t in self.tables.values() for a in t.values()))

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready summary (not the samples): ``source``, ``samples``, ``units`` (channel →
        unit), ``tables`` (table → channel → unit), ``metadata``."""
        return {"source": self.source, "samples": self.samples, "units": dict(self.units),
                "tables": {k: {c: self.table_units.get(k, {}).get(c, "") for c in t}
                           for k, t in self.tables.items()},
                "metadata": self.metadata}

    def report(self) -> str:
        """One line: samples, channels (with units), further tables."""
        channels = ", ".join(f"{k} [{u}]" if u else k for k, u in self.units.items())
        tables = f"; tables {', '.join(self.tables)}" if self.tables else ""
        return f"{self.samples:,} samples; channels {channels}{tables}"

    def _display_items(self) -> list[Item]:
        return [("samples", f"{self.samples:,}"), ("channels", str(len(self.columns))),
                ("tables", ", ".join(self.tables) or "-"), ("source", self.source)]

    def _display_table(self) -> Table:
        return (("channel", "unit"), [(k, u or "-") for k, u in self.units.items()])

    def setup(self) -> Any:
        """The stored setup (a JSON-ready dict), or None where the file keeps none."""
        return self.metadata.get("properties", {}).get("setup")

    def attributes(self) -> dict[str, str]:
        """The metadata as text attributes (HDF5, NetCDF, MATLAB char arrays): ``source``,
        ``notes`` (one per line), ``state``, ``properties`` and ``setup`` (JSON text; ``setup``
        only where stored), ``exported_by``."""
        from magcilia._version import __version__

        meta = self.metadata
        out = {"source": self.source, "notes": "\n".join(meta.get("notes", [])),
               "state": json.dumps(meta.get("state", {})),
               "properties": json.dumps(meta.get("properties", {})),
               "exported_by": f"magcilia {__version__}"}
        if self.setup() is not None:
            out["setup"] = json.dumps(self.setup())
        if meta.get("renamed"):
            out["renamed"] = json.dumps(meta["renamed"])
        return out


def unit_of(key: str) -> str:
    """The unit of a reader's column (``voltage_V`` → ``"V"``; ``setreset`` → ``"1"``)."""
    role = KEY_ROLE.get(key)
    if role is None:
        return ""
    unit = ROLES[role][2]
    return DIMENSIONLESS if unit is None else unit


def matlab_names(names: list[str] | tuple[str, ...]) -> dict[str, str]:
    """Each name as a MATLAB variable or field name (letters, digits, ``_``, a letter first,
    ≤ 63 characters), distinct: ``c1.x`` → ``c1_x``."""
    out: dict[str, str] = {}
    taken: set[str] = set()
    for name in names:
        new = name if _MATLAB_NAME.match(name) else re.sub(r"\W", "_", name, flags=re.ASCII)
        if not new[:1].isalpha() or not new.isascii():
            new = "x_" + new
        new = new[:63]
        base, k = new, 1
        while new in taken:
            k += 1
            new = f"{base[:60]}_{k}"
        taken.add(new)
        out[name] = new
    return out
