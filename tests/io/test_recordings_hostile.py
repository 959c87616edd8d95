"""Hostile and damaged recordings: every failure is one MagciliaError line naming the file.

One test per failure measured in issue 12: empty, truncated, zlib-damaged and crashing MATLAB
files, MATLAB v7.3 (HDF5), complex and non-numeric variables, zip bombs and huge declared sizes,
a CSV field beyond the csv module's limit, duplicate columns and channels, huge angles, TDMS
string channels and damaged structure; and that nothing is dropped without being counted.
"""

from __future__ import annotations

import io
import struct
import sys
import zlib
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from scipy.io import savemat

import magcilia as mc
from magcilia._errors import MissingDependencyError
from magcilia.io import RecordingWriter, matfile, recordings
from magcilia.io.recordings import measurement_from_samples, read_samples

ANG = np.repeat([0.0, 10.0, 20.0], 4)
VOLT = np.array([1.0, 1.2, 0.8, 1.0, 2.0, 2.1, 1.9, 2.0, 2.9, 3.1, 3.0, 3.0]) * 1e-3
COLUMNS = {"angle_deg": ANG, "voltage_V": VOLT}
MAT73_HEADER = b"MATLAB 7.3 MAT-file, Platform: GLNXA64, Created on: Thu Jan  1 00:00:00 2026"


def _one_line(info: pytest.ExceptionInfo[Any], path: Path) -> str:
    """The error's message, checked to be one line naming the file."""
    text = str(info.value)
    assert "\n" not in text and "\r" not in text
    assert str(path) in text
    return text


def _mat_bytes(variables: dict[str, Any], **kwargs: Any) -> bytearray:
    buf = io.BytesIO()
    savemat(buf, variables, **kwargs)
    return bytearray(buf.getvalue())


def _write_mat73(path: Path, variables: dict[str, Any], header: bool = True) -> Path:
    """A MATLAB v7.3 file as MATLAB writes one (512-byte user block with the MAT-file header,
    arrays transposed, MATLAB_class attributes)."""
    h5py = pytest.importorskip("h5py")
    with h5py.File(path, "w", userblock_size=512) as f:
        for name, value in variables.items():
            arr = np.asarray(value)
            if arr.dtype.kind == "c":  # MATLAB: a compound of real and imag
                pair = np.dtype([("real", "<f8"), ("imag", "<f8")])
                data = np.empty(arr.shape, pair)
                data["real"], data["imag"] = arr.real, arr.imag
                arr, cls = data, "double"
            elif arr.dtype.kind == "U":  # MATLAB: uint16 character codes
                arr, cls = np.frombuffer(str(arr).encode("utf-16-le"), "<u2"), "char"
            else:
                cls = {"f": "double", "i": "int32", "u": "uint8", "b": "logical"}[arr.dtype.kind]
            ds = f.create_dataset(name, data=arr.reshape(1, -1) if arr.ndim == 1 else arr.T)
            ds.attrs["MATLAB_class"] = np.bytes_(cls)
    if header:
        with path.open("r+b") as f:
            f.write((MAT73_HEADER.ljust(116) + b"\0" * 8 + b"\x00\x02IM").ljust(512, b"\0"))
    return path


# -- MATLAB -------------------------------------------------------------------------------------
def test_an_empty_mat_file(tmp_path: Path) -> None:
    path = tmp_path / "empty.mat"
    path.write_bytes(b"")
    with pytest.raises(mc.MagciliaError, match=r"the file is empty \(0 bytes\)") as info:
        mc.read_measurements(path)
    _one_line(info, path)


