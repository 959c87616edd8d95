"""A seeded corpus of mutated recordings (CSV, MATLAB v4/v5/v7.3, TDMS, HDF5) for the fuzz tests.

Small valid recordings are made here (nothing binary is stored in the repository); case ``i`` of
seed ``s`` takes seed recording ``i mod n`` and applies one to four mutations drawn with
``numpy.random.default_rng([s, i])``: bit flips, interesting integers (0, -1, 2**31, ...) written
over length and type fields, truncation, insertion, deletion, duplication and swaps of chunks,
another recording's header spliced in, for compressed MATLAB variables mutations of the inflated
bytes (re-deflated so that they pass zlib and reach the parser), for TDMS mutations of the lead-ins
and data types, and for CSV numbers, names and lines mutated as text. The same seed, index and
library versions give the same bytes (the times written into headers are fixed).

Values: :func:`check_case` reads a case and compares what it reads with what its seed holds
(the unmutated seed read the same way): a case is ``refused`` (one error line), ``same`` (read,
and every condition, value and count as written), ``noted`` (read with other values, and the
measurement says something is off: a reader's note, a quality finding, dropped or saturated
samples) or ``silent`` (read with other values, and nothing said). :func:`touches_structure`
tells damage to a TDMS file's structure (lead-ins, metadata, lengths) from damage to its raw
data alone: TDMS has no checksums, so a value changed in place inside the raw data reads as a
value (the quality checks note the gross ones).

Used by ``tests/fuzz/test_fuzz_recordings.py`` and ``scripts/fuzz_recordings.py``.
"""

from __future__ import annotations

import functools
import io
import re
import struct
import tempfile
import zlib
from collections.abc import Callable, Iterator, Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from scipy.io import savemat

import magcilia as mc
from magcilia._errors import MissingDependencyError
from magcilia.io import RecordingWriter
from magcilia.io.recordings import nptdms_module

ANGLES = np.repeat([-20.0, 0.0, 10.0, 25.0], 4)
SETRESET = np.tile([1.0, -1.0], 8)
VOLTS = np.repeat([-2e-3, 0.0, 1e-3, 2.5e-3], 4) * SETRESET + 1e-4
TIME = np.arange(16) * 1e-3
#: 3-axis seeds: two samples of each angle at azimuth 0, two at 90 deg; field (16, 3) in T
AZIMUTHS = np.tile([0.0, 0.0, 90.0, 90.0], 4)
FIELDS = np.column_stack([4e-5 + 2e-7 * ANGLES, 5e-5 - 1e-7 * AZIMUTHS / 90 + 1e-8 * ANGLES,
                          8e-6 + 3e-7 * ANGLES]) + 1e-9 * np.tile([1.0, -1.0], 8)[:, None]
#: a sweep as magcilia records one: 6 planned angles × 40 samples, noise, 4 chunks
SWEEP_ANGLES = np.array([-20.0, -5.0, 0.0, 10.0, 25.0, 40.0])
SWEEP_PER = 40
#: a load recording from another program: 2 azimuths × 4 tip forces × 8 samples, 2 segments
LOAD_FORCES = np.array([0.0, 1e-5, 2e-5, 4e-5])
INTERESTING = (0, 1, 2, 7, 8, 0x7F, 0x80, 0xFF, 0x100, 0x7FFF, 0x8000, 0xFFFF, 0x10000,
               0x7FFFFFFF, 0x80000000, 0xFFFFFFFF)
TDMS_TYPES = (0, 1, 5, 8, 9, 0x19, 0x20, 0x21, 0x44, 0x08000C, 0x10000D, 0xFFFFFFFF)
TEXT_VALUES = ("nan", "inf", "-inf", "1e309", "-1.7e308", "1.8e300", "", "abc", "0x10", "1_0",
               " ", "\x00", "1e-400", "-0", "9" * 400, "set", "+1", "'", '"', "\x1b[2J", "1e5")
MAT_HEADER_5 = b"MATLAB 5.0 MAT-file Platform: posix, Created on: Thu Jan  1 00:00:00 2026"
MAT_HEADER_73 = (b"MATLAB 7.3 MAT-file, Platform: GLNXA64, Created on: Thu Jan  1 00:00:00 2026 "
                 b"HDF5 schema 1.00 .")


