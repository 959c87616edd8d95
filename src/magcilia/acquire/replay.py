"""A recording played back as a source: the samples of a TDMS recording, in chunks, at their rate.

:class:`ReplaySource` reads the ``recording`` group of a file that magcilia wrote
(:mod:`magcilia.io.recording_file`: ``magcilia record``, ``magcilia live --record``, the views'
Record button) a chunk at a time, with the times, set/reset marks and further channels the file
holds, so that anything that reads a :class:`~magcilia.acquire.source.Source` — the live read-out
above all (:mod:`magcilia.live.replay`) — can run on it again. It has the recorded rate and
channels (the sensor output, stored as ``voltage_V``, under the channel name the recording
names, ``output`` by default; a recording of field channels only — a 3-axis sensor's or an
array's ``NAME.x``, ``.y``, ``.z`` — has those alone), and:

* ``realtime=False`` (default): samples as fast as they are read (a reader waits for room
  instead of losing them: :mod:`magcilia.acquire.buffer`); ``realtime=True``: paced by the wall
  clock at the recorded rate (× ``speed``), as the device delivered them;
* ``block.time`` is the recorded time of each sample and ``block.first`` its index in the
  recording (:attr:`ReplaySource.recorded_clock` says so);
* the last read may return fewer samples than asked for (the rest of the file); the next one
  fails with :class:`EndOfRecordingError` and :attr:`finished` turns True;
* :attr:`tare_samples`: the indices of the samples from which the recorded live read-out took a
  tare (its ``tares`` group), where a replay takes it again.

The file is opened as an open file (npTDMS never reads an index file beside it, as
:mod:`magcilia.io.tdmsfile` explains) and read channel by channel slice by slice; the chunks'
checksums are not verified here (``magcilia readout`` and ``calibrate`` verify them).
"""

from __future__ import annotations

import contextlib
import json
import time
from collections.abc import Iterator
from pathlib import Path
from typing import IO, Any

import numpy as np

from magcilia import _validate as v
from magcilia._errors import AcquisitionError, MagciliaError
from magcilia.acquire.source import OUTPUT, Block, Channel, Source
from magcilia.io.tdmsfile import GROUP, nptdms_module, quiet_nptdms

#: channels of the ``recording`` group that are not the source's own channels
_BOOKKEEPING = ("time_s", "voltage_V", "setreset", "angle_deg")


class EndOfRecordingError(AcquisitionError):
    """A replayed recording has no more samples."""


def stored_properties(path: str | Path) -> dict[str, Any]:
    """A recording's file properties with the JSON-valued ones parsed (metadata that
    :class:`~magcilia.io.recording_file.RecordingWriter` stored as JSON text)."""
    from magcilia.io.recording_file import recording_properties

    props = recording_properties(path)
    out: dict[str, Any] = {}
    for key, value in props.items():
        if isinstance(value, str) and value[:1] in "{[":
            try:
                out[key] = json.loads(value)
                continue
            except ValueError:
                pass
        out[key] = value
    return out


