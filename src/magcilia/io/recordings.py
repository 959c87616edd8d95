"""Measured field-vs-tilt recordings: reading files and reducing raw samples to per-condition
means (the reduction itself, :func:`measurement_from_samples`, :func:`reading` and
:func:`beyond_range`, lives in :mod:`magcilia.io.reduction`; its names are importable from here
too).

Formats (chosen by the file suffix):

- **CSV** (``.csv``, ``.txt``): a header row with ``angle_deg`` and ``voltage_V``; one row per raw
  sample, repeated angles are samples of the same angle. Optional ``time_s`` and ``setreset``
  (``set``/``reset`` or ``+1``/``-1``: samples taken after a set or a reset pulse of the AMR
  strap), ``azimuth_deg`` and, in place of ``voltage_V``, ``field_x_T``, ``field_y_T``,
  ``field_z_T`` (below). Lines starting with ``#`` are comments. Other columns are ignored; a
  column we read that appears twice in the header is an error (which one is meant is ambiguous).
- **MATLAB** (``.mat``): variables ``angle_deg`` and ``voltage_V`` (real numeric vectors of equal
  length), optionally ``time_s`` and ``setreset``. Versions 4 and 5/7 (SciPy) and 7.3 (MATLAB's
  default for large data: HDF5, read with the optional ``h5py``: ``pip install
  'magcilia[hdf5]'``). Complex, text, cell, struct, sparse or matrix-shaped variables and a
  variable saved twice are errors.
- **TDMS** (``.tdms``, NI LabVIEW, needs the optional ``npTDMS``: ``pip install
  'magcilia[tdms]'``): channels named ``angle_deg`` and ``voltage_V`` in any group (or in the
  group named by ``group``). A channel we read must appear in one group only (a name in two
  groups is ambiguous and an error); magcilia's own recordings keep the samples in group
  ``recording`` and give the further groups (``readout``, ``events``) other channel names
  (:mod:`magcilia.io.recording_file`).
- **HDF5** (``.h5``, ``.hdf5``, needs the optional ``h5py``: ``pip install 'magcilia[hdf5]'``):
  1-D datasets named as the columns, at the root or in the group named by ``group``
  (:mod:`magcilia.io.hdf5file`).

Tilt azimuths and 3-axis field data
-----------------------------------
Every format takes the same optional columns (variables, channels, datasets):

- ``azimuth_deg``: the tilt direction φ of each sample, degrees (0, the default: tilt toward +x,
  the paper's path; 90: toward +y), finite and within ±:data:`MAX_AZIMUTH_DEG`. Samples are
  grouped per condition (azimuth, angle), and the conditions come ordered by azimuth, then angle
  (azimuths are kept as given: −90 and 270 deg are two conditions);
- ``field_x_T``, ``field_y_T``, ``field_z_T``: a 3-axis magnetometer at the sensing point, T (axes
  as in the README's frame figure), all three or none, *instead of* ``voltage_V``: a recording
  holds one observable (a file with both is an error: split it), and set/reset marks go with the
  single-axis output only. The :class:`Measurement` then has ``fields`` and ``field_sem`` (shape
  (a, 3)) and NaN ``volts``. The NaN/inf policy applies to every column read; the range check
  (``saturation``) applies to voltages only: 3-axis data are not range-checked here.

Load recordings
---------------
A ``force_N`` (known tip force) or ``flow_m_per_s`` (known uniform flow speed) column *in place
of* ``angle_deg`` makes a load recording: the cilium stands upright and bends toward the
azimuth; samples are grouped per (azimuth, load), and the :class:`Measurement` has ``forces``
or ``speeds`` (angles 0). One kind of load per file (both columns, or an angle column beside a
load, are errors); a flow recording's fluid is the reader's ``fluid`` argument (water by
default), kept as ``metadata["fluid"]``. Units by mapping or name: ``F [mN]``, ``flow_mm_per_s``.

A raw-sample CSV with both (``magcilia.acquire.synthetic.write_field_recording`` makes one)::

    angle_deg,azimuth_deg,field_x_T,field_y_T,field_z_T
    0,90,3.9275e-05,5.3047e-05,7.6123e-06
    40,90,3.9834e-05,4.6220e-05,2.0459e-05

Other names and units
---------------------
``columns`` maps the roles (angle, voltage, time, setreset, azimuth, field_x, field_y, field_z,
force, flow) to the file's own names with units (field: T, mT, uT, nT, gauss, G, mG; force: N,
mN, uN, nN; flow: m/s, mm/s, cm/s):
``columns={"angle": "Tilt[deg]", "voltage": "Vout[mV]"}`` or the CLI's
``--columns angle=Tilt[deg],voltage=Vout[mV]``; a header ``Vout [mV]`` names its unit itself
(:mod:`magcilia.io.columns`). Whatever the file's units, the columns read are in deg, V, s
and T.
CSV files take a ``delimiter`` (sniffed from the header by default: tab, ``;``, ``,`` or white
space) and a ``decimal`` mark (``","`` for European exports such as ``1,25;0,031``); see
:mod:`magcilia.io.csvfile`.

With set/reset samples the offset-free reading of an angle is ``(mean(V_set) − mean(V_reset))/2``
(the bridge flips polarity, the offset does not; HMC1021 datasheet).

Hostile files
-------------
Every failure of a reader becomes one :class:`~magcilia.MagciliaError` line naming the file and
what is wrong; an unexpected exception of a third-party parser is caught at the reader boundary
(:func:`read_samples`) and kept as the error's ``__cause__``. Sizes taken from a file are bounded
by the module constants below (each error names the constant to raise where a genuine file can
exceed it): :data:`MAX_SAMPLES` samples per column, :data:`MAX_LINE_CHARS` characters per CSV
line, and for MATLAB files those of :mod:`magcilia.io.matfile`.

MATLAB and HDF5 files are parsed in a child process after a check of their structure
(:mod:`magcilia.io.matfile`, which says why and what it costs). A file reaches nothing outside
itself: HDF5 external links, external storage, virtual datasets and plugin filters are refused
(:mod:`magcilia.io.hdf5file`), TDMS index files beside a recording are never read
(:mod:`magcilia.io.tdmsfile`); CSV and MATLAB v4/v5 files have no way to name another file.

Damage and quality
------------------
A reader returns its notes with the columns (:func:`read_recording`,
:class:`~magcilia.io.recording_state.RawRecording`): damage it could read past (TDMS: see
:mod:`magcilia.io.tdmsfile`; a file that says it is complete is refused instead), and what the
file says of itself (a recording cut short, the planned angles it lacks:
:mod:`magcilia.io.recording_state`). :func:`read_measurements` then checks the samples
(:func:`check_quality`, :mod:`magcilia.io.quality`: sparse conditions, outliers, duplicated
blocks, garbled values) and keeps, omits or refuses what is flagged (``suspect``); everything is
in the measurement's ``metadata`` and said by :meth:`Measurement.notes`.

Speed and memory
----------------
A plain CSV file (numbers only after the header) is parsed by pandas' C reader in blocks of a
million rows (:mod:`magcilia.io.csvfile`), copied into columns sized from the first block's
share of the file and, in :func:`read_measurements`, reduced block by block as they come;
anything else goes to the careful line-by-line reader, which gives the same columns and the
errors that name a line. The quality checks need every sample at once, so the columns are held
whole (three columns of 1e7 samples: 240 MB); they cost a few vectorised passes
(:mod:`magcilia.io.sample_checks`). The reduction (:func:`measurement_from_samples`, and every
reader through it) is one pass over pieces of :data:`REDUCE_SAMPLES` samples: the runs of equal
conditions (the angle; with an azimuth column, the pair as one complex key) are grouped, their
sums gathered per condition with ``np.bincount``, in a two-pass form accurate on a large offset,
and the pieces merged with Chan's formulas. A 1e7-row CSV recording (300 MB) is read, checked and
reduced in 0.68 s with a peak of 0.47 GB on a 2-core VM (the read without the checks: 0.68 s,
0.25 GB), where pandas' reader alone takes 0.6–1.3 s (``benchmarks/bench_recordings.py``).

Angles are tilt angles in degrees: a finite ``|angle_deg|`` above :data:`MAX_ANGLE_DEG` (a
column in the wrong unit, or garbage) is an error rather than grouped, so the grouping by
rounding to :data:`ANGLE_DECIMALS` decimals never overflows; azimuths likewise.
"""

