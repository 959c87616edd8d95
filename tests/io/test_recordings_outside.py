"""Files reach nothing outside themselves (issue 25): a crafted file per format and reach.

HDF5 and MATLAB v7.3: a ``voltage_V`` that keeps its bytes in another file (external storage)
must not return that file's bytes; virtual datasets, filters that would load a plugin from
elsewhere and external links are refused; datasets only partly written (unallocated chunks, a
contiguous dataset never written) are refused rather than read as the fill value. TDMS: an
index file beside the recording is never read (``test_recordings_damage.py``). CSV: a row that
starts with a spreadsheet's error value is a row, and numbers follow the fast reader's grammar.
``magcilia calibrate FILE --out DIR`` on a refused file: exit 2, one line, no folder.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np
import pytest

import magcilia as mc
from magcilia.cli import main

h5py = pytest.importorskip("h5py")

ANG = np.repeat([0.0, 10.0, 20.0], 4)
VOLT = np.linspace(1e-3, 3e-3, 12)
#: what a crafted file would leak: the values of another file on the machine
SECRET = np.linspace(1.25e-3, 4.5e-3, 12)
MAT73_HEADER = (b"MATLAB 7.3 MAT-file, Platform: GLNXA64, Created on: Thu Jan  1 00:00:00 2026 "
                b"HDF5 schema 1.00 .").ljust(116) + b"\x00" * 8 + b"\x00\x02IM"


def _secret(tmp_path: Path) -> Path:
    path = tmp_path / "elsewhere" / "secret.bin"
    path.parent.mkdir()
    path.write_bytes(SECRET.tobytes())
    return path


def _voltage(kind: str, secret: Path, shape: tuple[int, ...]) -> Any:
    """A function making the ``voltage_V`` dataset of the crafted kind in a file."""
    n = int(np.prod(shape))

    def make(f: Any) -> Any:
        if kind == "external-storage":
            return f.create_dataset("voltage_V", shape=shape, dtype="f8",
                                    external=[(str(secret), 0, n * 8)])
        if kind == "virtual":
            layout = h5py.VirtualLayout(shape=shape, dtype="f8")
            layout[...] = h5py.VirtualSource(str(secret.with_suffix(".h5")), "v", shape=shape)
            return f.create_virtual_dataset("voltage_V", layout)
        if kind == "plugin-filter":
            from h5py import h5d, h5p, h5s, h5t, h5z

            dcpl = h5p.create(h5p.DATASET_CREATE)
            dcpl.set_chunk(shape)
            dcpl.set_filter(32015, h5z.FLAG_OPTIONAL, (3,))  # zstd: a plugin
            ds = h5py.Dataset(h5d.create(f.id, b"voltage_V", h5t.IEEE_F64LE,
                                         h5s.create_simple(shape), dcpl=dcpl))
            ds[...] = VOLT.reshape(shape)
            return ds
        if kind == "unwritten-chunks":
            chunks = (1, 2) if len(shape) == 2 else (2,)
            ds = f.create_dataset("voltage_V", shape=shape, dtype="f8", chunks=chunks)
            ds[(0, slice(0, 4)) if len(shape) == 2 else slice(0, 4)] = 1e-3
            return ds
        assert kind == "never-written"
        return f.create_dataset("voltage_V", shape=shape, dtype="f8")

    return make


KINDS = {"external-storage": r"keeps its values in another file \(HDF5 external storage: .*"
                             r"secret.bin\); magcilia reads only what is inside the file",
         "virtual": r"is a virtual dataset \(its values are gathered from other datasets or "
                    r"files\)",
         "plugin-filter": r"is decoded by HDF5 filter 32015 \(.*\), a plugin that magcilia does "
                          r"not load",
         "unwritten-chunks": r"was only partly written: 2 of its 6 chunks hold data \(the others "
                             r"would read as the fill value 0.0\)",
         "never-written": r"was never written \(no storage allocated"}


def _hdf5(path: Path, kind: str, secret: Path) -> Path:
    with h5py.File(path, "w") as f:
        f["angle_deg"] = ANG
        _voltage(kind, secret, (12,))(f)
    return path


def _mat73(path: Path, kind: str, secret: Path) -> Path:
    with h5py.File(path, "w", userblock_size=512) as f:
        f.create_dataset("angle_deg", data=ANG.reshape(1, -1)).attrs["MATLAB_class"] = (
            np.bytes_("double"))
        _voltage(kind, secret, (1, 12))(f).attrs["MATLAB_class"] = np.bytes_("double")
    with path.open("r+b") as f:
        f.write(MAT73_HEADER.ljust(512, b"\x00"))
    return path


@pytest.mark.parametrize("kind", sorted(KINDS))
@pytest.mark.parametrize("fmt", ["hdf5", "mat73"])
def test_a_dataset_reaching_outside_or_unwritten_is_refused(tmp_path: Path, fmt: str,
                                                            kind: str) -> None:
    secret = _secret(tmp_path)
    if kind == "virtual":
        with h5py.File(secret.with_suffix(".h5"), "w") as f:
            f["v"] = SECRET
    path = (_hdf5(tmp_path / "crafted.h5", kind, secret) if fmt == "hdf5"
            else _mat73(tmp_path / "crafted.mat", kind, secret))
    what = "dataset" if fmt == "hdf5" else "variable"
    with pytest.raises(mc.MagciliaError, match=f"{what} voltage_V " + KINDS[kind]) as info:
        mc.read_measurements(path)
    text = str(info.value)
    assert "\n" not in text and text.startswith(str(path))


def test_external_storage_never_returns_the_other_files_bytes(tmp_path: Path) -> None:
    """Read without the check, h5py would return the other file's values as volts: the reader
    refuses before a value is read, and nothing of the other file reaches the result."""
    secret = _secret(tmp_path)
    path = _hdf5(tmp_path / "leak.h5", "external-storage", secret)
    with h5py.File(path) as f:  # (the attack works on a plain h5py read)
        np.testing.assert_array_equal(f["voltage_V"][()], SECRET)
    for read in (mc.read_measurements, mc.io.read_samples):
        with pytest.raises(mc.MagciliaError, match="HDF5 external storage") as info:
            read(path)
        assert "1.25" not in str(info.value) and info.value.__cause__ is None


@pytest.mark.parametrize("kind", ["external-storage", "external-link"])
def test_calibrate_refuses_a_crafted_file_in_one_line_and_writes_nothing(
        tmp_path: Path, kind: str, capsys: pytest.CaptureFixture[str]) -> None:
    secret = _secret(tmp_path)
    path = tmp_path / "crafted.h5"
    if kind == "external-storage":
        _hdf5(path, kind, secret)
    else:
        other = tmp_path / "elsewhere" / "other.h5"
        with h5py.File(other, "w") as f:
            f["voltage_V"] = SECRET
        with h5py.File(path, "w") as f:
            f["angle_deg"] = ANG
            f["voltage_V"] = h5py.ExternalLink(str(other), "voltage_V")
    out = tmp_path / "cal"
    assert main(["calibrate", str(path), "--out", str(out), "--quiet"]) == 2
    captured = capsys.readouterr()
    lines = captured.err.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("magcilia: error: ") and str(path) in lines[0]
    assert "Traceback" not in captured.err and captured.out == ""
    assert not out.exists()
    assert sorted(p.name for p in tmp_path.iterdir()) == ["crafted.h5", "elsewhere"]


@pytest.mark.parametrize("how", ["soft-link", "soft-linked-group"])
def test_a_soft_link_through_an_external_link_is_refused(tmp_path: Path, how: str) -> None:
    """A soft link (inside the file) whose target passes through an external link: refused
    without following it (HDF5 is never asked to traverse a link to find out)."""
    other = _secret(tmp_path).with_suffix(".h5")
    with h5py.File(other, "w") as f:
        f["run/voltage_V"] = SECRET
        f["run/angle_deg"] = ANG
    path = tmp_path / "soft.h5"
    with h5py.File(path, "w") as f:
        f["elsewhere"] = h5py.ExternalLink(str(other), "/run")
        if how == "soft-link":
            f["angle_deg"] = ANG
            f["voltage_V"] = h5py.SoftLink("/elsewhere/voltage_V")
        else:
            f["run"] = h5py.SoftLink("elsewhere")
    kw = {} if how == "soft-link" else {"group": "run"}
    match = ("dataset voltage_V is an external link to another file" if how == "soft-link"
             else "the group 'run' is reached through an external link to another file")
    with pytest.raises(mc.MagciliaError, match=match):
        mc.read_measurements(path, **kw)


def test_a_whole_chunked_dataset_is_read(tmp_path: Path) -> None:
    """Chunked and compressed (gzip, shuffle, Fletcher32: built in) and written in full."""
    path = tmp_path / "whole.h5"
    with h5py.File(path, "w") as f:
        f["angle_deg"] = ANG
        f.create_dataset("voltage_V", data=VOLT, chunks=(4,), compression="gzip", shuffle=True,
                         fletcher32=True)
    np.testing.assert_allclose(mc.read_measurements(path).volts,
                               [VOLT[:4].mean(), VOLT[4:8].mean(), VOLT[8:].mean()])


# -- CSV: what the careful reader reads as a number ----------------------------------------------
@pytest.mark.parametrize(("row", "match"), [
    ("#N/A,1e-3", r"row 4, column angle_deg: '#N/A' is not a number"),
    ('"#DIV/0!",1e-3', r"row 4, column angle_deg: '#DIV/0!' is not a number"),
    ("10,1_0e-3", r"row 4, column voltage_V: '1_0e-3' is not a number"),
    ("10,\u0661\u0662", r"row 4, column voltage_V: '\u0661\u0662' is not a number")],
    ids=["na", "div0", "underscore", "arabic-digits"])
def test_careful_csv_reads_numbers_as_the_fast_reader_does(tmp_path: Path, row: str,
                                                           match: str) -> None:
    path = tmp_path / "r.csv"
    path.write_text(f"angle_deg,voltage_V\n0,1e-3\n0,2e-3\n{row}\n10,2e-3\n20,3e-3\n",
                    encoding="utf-8")
    with pytest.raises(mc.MagciliaError, match=match):
        mc.read_measurements(path)


def test_comment_lines_are_still_comments(tmp_path: Path) -> None:
    path = tmp_path / "c.csv"
    path.write_text("# bench 3\nangle_deg,voltage_V\n0,1e-3\n#note: tilt stage reset\n"
                    "# N/A below is a comment too\n10,2e-3\n", encoding="utf-8")
    assert mc.read_measurements(path).counts.tolist() == [1, 1]
