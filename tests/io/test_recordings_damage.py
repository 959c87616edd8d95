"""Damage is reported, not absorbed (issue 25): damaged TDMS files and recordings cut short.

Each kind of damage the issue measured is crafted here with npTDMS directly (no dependence on the
record command): a truncated segment and its metadata, a flipped byte-order or interleaving bit in
a table of contents, a next-segment offset off by one, segment versions that differ, data the
table of contents does not announce, a channel length that cuts a chunk in two, a closing sample
count that disagrees, and a sweep that lacks planned angles or holds unplanned ones. A file that
says it is complete is refused in one line; another program's file, or a recording cut short, is
read with a note (and the measurement says it). A recording cut before its first chunk says so
in every reader.
"""

from __future__ import annotations

import json
import logging
import re
import struct
from pathlib import Path
from typing import Any

import numpy as np
import pytest

import magcilia as mc
from magcilia.io.recordings import read_recording, read_samples
from magcilia.io.tdmsfile import segments

nptdms = pytest.importorskip("nptdms")

PLANNED = [0.0, 10.0, 20.0, 30.0, 40.0, 50.0]
PER = 8


def _sweep(angles: list[float], per: int = PER) -> dict[str, np.ndarray]:
    angle = np.repeat(np.asarray(angles, dtype=np.float64), per)
    rng = np.random.default_rng(7)
    volts = 3e-3 * np.sin(np.radians(angle)) + 1e-4 + rng.normal(0.0, 1e-5, angle.size)
    return {"time_s": np.arange(angle.size) * 1e-3, "voltage_V": volts, "angle_deg": angle}


def _recording(path: Path, columns: dict[str, np.ndarray] | None = None, *,
               complete: bool | None = True, chunk: int = PER, planned: list[float] | None = None,
               samples: int | None = None, own: bool = True, group: str = "recording",
               declare: bool = True, stopped: str | None = None) -> Path:
    """A recording as magcilia writes one: a first segment with the properties (complete=False),
    one segment per chunk of every channel, and a closing segment with ``complete`` and the
    sample count (left out with ``complete=None``: a file killed before closing)."""
    props: dict[str, Any] = {"complete": False} if complete is not None or own else {}
    if own:
        props["magcilia_version"] = "0.test"
        props["samples_per_angle"] = PER
        props["planned_angles_deg"] = json.dumps(PLANNED if planned is None else planned)
    with path.open("wb") as f, nptdms.TdmsWriter(f) as writer:
        writer.write_segment([nptdms.RootObject(props), nptdms.GroupObject(group)])
        if columns is not None:
            if declare:
                writer.write_segment([nptdms.ChannelObject(group, k, np.zeros(0))
                                      for k in columns])
            n = next(iter(columns.values())).size
            for start in range(0, n, chunk):
                writer.write_segment([nptdms.ChannelObject(group, k, a[start:start + chunk])
                                      for k, a in columns.items()])
        if complete is not None:
            close: dict[str, Any] = {"complete": complete,
                                     "samples": (0 if columns is None else
                                                 next(iter(columns.values())).size)
                                     if samples is None else samples}
            if stopped:
                close["stopped"] = stopped
            writer.write_segment([nptdms.RootObject(close)])
    return path


def _one_line(info: pytest.ExceptionInfo[Any], path: Path) -> str:
    text = str(info.value)
    assert "\n" not in text and str(path) in text
    return text


def _lead_ins(path: Path) -> list[int]:
    with path.open("rb") as f:
        found, problems = segments(f, path.stat().st_size)
    assert not problems
    return [s.position for s in found]


def test_a_sound_recording_reads_without_notes(tmp_path: Path) -> None:
    path = _recording(tmp_path / "ok.tdms", _sweep(PLANNED))
    m = mc.read_measurements(path)
    assert len(m) == 6 and m.notes() == []
    assert m.metadata["recording"]["complete"] is True
    assert m.metadata["recording"]["missing_angles_deg"] == []
    np.testing.assert_allclose(m.angles_deg, PLANNED)


