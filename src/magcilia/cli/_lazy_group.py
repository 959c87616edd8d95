"""A click group whose subcommands are imported when they run, not when ``magcilia`` starts.

``magcilia --help`` lists every command with its one-line help from a table (name -> the first
line of its docstring; the command is ``magcilia.cli.<name>.command``), so listing them imports
no command module (and none of SciPy, pandas, numba or matplotlib behind them). ``group.commands``
stays a mapping of every command: looking one up (running it, ``magcilia NAME --help``, shell
completion, ``commands.items()``) imports its module then, once.
"""

from __future__ import annotations

import importlib
from collections.abc import Iterator, Mapping, MutableMapping

import click


class LazyCommands(MutableMapping[str, click.Command]):
    """``name -> click.Command``, importing ``magcilia.cli.<name>`` on first lookup.

    Commands added at run time (``group.add_command``) sit beside the table's; the keys (the
    listing, ``in``, ``len``, a misspelt name's suggestions) never import anything."""

    def __init__(self, table: Mapping[str, str]) -> None:
        self.table = dict(table)
        self.loaded: dict[str, click.Command] = {}

    def __getitem__(self, name: str) -> click.Command:
        if name not in self.loaded:
            if name not in self.table:
                raise KeyError(name)
            self.loaded[name] = importlib.import_module(f"magcilia.cli.{name}").command
        return self.loaded[name]

    def __setitem__(self, name: str, command: click.Command) -> None:
        self.loaded[name] = command

    def __delitem__(self, name: str) -> None:
        if name not in self:
            raise KeyError(name)
        self.loaded.pop(name, None)
        self.table.pop(name, None)

    def __iter__(self) -> Iterator[str]:
        yield from self.table
        yield from (name for name in self.loaded if name not in self.table)

    def __len__(self) -> int:
        return len(self.table.keys() | self.loaded.keys())

    def __contains__(self, name: object) -> bool:
        return name in self.table or name in self.loaded

    def peek(self, name: str) -> click.Command:
        """The command if imported, else a stand-in holding only its name and the table's help
        line (what the listing needs), without importing its module."""
        if name in self.loaded or name not in self.table:
            return self[name]
        return click.Command(name, help=self.table[name])


class LazyGroup(click.Group):
    """A :class:`click.Group` whose ``commands=`` is a :class:`LazyCommands`: its help lists the
    commands not imported yet from the table's lines."""

    def format_commands(self, ctx: click.Context, formatter: click.HelpFormatter) -> None:
        """The ``Commands:`` section as :meth:`click.Group.format_commands` writes it (the same
        width rule and shortening, by click's own ``get_short_help_str``), from stand-ins for
        the commands not imported."""
        commands = self.commands
        if not isinstance(commands, LazyCommands):
            super().format_commands(ctx, formatter)
            return
        shown = [(name, commands.peek(name)) for name in self.list_commands(ctx)]
        shown = [(name, command) for name, command in shown if not command.hidden]
        if not shown:
            return
        limit = formatter.width - 6 - max(len(name) for name, _ in shown)
        rows = []
        for name, command in shown:
            text = command.get_short_help_str(limit)
            if name not in commands.loaded and text == command.help and not text.endswith("."):
                # the whole first line fits (a wide terminal): the sentence goes on in the
                # docstring, so ask the command itself
                text = commands[name].get_short_help_str(limit)
            rows.append((name, text))
        with formatter.section("Commands"):
            formatter.write_dl(rows)
