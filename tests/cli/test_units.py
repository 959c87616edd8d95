"""The unit policy of the command line (issue 13, item 3): a command's console, CSV and JSON agree;
keys and columns carry units; ``--si`` gives SI everywhere; every physical option takes unit
strings, a bare number meaning the option's display unit; echoes use the units typed."""

from __future__ import annotations

import csv
import json
import math
import re
from pathlib import Path

import numpy as np
import pytest

from magcilia._errors import MagciliaError
from magcilia.cli import main
from magcilia.cli._common import parse_named_ranges
from magcilia.cli.readout import parse_span
from magcilia.io.recordings import example_path
from magcilia.report.units import output_units
from magcilia.units import OutputUnits, parse_range, parse_value, parse_values

TIP = ["--tip-radius", "0.05mm"]
GAUSS = 1e-4


def run_json(capsys: pytest.CaptureFixture[str], args: list[str]) -> dict:
    assert main(args) == 0
    return json.loads(capsys.readouterr().out)


def run_text(capsys: pytest.CaptureFixture[str], args: list[str]) -> str:
    assert main(args) == 0
    return capsys.readouterr().out


def close(a: object, b: object, rel: float = 1e-9, key: str = "") -> bool:
    """Whether two JSON-like documents are equal, numbers within ``rel``.

    The same request spelled in two units reaches the solvers with inputs that may differ in
    their last bit (0.1 mN and 100 uN), so results are compared at ``rel`` and the numbers that
    are rounding noise by nature are compared by what they mean: a solver's residual (``key``
    starting with "residual") only has to be converged in both, and a vector's component is
    compared within ``rel`` of the vector's largest component (a 0 against 1e-17)."""
    if isinstance(a, dict) and isinstance(b, dict):
        return a.keys() == b.keys() and all(close(a[k], b[k], rel, k) for k in a)
    if isinstance(a, list | tuple) and isinstance(b, list | tuple):
        if len(a) != len(b):
            return False
        numbers = [abs(x) for x in (*a, *b) if _number(x)]
        floor = rel * max(numbers, default=0.0)
        return all(close(x, y, rel, key) if not (_number(x) and _number(y))
                   else x == pytest.approx(y, rel=rel, abs=max(floor, 1e-300))
                   for x, y in zip(a, b, strict=True))
    if _number(a) and _number(b):
        if key.startswith("residual"):
            return abs(a) < 1e-9 and abs(b) < 1e-9  # type: ignore[operator]
        return a == pytest.approx(b, rel=rel, abs=1e-300)
    return a == b


def _number(x: object) -> bool:
    return isinstance(x, float | int) and not isinstance(x, bool)


def number_after(text: str, label: str) -> float:
    """The first number after ``label`` in ``text``."""
    match = re.search(re.escape(label) + r"\s*([-+]?[\d.]+(?:e[-+]?\d+)?)", text)
    assert match is not None, (label, text)
    return float(match.group(1))


# -- the parsers ---------------------------------------------------------------------------------

@pytest.mark.parametrize(
    ("text", "dimension", "unit", "counts", "expected"),
    [
        ("0:0.2mN", "force", "mN", (2,), [0.0, 2e-4]),
        ("0mN:0.2mN", "force", "mN", (2,), [0.0, 2e-4]),
        ("0:200uN", "force", "mN", (2,), [0.0, 2e-4]),
        ("0:0.2", "force", "mN", (2,), [0.0, 2e-4]),
        ("2mm:4mm", "length", "mm", (2,), [2e-3, 4e-3]),
        ("2mm:0.4cm", "length", "mm", (2,), [2e-3, 4e-3]),
        ("-1:1 mm", "length", "mm", (2,), [-1e-3, 1e-3]),
        ("0:85:5deg", "angle", "deg", (2, 3), [0.0, math.radians(85), math.radians(5)]),
        ("0:1.5rad", "angle", "deg", (2, 3), [0.0, 1.5]),
        ("0.5Hz:0.5kHz", "frequency", "Hz", (2,), [0.5, 500.0]),
        ("1:10", None, "", (2,), [1.0, 10.0]),
    ],
)
def test_parse_values_forms(text: str, dimension: str | None, unit: str,
                            counts: tuple[int, ...], expected: list[float]) -> None:
    np.testing.assert_allclose(parse_values(text, dimension, unit, "--x", counts), expected,
                               rtol=1e-12)