@dataclass(frozen=True)
class Case:
    """One mutated recording: its index, seed recording, suffix, bytes and mutations applied."""

    index: int
    seed_name: str
    suffix: str
    data: bytes
    mutations: tuple[str, ...]

    def write(self, directory: Path) -> Path:
        """Write the recording as ``case<index>-<seed>.<suffix>`` in ``directory``."""
        path = directory / f"case{self.index}-{self.seed_name}{self.suffix}"
        path.write_bytes(self.data)
        return path


def write_mat73(path: Path, variables: dict[str, np.ndarray]) -> None:
    """A MATLAB v7.3 file as MATLAB writes one: HDF5 with a 512-byte user block holding the
    MAT-file header, column vectors stored transposed (HDF5 shape (1, n)), ``MATLAB_class``."""
    import h5py

    with h5py.File(path, "w", userblock_size=512) as f:
        for name, value in variables.items():
            arr = np.asarray(value)
            data = arr.reshape(1, -1) if arr.ndim == 1 else arr.T
            ds = f.create_dataset(name, data=data)
            cls = "double" if arr.dtype == np.float64 else str(arr.dtype)
            ds.attrs["MATLAB_class"] = np.bytes_(cls)
    header = MAT_HEADER_73.ljust(116) + b"\x00" * 8 + b"\x00\x02IM"
    with path.open("r+b") as f:
        f.write(header.ljust(512, b"\x00"))


@functools.cache
def seeds() -> dict[str, tuple[str, bytes]]:
    """The valid recordings that the mutations start from: name -> (suffix, bytes)."""
    out: dict[str, tuple[str, bytes]] = {}
    rows = "\n".join(f"{a:g},{v:.6g},{t:g},{'set' if s > 0 else 'reset'}"
                     for a, v, t, s in zip(ANGLES, VOLTS, TIME, SETRESET, strict=True))
    out["csv"] = (".csv", f"# bench 3\nangle_deg,voltage_V,time_s,setreset\n{rows}\n".encode())
    rows = "\r\n".join(f'"{a:g}", {v:.6g},"x{i}",{s:+g}'
                       for i, (a, v, s) in enumerate(zip(ANGLES, VOLTS, SETRESET, strict=True)))
    out["csv_quoted"] = (".csv", ("\ufeffangle_deg, voltage_V,note,setreset\r\n" + rows
                                  ).encode())
    rows = "\n".join(f"{t:g};{a:g};{v * 1e3:.6g};{s:+g}".replace(".", ",")
                     for a, v, t, s in zip(ANGLES, VOLTS, TIME, SETRESET, strict=True))
    out["csv_eu"] = (".csv", f"Zeit [s];Winkel [deg];Spannung [mV];SR\n{rows}\n".encode())
    rows = "\n".join(f"{a:g},{z:g},{b[0]:.9g},{b[1]:.9g},{b[2]:.9g}"
                     for a, z, b in zip(ANGLES, AZIMUTHS, FIELDS, strict=True))
    out["csv_field"] = (".csv", ("angle_deg,azimuth_deg,field_x_T,field_y_T,field_z_T\n"
                                 f"{rows}\n").encode())
    rows = "\n".join(f"{np.radians(z):.12g}\t{a:g}\t{b[0] * 1e6:.9g}\t{b[1] / 1e-4:.9g}\t"
                     f"{b[2] * 1e3:.9g}\t# {i}"
                     for i, (a, z, b) in enumerate(zip(ANGLES, AZIMUTHS, FIELDS, strict=True)))
    out["csv_field_mapped"] = (".csv", ("Phi [rad]\tTilt\tBx [uT]\tBy\tBz [mT]\tnote\n"
                                        f"{rows}\n").encode())
    field_columns = {"angle_deg": ANGLES, "azimuth_deg": AZIMUTHS, "field_x_T": FIELDS[:, 0],
                     "field_y_T": FIELDS[:, 1], "field_z_T": FIELDS[:, 2]}
    buf = io.BytesIO()
    savemat(buf, field_columns, do_compression=True)
    data = bytearray(buf.getvalue())
    data[:116] = MAT_HEADER_5.ljust(116)
    out["mat_v5z_field"] = (".mat", bytes(data))
    columns = {"angle_deg": ANGLES, "voltage_V": VOLTS, "time_s": TIME, "setreset": SETRESET}
    for name, kwargs in (("mat_v5", {"do_compression": False}),
                         ("mat_v5z", {"do_compression": True}), ("mat_v4", {"format": "4"})):
        buf = io.BytesIO()
        extra = {} if name == "mat_v4" else {"note": "bench 3"}
        savemat(buf, {**columns, **extra}, **kwargs)
        data = bytearray(buf.getvalue())
        if name != "mat_v4":  # the header's text holds the time of writing
            data[:116] = MAT_HEADER_5.ljust(116)
        out[name] = (".mat", bytes(data))
    with tempfile.TemporaryDirectory() as tmp:
        try:  # without npTDMS (the extra "tdms") the TDMS seeds are left out
            nptdms = nptdms_module()
        except MissingDependencyError:
            pass
        else:
            buf = io.BytesIO()
            with nptdms.TdmsWriter(buf) as writer:
                writer.write_segment([nptdms.RootObject({"operator": "bench 3"})] + [
                    nptdms.ChannelObject("run", k, a) for k, a in columns.items()])
            out["tdms"] = (".tdms", buf.getvalue())
            buf = io.BytesIO()
            with nptdms.TdmsWriter(buf) as writer:
                writer.write_segment([nptdms.ChannelObject("run", k, a)
                                      for k, a in field_columns.items()])
            out["tdms_field"] = (".tdms", buf.getvalue())
            path = Path(tmp) / "rec.tdms"
            with RecordingWriter(path, metadata={"source": "fuzz"}, chunk=6) as rec:
                rec.write(TIME, VOLTS, angle_deg=ANGLES, setreset=SETRESET)
                rec.write_group("readout", {"readout_time_s": TIME[:3], "value": VOLTS[:3]})
            out["tdms_magcilia"] = (".tdms", re.sub(  # its start time, fixed
                rb"\d{4}-\d\d-\d\dT\d\d:\d\d:\d\d\+00:00", b"2026-01-01T00:00:00+00:00",
                path.read_bytes()))
            out["tdms_sweep"] = (".tdms", _sweep_tdms(Path(tmp) / "sweep.tdms"))
            out["tdms_load"] = (".tdms", _load_tdms(nptdms))
        try:  # without h5py (the extra "hdf5") the v7.3 and HDF5 seeds are left out
            write_mat73(Path(tmp) / "v73.mat", columns)
            write_hdf5(Path(tmp) / "rec.h5")
            write_hdf5_field(Path(tmp) / "field.h5", field_columns)
        except ImportError:
            pass
        else:
            out["mat_v73"] = (".mat", (Path(tmp) / "v73.mat").read_bytes())
            out["h5"] = (".h5", (Path(tmp) / "rec.h5").read_bytes())
            out["h5_field"] = (".h5", (Path(tmp) / "field.h5").read_bytes())
    return out


