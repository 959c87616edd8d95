"""Drag of the cilium in a flow: the cylinder drag law, the low-Re law of a slender body standing
on the wall, fluid presets and the local drag per length.

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

**Low Reynolds number: a finite slender body standing on a wall.** Lamb's law is that of an
infinite cylinder: its logarithm ``ln(8/Re)`` is the Oseen screening length (where inertia takes
over) over the radius, and it grows without bound as Re → 0. A cilium of length L on the sensor's
surface is screened much sooner, by its own ends and by the no-slip wall at its base; its drag is
that of slender-body theory. Per unit length, along the local normal::

    f = 8π μ U_n / Λ(s),
    Λ = 2 ln(2 √(s (L − s)) / a) + 1  −  [ln(w₂/w₁) + (1 − h/w₂)² − (1 − h/w₁)²],
    w₁ = h + g,  w₂ = h + g + L,

with a(s) the local radius, s the arc length from the base, h the height of the point above the
wall and g the gap between the wall and the base (0 for the cilium). The first part is the local
slender-body law of a free rod (Lighthill 1976, SIAM Rev. 18, 161; Keller & Rubinow
1976, J. Fluid Mech. 75, 705: the normal coefficient ``4πμ / (ln(2√(s(L−s))/a) + ½)``);
the bracket is the velocity on the axis induced by the wall images of a uniform line of
Stokeslets, from Blake's image system of a Stokeslet parallel to a no-slip plane (J. R. Blake 1971,
Proc. Camb. Phil. Soc. 70, 303): on the vertical through a Stokeslet at height z′ the
images add ``−1/(h + z′) − 2 h z′ / (h + z′)³`` (times ``F / 8πμ``) to its ``1/|h − z′|``, which
integrates in closed form. It is a resistive-force law: local, with the force density taken
uniform in the nonlocal part (errors O(1/Λ²)), the rod's own shape used for the ends and its
current height for the wall. Distances closer than one radius to an end or to the wall, where
slender-body theory does not hold, are regularised (``√(x² + a²)``), so Λ stays positive.

Checks (``tests/mechanics/test_slender_drag.py``, ``docs/mechanics.md``): far from the wall a
prolate spheroid gives ``8πμ l U / (ln(2l/b) + ½)``, within 2 % of the exact Stokes drag of
Chwang & Wu (1975, J. Fluid Mech. 67, 787: ``32πμ l U e³ / (2e + (3e² − 1) ln((1+e)/(1−e)))``) from
semi-axis ratio 5 on (0.6 % at 10); a blunt cylinder of aspect ratio p = L/2a = 5–20 agrees with
the Tirado & García de la Torre (1979, J. Chem. Phys. 71, 2581) friction coefficient
``4πμ L U / (ln p + 0.839 + 0.185/p + 0.233/p²)`` to 5.5 % at p = 5, 2.6 % at 10, 1.3 % at 20
(low: the local law misses part of the force on the blunt ends); the image bracket is checked
against Blake's full image tensor (no slip on the wall; the on-axis integral); on 9:1 hairs
standing on the wall the local law is within 2.5 % of the nonlocal slender-body solution
(:func:`upright_rod_drag`) for the total force and 5 % for the base moment, uniform or shear.

The two laws are blended in the local Reynolds number: the slender-body law below ``Re = 0.02``,
today's (Lamb / White) law above ``Re = 0.5`` (where Lamb's law begins to blend into White's),
and ``(1 − w) f_slender + w f_cylinder`` between, with ``w = 3u² − 2u³``,
``u = log(Re / 0.02) / log 25`` (centred on Re = 0.1): C¹, as the other blend, and wide enough that
the drag per length stays increasing in the speed for every Λ ≥ 1 (the laws differ up to 8× at
the blend's ends; the smallest Λ of a standing rod, at its regularised base, is ≈ 1.44). Above
Re = 0.5 the drag is unchanged bit for bit. The blend is an interpolation, not a theory: inertia
screens the slender body beyond the Oseen length ``~ ν/U``, which passes the body's length near
Re ~ 0.1–1 for a 9:1 hair (an Oseen-corrected slender-body theory, Khayat & Cox 1989, J. Fluid
Mech. 209, 435, would bridge it). For a rigid upright 9:1 cylinder on the wall the slender-body
law gives 3.2× Lamb's total drag at Re = 0.01 and 4.3× at Re = 0.001 (2.1× and 2.8× without the
wall): Lamb's drag per length falls as 1/ln(8/Re), the finite body's does not, and the wall raises
it by half (×1.53 in uniform flow, ×1.29 in shear) through the slow flow near the base. With the
blend magcilia's total is 1.5× Lamb's at Re = 0.1 and 2.1× at 0.05 (``docs/mechanics.md``).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from magcilia import _validate as v
from magcilia._display import Display, Item, number, si

F64 = NDArray[np.float64]

#: largest Reynolds number of the drag correlation (White 1991)
RE_MAX = 2.0e5
_RE_LAMB, _RE_WHITE = 0.5, 1.0
#: the slender-body law holds below RE_SLENDER[0], today's (Lamb / White) law above RE_SLENDER[1]
RE_SLENDER = (0.02, 0.5)
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
#: glycerol (anhydrous) at 20 °C: ρ = 1261 kg/m³, μ = 1.412 Pa·s (CRC Handbook, 97th ed.,
#: "Viscosity of liquids"; Segur & Oberstar, Ind. Eng. Chem. 43, 2117 (1951)): a viscous liquid in
#: which every bending mode of a mm-scale hair is overdamped
GLYCEROL = Fluid(density=1261.0, viscosity=1.412, name="glycerol")
FLUIDS = {"air": AIR, "water": WATER, "glycerol": GLYCEROL}


def _re_cd(re: F64) -> F64:
    """Re · C_D(Re) (dimensionless); finite and → 0 as Re → 0 (no 0/0 at zero speed)."""
    re = np.maximum(re, 1e-300)
    with np.errstate(divide="ignore", over="ignore"):
        lamb = 8.0 * math.pi / (0.5 - _EULER_GAMMA - np.log(np.minimum(re, _RE_WHITE) / 8.0))
    white = re + 10.0 * np.cbrt(re)
    u = np.clip(np.log(re / _RE_LAMB) / math.log(_RE_WHITE / _RE_LAMB), 0.0, 1.0)
    w = u * u * (3.0 - 2.0 * u)
    return np.asarray((1.0 - w) * lamb + w * white, dtype=np.float64)


def _re_cd_blend(re: F64, slender: F64) -> F64:
    """Re · C_D with the slender-body law ``16π / Λ`` (``slender``: Λ) below RE_SLENDER[0],
    the cylinder law above RE_SLENDER[1] (bit for bit) and a C¹ blend of the two between."""
    lo, hi = RE_SLENDER
    if not np.any(re > lo):  # the slender-body law alone
        return np.asarray(np.broadcast_to(16.0 * math.pi / slender, re.shape), dtype=np.float64)
    if np.all(re < _RE_LAMB):  # Lamb's law alone, as _re_cd gives it there
        cyl = 8.0 * math.pi / (0.5 - _EULER_GAMMA - np.log(np.maximum(re, 1e-300) / 8.0))
    else:
        cyl = _re_cd(re)
    u = np.clip(np.log(np.maximum(re, 1e-300) / lo) / math.log(hi / lo), 0.0, 1.0)
    w = u * u * (3.0 - 2.0 * u)
    mixed = w * cyl + (1.0 - w) * (16.0 * math.pi / slender)
    return np.asarray(np.where(w >= 1.0, cyl, mixed), dtype=np.float64)


def slender_log(arc: ArrayLike, height: ArrayLike, radius: ArrayLike, length: float,
                gap: float = 0.0) -> F64:
    """The slender-body resistance logarithm Λ (dimensionless) of a rod standing on a wall.

    The local normal drag per length at low Reynolds number is ``8π μ U_n / Λ`` (see the module
    docstring for the formula and its sources).

    Parameters
    ----------
    arc : array-like
        Arc length from the rod's base, m (0 ≤ s ≤ length).
    height : array-like, broadcastable
        Height of the point above the wall, m (the arc length for a straight upright rod).
    radius : array-like, broadcastable
        Local radius a(s), m (> 0).
    length : float
        Length of the rod, m.
    gap : float
        Distance from the wall to the rod's base, m (0: standing on it; ``inf``: no wall).

    Returns
    -------
    ndarray, the broadcast shape
        Λ, positive (distances closer than a radius to an end or to the wall are regularised).

    Examples
    --------
    >>> round(float(slender_log(0.5, 0.5, 0.01, 1.0, gap=math.inf)), 3)  # 2 ln(100) + 1
    10.211
    """
    lam = free_log(arc, radius, length)
    if math.isfinite(gap):
        lam = lam - wall_log(height, radius, length, gap)
    return np.asarray(lam, dtype=np.float64)


def free_log(arc: ArrayLike, radius: ArrayLike, length: float | F64) -> F64:
    """The free rod's part of :func:`slender_log`, ``2 ln(2 √(s (L − s)) / a) + 1`` with the
    distances to the ends regularised within a radius (dimensionless, the broadcast shape)."""
    s = np.asarray(arc, dtype=np.float64)
    a2 = np.asarray(radius, dtype=np.float64) ** 2
    return np.asarray(np.log(4.0 * np.sqrt((s * s + a2) * ((length - s) ** 2 + a2)) / a2) + 1.0,
                      dtype=np.float64)


def wall_log(height: ArrayLike, radius: ArrayLike, length: float | F64,
             gap: float = 0.0) -> F64:
    """The wall's part of :func:`slender_log` (subtracted from :func:`free_log`): the on-axis
    velocity of the Blake images of a uniform line of Stokeslets of length ``length`` from ``gap``
    above the wall, ``ln(w₂/w₁) + (1 − h/w₂)² − (1 − h/w₁)²`` (× F / 8πμ per length),
    ``w₁ = h + gap``, ``w₂ = h + gap + length``, with h regularised as ``√(h² + a²)``."""
    h = np.asarray(height, dtype=np.float64)
    a = np.asarray(radius, dtype=np.float64)
    hr = np.sqrt(h * h + a * a)
    w1, w2 = hr + gap, hr + gap + length
    return np.asarray(np.log(w2 / w1) + (1.0 - hr / w2) ** 2 - (1.0 - hr / w1) ** 2,
                      dtype=np.float64)


def upright_rod_drag(radius: Callable[[F64], F64], length: float,
                     speed: Callable[[F64], F64], viscosity: float, gap: float = 0.0,
                     nodes: int = 400) -> tuple[F64, F64, F64]:
    """Stokes drag on a rigid straight rod standing upright on a wall, by nonlocal slender-body
    theory: the reference that the local law (:func:`slender_log`) approximates.

    Solves, on ``nodes`` Gauss–Legendre points, the slender-body integral equation with the wall's
    Blake images (the force density f along x, the flow U(z) along x)::

        8π μ U(z) = Λ(z) f(z) + ∫ (f(z′) − f(z)) [1/|z − z′| − 1/(z + z′) − 2 z z′/(z + z′)³] dz′

    (z, z′ heights over the rod, gap to gap + length; no wall terms for ``gap = inf``).

    Parameters
    ----------
    radius : callable
        Vectorised a(s), m, of the arc length s from the base (m).
    length : float
        Rod length, m.
    speed : callable
        Vectorised flow speed U(z), m/s, at heights z above the wall (m).
    viscosity : float
        Dynamic viscosity μ, Pa·s.
    gap : float
        Wall to base, m (``math.inf``: no wall).
    nodes : int
        Quadrature points (the wall terms converge slowly near the wall: ~0.1 % from 400).

    Returns
    -------
    arc, weights, force : ndarray, (nodes,) each
        Arc lengths (m), quadrature weights (m) and force density (N/m) on the rod; the total
        force is ``weights @ force``.

    Examples
    --------
    >>> s, w, f = upright_rod_drag(lambda s: np.full_like(s, 1e-4), 3e-3,
    ...                            lambda z: np.full_like(z, 1e-3), 1e-3, gap=math.inf)
    >>> round(float(w @ f) / (4 * math.pi * 1e-3 * 1e-3 * 3e-3), 3)  # Tirado & García: 0.281
    0.278
    """
    t, wq = np.polynomial.legendre.leggauss(nodes)
    s = 0.5 * length * (t + 1.0)
    w = 0.5 * length * wq
    z = s + (gap if math.isfinite(gap) else 0.0)
    lam = slender_log(s, z, np.asarray(radius(s), dtype=np.float64), length, gap)
    zi, zj = z[:, None], z[None, :]
    dist = np.abs(zi - zj)
    np.fill_diagonal(dist, 1.0)
    kernel = 1.0 / dist
    if math.isfinite(gap):
        kernel -= 1.0 / (zi + zj) + 2.0 * zi * zj / (zi + zj) ** 3
    np.fill_diagonal(kernel, 0.0)
    a = kernel * w[None, :]
    system = np.diag(lam - a.sum(axis=1)) + a
    u = np.asarray(speed(z), dtype=np.float64)
    force = np.asarray(np.linalg.solve(system, 8.0 * math.pi * viscosity * u), dtype=np.float64)
    return s, w, force


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


def drag_per_length(normal_speed: F64, diameter: F64, fluid: Fluid,
                    slender: F64 | Callable[[], F64] | None = None) -> F64:
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
    slender : ndarray (broadcastable) or a callable returning it, optional
        The slender-body logarithm Λ of each point (:func:`slender_log`); a callable is called
        only if some Re is below 0.5. Given, the drag below ``Re = 0.5`` is that of a finite
        slender body on a wall, ``8π μ U_n / Λ`` below ``Re = 0.02``, blended (C¹) into the
        cylinder law between; omitted, the 2-D cylinder law at every Re (as before).
    """
    re = fluid.reynolds(normal_speed, diameter)
    if slender is None or not np.any(re < RE_SLENDER[1]):
        re_cd = _re_cd(re)
    else:
        re_cd = _re_cd_blend(re, slender() if callable(slender) else slender)
    return 0.5 * fluid.viscosity * normal_speed * re_cd