class ReplaySource(Source):
    """The samples of a magcilia TDMS recording, played back (see the module docstring).

    Parameters
    ----------
    path : str or Path
        The recording (``.tdms``).
    realtime : bool
        Pace the samples by the wall clock at the recorded rate (False: as fast as they are
        read).
    speed : float
        With ``realtime``: how many times faster than recorded.

    Attributes
    ----------
    properties : dict
        The file's properties (metadata; JSON values parsed): what the recording stores.
    length : int
        Samples in the file.

    Raises
    ------
    MagciliaError
        If the file is not a magcilia recording with samples (one line naming the file).
    """

    #: block times are the recorded times, block.first the index in the recording
    recorded_clock = True

    def __init__(self, path: str | Path, *, realtime: bool = False, speed: float = 1.0) -> None:
        super().__init__()
        self.path = Path(path)
        if not self.path.is_file():
            raise MagciliaError(f"{self.path}: no such file")
        self.properties = stored_properties(self.path)
        self.realtime = bool(realtime)
        self.speed = v.positive("speed", speed, "", "factor")
        self.name = f"replay:{self.path.name}"
        rate = self.properties.get("rate_Hz")
        if not isinstance(rate, int | float) or not rate > 0:
            raise MagciliaError(f"{self.path}: not a recording magcilia wrote (no rate_Hz "
                                "property); replay needs one")
        self.rate = float(rate)
        replay = self.properties.get("replay")
        self.channel = str(replay.get("channel", OUTPUT)) if isinstance(replay, dict) else OUTPUT
        units = self.properties.get("channels")
        units = units if isinstance(units, dict) else {}
        self._file: IO[bytes] | None = None
        self._tdms: Any = None
        self._group: Any = None
        self._extra: tuple[str, ...] = ()
        self._position = 0
        self._started = 0.0
        self.finished = False
        with self._opened() as group:
            names = [c.name for c in group.channels()]
            self._extra = tuple(n for n in names if n not in _BOOKKEEPING)
            self._volts = "voltage_V" in names
            if "time_s" not in names or not (self._volts or self._extra):
                raise MagciliaError(f"{self.path}: no samples (group {GROUP!r} lacks time_s or "
                                    "voltage_V); nothing to replay")
            self.length = len(group["time_s"])
            self._setreset = "setreset" in names
            self.tare_samples = frozenset(int(x) for x in self._tares())
        own = (Channel(self.channel, str(units.get(self.channel, "V"))),) if self._volts else ()
        self.channels = (*own, *(Channel(n, str(units.get(n, ""))) for n in self._extra))

    # -- the file ---------------------------------------------------------------------------------
    @contextlib.contextmanager
    def _opened(self) -> Iterator[Any]:
        """The file open for a look (its ``recording`` group), closed again."""
        self._open_file()
        try:
            yield self._group
        finally:
            self._close_file()

    def _open_file(self) -> None:
        nptdms = nptdms_module("Replaying TDMS recordings")
        self._file = self.path.open("rb")
        try:
            with quiet_nptdms():
                self._tdms = nptdms.TdmsFile.open(self._file)
                self._group = self._tdms[GROUP]
        except Exception as exc:  # noqa: BLE001 - npTDMS raises KeyError, struct.error, …
            self._close_file()
            raise MagciliaError(f"{self.path}: cannot replay ({type(exc).__name__}: "
                                f"{str(exc)[:160]}); is it a magcilia recording?") from None

    def _close_file(self) -> None:
        tdms, file = self._tdms, self._file
        self._tdms = self._group = self._file = None
        if tdms is not None:
            tdms.close()
        if file is not None:
            file.close()

    def _tares(self) -> list[float]:
        """The recorded tares' first samples (the ``tares`` group), or none."""
        try:
            return [float(x) for x in self._tdms["tares"]["tare_sample"][:]]
        except KeyError:
            return []

    # -- Source -----------------------------------------------------------------------------------
    def _open(self) -> None:
        self._open_file()
        self._started = time.monotonic() - self._position / (self.rate * self.speed)

    def _close(self) -> None:
        self._close_file()

    def rewind(self) -> None:
        """Start again from the first sample."""
        self._position = 0
        self.finished = False

    def _read(self, n: int) -> Block:
        start = self._position
        if start >= self.length:
            self.finished = True
            raise EndOfRecordingError(f"{self.name}: end of the recording after {self.length} "
                                      "samples")
        stop = min(start + n, self.length)  # the last read may be short: the file ends
        group = self._group
        try:
            with quiet_nptdms():
                t = np.asarray(group["time_s"][start:stop], dtype=np.float64)
                data = ([np.asarray(group["voltage_V"][start:stop], dtype=np.float64)]
                        if self._volts else [])
                data += [np.asarray(group[k][start:stop], dtype=np.float64)
                         for k in self._extra]
                sr = (np.asarray(group["setreset"][start:stop]).astype(np.int8)
                      if self._setreset else None)
        except Exception as exc:  # noqa: BLE001 - a file damaged where it is read: one line
            raise AcquisitionError(f"{self.name}: cannot read samples {start}…{stop} "
                                   f"({type(exc).__name__}: {str(exc)[:160]})") from None
        self._position = stop
        if self.realtime:
            wait = self._started + stop / (self.rate * self.speed) - time.monotonic()
            if wait > 0.0:
                time.sleep(wait)
        return Block(time=t, data=np.array(data), channels=self.channels, first=start,
                     setreset=sr)

    def metadata(self) -> dict[str, Any]:
        """The recording's metadata, and that it is a replay of this file."""
        return {**super().metadata(), "replay_of": str(self.path),
                "recorded_source": self.properties.get("source")}
