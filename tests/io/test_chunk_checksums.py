"""CRC-32 checksums of magcilia's own recordings (issue 25, "no value change without a note"):
every flushed chunk of every channel of group ``recording`` carries the CRC-32 of its raw data,
so that a byte changed in place is found, named by chunk and samples: an error for a file that
says it is complete, a note for one cut short. Chunks that are missing or out of order are found
too; a killed recording's whole chunks verify; files without checksums read as before.

The references are independent of the reader: npTDMS's own chunk-by-chunk reading and
``zlib.crc32`` of the bytes it returns, and byte offsets found by searching the file for a
sample's bytes.
"""

from __future__ import annotations

import zlib
from pathlib import Path

import numpy as np
import pytest

import magcilia as mc
from magcilia.io import RecordingWriter, chunk_checksums
from magcilia.io.recordings import read_recording
from magcilia.io.tdmsfile import segments

nptdms = pytest.importorskip("nptdms")

CHUNK = 50


def _columns(n: int = 230) -> dict[str, np.ndarray]:
    rng = np.random.default_rng(31)
    angle = np.repeat([0.0, 10.0, 20.0, 30.0, 40.0], -(-n // 5))[:n]
    return {"time_s": np.arange(n) / 1e3 + 0.5, "volts": 1e-3 * angle + rng.normal(0, 1e-5, n),
            "angle_deg": angle, "setreset": rng.choice([1.0, -1.0], n),
            "temperature_C": 21.0 + rng.normal(0, 0.01, n)}


def _record(path: Path, *, close: bool = True, n: int = 230) -> dict[str, np.ndarray]:
    """A recording as the writer makes one (three writes, a further group); left open (cut
    short: ``complete`` False, every chunk flushed) with ``close=False``."""
    cols = _columns(n)
    rec = RecordingWriter(path, metadata={"source": "test"}, chunk=CHUNK, flush_interval=None)
    for part in (slice(0, 70), slice(70, 71), slice(71, n)):
        rec.write(cols["time_s"][part], cols["volts"][part], angle_deg=cols["angle_deg"][part],
                  setreset=cols["setreset"][part],
                  extra={"temperature_C": cols["temperature_C"][part]})
    rec.write_group("readout", {"readout_time_s": [0.1, 0.2], "value": [1.0, 2.0]})
    if close:
        rec.close()
    else:
        rec._flush_pending()  # the last samples on disk; never closed (a kill after a flush)
        assert rec._file is not None
        rec._file.close()
    return cols


def test_the_rows_are_crc32_of_the_chunks_as_nptdms_reads_them(tmp_path: Path) -> None:
    path = tmp_path / "r.tdms"
    _record(path)
    with nptdms.TdmsFile.open(path) as tdms:
        assert tdms.properties["checksums"] == "crc32"
        layout = tdms["checksums"]["chunks"].properties["layout"].split(",")
        expected, first = [], 0
        for chunk in tdms.data_chunks():
            if "recording" not in [g.name for g in chunk.groups()]:
                continue
            data = [chunk["recording"][name.removeprefix("crc32:")][:] for name in layout[2:]]
            expected.append([first, data[0].size,
                             *(zlib.crc32(np.ascontiguousarray(d).tobytes()) for d in data)])
            first += data[0].size
        rows = tdms["checksums"]["chunks"][:].reshape(-1, len(layout))
    assert layout[:2] == ["first_sample", "samples"] and len(layout) == 7
    assert rows.tolist() == expected and rows[:, 1].tolist() == [0, 50, 50, 50, 50, 30]
    assert not read_recording(path).notes


def _flip_in_chunk(path: Path, stored: np.ndarray, out: Path) -> None:
    """``path`` with one bit changed in the raw bytes of a channel's chunk (the bytes of
    ``stored``, the chunk's values as written, found once in the file)."""
    data = bytearray(path.read_bytes())
    pattern = np.ascontiguousarray(stored).tobytes()
    at = data.find(pattern)
    assert at > 0 and data.find(pattern, at + 1) < 0
    data[at + len(pattern) // 2] ^= 0x04
    out.write_bytes(bytes(data))


@pytest.mark.parametrize("channel", ["time_s", "voltage_V", "angle_deg", "setreset",
                                     "temperature_C"])
@pytest.mark.parametrize("complete", [True, False], ids=["complete", "cut-short"])
def test_a_byte_of_raw_data_changed_in_place_is_found(tmp_path: Path, channel: str,
                                                      complete: bool) -> None:
    path = tmp_path / "r.tdms"
    cols = _record(path, close=complete)
    values = cols[{"voltage_V": "volts"}.get(channel, channel)][150:200]
    bad = tmp_path / "bad.tdms"
    _flip_in_chunk(path, values.astype(np.int8) if channel == "setreset" else values, bad)
    chunk = (f"the chunk of samples 151–200 (chunk 4 of 5) of channel {channel} does not "
             "match its CRC-32")
    if channel == "temperature_C":  # a channel that no reader asks for is neither read nor
        assert not read_recording(bad).notes  # verified
        return
    if complete:
        with pytest.raises(mc.MagciliaError) as info:
            read_recording(bad, required=("voltage_V",))
        message = str(info.value)
        assert message.startswith(f"{bad}: the file says it is complete, but {chunk}"), message
        assert "\n" not in message
        return
    raw = read_recording(bad)
    assert [n for n in raw.notes if n.startswith(chunk)], raw.notes
    m = mc.read_measurements(bad, saturation="keep", nan_policy="omit")
    assert [n for n in m.notes() if n.startswith(chunk)], m.notes()


def _data_segments(path: Path) -> list[tuple[int, int]]:
    with path.open("rb") as f:
        found, problems = segments(f, path.stat().st_size)
    assert not problems
    return [(s.position, s.end) for s in found if s.end is not None and s.end > s.data]


@pytest.mark.parametrize("how", ["swapped", "deleted", "repeated"])
@pytest.mark.parametrize("complete", [True, False], ids=["complete", "cut-short"])
def test_chunks_missing_repeated_or_out_of_order_are_found(tmp_path: Path, how: str,
                                                           complete: bool) -> None:
    """Whole segments moved keep the chain of lead-ins sound and read as samples; the rows'
    first samples tell."""
    path = tmp_path / "r.tdms"
    _record(path, close=complete)
    data = path.read_bytes()
    (a, b), (c, d) = _data_segments(path)[2:4]  # chunks 2 and 3: 50 samples each
    assert b - a == d - c and b == c
    moved = {"swapped": data[:a] + data[c:d] + data[a:b] + data[d:],
             "deleted": data[:a] + data[c:],
             "repeated": data[:c] + data[a:b] + data[c:]}[how]
    bad = tmp_path / "bad.tdms"
    bad.write_bytes(moved)
    due = {"swapped": "chunk 2 of 5 starts at sample 101 by its checksums, where sample 51 is due",
           "deleted": "chunk 2 of 4 starts at sample 101 by its checksums, where sample 51 is due",
           "repeated": "chunk 3 of 6 starts at sample 51 by its checksums, where sample 101 is "
                       "due"}[how]
    if complete:
        with pytest.raises(mc.MagciliaError, match="the file says it is complete, but "):
            read_recording(bad)
        return
    notes = read_recording(bad).notes
    assert [n for n in notes if n.startswith(due)], notes


def test_every_whole_chunk_of_a_file_cut_inside_its_last_segment_verifies(tmp_path: Path
                                                                           ) -> None:
    """A kill inside a segment's write leaves the chunk without its row: the whole chunks
    verify, the cut segment is said (as before), no chunk is called damaged."""
    path = tmp_path / "r.tdms"
    _record(path, close=False)
    data = path.read_bytes()
    last = _data_segments(path)[-1]
    for cut in range(last[0] + 30, last[1], 97):
        (tmp_path / "c.tdms").write_bytes(data[:cut])
        raw = read_recording(tmp_path / "c.tdms")
        assert not [n for n in raw.notes if "CRC" in n or "checksum" in n], (cut, raw.notes)
        assert any("it was cut" in n for n in raw.notes)
        assert raw.columns["voltage_V"].size >= 200


def test_rows_read_from_the_segments_ends_or_by_nptdms_agree(tmp_path: Path) -> None:
    """A segment holding only a further group's values (values written after the last samples)
    makes the reader ask npTDMS for the rows; both ways read the same rows."""
    from magcilia.io.tdmsfile import _row_tails

    path = tmp_path / "r.tdms"
    rec = RecordingWriter(path, chunk=CHUNK, flush_interval=None)
    rec.write(np.arange(120.0), np.arange(120.0) * 1e-4, angle_deg=np.repeat([0.0, 9.0], 60))
    rec.close()
    late = tmp_path / "late.tdms"
    rec = RecordingWriter(late, chunk=CHUNK, flush_interval=None)
    rec.write(np.arange(120.0), np.arange(120.0) * 1e-4, angle_deg=np.repeat([0.0, 9.0], 60))
    rec._flush_pending()
    rec.write_group("events", {"event_time_s": [1.0]})
    rec.close()
    for p, tails in ((path, True), (late, False)):
        with p.open("rb") as f, nptdms.TdmsFile.open(f) as tdms:
            channel = tdms["checksums"]["chunks"]
            found, _ = segments(f, p.stat().st_size)
            rows = _row_tails(f, p.stat().st_size, found, 5, len(channel))
            assert (rows is not None) == tails
            if rows is not None:
                assert rows.tolist() == channel[:].tolist()
        assert not read_recording(p).notes


def test_files_without_checksums_read_as_before(tmp_path: Path) -> None:
    """An earlier magcilia recording (no ``checksums`` property) is read chunk by chunk as
    before; a file that says it has checksums but lacks them is damaged."""
    path = tmp_path / "r.tdms"
    _record(path)
    with nptdms.TdmsFile.open(path) as tdms:
        props = {k: v for k, v in tdms.properties.items() if k != "checksums"}
        cols = {c.name: c[:] for c in tdms["recording"].channels()}
    for name, say in (("earlier.tdms", False), ("lost.tdms", True)):
        with nptdms.TdmsWriter(tmp_path / name) as writer:
            writer.write_segment([nptdms.RootObject({**props, "complete": False,
                                                     **({"checksums": "crc32"} if say else {})})])
            for a in range(0, 230, CHUNK):
                writer.write_segment([nptdms.ChannelObject("recording", k, v[a:a + CHUNK])
                                      for k, v in cols.items()])
            writer.write_segment([nptdms.RootObject({"complete": True, "samples": 230})])
        if say:
            with pytest.raises(mc.MagciliaError, match="the chunks' checksums are missing"):
                read_recording(tmp_path / name)
        else:
            raw = read_recording(tmp_path / name)
            assert not raw.notes and raw.columns["voltage_V"].tolist() == cols["voltage_V"].tolist()


@pytest.mark.parametrize(("layout", "values", "found"), [
    ("first_sample,samples,crc32:v", np.array([0, 2, 0], np.uint64), "does not match"),
    ("first,samples,crc32:v", np.array([0, 2, 0], np.uint64), "layout property is damaged"),
    (None, np.array([0, 2, 0], np.uint64), "layout property is damaged"),
    ("first_sample,samples,crc32:v", np.array([0, 2, 0], np.float64), "type is damaged"),
    ("first_sample,samples,crc32:v", np.array([0, 1, 0, 1], np.uint64), "partial row"),
    ("first_sample,samples,crc32:w", np.array([0, 2, 0], np.uint64), "v has no checksums"),
    ("first_sample,samples,crc32:v", np.array([0, 3, 0], np.uint64), "cover 3"),
])
def test_what_damaged_checksums_say(layout: str | None, values: np.ndarray, found: str) -> None:
    problems = chunk_checksums.verify_chunks(values, layout, {"v": np.array([1.0, 2.0])},
                                             cut=False)
    assert len(problems) >= 1 and found in problems[0], problems
    good = np.array([0, 2, zlib.crc32(np.array([1.0, 2.0]).tobytes())], np.uint64)
    assert chunk_checksums.verify_chunks(good, "first_sample,samples,crc32:v",
                                         {"v": np.array([1.0, 2.0])}, cut=False) == []
    assert chunk_checksums.verify_chunks(good, "first_sample,samples,crc32:v",
                                         {"v": np.array([1.0, 2.0, 3.0])}, cut=False) == [
        "the last 1 value(s) of channel v are in no checksummed chunk"]


def test_checksums_are_verified_where_damage_hid_whose_file_it_is(tmp_path: Path) -> None:
    """Bits flipped in the root properties' names (``magcilia_version``, ``checksums``: found by
    the fuzz) make the file look like another program's; its rows are still verified."""
    path = tmp_path / "r.tdms"
    cols = _record(path, close=False)
    hidden = tmp_path / "hidden.tdms"
    hidden.write_bytes(path.read_bytes().replace(b"magcilia_version", b"magcilia_Version")
                       .replace(b"\x09\x00\x00\x00checksums", b"\x09\x00\x00\x00checksumz"))
    assert b"checksumz" in hidden.read_bytes()
    raw = read_recording(hidden)
    assert not raw.state.own and not raw.notes
    bad = tmp_path / "bad.tdms"
    _flip_in_chunk(hidden, cols["volts"][50:100], bad)
    assert [n for n in read_recording(bad).notes
            if n.startswith("the chunk of samples 51–100 (chunk 2 of 5) of channel voltage_V")]
