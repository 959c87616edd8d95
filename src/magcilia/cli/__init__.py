"""The ``magcilia`` command line: a thin layer over the library (parse, load, call, write)."""

from __future__ import annotations

import contextlib
import logging
import sys
import warnings
from collections.abc import Sequence

import click

from magcilia._errors import MagciliaError, MagciliaWarning, MissingDependencyError
from magcilia._version import __version__
from magcilia.cli._lazy_group import LazyCommands, LazyGroup

# the subcommands: name -> the first line of its docstring (the command is
# ``magcilia.cli.<name>.command``). ``magcilia --help`` lists them from here without importing
# a command module; tests/cli/test_lazy_commands.py holds each line equal to its docstring's.
COMMANDS: dict[str, str] = {
    "field": "Field at the sensing element (gauss) and sensor output (mV) vs tilt angle (T, V, rad",
    "calibrate": (
        "Calibrate the model to the recording DATA (CSV, .mat, .tdms or .h5), or with "
        "--model"
    ),
    "bend": "Large-deflection shape of the cilium under a tip force, a flow and/or a magnetic",
    "readout": (
        "Estimate the tilt angle, tip force or flow speed for each reading of RECORDING (CSV, "
        ".mat"
    ),
    "design": (
        "Design metrics: dV/dF, dV/dU, dV/dθ (mV per mN, m/s, deg), minimum detectable force "
        "(mN),"
    ),
    "demo": "Calibrate the paper's model to the bundled SYNTHETIC recording and write a report.",
    "sensitivity": (
        "Sensitivity of the model around SETUP (a setup TOML file or a preset: paper, "
        "paper-initial)."
    ),
    "approximate": (
        "Fit a continuous piecewise-linear function to SETUP's output vs tilt (the paper's Sec. "
        "V)."
    ),
    "angle": (
        "Measure the holder's tilt in each PHOTO (JPEG, PNG, TIFF) from the reflective tape on "
        "it."
    ),
    "record": (
        "Record a calibration sweep: for each tilt angle, samples of the sensor output with "
        "the"
    ),
    "live": (
        "Watch a sensor live: the force, angle or flow speed ± σ, a sparkline of the last "
        "10 s,"
    ),
    "dashboard": (
        "Serve a browser dashboard of the live read-out: the value with its σ, flags, "
        "plots of"
    ),
    "plan": (
        "Plan a tilt-table calibration of SETUP: the BUDGET readings (tilt angles × azimuths) "
        "that"
    ),
    "array": "An array of cilia over three-axis magnetometers (--setup: an array setup file",
    "batch": "Many recordings at once (on this machine, or a Dask cluster with --scheduler).",
    "optimise": (
        "Search the cilium's height, base and tip radius (and, given bounds, magnetization scale "
        "or"
    ),
    "modes": (
        "Bending modes of the cilium clamped at its base: natural frequency (Hz), damping "
        "ratio"
    ),
    "ringdown": "Young's modulus and damping ratio from the ring-down of a flicked cilium.",
    "export": (
        "Export RECORDING (CSV, .mat, .tdms, .h5) to CSV, MATLAB, HDF5 or NetCDF for other "
        "tools."
    ),
    "show": (
        "Draw SETUP (a setup TOML file or a preset) or an ARRAY file in 3-D: the cilium as its"
    ),
}


@click.group(cls=LazyGroup, commands=LazyCommands(COMMANDS),
             context_settings={"help_option_names": ["-h", "--help"]})
@click.version_option(__version__, prog_name="magcilia")
@click.option("-v", "--verbose", count=True,
              help="Log what long steps do on stderr: -v progress (INFO), -vv details (DEBUG).")
@click.option("-q", "--quiet", is_flag=True,
              help="Warnings and errors only: no progress bars, no log (each command's --quiet).")
@click.pass_context
def cli(ctx: click.Context, verbose: int, quiet: bool) -> None:
    """Magnetic cilia force and flow sensors: field, calibration, sensitivity, bending, read-out.

    Lengths in mm, angles in degrees and fields in gauss on the command line, or any unit typed
    with the value (2.5mm, 0:0.2mN); outputs in display units, SI with --si. Setup files carry
    their units ("3.0 mm"). Run `magcilia COMMAND --help` for each command.
    """
    if verbose and quiet:
        raise click.UsageError("-v/--verbose and -q/--quiet exclude each other")
    level = logging.WARNING if quiet or not verbose else (logging.INFO if verbose == 1
                                                           else logging.DEBUG)
    _configure_logging(ctx, level)
    if quiet:
        from magcilia.cli._common import QUIET_KEY

        ctx.meta[QUIET_KEY] = True
        # the group's -q turns on every command's own --quiet (a command without one never looks
        # the key up: naming every command keeps their modules unimported)
        ctx.default_map = {name: {"quiet": True} for name in cli.commands}