@pytest.mark.parametrize("compress", [False, True], ids=["plain", "compressed"])
def test_truncated_mat_files(tmp_path: Path, compress: bool) -> None:
    data = _mat_bytes(COLUMNS, do_compression=compress)
    for cut in (10, 127, 130, 200, len(data) // 2, len(data) - 1):
        path = tmp_path / f"cut{cut}.mat"
        path.write_bytes(data[:cut])
        with pytest.raises(mc.MagciliaError, match="MAT") as info:
            mc.read_measurements(path)
        _one_line(info, path)


def test_a_damaged_zlib_stream(tmp_path: Path) -> None:
    data = _mat_bytes(COLUMNS, do_compression=True)
    data[150:158] = b"\xff" * 8  # inside the first variable's deflate stream
    path = tmp_path / "z.mat"
    path.write_bytes(data)
    with pytest.raises(mc.MagciliaError, match=r"compressed variable at byte 128 is damaged"
                       ) as info:
        mc.read_measurements(path)
    _one_line(info, path)


def test_a_file_that_crashes_scipy_is_one_line(tmp_path: Path) -> None:
    """A real-part data type of 0 makes scipy.io.loadmat (1.17) die of SIGSEGV; the child
    process dies instead of the caller."""
    data = _mat_bytes(COLUMNS)
    tag = data.index(b"angle_deg") + 16  # the real part's tag follows the padded name
    assert struct.unpack_from("<I", data, tag)[0] == 9  # miDOUBLE
    data[tag] = 0
    path = tmp_path / "segv.mat"
    path.write_bytes(data)
    with pytest.raises(mc.MagciliaError, match="MATLAB") as info:
        mc.read_measurements(path)
    _one_line(info, path)


def test_a_crash_or_hang_of_the_reader_is_one_line(tmp_path: Path,
                                                   monkeypatch: pytest.MonkeyPatch) -> None:
    path = tmp_path / "r.mat"
    savemat(path, COLUMNS)
    monkeypatch.setattr(matfile, "_mat_child_code",
                        lambda: "import os, signal; os.kill(os.getpid(), signal.SIGSEGV)")
    if sys.platform != "win32":
        with pytest.raises(mc.MagciliaError, match=r"the MATLAB reader crashed on this file "
                           r"\(signal 11, SIGSEGV\); it is damaged or not a MAT file") as info:
            read_samples(path)
        _one_line(info, path)
    monkeypatch.setattr(matfile, "_mat_child_code", lambda: "raise SystemExit(3)")
    with pytest.raises(mc.MagciliaError, match=r"failed on this file \(exit code 3\)"):
        read_samples(path)
    monkeypatch.setattr(matfile, "_mat_child_code", lambda: "import time; time.sleep(30)")
    monkeypatch.setattr(matfile, "MAT_TIMEOUT_S", 0.5)
    with pytest.raises(mc.MagciliaError, match=r"longer than MAT_TIMEOUT_S = 0\.5 s") as info:
        read_samples(path)
    _one_line(info, path)


def _bomb(path: Path, zeros: int, pieces: int) -> Path:
    """A small variable (angle_deg) followed by ``zeros × pieces`` zero bytes in one deflate
    stream: its element declares a few bytes and inflates to many."""
    inner = bytes(_mat_bytes({"angle_deg": np.zeros(2)})[128:])
    deflate, block = zlib.compressobj(), bytes(zeros)
    packed = deflate.compress(inner) + b"".join(deflate.compress(block) for _ in range(pieces))
    packed += deflate.flush()
    path.write_bytes(bytes(_mat_bytes({})[:128]) + struct.pack("<II", 15, len(packed)) + packed)
    return path


def test_a_zip_bomb_is_refused_before_it_is_inflated(tmp_path: Path,
                                                     monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(matfile, "MAX_DECOMPRESSED", 1 << 20)
    path = tmp_path / "honest.mat"  # 1.6 MB of zeros, declared as such
    savemat(path, {"angle_deg": np.zeros(200_000), "voltage_V": VOLT}, do_compression=True)
    assert path.stat().st_size < 10_000
    with pytest.raises(mc.MagciliaError, match=r"variable angle_deg .* declares 1,600,\d+ bytes, "
                       r"more than MAX_DECOMPRESSED = 0\.000976562 GiB.*raise "
                       r"magcilia\.io\.matfile\.MAX_DECOMPRESSED") as info:
        mc.read_measurements(path)
    _one_line(info, path)
    path = _bomb(tmp_path / "lying.mat", 1 << 16, 40)  # declares 64 bytes, inflates to 2.6 MB
    with pytest.raises(mc.MagciliaError, match=r"variable angle_deg .* inflates to more than "
                       r"MAX_DECOMPRESSED") as info:
        mc.read_measurements(path)
    _one_line(info, path)


@pytest.mark.slow
def test_a_real_size_zip_bomb(tmp_path: Path) -> None:
    """1.1 GiB of zeros behind a small variable in a 1 MB file: refused by counting the inflated
    bytes in bounded pieces (the fast test above does the same against a lowered limit)."""
    path = _bomb(tmp_path / "bomb.mat", 1 << 24, 70)
    assert path.stat().st_size < 2_000_000
    with pytest.raises(mc.MagciliaError, match=r"variable angle_deg .* inflates to more than "
                       r"MAX_DECOMPRESSED = 1 GiB"):
        read_samples(path)


def test_a_huge_declared_size_meets_the_memory_limit(tmp_path: Path) -> None:
    data = _mat_bytes(COLUMNS)
    tag = data.index(b"angle_deg") + 16
    struct.pack_into("<I", data, tag + 4, 0xFFFFFFF0)  # a 4 GiB real part in a 1 kB file
    path = tmp_path / "huge.mat"
    path.write_bytes(data)
    with pytest.raises(mc.MagciliaError) as info:
        read_samples(path)
    text = _one_line(info, path)
    if sys.platform.startswith("linux"):
        assert "needs more than MAT_MEMORY_LIMIT = 4 GiB" in text


def test_matlab_v73_files_are_read(tmp_path: Path) -> None:
    v5 = tmp_path / "v5.mat"
    savemat(v5, {**COLUMNS, "time_s": np.arange(12) * 1e-3})
    v73 = _write_mat73(tmp_path / "v73.mat", {**COLUMNS, "time_s": np.arange(12) * 1e-3,
                                              "note": "bench"})
    a, b = read_samples(v5), read_samples(v73)
    assert sorted(a) == sorted(b) == ["angle_deg", "time_s", "voltage_V"]
    for key in a:
        np.testing.assert_array_equal(a[key], b[key])
    np.testing.assert_allclose(mc.read_measurements(v73).volts, [1e-3, 2e-3, 3e-3])
    plain = _write_mat73(tmp_path / "plain.mat", {"angle_deg": ANG.astype(np.int32),
                                                  "voltage_V": VOLT[None, :]}, header=False)
    np.testing.assert_array_equal(read_samples(plain)["angle_deg"], ANG)


@pytest.mark.parametrize(
    ("value", "match"),
    [(VOLT * (1 + 1j), "variable voltage_V is complex; save its real part"),
     ("1 mV", "variable voltage_V is a MATLAB char array, not a numeric vector"),
     (VOLT.reshape(3, 4), r"variable voltage_V is a 3×4 matrix; save a vector")],
    ids=["complex", "text", "matrix"],
)
def test_bad_matlab_v73_variables(tmp_path: Path, value: Any, match: str) -> None:
    path = _write_mat73(tmp_path / "bad.mat", {"angle_deg": ANG, "voltage_V": value})
    with pytest.raises(mc.MagciliaError, match=match) as info:
        read_samples(path)
    _one_line(info, path)


def test_a_v73_variable_beyond_the_limit(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    path = _write_mat73(tmp_path / "big.mat", COLUMNS)
    monkeypatch.setattr(matfile, "MAX_DECOMPRESSED", 50)
    with pytest.raises(mc.MagciliaError, match=r"variable angle_deg holds 96 bytes, more than "
                       r"MAX_DECOMPRESSED = 50; raise magcilia\.io\.matfile") as info:
        read_samples(path)
    _one_line(info, path)


def test_v73_without_h5py_names_the_extra(tmp_path: Path,
                                          monkeypatch: pytest.MonkeyPatch) -> None:
    path = _write_mat73(tmp_path / "v73.mat", COLUMNS)
    monkeypatch.setitem(sys.modules, "h5py", None)
    with pytest.raises(MissingDependencyError, match=r"magcilia\[hdf5\]"):
        read_samples(path)


@pytest.mark.parametrize(
    ("value", "match"),
    [(VOLT * (1 + 1j), "variable voltage_V is complex; save its real part"),
     ("1 mV", "variable voltage_V is a MATLAB char array, not a numeric vector"),
     ({"a": 1.0}, "variable voltage_V is a MATLAB struct array, not a numeric vector"),
     (np.array([VOLT, "x"], dtype=object), "variable voltage_V is a MATLAB cell array"),
     (VOLT.reshape(3, 4), r"variable voltage_V is a 3×4 matrix; save a vector"),
     (VOLT[:5], r"the columns have different lengths \(angle_deg 12, voltage_V 5\)")],
    ids=["complex", "text", "struct", "cell", "matrix", "ragged"],
)
def test_bad_matlab_variables(tmp_path: Path, value: Any, match: str) -> None:
    path = tmp_path / "bad.mat"
    savemat(path, {"angle_deg": ANG, "voltage_V": value})
    with pytest.raises(mc.MagciliaError, match=match) as info:
        mc.read_measurements(path)
    _one_line(info, path)


def test_a_variable_saved_twice_is_an_error(tmp_path: Path) -> None:
    first = _mat_bytes(COLUMNS)
    again = _mat_bytes({"voltage_V": VOLT * 2})[128:]
    path = tmp_path / "twice.mat"
    path.write_bytes(bytes(first + again))
    with pytest.raises(mc.MagciliaError, match="variable voltage_V appears 2 times") as info:
        mc.read_measurements(path)
    _one_line(info, path)


def test_matlab_v4_files_are_still_read(tmp_path: Path) -> None:
    path = tmp_path / "v4.mat"
    savemat(path, COLUMNS, format="4")
    np.testing.assert_allclose(mc.read_measurements(path).volts, [1e-3, 2e-3, 3e-3])
    data = path.read_bytes()
    (tmp_path / "cut.mat").write_bytes(data[:-9])
    with pytest.raises(mc.MagciliaError, match="truncated or damaged"):
        read_samples(tmp_path / "cut.mat")


# -- CSV ----------------------------------------------------------------------------------------
@pytest.mark.parametrize(
    ("content", "match"),
    [(b"angle_deg,voltage_V\n0," + b"1" * 140_000 + b"\n10,2e-3\n",
      r"row 2 is not well-formed CSV \(field larger than field limit \(131072\)\)"),
     (b"angle_deg,voltage_V\n0,1e-3\n10,2\x00\n", r"row 3, column voltage_V: '2\\x00' is not"),
     (b"angle_deg,voltage_V,voltage_V\n0,1e-3,1\n10,2e-3,2\n",
      r"column 'voltage_V' appears 2 times in the header \(columns 2, 3\)"),
     (b"angle_deg,voltage_V\n0,1e-3\n10,\xff\n", r"not a UTF-8 text file \(line 3\)"),
     (b"angle_deg,voltage_V\n0,\x1b[2J\n", r"'\\x1b\[2J' is not a number"),
     (b"angle\x1b[2J,voltage_V\n0,1\n", r"missing column 'angle_deg' \(header: angle\\x1b"),
     (b"# a comment\n\nangle_deg,voltage_V\n0,1e-3\n# more\n10,xyz\n",
      r"row 6, column voltage_V: 'xyz' is not a number")],
    ids=["huge-field", "nul", "duplicate-column", "not-utf8", "escape", "escape-header",
         "line-numbers"],
)
def test_hostile_csv_files(tmp_path: Path, content: bytes, match: str) -> None:
    path = tmp_path / "bad.csv"
    path.write_bytes(content)
    with pytest.raises(mc.MagciliaError, match=match) as info:
        mc.read_measurements(path)
    _one_line(info, path)


def test_csv_limits(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    path = tmp_path / "long.csv"
    path.write_text("angle_deg,voltage_V\n" + "\n".join(f"{a},{v}" for a, v in zip(ANG, VOLT,
                                                                                strict=True)))
    monkeypatch.setattr(recordings, "MAX_SAMPLES", 5)
    with pytest.raises(mc.MagciliaError, match=r"more than MAX_SAMPLES = 5 samples.*raise "
                       r"magcilia\.io\.recordings\.MAX_SAMPLES") as info:
        read_samples(path)
    _one_line(info, path)
    monkeypatch.setattr(recordings, "MAX_LINE_CHARS", 10)
    with pytest.raises(mc.MagciliaError, match=r"line 1 is longer than MAX_LINE_CHARS = 10"):
        read_samples(path)


def test_csv_columns_besides_ours_may_repeat(tmp_path: Path) -> None:
    path = tmp_path / "extra.csv"
    path.write_text("angle_deg,voltage_V,,\n" + "\n".join(f"{a},{v},," for a, v in zip(
        ANG, VOLT, strict=True)))
    assert read_samples(path)["voltage_V"].size == 12


# -- TDMS ---------------------------------------------------------------------------------------
def _tdms(path: Path, channels: list[tuple[str, str, Any]], props: dict[str, Any] | None = None
          ) -> Path:
    nptdms = pytest.importorskip("nptdms")
    with nptdms.TdmsWriter(path) as writer:
        writer.write_segment([nptdms.RootObject(props or {})]
                             + [nptdms.ChannelObject(g, n, d) for g, n, d in channels])
    return path


def test_a_channel_in_two_groups_is_an_error(tmp_path: Path) -> None:
    path = _tdms(tmp_path / "dup.tdms", [("a", "angle_deg", ANG), ("a", "voltage_V", VOLT),
                                         ("b", "voltage_V", VOLT * 2)])
    with pytest.raises(mc.MagciliaError, match=r"channel voltage_V appears in 2 groups \(a, b\)"
                       ) as info:
        mc.read_measurements(path)
    _one_line(info, path)


def test_a_magcilia_recording_with_readout_and_events_groups_reads(tmp_path: Path) -> None:
    pytest.importorskip("nptdms")
    path = tmp_path / "live.tdms"
    with RecordingWriter(path, chunk=5) as rec:
        rec.write(np.arange(12) * 1e-3, VOLT, angle_deg=ANG)
        rec.write_group("readout", {"readout_time_s": [0.0, 1.0], "value": [1.0, 2.0]})
        rec.write_group("events", {"event_time_s": [0.5], "event_code": [1.0]})
    np.testing.assert_allclose(mc.read_measurements(path).volts, [1e-3, 2e-3, 3e-3])


@pytest.mark.parametrize(
    ("data", "match"),
    [(np.array(["1", "2"] * 6), "holds String values, not real numbers"),
     (VOLT * (1 + 1j), "holds ComplexDoubleFloat values, not real numbers"),
     (np.array(["2024-01-01"] * 12, dtype="datetime64[us]"), "holds TimeStamp values"),
     (VOLT[:7], r"the columns have different lengths \(angle_deg 12, voltage_V 7\)")],
    ids=["string", "complex", "timestamp", "ragged"],
)
def test_bad_tdms_channels(tmp_path: Path, data: Any, match: str) -> None:
    path = _tdms(tmp_path / "bad.tdms", [("g", "angle_deg", ANG), ("g", "voltage_V", data)])
    with pytest.raises(mc.MagciliaError, match=match) as info:
        mc.read_measurements(path)
    _one_line(info, path)


def test_damaged_tdms_structure(tmp_path: Path) -> None:
    """Damage that makes npTDMS raise struct.error, ValueError, KeyError, NotImplementedError or
    OSError (an impossible seek), or cuts the file: one line each, the parser's error kept."""
    good = _tdms(tmp_path / "good.tdms", [("g", "angle_deg", ANG), ("g", "voltage_V", VOLT)])
    data = bytearray(good.read_bytes())
    cases = [(4, 0), (12, 0), (20, 0xFFFFFFFF), (32, 0), (32, 0xFFFFFFFF), (36, 0x7FFFFFFF),
             (40, 0xFFFFFFFF), (44, 0), (56, 0xFFFFFFFF), (88, 0), (96, 0xFFFFFFFF)]
    for at, value in cases:
        bad = bytearray(data)
        struct.pack_into("<I", bad, at, value)
        path = tmp_path / f"bad{at}-{value}.tdms"
        path.write_bytes(bad)
        with pytest.raises(mc.MagciliaError) as info:
            mc.read_measurements(path)
        text = _one_line(info, path)
        if "cannot read as a TDMS file" in text:
            assert info.value.__cause__ is not None  # the parser's exception is kept
    for cut in (3, 27, 40, 60, 100, 200):  # npTDMS reads what it can of a cut file
        path = tmp_path / f"cut{cut}.tdms"
        path.write_bytes(data[:cut])
        with pytest.raises(mc.MagciliaError) as info:  # unreadable, missing or unequal channels
            mc.read_measurements(path)
        if "cannot read as a TDMS file" in _one_line(info, path):
            assert info.value.__cause__ is not None


def test_daqmx_and_void_channels(tmp_path: Path) -> None:
    good = _tdms(tmp_path / "good.tdms", [("g", "angle_deg", ANG), ("g", "voltage_V", VOLT)])
    data = good.read_bytes()
    double = b"\x14\x00\x00\x00\x0a\x00\x00\x00"  # raw data index: length 20, type double
    assert data.count(double) == 2
    for code in (0xFFFFFFFF, 0, 0x20):
        path = tmp_path / f"type{code}.tdms"
        path.write_bytes(data.replace(double, double[:4] + struct.pack("<I", code)))
        with pytest.raises(mc.MagciliaError) as info:
            mc.read_measurements(path)
        _one_line(info, path)


# -- samples ------------------------------------------------------------------------------------
@pytest.mark.parametrize("angle", [1e300, 1.8e300, -3e305, 361.0, np.finfo(float).max])
def test_huge_angles_are_an_error_not_dropped(angle: float) -> None:
    ang = ANG.copy()
    ang[5] = angle
    with pytest.raises(mc.MagciliaError, match=r"sample 6 has angle_deg=.* beyond ±360 deg"):
        measurement_from_samples(ang, VOLT, nan_policy="omit", source="r.csv")


def test_tilts_up_to_a_full_turn_are_grouped() -> None:
    m = measurement_from_samples(np.repeat([-360.0, 0.0, 359.999999999], 4), VOLT)
    np.testing.assert_allclose(m.angles_deg, [-360.0, 0.0, 359.999999999])


def test_samples_without_an_angle_or_angles_without_samples_are_counted() -> None:
    ang, volt = ANG.copy(), VOLT.copy()
    ang[0] = np.nan  # no angle to count it under
    volt[4:8] = np.nan  # every sample at 10 deg
    ang = np.append(ang, [30.0, 30.0])
    volt = np.append(volt, [1.0, 1.0])  # saturated: 30 deg has no usable sample
    m = measurement_from_samples(ang, volt, nan_policy="omit", saturation="omit", source="r")
    assert m.angles_deg.tolist() == pytest.approx([0.0, 20.0])
    assert int(m.counts.sum()) + int(m.nonfinite.sum()) + int(m.saturated.sum()) == 7
    assert m.metadata["dropped"] == {"no_angle": 1, "angles_deg": [10.0, 30.0], "samples": 6}
    assert "1 without a finite angle" in m.report()
    assert "6 at 2 angle(s) left with no usable sample (10, 30 deg)" in m.report()
    assert mc.Measurement.from_dict(m.to_dict()).metadata == m.metadata


def test_readings_that_overflow_are_an_error() -> None:
    volt = VOLT.copy()
    volt[:4] = 1.5e308
    with pytest.raises(mc.MagciliaError, match="the reading at 0 deg overflows"):
        measurement_from_samples(ANG, volt, saturation="keep", source="r")


def test_a_bad_setreset_value_is_named() -> None:
    with pytest.raises(mc.MagciliaError, match=r"sample 3 has setreset=0\.5, neither \+1"):
        measurement_from_samples(ANG, VOLT, setreset=[1, -1, 0.5] + [1, -1] * 4 + [-1])