@pytest.mark.parametrize(
    ("text", "dimension", "unit", "counts"),
    [("0:1mm", "force", "mN", (2,)), ("1:2:3", "force", "mN", (2,)), ("a:b", "angle", "deg", (2,)),
     ("1mm:2", None, "", (2,)), ("0:inf", "length", "mm", (2,)), ("1e400:2", "length", "mm", (2,)),
     (":", "length", "mm", (2,)), ("3", "length", "mm", (2,))],
)
def test_parse_values_refuses_in_one_line(text: str, dimension: str | None, unit: str,
                                          counts: tuple[int, ...]) -> None:
    with pytest.raises(MagciliaError, match=r"^--x must be .*; got ") as info:
        parse_values(text, dimension, unit, "--x", counts)
    assert "\n" not in str(info.value)


def test_value_and_range_helpers() -> None:
    assert parse_value("50um", "length", "mm", "--tip-radius") == pytest.approx(5e-5)
    assert parse_value("0.05", "length", "mm", "--tip-radius") == pytest.approx(5e-5)
    with pytest.raises(MagciliaError, match="with a length unit"):
        parse_value("2MPa", "length", "mm", "--tip-radius")
    assert parse_range("0:85:5", "--angles") == pytest.approx(
        (0.0, math.radians(85), math.radians(5)))
    assert parse_span("0:0.2mN", "force") == parse_span("0mN:0.2mN", "force") == pytest.approx(
        (0.0, 2e-4))
    assert parse_span("-10:1rad", "angle") == pytest.approx((-10.0, 1.0))  # both in rad
    assert parse_span("0:60", "angle") == pytest.approx((0.0, math.radians(60)))


def test_named_ranges_echo_in_the_units_typed() -> None:
    names = ("height", "z", "n_loops")
    assert close(parse_named_ranges("--bound", ("height=2mm:4mm", "z=0:0.8", "n_loops=1:4"),
                                    names),
                 {"height": (2e-3, 4e-3), "z": (0.0, 8e-4), "n_loops": (1.0, 4.0)})
    with pytest.raises(MagciliaError) as info:
        parse_named_ranges("--bound", ("height=-1:4",), names)
    message = str(info.value)
    assert "'height=-1:4'" in message and "mm" in message and "0.004" not in message
    with pytest.raises(MagciliaError, match="each a number in mm or with a length unit"):
        parse_named_ranges("--bound", ("z=0:1N",), names)
    with pytest.raises(MagciliaError, match="LOW <= HIGH; got 'height=4mm:2mm'"):
        parse_named_ranges("--bound", ("height=4mm:2mm",), names)


def test_output_units_follow_the_registry() -> None:
    display, si = output_units(), output_units(si=True)
    assert [display.unit(w) for w in ("angle", "force", "flow", "field", "output", "height",
                                      "bridge_voltage", "n_loops")] == [
        "deg", "mN", "m/s", "gauss", "mV", "mm", "V", ""]
    assert [si.unit(w) for w in ("angle", "force", "flow", "field", "output", "height")] == [
        "rad", "N", "m/s", "T", "V", "m"]
    assert display.key("sigma_force", "force") == "sigma_force_mN"
    assert display.key("sensitivity", "sensitivity") == "sensitivity_mV_per_V_per_gauss"
    doc = {"tip_m": [1e-3, 2e-3], "angle_rad": math.pi, "slope_V_per_rad": 1.0, "cost_V2": 2.0,
           "flow_m_per_s": 0.5, "nested": [{"Bx_T": 1e-4}], "n": 3, "label_V": "text",
           "dipoles_per_loop": 5, "none_V": None}
    shown = display.convert(doc)
    assert close(shown, {
        "tip_mm": [1.0, 2.0], "angle_deg": 180.0, "slope_mV_per_deg": 1e3 * math.pi / 180,
        "cost_V2": 2.0, "flow_m_per_s": 0.5, "nested": [{"Bx_gauss": 1.0}], "n": 3,
        "label_mV": "text", "dipoles_per_loop": 5, "none_mV": None})
    assert close(si.convert(shown), doc)  # and back


