"""Read-out results for people: the table of estimates that ``magcilia readout`` writes, in the
quantity's display unit (deg, mN, m/s)."""

from __future__ import annotations

import csv
import io
import math

import numpy as np
from numpy.typing import NDArray

from magcilia.device.parameters import MEASURANDS
from magcilia.readout import ReadoutFlag, ReadoutResult


def flag_names(flags: int) -> str:
    """The names of a reading's flags, ``|``-separated (empty for a good reading)."""
    return "|".join(str(f.name).lower() for f in ReadoutFlag if f and flags & f)


def readout_csv(result: ReadoutResult, volts: NDArray[np.float64],
                times: NDArray[np.float64] | None = None) -> str:
    """CSV text, one row per reading: [time_s,] voltage_V, the estimate and its 1-σ in the
    display unit (empty where flagged), the flag bits and their names."""
    q = MEASURANDS[result.quantity]
    col = f"{result.quantity}_{q.display.replace('/', '_per_')}"
    buf = io.StringIO()
    writer = csv.writer(buf, lineterminator="\n")
    writer.writerow([*(["time_s"] if times is not None else []), "voltage_V", col,
                     f"sigma_{col}", "flags", "flag_names"])
    for i, volt in enumerate(volts):
        flag = int(result.flags[i])
        value = result.value[i]
        writer.writerow([
            *([repr(float(times[i]))] if times is not None else []), repr(float(volt)),
            "" if math.isnan(value) else f"{q.to_display(value):.10g}",
            "" if math.isnan(value) else f"{q.to_display(result.sigma[i]):.4g}", flag,
            flag_names(flag),
        ])
    return buf.getvalue()
