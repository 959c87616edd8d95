"""Validation tables of the bending solver and the drag law (writes docs/mechanics.md).

1. Uniform cantilever under a perpendicular dead tip load, α = P L² / (E I) from 0.1 to 10:
   magcilia's collocation solver vs the exact elastica (elliptic integrals, Bisshopp & Drucker
   1945, ``magcilia.mechanics.cantilever_tip``) and vs linear beam theory (x/L = α/3).
2. Tapered cilium (frustum, tip/base radius λ) under a small tip load: tip deflection vs the exact
   small-load compliance P L³ / (3 E I₀ λ).
3. Cylinder drag coefficient vs Reynolds number: Lamb's Oseen solution and White's correlation.

Run: python scripts/mechanics_validation.py [--out docs/mechanics.md]
"""

from __future__ import annotations

import argparse
import math
from pathlib import Path

import numpy as np

import magcilia as mc
from magcilia._atomic import write_text
from magcilia.mechanics import cantilever_tip, drag_coefficient, tip_compliance

LENGTH, RADIUS, MODULUS = 3e-3, 2e-4, 2e6


def elastica_rows() -> list[str]:
    setup = mc.Setup.paper(height=LENGTH, base_radius=RADIUS, tip_radius=RADIUS,
                           youngs_modulus=MODULUS)
    ei = MODULUS * math.pi * RADIUS**4 / 4.0
    rows = [("| α = PL²/EI | x/L exact | z/L exact | tip angle exact (deg) | x/L magcilia | "
             "rel. error of the tip position | x/L linear theory (α/3) |"),
            "|---|---|---|---|---|---|---|"]
    for alpha in (0.1, 0.3, 1.0, 3.0, 10.0):
        x, z, theta = cantilever_tip(alpha)
        tip = mc.bend(setup, force=alpha * ei / LENGTH**2).tip / LENGTH
        err = math.hypot(tip[0] - x, tip[2] - z) / math.hypot(x, z)
        rows.append(f"| {alpha:g} | {x:.8f} | {z:.8f} | {math.degrees(theta):.4f} | "
                    f"{tip[0]:.8f} | {err:.1e} | {alpha / 3:.4f} |")
    return rows


def taper_rows() -> list[str]:
    rows = ["| λ = r_tip / r_base | exact compliance (m/N) | magcilia (m/N) | rel. error |",
            "|---|---|---|---|"]
    for lam in (0.1, 0.25, 0.5, 1.0):
        setup = mc.Setup.paper(height=LENGTH, base_radius=RADIUS, tip_radius=lam * RADIUS,
                               youngs_modulus=MODULUS)
        exact = tip_compliance(setup)
        force = 1e-6 / exact  # ~1 µm deflection: linear regime
        numeric = mc.bend(setup, force=force).tip[0] / force
        rows.append(f"| {lam:g} | {exact:.6g} | {numeric:.6g} | {abs(numeric / exact - 1):.1e} |")
    return rows


def drag_rows() -> list[str]:
    rows = ["| Re | C_D magcilia | Lamb (Oseen) 8π/(Re(2.002 − ln Re)) | White 1 + 10 Re^(−2/3) |",
            "|---|---|---|---|"]
    for re in (0.01, 0.1, 0.5, 1.0, 10.0, 100.0, 1e3, 1e4, 1e5):
        lamb = 8 * math.pi / (re * (2.002 - math.log(re))) if re < 1.0 else math.nan
        white = 1 + 10 * re ** (-2 / 3) if re >= 1.0 else math.nan
        cd = float(np.asarray(drag_coefficient(re)))
        rows.append(f"| {re:g} | {cd:.4g} | {lamb:.4g} | {white:.4g} |".replace("nan", "–"))
    return rows


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", default="docs/mechanics.md")
    args = parser.parse_args()
    text = "\n".join([
        "# Mechanics validation", "",
        "Made by `scripts/mechanics_validation.py`. SI inside; lengths over L in the tables.", "",
        (f"## Uniform cantilever vs the exact elastica (L = {LENGTH * 1e3:g} mm, r = "
        f"{RADIUS * 1e3:g} mm, E = {MODULUS / 1e6:g} MPa)"), "",
        *elastica_rows(), "",
        "Linear theory is already 10 % off at α = 1; the collocation solver agrees with the exact",
        "elastica to near machine precision over the whole range.", "",
        "## Tapered cilium: small-load tip compliance vs P L³ / (3 E I₀ λ)", "",
        *taper_rows(), "",
        "The residual ~1e-7 is the geometric nonlinearity of the 1 µm test deflection. A sharp",
        "cone (λ = 0) has infinite compliance under a tip load: magcilia refuses it and",
        "asks for a tip radius (or a load below the tip).", "",
        "## Cylinder drag coefficient", "",
        *drag_rows(), "",
        "Between Re 0.5 and 1 magcilia blends the two laws smoothly (C¹); above Re = 2e5 (the drag",
        "crisis) it refuses the flow speed. White's correlation (Viscous Fluid Flow, 1991) is a",
        "curve fit to cylinder measurements, good to roughly ±10 %; drag per unit length is",
        "½ ρ U_n² d C_D with the velocity component normal to the local centreline (tangential",
        "friction neglected).", "",
    ])
    write_text(Path(args.out), text)
    print(text)


if __name__ == "__main__":
    main()