def _sweep_tdms(path: Path) -> bytes:
    """A sweep recorded as ``record_sweep`` records one (planned angles, samples per angle,
    complete), its start time fixed."""
    rng = np.random.default_rng(20260101)
    angle = np.repeat(SWEEP_ANGLES, SWEEP_PER)
    volts = 2e-3 * np.sin(np.radians(angle) * 1.7) + 1e-4 + rng.normal(0.0, 2e-5, angle.size)
    metadata = {"source": "fuzz", "rate_Hz": 1000.0, "samples_per_angle": SWEEP_PER,
                "planned_angles_deg": SWEEP_ANGLES.tolist()}
    with RecordingWriter(path, metadata=metadata, chunk=60) as rec:
        for a in SWEEP_ANGLES:
            rows = angle == a
            rec.write(np.flatnonzero(rows) * 1e-3, volts[rows], angle_deg=angle[rows])
    return re.sub(rb"\d{4}-\d\d-\d\dT\d\d:\d\d:\d\d\+00:00", b"2026-01-01T00:00:00+00:00",
                  path.read_bytes())


def _load_tdms(nptdms: object) -> bytes:
    """A tip-force recording at two azimuths from another program (no magcilia properties),
    written in two segments."""
    rng = np.random.default_rng(20260102)
    force = np.tile(np.repeat(LOAD_FORCES, 8), 2)
    azimuth = np.repeat([0.0, 90.0], force.size // 2)
    volts = 40.0 * force * np.cos(np.radians(azimuth)) + rng.normal(0.0, 1e-5, force.size)
    buf = io.BytesIO()
    with nptdms.TdmsWriter(buf) as writer:  # type: ignore[attr-defined]
        for half in (slice(0, 32), slice(32, 64)):
            writer.write_segment([nptdms.ChannelObject(  # type: ignore[attr-defined]
                "daq", k, a[half]) for k, a in (("force_N", force), ("azimuth_deg", azimuth),
                                                ("voltage_V", volts))])
    return buf.getvalue()


#: How :func:`read_case` reads the seeds that need options (by seed name).
READ_OPTIONS: dict[str, dict[str, str]] = {
    "csv_eu": {"decimal": ",", "columns": "time=Zeit,angle=Winkel,voltage=Spannung,setreset=SR"},
    "h5": {"group": "run", "columns": "angle=Tilt,voltage=Vout,time=t,setreset=SR"},
    "csv_field_mapped": {"columns": "azimuth=Phi,angle=Tilt[deg],field_x=Bx,field_y=By[gauss],"
                                    "field_z=Bz"},
}


def write_hdf5_field(path: Path, columns: dict[str, np.ndarray]) -> None:
    """An HDF5 3-axis recording at the root (no times stored: the same bytes each time)."""
    import h5py

    with h5py.File(path, "w") as f:
        for name, values in columns.items():
            f.create_dataset(name, data=values, track_times=False)


def write_hdf5(path: Path) -> None:
    """An HDF5 recording: datasets in group ``run``, units in attributes and names (no times
    stored, so the bytes are the same each time)."""
    import h5py

    with h5py.File(path, "w") as f:
        group = f.create_group("run")
        for name, values, unit in (("Tilt", ANGLES, "deg"), ("Vout", VOLTS * 1e3, "mV"),
                                   ("t", TIME, "s"), ("SR", SETRESET.astype(np.int8), None)):
            data = group.create_dataset(name, data=values, track_times=False)
            if unit:
                data.attrs["units"] = unit
        f.create_dataset("notes", data=np.arange(6.0).reshape(2, 3), track_times=False)


# -- byte mutations -----------------------------------------------------------------------------
Mutation = Callable[[bytearray, np.random.Generator], bytearray]


def _pos(data: bytearray, rng: np.random.Generator, end: int = 0) -> int:
    """A position in ``data``, often near the start (where the headers are)."""
    n = len(data) + end
    if n <= 0:
        return 0
    if rng.random() < 0.5:
        return int(rng.integers(0, min(n, 256)))
    return int(rng.integers(0, n))


def flip_bits(data: bytearray, rng: np.random.Generator) -> bytearray:
    for _ in range(int(rng.integers(1, 9))):
        if data:
            data[_pos(data, rng, -1) if len(data) > 1 else 0] ^= 1 << int(rng.integers(0, 8))
    return data


def set_bytes(data: bytearray, rng: np.random.Generator) -> bytearray:
    for _ in range(int(rng.integers(1, 5))):
        if data:
            data[min(_pos(data, rng), len(data) - 1)] = int(rng.choice([0, 1, 0x7F, 0x80, 0xFF]))
    return data


def write_integer(data: bytearray, rng: np.random.Generator) -> bytearray:
    if len(data) < 8:
        return data
    value = int(rng.choice(INTERESTING))
    value = (value + int(rng.integers(-1, 2))) % (1 << 32)
    fmt = str(rng.choice(["<I", ">I", "<Q"]))
    size = struct.calcsize(fmt)
    at = min(_pos(data, rng), len(data) - size)
    if rng.random() < 0.7:
        at -= at % 4
    data[at:at + size] = struct.pack(fmt, value)
    return data


def truncate(data: bytearray, rng: np.random.Generator) -> bytearray:
    return data[:_pos(data, rng)] if rng.random() < 0.5 else data[:int(rng.integers(0, len(data)
                                                                                      + 1))]


def insert(data: bytearray, rng: np.random.Generator) -> bytearray:
    at = _pos(data, rng)
    junk = rng.integers(0, 256, int(rng.integers(1, 65)), dtype=np.uint8).tobytes()
    return data[:at] + junk + data[at:]


def delete(data: bytearray, rng: np.random.Generator) -> bytearray:
    at = _pos(data, rng)
    return data[:at] + data[at + int(rng.integers(1, 65)):]


def duplicate(data: bytearray, rng: np.random.Generator) -> bytearray:
    at = _pos(data, rng)
    chunk = data[at:at + int(rng.integers(1, 257))]
    to = _pos(data, rng)
    return data[:to] + chunk * int(rng.integers(1, 4)) + data[to:]


def swap(data: bytearray, rng: np.random.Generator) -> bytearray:
    a, b = sorted((_pos(data, rng), _pos(data, rng)))
    n = min(int(rng.integers(1, 65)), b - a)
    if n <= 0:
        return data
    data[a:a + n], data[b:b + n] = data[b:b + n], data[a:a + n]
    return data


def splice(data: bytearray, rng: np.random.Generator) -> bytearray:
    """Another seed recording's header (or tail) in place of this one's."""
    others = [d for _, d in seeds().values()]
    other = others[int(rng.integers(0, len(others)))]
    n = int(rng.integers(1, min(len(other), 600) + 1))
    if rng.random() < 0.7:
        return bytearray(other[:n]) + data[n:]
    return data[:len(data) - n] + bytearray(other[-n:])


BYTE_MUTATIONS: tuple[Mutation, ...] = (flip_bits, set_bytes, write_integer, write_integer,
                                        truncate, insert, delete, duplicate, swap, splice)


# -- format-aware mutations ---------------------------------------------------------------------
def mat_inner(data: bytearray, rng: np.random.Generator) -> bytearray:
    """Mutate the inflated bytes of a compressed MATLAB variable and deflate them again."""
    if len(data) < 136 or data[126:128] != b"IM":
        return data
    starts, pos = [], 128
    while pos + 8 <= len(data):
        mdtype, nbytes = struct.unpack_from("<II", data, pos)
        if mdtype == 15:
            starts.append((pos, nbytes))
        pos += 8 + nbytes
    if not starts:
        return data
    pos, nbytes = starts[int(rng.integers(0, len(starts)))]
    try:
        inner = bytearray(zlib.decompress(bytes(data[pos + 8:pos + 8 + nbytes])))
    except zlib.error:
        return data
    for _ in range(int(rng.integers(1, 3))):
        op = (flip_bits, set_bytes, write_integer, truncate, insert, duplicate)[
            int(rng.integers(0, 6))]
        inner = op(inner, rng)
    packed = zlib.compress(bytes(inner))
    return (data[:pos] + struct.pack("<II", 15, len(packed)) + packed
            + data[pos + 8 + nbytes:])


def tdms_leadin(data: bytearray, rng: np.random.Generator) -> bytearray:
    """Write an interesting integer into a TDMS segment's lead-in or the metadata after it."""
    marks = [m.start() for m in re.finditer(b"TDSm", bytes(data))]
    if not marks:
        return data
    at = marks[int(rng.integers(0, len(marks)))] + 4 + 4 * int(rng.integers(0, 16))
    if at + 8 > len(data):
        return data
    fmt = "<Q" if rng.random() < 0.3 else "<I"
    value = int(rng.choice(INTERESTING)) + int(rng.integers(-1, 2))
    data[at:at + struct.calcsize(fmt)] = struct.pack(fmt, value % (1 << 32))
    return data


def tdms_dtype(data: bytearray, rng: np.random.Generator) -> bytearray:
    """Give a channel another TDMS data type (string, complex, timestamp, DAQmx, void, ...)."""
    marks = [m.start() for m in re.finditer(rb"\x14\x00\x00\x00(?=[\x01-\x44]\x00\x00\x00)",
                                            bytes(data))]
    if not marks:
        return data
    at = marks[int(rng.integers(0, len(marks)))] + 4
    data[at:at + 4] = struct.pack("<I", int(rng.choice(TDMS_TYPES)))
    return data


def csv_text(data: bytearray, rng: np.random.Generator) -> bytearray:
    """Mutate a CSV as text: a value, a column name, a line, a huge field, a control byte."""
    text = bytes(data).decode("utf-8", "replace")
    kind = int(rng.integers(0, 7))
    if kind == 0:  # a value
        numbers = list(re.finditer(r"-?[0-9.]+(e-?[0-9]+)?", text))
        if numbers:
            m = numbers[int(rng.integers(0, len(numbers)))]
            text = text[:m.start()] + str(rng.choice(TEXT_VALUES)) + text[m.end():]
    elif kind == 1:  # a column name: duplicated, missing or renamed
        names = ("angle_deg", "voltage_V", "time_s", "setreset", "note", "", "azimuth_deg",
                 "field_x_T", "field_z_T")
        old, new = rng.choice(names, 2)
        text = text.replace(str(old), str(new), 1)
    elif kind == 2:  # a huge field
        text = text.replace(",", "," + "7" * int(rng.choice([1000, 140_000])), 1)
    elif kind == 3:  # lines duplicated, dropped or joined
        lines = text.splitlines(keepends=True)
        if lines:
            i = int(rng.integers(0, len(lines)))
            lines[i] = str(rng.choice([lines[i] * 2, "", lines[i].rstrip("\r\n")]))
        text = "".join(lines)
    elif kind == 4:  # another delimiter or a quote
        text = text.replace(str(rng.choice([",", "\n"])), str(rng.choice([";", '"', "\t", "\r"])),
                            int(rng.integers(1, 4)))
    elif kind == 5:  # a control or non-UTF-8 byte
        raw = bytearray(text.encode())
        at = _pos(raw, rng)
        return raw[:at] + bytes([int(rng.choice([0, 0x1B, 0x85, 0xC3, 0xFF]))]) + raw[at:]
    else:  # many columns
        text = text.replace("\n", "," * int(rng.integers(1, 3000)) + "\n", 1)
    return bytearray(text.encode())


FORMAT_MUTATIONS: dict[str, tuple[Mutation, ...]] = {
    "csv": (csv_text, csv_text, csv_text),
    "mat_v5z": (mat_inner, mat_inner, mat_inner),
    "tdms": (tdms_leadin, tdms_leadin, tdms_dtype),
    "tdms_magcilia": (tdms_leadin, tdms_leadin, tdms_dtype),
    "csv_quoted": (csv_text, csv_text, csv_text),
    "csv_eu": (csv_text, csv_text, csv_text),
    "csv_field": (csv_text, csv_text, csv_text),
    "csv_field_mapped": (csv_text, csv_text, csv_text),
    "tdms_field": (tdms_leadin, tdms_leadin, tdms_dtype),
    "tdms_sweep": (tdms_leadin, tdms_leadin, tdms_dtype),
    "tdms_load": (tdms_leadin, tdms_leadin, tdms_dtype),
    "mat_v5z_field": (mat_inner, mat_inner, mat_inner),
}


def case(index: int, seed: int = 0, names: Sequence[str] | None = None) -> Case:
    """Case ``index`` of the corpus of ``seed`` (over the seed recordings ``names``, default
    all)."""
    pool = sorted(seeds()) if names is None else list(names)
    name = pool[index % len(pool)]
    suffix, original = seeds()[name]
    rng = np.random.default_rng([seed, index])
    ops = BYTE_MUTATIONS + FORMAT_MUTATIONS.get(name, ())
    data = bytearray(original)
    applied = []
    for _ in range(min(int(rng.geometric(0.5)), 4)):
        op = ops[int(rng.integers(0, len(ops)))]
        data = op(data, rng)
        applied.append(op.__name__)
    return Case(index, name, suffix, bytes(data), tuple(applied))


def cases(n: int, seed: int = 0, suffixes: Sequence[str] | None = None,
          start: int = 0) -> Iterator[Case]:
    """Cases ``start`` … ``start + n − 1`` of seed ``seed`` (only the seed recordings with the
    given suffixes, default all)."""
    names = sorted(k for k, (s, _) in seeds().items() if suffixes is None or s in suffixes)
    for i in range(start, start + n):
        yield case(i, seed, names)


def read_case(path: Path, index: int) -> mc.Measurement:
    """Read a mutated recording as ``magcilia calibrate`` does, the policies varied by index
    (and the options of :data:`READ_OPTIONS` for the seed in the file's name)."""
    options = next((o for name, o in READ_OPTIONS.items()
                    if path.stem == name or path.stem.endswith(f"-{name}")), {})
    return mc.read_measurements(path, nan_policy=("raise", "omit")[index % 2],
                                saturation=("raise", "omit", "keep")[index % 3], **options)


@functools.cache
def _truth(name: str, index_mod: int) -> mc.Measurement:
    """The unmutated seed ``name`` read as case ``index_mod`` (mod 6: the policies) reads."""
    suffix, data = seeds()[name]
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / f"truth-{name}{suffix}"
        path.write_bytes(data)
        return read_case(path, index_mod)


def _values(m: mc.Measurement) -> list[np.ndarray]:
    """What a measurement holds, as arrays to compare."""
    return [np.asarray(x, dtype=np.float64) for x in (
        m.angles, m.azimuths, m.volts, m.sem, m.counts, m.saturated, m.nonfinite,
        np.zeros(0) if m.fields is None else m.fields,
        np.zeros(0) if m.field_sem is None else m.field_sem,
        np.zeros(0) if m.loads is None else m.loads)]


def same_values(m: mc.Measurement, truth: mc.Measurement) -> bool:
    """Whether ``m`` holds the conditions, values and counts of ``truth`` (values to 1e-12
    relative: the same samples reduce to the same doubles; a last-bit change of one sample is
    below that)."""
    a, b = _values(m), _values(truth)
    return all(x.shape == y.shape and np.allclose(x, y, rtol=1e-12, atol=0.0, equal_nan=True)
               for x, y in zip(a, b, strict=True))


def said(m: mc.Measurement) -> bool:
    """Whether the measurement says something is off: a reader's note or a quality finding
    (:meth:`magcilia.Measurement.notes`, where the tree has it), samples dropped as
    non-finite or saturated, or conditions left without a sample."""
    notes = getattr(m, "notes", None)
    return bool((callable(notes) and notes()) or m.nonfinite.sum() or m.saturated.sum()
                or m.metadata.get("dropped"))


def check_case(path: Path, index: int, name: str) -> tuple[str, str]:
    """Read a mutated recording of seed ``name`` and compare it with the seed: ``refused``,
    ``same``, ``noted`` or ``silent`` (see the module docstring), and a detail (the error's
    text after the file name; what changed)."""
    try:
        m = read_case(path, index)
    except mc.MagciliaError as exc:
        return "refused", str(exc)[len(str(path)):][:120]
    truth = _truth(name, index % 6)
    if same_values(m, truth):
        return "same", ""
    if len(m) != len(truth):
        what = f"{len(truth)} -> {len(m)} conditions"
    elif not np.array_equal(m.counts, truth.counts):
        what = "samples moved between conditions"
    else:
        new, old = (m.volts, truth.volts) if m.fields is None else (m.fields, truth.fields)
        sem = truth.sem if m.fields is None else truth.field_sem
        with np.errstate(divide="ignore", invalid="ignore"):
            shift = np.nanmax(np.abs(np.asarray(new) - np.asarray(old)) / np.asarray(sem))
        what = f"values changed by up to {shift:.2g} standard errors"
    return ("noted" if said(m) else "silent"), what


def tdms_raw_ranges(data: bytes) -> list[tuple[int, int]]:
    """The byte ranges of raw data in a sound TDMS file, by its segments' lead-ins (a reference
    written here, apart from the reader's own walk)."""
    ranges, pos = [], 0
    while pos + 28 <= len(data) and data[pos:pos + 4] == b"TDSm":
        toc = struct.unpack_from("<I", data, pos + 4)[0]
        order = ">" if toc & 0x40 else "<"
        _, next_offset, raw_offset = struct.unpack_from(order + "IQQ", data, pos + 8)
        end = pos + 28 + next_offset
        if pos + 28 + raw_offset < end:
            ranges.append((pos + 28 + raw_offset, end))
        pos = end
    return ranges


def touches_structure(case: Case, directory: Path) -> bool:
    """Whether what a TDMS case reads comes from damage to its structure (a lead-in, metadata, a
    length) rather than from bytes of raw data changed in place: the case's raw-data changes
    alone, applied to its seed, must read as the case reads (else the structure mattered)."""
    original = seeds()[case.seed_name][1]
    if len(case.data) != len(original):
        return True
    new, old = np.frombuffer(case.data, np.uint8), np.frombuffer(original, np.uint8)
    inside = np.zeros(new.size, dtype=bool)
    for a, b in tdms_raw_ranges(original):
        inside[a:b] = True
    changed = new != old
    if not (changed & inside).any():
        return True
    if not (changed & ~inside).any():
        return False
    data_only = np.where(inside, new, old).tobytes()
    paths = [directory / f"cause-{which}-{case.seed_name}{case.suffix}" for which in ("a", "b")]
    paths[0].write_bytes(case.data)
    paths[1].write_bytes(data_only)
    try:
        read = [read_case(p, case.index) for p in paths]
    except mc.MagciliaError:
        return True
    finally:
        for p in paths:
            p.unlink()
    return not same_values(*read)
