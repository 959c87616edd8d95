"""The ``magcilia`` command line: a thin layer over the library (parse, load, call, write)."""

from __future__ import annotations

import sys
from collections.abc import Sequence

import click

from magcilia._errors import MagciliaError, MissingDependencyError
from magcilia._validate import printable
from magcilia._version import __version__


@click.group(context_settings={"help_option_names": ["-h", "--help"]})
@click.version_option(__version__, prog_name="magcilia")
def cli() -> None:
    """Magnetic cilia force and flow sensors: field, calibration, sensitivity, bending, read-out.

    Lengths in mm, angles in degrees and fields in gauss on the command line, or any unit typed
    with the value (2.5mm, 0:0.2mN); outputs in display units, SI with --si. Setup files carry
    their units ("3.0 mm"). Run `magcilia COMMAND --help` for each command.
    """


# one line per subcommand module: (module name under magcilia.cli, command name)
_COMMANDS: tuple[tuple[str, str], ...] = (
    ("field", "field"),
    ("calibrate", "calibrate"),
    ("bend", "bend"),
    ("readout", "readout"),
    ("design", "design"),
    ("demo", "demo"),
    ("sensitivity", "sensitivity"),
    ("approximate", "approximate"),
    ("angle", "angle"),
    ("record", "record"),
    ("live", "live"),
    ("dashboard", "dashboard"),
)


def _register() -> None:
    import importlib

    for module_name, command_name in _COMMANDS:
        module = importlib.import_module(f"magcilia.cli.{module_name}")
        cli.add_command(module.command, name=command_name)


_register()


def main(argv: Sequence[str] | None = None) -> int:
    """Run the CLI in-process and return the exit code (0 ok, 1 aborted, 2 a usage or input
    error, printed as one line)."""
    try:
        cli.main(args=list(argv) if argv is not None else None, prog_name="magcilia",
                 standalone_mode=False)
    except click.exceptions.Exit as exc:
        return int(exc.exit_code)
    except click.exceptions.Abort:
        click.echo("magcilia: aborted", err=True)
        return 1
    except click.UsageError as exc:
        where = exc.ctx.command_path if exc.ctx is not None else "magcilia"
        return _error(f"{' '.join(exc.format_message().split())} (see {where} --help)")
    except click.ClickException as exc:
        return _error(" ".join(exc.format_message().split()))
    except (MagciliaError, MissingDependencyError) as exc:
        return _error(str(exc))
    except OSError as exc:
        name = f" {exc.filename}" if exc.filename else ""
        return _error(f"cannot access{name}: {exc.strerror or exc}")
    return 0


def _error(message: str) -> int:
    """Print ``magcilia: error: MESSAGE`` as one line on stderr (non-printable characters from
    files escaped); the exit code of every usage and input error, 2."""
    click.echo(f"magcilia: error: {printable(message)}", err=True)
    return 2


def run() -> None:
    """Console-script entry point."""
    sys.exit(main())
