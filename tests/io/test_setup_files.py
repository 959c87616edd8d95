"""Setup TOML files and unit-bearing values."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

import magcilia as mc
from magcilia.units import parse_quantity

EXAMPLES = Path(__file__).resolve().parents[2] / "examples"


@pytest.mark.parametrize(
    ("text", "dimension", "value"),
    [("3.0 mm", "length", 3e-3), ("30 mg", "mass", 30e-6), ("7.5 V", "voltage", 7.5),
     ("6 gauss", "field", 6e-4), ("1.0 mV/V/gauss", "sensitivity", 10.0),
     ("0.92 g/cm^3", "density", 920.0), ("2.5 MPa", "pressure", 2.5e6),
     ("-1e-3 V", "voltage", -1e-3)],
)
def test_parse_quantity(text: str, dimension: str, value: float) -> None:
    assert parse_quantity(text, dimension, "key") == pytest.approx(value, rel=1e-12)


@pytest.mark.parametrize("text", ["3.0", "3 kg", "mm", "3.0 mm extra", "nan mm", "1e999 mm"])
def test_parse_quantity_errors_name_the_key(text: str) -> None:
    with pytest.raises(mc.MagciliaError, match=r"cilium\.height must be a length with a unit"):
        parse_quantity(text, "length", "cilium.height")


def test_round_trip(tmp_path: Path) -> None:
    s = mc.Setup.paper(tip_radius=3e-5, youngs_modulus=2.2e6, ring="rms", magnetization_scale=0.3,
                       offset=-1.5e-3, gain=20.0, n_loops=4)
    path = tmp_path / "s.toml"
    mc.save_setup(s, path)
    back = mc.load_setup(path)
    assert back.params().keys() == s.params().keys()
    for key, value in s.params().items():
        assert back.params()[key] == pytest.approx(value, rel=1e-11)
    assert back.ring == "rms" and back.cilium.youngs_modulus == pytest.approx(2.2e6)
    np.testing.assert_allclose(back.output([0.0, 0.5]), s.output([0.0, 0.5]), rtol=1e-10)


def test_bundled_example_is_the_paper() -> None:
    s = mc.load_setup(EXAMPLES / "paper.toml")
    ref = mc.Setup.paper()
    for key, value in ref.params().items():
        assert s.params()[key] == pytest.approx(value, rel=1e-12)
    np.testing.assert_allclose(s.output([0.0, 1.0]), ref.output([0.0, 1.0]), rtol=1e-12)


@pytest.mark.parametrize(
    ("text", "match"),
    [
        ('[cilium]\nheight = 3.0\n', r"cilium\.height must be a length with a unit"),
        ('[cilium]\nheigth = "3 mm"\n', r"cilium\.heigth must be one of height"),
        ('[cilium]\nheight = "-3 mm"\n', "height must be a positive length"),
        ('[wiring]\nx = 1\n', r"table \[wiring\] must be one of"),
        ('[model]\nn_loops = 0\n', r"model\.n_loops must be an integer >= 1"),
        ('[model]\nring = "max"\n', r"model\.ring must be one of"),
        ('[sensor]\npreset = "HMC5883"\n', r"sensor\.preset must be one of"),
        ('[cilium\nheight = "3 mm"\n', "is not valid TOML"),
        ('[cilium]\ntip_radius = "1 mm"\n', "tip_radius must be at most base_radius"),
    ],
    ids=["unitless", "unknown-key", "negative", "unknown-table", "n0", "ring", "preset", "syntax",
         "tip>base"],
)
def test_bad_setup_files(tmp_path: Path, text: str, match: str) -> None:
    path = tmp_path / "bad.toml"
    path.write_text(text)
    with pytest.raises(mc.MagciliaError, match=match) as info:
        mc.load_setup(path)
    assert "\n" not in str(info.value)
    assert str(path) in str(info.value)