class _EchoHandler(logging.Handler):
    """Log records as lines on the current stderr (click.echo, so captured streams work):
    ``magcilia: info: message``."""

    def emit(self, record: logging.LogRecord) -> None:
        from magcilia._validate import printable  # (NumPy: not at start-up)

        try:
            click.echo(f"magcilia: {record.levelname.lower()}: {printable(self.format(record))}",
                       err=True)
        except Exception:  # noqa: BLE001 (logging must never raise into the caller)
            self.handleError(record)


def _configure_logging(ctx: click.Context, level: int) -> None:
    """Attach a stderr handler at ``level`` to the ``magcilia`` logger for this command, and
    take it off again when the command ends (the library itself never configures logging)."""
    logger = logging.getLogger("magcilia")
    handler = _EchoHandler(level)
    old_level = logger.level
    logger.addHandler(handler)
    logger.setLevel(min(level, old_level) if old_level else level)

    def restore() -> None:
        logger.removeHandler(handler)
        logger.setLevel(old_level)

    ctx.call_on_close(restore)


def main(argv: Sequence[str] | None = None) -> int:
    """Run the CLI in-process and return the exit code (0 ok, 1 aborted, 2 a usage or input
    error, printed as one line)."""
    try:
        with warnings.catch_warnings():
            warnings.showwarning = _show_warning  # restored on leaving
            # magcilia's own warnings (a coarse layout, …) are a command's output: one line each
            warnings.simplefilter("always", MagciliaWarning)
            code = cli.main(args=list(argv) if argv is not None else None, prog_name="magcilia",
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
    # without standalone mode click returns a command's ``click.exceptions.Exit`` code (the
    # commands themselves return None)
    return code if isinstance(code, int) and not isinstance(code, bool) else 0


def _show_warning(message: Warning | str, category: type[Warning], filename: str, lineno: int,
                  file: object = None, line: str | None = None) -> None:
    """A library warning (e.g. a posterior stopped at its time limit) as one line on stderr,
    ``magcilia: warning: MESSAGE``, without Python's file and source line."""
    from magcilia._validate import printable

    del category, filename, lineno, file, line
    click.echo(f"magcilia: warning: {printable(' '.join(str(message).split()))}", err=True)


def _error(message: str) -> int:
    """Print ``magcilia: error: MESSAGE`` as one line on stderr (non-printable characters from
    files escaped); the exit code of every usage and input error, 2."""
    from magcilia._validate import printable

    click.echo(f"magcilia: error: {printable(message)}", err=True)
    return 2


def run() -> None:
    """Console-script entry point: :func:`main`, then the process ends with its code.

    A finished command's process ends at once (:func:`_exit_now`): its output flushed and the
    exit handlers run, without the interpreter's tear-down of every module: after a
    ``calibrate`` that took 0.27 s of CPU time (numba's compiled code and SciPy freed; 0.06 s
    after SciPy's import alone; the 2-core VM at a load of 8)."""
    code = main()
    _exit_now(code)
    sys.exit(code)


def _exit_now(code: int) -> None:
    """End the process with ``code`` the way the interpreter would, less its tear-down: flush
    stdout and stderr, run the ``atexit`` handlers (logging's, multiprocessing's, weakref
    finalizers such as temporary folders', coverage's), then ``os._exit``. Returns (and the
    caller exits as usual) where that would not be the same: another thread still running (the
    interpreter would wait for it), or output that cannot be flushed (a closed pipe: the
    interpreter's own message and exit code)."""
    import atexit
    import os
    import threading

    if threading.active_count() != 1:
        return
    try:
        for stream in (sys.stdout, sys.stderr):
            if stream is not None:
                stream.flush()
    except (OSError, ValueError):
        return
    atexit._run_exitfuncs()
    with contextlib.suppress(OSError, ValueError):
        for stream in (sys.stdout, sys.stderr):
            if stream is not None:
                stream.flush()
    os._exit(code)
