"""Read-out results for people: the table of estimates that ``magcilia readout`` writes and its
summary, in one unit system: the quantity's display unit (deg, mN, m/s) or SI (rad, N, m/s).

The CSV is built from whole columns (:mod:`magcilia.report.csvtext`): ``time_s`` and
``voltage_V`` as read (the shortest text that reads back as the same number), the estimate to 10
significant digits and its 1-σ to 4, the flag bits and their names. Rows without an estimate
(:data:`~magcilia.readout.inverse.NO_ESTIMATE`) have empty estimate and 1-σ fields.
"""

from __future__ import annotations

import os
from collections.abc import Callable
from typing import Any

import numpy as np
from numpy.typing import NDArray

from magcilia._atomic import atomic_open
from magcilia.device.parameters import MEASURANDS
from magcilia.readout import Readout, ReadoutResult
from magcilia.readout.inverse import summary_line
from magcilia.readout.protocol import flag_names as _flag_names
from magcilia.report import csvrows, csvtext

#: rows of the CSV formatted at a time (their text stays small)
ROWS = 65536


def flag_names(flags: int) -> str:
    """The names of a reading's flags, ``|``-separated (empty for a good reading)."""
    return "|".join(name.lower() for name in _flag_names(flags))


def units(quantity: str, si: bool = False) -> tuple[str, float]:
    """The unit of a quantity's values in a read-out's outputs and its SI value: the display
    unit (``("mN", 1e-3)``), or with ``si`` the SI unit (``("N", 1.0)``)."""
    q = MEASURANDS[quantity]
    return (q.unit, 1.0) if si else (q.display, q.display_factor)


def column_name(quantity: str, si: bool = False) -> str:
    """The CSV column of a quantity's estimates: ``force_mN``, ``angle_deg``, ``flow_m_per_s``
    (with ``si``: ``force_N``, ``angle_rad``)."""
    unit = units(quantity, si)[0]
    return f"{quantity}_{unit.replace('/', '_per_')}"


def readout_header(quantity: str, times: bool, si: bool = False) -> str:
    """The CSV's first line (with its newline)."""
    col = column_name(quantity, si)
    return ",".join([*(["time_s"] if times else []), "voltage_V", col, f"sigma_{col}", "flags",
                     "flag_names"]) + "\n"


def readout_rows(result: ReadoutResult, volts: NDArray[np.float64],
                 times: NDArray[np.float64] | None = None, si: bool = False,
                 rows: slice | NDArray[np.intp] = slice(None)) -> bytes:
    """The CSV lines (ASCII, no header) of the readings ``rows`` of a result: [time_s,]
    voltage_V, the estimate (10 significant digits) and its 1-σ (4) in the display unit (SI with
    ``si``), empty without an estimate, the flag bits and their names."""
    factor = units(result.quantity, si)[1]
    value = np.asarray(result.value).reshape(-1)[rows]
    sigma = np.asarray(result.sigma).reshape(-1)[rows]
    flags = np.asarray(result.flags).reshape(-1)[rows]
    if factor != 1.0:
        value = value / factor
        sigma = sigma / factor
    seen, code = np.unique(flags, return_inverse=True)  # a few distinct flag values
    columns = [csvtext.shortest(np.asarray(volts).reshape(-1)[rows]),
               csvtext.significant(value, 10), csvtext.significant(sigma, 4),
               csvtext.table(code, [str(int(f)) for f in seen]),
               csvtext.table(code, [flag_names(int(f)) for f in seen])]
    if times is not None:
        columns.insert(0, csvtext.shortest(np.asarray(times).reshape(-1)[rows]))
    return csvtext.rows(columns)


def readout_csv(result: ReadoutResult, volts: NDArray[np.float64],
                times: NDArray[np.float64] | None = None, si: bool = False) -> str:
    """CSV text, one row per reading: [time_s,] voltage_V, the estimate and its 1-σ in the
    display unit (SI with ``si``; empty where there is no estimate), the flag bits and their
    names."""
    return readout_header(result.quantity, times is not None, si) + readout_rows(
        result, volts, times, si).decode("ascii")


