"""What a live read-out writes into its recording besides the raw samples: the ``readout`` group's
columns for every kind of read-out, and the default file names.

A single-axis read-out's ``readout`` group holds ``readout_time_s``, ``raw_V``, ``value``,
``sigma``, ``flags``, ``correction_V`` and ``noise_V`` (one value per reading; the correction each
value was read with, and the noise of one reading σ used, the zero's σ included). A read-out of
several field channels holds ``readout_time_s``, then per channel ``raw_T[NAME]``,
``correction_T[NAME]`` and ``noise_T[NAME]`` (the window means, the tare + tracking correction
and the noise σ used, T), and per estimate ``value_x``,
``value_y``, ``sigma_x``, ``sigma_y`` (N) and ``flags`` — for an array one set per cilium,
``value_x[CILIUM]`` … ``flags[CILIUM]`` in the array's order. TDMS channels are one-dimensional:
the brackets name the column of a per-sample array.
"""

from __future__ import annotations

import datetime as dt
import math
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

F64 = NDArray[np.float64]


def new_recording_path(directory: Path) -> Path:
    """``live-YYYYmmdd-HHMMSS.tdms`` in ``directory``, made unique with ``-2``, ``-3`` …, and
    reserved: created empty at once (exclusively), so that no other recording takes the name."""
    directory.mkdir(parents=True, exist_ok=True)
    base = directory / f"live-{dt.datetime.now().strftime('%Y%m%d-%H%M%S')}"
    path, k = base.with_suffix(".tdms"), 2
    while True:
        try:
            path.open("xb").close()
        except FileExistsError:
            path, k = Path(f"{base}-{k}.tdms"), k + 1
        else:
            return path


def sample_columns(inputs: tuple[str, ...], raw: F64) -> dict[str, F64]:
    """The raw samples (n, c) of several channels as recording channels named by ``inputs``."""
    return {name: np.ascontiguousarray(raw[:, k]) for k, name in enumerate(inputs)}


def readout_group(out: dict[str, Any], *, unit: str, channel_unit: str, inputs: tuple[str, ...],
                  names: tuple[str, ...], noise: Any = math.nan
                  ) -> tuple[dict[str, F64], dict[str, str]]:
    """The ``readout`` group's columns and units of output samples ``out`` (the History's
    columns, :data:`~magcilia.live.history.COLUMNS`) — see the module docstring.

    Parameters
    ----------
    out : dict
        ``time`` (m,), ``raw`` and ``correction`` (m,) or (m, c), ``value`` and ``sigma`` (m,),
        (m, 2) or (m, C, 2), ``flags`` (m,) or (m, C).
    unit : str
        SI unit of the values.
    channel_unit : str
        Unit of the channels (``"V"`` or ``"T"``).
    inputs, names : tuple of str
        The channels, and the cilia of an array.
    noise : float or array-like, shape (c,)
        The noise RMS of one reading that σ used for these samples, per channel.
    """
    value = np.asarray(out["value"])
    m = value.shape[0]
    noise = np.broadcast_to(np.asarray(noise, dtype=np.float64).reshape(-1), (len(inputs),))
    if value.ndim == 1:
        return ({"readout_time_s": out["time"], f"raw_{channel_unit}": out["raw"],
                 "value": value, "sigma": out["sigma"], "flags": out["flags"],
                 f"correction_{channel_unit}": out["correction"],
                 f"noise_{channel_unit}": np.full(m, noise[0])},
                {"readout_time_s": "s", f"raw_{channel_unit}": channel_unit, "value": unit,
                 "sigma": unit, f"correction_{channel_unit}": channel_unit,
                 f"noise_{channel_unit}": channel_unit})
    cols: dict[str, F64] = {"readout_time_s": out["time"]}
    units = {"readout_time_s": "s"}
    raw, corr = np.asarray(out["raw"]), np.asarray(out["correction"])
    for k, name in enumerate(inputs):
        cols[f"raw_{channel_unit}[{name}]"] = raw[:, k]
        units[f"raw_{channel_unit}[{name}]"] = channel_unit
    per = [""] if value.ndim == 2 else [f"[{n}]" for n in names]
    value = value.reshape(value.shape[0], -1, 2)
    sigma = np.asarray(out["sigma"]).reshape(value.shape)
    flags = np.asarray(out["flags"]).reshape(value.shape[0], -1)
    for c, tag in enumerate(per):
        for a, axis in enumerate("xy"):
            cols[f"value_{axis}{tag}"] = value[:, c, a]
            cols[f"sigma_{axis}{tag}"] = sigma[:, c, a]
            units[f"value_{axis}{tag}"] = units[f"sigma_{axis}{tag}"] = unit
        cols[f"flags{tag}"] = flags[:, c].astype(np.float64)
    for k, name in enumerate(inputs):
        cols[f"correction_{channel_unit}[{name}]"] = corr[:, k]
        cols[f"noise_{channel_unit}[{name}]"] = np.full(m, noise[k])
        units[f"correction_{channel_unit}[{name}]"] = units[f"noise_{channel_unit}[{name}]"] = \
            channel_unit
    return cols, units