# -- recordings cut short -----------------------------------------------------------------------
@pytest.mark.parametrize("declared", [False, True], ids=["no-channels", "empty-channels"])
def test_a_recording_cut_before_its_first_chunk_says_so_in_every_reader(
        tmp_path: Path, declared: bool) -> None:
    path = _recording(tmp_path / "cut.tdms", _sweep([])if declared else None, complete=None,
                      declare=declared)
    for read in (mc.read_measurements, read_samples, read_recording):
        with pytest.raises(mc.MagciliaError, match="the recording was cut before its first "
                                                   r"chunk \(complete=False, no samples on "
                                                   r"disk\); record again") as info:
            read(path)
        _one_line(info, path)
    with pytest.raises(mc.MagciliaError, match="cut before its first chunk"):
        read_samples(path, required=("voltage_V",))  # (as readout reads)


def test_a_sweep_cut_short_is_read_and_said_incomplete(tmp_path: Path) -> None:
    """Killed after 3 of 6 planned angles (and inside the 4th angle's chunk): the whole samples
    are read, the measurement says it is incomplete and which planned angles are missing."""
    full = _recording(tmp_path / "full.tdms", _sweep(PLANNED[:4]), complete=None)
    data = full.read_bytes()
    cut = tmp_path / "cut.tdms"
    cut.write_bytes(data[:len(data) - 20])  # inside the last chunk's data
    m = mc.read_measurements(cut)
    np.testing.assert_allclose(m.angles_deg, PLANNED[:4])
    assert m.counts.tolist()[:3] == [PER] * 3
    notes = m.notes()
    assert any(n.startswith("the recording is incomplete (complete=False: it was cut short); "
                            "4 of 6 planned angles recorded, missing 40, 50 deg") for n in notes)
    assert any("the last segment" in n for n in notes)  # where the kill fell
    assert m.metadata["recording"]["missing_angles_deg"] == [40.0, 50.0]
    assert "note: the recording is incomplete" in m.report()


def test_a_stopped_sweep_says_where(tmp_path: Path) -> None:
    path = _recording(tmp_path / "stopped.tdms", _sweep(PLANNED[:2]), complete=False,
                      stopped="stopped at angle 3 (20 deg): interrupted")
    (note,) = mc.read_measurements(path).notes()
    assert note == ("the recording is incomplete (complete=False: it was cut short; stopped at "
                    "angle 3 (20 deg): interrupted); 2 of 6 planned angles recorded, missing 20, "
                    "30, 40, 50 deg")


# -- a file that says it is complete must hold what it planned -----------------------------------
@pytest.mark.parametrize(
    ("angles", "match"),
    [(PLANNED[:5], r"1 planned angle\(s\) are missing \(50 deg\)"),
     ([*PLANNED, 60.0], r"1 recorded angle\(s\) were never planned \(60 deg\)")],
    ids=["missing", "unplanned"])
def test_a_complete_sweep_against_its_plan(tmp_path: Path, angles: list[float],
                                           match: str) -> None:
    path = _recording(tmp_path / "plan.tdms", _sweep(angles))
    with pytest.raises(mc.MagciliaError, match="the file says it is complete, but " + match
                       ) as info:
        mc.read_measurements(path)
    _one_line(info, path)


def test_a_dropped_digit_in_a_complete_sweep_is_damage(tmp_path: Path) -> None:
    cols = _sweep(PLANNED)
    cols["angle_deg"][13] = 1.0  # 10 deg -> 1 deg: an angle never planned, one sample short
    path = _recording(tmp_path / "digit.tdms", cols)
    with pytest.raises(mc.MagciliaError, match=r"1 recorded angle\(s\) were never planned \(1 "
                       r"deg\); 1 angle\(s\) hold another number of samples than planned \(10 "
                       r"deg: 7 of 8\)"):
        mc.read_measurements(path)


def test_a_closing_count_that_disagrees_is_damage(tmp_path: Path) -> None:
    path = _recording(tmp_path / "count.tdms", _sweep(PLANNED), samples=40)
    with pytest.raises(mc.MagciliaError, match="the file holds 48 samples; its closing note "
                                               "says 40"):
        mc.read_measurements(path)


