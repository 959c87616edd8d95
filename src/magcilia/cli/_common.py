"""Shared helpers of the CLI subcommands: loading setups, unit options, output files."""

from __future__ import annotations

import contextlib
import functools
import math
import sys
from collections.abc import Callable, Iterator, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

import click
import numpy as np
from numpy.typing import NDArray

from magcilia._atomic import json_text
from magcilia._errors import MagciliaError
from magcilia._validate import fail
from magcilia.cli._options import (  # noqa: F401 (re-exported: the commands import them here)
    PRESETS,
    RenamedOption,
    array_file_arg,
    is_preset_name,
    load_setup_arg,
    setup_label,
    setup_option,
)
from magcilia.device.parameters import MEASURANDS, PARAMETERS, Parameter
from magcilia.device.sensor import DEFAULT_BANDWIDTH
from magcilia.device.setup import Setup
from magcilia.io.columns import Columns, columns_help
from magcilia.io.quality import OUTLIER_SIGMAS, SUSPECT_POLICIES
from magcilia.io.recordings import Measurement
from magcilia.mechanics import FLUIDS, Flow
from magcilia.units import UNITS, dimension_words, parse_range, parse_value, parse_values

if TYPE_CHECKING:
    from magcilia.calibration import CalibrationResult

#: most angles of an ``--angles START:STOP:STEP`` grid (0.0001 deg steps over 0..90 deg are 900 001
#: angles; a finer grid says more about float rounding than about the sensor)
MAX_ANGLES = 1_000_000


def angle_grid(text: str, key: str = "--angles") -> NDArray[np.float64]:
    """Angles in rad from ``start:stop[:step]`` in degrees, or with an angle unit (``0:85:5deg``,
    ``0:1.4rad``; stop included when on the grid), at most :data:`MAX_ANGLES` of them."""
    start, stop, step = parse_range(text, key, "deg")
    if step is None:
        step = math.radians(1.0)
    count = (stop - start) / step + 1e-9
    if not count < MAX_ANGLES:  # also inf and NaN (an overflowing span)
        raise fail(key, text, f"a grid of at most {MAX_ANGLES} angles (MAX_ANGLES); use a "
                              "larger step or a shorter range")
    n = math.floor(count) + 1
    return np.asarray(start + step * np.arange(n), dtype=np.float64)


def echo_json(data: Any) -> None:
    """Print JSON to stdout."""
    click.echo(json_text(data), nl=False)


def bandwidth_option(help_text: str = "Noise band of each reading, F_LOW:F_HIGH in Hz.") -> Any:
    """The shared ``--bandwidth`` option (default: one raw sample at 1 kHz)."""
    default = f"{DEFAULT_BANDWIDTH[0]:g}:{DEFAULT_BANDWIDTH[1]:g}"
    return click.option("--bandwidth", default=default, show_default=True, help=help_text)


def parse_bandwidth(text: str) -> tuple[float, float]:
    """``F_LOW:F_HIGH`` in Hz, or with units (``0.5Hz:0.5kHz``) -> (f_low, f_high)."""
    f_lo, f_hi, step = parse_range(text, "--bandwidth", "Hz")
    if step is not None or f_lo <= 0.0:
        raise fail("--bandwidth", text, "F_LOW:F_HIGH in Hz with 0 < F_LOW < F_HIGH, e.g. 0.5:500")
    return f_lo, f_hi


