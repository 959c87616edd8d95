"""The numbers of docs/stiffness.md: the presets' Young's modulus from the paper's 300 % modulus.

Every figure comes from :mod:`magcilia.device.stiffness` (the formulas' one home) and the drag law
of :mod:`magcilia.mechanics.drag`; the page holds this script's output between its markers, and
tests/docs/test_stiffness_page.py checks that it still does.

Run: python scripts/stiffness_table.py            (print the block)
     python scripts/stiffness_table.py --write    (replace the block in docs/stiffness.md)
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np

import magcilia as mc
from magcilia._atomic import write_text
from magcilia.device import stiffness as st
from magcilia.mechanics.drag import WATER, drag_exponent, drag_per_length

PAGE = Path(__file__).resolve().parents[1] / "docs" / "stiffness.md"
START = "<!-- stiffness-table: start (scripts/stiffness_table.py) -->"
END = "<!-- stiffness-table: end -->"
#: the old default, for comparison: Guth–Gold of an unsourced 2.5 MPa polymer
OLD_POLYMER = 2.5e6
#: uniform water speeds of the flow-share table, m/s
SPEEDS = (0.01, 0.05, 0.1, 0.3)

LAWS = {
    "neo-Hookean": "σ = (E/3)(λ − λ⁻²)",
    "Mooney-Rivlin C2/C1 = 0.5": "σ = 2(C₁ + C₂/λ)(λ − λ⁻²), E = 6(C₁ + C₂)",
    "Mooney-Rivlin C2/C1 = 1": "σ = 2(C₁ + C₂/λ)(λ − λ⁻²), E = 6(C₁ + C₂)",
    "Martin-Roth-Stiehler A = 0.38": "σ = E (λ⁻¹ − λ⁻²) exp(A(λ − λ⁻¹))",
}


def mpa(x: float, digits: int = 3) -> str:
    return f"{x / 1e6:.{digits}g}"


def flow_share(setup: mc.Setup, speed: float) -> float:
    """1/n: the drag law's local exponent n averaged over the upright hair with the weight of
    each element's moment about the base (tests/readout/test_force_scale.py checks it against
    the model's own derivative within 2 %)."""
    s = np.linspace(0.0, setup.cilium.height, 401)
    d = 2.0 * setup.cilium.radius(s)
    moment = np.abs(drag_per_length(np.full_like(d, speed), d, WATER)) * s
    n = float(np.sum(moment * drag_exponent(speed, d, WATER)) / np.sum(moment))
    return 1.0 / n


def block() -> str:
    """The generated part of the page (markdown, between the markers)."""
    readings = st.neat_readings()
    centre, half = st.span_centre(readings)
    # the C₂/C₁ whose Mooney–Rivlin reading is the stiffest reading: r = (1 + c)/(1 + c/λ)
    r = max(readings.values()) / st.neo_hookean_modulus(st.SIS_300_MODULUS)
    ratio_inside = (r - 1.0) / (1.0 - r / st.STRETCH_300)
    material = mc.Material()
    phi = material.volume_fraction
    einstein, guth = st.einstein_factor(phi), st.guth_gold_factor(phi)
    filler = st.filler_uncertainty(phi)
    setup = mc.Setup.paper()
    modulus = setup.modulus
    lo = min(readings.values()) * einstein
    hi = max(readings.values()) * guth
    lines = [
        START,
        "",
        f"**Neat polymer** (σ₃₀₀ = {mpa(st.SIS_300_MODULUS)} MPa at λ = {st.STRETCH_300:g}):",
        "",
        "| reading | law | small-strain E (MPa) |",
        "|---|---|---|",
        *(f"| {name} | {LAWS[name]} | {mpa(value)} |" for name, value in readings.items()),
        "",
        f"Mooney–Rivlin readings stay inside the span up to C₂/C₁ = {ratio_inside:.2f}.",
        "",
        (f"Span {mpa(min(readings.values()))}–{mpa(max(readings.values()))} MPa: centre "
        f"{mpa(centre, 4)} MPa, half the span {100 * half:.3g} % of it. Default "
        f"`polymer_modulus` **{mpa(st.POLYMER_MODULUS)} MPa**, "
        f"`polymer_modulus_uncertainty` **{st.POLYMER_UNCERTAINTY:g}** (rounded)."),
        "",
        f"**Filled composite** (30 mg cobalt + 30 mg polymer: φ = {phi:.4f}):",
        "",
        "| filler law | factor | composite E (MPa) |",
        "|---|---|---|",
        f"| Einstein 1 + 2.5φ | {einstein:.4f} | {mpa(st.POLYMER_MODULUS * einstein)} |",
        f"| Guth–Gold 1 + 2.5φ + 14.1φ² | {guth:.4f} | {mpa(st.POLYMER_MODULUS * guth)} |",
        "",
        (f"Guth–Gold is the presets' law; Einstein lies {100 * filler:.2g} % below it (the "
        "filler law's relative 1 σ)."),
        "",
        (f"**The presets' modulus**: E = {mpa(modulus.value)} MPa ± "
        f"{100 * modulus.relative:.2g} % (1 σ = {mpa(modulus.sigma, 2)} MPa; "
        f"√({st.POLYMER_UNCERTAINTY:g}² + {filler:.3f}²) = {modulus.relative:.3f}). Every "
        f"reading of the neat polymer times every filler law lies within "
        f"{mpa(lo)}–{mpa(hi)} MPa."),
        "",
        (f"The old default, Guth–Gold of an unsourced {mpa(OLD_POLYMER, 2)} MPa polymer, was "
        f"{mpa(st.composite_modulus(OLD_POLYMER, phi))} MPa: "
        f"{st.composite_modulus(OLD_POLYMER, phi) / modulus.value:.3g} times the sourced one, "
        "so every absolute force figure made with it was as many times too large."),
        "",
        ("**Flow speeds** share 1/n of the modulus's relative σ (n: the drag law's local exponent, "
        "averaged over the force sensor's hair with the weight of each element's moment about "
        "the base; water, uniform flow):"),
        "",
        "| speed (m/s) | 1/n | σ_U/U |",
        "|---|---|---|",
    ]
    sensor = mc.Setup.paper(tip_radius=5e-5)
    for u in SPEEDS:
        k = flow_share(sensor, u)
        lines.append(f"| {u:g} | {k:.2f} | {100 * k * modulus.relative:.2g} % |")
    lines += ["", END]
    return "\n".join(lines)


def replaced(page: str, new: str) -> str:
    """``page`` with its generated block replaced by ``new``."""
    head, rest = page.split(START, 1)
    _, tail = rest.split(END, 1)
    return head + new + tail


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--write", action="store_true",
                        help=f"replace the block in {PAGE.relative_to(PAGE.parents[1])}")
    args = parser.parse_args()
    text = block()
    if args.write:
        write_text(PAGE, replaced(PAGE.read_text(encoding="utf-8"), text))
        print(f"wrote {PAGE}")
    else:
        print(text)


if __name__ == "__main__":
    main()
