"""The device description: checked, frozen objects in SI units.

* :mod:`.cilium`: the hair's body (cone, frustum or measured profile);
* :mod:`.material`: the cobalt/polymer composite (the paper's eq. 1);
* :mod:`.sensor`: the single-axis AMR sensor and its amplifier;
* :mod:`.setup`: :class:`Setup`, all of them placed over the sensing element;
* :mod:`.actuation`: :class:`Actuation`, an external field (uniform or magpylib) acting on it.
"""

from __future__ import annotations

from magcilia.device.actuation import Actuation
from magcilia.device.cilium import Cilium
from magcilia.device.material import Material
from magcilia.device.sensor import DEFAULT_BANDWIDTH, Sensor
from magcilia.device.setup import PAPER_INITIAL, PAPER_OPTIMIZED, Pose, Setup

__all__ = [
    "DEFAULT_BANDWIDTH",
    "PAPER_INITIAL",
    "PAPER_OPTIMIZED",
    "Actuation",
    "Cilium",
    "Material",
    "Pose",
    "Sensor",
    "Setup",
]