from __future__ import annotations

import contextlib
import dataclasses
import logging
import time
from collections.abc import Callable, Iterator, Mapping
from dataclasses import dataclass, field
from importlib import resources
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from magcilia import _validate as v
from magcilia._errors import MagciliaError, MissingDependencyError
from magcilia._validate import printable
from magcilia.device.sensor import Sensor
from magcilia.io.columns import (
    ACTUATION_KEYS,
    FIELD_KEYS,
    LOAD_KEYS,
    OBSERVABLE,
    Columns,
    scaled,
    to_kelvin,
)
from magcilia.io.csvfile import (
    NotPlainCSV,
    decimal_of,
    delimiter_of,
    plain_csv_columns,
    read_csv_carefully,
    too_many_samples,
)
from magcilia.io.hdf5file import read_hdf5
from magcilia.io.matfile import read_mat
from magcilia.io.measurement import Measurement
from magcilia.io.quality import (  # noqa: F401 (check_quality: kept here, io exports it)
    SUSPECT_POLICIES,
    check_quality,
)
from magcilia.io.readings import beyond_range, reading  # noqa: F401 (public here too)
from magcilia.io.recording_state import RawRecording
from magcilia.io.reduction import (  # noqa: F401 (the reduction's public names: kept here)
    MAX_ANGLE_DEG,
    MAX_AZIMUTH_DEG,
    MAX_FIELD_T,
    MAX_LOAD,
    NAN_POLICIES,
    REDUCE_SAMPLES,
    SATURATION_POLICIES,
    _Following,
    _measure,
    _Reduction,
    measurement_from_samples,
)
from magcilia.io.sniff import looks_like_setup, swapped_setup
from magcilia.io.tdmsfile import (  # noqa: F401 (nptdms_module, quiet_nptdms: kept here)
    nptdms_module,
    quiet_nptdms,
    read_tdms,
)

