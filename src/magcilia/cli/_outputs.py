"""The one output policy of the CLI (issue 30 item 6): an existing output file is replaced only
with ``--force``, as an output folder (:func:`magcilia._atomic.staged_directory`), with the same
message (:func:`magcilia._atomic.exists_message`), and never when it is also an input.

Every option that names an output file takes :data:`OUTPUT_FILE` as its type, and the command
carries :func:`writes_files` right under ``@click.command()``: it adds ``--force`` where the
command has none and, before the command runs (so before any work), refuses in one line

- an output that exists, without ``--force`` (the file is left byte-identical);
- an output that is a folder;
- an output that is one of the command's inputs (the setup file, the recording, ...), even with
  ``--force``;
- one file named by two outputs.

The files themselves are written atomically by the commands (:mod:`magcilia._atomic`).
"""

from __future__ import annotations

import functools
import os
from collections.abc import Callable, Iterable, Iterator
from pathlib import Path
from typing import Any

import click

from magcilia._atomic import exists_message
from magcilia._errors import MagciliaError

#: ``ctx.meta`` key: ``--force`` given where the command's ``--force`` is also the deprecated
#: spelling of another option (``bend --force`` alone; ``bend --force 0.2mN`` is ``--tip-force``)
FORCE_KEY = "magcilia.force"

FORCE_HELP = ("Replace existing output files (never an input file); without it an existing "
              "output is left as it is.")


class OutputFile(click.Path):
    """The type of every option that names an output file (a file, not a folder)."""

    name = "file"

    def __init__(self) -> None:
        super().__init__(dir_okay=False)


#: the type of every output-file option (``type=OUTPUT_FILE``)
OUTPUT_FILE = OutputFile()

force_option = click.option("--force", is_flag=True, help=FORCE_HELP)

#: what a command writes besides its output-file options: params -> (option, path) pairs
Extra = Callable[[dict[str, Any]], Iterable[tuple[str, str]]]


def _option_name(param: click.Parameter) -> str:
    if isinstance(param, click.Option):
        return max(param.opts, key=len)
    return (param.name or "").upper()


def _strings(value: Any) -> Iterator[str]:
    if isinstance(value, (str, os.PathLike)):
        yield os.fspath(value)
    elif isinstance(value, (tuple, list)):
        for v in value:
            yield from _strings(v)


def _same_file(a: str, b: str) -> bool:
    try:
        return Path(a).samefile(b)
    except OSError:
        return False


def check_outputs(outputs: Iterable[tuple[str, str]], inputs: Iterable[tuple[str, str]],
                  force: bool) -> None:
    """Refuse (a one-line :class:`MagciliaError`) an output that may not be written: named
    twice, a folder, one of ``inputs`` (even with ``force``), or existing without ``force``.

    Parameters
    ----------
    outputs : iterable of (option, path)
        The files the command is about to write, by the option that names them.
    inputs : iterable of (option, path)
        The values of the command's other options and arguments (only existing files count).
    force : bool
        Whether ``--force`` was given.
    """
    outputs = [(o, p) for o, p in outputs if p]
    files = [(o, p) for o, p in inputs if p and Path(p).is_file()]
    for k, (option, path) in enumerate(outputs):
        for other, earlier in outputs[:k]:
            if Path(earlier).absolute() == Path(path).absolute() or _same_file(earlier, path):
                raise MagciliaError(f"{path} is given to both {other} and {option}; give each "
                                    "output its own file")
        if Path(path).is_dir():
            raise MagciliaError(f"{path} is a folder, not a file; choose another {option}")
        for name, source in files:
            if _same_file(source, path):
                raise MagciliaError(f"{path} is the input of {name}; an input is never replaced "
                                    f"(--force neither): choose another {option}")
        if os.path.lexists(path) and not force:
            raise MagciliaError(exists_message(path, option))


def _force_given(ctx: click.Context) -> bool:
    for param in ctx.command.params:
        if isinstance(param, click.Option) and "--force" in param.opts and param.is_flag:
            return bool(ctx.params.get(param.name or ""))
    return bool(ctx.meta.get(FORCE_KEY))


def check_context(ctx: click.Context, extra: Extra | None = None) -> None:
    """:func:`check_outputs` for the command of ``ctx``: its :data:`OUTPUT_FILE` options (and
    ``extra``'s files) against the values of its other parameters."""
    outputs: list[tuple[str, str]] = []
    inputs: list[tuple[str, str]] = []
    for param in ctx.command.params:
        value = ctx.params.get(param.name or "")
        pairs = [(_option_name(param), s) for s in _strings(value)]
        (outputs if isinstance(param.type, OutputFile) else inputs).extend(pairs)
    if extra is not None:
        outputs.extend(extra(ctx.params))
    check_outputs(outputs, inputs, _force_given(ctx))


def _has_force(command: Any) -> bool:
    """Whether the command declares ``--force`` (as a flag, or as a deprecated spelling)."""
    for param in getattr(command, "__click_params__", []):
        if isinstance(param, click.Option) and (
                "--force" in param.opts or "--force" in getattr(param, "old_opts", ())):
            return True
    return False


def writes_files(command: Any = None, *, extra: Extra | None = None) -> Any:
    """A decorator, right under ``@click.command()``, of a command that writes output files
    (:data:`OUTPUT_FILE` options, and ``extra(params)`` -> (option, path) pairs for files it
    names itself): adds ``--force`` if the command has none and checks the outputs before the
    command runs (:func:`check_outputs`)."""

    def decorate(function: Any) -> Any:
        added = not _has_force(function)
        if added:
            function = force_option(function)

        @functools.wraps(function)
        def checked(**kwargs: Any) -> Any:
            check_context(click.get_current_context(), extra)
            if added:
                kwargs.pop("force", None)
            return function(**kwargs)

        return checked

    return decorate if command is None else decorate(command)


def in_folder(folder: str | os.PathLike[str], name: str = "") -> str:
    """``folder/name`` as a message shows it: one separator whatever the folder's spelling
    (``fit/`` and ``fit`` give ``fit/result.json``, never ``fit//result.json``)."""
    return os.path.join(str(Path(folder)), name)  # noqa: PTH118 (a Path drops the end's "/")
