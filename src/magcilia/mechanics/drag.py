"""Drag of a cylinder in cross-flow: the drag law, fluid presets and the local drag per length.

The cilium is treated as a slender cylinder of local diameter ``d(s) = 2 r(s)``. By the
cross-flow (independence) principle only the velocity component normal to the local tangent,
``U_n``, makes drag, and the drag acts along the local normal; tangential (skin) friction along the
axis is neglected (it is a small fraction of the normal drag for a slender body and makes almost no
bending moment). Per unit length::

    f = ½ ρ U_n |U_n| d C_D(Re),   Re = ρ |U_n| d / μ.

Drag coefficient ``C_D(Re)`` (diameter-based Reynolds number):

* ``Re < 0.5``: Lamb's (1911) Oseen solution, ``C_D = 8π / (Re (½ − γ_E − ln(Re/8)))``
  (= ``8π / (Re (2.002 − ln Re))``; H. Lamb, Phil. Mag. 21, 112 (1911));
* ``Re > 1``: White's correlation ``C_D = 1 + 10 Re^(−2/3)``, valid for 1 < Re < 2e5
  (F. M. White, *Viscous Fluid Flow*, 2nd ed., McGraw-Hill 1991, eq. 3-225);
* ``0.5 ≤ Re ≤ 1``: a smooth (C¹) blend of the two, weight ``w = 3u² − 2u³`` with
  ``u = log(Re/0.5) / log 2``; the two laws differ by ≤ 14 % there.

Above ``Re = 2e5`` (the drag crisis) the correlation does not hold and magcilia refuses the flow.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from magcilia import _validate as v
from magcilia._display import Display, Item, number, si

F64 = NDArray[np.float64]

#: largest Reynolds number of the drag correlation (White 1991)
RE_MAX = 2.0e5
_RE_LAMB, _RE_WHITE = 0.5, 1.0
_EULER_GAMMA = 0.5772156649015329


@dataclass(frozen=True, repr=False)
class Fluid(Display):
    """A Newtonian fluid.

    Parameters
    ----------
    density : float
        Mass density ρ, kg/m³.
    viscosity : float
        Dynamic viscosity μ, Pa·s.
    name : str
        Label for reports.
    """

    density: float
    viscosity: float
    name: str = "fluid"

    def __post_init__(self) -> None:
        object.__setattr__(self, "density",
                           v.positive("density", self.density, "kg/m^3", "density"))
        object.__setattr__(self, "viscosity",
                           v.positive("viscosity", self.viscosity, "Pa*s", "viscosity"))

    def reynolds(self, speed: ArrayLike, diameter: ArrayLike) -> F64:
        """Reynolds number ``ρ |U| d / μ`` (dimensionless) for speeds (m/s) and diameters (m)."""
        return (self.density / self.viscosity) * np.abs(np.asarray(speed, dtype=np.float64)) \
            * np.asarray(diameter, dtype=np.float64)

    def _display_items(self) -> list[Item]:
        return [("", self.name), ("density", f"{number(self.density)} kg/m³"),
                ("viscosity", si(self.viscosity, "Pa·s"))]


#: air at 20 °C and 1 atm: ρ = 1.204 kg/m³, μ = 1.81e-5 Pa·s (CRC Handbook of Chemistry and
#: Physics, 97th ed., "Properties of air"; White, Fluid Mechanics, table A.2)
AIR = Fluid(density=1.204, viscosity=1.81e-5, name="air")
#: water at 20 °C: ρ = 998.2 kg/m³, μ = 1.002e-3 Pa·s (CRC Handbook, 97th ed., "Properties of
#: water in the range 0–100 °C"; IAPWS values)
WATER = Fluid(density=998.2, viscosity=1.002e-3, name="water")
FLUIDS = {"air": AIR, "water": WATER}


def _re_cd(re: F64) -> F64:
    """Re · C_D(Re) (dimensionless); finite and → 0 as Re → 0 (no 0/0 at zero speed)."""
    re = np.maximum(re, 1e-300)
    with np.errstate(divide="ignore", over="ignore"):
        lamb = 8.0 * math.pi / (0.5 - _EULER_GAMMA - np.log(np.minimum(re, _RE_WHITE) / 8.0))
    white = re + 10.0 * np.cbrt(re)
    u = np.clip(np.log(re / _RE_LAMB) / math.log(_RE_WHITE / _RE_LAMB), 0.0, 1.0)
    w = u * u * (3.0 - 2.0 * u)
    return np.asarray((1.0 - w) * lamb + w * white, dtype=np.float64)


def drag_coefficient(reynolds: ArrayLike) -> F64:
    """Drag coefficient of a circular cylinder in cross-flow, C_D(Re) (dimensionless).

    Parameters
    ----------
    reynolds : array-like, any shape
        Diameter-based Reynolds numbers, 0 < Re ≤ 2e5.

    Returns
    -------
    ndarray, same shape
        Lamb's Oseen law below Re = 0.5, White's ``1 + 10 Re^(-2/3)`` above 1, blended between.

    Examples
    --------
    >>> float(drag_coefficient(100.0).round(4))
    1.4642
    """
    re = v.finite_array("reynolds", reynolds)
    if np.any(re <= 0.0) or np.any(re > RE_MAX):
        bad = float(re[(re <= 0.0) | (re > RE_MAX)].ravel()[0])
        raise v.fail("reynolds", bad, f"in (0, {RE_MAX:g}] (the drag law's range)")
    return _re_cd(re) / re


def drag_per_length(normal_speed: F64, diameter: F64, fluid: Fluid) -> F64:
    """Signed drag per unit length along the local normal, N/m (kernel: no checks).

    ``f = ½ μ U_n · (Re C_D(Re))``, identical to ``½ ρ U_n |U_n| d C_D`` and finite at U_n = 0.

    Parameters
    ----------
    normal_speed : ndarray, any shape
        Velocity component normal to the axis, m/s (signed).
    diameter : ndarray, broadcastable
        Local diameter, m.
    fluid : Fluid
        The fluid.
    """
    re = fluid.reynolds(normal_speed, diameter)
    return 0.5 * fluid.viscosity * normal_speed * _re_cd(re)


def max_speed(diameter: float, fluid: Fluid) -> float:
    """Fastest flow (m/s) past a cylinder of ``diameter`` (m) within the drag law (Re ≤ RE_MAX)."""
    return RE_MAX * fluid.viscosity / (fluid.density * diameter)


def check_reynolds(speed: float, diameter: float, fluid: Fluid, name: str = "flow speed") -> None:
    """Raise a one-line error if ``speed`` (m/s) past ``diameter`` (m) exceeds the drag law."""
    re = float(fluid.reynolds(speed, diameter))
    if re > RE_MAX:
        limit = max_speed(diameter, fluid)
        raise v.fail(name, f"{speed:.6g} m/s (Re = {re:.3g} in {fluid.name})",
                     f"at most {limit:.4g} m/s, where the cylinder drag law ends (Re ≤ {RE_MAX:g})")
