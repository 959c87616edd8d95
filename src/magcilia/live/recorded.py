"""What a live recording stores for its replay, and how it is read back.

A live recording (``magcilia live --record FILE``, or the views' Record button) stores, besides
the raw samples (group ``recording``) and the values the view showed (group ``readout``: each
reading ``raw_V``, the ``correction_V`` of tare and zero tracking, ``value``, ``sigma``,
``flags`` and the ``noise_V`` that σ used), what it takes to compute those values again:

* the file property ``replay`` (:func:`replay_metadata`): the read-out's own settings
  (:func:`readout_spec`: its ``kind`` — ``scalar``, ``vector`` or ``array`` —, its ``inputs``, the
  ``cilia`` of an array; a single output's quantity, span, table size, edge rule, fluid and the
  calibration's covariance; a force vector's span, grid, edge tolerance and channels; an array's
  spans, table size, regularisation and stopping rule; the setup, or the array file's document,
  is the property ``setup``), the pipeline's (channel, samples per processing step, tare
  seconds, set/reset demodulation) and the whole state of zero tracking when the recording started
  (:meth:`~magcilia.live.zero.Zero.state`: a recording started mid-run goes on from there);
* for force vectors, the ``readout`` group's ``noise_T[NAME]`` per channel instead of
  ``noise_V`` (:mod:`magcilia.live.recording`);
* the group ``tares``, channel ``tare_sample``: the index of the first sample of every tare
  request's window — a replay takes the tare again there, from the same readings, with the same
  rest check.

The pipeline's hooks for a replay (:func:`recorded_clock`, :func:`replayed_tare`,
:func:`replay_finished`) live here, the replay itself in :mod:`magcilia.live.replay`.
:func:`recorded_readout`, :func:`recorded_readings` and :func:`read_recorded` are what
``magcilia readout FILE`` of a live recording uses: the stored read-out and the readings the
view read, corrected as the view corrected them, with the noise σ used (a single output's;
a recording of force vectors is replayed, :mod:`magcilia.live.replay`).
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from magcilia._errors import MagciliaError
from magcilia.acquire.replay import ReplaySource
from magcilia.acquire.source import Block, Source
from magcilia.calibration import ParameterCovariance
from magcilia.device.temperature import TemperatureModel
from magcilia.io.array_file import array_from_dict
from magcilia.io.setup_files import setup_from_dict
from magcilia.mechanics import FLUIDS, Flow
from magcilia.readout.array_readout import ArrayReadout
from magcilia.readout.biaxial import BiaxialReadout
from magcilia.readout.channel import Channel
from magcilia.readout.dynamic import DynamicReadout
from magcilia.readout.inverse import Readout
from magcilia.readout.thermal import ThermalReadout

F64 = NDArray[np.float64]

#: version of the ``replay`` property this module writes
REPLAY_VERSION = 1
#: table points of a read-out built without ``table_size`` (``Readout``'s default)
_DEFAULT_TABLE = 257


# -- the hooks of the pipeline ------------------------------------------------------------------
def recorded_clock(source: Source) -> bool:
    """Whether ``source``'s block times are a recorded read-out's clock (a replay)."""
    return bool(getattr(source, "recorded_clock", False))


def replay_finished(source: Source) -> bool:
    """Whether ``source`` is a replay that has reached the end of its recording."""
    return isinstance(source, ReplaySource) and source.finished


def replayed_tare(source: Source, block: Block) -> bool:
    """Whether the recorded read-out began a tare's window at ``block``'s first sample."""
    return isinstance(source, ReplaySource) and block.first in source.tare_samples


def readout_spec(readout: Any) -> dict[str, Any]:
    """What rebuilds ``readout`` with the setup (JSON-ready; see the module docstring)."""
    inputs = list(readout.inputs)
    if isinstance(readout, BiaxialReadout):
        return {"kind": "vector", "inputs": inputs, "span": readout.span,
                "table_size": [int(readout.forces.size), int(readout.azimuths.size)],
                "edge_tolerance": readout.edge_tolerance,
                "channels": [c.to_dict() for c in readout.channels]}
    if isinstance(readout, ArrayReadout):
        return {"kind": "array", "inputs": inputs, "cilia": list(readout.array.names),
                "span": readout.span.tolist(), "table_size": readout.table_size,
                "regularization": readout.regularization,
                "max_iterations": readout.max_iterations, "tolerance": readout.tolerance}
    if isinstance(readout, ThermalReadout):  # the read-out at the reference, and the model's
        return {**readout_spec(readout.readout), "inputs": inputs, "temperature": {
            "model": readout.model.to_dict(), "calibrated_range_K": list(readout.calibrated_range)}}
    if isinstance(readout, DynamicReadout):  # the static read-out's, and the filter's
        return {**readout_spec(readout.static), "dynamic": {
            "rate_Hz": readout.rate, "bandwidth_Hz": readout.bandwidth,
            "averaged": readout.averaged, "fluid": readout.fluid}}
    calibration = readout.calibration
    fluid = next((name for name, f in FLUIDS.items() if f == readout.flow.fluid), None)
    return {"kind": "scalar", "inputs": inputs, "quantity": readout.quantity,
            "span": list(readout.span),
            "table_size": int(readout.table_quantity.size), "edge": readout.edge,
            "edge_tolerance": list(readout.edge_tolerance), "fluid": fluid,
            "calibration": (calibration.to_dict() if isinstance(calibration, ParameterCovariance)
                            else None)}


def replay_metadata(live: Any) -> dict[str, Any]:
    """The file property ``replay`` of the recording of ``live`` (a
    :class:`~magcilia.live.pipeline.LiveReadout`; see the module docstring)."""
    return {"replay": {
        "version": REPLAY_VERSION, "channel": live.channel,
        "batch_samples": live._chunk(),  # the pipeline's own step, for its replay
        "tare_seconds": live.tare_seconds, "demodulate": live.demodulate,
        "readout": readout_spec(live.readout), "zero": live.zero.state()}}


def recording_metadata(live: Any) -> dict[str, Any]:
    """The file properties of a recording of ``live`` (a
    :class:`~magcilia.live.pipeline.LiveReadout`): the source's, the read-out's description,
    the setup (or array document), rates, event codes, kind, inputs, cilia, the tare's
    correction and :func:`replay_metadata`."""
    from magcilia.live.status import EVENTS

    s = live.sensor
    described = s.view if s.thermal is None else s.thermal.thermal  # (a ThermalReadout's view)
    metadata = {**live.source.metadata(), "live": True, "readout": described.to_dict(),
                "setup": s.setup, "output_rate_Hz": live.rate, "factor": live.factor,
                "event_codes": EVENTS, "kind": s.kind, "inputs": list(live.inputs),
                f"tare_correction_{s.channel_unit}": np.asarray(live.zero.correction).tolist(),
                **replay_metadata(live)}
    if s.names:
        metadata["cilia"] = list(s.names)
    return metadata


# -- reading a live recording back --------------------------------------------------------------
def stored(props: dict[str, Any], path: Path) -> tuple[dict[str, Any], dict[str, Any]]:
    """The stored setup and read-out settings of a live recording's properties."""
    if not props.get("live"):
        raise MagciliaError(f"{path}: not a live read-out's recording (magcilia live --record, "
                            "or the view's Record button)")
    setup = props.get("setup")
    replay_doc = props.get("replay")
    spec = replay_doc.get("readout") if isinstance(replay_doc, dict) else None
    if spec is None and isinstance(props.get("readout"), dict):  # recorded before replays
        old = props["readout"]
        spec = {"quantity": old.get("quantity"), "span": old.get("span"),
                "table_size": old.get("table_size", 513) // 2 + 1, "edge": old.get("edge"),
                "fluid": "water", "calibration": None}
    if not isinstance(setup, dict) or not isinstance(spec, dict):
        raise MagciliaError(f"{path}: the recording does not store its setup and read-out")
    return setup, spec


