"""The README's promise for every command: errors are one line on stderr, exit code 2, with the
bytes of a file never reaching the terminal raw."""

from __future__ import annotations

from pathlib import Path

import pytest

from magcilia.cli import main


@pytest.mark.parametrize(("args", "starts"), [
    (["field", "--bogus"], "No such option '--bogus'"),
    (["nosuch"], "No such command 'nosuch'"),
    (["readout", "--setup", "paper", "x.csv"], "Missing option '--quantity'"),
    (["field", "--setup", "paper", "--angles"], "Option '--angles' requires an argument"),
    (["bend", "--setup", "paper", "--tip-force", "1mN", "--tip-radius", "0.05mm", "--at", "oops"],
     "--at"),
])
def test_usage_errors_are_one_line_with_exit_2(args: list[str], starts: str,
                                               capsys: pytest.CaptureFixture[str]) -> None:
    assert main(args) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and err.startswith("magcilia: error: ")
    assert starts in err


def test_control_characters_from_a_file_are_escaped(tmp_path: Path,
                                                    capsys: pytest.CaptureFixture[str]) -> None:
    """A CSV header with a terminal escape (clear screen) and a line break in a column name."""
    path = tmp_path / "evil.csv"
    path.write_bytes(b'"angle\x1b[2J_deg","volt\nage_V"\n1,2\n')
    assert main(["calibrate", str(path), "--out", str(tmp_path / "fit")]) == 2
    err = capsys.readouterr().err
    assert "\x1b" not in err and err.count("\n") == 1
    assert "\\x1b[2J" in err or "angle_deg" in err


def test_a_library_warning_is_one_line(capsys: pytest.CaptureFixture[str]) -> None:
    import warnings

    import click

    from magcilia import cli as cli_module

    @click.command()
    def warns() -> None:
        warnings.warn("sampling stopped\nat the time limit", UserWarning, stacklevel=1)

    cli_module.cli.add_command(warns, name="warns-test")
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("always")  # the suite turns warnings into errors
            assert cli_module.main(["warns-test"]) == 0
    finally:
        cli_module.cli.commands.pop("warns-test")
    err = capsys.readouterr().err
    assert err == "magcilia: warning: sampling stopped at the time limit\n"