F64 = NDArray[np.float64]
logger = logging.getLogger(__name__)
#: The columns a recording may hold (other columns, variables or channels are ignored), by
#: their default names (:class:`~magcilia.io.columns.Columns` maps others onto them).
COLUMNS = ("angle_deg", "voltage_V", "time_s", "setreset", "azimuth_deg", *FIELD_KEYS,
           *LOAD_KEYS, *ACTUATION_KEYS)
#: fluids a flow recording may name (:data:`magcilia.mechanics.drag.FLUIDS`)
FLUID_NAMES = ("air", "water", "glycerol")
#: A reader's progress: ``progress(bytes_read, file_size)``.
Progress = Callable[[int, int], None]
#: Most samples per column in any format (4 columns × 8 bytes × 50 million = 1.6 GB of arrays).
MAX_SAMPLES = 50_000_000
#: Longest CSV line, characters (a recording's line is tens of characters).
MAX_LINE_CHARS = 1 << 20


def _csv_limits() -> dict[str, int]:
    """The limits of the CSV readers (read at each call, so that they can be raised)."""
    return {"max_samples": MAX_SAMPLES, "max_line_chars": MAX_LINE_CHARS}


@dataclass(frozen=True)
class _How:
    """How to read a recording: the column and unit mapping, the CSV delimiter (None: sniffed)
    and decimal mark, the group (HDF5, TDMS; "" for any or the root), a progress callback."""

    columns: Columns = field(default_factory=Columns)
    delimiter: str | None = None
    decimal: str = "."
    group: str = ""
    progress: Progress | None = None
    #: called with each block of columns (deg, V, s) as the fast CSV reader reads it, and with
    #: None where that reader gives up (the careful one starts again)
    blocks: Callable[[dict[str, F64] | None], None] | None = None


def _how(path: Path, columns: Columns | Mapping[str, str] | str | None, delimiter: str | None,
         decimal: str, group: str | None, progress: Progress | None) -> _How:
    """The reading options checked (the CSV ones on a CSV file, ``group`` on HDF5 and TDMS)."""
    how = _How(Columns.coerce(columns), delimiter_of(delimiter), decimal_of(decimal),
               "" if group is None else str(group), progress)
    suffix = path.suffix.lower()
    if READERS[suffix] is not _read_csv and (how.delimiter is not None or how.decimal != "."):
        raise v.fail("delimiter" if how.delimiter is not None else "decimal",
                     delimiter if how.delimiter is not None else decimal,
                     f"left out for a {FORMATS[suffix]} file (delimiter and decimal mark are "
                     "CSV options)")
    if how.group.strip("/") and READERS[suffix] not in (_read_hdf5, _read_tdms):
        raise v.fail("group", group, f"left out for a {FORMATS[suffix]} file (groups are in "
                                     "HDF5 and TDMS files)")
    if progress is not None and not callable(progress):
        raise v.fail("progress", type(progress).__name__, "a callable progress(done, total)")
    return how


