"""The device description: checked, frozen objects in SI units.

* :mod:`.cilium`: the hair's body (cone, frustum or measured profile);
* :mod:`.material`: the cobalt/polymer composite (the paper's eq. 1);
* :mod:`.stiffness`: its Young's modulus from the paper's 300 % modulus, with an uncertainty, and
  :class:`Modulus` (a setup's modulus, its σ and source);
* :mod:`.sensor`: the single-axis AMR sensor and its amplifier, its limits (cross-axis effect,
  flipping) and :class:`SensorCheck`;
* :mod:`.magnetometer`: 3-axis magnetometers with datasheet presets (:data:`MAGNETOMETERS`);
* :mod:`.setup`: :class:`Setup`, all of them placed over the sensing element;
* :mod:`.array`: :class:`CiliaArray`, many cilia (each a Setup) over many 3-axis sensors.
* :mod:`.actuation`: :class:`Actuation`, an external field (uniform or magpylib) acting on it.
* :mod:`.temperature`: :class:`TemperatureModel`, the sensor's and the cilium's temperature
  coefficients (cited), and :class:`TemperatureProfile`, a temperature over time.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from magcilia._lazy import attach

if TYPE_CHECKING:
    from magcilia.device.actuation import Actuation
    from magcilia.device.array import CiliaArray
    from magcilia.device.cilium import Cilium
    from magcilia.device.magnetometer import MAGNETOMETERS, Magnetometer
    from magcilia.device.material import Material
    from magcilia.device.sensor import DEFAULT_BANDWIDTH, Sensor, SensorCheck, SensorFlag
    from magcilia.device.setup import PAPER_INITIAL, PAPER_OPTIMIZED, Pose, Setup
    from magcilia.device.stiffness import Modulus
    from magcilia.device.temperature import TemperatureModel, TemperatureProfile

__all__ = [
    "DEFAULT_BANDWIDTH",
    "MAGNETOMETERS",
    "PAPER_INITIAL",
    "PAPER_OPTIMIZED",
    "Actuation",
    "CiliaArray",
    "Cilium",
    "Magnetometer",
    "Material",
    "Modulus",
    "Pose",
    "Sensor",
    "SensorCheck",
    "SensorFlag",
    "Setup",
    "TemperatureModel",
    "TemperatureProfile",
]

__getattr__, __dir__ = attach(__name__)
