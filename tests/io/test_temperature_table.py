"""A setup file's ``[temperature]`` table (issue #29 item 4): units, σ, the calibrated range, the
errors, and the setup that leaves it alone."""

from __future__ import annotations

from pathlib import Path

import pytest

import magcilia as mc
from magcilia.io.setup_files import load_setup
from magcilia.io.temperature_table import load_temperature, temperature_from_dict

TABLE = '''
[cilium]
height = "3.2613 mm"

[temperature]
reference = "25 degC"
drive = "current"
sensitivity_tempco = "-0.27 %/K ± 0.01 %/K"
offset_tempco = "1 mG/K"
modulus_tempco = "0 ppm/K"
magnetization_tempco = "-50 ppm/degC +- 20 ppm/degC"
temperature_sigma = "50 mK"
calibrated_range = "293.15 K:30 degC"
'''


def test_the_table_in_si(tmp_path: Path) -> None:
    path = tmp_path / "s.toml"
    path.write_text(TABLE, encoding="utf-8")
    m = load_temperature(path)
    assert m is not None
    assert m.reference == pytest.approx(298.15) and m.drive == "current"
    assert m.sensitivity_tempco == pytest.approx(-2.7e-3)
    assert m.sensitivity_tempco_sigma == pytest.approx(1e-4)
    assert m.offset_tempco == pytest.approx(1e-7) and m.offset_tempco_sigma == 0.0  # exact
    assert m.modulus_tempco == 0.0
    assert m.magnetization_tempco == pytest.approx(-5e-5)
    assert m.magnetization_tempco_sigma == pytest.approx(2e-5)
    assert m.temperature_sigma == pytest.approx(0.05)
    assert m.calibrated_range == pytest.approx((293.15, 303.15))
    defaults = mc.TemperatureModel()
    assert m.bridge_resistance_tempco == defaults.bridge_resistance_tempco  # left out: default
    assert load_setup(path).cilium.height == pytest.approx(3.2613e-3)  # the setup ignores it
    assert mc.ThermalReadout(mc.Readout(mc.Setup.paper(), span=(0.0, 0.5), table_size=17),
                             m).calibrated_range == pytest.approx((293.15, 303.15))


def test_a_file_without_the_table(tmp_path: Path) -> None:
    path = tmp_path / "s.toml"
    path.write_text('[cilium]\nheight = "3 mm"\n', encoding="utf-8")
    assert load_temperature(path) is None


@pytest.mark.parametrize(("table", "match"), [
    ({"sensitivity": "-3000 ppm/K"}, r"\[temperature\] key must be one of reference, drive"),
    ({"reference": "20"}, r"temperature.reference must be an absolute temperature with a unit"),
    ({"reference": "-300 degC"}, "above absolute zero"),
    ({"sensitivity_tempco": "-3000 ppm"}, r"sensitivity_tempco must be a tempco with a unit"),
    ({"offset_tempco": "1 mV/K"}, r"offset_tempco must be a field drift with a unit"),
    ({"modulus_tempco": "1 ppm/K +- 1 ppm/K +- 2 ppm/K"}, "optional sigma"),
    ({"magnetization_tempco": "1 ppm/K +- -1 ppm/K"}, "magnetization_tempco_sigma"),
    ({"drive": "pulsed"}, r"temperature.drive must be one of 'voltage', 'current'"),
    ({"calibrated_range": "293 K"}, "LOW:HIGH"),
    ({"calibrated_range": "30 degC:20 degC"}, "high ≥ low"),
    ("nope", r"\[temperature\] must be a table"),
])
def test_bad_tables_are_one_line_errors(table: object, match: str) -> None:
    with pytest.raises(mc.MagciliaError, match=match) as info:
        temperature_from_dict(table, "s.toml")
    assert "\n" not in str(info.value)