# -- damaged structure ----------------------------------------------------------------------------
def _damaged(tmp_path: Path, name: str, how: str, complete: bool | None, own: bool = True
             ) -> Path:
    """A recording (complete, cut short or foreign) damaged in one way."""
    path = _recording(tmp_path / f"{name}.tdms", _sweep(PLANNED), complete=complete, own=own)
    data = bytearray(path.read_bytes())
    starts = _lead_ins(path)
    data_segment = starts[3]  # a segment holding a chunk of samples
    closing = complete is not None  # the last segment is the closing note
    last_data = starts[-2] if closing else starts[-1]
    toc = struct.unpack_from("<I", data, data_segment + 4)[0]
    if how == "truncated":  # the file ends inside the last chunk's data
        data = data[:(starts[-1] if closing else len(data)) - 30]
    elif how == "truncated-metadata":  # the file ends inside the last chunk's metadata
        data = data[:last_data + 40]
    elif how in ("big-endian", "interleaved"):
        struct.pack_into("<I", data, data_segment + 4, toc | (0x40 if how == "big-endian"
                                                              else 0x20))
    elif how in ("offset+1", "offset-1"):  # the last chunk's next-segment offset
        offset = struct.unpack_from("<Q", data, last_data + 12)[0]
        struct.pack_into("<Q", data, last_data + 12, offset + (1 if how == "offset+1" else -1))
    elif how == "version":
        version = struct.unpack_from("<I", data, data_segment + 8)[0]
        struct.pack_into("<I", data, data_segment + 8, 4712 if version == 4713 else 4713)
    elif how == "unannounced":  # a chunk's raw data flag cleared: its samples would vanish
        struct.pack_into("<I", data, data_segment + 4, toc & ~0x8)
    elif how == "chunk-length":  # every channel's count halved: the chunk read as two, mixed up
        index = b"\x14\x00\x00\x00\x0a\x00\x00\x00\x01\x00\x00\x00" + struct.pack("<Q", PER)
        at = data_segment
        for _ in range(3):
            at = data.find(index, at + 1)
            struct.pack_into("<Q", data, at + 12, PER // 2)
    path.write_bytes(bytes(data))
    return path


KINDS = {  # damage -> what the note or error says
    "truncated": r"less data than its lead-in declares",
    "truncated-metadata": r"(metadata is cut short|\(it was cut\))",
    "big-endian": r"(byte orders|big-endian)",
    "interleaved": r"(interleaving|interleaved)",
    "offset+1": r"(\(it was cut\)|less data than|does not start with)",
    "offset-1": r"(stray bytes|whole number of chunks|does not start with)",
    "version": r"TDMS versions",
    "unannounced": r"does not announce",
    "chunk-length": r"(chunks in .* segments|different numbers of values)",
}


def _refused_or_noted(path: Path, pattern: str) -> str:
    """The one-line error reading ``path`` gives, or its notes: either must say ``pattern``."""
    try:
        m = mc.read_measurements(path)
    except mc.MagciliaError as exc:
        text = str(exc)
        assert "\n" not in text and str(path) in text
        return text
    said = "; ".join(m.notes())
    assert re.search(pattern, said), said
    return said


@pytest.mark.parametrize("how", sorted(KINDS))
@pytest.mark.parametrize("kind", ["complete", "cut-short", "foreign"])
def test_damage_is_refused_or_noted_never_silent(tmp_path: Path, how: str, kind: str) -> None:
    """Every kind of damage, to a complete recording, one cut short and another program's file:
    one error line or a note that says it."""
    complete, own = {"complete": (True, True), "cut-short": (None, True),
                     "foreign": (None, False)}[kind]
    _refused_or_noted(_damaged(tmp_path, how, how, complete=complete, own=own), KINDS[how])


@pytest.mark.parametrize("how", ["interleaved", "version", "unannounced", "chunk-length"])
def test_damage_inside_a_complete_recording_is_an_error(tmp_path: Path, how: str) -> None:
    """A file that says it is complete (its closing note read) cannot hold damage: the error
    names the first finding."""
    path = _damaged(tmp_path, how, how, complete=True)
    with pytest.raises(mc.MagciliaError, match="the file says it is complete, but .*"
                       + KINDS[how]) as info:
        mc.read_measurements(path)
    _one_line(info, path)


def test_a_truncated_complete_recording_reads_as_cut_short(tmp_path: Path) -> None:
    """Cut inside its last chunk, a complete recording loses its closing note: it is read as a
    recording cut short, with the damage noted (the issue's 148 of 396 samples read with no
    word)."""
    path = _damaged(tmp_path, "t", "truncated", complete=True)
    m = mc.read_measurements(path)
    said = m.notes()
    assert any("less data than its lead-in declares" in n for n in said)
    assert any(n.startswith("the recording is incomplete") for n in said)
    assert m.metadata["recording"]["complete"] is False


def test_nptdms_warnings_become_notes_not_log_lines(tmp_path: Path,
                                                    caplog: pytest.LogCaptureFixture) -> None:
    path = _damaged(tmp_path, "warn", "truncated", complete=None)
    with caplog.at_level(logging.DEBUG):
        m = mc.read_measurements(path)
    assert not [r for r in caplog.records if r.name.startswith("nptdms")]
    assert any("less data than its lead-in declares" in n for n in m.notes())


def test_read_samples_logs_the_notes(tmp_path: Path, caplog: pytest.LogCaptureFixture) -> None:
    path = _damaged(tmp_path, "logged", "version", complete=None, own=False)
    with caplog.at_level(logging.WARNING, logger="magcilia"):
        read_samples(path)
    assert any("TDMS versions differ" in r.getMessage() for r in caplog.records)


# -- nothing outside the file --------------------------------------------------------------------
def test_an_index_file_beside_the_recording_is_never_read(tmp_path: Path) -> None:
    """npTDMS, given a path, reads the segment metadata from ``x.tdms_index`` beside ``x.tdms``;
    magcilia hands it the open file, so a planted index file changes nothing."""
    path = _recording(tmp_path / "rec.tdms", _sweep(PLANNED))
    before = mc.read_measurements(path).to_dict()
    other = _recording(tmp_path / "other.tdms", _sweep([5.0, 15.0], per=24))
    index = bytearray(other.read_bytes())
    for at in _lead_ins(other):
        index[at:at + 4] = b"TDSh"
    (tmp_path / "rec.tdms_index").write_bytes(bytes(index))
    assert mc.read_measurements(path).to_dict() == before
    renamed = tmp_path / "index.tdms"  # an index file passed as the recording
    renamed.write_bytes(bytes(index))
    with pytest.raises(mc.MagciliaError, match=r"a TDMS index file \(it starts with 'TDSh'\)"):
        mc.read_measurements(renamed)


def test_a_name_hit_by_damage_is_noted_not_silently_missing(tmp_path: Path) -> None:
    """A byte of a channel's name overwritten (``setreset`` → ``set\\x00\\x00t``): the column is
    missing, so the readings are no longer set/reset differences; the note says why."""
    sr = np.tile([1.0, -1.0], 24)
    cols = {**_sweep(PLANNED), "setreset": sr}
    path = _recording(tmp_path / "name.tdms", cols, complete=None, own=False)
    path.write_bytes(path.read_bytes().replace(b"setreset", b"set\x00\x00\x00\x03t"))
    m = mc.read_measurements(path)
    assert not m.set_reset
    assert any(n.startswith("1 group or channel name(s) hold control characters "
                            "(set\\x00\\x00\\x00\\x03t)") for n in m.notes()), m.notes()


def test_a_name_one_bit_from_a_column_is_noted(tmp_path: Path) -> None:
    """A bit flipped in an optional channel's name (``azimuth_deg`` → ``azhmuth_deg``, found by
    the fuzz) drops the column: the conditions merge, and the note names the channel."""
    cols = {**_sweep(PLANNED), "azimuth_deg": np.tile([0.0, 90.0], 24)}
    path = _recording(tmp_path / "name.tdms", cols, complete=None, own=False)
    assert len(mc.read_measurements(path, saturation="keep")) == 12
    path.write_bytes(path.read_bytes().replace(b"azimuth_deg", b"azhmuth_deg"))
    m = mc.read_measurements(path, saturation="keep")
    assert len(m) == 6
    assert "channel azhmuth_deg (group recording) is one character from azimuth_deg and is not " \
           "read: a damaged name (or map it with columns=)" in m.notes()
