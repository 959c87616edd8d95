"""The commands' temperature: ``record --temperature`` and ``live --temperature`` (the simulated
source's; one option) and the compensation of ``magcilia readout`` where the recording has a
temperature column (:class:`magcilia.ThermalReadout`)."""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

import click
import numpy as np

from magcilia._errors import MagciliaError
from magcilia._validate import fail

if TYPE_CHECKING:
    from magcilia.device.temperature import TemperatureModel, TemperatureProfile
    from magcilia.readout.inverse import Readout
    from magcilia.readout.result import ReadoutResult
    from magcilia.readout.thermal import ThermalReadout

#: the recordings' temperature column (K; the readers turn temperature_degC into it)
COLUMN = "temperature_K"
#: what ``--temperature`` takes
TEMPERATURE_HELP = ("sim: the temperature, K or with a unit (293K, 20degC), or a ramp START:END "
                    "over --duration (293K:313K); recorded as temperature_K, the simulated "
                    "output following the setup's [temperature] coefficients (live: read "
                    "compensated, flagged TEMPERATURE OUTSIDE beyond its calibrated_range and "
                    "the tare's).")


def temperature_option(command: Any) -> Any:
    """``--temperature`` (:data:`TEMPERATURE_HELP`): ``record``'s and ``live``'s one option."""
    return click.option("--temperature", default=None, metavar="T|START:END",
                        help=TEMPERATURE_HELP)(command)


def temperature_profile(text: str | None, duration: float | None) -> TemperatureProfile | None:
    """``--temperature``: a constant (``293K``, ``20degC``; a bare number is K) or a ramp
    ``START:END`` over ``duration`` s (None: no temperature)."""
    from magcilia.device.temperature import TemperatureProfile
    from magcilia.units import parse_temperature

    if text is None:
        return None
    start, colon, end = text.partition(":")
    if not colon:
        return TemperatureProfile.constant(parse_temperature(text.strip(), "--temperature", "K"))
    if duration is None:
        raise fail("--temperature", text, "a constant temperature (293K), or a ramp START:END "
                                          "with --duration (the ramp spans the recording)")
    return TemperatureProfile.ramp(parse_temperature(start.strip(), "--temperature", "K"),
                                   parse_temperature(end.strip(), "--temperature", "K"), duration)


def setup_temperature(setup_arg: str) -> TemperatureModel:
    """The setup file's ``[temperature]`` coefficients, else the defaults (a preset's)."""
    from magcilia.cli._options import is_preset_name
    from magcilia.device.temperature import TemperatureModel
    from magcilia.io.temperature_table import load_temperature

    model = None if is_preset_name(setup_arg) else load_temperature(setup_arg)
    return TemperatureModel() if model is None else model


def tare_temperatures(count: int, temps: np.ndarray | None, tare_file_temps: np.ndarray | None,
                      from_file: bool) -> np.ndarray:
    """The temperatures of the tare's readings: the recording's first ``count`` (``--tare``) or
    the tare file's (``--tare-file``), which must then have a temperature column too."""
    if from_file:
        if tare_file_temps is None:
            raise MagciliaError("--tare-file has no temperature_K or temperature_degC column; "
                                "the recording has one: record the tare with its temperature, "
                                "or tare on the recording's first readings (--tare)")
        return tare_file_temps
    assert temps is not None
    return temps[:count]


def compensated(readout: Readout, setup_arg: str, volts: np.ndarray, temps: np.ndarray,
                baseline: np.ndarray | None, baseline_temps: np.ndarray | None,
                band: tuple[float, float]) -> tuple[ReadoutResult, ThermalReadout, list[str],
                                                     dict[str, Any]]:
    """``magcilia readout`` of a recording with a temperature column: the compensated
    estimates (as a ReadoutResult for the CSV writer), the read-out, note lines and the JSON
    summary's ``temperature`` entry. ``readout`` is untared; ``baseline`` (V) with
    ``baseline_temps`` (K) the tare's readings, if any."""
    from magcilia.readout.thermal import ThermalReadout

    thermal = ThermalReadout(readout, setup_temperature(setup_arg))
    if baseline is not None:
        assert baseline_temps is not None
        thermal = thermal.tare(np.column_stack([baseline, baseline_temps]))
    result = thermal.read_at(volts, temps, bandwidth=band)
    notes = []
    note = thermal.outside_note(temps) if np.isfinite(temps).any() else ""
    if note:
        notes.append(f"note: {note}")
    good = np.isfinite(result.value)
    doc = {"reference_K": thermal.model.reference,
           "calibrated_range_K": list(thermal.calibrated_range),
           "range_K": [float(np.nanmin(temps)), float(np.nanmax(temps))]
           if np.isfinite(temps).any() else None,
           "outside_calibrated_range": result.outside,
           "median_sigma_temperature_SI": (float(np.median(result.sigma_temperature[good]))
                                           if good.any() else None),
           "model": thermal.model.to_dict()}
    return result.as_readout_result(), thermal, notes, doc
