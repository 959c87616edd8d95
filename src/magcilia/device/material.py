"""The magnetic composite: cobalt particles in an elastomer (the paper's eq. 1) and its stiffness.

``m_c = phi * V_c * M_Co`` with ``phi = V_Co / (V_Co + V_p)`` and ``M_Co = n_Co * mu_bar``; the
Young's modulus of the composite from the neat polymer's by Guth–Gold, with its uncertainty
(:mod:`magcilia.device.stiffness`, ``docs/stiffness.md``).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, fields
from typing import Any

from magcilia._display import Display, Item, number, scaled
from magcilia.constants import (
    COBALT_ATOM_DENSITY,
    COBALT_DENSITY,
    COBALT_MOMENT_PER_ATOM,
    MU_B,
    SIS_DENSITY,
)
from magcilia.device.parameters import PARAMETERS
from magcilia.device.stiffness import (
    POLYMER_MODULUS,
    POLYMER_UNCERTAINTY,
    composite_modulus,
    filler_uncertainty,
    percent,
)


def volume_fraction(cobalt_mass: Any, polymer_mass: Any, cobalt_density: Any,
                    polymer_density: Any) -> Any:
    """The cobalt's volume fraction phi = V_Co / (V_Co + V_p), dimensionless, of a suspension of
    ``cobalt_mass`` and ``polymer_mass`` (kg) at their densities (kg/m³); arrays broadcast
    (:attr:`Material.volume_fraction` of many recipes at once)."""
    v_co = cobalt_mass / cobalt_density
    v_p = polymer_mass / polymer_density
    return v_co / (v_co + v_p)


@dataclass(frozen=True, repr=False)
class Material(Display):
    """Cobalt/polymer composite made by the paper's recipe (all SI).

    Parameters
    ----------
    cobalt_mass, polymer_mass : float
        Masses of cobalt and polymer in the suspension, kg (paper: 30 mg each).
    cobalt_density, polymer_density : float
        kg/m³ (cobalt 8.90e3, CRC Handbook; SIS polymer 0.92e3, typical for Kraton D1163).
    atom_density : float
        Cobalt atoms per m³, n_Co (9.09e28, Kittel).
    moment_per_atom : float
        Mean moment per cobalt atom, A·m² (1.72 μ_B, Kittel table 11.2).
    magnetization_scale : float
        Effective fraction of the saturation magnetization actually present (remanence of the
        multi-domain particles); 1 is the paper's assumption. Scales the moment linearly.
    polymer_modulus : float
        Small-strain Young's modulus of the neat polymer, Pa. Default 0.493 MPa: the centre of
        the readings of Kraton D1163P's 300 % modulus (0.483 MPa, the paper) through the
        neo-Hookean, Mooney–Rivlin and Martin–Roth–Stiehler laws
        (:data:`~magcilia.device.stiffness.POLYMER_MODULUS`, ``docs/stiffness.md``).
    polymer_modulus_uncertainty : float
        Relative 1 σ of ``polymer_modulus`` (default 0.25: half the readings' span); set it with
        a polymer modulus you measured (0: exact).

    Examples
    --------
    >>> m = Material()
    >>> round(m.volume_fraction, 4)
    0.0937
    >>> f"{m.cobalt_magnetization:.4g}"
    '1.45e+06'
    >>> round(m.composite_modulus / 1e6, 3), round(m.composite_modulus_uncertainty, 2)
    (0.669, 0.27)
    """

    cobalt_mass: float = 30e-6
    polymer_mass: float = 30e-6
    cobalt_density: float = COBALT_DENSITY
    polymer_density: float = SIS_DENSITY
    atom_density: float = COBALT_ATOM_DENSITY
    moment_per_atom: float = COBALT_MOMENT_PER_ATOM * MU_B
    magnetization_scale: float = 1.0
    polymer_modulus: float = POLYMER_MODULUS
    polymer_modulus_uncertainty: float = POLYMER_UNCERTAINTY

    def __post_init__(self) -> None:
        for f in fields(self):
            object.__setattr__(self, f.name, PARAMETERS[f.name].check(getattr(self, f.name)))

    @property
    def volume_fraction(self) -> float:
        """phi = V_Co / (V_Co + V_p), dimensionless (paper preset ≈ 0.0937;
        :func:`volume_fraction`)."""
        return float(volume_fraction(self.cobalt_mass, self.polymer_mass, self.cobalt_density,
                                     self.polymer_density))

    @property
    def density(self) -> float:
        """Mass density of the composite, kg/m³: the rule of mixtures by volume,
        ``phi rho_Co + (1 - phi) rho_p`` (exact for a suspension without voids; 1,668 kg/m³ for
        the paper's recipe, 30 mg cobalt at 8.90 g/cm³ in 30 mg polymer at 0.92 g/cm³)."""
        phi = self.volume_fraction
        return phi * self.cobalt_density + (1.0 - phi) * self.polymer_density

    @property
    def cobalt_magnetization(self) -> float:
        """M_Co = n_Co · mu_bar, A/m (≈ 1.450e6 for textbook cobalt)."""
        return self.atom_density * self.moment_per_atom

    @property
    def magnetization(self) -> float:
        """Magnetization of the composite, A/m: scale · phi · M_Co."""
        return self.magnetization_scale * self.volume_fraction * self.cobalt_magnetization

    @property
    def composite_modulus(self) -> float:
        """Young's modulus of the filled elastomer by Guth–Gold, Pa.

        ``E_c = E_p (1 + 2.5 phi + 14.1 phi^2)`` (Guth, J. Appl. Phys. 16, 20 (1945);
        :func:`magcilia.device.stiffness.composite_modulus`).
        """
        return float(composite_modulus(self.polymer_modulus, self.volume_fraction))

    @property
    def composite_modulus_uncertainty(self) -> float:
        """Relative 1 σ of :attr:`composite_modulus`: the polymer's and the filler law's
        (:func:`~magcilia.device.stiffness.filler_uncertainty`) in quadrature (0.27 for the
        paper's recipe)."""
        return math.hypot(self.polymer_modulus_uncertainty,
                          filler_uncertainty(self.volume_fraction))

    def _display_items(self) -> list[Item]:
        names = ("cobalt_mass", "polymer_mass", "magnetization_scale", "cobalt_density",
                 "polymer_density", "polymer_modulus")
        items = [(n, PARAMETERS[n].text(getattr(self, n))) for n in names]
        items[-1] = (items[-1][0],
                     f"{items[-1][1]} ±{percent(self.polymer_modulus_uncertainty)}")
        return [*items[:3], ("magnetization", scaled(self.magnetization, 1e3, "kA/m")),
                ("volume_fraction", number(self.volume_fraction)), *items[3:]]