class _CSVLocator:
    """The column mapping for the CSV readers: the header's names -> key -> index, the unit
    factors kept."""

    def __init__(self, path: Path, how: _How, required: tuple[str, ...]):
        self.path, self.how, self.required = path, how, required
        self.factors: dict[str, float] = {}

    def __call__(self, header: list[str]) -> dict[str, int]:
        found = self.how.columns.locate(header, where=str(self.path), required=self.required)
        self.factors = {k: f for k, (_, f) in found.items() if f != 1.0}
        return {k: i for k, (i, _) in found.items()}

    def scaled(self, block: dict[str, F64]) -> dict[str, F64]:
        """A block's columns in deg, V and s."""
        for key, factor in self.factors.items():
            block[key] = scaled(block[key], factor)
        return block

    def header_names(self) -> tuple[str, ...]:
        """The required keys as the CSV readers name them in messages (the observable as
        ``voltage_V``)."""
        return tuple("voltage_V" if k == OBSERVABLE else k for k in self.required)

    def options(self) -> dict[str, Any]:
        """The readers' keyword arguments."""
        return {"delimiter": self.how.delimiter, "decimal": self.how.decimal, "locate": self,
                **_csv_limits()}


def _read_csv(path: Path, required: tuple[str, ...], how: _How) -> RawRecording:
    """A CSV recording's columns: the fast reader's, or the careful reader's."""
    locate = _CSVLocator(path, how, required)
    follow = how.blocks
    try:
        cols = plain_csv_columns(
            path, COLUMNS, locate.header_names(), progress=how.progress, **locate.options(),
            on_block=None if follow is None else lambda block: follow(locate.scaled(block)))
    except NotPlainCSV:
        if follow is not None:
            follow(None)
        cols = read_csv_carefully(path, COLUMNS, locate.header_names(), progress=how.progress,
                                  **locate.options())
    return RawRecording(locate.scaled(cols))


def _read_tdms(path: Path, required: tuple[str, ...], how: _How) -> RawRecording:
    return read_tdms(path, how.columns, required, group=how.group, max_samples=MAX_SAMPLES)


def _read_mat(path: Path, required: tuple[str, ...], how: _How) -> RawRecording:
    names = how.columns.names()  # key -> variable name (MATLAB names carry no unit)
    need = tuple(names["voltage_V" if k == OBSERVABLE else k] for k in required)
    if OBSERVABLE in required:  # the voltage (last), or the field components in its place
        need = (*(n for n in need if n != names["voltage_V"]), names["voltage_V"])
    variables = read_mat(path, tuple(dict.fromkeys(names.values())), need,
                         tuple(names[k] for k in FIELD_KEYS) if OBSERVABLE in required else (),
                         tuple(names[k] for k in (*LOAD_KEYS, *ACTUATION_KEYS))
                         if required and required[0] == "angle_deg" else ())
    found = list(variables)
    located = how.columns.locate(found, where=str(path), required=required, kind="variable")
    return RawRecording({key: scaled(variables[found[i]], factor)
                         for key, (i, factor) in located.items()})


def _read_hdf5(path: Path, required: tuple[str, ...], how: _How) -> RawRecording:
    return RawRecording(read_hdf5(path, how.columns, required, group=how.group or "/",
                                  max_samples=MAX_SAMPLES))


READERS = {".csv": _read_csv, ".txt": _read_csv, ".mat": _read_mat, ".tdms": _read_tdms,
           ".h5": _read_hdf5, ".hdf5": _read_hdf5}
FORMATS = {".csv": "CSV", ".txt": "CSV", ".mat": "MATLAB .mat", ".tdms": "TDMS", ".h5": "HDF5",
           ".hdf5": "HDF5"}


def _describe(exc: BaseException) -> str:
    """An exception as a short, harmless line: ``TypeName: message``."""
    text = printable(str(exc))
    return type(exc).__name__ + (f": {text[:160]}" + ("…" if len(text) > 160 else "")
                                 if text else "")


def _is_preset(name: str) -> bool:
    from magcilia.io.presets import NAMES

    return name in NAMES


