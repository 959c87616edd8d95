"""``magcilia modes``: the text, the JSON, the issue's positional spelling, one-line errors."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import pytest

import magcilia as mc
from magcilia.cli import main


def _run(capsys: pytest.CaptureFixture[str], argv: list[str]) -> tuple[int, str, str]:
    code = main(argv)
    captured = capsys.readouterr()
    return code, captured.out, captured.err


def test_text_and_json_match_the_library(capsys: pytest.CaptureFixture[str],
                                         tmp_path: Path) -> None:
    setup = mc.presets.load("force-sensor")
    expected = mc.modes(setup, "water", count=2)
    code, out, err = _run(capsys, ["modes", "--setup", "force-sensor", "--fluid", "water",
                                   "--count", "2"])
    assert code == 0 and not err
    assert out.strip() == expected.report()
    target = tmp_path / "m.json"
    code, out, _ = _run(capsys, ["modes", "--setup", "force-sensor", "--fluid", "glycerol",
                                 "--gravity", "--json", "--json-file", str(target)])
    doc = json.loads(out)
    assert code == 0 and doc == json.loads(target.read_text())
    assert doc["setup"] == "force-sensor" and doc["gravity"] is True
    assert all(m["overdamped"] and m["damped_frequency_Hz"] == 0.0 for m in doc["modes"])


def test_modulus_override_scales_the_frequencies(capsys: pytest.CaptureFixture[str]) -> None:
    _, out, _ = _run(capsys, ["modes", "--setup", "force-sensor", "--modulus", "0.5",
                              "--count", "1", "--json"])
    f1 = json.loads(out)["modes"][0]["frequency_Hz"]
    assert f1 == pytest.approx(130.0, rel=0.03)  # NOTES §8


def test_the_issue_spelling_runs_from_a_shell() -> None:
    """``magcilia modes SETUP --fluid water --json`` (issue 28's public name), the tree under
    test: JSON on stdout, the positional SETUP's one line on stderr."""
    proc = subprocess.run([sys.executable, "-m", "magcilia", "modes", "force-sensor", "--fluid",
                           "water", "--json"], capture_output=True, text=True, timeout=120,
                          check=False)
    assert proc.returncode == 0, proc.stderr
    freqs = [m["frequency_Hz"] for m in json.loads(proc.stdout)["modes"]]
    assert len(freqs) == 3 and freqs == sorted(freqs)


@pytest.mark.parametrize(("argv", "word"), [
    (["--count", "0"], "--count"),
    (["--fluid", "honey"], "--fluid"),
    (["--elements", "1"], "--elements"),
    (["--modulus", "0.0001", "--gravity"], "buckles under its own weight"),
])
def test_bad_input_is_one_line(capsys: pytest.CaptureFixture[str], argv: list[str],
                               word: str) -> None:
    code, out, err = _run(capsys, ["modes", "--setup", "force-sensor", *argv])
    assert code == 2 and not out
    assert err.startswith("magcilia: error:") and word in err and err.count("\n") == 1