def parse_named_ranges(option: str, items: tuple[str, ...],
                       names: Sequence[str]) -> dict[str, tuple[float, float]]:
    """``NAME=LOW:HIGH`` items of a repeatable option -> SI pairs; LOW and HIGH are in the
    parameter's display unit (mm for lengths, whole numbers for n_loops) or carry a unit
    (``height=2mm:4mm``, ``z=0:0.8mm``). A range outside the parameter's domain is refused in the
    units typed (the display unit for bare numbers), never in metres."""
    out: dict[str, tuple[float, float]] = {}
    for item in items:
        name, _, text = item.partition("=")
        name = name.strip()
        if name not in names:
            raise fail(option, item, "NAME=LOW:HIGH with NAME one of " + ", ".join(names))
        p = PARAMETERS[name]
        try:
            lo, hi = parse_values(text, p.dimension, p.display, option, (2,))
        except MagciliaError:
            example = (f"{name}=2:4 or {name}=2{p.display}:4{p.display}" if p.display
                       else f"{name}=1:10")
            raise fail(option, item, f"NAME=LOW:HIGH with LOW and HIGH each "
                                     f"{dimension_words(p.dimension, p.display)}, e.g. "
                                     f"{example}") from None
        if not lo <= hi:
            raise fail(option, item, "NAME=LOW:HIGH with LOW <= HIGH")
        if p.outside([lo, hi]) is not None or not (p.within(lo) and p.within(hi)):
            raise fail(option, item, _display_domain(p))
        out[name] = (lo, hi)
    return out


def _display_domain(p: Parameter, plural: bool = True) -> str:
    """A parameter's domain and limits in its display unit, in words (for range errors)."""
    unit = f" {p.display}" if p.display else ""
    hi = p.to_display(p.maximum)
    values = "values" if plural else "value"
    if p.domain == "integer":
        return f"{'whole numbers' if plural else 'a whole number'} >= 1, at most {p.maximum:g}"
    if p.domain == "positive":
        return (f"{'' if plural else 'a '}positive {values} within "
                f"[{p.to_display(p.minimum):g}, {hi:g}]{unit}")
    if p.domain == "non_negative":
        return f"{'' if plural else 'a '}{values} within [0, {hi:g}]{unit}"
    return f"{'' if plural else 'a '}{values} within [{-hi:g}, {hi:g}]{unit}"


def _checked_override(name: str, option: str, text: str, example: str) -> float:
    """A ``--tip-radius``-like override: parsed (bare: display unit), refused as typed when it
    leaves the parameter's domain."""
    p = PARAMETERS[name]
    value = parse_value(text, p.dimension, p.display, option, example)
    if p.outside([value]) is not None or not p.within(value):
        raise fail(option, text, _display_domain(p, plural=False))
    return value


def load_mechanics_setup(arg: str, tip_radius: str | None, modulus: str | None) -> Setup:
    """The ``--setup`` value (a preset or a setup file) with the optional --tip-radius (bare: mm)
    / --modulus (bare: MPa; VALUE or VALUE:SIGMA) overrides applied."""
    setup = load_setup_arg(arg)
    changes: dict[str, float] = {}
    if tip_radius is not None:
        changes["tip_radius"] = _checked_override("tip_radius", "--tip-radius", tip_radius,
                                                  "0.05mm or 50um")
    if modulus is not None:
        changes.update(parse_modulus(modulus))
    return setup.replace(**changes) if changes else setup


def parse_modulus(text: str) -> dict[str, float]:
    """``--modulus VALUE[:SIGMA]`` (bare numbers in MPa, or with units: ``0.5MPa:50kPa``) as
    setup keywords: ``youngs_modulus`` and, with a σ, ``youngs_modulus_sigma`` (a modulus given
    without one is taken as exact)."""
    p, ps = PARAMETERS["youngs_modulus"], PARAMETERS["youngs_modulus_sigma"]
    example = "0.5 (MPa, taken as exact) or 0.5:0.05 (a measured modulus and its 1-sigma)"
    try:
        parts = parse_values(text, p.dimension, p.display, "--modulus", (1, 2))
    except MagciliaError:
        raise fail("--modulus", text, f"VALUE or VALUE:SIGMA, each "
                                      f"{dimension_words(p.dimension, p.display)}, e.g. "
                                      f"{example}") from None
    if p.outside(parts[:1]) is not None or not p.within(parts[0]):
        raise fail("--modulus", text, _display_domain(p, plural=False))
    out = {"youngs_modulus": parts[0]}
    if len(parts) == 2:
        if ps.outside(parts[1:]) is not None or not ps.within(parts[1]):
            raise fail("--modulus", text, "a SIGMA " + _display_domain(ps, plural=False))
        out["youngs_modulus_sigma"] = parts[1]
    return out