def _recording_path(path: str | Path) -> Path:
    """``path`` as a Path, checked to be an existing file of a format we read."""
    p = Path(path)
    if looks_like_setup(p) or (not p.exists() and _is_preset(str(path))):
        raise MagciliaError(swapped_setup(printable(str(p))))
    if p.suffix.lower() not in READERS:
        raise v.fail(f"{p}: file type", p.suffix or "(none)", "one of " + ", ".join(READERS))
    if not p.is_file():
        raise MagciliaError(f"{p}: no such file")
    return p


@contextlib.contextmanager
def _reader_boundary(p: Path) -> Iterator[None]:
    """Any failure of a reader of ``p`` as one :class:`MagciliaError` line (the parser's own
    exception kept as its ``__cause__``)."""
    t0 = time.perf_counter()
    try:
        yield
        logger.info("read %s in %.3g s", p, time.perf_counter() - t0)
    except (MagciliaError, MissingDependencyError):
        raise
    except (PermissionError, IsADirectoryError, FileNotFoundError) as exc:
        raise MagciliaError(f"{p}: cannot read the file ({printable(exc.strerror or str(exc))})"
                            ) from exc
    except Exception as exc:  # the reader boundary: any parser failure is one line
        raise MagciliaError(f"{p}: cannot read as a {FORMATS[p.suffix.lower()]} file "
                            f"({_describe(exc)}); the file is damaged or not a recording"
                            ) from exc


def read_recording(
    path: str | Path, required: tuple[str, ...] = ("angle_deg", OBSERVABLE), *,
    columns: Columns | Mapping[str, str] | str | None = None, delimiter: str | None = None,
    decimal: str = ".", group: str | None = None, progress: Progress | None = None,
    temperature: bool = False,
) -> RawRecording:
    """A recording's raw sample columns (as :func:`read_samples`), with the reader's notes on the
    file (damage it read past, a recording cut short: one line each, see
    :mod:`magcilia.io.tdmsfile`) and what the file says about itself (complete, planned angles:
    :class:`~magcilia.io.recording_state.RecordingState`).

    The parameters and errors are :func:`read_samples`'; a recording cut before its first chunk
    is the error ``the recording was cut before its first chunk``.
    """
    p = _recording_path(path)
    how = _how(p, columns, delimiter, decimal, group, progress)
    if temperature:
        how = dataclasses.replace(how, columns=how.columns.with_temperature())
    return _read_recording(p, required, how)


def _read_recording(p: Path, required: tuple[str, ...], how: _How) -> RawRecording:
    """:func:`read_recording` of a checked path with checked options."""
    unknown = [k for k in required if k not in (*COLUMNS, OBSERVABLE)]
    if unknown:
        raise v.fail("required", unknown[0], "keys among " + ", ".join((*COLUMNS, OBSERVABLE)))
    with _reader_boundary(p):
        raw = _read(p, required, how)
    cols = to_kelvin(raw.columns)
    lengths = {k: a.size for k, a in cols.items()}
    if len(set(lengths.values())) > 1:
        raise MagciliaError(
            f"{p}: the columns have different lengths "
            f"({', '.join(f'{k} {n}' for k, n in lengths.items())}); every column needs one "
            "value per sample"
        )
    if any(n > MAX_SAMPLES for n in lengths.values()):
        raise too_many_samples(p, "the recording", MAX_SAMPLES)
    logger.debug("%s: %d rows of %s", p, max(lengths.values(), default=0), ", ".join(cols))
    return raw