def recorded_kind(path: str | Path) -> str:
    """The kind of read-out a live recording stores: ``"scalar"``, ``"vector"`` or
    ``"array"``."""
    from magcilia.acquire.replay import stored_properties

    p = Path(path)
    return str(stored(stored_properties(p), p)[1].get("kind", "scalar"))


def _field_readout(p: Path, setup_doc: dict[str, Any], spec: dict[str, Any]) -> Any:
    """The force-vector read-out (3-axis sensor or array) that ``spec`` describes."""
    try:
        if spec["kind"] == "array":
            return ArrayReadout(array_from_dict(setup_doc, source=f"{p} (stored array)"),
                                spec["span"], table_size=int(spec["table_size"]),
                                regularization=float(spec["regularization"]),
                                max_iterations=int(spec["max_iterations"]),
                                tolerance=float(spec["tolerance"]))
        doc = {k: x for k, x in setup_doc.items() if k != "channels"}
        channels = [Channel(c["position"], c["axis"], c["sigma"],
                            float("inf") if c["field_range"] is None else c["field_range"],
                            c["name"], c["resolution"]) for c in spec["channels"]]
        return BiaxialReadout(setup_from_dict(doc, source=f"{p} (stored setup)"), channels,
                              float(spec["span"]), table_size=tuple(spec["table_size"]),
                              edge_tolerance=float(spec["edge_tolerance"]))
    except (KeyError, TypeError, ValueError) as exc:
        raise MagciliaError(f"{p}: the stored read-out is incomplete ({exc})") from None
    except MagciliaError as exc:
        raise MagciliaError(f"{p}: the stored read-out: {exc}") from None


