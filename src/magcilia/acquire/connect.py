"""Sources by name, as the command line gives them: ``sim``, ``serial:PORT``, ``nidaq:DEV/ai0``."""

from __future__ import annotations

from magcilia import _validate as v
from magcilia.acquire.serial_formats import SerialFormat
from magcilia.acquire.simulated import SimulatedSource
from magcilia.acquire.source import Channel, Source
from magcilia.device.setup import Setup
from magcilia.device.temperature import TemperatureModel, TemperatureProfile
from magcilia.mechanics.drag import AIR

KINDS = ("sim", "serial:PORT", "nidaq:DEV/aiN")


def source_from_spec(spec: str, *, setup: Setup, rate: float = 1000.0,
                     rng: int | None = None, set_reset: int | None = None,
                     realtime: bool = False, dynamics: bool = False,
                     temperature: TemperatureProfile | None = None,
                     thermal: TemperatureModel | None = None,
                     serial: SerialFormat | None = None,
                     names: tuple[Channel, ...] | None = None) -> Source:
    """The source named by ``spec``.

    Parameters
    ----------
    spec : str
        ``"sim"`` (a :class:`SimulatedSource` of ``setup``), ``"serial:PORT"`` (a device speaking
        magcilia's framed protocol, e.g. ``serial:/dev/ttyACM0`` or ``serial:COM3``) or
        ``"nidaq:DEV/aiN"`` (an NI-DAQmx channel, e.g. ``nidaq:Dev1/ai0``).
    setup : Setup
        The simulated sensor (``sim`` only).
    rate : float
        Sample rate, Hz (``sim`` and ``nidaq``; a serial device sends its own).
    rng : int, optional
        Seed of the simulation.
    set_reset : int, optional
        Alternate set/reset pulses every this many samples (``sim``; ``nidaq`` with a strap
        line is configured in Python).
    realtime : bool
        Pace the simulation by the wall clock.
    dynamics : bool
        ``sim``: the simulated hair moves through its bending modes, in air
        (:class:`SimulatedSource`'s ``dynamics``).
    temperature, thermal : TemperatureProfile, TemperatureModel, optional
        ``sim``: the temperature over time and the coefficients the output follows
        (:class:`SimulatedSource`'s).
    serial : SerialFormat, optional
        ``serial:PORT``: what the device sends (default magcilia's framed protocol; ASCII lines
        or float32 frames are read by
        :class:`~magcilia.acquire.serial_unverified.UnverifiedSerialSource` at ``rate``).
    names : tuple of Channel, optional
        ``serial:PORT``: what the device's channels are, in order (a 3-axis part's field
        channels, :func:`~magcilia.acquire.simulated_loads.field_channels`); default
        ``output``, ``ch1``, … in V.
    """
    kind, _, target = spec.partition(":")
    serial = SerialFormat() if serial is None else serial
    if not serial.verified and not (kind == "serial" and target):
        raise v.fail("--format", serial.format, "magcilia (the default) unless --source is "
                     "serial:PORT")
    if kind == "sim" and not target:
        return SimulatedSource(setup, rate=rate, rng=rng, set_reset=set_reset, realtime=realtime,
                               dynamics=dynamics, fluid=AIR if dynamics else None,
                               temperature=temperature, thermal=thermal)
    if dynamics:
        raise v.fail("--sim-dynamics", True, "given with --source sim only")
    if temperature is not None:
        raise v.fail("--temperature", temperature.describe(), "given with --source sim only (a "
                     "device's temperature comes from its own channel)")
    if kind == "serial" and target:
        if not serial.verified:
            from magcilia.acquire.serial_unverified import UnverifiedSerialSource

            return UnverifiedSerialSource(target, format=serial.format, rate=rate,
                                          fields=serial.fields, channels=serial.channels,
                                          names=names)
        from magcilia.acquire.serial import SerialSource

        return SerialSource(target, names=names)
    if kind == "nidaq" and target:
        from magcilia.acquire.nidaq import NidaqSource

        return NidaqSource(target, rate=rate)
    raise v.fail("--source", spec, "one of " + ", ".join(KINDS))
