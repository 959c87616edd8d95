"""``magcilia export`` and ``mc.export`` (issue 30 item 1): recordings out to CSV, MATLAB (v5 and
v7.3), HDF5 and NetCDF; each opened by the tool a colleague uses (SciPy, h5py, xarray) and read
back by the project's own readers, samples and units equal; the metadata there; the output policy
(``--force``, atomic, nothing left behind) and the bad inputs."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import numpy as np
import pytest

import magcilia as mc
from magcilia._errors import MagciliaError, MissingDependencyError
from magcilia.cli import main
from magcilia.io import export_formats
from magcilia.io.export_data import matlab_names
from magcilia.io.export_recording import export, gather
from magcilia.io.recording_file import RecordingWriter
from magcilia.io.recordings import read_recording
from magcilia.io.setup_files import setup_to_dict

h5py = pytest.importorskip("h5py")
N = 40
RNG = np.random.default_rng(30)
ANGLES = np.repeat([0.0, 10.0, 20.0, 30.0], N // 4)
VOLTS = 0.01 + 1e-3 * np.sin(np.radians(ANGLES)) + RNG.normal(0.0, 1e-5, N)
TIMES = np.arange(N) / 1e3
SETRESET = np.tile([1.0, -1.0], N // 2)
TEMPS = 296.0 + RNG.normal(0.0, 0.01, N)
#: the readers' keys of the recording below and their units
UNITS = {"angle_deg": "deg", "voltage_V": "V", "time_s": "s", "setreset": "1",
         "temperature_K": "K"}


@pytest.fixture
def recording(tmp_path: Path) -> Path:
    """A magcilia TDMS recording cut short: a planned angle (40 deg) never reached, the setup
    stored, a temperature, set/reset marks, a further channel (``c1.x``) and an events table."""
    path = tmp_path / "run.tdms"
    setup = setup_to_dict(mc.presets.load("paper"))
    writer = RecordingWriter(path, metadata={"source": "simulated", "setup": setup,
                                             "planned_angles_deg": [0, 10, 20, 30, 40],
                                             "samples_per_angle": N // 4}, chunk=N)
    writer.write(TIMES, VOLTS, angle_deg=ANGLES, setreset=SETRESET,
                 extra={"temperature_K": TEMPS, "c1.x": np.linspace(-1e-5, 1e-5, N)})
    writer.write_group("events", {"event_time_s": [0.004, 0.02], "event_code": [1, 2]},
                       units={"event_time_s": "s"})
    assert writer.abort("stopped at angle 40: test stop")
    return path


def _samples(path: Path) -> dict[str, np.ndarray]:
    return read_recording(path, (), temperature=True).columns


# -- round trips through the project's readers ---------------------------------------------
@pytest.mark.parametrize(("name", "version"), [("out.csv", None), ("out.mat", "5"),
                                               ("out.mat", "7.3"), ("out.h5", None)],
                         ids=["csv", "mat5", "mat73", "h5"])
def test_round_trip_gives_the_same_samples_and_units(recording: Path, tmp_path: Path, name: str,
                                                     version: str | None) -> None:
    out = tmp_path / name
    written = export(recording, out, mat_version=version)
    back = _samples(out)
    assert set(back) == set(UNITS)
    for key, values in _samples(recording).items():
        np.testing.assert_array_equal(back[key], values, err_msg=key)  # bit for bit
    assert {k: written.units[k] for k in UNITS} == UNITS
    assert written.samples == N
    assert sorted(p.name for p in tmp_path.iterdir()) == sorted(["run.tdms", name])


def test_every_channel_goes_out_with_its_unit(recording: Path) -> None:
    data = gather(recording)
    assert list(data.columns) == [*UNITS, "c1.x"]
    assert data.units["c1.x"] == ""  # the file names no unit for it
    assert data.tables["events"]["event_code"].tolist() == [1.0, 2.0]
    assert data.table_units["events"] == {"event_time_s": "s", "event_code": ""}
    assert data.setup() == setup_to_dict(mc.presets.load("paper"))
    assert any("incomplete" in n and "40 deg" in n for n in data.metadata["notes"])
    assert data.metadata["state"]["complete"] is False


# -- the tools a colleague uses -------------------------------------------------------------------
def test_mat_v5_opens_in_scipy_with_units_and_metadata(recording: Path, tmp_path: Path) -> None:
    from scipy.io import loadmat

    out = tmp_path / "run.mat"
    export(recording, out)
    assert out.read_bytes()[:10] == b"MATLAB 5.0"
    mat = loadmat(out, simplify_cells=True)
    np.testing.assert_array_equal(mat["voltage_V"], VOLTS)
    np.testing.assert_array_equal(mat["angle_deg"], ANGLES)
    assert mat["c1_x"].shape == (N,)  # ``c1.x`` is no MATLAB name
    assert mat["units"]["voltage_V"] == "V" and mat["units"]["temperature_K"] == "K"
    meta = mat["metadata"]
    assert json.loads(meta["setup"])["cilium"]["height"] == "3.2613 mm"
    assert "incomplete" in meta["notes"]
    assert json.loads(meta["renamed"]) == {"c1.x": "c1_x"}
    assert mat["tables"]["events"]["units"]["event_time_s"] == "s"
    np.testing.assert_array_equal(mat["tables"]["events"]["event_time_s"], [0.004, 0.02])


def _mat_text(dset: Any) -> str:
    assert dset.attrs["MATLAB_class"] == b"char"
    return bytes(np.asarray(dset[()], dtype="<u2").ravel().tobytes()).decode("utf-16-le")


def test_mat_v73_opens_in_h5py_as_matlab_writes_it(recording: Path, tmp_path: Path) -> None:
    out = tmp_path / "run.mat"
    export(recording, out, mat_version="7.3")
    head = out.read_bytes()[:128]
    assert head.startswith(b"MATLAB 7.3 MAT-file")
    assert head[124:128] == b"\x00\x02IM"  # version 0x0200, little-endian mark
    with h5py.File(out, "r") as f:
        assert f.userblock_size == 512
        volts = f["voltage_V"]
        assert volts.attrs["MATLAB_class"] == b"double"
        assert volts.shape == (1, N)  # MATLAB's N×1 column, dimensions reversed
        np.testing.assert_array_equal(volts[0], VOLTS)
        np.testing.assert_array_equal(f["setreset"][0], SETRESET)
        units = f["units"]
        assert units.attrs["MATLAB_class"] == b"struct"
        assert [bytes(x).decode() for x in units.attrs["MATLAB_fields"]][:2] == ["angle_deg",
                                                                                 "voltage_V"]
        assert _mat_text(units["voltage_V"]) == "V"
        assert json.loads(_mat_text(f["metadata"]["setup"]))["sensor"]["preset"] == "HMC1021Z"
        assert f["units"]["c1_x"].attrs["MATLAB_empty"] == 1  # '' (no unit known)
        np.testing.assert_array_equal(f["tables"]["events"]["event_code"][0], [1.0, 2.0])


def test_hdf5_datasets_carry_units_and_the_metadata(recording: Path, tmp_path: Path) -> None:
    out = tmp_path / "run.h5"
    export(recording, out)
    with h5py.File(out, "r") as f:
        assert {k: f[k].attrs.get("units") for k in UNITS} == UNITS
        np.testing.assert_array_equal(f["temperature_K"][()], TEMPS)
        assert json.loads(f.attrs["setup"])["sensor"]["preset"] == "HMC1021Z"
        assert json.loads(f.attrs["state"])["stopped"] == "stopped at angle 40: test stop"
        assert "incomplete" in f.attrs["notes"]
        assert f["events"]["event_time_s"].attrs["units"] == "s"


def test_netcdf_opens_in_xarray_with_units(recording: Path, tmp_path: Path) -> None:
    xr = pytest.importorskip("xarray")
    pytest.importorskip("h5netcdf")
    out = tmp_path / "run.nc"
    export(recording, out)
    with xr.open_dataset(out, engine="h5netcdf") as ds:
        assert ds["voltage_V"].dims == ("sample",)
        np.testing.assert_array_equal(ds["time_s"].values, TIMES)  # the coordinate
        assert "time_s" in ds.coords
        np.testing.assert_array_equal(ds["voltage_V"].values, VOLTS)
        assert {k: ds[k].attrs.get("units") for k in UNITS} == UNITS
        assert json.loads(ds.attrs["setup"])["cilium"]["base_radius"] == "0.1801 mm"
        assert "incomplete" in ds.attrs["notes"]
    with xr.open_dataset(out, engine="h5netcdf", group="events") as events:
        assert events["event_time_s"].attrs["units"] == "s"
        np.testing.assert_array_equal(events["event_code"].values, [1.0, 2.0])


def test_csv_names_units_in_the_header_and_keeps_the_metadata(recording: Path,
                                                              tmp_path: Path) -> None:
    out = tmp_path / "run.csv"
    export(recording, out)
    lines = out.read_text(encoding="utf-8").splitlines()
    meta = json.loads(lines[0].removeprefix("# magcilia-export: "))
    table = json.loads(lines[1].removeprefix("# magcilia-table: "))
    assert lines[2:4] == ["# events: 0.004,1.0", "# events: 0.02,2.0"]
    assert lines[4] == "angle_deg,voltage_V,time_s,setreset,temperature_K,c1.x"
    assert lines[5].split(",")[3] == "1" and lines[6].split(",")[3] == "-1"
    assert meta["units"]["voltage_V"] == "V"
    assert meta["properties"]["setup"]["sensor"]["preset"] == "HMC1021Z"
    assert table == {"table": "events", "columns": ["event_time_s", "event_code"], "rows": 2,
                     "units": {"event_time_s": "s", "event_code": ""}}


def test_other_formats_in_and_a_mapped_csv(tmp_path: Path) -> None:
    """A lab's CSV in mV with its own names goes out in the readers' names and SI."""
    src = tmp_path / "lab.csv"
    src.write_text("Tilt,Vout [mV]\n" + "".join(f"{float(a)!r},{float(v) * 1e3!r}\n"
                                                 for a, v in zip(ANGLES, VOLTS, strict=True)))
    with pytest.raises(MagciliaError, match="Vout"):  # a name mapped must be there
        export(src, tmp_path / "lab.h5", columns={"angle": "Tilt[deg]", "voltage": "Vout2"})
    data = export(src, tmp_path / "lab.h5", columns={"angle": "Tilt[deg]", "voltage": "Vout"})
    assert data.units == {"angle_deg": "deg", "voltage_V": "V"}
    np.testing.assert_allclose(_samples(tmp_path / "lab.h5")["voltage_V"], VOLTS, rtol=1e-15)
    export(tmp_path / "lab.h5", tmp_path / "again.mat")  # an export is a recording again
    np.testing.assert_allclose(_samples(tmp_path / "again.mat")["voltage_V"], VOLTS, rtol=1e-15)


@pytest.mark.parametrize("suffix", [".mat", ".h5", ".csv"])
def test_a_coil_recording_of_a_3_axis_sensor_round_trips(tmp_path: Path, suffix: str) -> None:
    """The applied field (``actuation_*_T``) and the measured field (``field_*_T``), in T."""
    keys = ("actuation_x_T", "actuation_y_T", "actuation_z_T", "field_x_T", "field_y_T",
            "field_z_T")
    values = np.column_stack([np.repeat([0.0, 1e-3], 6), np.zeros(12), np.repeat([0.0, -2e-3], 6),
                              RNG.normal(0.0, 1e-6, (12, 3)) + [3e-5, 1e-5, 4e-5]])
    src = tmp_path / "coil.csv"
    src.write_text(",".join(keys) + "\n" + "".join(",".join(repr(float(x)) for x in row) + "\n"
                                                   for row in values))
    written = export(src, tmp_path / f"out{suffix}")
    assert written.units == dict.fromkeys(keys, "T")
    back = _samples(tmp_path / f"out{suffix}")
    for j, key in enumerate(keys):
        np.testing.assert_array_equal(back[key], values[:, j], err_msg=key)


def test_large_numbers_go_to_mat_v73(recording: Path, tmp_path: Path,
                                     monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(export_formats, "MAT_V5_LIMIT", 100)  # bytes: this recording is above
    export(recording, tmp_path / "big.mat")
    assert (tmp_path / "big.mat").read_bytes().startswith(b"MATLAB 7.3 MAT-file")
    export(recording, tmp_path / "small.mat", mat_version="5")
    assert (tmp_path / "small.mat").read_bytes().startswith(b"MATLAB 5.0")


def test_matlab_names() -> None:
    assert matlab_names(["c1.x", "c1_x", "1st", "voltage_V"]) == {
        "c1.x": "c1_x", "c1_x": "c1_x_2", "1st": "x_1st", "voltage_V": "voltage_V"}


# -- the output policy and bad input (CLI) ------------------------------------------------------
def test_existing_output_is_kept_byte_identical_without_force(
        recording: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    out = tmp_path / "run.mat"
    out.write_bytes(b"a colleague's file")
    assert main(["export", str(recording), "--out", str(out)]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "exists; pass --force to replace it" in err
    assert out.read_bytes() == b"a colleague's file"
    assert main(["export", str(recording), "--out", str(out), "--force"]) == 0
    printed = capsys.readouterr().out
    assert printed.startswith(f"wrote {out} ({N} samples; channels angle_deg [deg], voltage_V "
                              "[V], time_s [s], setreset [1], temperature_K [K], c1.x; tables "
                              "events)\nnote: the recording is incomplete")
    assert _samples(out)["voltage_V"].tolist() == VOLTS.tolist()
    assert sorted(p.name for p in tmp_path.iterdir()) == ["run.mat", "run.tdms"]


def test_the_recording_itself_is_never_the_output(recording: Path,
                                                  capsys: pytest.CaptureFixture[str]) -> None:
    before = recording.read_bytes()
    assert main(["export", str(recording), "--to", "h5", "--out", str(recording),
                 "--force"]) == 2
    assert "is the input of RECORDING; an input is never replaced" in capsys.readouterr().err
    assert recording.read_bytes() == before


def test_a_failed_write_leaves_no_file(recording: Path, tmp_path: Path,
                                       monkeypatch: pytest.MonkeyPatch) -> None:
    old = tmp_path / "old.h5"
    old.write_bytes(b"old")

    def broken(data: Any, path: Path) -> None:
        path.write_bytes(b"half")
        raise OSError(28, "No space left on device")

    writer = export_formats.WRITERS["h5"]
    monkeypatch.setitem(export_formats.WRITERS, "h5",
                        export_formats.Writer(broken, writer.check, hdf5=True))
    with pytest.raises(MagciliaError, match=r"cannot write .*No space left"):
        export(recording, old, overwrite=True)
    with pytest.raises(MagciliaError, match="cannot write"):
        export(recording, tmp_path / "new.h5")
    assert old.read_bytes() == b"old"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["old.h5", "run.tdms"]


def test_an_unwritable_output_fails_before_the_recording_is_read(
        recording: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    import magcilia.io.export_recording as export_module

    def no_read(*args: Any, **kwargs: Any) -> None:
        raise AssertionError("the recording was read")

    monkeypatch.setattr(export_module, "read_recording", no_read)
    with pytest.raises(MagciliaError, match=r"run\.tdms is a file, not a folder"):
        export(recording, tmp_path / "run.tdms" / "sub" / "x.csv")
    (tmp_path / "old.csv").write_text("old")
    with pytest.raises(MagciliaError, match="exists; pass --force"):
        export(recording, tmp_path / "old.csv")
    monkeypatch.setattr(export_module.os, "access", lambda *a: False)  # (root writes anywhere)
    with pytest.raises(MagciliaError, match="Permission denied"):
        export(recording, tmp_path / "new" / "x.csv")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["old.csv", "run.tdms"]


@pytest.mark.parametrize(("args", "message"), [
    (["--to", "parquet"], "Invalid value for '--to'"),
    (["--out", "{tmp}/run.xlsx"], "output suffix must be one of .csv, .mat, .h5"),
    (["--to", "csv", "--mat-version", "7.3"], "mat_version must be left out"),
    (["--out", "{tmp}/run.tdms/x.csv"], "is a file, not a folder"),
    (["--out", "{tmp}"], "is a directory"),
], ids=["format", "suffix", "mat-version", "unwritable", "folder"])
def test_bad_output_is_one_line(recording: Path, tmp_path: Path, args: list[str], message: str,
                                capsys: pytest.CaptureFixture[str]) -> None:
    argv = ["export", str(recording), *[a.format(tmp=tmp_path) for a in args]]
    if "--out" not in argv:
        argv += ["--out", str(tmp_path / "x.csv")]
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert err.startswith("magcilia: error: ") and err.count("\n") == 1 and message in err
    assert sorted(p.name for p in tmp_path.iterdir()) == ["run.tdms"]


def test_a_setup_given_as_recording_is_refused(tmp_path: Path,
                                               capsys: pytest.CaptureFixture[str]) -> None:
    setup = tmp_path / "paper.toml"
    mc.save_setup(mc.presets.load("paper"), setup)
    assert main(["export", str(setup), "--out", str(tmp_path / "x.csv")]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "paper.toml" in err and ".toml" in err
    assert not (tmp_path / "x.csv").exists()


def test_cli_json(recording: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["export", str(recording), "--out", str(tmp_path / "r.hdf5"), "--json"]) == 0
    doc = json.loads(capsys.readouterr().out)
    assert doc["format"] == "h5" and doc["samples"] == N and doc["units"]["voltage_V"] == "V"
    assert doc["tables"] == {"events": {"event_time_s": "s", "event_code": ""}}
    assert doc["metadata"]["properties"]["setup"]["sensor"]["preset"] == "HMC1021Z"


# -- xarray views ---------------------------------------------------------------------------------
def test_measurement_to_xarray(recording: Path) -> None:
    pytest.importorskip("xarray")
    m = mc.read_measurements(recording)
    ds = m.to_xarray()
    assert ds["output_V"].dims == ("condition",)
    np.testing.assert_array_equal(ds["angle_rad"].values, m.angles)
    assert "angle_rad" in ds.coords and "azimuth_rad" in ds.coords
    assert ds["output_V"].attrs["units"] == "V" and ds["angle_rad"].attrs["units"] == "rad"
    np.testing.assert_array_equal(ds["count"].values, m.counts)
    assert "incomplete" in ds.attrs["notes"] and ds.attrs["set_reset"] == 1
    assert json.loads(ds.attrs["metadata"])["recording"]["complete"] is False


def test_load_measurement_to_xarray_has_the_load_as_coordinate(tmp_path: Path) -> None:
    pytest.importorskip("xarray")
    forces = np.repeat([0.0, 1e-4, 2e-4], 5)
    src = tmp_path / "loads.csv"
    src.write_text("force_N,voltage_V\n" + "".join(
        f"{float(f)!r},{0.01 + 10 * float(f) + 1e-6 * (i % 2)!r}\n"
        for i, f in enumerate(forces)))
    ds = mc.read_measurements(src).to_xarray()
    assert "force_N" in ds.coords and ds["force_N"].attrs["units"] == "N"
    np.testing.assert_allclose(ds["force_N"].values, [0.0, 1e-4, 2e-4])


def test_without_xarray_one_line_names_the_extra(recording: Path, tmp_path: Path,
                                                 monkeypatch: pytest.MonkeyPatch) -> None:
    import sys

    monkeypatch.setitem(sys.modules, "xarray", None)  # import xarray -> ImportError
    m = mc.read_measurements(recording)
    with pytest.raises(MissingDependencyError, match=r"pip install 'magcilia\[export\]'"):
        m.to_xarray()
    with pytest.raises(MissingDependencyError, match="Exporting to NetCDF"):
        export(recording, tmp_path / "run.nc")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["run.tdms"]
