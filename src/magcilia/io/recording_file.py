"""Recordings that survive a crash: samples streamed to a TDMS file in flushed chunks.

Every ``chunk`` samples the writer appends one TDMS segment (all channels) and flushes it to the
operating system, so a ``kill -9`` at any moment loses at most the chunk in progress and leaves a
file that :func:`magcilia.read_samples` and ``magcilia calibrate`` open (``tests/acquire`` kills
recorders to prove it; npTDMS reads a file cut inside its last segment). The file's properties
hold the metadata (source, rate, sensor, setup, start time, software version) and, once closed,
``complete`` and, if it ended early, ``stopped`` (why and where).

Layout: group ``recording`` with channels ``time_s`` (s), ``voltage_V`` (V), and where given
``angle_deg`` (the tilt of each sample, deg), ``setreset`` (+1 set, −1 reset) and any extra
channels of the source. Further groups (:meth:`RecordingWriter.write_group`: a live read-out's
values, its events) go into the same flushed segments; their channel names differ from the
``recording`` group's, so readers that look a channel up by name find the raw samples.
"""

from __future__ import annotations

import contextlib
import datetime as dt
import json
import os
from collections.abc import Callable, Iterator, Mapping
from pathlib import Path
from types import TracebackType
from typing import IO, Any, Self

import numpy as np
from numpy.typing import ArrayLike, NDArray

from magcilia import _validate as v
from magcilia._atomic import jsonable
from magcilia._errors import AcquisitionError, MagciliaError
from magcilia._validate import printable
from magcilia.io.recordings import nptdms_module, quiet_nptdms

F64 = NDArray[np.float64]
GROUP = "recording"


def _property(value: Any) -> Any:
    """A TDMS property value: strings, numbers and booleans as they are, the rest as JSON."""
    if isinstance(value, bool | int | float | str):
        return value
    return json.dumps(jsonable(value))