#: step in ln U of :func:`drag_exponent`'s central difference
_EXPONENT_STEP = 1e-4


def drag_exponent(normal_speed: ArrayLike, diameter: ArrayLike, fluid: Fluid,
                  slender: ArrayLike | None = None) -> F64:
    """The drag law's local exponent ``n = d ln f / d ln U_n`` (dimensionless; any shape that
    broadcasts): 1 where the drag is linear in the speed (creeping flow, the slender-body law),
    2 for form drag at a constant C_D, between for Lamb's and White's laws
    (:func:`drag_per_length`, a central difference in ln U_n). At a fixed bent shape the drag
    must scale with the Young's modulus E, so a flow speed read at a fixed output scales as
    ``E^(1/n)``: its share of E's uncertainty is ``σ_U/U = (σ_E/E)/n``
    (:mod:`magcilia.readout.scale`).

    Examples
    --------
    >>> float(drag_exponent(1e-6, 1e-4, WATER, slender=10.0).round(6))   # Re = 1e-4: creeping
    1.0
    >>> float(drag_exponent(10.0, 1e-3, AIR).round(3))   # Re = 665: White's 1 + 10 Re^(-2/3)
    1.923
    """
    u = np.abs(np.asarray(normal_speed, dtype=np.float64))
    d = np.asarray(diameter, dtype=np.float64)
    lam = None if slender is None else np.asarray(slender, dtype=np.float64)
    up, down = (np.abs(drag_per_length(u * math.exp(sign * _EXPONENT_STEP), d, fluid, lam))
                for sign in (1.0, -1.0))
    return np.asarray(np.log(up / down) / (2.0 * _EXPONENT_STEP), dtype=np.float64)


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
