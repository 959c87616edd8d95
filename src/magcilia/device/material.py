"""The magnetic composite: cobalt particles in an elastomer (the paper's eq. 1).

``m_c = phi * V_c * M_Co`` with ``phi = V_Co / (V_Co + V_p)`` and ``M_Co = n_Co * mu_bar``.
"""

from __future__ import annotations

from dataclasses import dataclass, fields

from magcilia._display import Display, Item, number, scaled
from magcilia.constants import (
    COBALT_ATOM_DENSITY,
    COBALT_DENSITY,
    COBALT_MOMENT_PER_ATOM,
    MU_B,
    SIS_DENSITY,
)
from magcilia.device.parameters import PARAMETERS


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
        Young's modulus of the neat polymer, Pa (SIS: ~2.4–2.7 MPa small strain; default 2.5e6).

    Examples
    --------
    >>> m = Material()
    >>> round(m.volume_fraction, 4)
    0.0937
    >>> f"{m.cobalt_magnetization:.4g}"
    '1.45e+06'
    """

    cobalt_mass: float = 30e-6
    polymer_mass: float = 30e-6
    cobalt_density: float = COBALT_DENSITY
    polymer_density: float = SIS_DENSITY
    atom_density: float = COBALT_ATOM_DENSITY
    moment_per_atom: float = COBALT_MOMENT_PER_ATOM * MU_B
    magnetization_scale: float = 1.0
    polymer_modulus: float = 2.5e6

    def __post_init__(self) -> None:
        for f in fields(self):
            object.__setattr__(self, f.name, PARAMETERS[f.name].check(getattr(self, f.name)))

    @property
    def volume_fraction(self) -> float:
        """phi = V_Co / (V_Co + V_p), dimensionless (paper preset ≈ 0.0937)."""
        v_co = self.cobalt_mass / self.cobalt_density
        v_p = self.polymer_mass / self.polymer_density
        return v_co / (v_co + v_p)

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

        ``E_c = E_p (1 + 2.5 phi + 14.1 phi^2)`` (Guth, J. Appl. Phys. 16, 20 (1945)).
        """
        phi = self.volume_fraction
        return self.polymer_modulus * (1.0 + 2.5 * phi + 14.1 * phi**2)

    def _display_items(self) -> list[Item]:
        names = ("cobalt_mass", "polymer_mass", "magnetization_scale", "cobalt_density",
                 "polymer_density", "polymer_modulus")
        items = [(n, PARAMETERS[n].text(getattr(self, n))) for n in names]
        return [*items[:3], ("magnetization", scaled(self.magnetization, 1e3, "kA/m")),
                ("volume_fraction", number(self.volume_fraction)), *items[3:]]
