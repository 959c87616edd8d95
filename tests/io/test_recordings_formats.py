"""Lab files (issue 13, item 5): column and unit mapping, delimiters, the decimal comma, HDF5
recordings and progress of long reads, with their hostile cases."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import magcilia as mc
from magcilia._errors import MissingDependencyError
from magcilia.io import csvfile, recordings
from magcilia.io.columns import Columns, split_unit
from magcilia.io.csvfile import NotPlainCSV, plain_csv_blocks, read_csv_carefully
from magcilia.io.recordings import measurement_from_samples, read_samples

RNG = np.random.default_rng(13)
ANG = np.repeat(np.arange(-40.0, 41.0, 10.0), 12)
VOLT = 0.01 + 2e-3 * np.sin(np.radians(ANG)) + RNG.normal(0.0, 2e-5, ANG.size)
TIME = np.arange(ANG.size) * 1e-3
REF = measurement_from_samples(ANG, VOLT)


def _limits() -> dict[str, int]:
    return {"max_samples": recordings.MAX_SAMPLES, "max_line_chars": recordings.MAX_LINE_CHARS}


def _num(x: float, decimal: str = ".") -> str:
    return repr(float(x)).replace(".", decimal)


def _table(path: Path, header: list[str], columns: list[np.ndarray], sep: str = ",",
           decimal: str = ".") -> Path:
    lines = [sep.join(header)] + [sep.join(_num(c[i], decimal) for c in columns)
                                  for i in range(columns[0].size)]
    path.write_text("\n".join(lines) + "\n", encoding="utf-8")
    return path


def _same(m: mc.Measurement, ref: mc.Measurement = REF, rtol: float = 1e-12) -> None:
    np.testing.assert_allclose(m.angles, ref.angles, rtol=1e-15, atol=1e-15)
    np.testing.assert_allclose(m.volts, ref.volts, rtol=rtol)
    np.testing.assert_allclose(m.sem, ref.sem, rtol=1e-9)
    np.testing.assert_array_equal(m.counts, ref.counts)


def _one_line(exc: pytest.ExceptionInfo[Any], path: Path | None = None) -> str:
    text = str(exc.value)
    assert "\n" not in text
    assert path is None or str(path) in text
    return text


# -- the mapping --------------------------------------------------------------------------------
def test_parse_and_coerce() -> None:
    cols = Columns.parse("angle=Tilt[deg], voltage = Vout[mV]")
    assert cols == Columns(angle="Tilt[deg]", voltage="Vout[mV]")
    assert cols.spec("voltage") == ("Vout", "mV") and cols.spec("time") == ("time_s", None)
    assert Columns.coerce({"voltage": "Vout[mV]"}).voltage == "Vout[mV]"
    assert Columns.coerce(None).is_default and Columns.coerce(cols) is cols
    assert Columns.coerce("time=t[ms]").spec("time") == ("t", "ms")
    # "(raw)" is no voltage unit: part of the name; "(mV)" is one
    assert Columns(voltage="Vout (raw)").spec("voltage") == ("Vout (raw)", None)
    assert Columns(voltage="Vout (mV)").spec("voltage") == ("Vout", "mV")
    assert split_unit("U [µV]") == ("U", "µV") and split_unit("[V]") == ("[V]", None)


@pytest.mark.parametrize(
    ("value", "match"),
    [("tilt=Tilt[deg]", (r"--columns must be ROLE=NAME\[unit\],\.\.\. with ROLE one of angle, "
                        r"voltage, time, setreset.*got 'tilt=Tilt\[deg\]'")),
     ("angle", r"--columns must be ROLE=NAME.*got 'angle'"),
     ("angle=", r"got 'angle='"),
     ("angle=a[deg],angle=b[deg]", r"each role once \(angle is given twice\)"),
     ("angle=Tilt[mm]", (r"columns angle must be NAME\[unit\] with an angle unit \(rad, deg, °\); "
                        r"got 'Tilt\[mm\]'")),
     ("voltage=Vout[deg]", r"a voltage unit \(V, mV, uV, µV\)"),
     ("setreset=SR[V]", r"columns setreset must be a column name without a unit"),
     ("angle=x[deg],voltage=x[V]", (r"columns voltage must be a column other than the angle's "
                                   r"\(x\)")),
     ({"tilt": "Tilt"}, (r"columns must be a role: angle, voltage, time, setreset, azimuth, "
                         r"field_x, field_y, field_z, force, flow, actuation_x, actuation_y, "
                         r"actuation_z, temperature, temperature_celsius; got 'tilt'")),
     (3, r"columns must be a Columns, a mapping")])
def test_bad_mappings(value: Any, match: str) -> None:
    with pytest.raises(mc.MagciliaError, match=match) as info:
        Columns.coerce(value)
    _one_line(info)


def test_units_from_the_mapping_the_header_and_the_name(tmp_path: Path) -> None:
    cases = {  # header names, mapping
        "mapping": (["Tilt", "Vout"], "angle=Tilt[deg],voltage=Vout[mV]"),
        "brackets": (["Tilt [deg]", "Vout [mV]"], "angle=Tilt,voltage=Vout"),
        "parentheses": (["Tilt (deg)", "Vout(mV)"], "angle=Tilt,voltage=Vout"),
        "both agree": (["Tilt [deg]", "Vout [mV]"], "angle=Tilt[deg],voltage=Vout[mV]"),
        "suffix": (["tilt_deg", "Vout_mV"], "angle=tilt_deg,voltage=Vout_mV"),
        "exact name": (["Tilt [deg]", "Vout [mV]"], "angle=Tilt [deg],voltage=Vout [mV]"),
        "radians, uV": (["phi", "U"], "angle=phi[rad],voltage=U[uV]"),
    }
    for name, (header, mapping) in cases.items():
        ang = np.radians(ANG) if "rad" in name else ANG
        volt = VOLT * (1e6 if "uV" in name else 1e3)
        path = _table(tmp_path / "m.csv", ["time_s", *header], [TIME, ang, volt])
        _same(mc.read_measurements(path, columns=mapping), rtol=1e-12)
        cols = read_samples(path, columns=mapping)
        assert sorted(cols) == ["angle_deg", "time_s", "voltage_V"], name
        np.testing.assert_allclose(cols["voltage_V"], VOLT, rtol=1e-14)


@pytest.mark.parametrize(
    ("header", "mapping", "match"),
    [(["Tilt", "Vout"], None, (r"m\.csv: missing column 'angle_deg' \(header: time_s, Tilt, "
                              r"Vout\); the file needs columns angle_deg and voltage_V, or map "
                              r"the angle to yours with --columns angle=NAME\[unit\]")),
     (["Tilt", "Vout"], "angle=Tilt[deg],voltage=U[V]",
      (r"missing column 'U' \(header: time_s, Tilt, Vout\); map the voltage to one of them with "
      r"--columns voltage=NAME\[unit\] \(API: columns=\{'voltage': 'NAME\[unit\]'\}\)")),
     (["Tilt", "Vout"], "angle=Tilt[deg],voltage=Vout",
      (r"column 'Vout' \(voltage\) has no unit; give it in the mapping, e.g. --columns "
      r"voltage=Vout\[V\] \(a voltage unit: V, mV, uV, µV\)")),
     (["Tilt [deg]", "Vout [mV]"], "angle=Tilt,voltage=Vout[V]",
      r"column 'Vout' \(voltage\): the mapping says V, the file's name says mV; make them agree"),
     (["Tilt [mm]", "Vout [mV]"], "angle=Tilt,voltage=Vout",
      (r"column 'Tilt' \(angle\) has the unit 'mm', not an angle unit \(rad, deg, °\); give it "
      r"in the mapping, e.g. --columns angle=Tilt\[deg\]")),
     (["Tilt [deg]", "Tilt (deg)", "Vout [mV]"], "angle=Tilt,voltage=Vout",
      r"column 'Tilt' appears 2 times in the header \(columns 2, 3\); keep one, it is ambiguous")])
def test_mapping_errors_name_the_fix(tmp_path: Path, header: list[str], mapping: str | None,
                                     match: str) -> None:
    path = _table(tmp_path / "m.csv", ["time_s", *header],
                  [TIME, *([ANG] * (len(header) - 1)), VOLT * 1e3])
    for read in (mc.read_measurements, read_samples):
        with pytest.raises(mc.MagciliaError, match=match) as info:
            read(path, columns=mapping)
        _one_line(info, path)


def test_an_unknown_unit_in_the_header_yields_to_the_mapping(tmp_path: Path) -> None:
    path = _table(tmp_path / "m.csv", ["Tilt (degrees)", "Vout [mV]"], [ANG, VOLT * 1e3])
    with pytest.raises(mc.MagciliaError, match=r"has the unit 'degrees', not an angle unit"):
        mc.read_measurements(path, columns="angle=Tilt,voltage=Vout")
    _same(mc.read_measurements(path, columns="angle=Tilt[deg],voltage=Vout"))


def test_setreset_and_time_are_mapped(tmp_path: Path) -> None:
    sr = np.tile([1.0, -1.0], ANG.size // 2)
    volt = 0.005 + sr * (VOLT - 0.01)
    path = _table(tmp_path / "sr.csv", ["t [ms]", "a", "u", "SR"], [TIME * 1e3, ANG, volt, sr])
    cols = read_samples(path, columns="time=t,angle=a[deg],voltage=u[V],setreset=SR")
    np.testing.assert_allclose(cols["time_s"], TIME, rtol=1e-14)
    np.testing.assert_array_equal(cols["setreset"], sr)
    m = mc.read_measurements(path, columns="time=t,angle=a[deg],voltage=u[V],setreset=SR")
    assert m.set_reset and len(m) == len(REF)


# -- delimiters and the decimal comma -----------------------------------------------------------
FILES = {  # name: (separator, decimal mark, delimiter argument)
    "semicolon": (";", ".", None),
    "tab": ("\t", ".", None),
    "whitespace": ("   ", ".", None),
    "european": (";", ",", None),
    "european-tab": ("\t", ",", "tab"),
    "european-whitespace": (" ", ",", "whitespace"),
    "comma-explicit": (",", ".", ","),
}


@pytest.mark.parametrize("name", sorted(FILES))
def test_delimiters_and_decimal_marks_are_read_fast(tmp_path: Path,
                                                    monkeypatch: pytest.MonkeyPatch,
                                                    name: str) -> None:
    sep, decimal, delimiter = FILES[name]
    path = _table(tmp_path / "d.csv", ["time_s", "angle_deg", "voltage_V"], [TIME, ANG, VOLT],
                  sep, decimal)
    if "whitespace" in name:  # leading and trailing blanks too
        path.write_text("".join(f"  {line}\t \n" for line in path.read_text().splitlines()))
    kw = {"delimiter": csvfile.delimiter_of(delimiter), "decimal": decimal}
    careful = read_csv_carefully(path, recordings.COLUMNS, ("angle_deg", "voltage_V"),
                                 **_limits(), **kw)
    blocks = list(plain_csv_blocks(path, recordings.COLUMNS, ("angle_deg", "voltage_V"),
                                   **_limits(), **kw))
    assert len(blocks) == 1 and blocks[0].keys() == careful.keys()
    for key in careful:  # the same doubles, bit for bit
        np.testing.assert_array_equal(blocks[0][key], careful[key])
    np.testing.assert_array_equal(careful["voltage_V"], VOLT)
    monkeypatch.setattr(recordings, "read_csv_carefully", None)  # a call would fail
    _same(mc.read_measurements(path, delimiter=delimiter, decimal=decimal), rtol=0)


def test_quoted_decimal_commas_with_comma_delimiters(tmp_path: Path) -> None:
    path = tmp_path / "q.csv"
    path.write_text("angle_deg,voltage_V\n" + "".join(
        f'"{_num(a, ",")}","{_num(v, ",")}"\n' for a, v in zip(ANG, VOLT, strict=True)))
    _same(mc.read_measurements(path, decimal=","), rtol=0)


@pytest.mark.parametrize(
    ("text", "kw", "match"),
    [("angle_deg;voltage_V\n-40,5;0,0125\n0;0,02\n", {},
      (r"row 2, column angle_deg: '-40,5' is not a number; a decimal comma\? pass decimal=',' "
      r"\(CLI: --decimal ,\)")),
     ("angle_deg voltage_V\n-40,5 0,0125\n", {},
      r"'-40,5' is not a number; a decimal comma\?"),
     ("angle_deg;voltage_V\n-40.5;0.0125\n", {"decimal": ","},
      (r"row 2, column angle_deg: '-40\.5' is not a number with a decimal comma \(decimal=','\); "
      r"for a decimal point pass decimal='\.'")),
     ("angle_deg;voltage_V\n1,5;1.000,5\n", {"decimal": ","},
      r"column voltage_V: '1\.000,5' is not a number with a decimal comma"),
     ("angle_deg;voltage_V\n1,5;1,000,5\n", {"decimal": ","},
      r"column voltage_V: '1,000,5' is not a number$"),
     ("angle_deg,voltage_V\n-40,5,0,0125\n", {"decimal": ","},
      r"row 2 has 4 fields, the header has 2"),
     ("angle_deg;voltage_V\n1;2\n", {"delimiter": ","},
      r"missing column 'angle_deg' \(header: angle_deg;voltage_V\)"),
     ("Tilt\tVout\n1\t2\n", {"delimiter": ";", "columns": "angle=Tilt[deg],voltage=Vout[V]"},
      r"missing column 'Tilt' \(header: Tilt\\tVout\)")])
def test_a_wrong_decimal_mark_or_delimiter_is_never_misread(tmp_path: Path, text: str,
                                                            kw: dict[str, str],
                                                            match: str) -> None:
    path = tmp_path / "eu.csv"
    path.write_text(text)
    for read in (mc.read_measurements, read_samples):
        with pytest.raises(mc.MagciliaError, match=match) as info:
            read(path, **kw)
        _one_line(info, path)


@pytest.mark.parametrize(
    ("kw", "suffix", "match"),
    [({"delimiter": "|"}, ".csv", (r"delimiter must be auto, ',', ';', tab or whitespace; got "
                                  r"'\|'")),
     ({"decimal": ";"}, ".csv", r"decimal must be '\.' or ',' \(a decimal comma\); got ';'"),
     ({"decimal": ","}, ".mat", (r"decimal must be left out for a MATLAB \.mat file \(delimiter "
                                r"and decimal mark are CSV options\); got ','")),
     ({"delimiter": "tab"}, ".h5", r"delimiter must be left out for a HDF5 file"),
     ({"group": "run3"}, ".csv", (r"group must be left out for a CSV file \(groups are in HDF5 "
                                 r"and TDMS files\)")),
     ({"progress": 3}, ".csv", r"progress must be a callable progress\(done, total\)"),
     ({"required": ("angle",)}, ".csv", (r"required must be keys among angle_deg, voltage_V, "
                                        r"time_s, setreset, azimuth_deg, field_x_T, "
                                        r"field_y_T, field_z_T, force_N, flow_m_per_s, "
                                        r"actuation_x_T, actuation_y_T, actuation_z_T, "
                                        r"observable; got 'angle'"))])
def test_bad_reading_options(tmp_path: Path, kw: dict[str, Any], suffix: str,
                             match: str) -> None:
    path = tmp_path / f"r{suffix}"
    path.write_bytes(b"angle_deg,voltage_V\n1,2\n")
    with pytest.raises(mc.MagciliaError, match=match) as info:
        read_samples(path, **kw)
    _one_line(info)


NUMBER = st.one_of(st.floats(allow_nan=False, allow_infinity=True, width=64).map(repr),
                   st.integers(-999, 999).map(str),
                   st.sampled_from(["", "nan", "-inf", "1e309", "1,5", "1.5", "0,0", ".5",
                                    ",5", "5,", "1e-3", "1,5e-3", "x", "+1", "--1"]))


@settings(max_examples=150, deadline=None, suppress_health_check=[HealthCheck.too_slow,
                                                                  HealthCheck.function_scoped_fixture])
@given(sep=st.sampled_from([",", ";", "\t", " ", "  ", " ; "]), decimal=st.sampled_from(".,"),
       delimiter=st.sampled_from([None, ",", ";", "tab", "whitespace"]),
       rows=st.lists(st.tuples(NUMBER, NUMBER, NUMBER), max_size=12),
       decimal_commas=st.booleans())
def test_the_fast_reader_agrees_with_the_careful_one_on_any_delimiter(
        tmp_path: Path, sep: str, decimal: str, delimiter: str | None,
        rows: list[tuple[str, str, str]], decimal_commas: bool) -> None:
    """Wherever the fast reader answers, the careful reader gives the same doubles; every
    refusal is one line."""
    lines = [sep.join(["angle_deg", "voltage_V", "time_s"])]
    lines += [sep.join(c.replace(".", ",") if decimal_commas else c for c in row)
              for row in rows]
    path = tmp_path / "h.csv"
    path.write_text("\n".join(lines) + "\n")
    kw: dict[str, Any] = {"delimiter": csvfile.delimiter_of(delimiter), "decimal": decimal}
    try:
        careful: dict[str, np.ndarray] | str = read_csv_carefully(
            path, recordings.COLUMNS, ("angle_deg", "voltage_V"), **_limits(), **kw)
    except mc.MagciliaError as exc:
        careful = str(exc)
        assert "\n" not in careful and str(path) in careful
    error = ""
    try:
        blocks = list(plain_csv_blocks(path, recordings.COLUMNS, ("angle_deg", "voltage_V"),
                                       **_limits(), **kw))
    except NotPlainCSV:
        return
    except mc.MagciliaError as exc:  # a header error: the careful reader's own
        error = str(exc)
    if error:
        assert error == careful
        return
    assert not isinstance(careful, str), careful
    fast = {k: np.concatenate([b[k] for b in blocks]) for k in blocks[0]}
    assert fast.keys() == careful.keys()
    for key, values in fast.items():
        np.testing.assert_array_equal(values, careful[key])


# -- HDF5 ---------------------------------------------------------------------------------------
h5py = pytest.importorskip("h5py")


def _h5(path: Path, datasets: dict[str, Any], attrs: dict[str, dict[str, Any]] | None = None,
        **create: Any) -> Path:
    with h5py.File(path, "w") as f:
        for name, value in datasets.items():
            f.create_dataset(name, data=value, **create)
        for name, items in (attrs or {}).items():
            f[name].attrs.update(items)
    return path


def test_hdf5_recordings(tmp_path: Path) -> None:
    root = _h5(tmp_path / "root.h5", {"angle_deg": ANG, "voltage_V": VOLT, "time_s": TIME})
    _same(mc.read_measurements(root), rtol=0)
    cols = read_samples(root, required=("voltage_V",))
    np.testing.assert_array_equal(cols["time_s"], TIME)
    # a group, a units attribute (bytes or str), float32 and int16 storage, column vectors
    grouped = _h5(tmp_path / "g.hdf5",
                  {"run3/Tilt": ANG.astype(np.int16), "run3/Vout": (VOLT * 1e3)[:, None],
                   "run3/t": TIME.astype(np.float32)},
                  {"run3/Vout": {"units": "mV"}, "run3/t": {"units": b"s"}})
    m = mc.read_measurements(grouped, group="run3", columns="angle=Tilt[deg],voltage=Vout")
    _same(m, rtol=1e-12)
    assert read_samples(grouped, group="/run3", columns={"angle": "Tilt[deg]", "voltage": "Vout",
                                                         "time": "t"})["time_s"].dtype == float
    # paths below the group in the names, and a dataset named with its unit
    paths = _h5(tmp_path / "p.h5", {"daq/Tilt [deg]": ANG, "daq/U": VOLT})
    _same(mc.read_measurements(paths, columns="angle=daq/Tilt,voltage=daq/U[V]"), rtol=0)
    named = _h5(tmp_path / "n.h5", {"Tilt [deg]": ANG, "Vout (mV)": VOLT * 1e3})
    _same(mc.read_measurements(named, columns="angle=Tilt,voltage=Vout"), rtol=1e-12)


@pytest.mark.parametrize(
    ("datasets", "attrs", "kw", "match"),
    [({"angle_deg": ANG, "voltage_V": np.zeros((3, 4))}, {}, {},
      r"dataset voltage_V has shape 3×4; store one column of samples, shape \(n,\)"),
     ({"angle_deg": ANG, "voltage_V": np.zeros((2, 2, 2))}, {}, {}, r"has shape 2×2×2"),
     ({"angle_deg": ANG, "voltage_V": np.array([b"1.0", b"2.0"])}, {}, {},
      r"dataset voltage_V holds \|S3 values, not real numbers"),
     ({"angle_deg": ANG, "voltage_V": VOLT.astype(np.complex128)}, {}, {},
      r"holds complex128 values, not real numbers"),
     ({"angle_deg": ANG, "voltage_V": np.zeros(3, dtype=[("a", "f8"), ("b", "f8")])}, {}, {},
      r"voltage_V is a compound \(table\) dataset"),
     ({"angle_deg": ANG, "voltage_V": 1.5}, {}, {}, r"voltage_V is a scalar"),
     ({"angle_deg": ANG, "voltage_V": VOLT[:-1]}, {}, {},
      r"the columns have different lengths \(angle_deg 108, voltage_V 107\)"),
     ({"angle_deg": ANG, "voltage_V": np.full(ANG.size, np.nan)}, {}, {},
      r"sample 1 is not finite"),
     ({"angle_deg": ANG, "voltage_V": VOLT}, {"voltage_V": {"units": "mV"}}, {},
      (r"dataset 'voltage_V' \(voltage\): its units attribute says mV, its name's suffix says V; "
      r"make them agree")),
     ({"angle_deg": ANG, "Vout": VOLT}, {"Vout": {"units": "volts"}},
      {"columns": "voltage=Vout"},
      (r"dataset 'Vout' \(voltage\) has units='volts', not a voltage unit \(V, mV, uV, µV\); "
      r"give it in the mapping, e.g. --columns voltage=Vout\[V\]")),
     ({"angle_deg": ANG, "voltage_V": VOLT}, {}, {"group": "run"},
      (r"no group 'run' \(groups at the root: none\); pass the group that holds the datasets "
      r"\(CLI: --group NAME\)")),
     ({"angle_deg": ANG, "voltage_V": VOLT}, {}, {"group": "voltage_V"}, r"no group 'voltage_V'"),
     ({"angle_deg": ANG, "g/voltage_V": VOLT}, {}, {"columns": "voltage=g[V]"},
      r"dataset g is a group, not a dataset"),
     ({"x": ANG}, {}, {}, (r"missing dataset 'angle_deg' \(found: x\); the file needs datasets "
                          r"angle_deg and voltage_V"))])
def test_hostile_hdf5_files(tmp_path: Path, datasets: dict[str, Any],
                            attrs: dict[str, dict[str, Any]], kw: dict[str, Any],
                            match: str) -> None:
    path = _h5(tmp_path / "bad.h5", datasets, attrs)
    with pytest.raises(mc.MagciliaError, match=match) as info:
        mc.read_measurements(path, **kw)
    _one_line(info, path)


def test_an_empty_hdf5_recording(tmp_path: Path) -> None:
    path = _h5(tmp_path / "e.h5", {"angle_deg": np.zeros(0), "voltage_V": np.zeros(0)})
    assert read_samples(path)["voltage_V"].size == 0
    with pytest.raises(mc.MagciliaError, match=r"e\.h5 must be a recording with at least two"):
        mc.read_measurements(path)


def test_hdf5_sizes_are_checked_before_reading(tmp_path: Path,
                                               monkeypatch: pytest.MonkeyPatch) -> None:
    # contiguous, never written: declares 8 TB that the file cannot hold
    path = tmp_path / "huge.h5"
    with h5py.File(path, "w") as f:
        f["angle_deg"] = ANG
        f.create_dataset("voltage_V", shape=(10**12,), dtype="f8")
    with pytest.raises(mc.MagciliaError, match=r"voltage_V has more than MAX_SAMPLES"):
        mc.read_measurements(path)
    monkeypatch.setattr(recordings, "MAX_SAMPLES", 10**13)
    with pytest.raises(mc.MagciliaError, match=r"declares 1,000,000,000,000 values, more than "
                                                r"the file's [\d,]+ bytes can hold; the file is "
                                                r"damaged"):
        mc.read_measurements(path)
    # chunked and compressed (a fill value): bounded by MAX_SAMPLES, then by the memory limit
    path = tmp_path / "chunked.h5"
    with h5py.File(path, "w") as f:
        f["angle_deg"] = ANG
        f.create_dataset("voltage_V", shape=(2 * 10**9,), dtype="f8", chunks=(1 << 16,),
                         compression="gzip")
    monkeypatch.setattr(recordings, "MAX_SAMPLES", 10**9)
    with pytest.raises(mc.MagciliaError, match=r"dataset voltage_V has more than MAX_SAMPLES = "
                                                r"1,000,000,000 samples"):
        mc.read_measurements(path)


def test_external_links_and_non_hdf5_files(tmp_path: Path) -> None:
    other = _h5(tmp_path / "other.h5", {"voltage_V": VOLT})
    path = tmp_path / "link.h5"
    with h5py.File(path, "w") as f:
        f["angle_deg"] = ANG
        f["voltage_V"] = h5py.ExternalLink(str(other), "/voltage_V")
    with pytest.raises(mc.MagciliaError, match=r"dataset voltage_V is an external link to "
                                                r"another file; copy the data in"):
        mc.read_measurements(path)
    for content, what in ((b"", "empty"), (b"angle_deg,voltage_V\n", "no HDF5 signature")):
        bad = tmp_path / "bad.h5"
        bad.write_bytes(content)
        with pytest.raises(mc.MagciliaError, match=rf"bad\.h5: not an HDF5 file \({what}"):
            mc.read_measurements(bad)
    truncated = tmp_path / "cut.h5"
    truncated.write_bytes(other.read_bytes()[:600])
    with pytest.raises(mc.MagciliaError, match=r"cut\.h5: .*damaged") as info:
        mc.read_measurements(truncated)
    _one_line(info, truncated)


def test_hdf5_without_h5py_names_the_extra(tmp_path: Path,
                                           monkeypatch: pytest.MonkeyPatch) -> None:
    import sys

    path = _h5(tmp_path / "r.h5", {"angle_deg": ANG, "voltage_V": VOLT})
    monkeypatch.setitem(sys.modules, "h5py", None)
    with pytest.raises(MissingDependencyError, match=r"Reading HDF5 recordings needs the "
                                                      r"package 'h5py'.*magcilia\[hdf5\]"):
        mc.read_measurements(path)


# -- the other formats take the mapping too -----------------------------------------------------
def test_mat_and_tdms_are_mapped(tmp_path: Path) -> None:
    from scipy.io import savemat

    mat = tmp_path / "m.mat"
    savemat(mat, {"Tilt": ANG, "Vout_mV": VOLT * 1e3})
    _same(mc.read_measurements(mat, columns="angle=Tilt[deg],voltage=Vout_mV"), rtol=1e-12)
    with pytest.raises(mc.MagciliaError, match=r"variable 'Tilt' \(angle\) has no unit"):
        mc.read_measurements(mat, columns="angle=Tilt,voltage=Vout_mV")
    nptdms = pytest.importorskip("nptdms")
    tdms = tmp_path / "t.tdms"
    with nptdms.TdmsWriter(tdms) as writer:
        writer.write_segment([nptdms.ChannelObject("a", "Tilt", ANG),
                              nptdms.ChannelObject("a", "Vout", VOLT * 1e3),
                              nptdms.ChannelObject("b", "Vout", VOLT)])
    with pytest.raises(mc.MagciliaError, match=r"channel Vout appears in 2 groups \(a, b\); keep "
                                                r"it in one group, .* \(or pass the group\)"):
        mc.read_measurements(tdms, columns="angle=Tilt[deg],voltage=Vout[mV]")
    _same(mc.read_measurements(tdms, group="a", columns="angle=Tilt[deg],voltage=Vout[mV]"),
          rtol=1e-12)
    with pytest.raises(mc.MagciliaError, match=r"missing channel 'Tilt' \(found: Vout\)"):
        mc.read_measurements(tdms, group="b", columns="angle=Tilt[deg],voltage=Vout[V]")
    with pytest.raises(mc.MagciliaError, match=r"no group 'c' \(groups: a, b\)"):
        mc.read_measurements(tdms, group="c")


# -- progress -----------------------------------------------------------------------------------
@pytest.mark.parametrize("kind", ["fast", "careful", "hdf5"])
def test_progress_of_a_read(tmp_path: Path, monkeypatch: pytest.MonkeyPatch, kind: str) -> None:
    monkeypatch.setattr(csvfile, "CSV_BLOCK_ROWS", 16)
    if kind == "hdf5":
        path = _h5(tmp_path / "p.h5", {"angle_deg": ANG, "voltage_V": VOLT})
    else:
        path = _table(tmp_path / "p.csv", ["angle_deg", "voltage_V"], [ANG, VOLT])
        if kind == "careful":
            path.write_text("# a comment\n" + path.read_text().replace("\n0.0,", '\n"0.0",'))
    for read in (mc.read_measurements, read_samples):
        calls: list[tuple[int, int]] = []
        read(path, progress=lambda done, total, calls=calls: calls.append((done, total)))
        size = path.stat().st_size
        assert calls[-1] == (size, size)
        assert all(t == size for _, t in calls) and len(calls) >= 2
        done = [d for d, _ in calls]
        assert done == sorted(done) and 0 <= done[0] <= size
        if kind == "fast":
            assert len(calls) >= ANG.size // 16


# -- the command line ---------------------------------------------------------------------------
def test_readout_reads_mapped_hdf5_and_european_csv(tmp_path: Path,
                                                    capsys: pytest.CaptureFixture[str]) -> None:
    from magcilia.cli import main

    volts = mc.Setup.paper().output(np.radians([10.0, 30.0, 50.0]))
    h5 = _h5(tmp_path / "scope.h5", {"run3/ch1": volts * 1e3, "run3/t": [0.0, 0.1, 0.2]},
             {"run3/ch1": {"units": "mV"}})
    eu = tmp_path / "eu.csv"
    eu.write_text("Zeit [ms];U [mV]\n" + "".join(f"{100 * i};{_num(v * 1e3, ',')}\n"
                                                 for i, v in enumerate(volts)))
    runs = {h5: ["--group", "run3", "--columns", "voltage=ch1,time=t[s]"],
            eu: ["--decimal", ",", "--columns", "voltage=U,time=Zeit"]}
    for path, options in runs.items():
        out = tmp_path / f"{path.stem}-angles.csv"
        assert main(["readout", "paper", str(path), "--quantity", "angle", "--span", "0:60",
                     "--out", str(out), *options]) == 0
        assert "3/3 readings estimated" in capsys.readouterr().out
        text = out.read_text().splitlines()
        angles = [float(line.split(",")[text[0].split(",").index("angle_deg")])
                  for line in text[1:]]
        np.testing.assert_allclose(angles, [10.0, 30.0, 50.0], atol=1e-3)


@pytest.mark.parametrize(
    ("options", "match"),
    [(["--columns", "tilt=Tilt[deg]"], "magcilia: error: --columns must be ROLE=NAME[unit],..."),
     (["--columns", "voltage=Vout[deg]"], "with a voltage unit (V, mV, uV, µV)"),
     (["--decimal", ";"], "Invalid value for '--decimal'"),
     (["--columns", "voltage=Vout[mV]"], "' (header: voltage_V); map the "),
     (["--group", "run3"], "group must be left out for a CSV file")])
def test_recording_options_fail_in_one_line(tmp_path: Path, capsys: pytest.CaptureFixture[str],
                                            options: list[str], match: str) -> None:
    from magcilia.cli import main

    rec = tmp_path / "r.csv"
    rec.write_text("voltage_V\n0.001\n")
    for args in (["readout", "--setup", "paper", str(rec), "--quantity", "angle", "--span", "0:60",
                  "--csv", str(tmp_path / "o.csv")],
                 ["calibrate", str(rec), "--out", str(tmp_path / "cal")]):
        assert main([*args, *options]) == 2
        err = capsys.readouterr().err
        assert match in err and err.count("\n") == 1, err
    assert not (tmp_path / "o.csv").exists() and not (tmp_path / "cal").exists()
