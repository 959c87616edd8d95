"""Issue 30 items 5 and 6: messages that mislead, option values checked before they reach
NumPy, and the unit and naming slips; each test fails on the behaviour the issue reported."""

from __future__ import annotations

import json
import math
import re
from pathlib import Path

import numpy as np
import pytest

from magcilia.cli import main

ROOT = Path(__file__).resolve().parents[2]
EXAMPLE = ROOT / "src" / "magcilia" / "data" / "example_recording.csv"


def _run(capsys: pytest.CaptureFixture[str], argv: list[str]) -> tuple[int, str, str]:
    code = main(argv)
    captured = capsys.readouterr()
    return code, captured.out, captured.err


# --- --seed: checked before NumPy's own check (a traceback) -----------------------------------

SEEDED = {
    "array": ["array", "--setup", "array"],
    "batch calibrate": ["batch", "calibrate", "none*.csv", "--out", "OUT"],
    "calibrate": ["calibrate", "rec.csv", "--out", "OUT"],
    "dashboard": ["dashboard"],
    "demo": ["demo", "--out", "OUT"],
    "live": ["live", "--duration", "0.2"],
    "optimise": ["optimise", "--setup", "paper"],
    "record": ["record", "--record", "OUT.tdms"],
    "sensitivity": ["sensitivity", "--setup", "paper", "--out", "OUT"],
}


@pytest.mark.parametrize("seed", ["-1", "4294967296", "1.5", "nan", ""])
@pytest.mark.parametrize("name", sorted(SEEDED))
def test_a_bad_seed_is_one_line(name: str, seed: str, tmp_path: Path,
                                capsys: pytest.CaptureFixture[str]) -> None:
    argv = [a.replace("OUT", str(tmp_path / "out")) for a in SEEDED[name]]
    code, out, err = _run(capsys, [*argv, "--seed", seed])
    assert code == 2 and out == ""
    assert err == (f"magcilia: error: --seed must be a whole number from 0 to 4294967295; got "
                   f"{seed!r}\n")
    assert list(tmp_path.iterdir()) == []


def test_every_seed_option_is_checked() -> None:
    from magcilia.cli._options import Seed

    from .test_option_meanings import COMMANDS

    seeded = {name for name, command in COMMANDS.items()
              for p in command.params if "--seed" in getattr(p, "opts", ())}
    assert seeded == set(SEEDED)
    for name in seeded:
        param = next(p for p in COMMANDS[name].params if "--seed" in getattr(p, "opts", ()))
        assert isinstance(param.type, Seed), name


# --- swapped SETUP and RECORDING --------------------------------------------------------------

def test_a_recording_given_as_the_setup_says_so(tmp_path: Path,
                                                capsys: pytest.CaptureFixture[str]) -> None:
    """``readout run.tdms force-sensor`` (the issue's swap; the recording over 1 MB)."""
    run = tmp_path / "run.tdms"
    run.write_bytes(b"TDSm" + bytes(1_200_000))
    code, _, err = _run(capsys, ["readout", str(run), "force-sensor", "--quantity", "force",
                                 "--span", "0:0.2", "--csv", str(tmp_path / "o.csv")])
    assert code == 2
    line = err.splitlines()[-1]
    assert line.startswith(f"magcilia: error: SETUP {run} looks like a recording (TDMS)")
    assert "swapped" in line and "larger than" not in line
    # a CSV recording as --setup of any command: by its suffix
    rec = tmp_path / "rec.csv"
    rec.write_text("angle_deg,voltage_V\n0,0.001\n")
    code, _, err = _run(capsys, ["field", "--setup", str(rec)])
    assert code == 2 and err.count("\n") == 1
    assert f"SETUP {rec} looks like a recording (CSV)" in err


def test_a_setup_given_as_the_recording_says_so(tmp_path: Path,
                                                capsys: pytest.CaptureFixture[str]) -> None:
    setup = tmp_path / "mine.toml"
    setup.write_bytes((ROOT / "examples" / "force-sensor.toml").read_bytes())
    for recording, what in ((setup, "a setup file"), ("force-sensor", "a preset name")):
        code, _, err = _run(capsys, ["readout", "--setup", "force-sensor", str(recording),
                                     "--quantity", "force", "--span", "0:0.2", "--csv",
                                     str(tmp_path / "o.csv")])
        assert code == 2 and err.count("\n") == 1
        assert f"RECORDING {recording} looks like a setup ({what})" in err and "swapped" in err
    code, _, err = _run(capsys, ["calibrate", str(setup), "--out", str(tmp_path / "fit")])
    assert code == 2 and f"RECORDING {setup} looks like a setup" in err
    # a setup file without the .toml suffix is known by its tables
    bare = tmp_path / "mine.txt"
    bare.write_bytes(setup.read_bytes())
    code, _, err = _run(capsys, ["ringdown", str(bare)])
    assert code == 2 and f"RECORDING {bare} looks like a setup (a setup file)" in err


