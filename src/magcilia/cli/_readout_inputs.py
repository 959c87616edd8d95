"""The inputs of the read-out commands (``readout``, ``live``): a span in display units, a
recording's columns after the quality checks, its voltages, the edge tolerance, the tare's
readings."""

from __future__ import annotations

import dataclasses

import numpy as np

from magcilia._errors import MagciliaError
from magcilia._validate import fail
from magcilia.cli import _thermal as thermal
from magcilia.cli._common import RecordingArgs
from magcilia.device.parameters import MEASURANDS
from magcilia.io import recordings
from magcilia.io.quality import screen
from magcilia.units import parse_quantity, parse_value, parse_values


def parse_span(text: str, quantity: str) -> tuple[float, float]:
    """``LO:HI`` in the display unit (deg, mN, m/s), or with units on each end or the last
    (``0:0.2mN``, ``0mN:200uN``) -> SI."""
    q = MEASURANDS[quantity]
    lo, hi = parse_values(text, q.dimension, q.display, "--span", (2,), f"0:1{q.display}")
    if hi <= lo:
        raise fail("--span", text, "LO:HI with HI > LO")
    return lo, hi


def read_checked(path: str, reading: RecordingArgs, required: tuple[str, ...], *,
                 quiet: bool, suspect: str) -> tuple[dict[str, np.ndarray], list[str],
                                                     dict[str, object]]:
    """A recording's columns after the quality checks (:func:`magcilia.io.quality.screen`: the
    flagged samples kept, omitted or refused by ``suspect``), with the notes
    to print (the reader's, an incomplete recording, the checks' findings) and the checks'
    result (``RecordingQuality.to_dict``)."""
    raw = reading.read(recordings.read_recording, path, quiet=quiet, required=required)
    cols = raw.columns
    notes = list(raw.notes)
    incomplete = raw.state.incomplete_note()
    if incomplete is not None:
        notes.append(incomplete)
    doc: dict[str, object] = {}
    if cols and next(iter(cols.values())).size:
        quality, kept = screen(cols, suspect, path)
        cols = dict(kept)
        doc = quality.to_dict()
        if quality.found:
            notes.append(quality.report())
    return cols, [f"note: {path}: {n}" for n in notes], doc


def read_recording(path: str, reading: RecordingArgs | None = None, option: str = "RECORDING",
                   quiet: bool = False, suspect: str = "keep"
                   ) -> tuple[np.ndarray, np.ndarray | None, list[str], dict[str, object],
                              np.ndarray | None]:
    """Voltages (V), optional times (s), the notes to print, the quality checks' result and the
    optional temperatures (K) of a recording (CSV/.mat/.tdms/.h5 with ``voltage_V``, or the
    columns that ``reading`` maps)."""
    reading = reading or RecordingArgs()  # (with the temperature, compensated when there)
    reading = dataclasses.replace(reading, columns=reading.columns.with_temperature())
    cols, notes, quality = read_checked(path, reading, ("voltage_V",), quiet=quiet,
                                        suspect=suspect)
    if cols["voltage_V"].size == 0:
        raise fail(option, path, "a recording with at least one reading")
    return cols["voltage_V"], cols.get("time_s"), notes, quality, cols.get(thermal.COLUMN)


def parse_edge_tolerance(text: str | None, quantity: str,
                         span: tuple[float, float]) -> float | None:
    """``--edge-tolerance``: a percentage of the span (``5%``), a value with a unit (``0.01mN``)
    or a bare number in the display unit -> SI (None: the library's default)."""
    if text is None:
        return None
    q = MEASURANDS[quantity]
    allowed = f"a percentage of the span (5%) or a value in {q.display} (or with a unit)"
    t = text.strip()
    try:
        value = (parse_value(t[:-1], None, "", "--edge-tolerance") / 100.0 * (span[1] - span[0])
                 if t.endswith("%") else parse_value(t, q.dimension, q.display, "--edge-tolerance"))
    except MagciliaError:
        raise fail("--edge-tolerance", text, allowed) from None
    if not value >= 0.0:
        raise fail("--edge-tolerance", text, allowed.replace("a percentage", "a non-negative "
                                                              "percentage"))
    return value


def tare_readings(spec: str, volts: np.ndarray, times: np.ndarray | None) -> np.ndarray:
    """``--tare SPEC``: the first readings of the recording, a duration with a unit from its
    start (``0.5s``, ``200ms``; needs ``time_s``) or a sample count (``500``)."""
    allowed = "a duration from the start with a unit (0.5s) or a number of readings (500)"
    t = spec.strip()
    if t.isdigit():
        count = int(t)
    else:
        try:
            seconds = parse_quantity(t, "time", "--tare")
        except MagciliaError:
            raise fail("--tare", spec, allowed) from None
        if not seconds > 0.0:
            raise fail("--tare", spec, allowed)
        if times is None:
            raise fail("--tare", spec, "a number of readings (500): the recording has no "
                       "time_s column")
        count = int(np.count_nonzero(times - times[0] < seconds))
    if count < 2:
        raise fail("--tare", spec, f"{allowed}, covering at least 2 readings")
    if count > volts.size:
        raise fail("--tare", spec, f"at most the recording's {volts.size} readings")
    return volts[:count]
