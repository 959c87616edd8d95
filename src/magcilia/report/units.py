"""The units of command outputs, read from the parameter registry: display units (what
:data:`~magcilia.device.parameters.PARAMETERS` and ``MEASURANDS`` show people) or SI.

Examples
--------
>>> u = output_units()
>>> u.key("force", "force"), u.key("Bx", "field"), u.key("output", "output"), u.key("x", "x")
('force_mN', 'Bx_gauss', 'output_mV', 'x_mm')
>>> output_units(si=True).key("force", "force"), output_units(si=True).value(2.0, "angle")
('force_N', 2.0)
>>> show(2.658e-7, "force"), show(2.0e-5, "force"), show(0.0, "force")
('0.2658 µN', '0.02 mN', '0 mN')
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
from numpy.typing import NDArray

from magcilia.device.parameters import MEASURANDS, PARAMETERS
from magcilia.units import UNITS, OutputUnits

#: where a dimension's display unit is read in the registry when its entries differ (a sensor
#: output is shown like the output offset, mV, not like the bridge supply, V)
DISPLAY_SOURCE = {"voltage": "offset", "length": "height", "field": "field_range"}


def output_units(si: bool = False) -> OutputUnits:
    """The units of a command's outputs: the registry's display units (measurands first: angle
    deg, force mN, speed m/s; lengths mm, fields gauss, voltages mV, …), or SI with ``si``.
    Names known: every parameter and measurand, and ``output`` (the sensor output, as the
    offset)."""
    dimensions: dict[str, str] = {}
    names: dict[str, tuple[str | None, str]] = {}
    for q in (*MEASURANDS.values(), *PARAMETERS.values()):
        names.setdefault(q.name, (q.dimension, q.display))
        if q.dimension and q.display:
            dimensions.setdefault(q.dimension, q.display)
    for dimension, name in DISPLAY_SOURCE.items():
        dimensions[dimension] = PARAMETERS[name].display
    names["output"] = names["offset"]
    return OutputUnits(si, dimensions, names)


# --- a display unit chosen per magnitude (issue 30 item 5): the one rule ------------------------

#: the smaller display units a dimension steps down to, largest first (forces: a µN-scale force
#: reads 0.2658 µN, not 0.0002658 mN)
STEP_DOWN = {"force": ("mN", "µN", "nN")}
#: a magnitude below this many display units is shown in the next smaller unit
SMALL = 0.01


def unit_for(units: OutputUnits, what: str, magnitude: float) -> str:
    """The unit of values of ``magnitude`` (SI; the largest of a column, the value itself
    alone): the display unit of ``what``, or a smaller one of :data:`STEP_DOWN` while the
    magnitude is below :data:`SMALL` of it. SI output (``--si``), zero, NaN and infinities keep
    the unit. The one rule of the console, the figures and CSV headers."""
    unit = units.unit(what)
    dimension = units.dimension(what)
    ladder = STEP_DOWN.get(dimension or "", ())
    magnitude = abs(float(magnitude))
    if units.si or unit not in ladder or not math.isfinite(magnitude) or magnitude == 0.0:
        return unit
    i = ladder.index(unit)
    while i + 1 < len(ladder) and magnitude / UNITS[dimension or ""][ladder[i]] < SMALL:
        i += 1
    return ladder[i]


def in_unit(value: float, unit: str, what: str) -> float:
    """An SI ``value`` of the dimension of ``what`` in ``unit`` (a unit of :func:`unit_for`)."""
    dimension = output_units().dimension(what)
    return float(value) / (UNITS[dimension][unit] if dimension else 1.0)


def show(value: float, what: str, units: OutputUnits | None = None, digits: int = 4,
         magnitude: float | None = None) -> str:
    """An SI ``value`` as ``"0.2658 µN"``: ``digits`` significant digits in the unit of
    :func:`unit_for` (of ``magnitude``, else of the value); an exact zero as ``0``."""
    units = units or output_units()
    unit = unit_for(units, what, value if magnitude is None else magnitude)
    number = in_unit(value, unit, what)
    text = "0" if number == 0.0 else f"{number:.{digits}g}"
    return f"{text} {unit}".rstrip()


# --- exact zeros print as 0 (issue 30 item 5) -----------------------------------------------------

#: a component below this fraction of its vector's largest is a rounding residue of a zero
ZERO_RELATIVE = 1e-12


def exact_zeros(vectors: Any) -> NDArray[np.float64]:
    """Vectors (shape (..., k)) with every component below :data:`ZERO_RELATIVE` of its
    vector's largest set to 0 (and -0.0 to 0): what is zero by symmetry (B_y of a tilt in the
    x–z plane, cos 90°) prints as 0, not -5.57e-16. A copy; NaN stays NaN."""
    v = np.array(vectors, dtype=np.float64)
    big = np.max(np.abs(np.nan_to_num(v, nan=0.0, posinf=0.0, neginf=0.0)), axis=-1,
                 keepdims=True, initial=0.0)
    small = np.abs(v) <= ZERO_RELATIVE * big
    v[small | (v == 0.0)] = 0.0
    return v
