"""The options that mean one thing across the CLI (issue 26 item 7): ``--setup PRESET|FILE``
with its one rule (:data:`SETUP_RULE`), and the one mechanism of this release's deprecated
spellings (:class:`RenamedOption`, the positional SETUP): each still works, with one line on
stderr, ``magcilia: warning: CMD OLD is deprecated; use NEW (removed in the next release)``.

The meaning of every option name is in ``tests/cli/test_option_meanings.py``; a command that
gives an existing name another meaning fails it.
"""

from __future__ import annotations

import functools
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

import click
from click.core import ParameterSource

from magcilia._errors import MagciliaError
from magcilia._validate import fail
from magcilia.device.setup import Setup
from magcilia.io import presets
from magcilia.io.setup_files import load_setup

#: built-in setups usable wherever a setup file is expected (:mod:`magcilia.io.presets`), by name
#: -> a zero-argument builder; kept for code that imported it (``presets.load(name)`` is the API)
PRESETS = {name: functools.partial(presets.load, name) for name in presets.NAMES}

#: the one rule of ``--setup VALUE``, in the help of every command that takes a setup
SETUP_RULE = ("a bare name (no path separator, no suffix) is a preset: "
              + ", ".join(presets.NAMES) + "; anything else is a setup TOML file")


def is_preset_name(value: str) -> bool:
    """Whether ``--setup VALUE`` names a preset (:data:`SETUP_RULE`): a bare name, without a
    path separator or a suffix (``paper``, ``force-sensor``; a file in the current folder named
    so is ``./paper``). A bare name that is not a preset is an error, never a file."""
    return not any(sep in value for sep in ("/", "\\")) and not Path(value).suffix


def _known_preset(value: str) -> str:
    """``value`` when it is a preset name, else the one-line error: the closest preset and the
    list (and, for a file of that name here, how to read it)."""
    if value not in presets.NAMES:
        message = presets.unknown_preset_message(value)
        if Path(value).is_file():
            message += f"; to read the file {value!r}, write ./{value}"
        raise MagciliaError(message)
    return value


def load_setup_arg(value: str) -> Setup:
    """A ``--setup`` value as one cilium's :class:`Setup`: a preset name (paper, paper-initial,
    force-sensor) or a setup TOML file (:data:`SETUP_RULE`)."""
    return presets.setup(_known_preset(value)) if is_preset_name(value) else load_setup(value)


def array_file_arg(value: str) -> str:
    """A ``--setup`` value of a command that reads an array file (``magcilia array``): the file,
    or for the ``array`` preset the copy of ``examples/array.toml`` that ships with magcilia
    (:data:`SETUP_RULE`)."""
    if not is_preset_name(value):
        return value
    found = presets.file(_known_preset(value))
    if found is None:
        raise fail("--setup", value, "an array file or the array preset (preset "
                                     f"{value!r} is one cilium)")
    return str(found)


def setup_label(value: str) -> str:
    """Short label for a ``--setup`` value (file stem or preset name)."""
    return value if is_preset_name(value) else Path(value).stem


# --- one meaning per option: the deprecated spellings of this release (issue 26 item 7) ---------

#: what each old spelling became; ``magcilia CMD --old`` still works this release, with one line
#: on stderr (:func:`warn_deprecated`)
DEPRECATION = ("magcilia: warning: {command} {old} is deprecated; use {new} (removed in the next "
               "release)")


def warn_deprecated(ctx: click.Context, old: str, new: str) -> None:
    """The one deprecation line of an old spelling (``--force`` for ``--tip-force``, a positional
    SETUP for ``--setup SETUP``): ``magcilia: warning: CMD OLD is deprecated; use NEW (removed in
    the next release)`` on stderr, once per command run and spelling (``-q`` keeps it: it is a
    warning)."""
    seen = ctx.meta.setdefault("magcilia.deprecated", set())
    if old in seen:
        return
    seen.add(old)
    command = " ".join(ctx.command_path.split()[1:]) or ctx.command_path
    click.echo(DEPRECATION.format(command=command, old=old, new=new), err=True)