def make_flow(speed: str | None, fluid: str, shear_height: str | None) -> Flow | None:
    """A Flow from the CLI options (None without --flow); bare numbers in m/s and mm."""
    if speed is None:
        return None
    q = MEASURANDS["flow"]
    u = parse_value(speed, q.dimension, q.display, "--flow", "0.1m/s")
    if shear_height is not None:
        p = PARAMETERS["height"]
        h = parse_value(shear_height, p.dimension, p.display, "--shear-height", "3mm")
        return Flow.shear(speed=u, height=h, fluid=FLUIDS[fluid])
    return Flow.uniform(u, FLUIDS[fluid])


def mechanics_options(command: Any) -> Any:
    """``--tip-radius`` and ``--modulus``: override the setup's mechanics on the command line."""
    command = click.option("--modulus", default=None, metavar="VALUE[:SIGMA]",
                           help="Override Young's modulus: MPa, or with a unit (e.g. 0.5MPa); "
                                "without a SIGMA it is taken as exact, VALUE:SIGMA is a "
                                "measured modulus and its 1-sigma (0.5:0.05). Default: the "
                                "setup's (the material's assumed modulus, +-27 %, until "
                                "fitted from load data).")(command)
    return click.option("--tip-radius", default=None,
                        help="Override the setup's tip radius: mm, or with a unit (e.g. 0.05mm, "
                             "50um).")(command)


def _no_progress(done: int, total: int) -> None:
    """The progress callback where no bar is shown."""


@contextlib.contextmanager
def progress_bar(desc: str, unit: str, *, quiet: bool = False,
                 **options: Any) -> Iterator[Callable[[int, int], None]]:
    """A ``progress(done, total)`` callback (the library's form) that drives a tqdm bar on
    stderr, not with ``quiet`` (the command's ``--quiet`` or ``magcilia -q``) or when stderr is
    not a terminal; ``options`` go to tqdm."""
    if quiet_requested(quiet) or not sys.stderr.isatty():
        yield _no_progress  # (tqdm not even imported)
        return
    from tqdm import tqdm

    with tqdm(desc=desc, unit=unit, file=sys.stderr, **options) as bar:
        def advance(done: int, total: int) -> None:
            bar.total = total
            bar.update(done - bar.n)

        yield advance


def calibrate_with_progress(data: Measurement, initial: Setup, *, quiet: bool,
                            **options: Any) -> CalibrationResult:
    """:func:`magcilia.calibrate` with a progress bar over the restarts on stderr (not with
    ``--quiet`` or when stderr is not a terminal)."""
    from magcilia.calibration import calibrate  # (the fit: imported by the commands that fit)

    with progress_bar("calibrating (restarts)", "run", quiet=quiet) as advance:
        return calibrate(data, initial=initial, progress=advance, **options)


#: key of ``click.Context.meta`` set by the group's ``-q/--quiet``
QUIET_KEY = "magcilia.quiet"


def quiet_requested(flag: bool = False) -> bool:
    """Whether to stay quiet (no progress bars, no info lines): a command's own ``--quiet``
    ``flag`` or the group's ``magcilia -q``."""
    ctx = click.get_current_context(silent=True)
    return flag or bool(ctx is not None and ctx.meta.get(QUIET_KEY, False))


# --- the unit policy of command outputs and physical options (docs/ARCHITECTURE.md, README Units)

def si_option(command: Any) -> Any:
    """The shared ``--si`` flag: every output of the command (console, CSV, JSON) in SI units
    instead of display units."""
    return click.option("--si", "si", is_flag=True,
                        help="All outputs (console, CSV, JSON) in SI units (m, rad, N, T, V) "
                             "instead of display units (mm, deg, mN, gauss, mV); names carry "
                             "the unit either way.")(command)


