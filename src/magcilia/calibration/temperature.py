"""The temperatures a calibration saw: the range and the mean over the samples fitted, where the
recordings carry a temperature column (``temperature_K`` or ``temperature_degC``).

The readers keep them per recording (:attr:`magcilia.Measurement.temperature_range`, over the
samples the reduction used: those dropped as non-finite, saturated or suspect do not count);
:func:`with_temperature` joins them over the recordings fitted into the
:class:`~magcilia.calibration.result.CalibrationResult` (``temperature_range``,
``temperature_mean``). ``magcilia calibrate`` writes them into ``fitted_setup.toml``'s
``[temperature]`` table (:func:`magcilia.io.temperature_table.fitted_temperature_table`:
``calibrated_range``, and ``reference`` the mean, the temperature the fitted parameters are at),
so that ``readout`` and ``live`` compensate about it and flag readings outside the range
(``TEMPERATURE_OUTSIDE``) without the user typing it.

Recordings without a temperature leave both unset (None, NaN): the setup's ``[temperature]``
table is then written as it was given, and a compensated read-out's calibrated range is the
table's ``calibrated_range`` if it names one, else the reference temperature alone, widened by
the tare's temperatures (:class:`magcilia.ThermalReadout`).
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import replace
from typing import Any, Protocol, TypeVar

from magcilia.io.measurement import Measurement


class Temperatures(Protocol):
    """What a calibration result holds of its temperatures (see the module docstring)."""

    @property
    def temperature_range(self) -> tuple[float, float] | None: ...

    @property
    def temperature_mean(self) -> float: ...


R = TypeVar("R", bound=Temperatures)


def calibration_temperature(data: Measurement | Sequence[Measurement]
                            ) -> tuple[float, float, float] | None:
    """(lowest, highest, mean) temperature, K, of the samples of ``data`` (one measurement or
    several: the mean weighted by their samples), or None where none carries a temperature."""
    items = [data] if isinstance(data, Measurement) else list(data)
    seen = [m.metadata["temperature_K"] for m in items
            if isinstance(m, Measurement) and m.metadata.get("temperature_K")]
    if not seen:
        return None
    counts = [float(t.get("samples", 1)) for t in seen]
    mean = sum(float(t["mean"]) * n for t, n in zip(seen, counts, strict=True)) / sum(counts)
    return (min(float(t["min"]) for t in seen), max(float(t["max"]) for t in seen), mean)


def with_temperature(result: R, data: Measurement | Sequence[Measurement]) -> R:
    """``result`` with the temperatures of ``data`` (:func:`calibration_temperature`)."""
    seen = calibration_temperature(data)
    if seen is None:
        return result
    fitted: Any = result  # (a frozen dataclass: CalibrationResult)
    out: R = replace(fitted, temperature_range=(seen[0], seen[1]), temperature_mean=seen[2])
    return out


def temperature_doc(result: Temperatures) -> dict[str, float] | None:
    """``result.json``'s ``temperature_K``: ``{"min", "max", "mean"}`` (K), or None."""
    if result.temperature_range is None:
        return None
    lo, hi = result.temperature_range
    return {"min": lo, "max": hi, "mean": result.temperature_mean}


def temperature_fields(doc: Mapping[str, Any] | None) -> dict[str, Any]:
    """The result's temperature fields from :func:`temperature_doc`'s content ({} for None)."""
    if not doc:
        return {}
    mean = doc.get("mean")
    return {"temperature_range": (float(doc["min"]), float(doc["max"])),
            "temperature_mean": math.nan if mean is None else float(mean)}


def temperature_lines(result: Temperatures) -> list[str]:
    """The report's line on the temperatures (none without): ``temperature 293.2–296.8 K
    during calibration``."""
    if result.temperature_range is None:
        return []
    lo, hi = result.temperature_range
    mean = ("" if not math.isfinite(result.temperature_mean)
            else f" (mean {result.temperature_mean:.1f} K)")
    return [f"temperature {lo:.1f}–{hi:.1f} K during calibration{mean}"]


__all__ = ["calibration_temperature", "temperature_doc", "temperature_fields",
           "temperature_lines", "with_temperature"]
