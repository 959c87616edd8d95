"""Recordings that survive a crash: samples streamed to a TDMS file in flushed chunks.

The writer appends one TDMS segment (all channels) and flushes it to the operating system every
``chunk`` samples, or sooner, once the oldest sample waiting has waited ``flush_interval``
seconds (checked at each write): a ``kill -9`` at any moment loses at most the samples not yet
flushed — about half a second of them with :func:`chunk_for` — and leaves a file that
:func:`magcilia.io.read_samples` and ``magcilia calibrate`` open (``tests/acquire`` kills
recorders to prove it; npTDMS reads a file cut inside its last segment).

The first segment, written when the file opens, holds the file's properties: the metadata
(source, rate, channels and their units, sensor, setup, planned angles of a sweep, start time,
software version, ``chunk_samples`` and ``flush_interval_s``) and ``complete = False``. So a file
killed before its first chunk of samples still opens and says what it was meant to hold; it has
no ``recording`` channels yet. Closing appends ``complete`` (True, or False with ``stopped``: why
and where it ended early) and ``samples``.

An existing file is never destroyed before the new recording holds something: with
``overwrite=True`` the new file is written beside it under a hidden temporary name
(``.NAME.magcilia-partial-PID-HEX.tdms``, a :class:`magcilia._atomic.PartialFile`, locked while
written) and renamed over it when its first chunk of samples is flushed; a recording that fails
before that removes its temporary file and leaves the old one as it was, and one that is killed
before that leaves it to the next run that writes in the folder, which removes it
(:func:`magcilia._atomic.remove_leftovers`). ``overwrite=False`` refuses an existing file.

Layout: group ``recording`` with channels ``time_s`` (s), ``voltage_V`` (V; none for a source of
field channels only, e.g. a live 3-axis sensor's ``NAME.x``, ``.y``, ``.z``), and where given
``angle_deg`` (the tilt of each sample, deg), ``setreset`` (+1 set, −1 reset) and any extra
channels of the source. Further groups (:meth:`RecordingWriter.write_group`: a live read-out's
values, its events) go into the same flushed segments; their channel names differ from the
``recording`` group's, so readers that look a channel up by name find the raw samples.

Checksums: each segment that writes the ``recording`` channels ends with a row of group
``checksums``, channel ``chunks`` (uint64): the chunk's first sample, its number of samples and
the CRC-32 (``zlib.crc32``, the serial protocol's) of each ``recording`` channel's raw bytes in
that segment, in the order of the channel's ``layout`` property; the root property
``checksums = "crc32"`` says the file has them (:mod:`magcilia.io.chunk_checksums`). Readers
that do not know them see one more channel in one more group. The row is computed from the
arrays as they are written (about 6 GB/s: no cost to the writer's speed) and is the segment's last
raw data, so a segment cut by a kill has no row and every whole segment's chunk verifies.
"""

from __future__ import annotations

import contextlib
import datetime as dt
import errno
import io
import json
import math
import os
from collections.abc import Callable, Iterator, Mapping
from pathlib import Path
from time import monotonic
from types import TracebackType
from typing import IO, Any, Self

import numpy as np
from numpy.typing import ArrayLike, NDArray

from magcilia import _validate as v
from magcilia._atomic import PartialFile, exists_message, jsonable, remove_leftovers
from magcilia._errors import AcquisitionError, MagciliaError
from magcilia._validate import printable
from magcilia.io import chunk_checksums
from magcilia.io.tdmsfile import GROUP, nptdms_module, quiet_nptdms

F64 = NDArray[np.float64]
#: seconds of samples per flushed chunk (:func:`chunk_for`), and the longest a sample waits
#: unflushed (``flush_interval``), s: together they bound what a crash loses
FLUSH_SECONDS = 0.5


