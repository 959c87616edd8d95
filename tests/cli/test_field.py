"""The CLI run in-process: version, help, the field command and its error handling."""

from __future__ import annotations

import csv
import json
from pathlib import Path

import numpy as np
import pytest

import magcilia as mc
from magcilia.cli import main

EXAMPLE = str(Path(__file__).resolve().parents[2] / "examples" / "paper.toml")


def test_version_and_help(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["--version"]) == 0
    assert mc.__version__ in capsys.readouterr().out
    assert main(["--help"]) == 0
    assert "field" in capsys.readouterr().out
    assert main(["field", "--help"]) == 0
    assert "degrees" in capsys.readouterr().out


def test_field_table_csv_json_plot(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    csv_path, png, js = tmp_path / "t.csv", tmp_path / "f.png", tmp_path / "f.json"
    code = main(["field", EXAMPLE, "paper-initial", "--angles", "0:85:5", "--csv", str(csv_path),
                 "--plot", str(png), "--json-file", str(js)])
    assert code == 0
    out = capsys.readouterr().out
    assert "angle/deg" in out and "85.00" in out
    rows = list(csv.DictReader(csv_path.read_text().splitlines()))
    assert len(rows) == 2 * 18
    first = [r for r in rows if r["setup"] == "paper"]
    expected = mc.Setup.paper().output(np.radians(np.arange(0, 86, 5)))
    np.testing.assert_allclose([float(r["output_mV"]) for r in first], expected * 1e3,
                               rtol=1e-9)
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    doc = json.loads(js.read_text())
    assert doc["units"] == "display" and "Bx_gauss" in doc["rows"][0]
    assert not list(tmp_path.glob(".*"))  # no temporary files left behind


def test_field_json_stdout(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["field", "paper", "--angles", "0:10:5", "--json"]) == 0
    doc = json.loads(capsys.readouterr().out)
    assert [r["angle_deg"] for r in doc["rows"]] == [0.0, 5.0, 10.0]


@pytest.mark.parametrize(
    ("args", "match"),
    [
        (["field", "--setup", "missing.toml"], "cannot access missing.toml"),
        (["field", "--setup", "paper", "--angles", "10:0"],
         "--angles must be a range with stop > start"),
        (["field", "--setup", "paper", "--angles", "a:b"], "--angles must be START:STOP"),
        (["field", "--setup", "paper", "--angles", "0:1mm"], "with an angle unit (rad, deg)"),
        (["field", "--setup", "paper", "--angles", "0:10:0"], "positive step"),
    ],
    ids=["missing-file", "reversed", "text", "wrong-unit", "zero-step"],
)
def test_field_errors(args: list[str], match: str, capsys: pytest.CaptureFixture[str]) -> None:
    assert main(args) == 2
    err = capsys.readouterr().err
    assert match in err
    assert err.count("\n") == 1 and "Traceback" not in err


def test_bad_setup_file_leaves_no_output(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    bad = tmp_path / "bad.toml"
    bad.write_text('[cilium]\nheight = "3"\n')
    out_csv = tmp_path / "out.csv"
    assert main(["field", str(bad), "--csv", str(out_csv)]) == 2
    assert "cilium.height must be a length with a unit" in capsys.readouterr().err
    assert not out_csv.exists()


def test_field_flags_what_the_element_sees(tmp_path: Path,
                                           capsys: pytest.CaptureFixture[str]) -> None:
    # Table I's initial placement stands the cilium on the element: 28-31 G along z over
    # 0-40 deg, beyond the HMC1021's 6 G range and 20 G flip field (issue 15)
    csv_path = tmp_path / "t.csv"
    assert main(["field", "--setup", "paper-initial", "--setup", "paper", "--angles", "0:40:20",
                 "--csv", str(csv_path)]) == 0
    err = capsys.readouterr().err
    assert err.count("magcilia: warning:") == 1 and "paper-initial puts up to 31.2 gauss" in err
    rows = list(csv.DictReader(csv_path.read_text().splitlines()))
    flags: dict[str, set[str]] = {}
    for r in rows:
        flags.setdefault(r["setup"], set()).add(r["flag"])
    assert flags["paper-initial"] == {"total-range,flip"}
    # the optimized placement keeps |B| near 0.6 G: only the cross-axis term shows
    assert flags["paper"] == {"cross-axis"}
    b = mc.Setup.paper_initial().field(np.radians([0.0, 20.0, 40.0]))
    assert b[:, 2].min() > 27.6e-4 and b[:, 2].max() < 31.3e-4