class RenamedOption(click.Option):
    """An option (with a value) with its new spelling in the help and its old ``old`` spellings
    still accepted for one release, each use warned once (:func:`warn_deprecated`): declare it as
    ``click.option("--tip-force", "force", cls=RenamedOption, old="--force", ...)``. The old
    spelling is not shown in the help; giving both spellings is an error (for a repeatable
    option their values add up).

    With ``alone``, an old spelling given without a value (at the end, or before another
    option) is a flag instead: it sets ``ctx.meta[alone]`` (``bend --force`` alone replaces
    existing outputs, as everywhere; ``bend --force 0.2mN`` is the deprecated ``--tip-force``)."""

    def __init__(self, *args: Any, old: str | Sequence[str], alone: str | None = None,
                 **kwargs: Any) -> None:
        super().__init__(*args, **kwargs)
        if self.is_flag or self.count:
            raise TypeError("RenamedOption takes an option with a value, not a flag")
        self.old_opts = [old] if isinstance(old, str) else list(old)
        self._old_dest = f"{self.name}__deprecated_spelling"
        self.alone = alone

    def add_to_parser(self, parser: Any, ctx: click.Context) -> None:
        super().add_to_parser(parser, ctx)
        # the parser asks its ``obj`` whether the value may be left out
        obj = _ValueOptional(self) if self.alone else self
        parser.add_option(obj=obj, opts=self.old_opts, dest=self._old_dest,
                          action="append" if self.multiple else "store", nargs=self.nargs)

    def consume_value(self, ctx: click.Context, opts: Any) -> Any:
        if self.alone and self._old_dest in opts:
            given = opts[self._old_dest]
            values = given if isinstance(given, list) else [given]
            if not all(isinstance(v, str) for v in values):  # click's no-value sentinel
                ctx.meta[self.alone] = True
                values = [v for v in values if isinstance(v, str)]
                opts = {k: v for k, v in opts.items() if k != self._old_dest}
                if values:
                    opts[self._old_dest] = values if self.multiple else values[-1]
        if self._old_dest in opts:
            new = max(self.opts, key=len)
            warn_deprecated(ctx, "/".join(self.old_opts), new)
            given = opts[self._old_dest]
            if self.name in opts:
                if not self.multiple:
                    raise click.UsageError(f"{new} and its old spelling "
                                           f"{'/'.join(self.old_opts)} given both; give {new} "
                                           "once", ctx)
                given = [*opts[self.name], *given]
            opts = {**opts, self.name: given}
        return super().consume_value(ctx, opts)


class _ValueOptional:
    """What the parser sees of a :class:`RenamedOption` whose old spelling may come alone."""

    _flag_needs_value = True

    def __init__(self, option: RenamedOption) -> None:
        self.option = option

    # the parser records the order of options by this object: it stands for ``option``
    def __eq__(self, other: object) -> bool:
        return other is self or other is self.option

    def __hash__(self) -> int:
        return hash(self.option)


class _LegacySetupArgument(click.Argument):
    """The positional SETUP of earlier releases, still accepted (with one deprecation line) by
    the commands that now take ``--setup``; hidden from the usage line. Its values go to the
    ``--setup`` option (:func:`setup_option`)."""

    def __init__(self, param_decls: Sequence[str], **kwargs: Any) -> None:
        kwargs.update(nargs=-1, required=False, expose_value=False)
        super().__init__(param_decls, **kwargs)

    def get_usage_pieces(self, ctx: click.Context) -> list[str]:  # noqa: ARG002 (click's)
        return []

    def handle_parse_result(self, ctx: click.Context, opts: Any, args: list[str]) -> Any:
        raw = opts.get(self.name)  # a sentinel, not a tuple, when none was given (click 8.2+)
        values = tuple(raw) if isinstance(raw, (list, tuple)) else ()
        if values and not ctx.resilient_parsing:
            option = next(p for p in ctx.command.params if isinstance(p, _SetupOption))
            if ctx.get_parameter_source(option.name or "") == ParameterSource.COMMANDLINE:
                raise click.UsageError(f"the setup given twice: --setup and a positional "
                                       f"{values[0]!r}; give it once, as --setup", ctx)
            if not option.multiple and len(values) > 1:
                raise click.UsageError(f"got unexpected extra argument ({values[1]})", ctx)
            warn_deprecated(ctx, "SETUP (positional)", "--setup SETUP")
            ctx.meta[_LEGACY_SETUP] = values
        return None, args


_LEGACY_SETUP = "magcilia.legacy_setup"