def read_samples(
    path: str | Path, required: tuple[str, ...] = ("angle_deg", OBSERVABLE), *,
    columns: Columns | Mapping[str, str] | str | None = None, delimiter: str | None = None,
    decimal: str = ".", group: str | None = None, progress: Progress | None = None,
    temperature: bool = False,
) -> dict[str, F64]:
    """Raw sample columns of a recording (CSV, MATLAB .mat, TDMS or HDF5), without any reduction.

    Parameters
    ----------
    path : str or Path
        The file; its suffix selects the reader (see the module docstring for the formats).
    required : tuple of str
        Columns that must be present, by their keys ``angle_deg``, ``voltage_V``, ``time_s``,
        ``setreset``, ``azimuth_deg``, ``field_x_T``, ``field_y_T``, ``field_z_T``, or
        ``"observable"``: ``voltage_V`` or the three field columns (a one-line error names the
        file, the missing column and those it has). Default: the angle and the observable.
    columns : Columns, mapping or str, optional
        Which of the file's columns holds the angle, voltage, time, setreset, azimuth and field
        components, with units: ``{"angle": "Tilt[deg]", "voltage": "Vout[mV]"}``, a
        :class:`~magcilia.io.columns.Columns` or the CLI's ``"angle=Tilt[deg],voltage=Vout[mV]"``
        (default: the names ``angle_deg``, ``voltage_V``, ``time_s``, ``setreset``,
        ``azimuth_deg``, ``field_x_T``, ``field_y_T``, ``field_z_T``).
    delimiter : {None, ",", ";", "\\t", "tab", " ", "whitespace", "auto"}
        CSV only: between fields; None or "auto" sniffs it from the header line.
    decimal : {".", ","}
        CSV only: the decimal mark (``","`` for ``1,25``; fields are then ``;``-separated, or
        quoted).
    group : str, optional
        HDF5 and TDMS only: the group that holds the columns (HDF5 default: the root; TDMS
        default: any group).
    progress : callable, optional
        Called as ``progress(bytes_read, file_size)`` while the file is read (CSV: after each
        block; other formats: at the start and the end).
    temperature : bool
        Also read the temperature, ``temperature_K`` (K) from a ``temperature_K`` or
        ``temperature_degC`` column (:mod:`magcilia.io.columns`); another column named like a
        temperature is then an error. False (default): temperature columns are left unread.

    Returns
    -------
    dict of str to ndarray, shape (samples,)
        The columns found among ``angle_deg`` (deg), ``voltage_V`` (V), ``time_s`` (s),
        ``setreset`` (+1 set, −1 reset), ``azimuth_deg`` (deg) and ``field_x_T``,
        ``field_y_T``, ``field_z_T`` (T), whatever the file's names and units, all of the same
        length (possibly 0: a file without samples; :func:`read_measurements` rejects it).
        Never both ``voltage_V`` and the field columns, and the field columns all three or none
        (one-line errors). The reader's notes on the file (damage read past, a recording cut
        short) are logged as warnings of the ``magcilia`` logger; :func:`read_recording` returns
        them.

    Raises
    ------
    MagciliaError
        For any file that cannot be read as a recording (one line naming the file and what is
        wrong; an unexpected exception of a third-party parser is its ``__cause__``), and for a
        recording cut before its first chunk.
    MissingDependencyError
        For a TDMS, HDF5 or MATLAB v7.3 file without the optional package that reads it.
    """
    raw = read_recording(path, required, columns=columns, delimiter=delimiter, decimal=decimal,
                         group=group, progress=progress, temperature=temperature)
    for note in raw.notes:
        logger.warning("%s: %s", path, note)
    return raw.columns


def _read(p: Path, required: tuple[str, ...], how: _How) -> RawRecording:
    """A reader's columns, with the progress at the start and end of a format read at once."""
    reader = READERS[p.suffix.lower()]
    if how.progress is None:
        return reader(p, required, how)
    size = p.stat().st_size
    if reader is not _read_csv:
        how.progress(0, size)
    raw = reader(p, required, how)
    how.progress(size, size)
    return raw