def recorded_readout(path: str | Path, *, setup: Any = None, quantity: str | None = None,
                     span: tuple[float, float] | None = None, dynamic: bool = False) -> Any:
    """The read-out a live recording stores, each of its setup, quantity and span replaced
    where given (a single output: its setup, quantity, span, table, edge rule, fluid and
    calibration, a :class:`~magcilia.Readout`; force vectors: the
    :class:`~magcilia.BiaxialReadout` or :class:`~magcilia.ArrayReadout` recorded, as stored).
    With ``dynamic``, a single output recorded by the dynamic read-out is that
    :class:`~magcilia.DynamicReadout` again (its rate, bandwidth, window means and fluid), the
    replay's; else its static read-out.

    Raises
    ------
    MagciliaError
        If ``path`` is not a live recording, or what it stores does not make a read-out, or
        a replacement is given for force vectors.
    """
    from magcilia.acquire.replay import stored_properties

    p = Path(path)
    props = stored_properties(p)
    setup_doc, spec = stored(props, p)
    if spec.get("kind", "scalar") != "scalar":
        given = [name for name, x in (("setup", setup), ("quantity", quantity), ("span", span))
                 if x is not None]
        if given:
            raise MagciliaError(f"{p}: a recording of force vectors ({spec['kind']}) is read "
                                f"with what it stores; leave out {', '.join(given)}")
        return _field_readout(p, setup_doc, spec)
    stored_setup = setup_from_dict(setup_doc, source=f"{p} (stored setup)")
    q = quantity or spec["quantity"]
    same = q == spec["quantity"]
    calibration = (ParameterCovariance.from_dict(spec["calibration"], source=str(p))
                   if spec.get("calibration") else None)
    fluid = spec.get("fluid") or "water"
    size = int(spec.get("table_size", 257))

    def build(table_size: int) -> Readout:
        return Readout(setup if setup is not None else stored_setup, q,
                       span=span if span is not None else
                       (tuple(spec["span"]) if same else None),
                       calibration=calibration,
                       flow=Flow.uniform(1.0, FLUIDS[fluid]) if q == "flow" else None,
                       table_size=table_size, edge=spec.get("edge") or "extrapolate")
    try:
        readout = build(size)
        if readout.fold is not None and readout.table_quantity.size != size:
            # a folded table keeps fewer points than it was built with: the default was used
            readout = build(_DEFAULT_TABLE)
        filtered = spec.get("dynamic") if dynamic else None
        if isinstance(filtered, dict):
            name = str(filtered.get("fluid"))
            return DynamicReadout(readout, float(filtered["rate_Hz"]),
                                  fluid=FLUIDS.get(name), averaged=bool(filtered["averaged"]),
                                  bandwidth=float(filtered["bandwidth_Hz"]))
        warm = spec.get("temperature") if dynamic else None  # (a replay compensates again)
        if isinstance(warm, dict):
            return ThermalReadout(readout, TemperatureModel.from_dict(warm["model"]),
                                  tuple(warm["calibrated_range_K"]))
    except MagciliaError as exc:
        what = "the stored read-out" if setup is None else "the read-out on the setup given"
        raise MagciliaError(f"{p}: {what}: {exc}") from None
    return readout


