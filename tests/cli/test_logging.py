"""Logging and quiet at the command line: ``magcilia -v/-vv`` logs the long steps to stderr,
``magcilia -q`` silences bars and logs, the library itself configures nothing; and
``python -m magcilia`` is the same program."""

from __future__ import annotations

import json
import logging
import subprocess
import sys
from pathlib import Path

import pytest

from magcilia import __version__
from magcilia.cli import main
from magcilia.io.recordings import example_path

SRC = Path(__file__).resolve().parents[2] / "src"


def _calibrate(tmp_path: Path, *group: str, json_out: bool = False) -> int:
    """A quick calibration of the bundled example (geometry fixed, one restart)."""
    return main([*group, "calibrate", str(example_path()), "--setup", "paper",
                 "--out", str(tmp_path / "cal"), "--bound", "height=3.2613:3.2613",
                 "--bound", "base_radius=0.1801:0.1801", "--bound", "n_loops=2:2",
                 "--bound", "dipoles_per_loop=5:5", "--restarts", "1",
                 *(["--json"] if json_out else [])])


def _terminal(monkeypatch: pytest.MonkeyPatch) -> None:
    """Make the captured stderr claim to be a terminal, so that progress bars are drawn."""
    monkeypatch.setattr(sys.stderr, "isatty", lambda: True)


def _magcilia_handlers() -> list[str]:
    return [type(h).__name__ for h in logging.getLogger("magcilia").handlers]


def test_verbose_logs_the_steps_to_stderr(tmp_path: Path,
                                          capsys: pytest.CaptureFixture[str]) -> None:
    assert _calibrate(tmp_path, "-v", json_out=True) == 0
    captured = capsys.readouterr()
    json.loads(captured.out)  # stdout stays clean JSON
    lines = captured.err.splitlines()
    assert any(line.startswith("magcilia: info: read ") and "example_recording.csv" in line
               for line in lines), captured.err
    assert any(line.startswith("magcilia: info: calibrating ") for line in lines)
    assert any(line.startswith("magcilia: info: restart 1/1: cost ") for line in lines)
    assert any(line.startswith("magcilia: info: best cost ") for line in lines)
    assert not any(line.startswith("magcilia: debug:") for line in lines)
    assert _magcilia_handlers() == ["NullHandler"]  # taken off when the command ended


def test_very_verbose_adds_details(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    assert _calibrate(tmp_path, "-vv") == 0
    err = capsys.readouterr().err
    assert "magcilia: debug: halving round: " in err
    assert "magcilia: debug: global search: " in err


def test_default_prints_a_bar_and_no_log(tmp_path: Path, capsys: pytest.CaptureFixture[str],
                                         monkeypatch: pytest.MonkeyPatch) -> None:
    _terminal(monkeypatch)
    assert _calibrate(tmp_path) == 0
    err = capsys.readouterr().err
    assert "calibrating (restarts)" in err  # the bar is there without -q
    assert "magcilia: info:" not in err


def test_group_quiet_silences_bars_and_logs(tmp_path: Path, capsys: pytest.CaptureFixture[str],
                                            monkeypatch: pytest.MonkeyPatch) -> None:
    _terminal(monkeypatch)
    assert _calibrate(tmp_path, "-q") == 0
    captured = capsys.readouterr()
    assert captured.err == ""
    assert "cost" in captured.out  # the result is still printed
    assert _magcilia_handlers() == ["NullHandler"]


def test_verbose_and_quiet_exclude_each_other(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["-v", "-q", "field", "paper"]) == 2
    assert "exclude each other" in capsys.readouterr().err


def test_library_import_configures_no_logging() -> None:
    code = ("import logging, magcilia; log = logging.getLogger('magcilia'); "
            "print([type(h).__name__ for h in log.handlers], logging.getLogger().handlers, "
            "log.level)")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         check=True, env={"PYTHONPATH": str(SRC)}).stdout
    assert out.strip() == "['NullHandler'] [] 0"


def test_python_dash_m_runs_the_cli() -> None:
    done = subprocess.run([sys.executable, "-m", "magcilia", "--version"], capture_output=True,
                          text=True, check=False, env={"PYTHONPATH": str(SRC)})
    assert done.returncode == 0, done.stderr
    assert done.stdout.strip() == f"magcilia, version {__version__}"