class RecordingWriter:
    """Streams samples to a TDMS file (see the module docstring).

    Parameters
    ----------
    path : str or Path
        The file to write (``.tdms``); replaced if it exists.
    metadata : mapping
        What the recording should remember (source, rate, sensor, setup, …); JSON-ready values.
    chunk : int
        Samples per flushed segment: at most this many are lost in a crash.
    fsync : bool
        Also ask the disk to store each chunk (survives a power cut, not only a killed process;
        slower).

    Examples
    --------
    >>> import numpy as np, tempfile, pathlib
    >>> path = pathlib.Path(tempfile.mkdtemp()) / "run.tdms"
    >>> with RecordingWriter(path, metadata={"source": "sim"}, chunk=100) as rec:
    ...     rec.write(np.arange(250) / 1e3, np.zeros(250), angle_deg=np.full(250, 10.0))
    >>> rec.samples, rec.chunks
    (250, 3)
    """

    def __init__(self, path: str | Path, *, metadata: Mapping[str, Any] | None = None,
                 chunk: int = 4096, fsync: bool = False) -> None:
        self.path = Path(path)
        self.metadata = dict(metadata or {})
        self.chunk = v.integer("chunk", chunk, 1)
        self.fsync = bool(fsync)
        self.samples = 0
        self.chunks = 0
        self._pending: dict[str, list[F64]] = {}
        self._names: tuple[str, ...] | None = None
        self._groups: dict[str, dict[str, list[F64]]] = {}  # further groups' pending columns
        self._units: dict[tuple[str, str], str] = {}
        self._file: IO[bytes] | None = None
        self._writer: Any = None

    # -- life cycle -------------------------------------------------------------------------------
    def open(self) -> Self:
        """Create the file and write its properties (idempotent)."""
        if self._writer is not None:
            return self
        nptdms = nptdms_module("Recording to TDMS files")
        if self.path.suffix.lower() != ".tdms":
            raise v.fail("recording file", str(self.path), "a path ending in .tdms")
        self.path.parent.mkdir(parents=True, exist_ok=True)
        from magcilia._version import __version__

        props = {key: _property(val) for key, val in self.metadata.items() if val is not None}
        props.update(magcilia_version=__version__, complete=False,
                     start_time=dt.datetime.now(dt.UTC).isoformat(timespec="seconds"))
        self._file = self.path.open("wb")
        self._writer = nptdms.TdmsWriter(self._file)
        self._segment([nptdms.RootObject(props), nptdms.GroupObject(GROUP)])
        return self

    def close(self, *, complete: bool = True, stopped: str | None = None) -> None:
        """Write what is pending and the closing properties, and close the file (idempotent).

        Parameters
        ----------
        complete : bool
            Whether the recording ended as planned.
        stopped : str, optional
            Why and where it ended early (stored as the property ``stopped``).
        """
        if self._writer is None:
            return
        nptdms = nptdms_module("Recording to TDMS files")
        try:
            self._flush_pending()
            props: dict[str, Any] = {"complete": complete, "samples": self.samples}
            if stopped:
                props["stopped"] = stopped
            self._segment([nptdms.RootObject(props)])
        finally:
            assert self._file is not None
            self._writer = None
            self._file.close()
            self._file = None

    def abort(self, stopped: str) -> bool:
        """Close after a failure, saying why and where (``stopped``); returns whether a recording
        is kept. A file without a single chunk of samples is removed; a failure to write the last
        note (the disk is what failed) is ignored: the chunks written so far stay readable."""
        with contextlib.suppress(MagciliaError):
            self.close(complete=False, stopped=stopped)
        if self.samples == 0:
            self.path.unlink(missing_ok=True)
            return False
        return True

    @contextlib.contextmanager
    def keeping(self, where: Callable[[], str]) -> Iterator[Self]:
        """Record inside the block; if it fails (the device, the disk, Ctrl-C), close the file with
        a note saying where it stopped (``where()``, e.g. "at angle 4") and raise one line saying
        what is kept (a Ctrl-C is raised again as it is).

        Raises
        ------
        AcquisitionError
            For a :class:`MagciliaError` or an ``OSError`` inside the block.
        """
        try:
            yield self
        except (MagciliaError, OSError, KeyboardInterrupt) as exc:
            reason = "interrupted" if isinstance(exc, KeyboardInterrupt) else str(exc)
            stopped = f"stopped {where()}: {reason}"
            kept = self.abort(stopped)
            if isinstance(exc, KeyboardInterrupt):
                raise
            if not kept:
                raise AcquisitionError(f"{reason}; nothing was recorded") from None
            raise AcquisitionError(f"{stopped}; the recording so far is kept in "
                                   f"{self.path}") from None

    def __enter__(self) -> Self:
        return self.open()

    def __exit__(self, exc_type: type[BaseException] | None, exc: BaseException | None,
                 tb: TracebackType | None) -> None:
        self.close(complete=exc is None,
                   stopped=None if exc is None else f"{type(exc).__name__}: {exc}")

    # -- writing ----------------------------------------------------------------------------------
    def write(self, time: ArrayLike, volts: ArrayLike, *, angle_deg: ArrayLike | None = None,
              setreset: ArrayLike | None = None,
              extra: Mapping[str, ArrayLike] | None = None) -> None:
        """Append samples; every ``chunk`` samples go to disk as one flushed segment.

        Parameters
        ----------
        time : array-like, shape (n,)
            Sample times, s.
        volts : array-like, shape (n,)
            Sensor output, V.
        angle_deg : array-like, shape (n,), optional
            Tilt angle of each sample, deg.
        setreset : array-like, shape (n,), optional
            +1 after a set pulse, −1 after a reset pulse.
        extra : mapping of str to array-like, each shape (n,), optional
            Further channels of the source (their names as channel names).

        Notes
        -----
        The same channels must be given on every call.
        """
        columns = {"time_s": time, "voltage_V": volts}
        if angle_deg is not None:
            columns["angle_deg"] = angle_deg
        if setreset is not None:
            columns["setreset"] = setreset
        columns.update(extra or {})
        arrays = {k: np.asarray(a, dtype=np.float64).ravel() for k, a in columns.items()}
        n = arrays["time_s"].size
        if any(a.size != n for a in arrays.values()):
            raise v.fail("recording columns", {k: a.size for k, a in arrays.items()},
                         "the same number of samples in every channel")
        self.open()
        if self._names is None:  # declare the channels at once: an early crash leaves them empty
            self._names = tuple(arrays)
            self._pending = {k: [np.zeros(0)] for k in self._names}
            self._flush_pending(0)
        elif tuple(arrays) != self._names:
            raise v.fail("recording channels", tuple(arrays), f"the channels {self._names} "
                         "of the first write")
        for k, a in arrays.items():
            self._pending[k].append(a)
        while self._pending_size() >= self.chunk:
            self._flush_pending(self.chunk)

    def write_group(self, group: str, columns: Mapping[str, ArrayLike],
                    units: Mapping[str, str] | None = None) -> None:
        """Append columns to a further group (not ``recording``), written with the next flushed
        chunk of samples (or at :meth:`close`).

        Parameters
        ----------
        group : str
            The group, e.g. ``"readout"``; its channel names must not be the ``recording``
            group's.
        columns : mapping of str to array-like, each shape (m,)
            The channels; the same names on every call for a group.
        units : mapping of str to str, optional
            Unit of each channel (stored as the channel's ``unit_string`` property).
        """
        arrays = {k: np.asarray(a, dtype=np.float64).ravel() for k, a in columns.items()}
        if group == GROUP or not arrays:
            raise v.fail("recording group", group, f"a group other than {GROUP!r} with channels")
        if len({a.size for a in arrays.values()}) > 1:
            raise v.fail(f"{group} columns", {k: a.size for k, a in arrays.items()},
                         "the same number of values in every channel")
        pending = self._groups.setdefault(group, {k: [] for k in arrays})
        if tuple(pending) != tuple(arrays):
            raise v.fail(f"{group} channels", tuple(arrays), f"the channels {tuple(pending)} "
                         "of the first write")
        for k, a in arrays.items():
            pending[k].append(a)
        for k, unit in (units or {}).items():
            self._units[group, k] = unit
        self.open()

    def _group_objects(self) -> list[Any]:
        """Every further group's pending columns as channel objects (and forget them)."""
        nptdms = nptdms_module("Recording to TDMS files")
        objects = []
        for group, pending in self._groups.items():
            for name, parts in pending.items():
                unit = self._units.get((group, name))
                objects.append(nptdms.ChannelObject(
                    group, name, np.concatenate(parts) if parts else np.zeros(0),
                    properties={"unit_string": unit} if unit else None))
                pending[name] = []
        return objects

    def _pending_size(self) -> int:
        return sum(a.size for a in self._pending.get("time_s", []))

    def _flush_pending(self, limit: int | None = None) -> None:
        """Write up to ``limit`` pending samples (all by default) as one segment."""
        n = self._pending_size() if limit is None else limit
        if self._names is None or (n == 0 and limit is None):
            if self._groups and limit is None:  # no samples but a further group's values
                self._segment(self._group_objects())
            return
        nptdms = nptdms_module("Recording to TDMS files")
        objects = []
        for name in self._names:
            joined = np.concatenate(self._pending[name])
            self._pending[name] = [joined[n:]] if joined.size > n else []
            data = joined[:n].astype(np.int8) if name == "setreset" else joined[:n]
            objects.append(nptdms.ChannelObject(GROUP, name, data))
        self._segment(objects + self._group_objects())
        self.samples += n
        self.chunks += n > 0

    def _segment(self, objects: list[Any]) -> None:
        """Write one TDMS segment and flush it to the operating system (and the disk)."""
        assert self._file is not None
        try:
            self._writer.write_segment(objects)
            self._file.flush()
            if self.fsync:
                os.fsync(self._file.fileno())
        except OSError as exc:
            raise MagciliaError(
                f"{self.path}: writing failed after {self.samples} samples "
                f"({exc.strerror or exc}); the recording so far is kept") from None


def recording_properties(path: str | Path) -> dict[str, Any]:
    """The file properties of a TDMS recording (metadata, ``complete``, ``stopped``, …)."""
    nptdms = nptdms_module()
    try:  # the file opened here: npTDMS leaks its own handle when parsing fails
        with quiet_nptdms(), Path(path).open("rb") as file, nptdms.TdmsFile.open(file) as tdms:
            return dict(tdms.properties)
    except OSError as exc:
        raise MagciliaError(f"{path}: cannot read the file ({exc.strerror or exc})") from None
    except Exception as exc:  # npTDMS raises struct.error, NotImplementedError, …
        raise MagciliaError(f"{path}: cannot read as a TDMS file ({type(exc).__name__}: "
                            f"{printable(str(exc))[:200]})") from exc