@dataclass(frozen=True, eq=False)
class RecordedReadings:
    """The readings a live view read, as it corrected them (immutable; SI).

    Attributes
    ----------
    time : ndarray, shape (m,)
        Each reading's time, s (the read-out's clock).
    volts : ndarray, shape (m,)
        Each reading (the window's mean, demodulated), V, with the view's correction (tare and
        zero tracking) added.
    correction : ndarray, shape (m,)
        That correction, V.
    noise : ndarray, shape (m,)
        The noise RMS of one reading that σ used, V (NaN in recordings made before it was
        stored).
    value, sigma : ndarray, shape (m,)
        What the view showed (SI; NaN where flagged).
    flags : ndarray of uint16, shape (m,)
        Its flags.
    """

    time: F64
    volts: F64
    correction: F64
    noise: F64
    value: F64
    sigma: F64
    flags: NDArray[np.uint16]


def recorded_readings(path: str | Path) -> RecordedReadings:
    """The readings of a live recording's ``readout`` group (see :class:`RecordedReadings`).

    Raises
    ------
    MagciliaError
        If the file has no ``readout`` group (not a live recording) or cannot be read.
    """
    from magcilia.io.tdmsfile import nptdms_module, quiet_nptdms

    p = Path(path)
    nptdms = nptdms_module("Reading live recordings")
    try:
        with quiet_nptdms(), p.open("rb") as file, nptdms.TdmsFile.open(file) as tdms:
            group = tdms["readout"]
            names = [c.name for c in group.channels()]

            def col(name: str) -> F64:
                if name not in names:
                    return np.full(len(group["raw_V"]), np.nan)
                return np.asarray(group[name][:], dtype=np.float64)
            raw, corr = col("raw_V"), col("correction_V")
            return RecordedReadings(time=col("readout_time_s"), volts=raw + corr,
                                    correction=corr, noise=col("noise_V"), value=col("value"),
                                    sigma=col("sigma"),
                                    flags=np.nan_to_num(col("flags")).astype(np.uint16))
    except KeyError:
        raise MagciliaError(f"{p}: no read-out values (group 'readout'): not a live "
                            "recording") from None
    except OSError as exc:
        raise MagciliaError(f"{p}: cannot read the file ({exc.strerror or exc})") from None


def read_recorded(readout: Readout, readings: RecordedReadings) -> Any:
    """``readout.read`` of the recorded readings with the noise each used (readings are grouped
    by that noise to 4 significant digits; the read-out's own noise where none is stored)."""
    noise = readings.noise
    if not np.isfinite(noise).any():
        return readout.read(readings.volts)
    finite = np.where(np.isfinite(noise) & (noise > 0), noise, np.nanmedian(noise))
    key = np.asarray([float(f"{x:.4g}") for x in finite])
    levels, where = np.unique(key, return_inverse=True)
    parts = [readout.read(readings.volts[where == i], noise=float(level))
             for i, level in enumerate(levels)]
    if len(parts) == 1:
        return parts[0]
    import dataclasses

    fields: dict[str, Any] = {}
    first = parts[0]
    for f in dataclasses.fields(first):
        value = getattr(first, f.name)
        if isinstance(value, np.ndarray) and value.shape == (int((where == 0).sum()),):
            out = np.empty(where.size, dtype=value.dtype)
            for i, part in enumerate(parts):
                out[where == i] = getattr(part, f.name)
            fields[f.name] = out
    return dataclasses.replace(first, **fields)