class Physical(click.ParamType):
    """A click type for one physical value: a number in the option's display unit, or with a
    unit of its dimension (``2.5mm``, ``90deg``, ``1kHz``) -> SI float (errors are one line)."""

    name = "value"

    def __repr__(self) -> str:
        return f"Physical({self.dimension!r}, {self.unit!r})"

    def __init__(self, dimension: str, unit: str, example: str = "") -> None:
        self.dimension, self.unit, self.example = dimension, unit, example

    @classmethod
    def of(cls, name: str, example: str = "") -> Physical:
        """The type of a registry quantity or parameter (``"angle"``, ``"height"``) or of a
        dimension shown in SI (``"time"``, ``"frequency"``)."""
        entry = {**PARAMETERS, **MEASURANDS}.get(name)
        if entry is not None and entry.dimension:
            return cls(entry.dimension, entry.display, example)
        return cls(name, next(iter(UNITS[name])), example)

    def convert(self, value: Any, param: click.Parameter | None,
                ctx: click.Context | None) -> float:  # noqa: ARG002 (click's signature)
        key = max(param.opts, key=len) if param is not None and param.opts else "value"
        return parse_value(str(value), self.dimension, self.unit, key, self.example)


def style_option(command: Any) -> Any:
    """``--style screen|paper``: the look of the figures a command writes
    (:mod:`magcilia.report.style`)."""
    from magcilia.report.style import STYLES

    return click.option(
        "--style", type=click.Choice(STYLES), default="screen", show_default=True,
        help="Figure style: screen, or paper (serif, one journal column wide, print-sized "
             "fonts; vector PDF/SVG by the file suffix, a PDF beside each PNG of a folder)."
    )(command)


@dataclass(frozen=True)
class RecordingArgs:
    """The options of :func:`recording_options`, as the readers' keyword arguments."""

    columns: Columns = field(default_factory=Columns)
    delimiter: str | None = None
    decimal: str = "."
    group: str | None = None

    def kwargs(self) -> dict[str, Any]:
        """Keyword arguments of :func:`magcilia.read_measurements` and
        :func:`magcilia.io.read_samples`."""
        return {"columns": self.columns, "delimiter": self.delimiter, "decimal": self.decimal,
                "group": self.group}

    def read(self, read: Callable[..., Any], path: str, *, quiet: bool = False,
             **kwargs: Any) -> Any:
        """``read(path, **kwargs)`` (read_measurements or read_samples) with these options and a
        progress bar on stderr for reads longer than a second (not with ``quiet`` or when stderr
        is not a terminal)."""
        with progress_bar(f"reading {Path(path).name}", "B", quiet=quiet, unit_scale=True,
                          unit_divisor=1024, delay=1.0, leave=False) as advance:
            return read(path, progress=advance, **self.kwargs(), **kwargs)


def recording_options(command: Any) -> Any:
    """``--columns``, ``--delimiter``, ``--decimal`` and ``--group`` for a command that reads a
    recording; the command receives them as one ``reading`` argument (:class:`RecordingArgs`),
    checked before the command runs."""
    @functools.wraps(command)
    def run(*args: Any, columns: str | None, delimiter: str, decimal: str, group: str | None,
            **kwargs: Any) -> Any:
        cols = Columns() if columns is None else Columns.parse(columns)
        reading = RecordingArgs(cols, None if delimiter == "auto" else delimiter, decimal, group)
        return command(*args, reading=reading, **kwargs)

    options = [
        click.option("--columns", default=None, metavar="ROLE=NAME[unit],...",
                     help=columns_help()),
        click.option("--delimiter", type=click.Choice(["auto", ",", ";", "tab", "whitespace"]),
                     default="auto", show_default=True,
                     help="CSV field delimiter; auto: from the header line."),
        click.option("--decimal", type=click.Choice([".", ","]), default=".",
                     show_default=True, help="CSV decimal mark (',' for 1,25)."),
        click.option("--group", default=None, metavar="NAME",
                     help="HDF5 or TDMS group holding the columns (default: HDF5 root, "
                          "TDMS any group)."),
    ]
    for option in reversed(options):
        run = option(run)
    return run