def read_measurements(
    path: str | Path,
    *,
    sensor: Sensor | None = None,
    nan_policy: str = "raise",
    saturation: str = "raise",
    columns: Columns | Mapping[str, str] | str | None = None,
    delimiter: str | None = None,
    decimal: str = ".",
    group: str | None = None,
    progress: Progress | None = None,
    fluid: str = "water",
    suspect: str = "keep",
) -> Measurement:
    """Read a recording (CSV, MATLAB .mat, TDMS or HDF5) and reduce it to per-condition means.

    A condition is a tilt angle (``angle_deg``) at a tilt azimuth (``azimuth_deg``, default 0);
    the observable is the single-axis output (``voltage_V``) or the 3-axis field (``field_x_T``,
    ``field_y_T``, ``field_z_T``). See the module docstring for the formats and the rules.

    Parameters
    ----------
    path : str or Path
        The file; its suffix selects the reader (see the module docstring for the formats).
    sensor : Sensor, optional
        Sensor settings for the range check (default: HMC1021Z at the paper's settings).
    nan_policy : {"raise", "omit"}
        NaN/inf samples (in any column read): an error, or dropped and counted in
        ``Measurement.nonfinite``.
    saturation : {"raise", "omit", "keep"}
        Output samples beyond the sensor's linear range: an error, dropped, or kept; always
        counted (3-axis field data are not range-checked).
    columns : Columns, mapping or str, optional
        Which of the file's columns holds the angle, voltage, time, setreset, azimuth and field
        components, with units: ``{"angle": "Tilt[deg]", "voltage": "Vout[mV]"}``, a
        :class:`~magcilia.io.columns.Columns` or the CLI's ``"angle=Tilt[deg],voltage=Vout[mV]"``
        (default: the names ``angle_deg``, ``voltage_V``, ``time_s``, ``setreset``,
        ``azimuth_deg``, ``field_x_T``, ``field_y_T``, ``field_z_T``).
    delimiter : {None, ",", ";", "\\t", "tab", " ", "whitespace", "auto"}
        CSV only: between fields; None or "auto" sniffs it from the header line.
    decimal : {".", ","}
        CSV only: the decimal mark (``","`` for ``1,25``; fields are then ``;``-separated, or
        quoted).
    group : str, optional
        HDF5 and TDMS only: the group that holds the columns (HDF5 default: the root; TDMS
        default: any group).
    progress : callable, optional
        Called as ``progress(bytes_read, file_size)`` while the file is read (CSV: after each
        block; other formats: at the start and the end).
    fluid : {"water", "air"}
        A flow recording's fluid (kept as ``metadata["fluid"]``; ignored for other recordings).
    suspect : {"keep", "omit", "raise"}
        Samples that the quality checks flag (:mod:`magcilia.io.quality`: conditions with far
        fewer samples than the others, outliers within their condition, duplicated blocks of
        rows): kept in the reduction, left out of it, or an error; counted and named in
        ``metadata["quality"]`` either way (:meth:`Measurement.notes` says them).

    Returns
    -------
    Measurement
        For a load recording (a ``force_N`` or ``flow_m_per_s`` column in place of
        ``angle_deg``): ``forces`` or ``speeds`` per condition (azimuth, load), angles 0.
        ``metadata`` holds ``quality`` (the checks' findings), ``notes`` (the reader's notes on
        the file: damage read past, a recording cut short and the planned angles it lacks),
        for magcilia's own recordings ``recording`` (complete, planned and missing angles) and,
        for a recording with a temperature column (``temperature_K`` or ``temperature_degC``),
        ``temperature_K`` (lowest, highest and mean over the samples used:
        :attr:`Measurement.temperature_range`; another column named like a temperature, in
        units magcilia does not take, is left alone).

    Examples
    --------
    A European export (``Zeit;Winkel;Spannung`` with ``0,001;-40;12,5``, the voltage in mV)::

        read_measurements("run.csv", decimal=",", columns={
            "time": "Zeit[s]", "angle": "Winkel[deg]", "voltage": "Spannung[mV]"})

    A 3-axis magnetometer's export in µT with the azimuth in radians::

        read_measurements("run.csv", columns="angle=Tilt[deg],azimuth=Phi[rad],"
                          "field_x=Bx[uT],field_y=By[uT],field_z=Bz[uT]")
    """
    fluid_name = v.choice("fluid", fluid, FLUID_NAMES)
    policy = v.choice("suspect", suspect, SUSPECT_POLICIES)
    _Reduction(sensor, nan_policy, saturation, "")  # the policies checked before the file is read

    def start() -> _Reduction:
        reduction = _Reduction(sensor, nan_policy, saturation, str(Path(path)))
        reduction.fluid = fluid_name
        return reduction

    p = _recording_path(path)
    follow = _Following(start)  # a CSV file reduced as it is read (its blocks still in cache)
    how = _how(p, columns, delimiter, decimal, group, progress)
    how = dataclasses.replace(how, blocks=follow, columns=how.columns.with_temperature(False))
    raw = _read_recording(p, ("angle_deg", OBSERVABLE), how)
    return _measure(start, raw, policy, follow)


def example_path() -> Path:
    """Path of the bundled SYNTHETIC example recording (CSV; made by
    ``scripts/make_example_recording.py`` from the paper's Table I cilium as an exact body, truth,
    body and seed in the JSON beside it)."""
    return Path(str(resources.files("magcilia") / "data" / "example_recording.csv"))
