"""The CLI's command table (``magcilia.cli.COMMANDS``): ``magcilia --help`` lists the commands from
it without importing them, exactly as click lists the commands themselves."""

from __future__ import annotations

from pathlib import Path

import click
import pytest

from magcilia import cli as cli_module
from magcilia.cli import COMMANDS, cli, main
from magcilia.cli._lazy_group import LazyCommands, LazyGroup

CLI_DIR = Path(cli_module.__file__).resolve().parent


def test_every_command_module_is_in_the_table() -> None:
    modules = set()
    for path in CLI_DIR.glob("*.py"):
        text = path.read_text(encoding="utf-8")
        if not path.stem.startswith("_") and ("\ncommand = " in text or "\ndef command(" in text):
            modules.add(path.stem)
    assert modules == set(COMMANDS)


@pytest.mark.parametrize("name", sorted(COMMANDS))
def test_the_table_line_is_the_commands_docstring_first_line(name: str) -> None:
    command = cli.commands[name]
    assert (command.help or "").splitlines()[0] == COMMANDS[name]


@pytest.mark.parametrize("width", [80, 60, 120])
def test_the_listing_is_clicks_own(width: int) -> None:
    """The table's listing (no command imported) equals click's listing of the commands."""
    lazy = LazyGroup("magcilia", commands=LazyCommands(COMMANDS))
    eager = click.Group("magcilia", commands={name: cli.commands[name] for name in COMMANDS})
    texts = []
    for group in (lazy, eager):
        formatter = click.HelpFormatter(width=width)
        group.format_commands(click.Context(group), formatter)
        texts.append(formatter.getvalue())
    assert texts[0] == texts[1]
    assert all(f"  {name} " in texts[0] for name in COMMANDS)
    assert isinstance(lazy.commands, LazyCommands)
    if width <= 80:  # (click's help is at most 80 wide: there no command is imported)
        assert lazy.commands.loaded == {}


def test_the_mapping_lists_and_looks_up_without_importing_others() -> None:
    lazy = LazyCommands(COMMANDS)
    assert list(lazy) == list(COMMANDS) and len(lazy) == len(COMMANDS) and "bend" in lazy
    assert lazy["bend"] is cli.commands["bend"]
    assert set(lazy.loaded) == {"bend"}
    with pytest.raises(KeyError):
        lazy["nothing"]
    extra = click.Command("extra")
    lazy["extra"] = extra
    assert list(lazy)[-1] == "extra" and lazy.peek("extra") is extra
    del lazy["extra"]
    del lazy["bend"]
    assert "extra" not in lazy and "bend" not in lazy and len(lazy) == len(COMMANDS) - 1


def test_an_unknown_command_is_a_one_line_usage_error(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["calibrat"]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and err.startswith("magcilia: error: No such command 'calibrat'")
    assert "calibrate" in err  # click's suggestion, from the table's names