class _SetupOption(click.Option):
    """``--setup``: takes the deprecated positional SETUP's value when only that was given."""

    def consume_value(self, ctx: click.Context, opts: Any) -> Any:
        legacy = ctx.meta.get(_LEGACY_SETUP)
        if legacy and self.name not in opts:
            opts = {**opts, self.name: list(legacy) if self.multiple else legacy[0]}
        return super().consume_value(ctx, opts)


def setup_option(help_text: str = "The sensor setup", *, default: str | None = None,
                 multiple: bool = False, positional: bool = True, optional: bool = False,
                 name: str = "setup_arg") -> Callable[[Any], Any]:
    """A decorator: the one ``--setup VALUE`` of every command (:data:`SETUP_RULE`: a preset name
    or a setup TOML file), received as ``name`` (a tuple with ``multiple``); required unless
    ``default`` or ``optional`` (then None when not given). With ``positional``, the command
    also takes the positional SETUP of earlier releases (deprecated; its warning names
    --setup), which must then come before any other positional argument."""

    def decorate(command: Any) -> Any:
        text = f"{help_text}: {SETUP_RULE}."
        if multiple:
            text += " Repeatable."
        # no default=None: click 8.2+ takes an explicit None as given, not as missing
        defaults = {} if default is None else {"default": default, "show_default": True}
        command = click.option("--setup", name, cls=_SetupOption,
                               required=default is None and not optional,
                               multiple=multiple, metavar="SETUP", help=text,
                               **defaults)(command)
        if positional:
            command = click.argument("legacy_setup", cls=_LegacySetupArgument)(command)
        return command

    return decorate


# --- checked values: what reaches numpy is checked first (issue 30 item 6) ---------------------

#: the largest ``--seed`` (numpy's legacy generators, used by some samplers, take 32 bits)
MAX_SEED = 2**32 - 1


class Seed(click.IntRange):
    """``--seed``: a whole number from 0 to :data:`MAX_SEED`, checked before it reaches NumPy
    (whose own check of ``-1`` is a traceback): one line naming the value and the range."""

    name = "seed"

    def __init__(self) -> None:
        super().__init__(0, MAX_SEED)

    def convert(self, value: Any, param: click.Parameter | None, ctx: click.Context | None) -> Any:
        try:
            return super().convert(value, param, ctx)
        except click.BadParameter:
            raise MagciliaError(f"--seed must be a whole number from 0 to {MAX_SEED}; got "
                                f"{value!r}") from None


#: the type of every ``--seed``
SEED = Seed()


# --- what a serial device sends (issue 30 item 3): the one definition of --format, --fields,
# --channels, for every command that takes --source --------------------------------------------

def serial_format_options(command: Callable[..., Any]) -> Callable[..., Any]:
    """``--format magcilia|ascii|floats``, ``--fields NAME[unit],...`` and ``--channels N`` of a
    command that takes ``--source serial:PORT``; the command receives them as one ``serial``
    argument (:class:`~magcilia.acquire.serial_formats.SerialFormat`), checked first."""
    from magcilia.acquire.serial_formats import SerialFormat

    @functools.wraps(command)
    def run(*args: Any, serial_format: str, fields: str | None, channels: int | None,
            **kwargs: Any) -> Any:
        return command(*args, serial=SerialFormat(serial_format, fields, channels), **kwargs)

    options = [
        click.option("--format", "serial_format", default="magcilia", show_default=True,
                     type=click.Choice(["magcilia", "ascii", "floats"]),
                     help="What --source serial:PORT sends: magcilia's framed protocol "
                          "(COBS, sequence, CRC-32), ascii (comma- or space-separated text "
                          "lines, an optional header line naming the fields: Arduino sketches) "
                          "or floats (bare little-endian float32 values ending in \\r\\n: "
                          "ReSkin/AnySkin). ascii and floats carry no checksum: their samples "
                          "are counted as unverified, malformed lines/frames as corrupt, and "
                          "the rate is --source-rate."),
        click.option("--fields", default=None, metavar="NAME[unit],...",
                     help="ascii/floats: each field of a line or frame in order, - to skip one "
                          "(output[mV], or -,bx[uT],by[uT],bz[uT]); default: the header "
                          "line's names, else output, ch1, ... in V."),
        click.option("--channels", default=None, type=int,
                     help="floats: values per frame (or give --fields); ascii: fields per "
                          "line."),
    ]
    for option in reversed(options):
        run = option(run)
    return run
