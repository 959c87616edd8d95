"""The [actuation] table of a TOML file (io/actuation_file.py)."""

from __future__ import annotations

from pathlib import Path

import magpylib
import numpy as np
import pytest

import magcilia as mc
from magcilia._errors import MagciliaError
from magcilia.io.actuation_file import load_actuation, read_actuation

SPHERE = '[[actuation.magnets]]\nkind = "sphere"\npolarization = ["0 T", "0 T", "1 T"]\n'
CUBE = ('[[actuation.magnets]]\nkind = "cuboid"\npolarization = ["0 T", "0 T", "1 T"]\n'
        'dimension = ["2 mm", "2 mm", "2 mm"]\n')


def _write(tmp_path: Path, text: str) -> Path:
    p = tmp_path / "act.toml"
    p.write_text(text)
    return p


def test_uniform_field_with_units_and_scale(tmp_path: Path) -> None:
    act = load_actuation(_write(tmp_path, '[actuation]\nfield = ["1 mT", "0 G", "-50 G"]\n'
                                          'scale = 0.5\n'))
    assert act.is_uniform and act.scale == 0.5
    np.testing.assert_allclose(act.uniform_field, [5e-4, 0.0, -2.5e-3], rtol=1e-15)


def test_magnets_match_magpylib(tmp_path: Path) -> None:
    text = """
[[actuation.magnets]]
kind = "cuboid"
polarization = ["0 T", "0 T", "1 T"]
dimension = ["2 mm", "2 mm", "2 mm"]
position = ["15 mm", "0 mm", "0 mm"]

[[actuation.magnets]]
kind = "cylinder"
polarization = ["0 T", "0 T", "1.2 T"]
dimension = ["3 mm", "1 mm"]
position = ["0 mm", "0 mm", "-8 mm"]

[[actuation.magnets]]
kind = "sphere"
polarization = ["500 mT", "0 T", "0 T"]
dimension = "2 mm"
position = ["-10 mm", "5 mm", "0 mm"]
"""
    act = load_actuation(_write(tmp_path, text))
    ref = [magpylib.magnet.Cuboid(polarization=(0, 0, 1), dimension=(2e-3,) * 3,
                                  position=(15e-3, 0, 0)),
           magpylib.magnet.Cylinder(polarization=(0, 0, 1.2), dimension=(3e-3, 1e-3),
                                    position=(0, 0, -8e-3)),
           magpylib.magnet.Sphere(polarization=(0.5, 0, 0), diameter=2e-3,
                                  position=(-10e-3, 5e-3, 0))]
    points = np.array([[0.0, 0.0, 0.0], [1e-3, 2e-3, 3e-3]])
    np.testing.assert_allclose(act.field(points), magpylib.getB(ref, points, sumup=True),
                               rtol=1e-12, atol=1e-18)


def test_the_example_files_load() -> None:
    folder = Path(__file__).resolve().parents[2] / "examples" / "actuation"
    acts = {p.stem: load_actuation(p) for p in sorted(folder.glob("*.toml"))}
    assert set(acts) == {"coil", "magnet"}
    assert acts["coil"].uniform_field.tolist() == pytest.approx([0.0, 0.0, 5e-4])
    b = acts["magnet"].field(np.zeros(3))
    assert b[2] == pytest.approx(-1.886e-4, rel=1e-3) and abs(b[0]) < 1e-12


def test_a_setup_file_may_carry_an_actuation(tmp_path: Path) -> None:
    p = tmp_path / "setup.toml"
    mc.save_setup(mc.Setup.paper(), p)
    assert read_actuation(p) is None
    plain = mc.load_setup(p)
    p.write_text(p.read_text() + '\n[actuation]\nfield = ["0 G", "0 G", "5 G"]\n')
    assert mc.load_setup(p).params() == plain.params()  # the setup ignores the table
    act = read_actuation(p)
    assert act is not None and act.uniform_field.tolist() == pytest.approx([0.0, 0.0, 5e-4])


@pytest.mark.parametrize(
    ("text", "match"),
    [
        ("[cilium]\n", "must be a TOML file with \\[actuation\\]"),
        ('[actuation]\nfield = ["0 G", "0 G"]\n', "field must be a list of 3 values with units"),
        ('[actuation]\nfield = ["0 G", "0 G", "5 mm"]\n', "field must be a list of 3 values"),
        ('[actuation]\nfield = [0, 0, 5]\n', "field must be a list of 3 values"),
        ("[actuation]\n", "must be either field"),
        ('[actuation]\ncurrent = "1 A"\n', "must be one of field, magnets, scale"),
        ('[actuation]\nfield = ["0 G", "0 G", "5 G"]\nscale = "x"\n', "scale must be a finite"),
        ('[[actuation.magnets]]\nkind = "horseshoe"\n', "kind must be one of cuboid"),
        (SPHERE + 'dimension = "-2 mm"\n', "dimension must be positive lengths"),
        (CUBE + 'colour = "red"\n', "must be one of kind"),
    ],
)
def test_bad_actuation_files(tmp_path: Path, text: str, match: str) -> None:
    with pytest.raises(MagciliaError, match=match) as info:
        load_actuation(_write(tmp_path, text))
    assert "\n" not in str(info.value)