# --- record: the help names what the file holds; aligned columns ------------------------------

def test_record_help_names_the_channels_the_file_holds(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    pytest.importorskip("nptdms")
    import nptdms

    from magcilia.io.recordings import quiet_nptdms

    out = tmp_path / "r.tdms"
    assert main(["record", "--record", str(out), "--angles", "0:10:10", "--samples", "20",
                 "--quiet"]) == 0
    assert main(["record", "--help"]) == 0
    text = " ".join(capsys.readouterr().out.split())
    with quiet_nptdms():
        channels = [c.name for c in nptdms.TdmsFile.read(out)["recording"].channels()]
    assert "angle_deg" in channels and "angle_rad" not in channels
    for name in channels:
        assert name in text, name
    assert "angle_rad" not in text


@pytest.mark.parametrize("si", [False, True])
def test_record_console_columns_line_up(si: bool) -> None:
    from magcilia.acquire.sweep import SweepPoint
    from magcilia.cli.record import point_text
    from magcilia.report.units import output_units

    points = [SweepPoint(angle=math.radians(a), mean=m, sem=s, samples=n, saturated=k)
              for a, m, s, n, k in ((0.0, 2.5e-3, 3e-5, 50, 0),
                                    (7.5, 2.75963e-3, 3.19063e-5, 2000, 0),
                                    (82.5, -1.2e-4, 2.6e-7, 20000, 0))]
    lines = [point_text(p, output_units(si)) for p in points]
    for mark in ("±", " mV " if not si else " V ", " samples"):
        assert len({line.index(mark) for line in lines}) == 1, (mark, lines)


# --- names and units -------------------------------------------------------------------------

def test_sensitivity_figures_say_base_radius_with_its_values() -> None:
    import matplotlib

    matplotlib.use("Agg")
    from magcilia.analysis import SobolResult
    from magcilia.report.sensitivity import display, plot_sobol

    assert display("base_radius") == ("base radius", "mm", pytest.approx(1e3))
    names = ("x", "base_radius", "height")
    sobol = SobolResult(names=names, S1=np.array([0.5, 0.3, 0.1]),
                        S1_conf=np.full(3, 0.01), ST=np.array([0.6, 0.35, 0.12]),
                        ST_conf=np.full(3, 0.01), bounds={}, n_base=8, n_evaluations=40,
                        measure="rms")
    ax = plot_sobol(sobol)
    labels = [t.get_text() for t in ax.get_yticklabels()]
    assert "base radius" in labels and not any("diameter" in t for t in labels)


def test_a_micronewton_force_is_shown_in_micronewton(capsys: pytest.CaptureFixture[str]) -> None:
    from magcilia.report.units import show

    assert show(2.658e-7, "force") == "0.2658 µN"
    assert show(2e-5, "force") == "0.02 mN" and show(3e-9, "force") == "3 nN"
    code, out, _ = _run(capsys, ["design", "--setup", "force-sensor"])
    row = next(line for line in out.splitlines() if line.startswith("force"))
    assert code == 0 and re.search(r" 0\.1\d+ µN ", row) and "e-0" not in row
    code, out, _ = _run(capsys, ["array", "--setup", "array"])
    assert code == 0 and re.search(r"median sigma \|F\| \d+\.?\d* µN \(noise \d+\.?\d* µN\)",
                                   out)


def test_exact_zeros_print_as_zero(capsys: pytest.CaptureFixture[str]) -> None:
    code, out, _ = _run(capsys, ["field", "--setup", "paper-initial", "--angles", "0:10:5"])
    assert code == 0 and "e-1" not in out
    first = out.splitlines()[1].split()
    assert first[2] == "0" and first[3] == "0" and first[5] == "0"  # Bx, By, output at 0 deg
    code, out, _ = _run(capsys, ["field", "--setup", "paper-initial", "--angles", "0:10:5",
                                 "--json", "--si"])
    assert all(r["By_T"] == 0.0 for r in json.loads(out)["rows"])
    code, out, _ = _run(capsys, ["bend", "--setup", "force-sensor", "--tip-force", "0.02",
                                 "--azimuth", "90", "--json"])
    doc = json.loads(out)
    assert doc["load"]["force_mN"] == [0.0, 0.02, 0.0]
    assert doc["tip_mm"][0] == 0.0 and doc["sigma_tip_mm"][0] == 0.0
    assert not re.search(r"e-1[5-9]|e-2\d", out)


def test_calibrate_echoes_its_input_and_joins_the_folder_once(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    setup = tmp_path / "start.toml"
    text = (ROOT / "examples" / "paper-initial.toml").read_text()
    setup.write_text(text.replace('base_radius = "0.25 mm"', 'base_radius = "0.1801 mm"'))
    out = tmp_path / "fit"
    code, printed, _ = _run(capsys, ["calibrate", str(EXAMPLE), "--setup", str(setup),
                                     "--out", f"{out}/", "--quiet"])
    assert code == 0
    assert f"wrote {out}/fitted_setup.toml, result.json" in printed and "//" not in printed
    rows = json.loads((out / "result.json").read_text())["table"]  # display units (mm)
    row = next(r for r in rows if r["parameter"] == "base_radius")
    assert row["initial"] == 0.1801  # as typed, not 0.18009999999999998


def test_unit_conversions_round_trip_short_decimals() -> None:
    from magcilia.report.units import output_units
    from magcilia.units import converted

    u = output_units()
    assert u.convert({"r_m": 0.1801e-3, "h_m": 0.07e-3}) == {"r_mm": 0.1801, "h_mm": 0.07}
    assert u.value(0.1801e-3, "length") == 0.1801
    assert converted(math.pi / 180, 90.0) == math.pi / 2  # not a short decimal: every digit
    assert converted(0.1801e-3, 1.0) == 0.1801e-3  # no conversion, no rounding


def test_the_readme_says_which_files_keep_fixed_names_and_their_units() -> None:
    """Every CSV column and JSON key carries its unit, except the read-back formats the README
    names; the batch table's units it lists are the table's own."""
    from magcilia.batch.results import COLUMNS, UNITS

    text = (ROOT / "README.md").read_text(encoding="utf-8")
    units = text[text.index("### Units"):text.index("### Calibration")]
    for name in ("`results.csv`", "`result.json`", "`voltage_V`"):
        assert name in units, name
    start = text.index("**The table** (`results.csv`")
    table = " ".join(text[start:text.index("\n\n", start)].split())
    checked = 0
    for name, unit in UNITS.items():
        if unit not in ("V", "V^2", "m"):
            continue
        after = table[table.index(f"`{name}`"):]  # the first unit in parentheses after it
        said = re.search(r"\(([^);]*)", after)
        assert said is not None and said.group(1).strip().replace("²", "^2") == unit, name
        assert name in COLUMNS
        checked += 1
    assert checked >= 10


def test_the_force_vector_figure_takes_the_unit_of_its_loads() -> None:
    """A µN-scale biaxial read-out is drawn in µN (as the console says it), a mN one in mN."""
    import matplotlib

    matplotlib.use("Agg")
    import magcilia as mc
    from magcilia.device.magnetometer import Magnetometer
    from magcilia.report.biaxial import plot_force_vectors

    setup = mc.Setup.paper(tip_radius=5e-5, youngs_modulus=2e6)
    sensor = Magnetometer(field_range=1e-3, resolution=1e-9, noise=1.5e-9, rate=100.0)
    for span, unit in ((5e-8, "µN"), (1e-4, "mN")):
        r = mc.BiaxialReadout(setup, sensor, span=span, table_size=(9, 16))
        phi = np.radians(np.arange(8) * 45.0)
        truth = 0.5 * span * np.stack([np.cos(phi), np.sin(phi)], -1)
        result = r.read(sensor.to_board(r.model(truth[:, 0], truth[:, 1])))
        ax = plot_force_vectors(truth, result)
        assert ax.get_xlabel() == f"$F_x$ ({unit})", span
        reach = ax.get_xlim()[1]
        factor = 1e-6 if unit == "µN" else 1e-3  # the data drawn in that unit
        assert reach == pytest.approx(1.12 * max(0.5 * span, result.span) / factor)