def write_readout_csv(path: str | os.PathLike[str], result: ReadoutResult,
                      volts: NDArray[np.float64], times: NDArray[np.float64] | None = None,
                      si: bool = False, progress: Callable[[int], object] | None = None) -> None:
    """Write :func:`readout_csv` to ``path`` atomically, :data:`ROWS` rows at a time;
    ``progress(rows)`` is called after each part with the rows written by it. The rows come
    from the compiled pass of :mod:`magcilia.report.csvrows` (the same bytes), from
    :func:`readout_rows` where numba is missing."""
    n = int(np.size(result.flags))

    def flat(a: NDArray[np.float64]) -> NDArray[np.float64]:
        return np.ascontiguousarray(a, dtype=np.float64).reshape(-1)

    fast = csvrows.readout_rows(
        None if times is None else flat(times), flat(volts), flat(result.value),
        flat(result.sigma), units(result.quantity, si)[1],
        np.ascontiguousarray(result.flags).reshape(-1), flag_names,
        lambda rows: readout_rows(result, volts, times, si, rows))
    with atomic_open(path, "wb") as f:
        f.write(readout_header(result.quantity, times is not None, si).encode("ascii"))
        for start in range(0, n, ROWS):
            part = slice(start, min(start + ROWS, n))
            f.write(readout_rows(result, volts, times, si, part) if fast is None else
                    fast(part.start, part.stop))
            if progress is not None:
                progress(part.stop - part.start)


def readout_summary(readout: Readout, result: ReadoutResult, si: bool = False) -> dict[str, Any]:
    """What ``magcilia readout --json`` prints: the read-out and the counts, every dimensional
    value with its unit in the key, in the display unit (SI with ``si``); voltages in mV
    (V with ``si``)."""
    unit, factor = units(readout.quantity, si)
    vunit, vfactor = ("V", 1.0) if si else ("mV", 1e-3)
    token = unit.replace("/", "_per_")
    good = result.estimated
    counts = result.counts()
    values = result.value[good] / factor
    doc: dict[str, Any] = {
        "quantity": readout.quantity, "unit": unit, "units": "SI" if si else "display",
        f"span_{token}": [x / factor for x in readout.span],
        f"fold_{token}": None if readout.fold is None else readout.fold / factor,
        f"output_range_{vunit}": [x / vfactor for x in readout.output_range],
        f"table_error_{token}": readout.table_error / factor,
        "table_size": int(readout.table_quantity.size),
        "edge": readout.edge,
        f"edge_tolerance_{token}": [x / factor for x in readout.edge_tolerance],
        f"edge_reach_{token}": [x / factor for x in readout.edge_reach],
        f"edge_error_{token}": readout.edge_error / factor,
        **counts,
        f"range_{token}": [float(values.min()), float(values.max())] if values.size else None,
        f"median_sigma_{token}": (float(np.median(result.sigma[good])) / factor if values.size
                                  else None),
        f"median_sigma_noise_{token}": (float(np.median(result.sigma_noise[good])) / factor
                                        if values.size else None),
        "scale_note": result.scale_note,
        "tare": None,
    }
    if readout.baseline is not None:
        b = readout.baseline
        doc["tare"] = {"readings": b.count, f"mean_{vunit}": b.mean / vfactor,
                       f"correction_{vunit}": b.correction / vfactor,
                       f"standard_error_{vunit}": b.standard_error / vfactor,
                       f"noise_{vunit}": b.noise / vfactor}
    return doc


def readout_line(readout: Readout, result: ReadoutResult, si: bool = False) -> str:
    """The summary line of ``magcilia readout``, in the units of its CSV."""
    unit, factor = units(readout.quantity, si)
    text = (f"{summary_line(result, unit, factor)}; table error ≤ "
            f"{readout.table_error / factor:.2g} {unit}")
    if readout.baseline is not None:
        b = readout.baseline
        volt = ("V", 1.0) if si else ("mV", 1e-3)
        text += (f"; tared on {b.count} readings (zero {b.mean / volt[1]:.6g} {volt[0]} ± "
                 f"{b.standard_error / volt[1]:.2g} {volt[0]})")
    return text
