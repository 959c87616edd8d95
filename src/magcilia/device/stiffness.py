"""The cilium's stiffness: Young's modulus from the paper's material, and how sure it is.

Every absolute force and flow figure scales with the Young's modulus E (the elastica depends on
loads only through F·L²/(E·I)), and tilt data cannot tell E (the field does not depend on it).
The paper gives one number for it: Kraton D1163P's 300 % modulus, 0.483 MPa (70 psi), the
engineering stress at a stretch λ = 4. This module turns that number into the presets' modulus
and its relative 1-σ uncertainty (the derivation, in prose: ``docs/stiffness.md``; its table is
``scripts/stiffness_table.py``):

1. **The neat polymer at small strain.** One 300 % modulus read through three standard laws of
   rubber in simple extension gives a span of small-strain moduli:

   * neo-Hookean, ``σ = (E/3)(λ − λ⁻²)`` (:func:`neo_hookean_modulus`);
   * Mooney–Rivlin, ``σ = 2(C₁ + C₂/λ)(λ − λ⁻²)`` with ``E = 6(C₁ + C₂)``, at the C₂/C₁ of
     :data:`MOONEY_RATIOS` (:func:`mooney_rivlin_modulus`);
   * Martin–Roth–Stiehler, ``σ = E (λ⁻¹ − λ⁻²) exp(A(λ − λ⁻¹))``, A = 0.38 for unfilled
     vulcanizates (L. A. Wood, J. Res. NBS 82, No. 1 (1977)) (:func:`mrs_modulus`).

   The default (:data:`POLYMER_MODULUS`) is the centre of their span, its relative 1 σ
   (:data:`POLYMER_UNCERTAINTY`) half the span (both rounded).
2. **The filled composite.** Guth–Gold, ``E_c = E (1 + 2.5φ + 14.1φ²)`` (E. Guth, J. Appl.
   Phys. 16, 20 (1945)), the law for rubbers filled with spheres up to φ ≈ 0.2; Einstein's
   dilute law ``1 + 2.5φ`` (no particle interactions) lies below it, and its distance from
   Guth–Gold is taken as the law's relative 1 σ (:func:`filler_uncertainty`).

The composite's relative 1 σ is the two added in quadrature
(:attr:`magcilia.Material.composite_modulus_uncertainty`). A setup says where its modulus comes
from with a :class:`Modulus`: ``"assumed"`` (the material's derived modulus), ``"measured"``
(given with its σ, or fitted from load data) or ``"exact"`` (given without a σ); its
:meth:`Modulus.note` is the one line every force and flow report prints.

Examples
--------
>>> round(neo_hookean_modulus(SIS_300_MODULUS) / 1e6, 3)        # MPa
0.368
>>> POLYMER_MODULUS, POLYMER_UNCERTAINTY
(493000.0, 0.25)
>>> round(composite_modulus(POLYMER_MODULUS, 0.0937) / 1e6, 4)
0.6695
>>> Modulus(6.7e5, 1.8e5, "assumed").note()
'force scale from an assumed modulus ±27 % (E 0.67 MPa)'
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

from magcilia import _validate as v
from magcilia._display import Display, Item, scaled

#: one psi in Pa (the paper quotes the 300 % modulus as 70 psi = 483 kPa)
PSI = 6894.757293168
#: Kraton D1163P's 300 % modulus as the paper states it (Sec. II: "300% modulus of 483 kPa"), Pa:
#: the engineering stress at 300 % elongation
SIS_300_MODULUS = 70.0 * PSI
#: the stretch at 300 % elongation
STRETCH_300 = 4.0
#: C₂/C₁ of the Mooney–Rivlin readings: from 0 (neo-Hookean) up to about 1, the range of Mooney
#: plots of unfilled rubbers in simple extension (L. R. G. Treloar, The Physics of Rubber
#: Elasticity, 3rd ed., Oxford 1975, ch. 10)
MOONEY_RATIOS = (0.5, 1.0)
#: the Martin–Roth–Stiehler exponent A of unfilled vulcanizates (Wood 1977: about 0.38)
MRS_EXPONENT = 0.38
#: where a setup's modulus comes from (:class:`Modulus`)
SOURCES = ("assumed", "measured", "exact")


def neo_hookean_modulus(stress: float, stretch: float = STRETCH_300) -> float:
    """Small-strain Young's modulus, Pa, of an incompressible neo-Hookean solid whose engineering
    stress at ``stretch`` is ``stress`` (Pa): ``E = 3σ / (λ − λ⁻²)``."""
    return 3.0 * stress / (stretch - stretch**-2)


def mooney_rivlin_modulus(stress: float, ratio: float, stretch: float = STRETCH_300) -> float:
    """Small-strain Young's modulus, Pa, of a Mooney–Rivlin solid with ``C₂/C₁ = ratio`` whose
    engineering stress at ``stretch`` is ``stress`` (Pa): from ``σ = 2(C₁ + C₂/λ)(λ − λ⁻²)`` and
    ``E = 6(C₁ + C₂)``, ``E = 3σ(1 + c) / ((1 + c/λ)(λ − λ⁻²))``; ``ratio = 0`` is neo-Hookean."""
    return 3.0 * stress * (1.0 + ratio) / ((1.0 + ratio / stretch) * (stretch - stretch**-2))


def mrs_modulus(stress: float, exponent: float = MRS_EXPONENT,
                stretch: float = STRETCH_300) -> float:
    """Young's modulus, Pa, from the Martin–Roth–Stiehler relation of rubber in extension,
    ``σ = E (λ⁻¹ − λ⁻²) exp(A(λ − λ⁻¹))`` (engineering stress ``stress``, Pa, at ``stretch``;
    ``exponent`` A)."""
    return stress / ((1.0 / stretch - stretch**-2) * math.exp(exponent * (stretch - 1.0 / stretch)))


def neat_readings(stress: float = SIS_300_MODULUS) -> dict[str, float]:
    """The small-strain moduli (Pa) that the laws of the module docstring read from one 300 %
    modulus ``stress`` (Pa), by name, from the softest reading to the stiffest."""
    out = {"neo-Hookean": neo_hookean_modulus(stress)}
    out.update({f"Mooney-Rivlin C2/C1 = {c:g}": mooney_rivlin_modulus(stress, c)
                for c in MOONEY_RATIOS})
    out[f"Martin-Roth-Stiehler A = {MRS_EXPONENT:g}"] = mrs_modulus(stress)
    return out


def span_centre(readings: dict[str, float]) -> tuple[float, float]:
    """The centre of the readings' span and half the span relative to it (unrounded)."""
    lo, hi = min(readings.values()), max(readings.values())
    return 0.5 * (lo + hi), (hi - lo) / (hi + lo)