def test_output_units_without_registry() -> None:
    u = OutputUnits(False, {"length": "mm"})
    assert u.convert({"at_m": 0.0025, "knots_rad": [0.0], "knots_deg": [0.0]}) == {
        "at_mm": 2.5, "knots_rad": [0.0]}  # rad has no display unit here; the copy is kept


# -- each command: console, CSV and JSON agree; --si is display times the factor ------------------

def test_field_console_csv_json_agree(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    csv_path, si_csv = tmp_path / "f.csv", tmp_path / "si.csv"
    out = run_text(capsys, ["field", "paper", "--angles", "0:10:5", "--csv", str(csv_path)])
    doc = run_json(capsys, ["field", "paper", "--angles", "0:10:5", "--json"])
    rows = list(csv.DictReader(csv_path.read_text().splitlines()))
    header, *lines = out.splitlines()
    assert header.split()[1:] == ["angle/deg", "Bx/gauss", "By/gauss", "Bz/gauss", "output/mV"]
    assert list(rows[0]) == ["setup", "angle_deg", "Bx_gauss", "By_gauss", "Bz_gauss",
                             "output_mV", "flag"]
    for line, row, item in zip(lines, rows, doc["rows"], strict=True):
        shown = [float(x) for x in line.split()[1:6]]
        for value, key in zip(shown, list(row)[1:6], strict=True):
            assert value == pytest.approx(float(row[key]), rel=1e-5, abs=1e-9)
            assert float(row[key]) == pytest.approx(item[key], rel=1e-15)
    assert doc["units"] == "display"
    si = run_json(capsys, ["field", "paper", "--angles", "0:10:5", "--json", "--si",
                           "--csv", str(si_csv)])
    assert si["units"] == "SI"
    for d, s in zip(doc["rows"], si["rows"], strict=True):
        assert s["angle_rad"] == pytest.approx(math.radians(d["angle_deg"]), rel=1e-12)
        assert s["Bx_T"] == pytest.approx(d["Bx_gauss"] * GAUSS, rel=1e-12)
        assert s["output_V"] == pytest.approx(d["output_mV"] * 1e-3, rel=1e-12)
    assert next(csv.DictReader(si_csv.read_text().splitlines()))["output_V"]
    assert "angle/rad" in run_text(capsys, ["field", "paper", "--angles", "0:10:5", "--si"])


def test_bend_console_json_agree(capsys: pytest.CaptureFixture[str]) -> None:
    args = ["bend", "paper", *TIP, "--force", "0.1mN"]
    out = run_text(capsys, args)
    doc = run_json(capsys, [*args, "--json"])
    assert number_after(out, "tip angle") == pytest.approx(doc["tip_angle_deg"], rel=1e-5)
    assert number_after(out, "output") == pytest.approx(doc["output_mV"], rel=1e-8)
    assert number_after(out, "(Bx") == pytest.approx(doc["Bx_gauss"], rel=1e-5)
    assert number_after(out, "tip position  x") == pytest.approx(doc["tip_mm"][0], rel=1e-5)
    assert " mV (Bx" in out and " gauss)" in out
    si = run_json(capsys, [*args, "--json", "--si"])
    assert si["units"] == "SI" and si["load"]["force_N"] == pytest.approx(1e-4)
    np.testing.assert_allclose(si["tip_m"], np.array(doc["tip_mm"]) * 1e-3, rtol=1e-12)
    np.testing.assert_allclose(si["centreline_m"]["x"],
                               np.array(doc["centreline_mm"]["x"]) * 1e-3, rtol=1e-12)
    assert si["tip_angle_rad"] == pytest.approx(math.radians(doc["tip_angle_deg"]), rel=1e-12)
    assert si["output_V"] == pytest.approx(doc["output_mV"] * 1e-3, rel=1e-12)
    assert si["Bx_T"] == pytest.approx(doc["Bx_gauss"] * GAUSS, rel=1e-12)
    si_out = run_text(capsys, [*args, "--si"])
    assert number_after(si_out, "tip angle") == pytest.approx(si["tip_angle_rad"], rel=1e-5)
    assert " rad" in si_out and " V (Bx" in si_out and " T)" in si_out


def test_design_console_json_agree(capsys: pytest.CaptureFixture[str]) -> None:
    out = run_text(capsys, ["design", "force-sensor"])
    doc = run_json(capsys, ["design", "force-sensor", "--json"])
    force = doc["metrics"]["force"]
    row = next(line for line in out.splitlines() if line.startswith("force"))
    # each in the unit printed beside it (a µN-scale minimum in µN, issue 30): in mN here
    found = re.findall(r"([-+]?\d[\d.]*(?:e[-+]?\d+)?) (\S+)", row)[:3]
    numbers = [float(x) * (1e-3 if unit == "µN" else 1.0) for x, unit in found]
    assert numbers == pytest.approx([force["sensitivity_mV_per_mN"], force["minimum_mN"],
                                     force["range_mN"]], rel=1e-3)
    assert number_after(out, "noise") == pytest.approx(doc["noise_mV"], rel=1e-3)
    si = run_json(capsys, ["design", "force-sensor", "--json", "--si"])
    sf = si["metrics"]["force"]
    assert sf["minimum_N"] == pytest.approx(force["minimum_mN"] * 1e-3, rel=1e-12)
    assert sf["sensitivity_V_per_N"] == pytest.approx(force["sensitivity_mV_per_mN"], rel=1e-12)
    angle, sa = doc["metrics"]["angle"], si["metrics"]["angle"]
    assert sa["range_rad"] == pytest.approx(math.radians(angle["range_deg"]), rel=1e-12)
    assert sa["sensitivity_V_per_rad"] == pytest.approx(
        angle["sensitivity_mV_per_deg"] * 1e-3 / math.radians(1.0), rel=1e-12)
    assert si["metrics"]["flow"]["minimum_m_per_s"] == pytest.approx(
        doc["metrics"]["flow"]["minimum_m_per_s"], rel=1e-12)
    assert "V/N" in run_text(capsys, ["design", "force-sensor", "--si"])


def test_approximate_console_json_agree(capsys: pytest.CaptureFixture[str]) -> None:
    args = ["approximate", "paper", "--table-size", "16"]
    out = run_text(capsys, args)
    doc = run_json(capsys, [*args, "--json"])
    assert number_after(out, "max error") == pytest.approx(doc["max_error_mV"], rel=1e-3)
    assert number_after(out, "error bound") == pytest.approx(
        doc["lookup_table"]["error_bound_deg"], rel=1e-3)
    node = out.splitlines()[3].split()  # node 1: angle, output, slope
    assert [float(x) for x in node[1:4]] == pytest.approx(
        [doc["knots_deg"][1], doc["values_mV"][1], doc["slopes_mV_per_deg"][1]], rel=1e-5)
    si = run_json(capsys, [*args, "--json", "--si"])
    np.testing.assert_allclose(si["knots_rad"], np.radians(doc["knots_deg"]), rtol=1e-12)
    np.testing.assert_allclose(si["values_V"], np.array(doc["values_mV"]) * 1e-3, rtol=1e-12)
    assert si["lookup_table"]["x_step_V"] == pytest.approx(
        doc["lookup_table"]["x_step_mV"] * 1e-3, rel=1e-12)
    assert "knots_deg" not in si and "max_angle_error_rad" in si


def test_record_console_json_agree(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    args = ["record", "--angles", "0:10:5", "--samples", "20", "--seed", "3"]
    out = run_text(capsys, [*args, "--out", str(tmp_path / "a.tdms")])
    doc = run_json(capsys, [*args, "--out", str(tmp_path / "b.tdms"), "--json"])
    si = run_json(capsys, [*args, "--out", str(tmp_path / "c.tdms"), "--json", "--si"])
    for line, point, p_si in zip(out.splitlines(), doc["points"], si["points"], strict=False):
        angle, mean = (float(x) for x in re.findall(r"[-+]?\d[\d.]*", line)[:2])
        assert angle == pytest.approx(point["angle_deg"], abs=1e-3)
        assert mean == pytest.approx(point["mean_mV"], rel=1e-5)
        assert p_si["mean_V"] == pytest.approx(point["mean_mV"] * 1e-3, rel=1e-12)
        assert p_si["angle_rad"] == pytest.approx(math.radians(point["angle_deg"]), abs=1e-15)
    assert doc["units"] == "display" and si["units"] == "SI"


def test_sensitivity_console_json_agree(tmp_path: Path,
                                        capsys: pytest.CaptureFixture[str]) -> None:
    args = ["sensitivity", "paper", "--points", "3", "--map-points", "3", "--sobol-base", "0",
            "--span", "height=2.5mm:3.5mm"]
    out = run_text(capsys, [*args, "--out", str(tmp_path / "a")])
    doc = json.loads((tmp_path / "a" / "sensitivity.json").read_text())
    row = next(r for r in doc["summary"] if r["parameter"] == "height")
    line = next(x for x in out.splitlines() if x.startswith("height"))
    assert "2.5..3.5 mm" in line
    assert float(line.split()[-2]) == pytest.approx(row["max_rms_change_mV"], rel=1e-3)
    assert row["span_mm"] == pytest.approx([2.5, 3.5])
    assert doc["sweeps"]["height"]["values_mm"][0] == pytest.approx(2.5)
    assert number_after(out, "x must be known to ±") == pytest.approx(
        doc["tolerance"]["tolerance_mm"][0], rel=1e-2)
    si = run_json(capsys, [*args, "--out", str(tmp_path / "b"), "--si", "--json"])
    assert si == json.loads((tmp_path / "b" / "sensitivity.json").read_text())
    assert "| height | 2.5..3.5 mm |" in (tmp_path / "a" / "summary.md").read_text()
    summary = (tmp_path / "b" / "summary.md").read_text()
    assert "max RMS change (V)" in summary and "| height | 0.0025..0.0035 m |" in summary
    row_si = next(r for r in si["summary"] if r["parameter"] == "height")
    assert row_si["span_m"] == pytest.approx([2.5e-3, 3.5e-3])
    assert row_si["max_rms_change_V"] == pytest.approx(row["max_rms_change_mV"] * 1e-3,
                                                       rel=1e-12)
    assert si["tolerance"]["tolerance_m"][0] == pytest.approx(
        doc["tolerance"]["tolerance_mm"][0] * 1e-3, rel=1e-12)
    assert si["sweeps"]["x"]["angles_rad"][1] == pytest.approx(
        math.radians(doc["sweeps"]["x"]["angles_deg"][1]), rel=1e-12)


def test_calibrate_console_json_agree(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    args = ["calibrate", str(example_path()), "--setup", "paper", "--quiet", "--starts", "16",
            "--bound", "height=3.2613mm:3.2613mm", "--bound", "base_radius=0.1801:0.1801",
            "--bound", "n_loops=2:2", "--bound", "dipoles_per_loop=5:5"]
    out = run_text(capsys, [*args, "--out", str(tmp_path / "a")])
    doc = run_json(capsys, [*args, "--out", str(tmp_path / "b"), "--json"])
    si = run_json(capsys, [*args, "--out", str(tmp_path / "c"), "--json", "--si"])
    x_line = next(x for x in out.splitlines() if x.startswith("x "))
    assert x_line.split()[1] == "mm"
    assert float(x_line.split()[3]) == pytest.approx(doc["values"]["x_mm"], rel=1e-5)
    assert number_after(out, "RMS") == pytest.approx(doc["rms_mV"], rel=1e-3)
    assert si["values"]["x_m"] == pytest.approx(
        doc["values"]["x_mm"] * 1e-3, rel=1e-12)
    assert si["values"]["offset_V"] == pytest.approx(doc["values"]["offset_mV"] * 1e-3,
                                                     rel=1e-12)
    assert si["bounds"]["height_m"] == pytest.approx([3.2613e-3, 3.2613e-3])
    assert doc["table"][2] == {**doc["table"][2], "parameter": "x", "unit": "mm"}
    i = doc["covariance"]["names"].index("x")
    assert si["covariance"]["matrix"][i][i] == pytest.approx(
        doc["covariance"]["matrix"][i][i] * 1e-6, rel=1e-12)
    saved = json.loads((tmp_path / "b" / "result.json").read_text())
    assert saved["units"] == "SI" and saved["values"]["x"] == pytest.approx(si["values"]["x_m"])
    si_out = run_text(capsys, [*args, "--out", str(tmp_path / "d"), "--si"])
    x_si = next(x for x in si_out.splitlines() if x.startswith("x "))
    assert x_si.split()[1] == "m" and float(x_si.split()[3]) == pytest.approx(
        si["values"]["x_m"], rel=1e-5)


def test_calibration_result_json_reads_back(tmp_path: Path,
                                            capsys: pytest.CaptureFixture[str]) -> None:
    """result.json keeps the SI to_dict() format, with its marker, for --calibration."""
    from magcilia.calibration import ParameterCovariance

    assert main(["calibrate", str(example_path()), "--setup", "paper", "--quiet", "--starts",
                 "8", "--out", str(tmp_path / "cal")]) == 0
    capsys.readouterr()
    covariance = ParameterCovariance.load(tmp_path / "cal")
    assert "x" in covariance.stderr


# -- every physical option takes a unit string; a wrong dimension is a one-line error -----------

@pytest.mark.parametrize(
    ("plain", "with_units"),
    [
        (["bend", "paper", "--tip-radius", "0.05", "--force", "0.1", "--at", "3",
          "--direction", "90"],
         ["bend", "paper", "--tip-radius", "50um", "--force", "100uN", "--at", "0.3cm",
          "--direction", f"{math.pi / 2!r}rad"]),
        (["bend", "paper", *TIP, "--flow", "0.1", "--shear-height", "3"],
         ["bend", "paper", *TIP, "--flow", "100mm/s", "--shear-height", "3mm"]),
        (["bend", "paper", "--tip-radius", "0.05", "--modulus", "2", "--force", "0.1"],
         ["bend", "paper", "--tip-radius", "0.05mm", "--modulus", "2000kPa", "--force", "0.1mN"]),
        (["design", "force-sensor", "--bandwidth", "0.5:500"],
         ["design", "force-sensor", "--bandwidth", "0.5Hz:0.5kHz"]),
        (["field", "paper", "--angles", "0:10:5"], ["field", "paper", "--angles", "0deg:10deg:5"]),
        (["approximate", "paper", "--range", "0:60"],
         ["approximate", "paper", "--range", f"0:{math.radians(60)!r}rad"]),
    ],
    ids=["bend-force", "bend-flow", "modulus", "bandwidth", "angles", "range"],
)
def test_unit_strings_equal_bare_display_numbers(plain: list[str], with_units: list[str],
                                                 capsys: pytest.CaptureFixture[str]) -> None:
    a = run_json(capsys, [*plain, "--json"])
    b = run_json(capsys, [*with_units, "--json"])
    assert close(a, b, rel=1e-9)


def test_unit_strings_on_acquisition_and_readout(tmp_path: Path,
                                                 capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["record", "--angles", "0:10:5deg", "--samples", "10", "--settle", "1ms",
                 "--rate", "1kHz", "--out", str(tmp_path / "r.tdms"), "--quiet"]) == 0
    capsys.readouterr()
    doc = run_json(capsys, ["record", "--duration", "100ms", "--rate", "2kHz",
                            "--out", str(tmp_path / "s.tdms"), "--json"])
    assert doc["units"] == "display" and doc["samples"] > 0
    rec = tmp_path / "v.csv"
    rec.write_text("voltage_V\n0.0030\n0.0031\n")
    a, b = tmp_path / "a.csv", tmp_path / "b.csv"
    for span, out in (("0:0.2", a), ("0mN:200uN", b)):
        assert main(["readout", "force-sensor", str(rec), "--quantity", "force", "--span", span,
                     "--out", str(out)]) == 0
    assert a.read_text() == b.read_text()


@pytest.mark.parametrize(
    ("args", "option"),
    [
        (["field", "--setup", "paper", "--angles", "0:10:5mm"], "--angles"),
        (["bend", "--setup", "paper", *TIP, "--tip-force", "0.1mm"], "--tip-force"),
        (["bend", "--setup", "paper", *TIP, "--tip-force", "0.1", "--at", "2mN"], "--at"),
        (["bend", "--setup", "paper", *TIP, "--tip-force", "0.1", "--direction", "90mm"],
         "--direction"),
        (["bend", "--setup", "paper", *TIP, "--flow", "1mm"], "--flow"),
        (["bend", "--setup", "paper", *TIP, "--flow", "1", "--shear-height", "1s"],
         "--shear-height"),
        (["bend", "--setup", "paper", "--tip-radius", "5deg"], "--tip-radius"),
        (["bend", "--setup", "paper", "--modulus", "5mm"], "--modulus"),
        (["design", "--setup", "paper", "--bandwidth", "1s:2s"], "--bandwidth"),
        (["approximate", "--setup", "paper", "--range", "0:1V"], "--range"),
        (["sensitivity", "--setup", "paper", "--out", "{tmp}/s", "--sweep", "x=0:1N"], "--sweep"),
        (["sensitivity", "--setup", "paper", "--out", "{tmp}/s", "--accuracy", "1mm"],
         "--accuracy"),
        (["calibrate", str(example_path()), "--out", "{tmp}/c", "--bound", "z=0:1V"], "--bound"),
        (["record", "--record", "{tmp}/r.tdms", "--settle", "1mm"], "--settle"),
        (["record", "--record", "{tmp}/r.tdms", "--source-rate", "1s"], "--source-rate"),
        (["record", "--record", "{tmp}/r.tdms", "--duration", "1Hz"], "--duration"),
        (["readout", "--setup", "force-sensor", "{tmp}/x.csv", "--quantity", "force", "--span",
          "0:1mm", "--csv", "{tmp}/o.csv"], "--span"),
        (["live", "--tracking", "3mm"], "--tracking"),
        (["live", "--source-rate", "3mm"], "--source-rate"),
        (["live", "--span", "0:1deg"], "--span"),
        (["dashboard", "--window", "1Hz"], "--window"),
    ],
)
def test_wrong_dimension_is_one_line(args: list[str], option: str, tmp_path: Path,
                                     capsys: pytest.CaptureFixture[str]) -> None:
    (tmp_path / "x.csv").write_text("voltage_V\n0.003\n")
    assert main([a.replace("{tmp}", str(tmp_path)) for a in args]) == 2
    err = capsys.readouterr().err
    assert err.startswith(f"magcilia: error: {option}") and err.count("\n") == 1
    assert " unit" in err or "with units" in err, err
    assert not (tmp_path / "s").exists() and not (tmp_path / "c").exists()


def test_bound_is_echoed_as_typed(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    code = main(["calibrate", str(example_path()), "--out", str(tmp_path / "c"),
                 "--bound", "height=-1:4"])
    err = capsys.readouterr().err
    assert code == 2 and "got 'height=-1:4'" in err and "mm" in err
    assert "0.004" not in err and "-0.001" not in err  # never silently metres


@pytest.mark.parametrize(
    ("args", "echo"),
    [
        (["bend", "--setup", "paper", "--tip-force", "0.1mN", "--at", "9mm"], "(0, 3.2613] mm"),
        (["design", "--setup", "paper", "--tip-radius", "-1"], "[0, 1000] mm; got '-1'"),
        (["design", "--setup", "paper", "--modulus", "0"], "MPa; got '0'"),
        (["sensitivity", "--setup", "paper", "--out", "{tmp}/s", "--sweep", "z=0:2m"],
         "mm; got 'z=0:2m'"),
    ],
    ids=["at", "tip-radius", "modulus", "span"],
)
def test_echoes_use_display_units(args: list[str], echo: str, tmp_path: Path,
                                  capsys: pytest.CaptureFixture[str]) -> None:
    assert main([a.replace("{tmp}", str(tmp_path)) for a in args]) == 2
    err = capsys.readouterr().err
    assert echo in err and err.count("\n") == 1
    assert not re.search(r"\bin m\b|\] m\b|got -?0\.00", err), err
