"""docs/stiffness.md holds the numbers scripts/stiffness_table.py prints from the library (the
derivation's one home, magcilia.device.stiffness), and its prose quotes no other modulus."""

from __future__ import annotations

import importlib.util
import re
from pathlib import Path
from types import ModuleType

import magcilia as mc
from magcilia.device import stiffness as st

ROOT = Path(__file__).resolve().parents[2]
PAGE = ROOT / "docs" / "stiffness.md"


def _script() -> ModuleType:
    spec = importlib.util.spec_from_file_location("stiffness_table",
                                                  ROOT / "scripts" / "stiffness_table.py")
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def test_the_page_holds_the_scripts_numbers() -> None:
    script = _script()
    page = PAGE.read_text(encoding="utf-8")
    block = script.block()
    assert block in page, "run python scripts/stiffness_table.py --write"
    assert script.replaced(page, block) == page


def test_the_prose_quotes_only_the_inputs_and_the_generated_figures() -> None:
    page = PAGE.read_text(encoding="utf-8")
    head, rest = page.split(_script().START, 1)
    _, tail = rest.split(_script().END, 1)
    block = _script().block()
    inputs = {"483 kPa", "70 psi"}
    for number in re.findall(r"\d+(?:\.\d+)? (?:MPa|kPa|psi|%)", head + tail):
        assert number in inputs or number in block or number in ("300 %",), number


def test_the_default_is_the_papers_material_within_the_range() -> None:
    """The presets' modulus lies within the paper-derived range 0.3–0.9 MPa, from the 300 %
    modulus the paper states (483 kPa); its σ is the readings' spread."""
    setup = mc.Setup.paper()
    assert 0.3e6 <= setup.youngs_modulus <= 0.9e6
    assert st.SIS_300_MODULUS == 70 * st.PSI and abs(st.SIS_300_MODULUS - 483e3) < 1e3
    assert mc.load_setup(ROOT / "examples" / "force-sensor.toml").youngs_modulus == \
        setup.youngs_modulus
    assert 0.2 < setup.youngs_modulus_uncertainty < 0.35
    assert setup.modulus.source == "assumed"