def parse_priors(items: tuple[str, ...],
                 names: Sequence[str]) -> dict[str, tuple[float, float]]:
    """``--prior NAME=VALUE:SIGMA`` items -> SI (value, σ) by name; VALUE and SIGMA in the
    parameter's display unit (mm, MPa) or with units (``height=3mm:200um``), NAME among
    ``names``, σ > 0 (a zero-width prior would fix the parameter: --fix does that)."""
    out: dict[str, tuple[float, float]] = {}
    for item in items:
        name, _, text = item.partition("=")
        name = name.strip()
        if name not in names:
            raise fail("--prior", item, "NAME=VALUE:SIGMA with NAME one of " + ", ".join(names))
        p = PARAMETERS[name]
        try:
            value, sigma = parse_values(text, p.dimension, p.display, "--prior", (2,))
        except MagciliaError:
            raise fail("--prior", item, "NAME=VALUE:SIGMA with VALUE and SIGMA each "
                                        f"{dimension_words(p.dimension, p.display)}, e.g. "
                                        f"{name}=3.26:0.1") from None
        if not sigma > 0:
            raise fail("--prior", item, "a prior with a positive SIGMA (a zero-width prior "
                                        "fixes the parameter: use --fix instead)")
        out[name] = (value, sigma)
    return out


# --- bending in any direction and actuation (issue 15) ----------------------------------------

def parse_vector(text: str, dimension: str, unit: str, key: str, example: str) -> tuple[float,
                                                                                      float, float]:
    """``X,Y,Z`` with optional units (``0.1,0,0mN``, ``0,0,5mT``; a bare part takes the unit of
    the last part that has one, or ``unit``) -> an SI triple (errors are one line)."""
    words = dimension_words(dimension, unit)
    allowed = f"X,Y,Z, each {words}, e.g. {example}"
    if not isinstance(text, str) or text.count(",") != 2:
        raise fail(key, text, allowed)
    try:
        x, y, z = parse_values(text.replace(",", ":"), dimension, unit, key, (3,))
    except MagciliaError:
        raise fail(key, text, allowed) from None
    return x, y, z


def actuation_options(command: Any) -> Any:
    """``--actuation-field``, ``--actuation`` (a TOML file's ``[actuation]`` table) and
    ``--actuation-scale``; the command receives ``actuation_field``, ``actuation_file`` and
    ``actuation_scale`` (see :func:`make_actuation`)."""
    options = [
        click.option("--actuation-field", "actuation_field", default=None, metavar="BX,BY,BZ",
                     help="A uniform actuation field (Helmholtz coils) in the board frame: "
                          "gauss, or with a unit (0,0,5mT). Replaces the setup file's "
                          "[actuation]."),
        click.option("--actuation", "actuation_file", default=None,
                     type=click.Path(dir_okay=False),
                     help="A TOML file with an [actuation] table (field = [...] or "
                          "[[actuation.magnets]]). Default: the setup file's [actuation], if "
                          "any."),
        click.option("--actuation-scale", "actuation_scale", default=None, type=float,
                     help="Factor on the actuation field (a coil current ratio)."),
    ]
    for option in reversed(options):
        command = option(command)
    return command


