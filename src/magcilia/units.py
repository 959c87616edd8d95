"""Unit-bearing values at the edges: ``"3.0 mm"``, ``"7.5 V"``, ``"30 mg"`` → SI floats.

Only the CLI and setup files use this; the Python API takes SI numbers. Each key of a setup file
names a *dimension* (length, mass, …); a value with a unit of another dimension, or none, is an
error that names the key.

Examples
--------
>>> parse_quantity("3.2613 mm", "length")
0.0032613
>>> parse_quantity("1.0 mV/V/gauss", "sensitivity")
10.0
>>> format_quantity(0.0032613, "mm")
'3.2613 mm'
"""

from __future__ import annotations

import math
import re

from magcilia._validate import fail
from magcilia.constants import GAUSS, MU_B

#: unit symbol -> SI factor, per dimension
UNITS: dict[str, dict[str, float]] = {
    "length": {"m": 1.0, "cm": 1e-2, "mm": 1e-3, "um": 1e-6, "µm": 1e-6, "nm": 1e-9},
    "mass": {"kg": 1.0, "g": 1e-3, "mg": 1e-6, "ug": 1e-9, "µg": 1e-9},
    "density": {"kg/m^3": 1.0, "kg/m3": 1.0, "g/cm^3": 1e3, "g/cm3": 1e3, "g/ml": 1e3},
    "number_density": {"m^-3": 1.0, "1/m^3": 1.0, "cm^-3": 1e6, "1/cm^3": 1e6},
    "moment_per_atom": {"muB": MU_B, "μB": MU_B, "A*m^2": 1.0, "A m^2": 1.0, "J/T": 1.0},
    "magnetization": {"A/m": 1.0, "kA/m": 1e3, "MA/m": 1e6},
    "voltage": {"V": 1.0, "mV": 1e-3, "uV": 1e-6, "µV": 1e-6},
    "field": {"T": 1.0, "mT": 1e-3, "uT": 1e-6, "µT": 1e-6, "nT": 1e-9, "gauss": GAUSS, "G": GAUSS,
              "mG": 1e-3 * GAUSS, "ugauss": 1e-6 * GAUSS, "µgauss": 1e-6 * GAUSS},
    "sensitivity": {"V/V/T": 1.0, "mV/V/gauss": 1e-3 / GAUSS, "mV/V/G": 1e-3 / GAUSS,
                    "mV/V/mT": 1.0},
    "angle": {"rad": 1.0, "deg": math.pi / 180.0, "°": math.pi / 180.0},
    "force": {"N": 1.0, "mN": 1e-3, "uN": 1e-6, "µN": 1e-6, "nN": 1e-9},
    "pressure": {"Pa": 1.0, "kPa": 1e3, "MPa": 1e6, "GPa": 1e9},
    "speed": {"m/s": 1.0, "mm/s": 1e-3, "cm/s": 1e-2},
    "frequency": {"Hz": 1.0, "kHz": 1e3},
    "time": {"s": 1.0, "ms": 1e-3, "us": 1e-6, "µs": 1e-6},
    "noise_density": {"T/sqrt(Hz)": 1.0, "nT/sqrt(Hz)": 1e-9, "pT/sqrt(Hz)": 1e-12,
                      "ugauss/sqrt(Hz)": 1e-6 * GAUSS, "µgauss/sqrt(Hz)": 1e-6 * GAUSS},
    "viscosity": {"Pa*s": 1.0, "Pa s": 1.0, "mPa*s": 1e-3, "mPa s": 1e-3},
}

#: longest text of a quantity (a number and a unit; longer text is refused before parsing)
MAX_QUANTITY_CHARS = 200

_NUMBER = re.compile(r"^\s*([-+]?(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?)\s*(.*?)\s*$")


def parse_quantity(text: object, dimension: str, key: str = "value") -> float:
    """Parse ``"<number> <unit>"`` into an SI float of the given dimension.

    Parameters
    ----------
    text : str
        The value with its unit, e.g. ``"0.71 mm"``. A bare number is an error (say the unit).
    dimension : str
        A key of :data:`UNITS`, e.g. ``"length"``.
    key : str
        The setup-file key or CLI option, used in the error message.

    Returns
    -------
    float
        The value in SI units (m, kg, V, T, …).
    """
    units = UNITS[dimension]
    allowed = (f"a {dimension.replace('_', ' ')} with a unit ({', '.join(units)}), "
               f"e.g. '1.0 {next(iter(units))}'")
    if not isinstance(text, str):
        raise fail(key, text, allowed)
    match = _NUMBER.match(text) if len(text) <= MAX_QUANTITY_CHARS else None
    if match is None or match.group(2) not in units:
        raise fail(key, text, allowed)
    value = float(match.group(1)) * units[match.group(2)]
    if not math.isfinite(value):
        raise fail(key, text, allowed)
    return value


def format_quantity(value: float, unit: str, digits: int = 6) -> str:
    """Format an SI value in ``unit`` (which must be known to :data:`UNITS`), e.g.
    ``'3.2613 mm'``."""
    for table in UNITS.values():
        if unit in table:
            return f"{value / table[unit]:.{digits}g} {unit}"
    raise KeyError(unit)


def parse_range(text: str, key: str, unit: str = "deg") -> tuple[float, float, float | None]:
    """Parse ``"start:stop[:step]"`` in ``unit`` (angle) into SI floats; step is None if absent."""
    parts = text.split(":")
    allowed = f"start:stop or start:stop:step in {unit}, e.g. '0:85:5'"
    try:
        nums = [float(p) for p in parts]
    except ValueError:
        raise fail(key, text, allowed) from None
    if len(nums) not in (2, 3) or not all(math.isfinite(v) for v in nums):
        raise fail(key, text, allowed)
    factor = UNITS["angle"].get(unit, 1.0)
    start, stop = nums[0] * factor, nums[1] * factor
    step = nums[2] * factor if len(nums) == 3 else None
    if step is not None and step <= 0:
        raise fail(key, text, "a range with a positive step")
    if stop <= start:
        raise fail(key, text, "a range with stop > start")
    return start, stop, step