def einstein_factor(phi: Any) -> Any:
    """Einstein's dilute stiffening of spheres at volume fraction ``phi``: ``1 + 2.5φ``
    (arrays broadcast)."""
    return 1.0 + 2.5 * phi


def guth_gold_factor(phi: Any) -> Any:
    """Guth–Gold stiffening of spheres at volume fraction ``phi``: ``1 + 2.5φ + 14.1φ²``
    (arrays broadcast)."""
    return 1.0 + 2.5 * phi + 14.1 * phi**2


def composite_modulus(polymer: Any, phi: Any) -> Any:
    """Young's modulus of the filled elastomer, Pa: the neat ``polymer`` modulus (Pa) times the
    Guth–Gold factor of the filler's volume fraction ``phi`` (:func:`guth_gold_factor`); arrays
    broadcast."""
    return polymer * guth_gold_factor(phi)


def filler_uncertainty(phi: float) -> float:
    """Relative 1 σ of the filler law at volume fraction ``phi``: how far Einstein's dilute law
    lies below Guth–Gold, ``1 − (1 + 2.5φ)/(1 + 2.5φ + 14.1φ²)`` (0.091 at the paper's φ)."""
    return 1.0 - einstein_factor(phi) / guth_gold_factor(phi)


_CENTRE, _HALF = span_centre(neat_readings())
#: the neat polymer's default small-strain Young's modulus, Pa: the centre of the readings of the
#: paper's 300 % modulus (0.368–0.619 MPa), to 3 digits (0.493 MPa)
POLYMER_MODULUS = float(f"{_CENTRE:.3g}")
#: its default relative 1 σ: half the readings' span, to 2 digits (0.25)
POLYMER_UNCERTAINTY = float(f"{_HALF:.2g}")


@dataclass(frozen=True, repr=False)
class Modulus(Display):
    """A setup's Young's modulus with its 1 σ and where it comes from (SI).

    Every force and flow figure scales with it, so its uncertainty (the force scale's) is
    systematic: one relative error shared by every reading of the setup (fully correlated).

    Parameters
    ----------
    value : float
        Young's modulus, Pa.
    sigma : float
        Its 1 σ, Pa (0 for ``"exact"``).
    source : {"assumed", "measured", "exact"}
        ``"assumed"``: derived from the material (the polymer's 300 % modulus and a filler law,
        :mod:`magcilia.device.stiffness`); ``"measured"``: given with its σ, or fitted from load
        data; ``"exact"``: given without a σ, taken as exact.
    """

    value: float
    sigma: float
    source: str

    def __post_init__(self) -> None:
        object.__setattr__(self, "value", v.positive("modulus", self.value, "Pa", "modulus"))
        object.__setattr__(self, "sigma", v.non_negative("modulus sigma", self.sigma, "Pa",
                                                         "modulus"))
        object.__setattr__(self, "source", v.choice("source", self.source, SOURCES))

    @property
    def relative(self) -> float:
        """The relative 1 σ, σ/E (0 for a modulus taken as exact)."""
        return 0.0 if self.source == "exact" else self.sigma / self.value

    def note(self) -> str:
        """The one line every force and flow report prints: ``"force scale from an assumed
        modulus ±27 % (E 0.67 MPa)"``, ``"... from a measured modulus ±6.1 % ..."`` or
        ``"force scale: modulus given, taken as exact (E 1 MPa)"``."""
        e = scaled(self.value, 1e6, "MPa")
        if self.source == "exact":
            return f"force scale: modulus given, taken as exact (E {e})"
        article = "an" if self.source == "assumed" else "a"
        return (f"force scale from {article} {self.source} modulus ±{percent(self.relative)} "
                f"(E {e})")

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready content (SI)."""
        return {"value": self.value, "sigma": self.sigma, "relative": self.relative,
                "source": self.source, "note": self.note(), "units": "SI"}

    def report(self) -> str:
        """The note (:meth:`note`)."""
        return self.note()

    def _display_items(self) -> list[Item]:
        return [("", scaled(self.value, 1e6, "MPa")), ("±", percent(self.relative)),
                ("source", self.source)]


def percent(relative: float) -> str:
    """A relative uncertainty as a percentage with two significant digits (``"27 %"``)."""
    return f"{100.0 * relative:.2g} %"
