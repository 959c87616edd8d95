"""``magcilia record --coil``: the coil calibration sweep
(:func:`magcilia.acquire.coil.record_coil`) on the simulated coil or through NI analog outputs."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import click
import numpy as np

from magcilia._validate import fail
from magcilia.cli._common import echo_json, load_setup_arg, setup_label
from magcilia.io.setup_files import setup_to_dict
from magcilia.report.units import output_units

#: T per gauss
_G = 1e-4


@dataclass(frozen=True)
class CoilOptions:
    """The coil options as typed: --coil-output, --coil-constant, --coil-sense,
    --coil-sense-constant."""

    output: str | None = None
    constant: str | None = None
    sense: str | None = None
    sense_constant: str | None = None


def check_record_path(out_path: str) -> None:
    """Refuse a --record that is no .tdms (an existing file, a folder: the output policy,
    :func:`magcilia.cli._outputs.writes_files`)."""
    if not out_path.lower().endswith(".tdms"):
        raise fail("--record", out_path, "a .tdms file (crash-safe, read by magcilia calibrate)")


def _per_axis(option: str, text: str | None) -> list[float]:
    """``"10"`` or ``"10,10,-12"`` (G/V) -> T/V per axis."""
    if text is None:
        raise fail(option, None, "given with --coil-output (field per output volt, G/V)")
    try:
        values = [float(x) * _G for x in text.split(",")]
    except ValueError:
        raise fail(option, text, "one number (G/V) or one per axis, e.g. 10 or 10,10,12"
                   ) from None
    return values


def _nidaq_channels(option: str, text: str) -> str:
    kind, _, target = text.partition(":")
    if kind != "nidaq" or not target:
        raise fail(option, text, "nidaq:DEV/CHANNEL[,CHANNEL...], e.g. nidaq:Dev1/ao0,ao1,ao2")
    return target


def coil_driver(options: CoilOptions) -> Any:
    """The NI coil output the options name, or None."""
    if options.output is None:
        for name, value in (("--coil-constant", options.constant), ("--coil-sense",
                                                                    options.sense)):
            if value is not None:
                raise fail(name, value, "given with --coil-output")
        return None
    from magcilia.acquire.coil_output import NidaqCoilOutput

    sense = None if options.sense is None else _nidaq_channels("--coil-sense", options.sense)
    return NidaqCoilOutput(
        _nidaq_channels("--coil-output", options.output),
        _per_axis("--coil-constant", options.constant), sense=sense,
        sense_constant=None if sense is None else _per_axis("--coil-sense-constant",
                                                            options.sense_constant))


def record_coil_command(source_spec: str, setup_arg: str, coil_text: str,
                        options: CoilOptions, samples: int, settle: float, rate: float,
                        set_reset: int | None, seed: int, out_path: str, force: bool,
                        as_json: bool, quiet: bool, si: bool, *, angles: str | None = None,
                        duration: float | None = None, dynamics: bool = False) -> None:
    """Check everything, then record the coil sweep and print it."""
    from magcilia.acquire import source_from_spec
    from magcilia.acquire.coil import CoilPoint, CoilSequence, record_coil
    from magcilia.acquire.simulated_coil import SimulatedCoilSource

    for option, value in (("--angles", angles), ("--duration", duration)):
        if value is not None:
            raise fail(option, value, "left out with --coil (the steps are fields)")
    if dynamics:
        raise fail("--sim-dynamics", True, "left out with --coil (the static hair)")
    check_record_path(out_path)
    setup = load_setup_arg(setup_arg)
    sequence = CoilSequence.from_text(coil_text)
    sequence.check(setup.sensor)  # before anything runs
    driver = coil_driver(options)
    if source_spec == "sim":
        if driver is not None:
            raise fail("--coil-output", options.output, "left out with --source sim (the "
                       "simulated coil)")
        if setup.cilium.tip_radius == 0.0:
            raise fail("--setup", setup_arg, "a cilium with a tip radius for the simulated coil "
                       "(a field's couple on a sharp tip is singular): --setup force-sensor, or "
                       "a setup file with tip_radius")
        source: Any = SimulatedCoilSource(setup, rate=rate, rng=seed, set_reset=set_reset)
    else:
        if driver is None:
            raise fail("--coil-output", None, f"given for --source {source_spec} (the analog "
                       "outputs that drive the coil, e.g. nidaq:Dev1/ao0,ao1,ao2)")
        source = source_from_spec(source_spec, setup=setup, rate=rate, rng=seed,
                                  set_reset=set_reset)
    units = output_units(si)
    metadata = {"setup_name": setup_label(setup_arg), "setup": setup_to_dict(setup),
                **(driver.metadata() if driver is not None else {})}

    def show(point: CoilPoint) -> None:
        if not (quiet or as_json):
            field = np.asarray(point.field) / _G
            mean, sem = (units.value(point.mean, "voltage"), units.value(point.sem, "voltage"))
            volt = units.unit("voltage")
            flag = (f"  SATURATED ({point.saturated} samples beyond range)" if point.saturated
                    else "")
            click.echo(f"({field[0]:+.4g}, {field[1]:+.4g}, {field[2]:+.4g}) G  {mean:+.6g} ± "
                       f"{sem:.5g} {volt}  ({point.samples} samples){flag}")

    result = record_coil(source, out_path, sequence, driver=driver, samples=samples,
                         settle=settle, sensor=setup.sensor, metadata=metadata,
                         overwrite=force, on_point=show)
    if as_json:
        echo_json({"units": units.system, **units.convert(result.to_dict())})  # type: ignore[dict-item]
        return
    click.echo(result.report().splitlines()[-1])
    click.echo(f"fit it with: magcilia calibrate {out_path} --model physical --prior "
               "height=...")
