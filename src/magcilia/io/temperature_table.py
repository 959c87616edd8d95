"""A setup file's ``[temperature]`` table ↔ :class:`magcilia.TemperatureModel`.

Every key is optional (the model's defaults, :mod:`magcilia.device.temperature`, cite their
sources); values carry units, a coefficient its 1 σ after ``+-`` (or ``±``; without one it is
taken as exact, σ 0)::

    [temperature]
    reference = "20 degC"                     # or "293.15 K"
    drive = "voltage"                         # or "current" (adds the bridge resistance's tempco)
    sensitivity_tempco = "-3000 ppm/K +- 300 ppm/K"
    bridge_resistance_tempco = "2500 ppm/K +- 400 ppm/K"
    offset_tempco = "0 nT/K +- 112.5 nT/K"    # field-referred: T/K, nT/K, mG/K
    modulus_tempco = "3411 ppm/K +- 3411 ppm/K"
    magnetization_tempco = "-47 ppm/K +- 100 ppm/K"
    temperature_sigma = "0.1 K"               # the thermometer's 1 σ
    calibrated_range = "20 degC:25 degC"      # the temperatures the calibration saw

Relative coefficients take 1/K, ppm/K, %/K (or per °C: the same step); the offset's a field per
kelvin.
"""

from __future__ import annotations

import math
import os
from collections.abc import Mapping
from typing import Any

from magcilia import _validate as v
from magcilia.device.temperature import COEFFICIENTS, DRIVES, TemperatureModel
from magcilia.io.setup_files import _read_document
from magcilia.units import parse_quantity, parse_temperature

#: the setup file's table of temperature coefficients
TEMPERATURE_TABLE = "temperature"
#: the unit dimension of each coefficient (magcilia.units.UNITS)
_DIMENSIONS = {"1/K": "tempco", "T/K": "field_drift"}


def temperature_from_dict(table: object, source: str = "setup") -> TemperatureModel:
    """A ``[temperature]`` table (see the module docstring) as a model (the defaults for the keys
    left out).

    Examples
    --------
    >>> m = temperature_from_dict({"reference": "25 degC",
    ...                            "sensitivity_tempco": "-2700 ppm/K +- 100 ppm/K"})
    >>> m.reference, round(m.sensitivity_tempco * 1e6), round(m.sensitivity_tempco_sigma * 1e6)
    (298.15, -2700, 100)
    """
    source = v.printable(source)
    if not isinstance(table, dict):
        raise v.fail(f"{source}: [temperature]", type(table).__name__,
                     'a table of key = "VALUE UNIT" lines')
    keys = ("reference", "drive", "temperature_sigma", "calibrated_range", *COEFFICIENTS)
    args: dict[str, Any] = {}
    for key, value in table.items():
        where = f"{source}: temperature.{v.printable(str(key))[:40]}"
        if key not in keys:
            raise v.fail(f"{source}: [temperature] key", v.printable(str(key))[:40],
                         "one of " + ", ".join(keys))
        if key == "reference":
            args[key] = parse_temperature(value, where)
        elif key == "drive":
            args[key] = v.choice(where, value, DRIVES)
        elif key == "temperature_sigma":
            args[key] = parse_quantity(value, "temperature", where)
        elif key == "calibrated_range":
            low, colon, high = value.partition(":") if isinstance(value, str) else ("", "", "")
            if not colon:
                raise v.fail(where, value, 'LOW:HIGH with units, e.g. "20 degC:25 degC"')
            args[key] = (parse_temperature(low.strip(), where),
                         parse_temperature(high.strip(), where))
        else:
            dimension = _DIMENSIONS[COEFFICIENTS[key][0]]
            text = value.replace("±", "+-") if isinstance(value, str) else value
            parts = text.split("+-") if isinstance(text, str) else [text]
            if len(parts) > 2:
                raise v.fail(where, value, 'a value and an optional sigma, "-3000 ppm/K +- 300 '
                                           'ppm/K"')
            args[key] = parse_quantity(parts[0].strip() if isinstance(parts[0], str)
                                       else parts[0], dimension, where)
            args[f"{key}_sigma"] = (parse_quantity(parts[1].strip(), dimension, f"{where} sigma")
                                    if len(parts) == 2 else 0.0)
    return TemperatureModel(**args)


def temperature_table(path: str | os.PathLike[str]) -> dict[str, Any] | None:
    """The ``[temperature]`` table of a setup file as written (checked), None without one."""
    doc = _read_document(path)
    if not isinstance(doc, dict) or TEMPERATURE_TABLE not in doc:
        return None
    temperature_from_dict(doc[TEMPERATURE_TABLE], str(path))
    return dict(doc[TEMPERATURE_TABLE])


def load_temperature(path: str | os.PathLike[str]) -> TemperatureModel | None:
    """The ``[temperature]`` table of a setup file as a model, None without one."""
    doc = _read_document(path)
    if not isinstance(doc, dict) or TEMPERATURE_TABLE not in doc:
        return None
    return temperature_from_dict(doc[TEMPERATURE_TABLE], str(path))


def fitted_temperature_table(table: Mapping[str, Any] | None,
                             calibrated_range: tuple[float, float] | None,
                             mean: float = math.nan) -> dict[str, Any] | None:
    """The ``[temperature]`` table of a fitted setup (``magcilia calibrate``'s
    ``fitted_setup.toml``): the initial setup file's ``table`` (its keys as written), with
    ``calibrated_range`` the temperatures the calibration saw (K, rounded outward to 1 mK) and
    ``reference`` their ``mean`` (K: the temperature the fitted parameters are at); the table as
    given where the calibration saw no temperature (``calibrated_range`` None); None where there
    is neither. The table is checked (:func:`temperature_from_dict`).

    Examples
    --------
    >>> fitted_temperature_table(None, (293.2, 296.8), 295.0)
    {'reference': '295.000 K', 'calibrated_range': '293.200 K:296.800 K'}
    """
    out = dict(table or {})
    if calibrated_range is not None:
        lo, hi = calibrated_range
        if math.isfinite(mean):
            out["reference"] = f"{mean:.3f} K"
        out["calibrated_range"] = (f"{math.floor(lo * 1e3 + 1e-6) / 1e3:.3f} K:"
                                   f"{math.ceil(hi * 1e3 - 1e-6) / 1e3:.3f} K")
    if not out:
        return None
    temperature_from_dict(out, "fitted setup")
    return out