def chunk_for(rate: float) -> int:
    """Samples per flushed chunk at ``rate`` (Hz): :data:`FLUSH_SECONDS` of them, at least 1."""
    return max(1, round(FLUSH_SECONDS * rate)) if math.isfinite(rate) and rate > 0.0 else 1


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
        The file to write (``.tdms``).
    metadata : mapping
        What the recording should remember (source, rate, sensor, setup, …); JSON-ready values.
    chunk : int
        Most samples per flushed segment.
    flush_interval : float or None
        Longest time a written sample waits before it is flushed, s (checked at each write; a
        crash loses at most the samples of ``chunk`` and of this interval); None: flush by
        ``chunk`` only.
    fsync : bool
        Also ask the disk to store each chunk (survives a power cut, not only a killed process;
        slower).
    overwrite : bool
        Replace an existing ``path`` (only once the new recording holds its first flushed chunk,
        see the module notes); False refuses it with a one-line error when the file opens.
    reserved : bool
        ``path`` is an empty file the caller created (exclusively) to hold the name: it is
        written in place, not through a temporary file (a live view's default file names).

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
                 chunk: int = 4096, flush_interval: float | None = FLUSH_SECONDS,
                 fsync: bool = False,
                 overwrite: bool = True, reserved: bool = False) -> None:
        self.path = Path(path)
        self.metadata = dict(metadata or {})
        self.chunk = v.integer("chunk", chunk, 1)
        self.flush_interval = None if flush_interval is None else v.non_negative(
            "flush_interval", flush_interval, "s", "time")
        self.fsync = bool(fsync)
        self.overwrite = bool(overwrite)
        self.reserved = bool(reserved)
        self.samples = 0
        self.written = 0  # samples handed to write(), flushed or not
        self.chunks = 0
        self._oldest: float | None = None  # monotonic time the oldest pending sample came
        self._part: PartialFile | None = None  # the hidden file written until it replaces ``path``
        self._owns_path = False  # whether ``path`` is this writer's file (created or replaced)
        self._pending: dict[str, list[F64]] = {}
        self._names: tuple[str, ...] | None = None
        self._groups: dict[str, dict[str, list[F64]]] = {}  # further groups' pending columns
        self._units: dict[tuple[str, str], str] = {}
        self._file: IO[bytes] | None = None  # unbuffered: each segment goes out in one piece
        self._size = 0  # bytes of whole segments in the file
        self._staging = io.BytesIO()  # a segment is built here, then written out
        self._writer: Any = None

    # -- life cycle -------------------------------------------------------------------------------
    def open(self) -> Self:
        """Create the file and write its first segment: the properties (idempotent).

        Raises
        ------
        MagciliaError
            If ``path`` does not end in ``.tdms``, is a folder, exists while ``overwrite`` is
            False, or cannot be created (one line).
        """
        if self._writer is not None:
            return self
        nptdms = nptdms_module("Recording to TDMS files")
        if self.path.suffix.lower() != ".tdms":
            raise v.fail("recording file", str(self.path), "a path ending in .tdms")
        from magcilia._version import __version__

        props = {key: _property(val) for key, val in self.metadata.items() if val is not None}
        props.update(magcilia_version=__version__, complete=False,
                     start_time=dt.datetime.now(dt.UTC).isoformat(timespec="seconds"),
                     chunk_samples=self.chunk,
                     **{chunk_checksums.PROPERTY: chunk_checksums.KIND})
        if self.flush_interval is not None:
            props["flush_interval_s"] = self.flush_interval
        self._file = self._create()
        self._size = 0
        self._writer = nptdms.TdmsWriter(self._staging)
        try:
            self._segment([nptdms.RootObject(props), nptdms.GroupObject(GROUP)])
        except MagciliaError:
            self._discard()
            raise
        return self

    def _create(self) -> IO[bytes]:
        """Open the file to write: ``path`` itself when it does not exist (created exclusively),
        else a locked temporary file beside it that replaces it at the first flushed chunk."""
        path = self.path
        try:
            path.parent.mkdir(parents=True, exist_ok=True)
            remove_leftovers(path.parent)  # what killed runs left there (their locks are free)
            if path.is_dir():
                raise MagciliaError(f"{path} is a folder, not a recording file; choose another "
                                    "--out")
            try:
                file = path.open("xb", buffering=0)
            except FileExistsError:
                if self.reserved and path.is_file() and path.stat().st_size == 0:
                    self._owns_path = True
                    return path.open("r+b", buffering=0)
                if not self.overwrite:
                    raise MagciliaError(exists_message(path)) from None
            else:
                self._owns_path = True
                return file
            self._part = PartialFile(path)  # locked while this process lives
            return self._part.path.open("r+b", buffering=0)
        except OSError as exc:
            raise MagciliaError(f"cannot write the recording {path}: "
                                f"{exc.strerror or exc}") from None

    def _publish(self, *, final: bool = False) -> None:
        """Rename the temporary file over ``path`` (on POSIX the open file goes on under its new
        name). Where an open file cannot be renamed (Windows) it is renamed when it closes
        (``final``); a final rename that fails keeps the recording under its temporary name and
        says so."""
        part = self._part
        if part is None:
            return
        try:
            part.publish()
        except OSError as exc:
            if not final:
                return
            part.close()
            self._part = None
            raise MagciliaError(f"{self.path}: cannot replace it with the new recording "
                                f"({exc.strerror or exc}); the recording is kept in "
                                f"{part.path}") from None
        part.close()
        self._part = None
        self._owns_path = True

    def _discard(self) -> None:
        """Close and remove the file this writer made (the old ``path`` stays as it was)."""
        file, self._file, self._writer = self._file, None, None
        if file is not None:
            with contextlib.suppress(OSError):
                file.close()
        if self._part is not None:
            self._part.discard()
            self._part.close()
            self._part = None
        elif self._owns_path:
            self.path.unlink(missing_ok=True)
            self._owns_path = False

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
            if self._part is not None and not (complete or self.samples):
                self._part.discard()  # nothing recorded: the old file stays
                self._part.close()
                self._part = None
            self._publish(final=True)  # a complete recording without samples replaces it too

    def abort(self, stopped: str) -> bool:
        """Close after a failure, saying why and where (``stopped``); returns whether a recording
        is kept. A file this writer made that holds no samples is removed (an existing file it was
        to replace stays as it was); a failure to write the last note (the disk is what failed) is
        ignored: the chunks written so far stay readable."""
        if self.samples == 0 and not self._pending_size():
            self._discard()
            return False
        with contextlib.suppress(MagciliaError):
            self.close(complete=False, stopped=stopped)
        if self.samples == 0:
            self._discard()
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
    def write(self, time: ArrayLike, volts: ArrayLike | None, *,
              angle_deg: ArrayLike | None = None,
              setreset: ArrayLike | None = None,
              extra: Mapping[str, ArrayLike] | None = None) -> None:
        """Append samples; every ``chunk`` samples go to disk as one flushed segment.

        Parameters
        ----------
        time : array-like, shape (n,)
            Sample times, s.
        volts : array-like, shape (n,), or None
            Sensor output, V (None: a source without one, e.g. field channels in ``extra``).
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
        columns: dict[str, ArrayLike] = {"time_s": time}
        if volts is not None:
            columns["voltage_V"] = volts
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
        now = monotonic()
        if self._oldest is None and n:
            self._oldest = now
        for k, a in arrays.items():
            self._pending[k].append(a)
        self.written += n
        while self._pending_size() >= self.chunk:
            self._flush_pending(self.chunk)
            self._oldest = now if self._pending_size() else None
        if (self._oldest is not None and self.flush_interval is not None
                and now - self._oldest >= self.flush_interval):
            self._flush_pending()

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
        objects, arrays = [], []
        for name in self._names:
            joined = np.concatenate(self._pending[name])
            self._pending[name] = [joined[n:]] if joined.size > n else []
            data = joined[:n].astype(np.int8) if name == "setreset" else joined[:n]
            objects.append(nptdms.ChannelObject(GROUP, name, data))
            arrays.append(data)
        row = chunk_checksums.chunk_row(self.samples, arrays)
        checksums = nptdms.ChannelObject(  # the segment's last raw data (see chunk_checksums)
            chunk_checksums.GROUP, chunk_checksums.CHANNEL, row,
            properties=None if self.chunks or n else {
                "layout": chunk_checksums.layout(self._names)})
        self._segment([*objects, *self._group_objects(), checksums])
        self.samples += n
        self.chunks += n > 0
        if limit is None:
            self._oldest = None
        if n:
            self._publish()  # the new recording holds a chunk: it may replace the old file now

    def _segment(self, objects: list[Any]) -> None:
        """Write one TDMS segment to the operating system (and the disk, with ``fsync``); a
        segment that fails half-way (a full disk) is cut off again, so the file holds whole
        segments only."""
        assert self._file is not None
        staging = self._staging
        staging.seek(0)
        staging.truncate()
        self._writer.write_segment(objects)
        data = memoryview(staging.getvalue())
        try:
            while data:
                written = self._file.write(data)
                if not written:
                    raise OSError(errno.EIO, "the file took no bytes")
                data = data[written:]
            if self.fsync:
                os.fsync(self._file.fileno())
            self._size = self._file.tell()
        except OSError as exc:
            with contextlib.suppress(OSError):
                os.ftruncate(self._file.fileno(), self._size)
                self._file.seek(self._size)
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
