"""The units of command outputs, read from the parameter registry: display units (what
:data:`~magcilia.device.parameters.PARAMETERS` and ``MEASURANDS`` show people) or SI.

Examples
--------
>>> u = output_units()
>>> u.key("force", "force"), u.key("Bx", "field"), u.key("output", "output"), u.key("x", "x")
('force_mN', 'Bx_gauss', 'output_mV', 'x_mm')
>>> output_units(si=True).key("force", "force"), output_units(si=True).value(2.0, "angle")
('force_N', 2.0)
"""

from __future__ import annotations

from magcilia.device.parameters import MEASURANDS, PARAMETERS
from magcilia.units import OutputUnits

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