def make_actuation(setup_arg: str, field_text: str | None, file: str | None,
                   scale: float | None) -> Any:
    """The actuation of the options (``--actuation-field`` or ``--actuation FILE``, else the
    setup file's ``[actuation]`` table), times ``--actuation-scale``; None without any."""
    from magcilia.device.actuation import Actuation
    from magcilia.io.actuation_file import load_actuation, read_actuation

    act: Actuation | None
    if field_text is not None and file is not None:
        raise fail("--actuation-field", field_text, "either --actuation-field or --actuation "
                                                    "FILE, not both")
    if field_text is not None:
        p = PARAMETERS["field_range"]
        act = Actuation.uniform(parse_vector(field_text, "field", p.display,
                                             "--actuation-field", "0,0,50 or 0,0,5mT"))
    elif file is not None:
        act = load_actuation(file)
    elif not is_preset_name(setup_arg):
        act = read_actuation(setup_arg)
    else:
        act = None
    if scale is not None:
        if act is None:
            raise fail("--actuation-scale", scale, "given with an actuation (--actuation-field, "
                                                  "--actuation FILE or the setup's [actuation])")
        if not math.isfinite(scale):
            raise fail("--actuation-scale", scale, "a finite number")
        act = act.scaled(scale)
    return act


# --- the execution layer's options (batch calibrate, sensitivity; magcilia.execution) ------------

def execution_options(default: str = "one per core; 1: in this process") -> Any:
    """A decorator: ``--workers N``, ``--scheduler ADDRESS`` and ``--timeout S`` for a command
    whose work runs through :func:`magcilia.execution.run_tasks` (``default``: what runs without
    them, for the help); the command receives ``workers``, ``scheduler`` and ``timeout``."""
    options = [
        click.option("--workers", type=click.IntRange(min=1), default=None,
                     help=f"Worker processes on this machine [default: {default}]; with "
                          "--scheduler local, the Dask LocalCluster's."),
        click.option("--scheduler", default=None, metavar="ADDRESS",
                     help="Run the tasks on a Dask cluster: its scheduler's address "
                          "(tcp://HOST:8786; default the MAGCILIA_SCHEDULER variable), or "
                          "'local' for a Dask LocalCluster on this machine (magcilia[cluster])."),
        click.option("--timeout", type=click.FloatRange(min=0.0, min_open=True), default=10.0,
                     show_default=True, help="Seconds to reach the scheduler before an error."),
    ]

    def decorate(command: Any) -> Any:
        for option in reversed(options):
            command = option(command)
        return command

    return decorate


def suspect_option(command: Any) -> Any:
    """``--suspect keep|omit|raise``, shared by ``calibrate``, ``readout`` and ``batch
    calibrate``: what to do with the samples the quality checks flag (:mod:`magcilia.io.quality`:
    conditions with far fewer samples than the others, outliers, duplicated blocks, garbled
    values); they are counted and named either way. The command receives ``suspect``."""
    return click.option(
        "--suspect", type=click.Choice(SUSPECT_POLICIES), default="keep",
        show_default=True,
        help="Samples the quality checks flag (conditions with far fewer samples than the others, "
             f"outliers beyond {OUTLIER_SIGMAS:g} robust SDs, duplicated blocks of rows, garbled "
             "values): keep them, omit them, or refuse the recording; counted and named in the "
             "output either way.")(command)


def fit_options(command: Any) -> Any:
    """The options of one paper-model fit that ``calibrate`` and ``batch calibrate`` share:
    ``--bias``, ``--bias-degree``, ``--fit-scale``, ``--nan-policy`` and ``--saturation`` (the
    command receives ``bias``, ``bias_degree``, ``fit_scale``, ``nan_policy``, ``saturation``)."""
    options = [
        click.option("--bias", type=click.Choice(["offset", "polynomial", "none"]),
                     default="offset", show_default=True,
                     help="DC bias model, fitted jointly."),
        click.option("--bias-degree", default=0, show_default=True,
                     help="Degree of the polynomial bias in the angle (with --bias polynomial)."),
        click.option("--fit-scale", is_flag=True, help="Also fit the magnetization scale."),
        click.option("--nan-policy", type=click.Choice(["raise", "omit"]), default="raise",
                     show_default=True, help="NaN/inf samples: error or drop."),
        click.option("--saturation", type=click.Choice(["raise", "omit", "keep"]),
                     default="raise", show_default=True,
                     help="Samples beyond the sensor's ±6 gauss range."),
    ]
    for option in reversed(options):
        command = option(command)
    return command
