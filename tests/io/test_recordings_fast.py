"""The fast CSV reader and the one-pass reduction (issue 17): the careful reader's answers and a
direct reduction's numbers, wherever blocks and pieces are cut."""

from __future__ import annotations

import io
import math
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import magcilia as mc
from magcilia.io import csvfile, recordings, reduction
from magcilia.io.csvfile import NotPlainCSV, plain_csv_blocks, read_csv_carefully
from magcilia.io.recordings import measurement_from_samples, read_samples

REQUIRED = ("angle_deg", "voltage_V")


def _limits() -> dict[str, int]:
    return {"max_samples": recordings.MAX_SAMPLES, "max_line_chars": recordings.MAX_LINE_CHARS}


def _fast(path: Path) -> dict[str, np.ndarray]:
    """The fast reader's blocks, joined (NotPlainCSV where it gives up)."""
    blocks = list(plain_csv_blocks(path, recordings.COLUMNS, REQUIRED, **_limits()))
    return {col: np.concatenate([b[col] for b in blocks]) for col in blocks[0]}


def _careful(path: Path) -> dict[str, np.ndarray] | str:
    """The careful reader's columns, or its error."""
    try:
        return read_csv_carefully(path, recordings.COLUMNS, REQUIRED, **_limits())
    except mc.MagciliaError as exc:
        return str(exc)


def _same_columns(a: dict[str, np.ndarray], b: dict[str, np.ndarray] | str) -> bool:
    return (not isinstance(b, str) and a.keys() == b.keys()
            and all(np.array_equal(a[k], b[k], equal_nan=True) for k in a))


def _assert_same(m: mc.Measurement, ref: mc.Measurement, rtol: float = 1e-13) -> None:
    np.testing.assert_array_equal(m.angles, ref.angles)
    np.testing.assert_allclose(m.volts, ref.volts, rtol=rtol)
    np.testing.assert_allclose(m.sem, ref.sem, rtol=rtol)
    for name in ("counts", "saturated", "nonfinite"):
        np.testing.assert_array_equal(getattr(m, name), getattr(ref, name))
    assert m.metadata == ref.metadata and m.set_reset == ref.set_reset


def _recording(rng: np.random.Generator, per: int = 50, set_reset: bool = False
               ) -> dict[str, np.ndarray]:
    """Six angles in runs of ``per`` samples; a few mV on a sine, 20 µV of noise."""
    angle = np.repeat([-30.0, -10.0, 0.0, 5.5, 20.0, 40.0], per)
    sr = np.tile([1.0, -1.0], angle.size // 2)
    volts = 1e-3 + 1e-2 * np.sin(np.radians(angle)) + rng.normal(0.0, 2e-5, angle.size)
    cols = {"angle_deg": angle, "voltage_V": volts * sr if set_reset else volts}
    return {**cols, "setreset": sr} if set_reset else cols


def _write(path: Path, cols: dict[str, np.ndarray], newline: str = "\n") -> Path:
    text = [",".join(cols)] + [",".join("set" if k == "setreset" and x > 0 else
                                        "reset" if k == "setreset" else repr(x)
                                        for k, x in zip(cols, row, strict=True))
                               for row in zip(*(cols[k].tolist() for k in cols), strict=True)]
    path.write_bytes(newline.join(text).encode() + newline.encode())
    return path


# -- the reduction ------------------------------------------------------------------------------
@pytest.mark.parametrize("pieces", [1 << 20, 1000, 7], ids=["whole", "1000", "7"])
@pytest.mark.parametrize("shuffled", [False, True], ids=["runs", "shuffled"])
@pytest.mark.parametrize("set_reset", [False, True], ids=["plain", "set-reset"])
def test_the_reduction_is_accurate_on_a_large_offset(monkeypatch: pytest.MonkeyPatch,
                                                     pieces: int, shuffled: bool,
                                                     set_reset: bool) -> None:
    """2 V of offset under 1 µV of noise (a sum of squares about zero would keep no digit of the
    spread): the means and standard errors of an exact per-angle reduction (math.fsum) to
    1e-12, whatever the pieces the samples are reduced in."""
    monkeypatch.setattr(reduction, "REDUCE_SAMPLES", pieces)
    rng = np.random.default_rng(3)
    angle = np.repeat([0.0, 5.0, 10.0, 15.0], 3000)
    sr = np.tile([1.0, -1.0], angle.size // 2)
    offset = 2.0
    volts = offset + sr * np.repeat([1e-4, 2e-4, 3e-4, 4e-4], 3000) + rng.normal(0, 1e-6,
                                                                               angle.size)
    order = rng.permutation(angle.size) if shuffled else np.arange(angle.size)
    m = measurement_from_samples(angle[order], volts[order], setreset=sr[order] if set_reset
                                 else None, saturation="keep")
    means, var_of_means = [], []
    for a in (0.0, 5.0, 10.0, 15.0):
        stats = []
        for polarity in ((1.0, -1.0) if set_reset else (None,)):
            x = volts[(angle == a) & ((sr == polarity) if polarity else True)]
            mean = math.fsum(x) / x.size
            stats.append((mean, math.fsum((x - mean) ** 2) / (x.size - 1) / x.size))
        means.append((stats[0][0] - stats[1][0]) / 2 if set_reset else stats[0][0])
        var_of_means.append(sum(s[1] for s in stats) / (4 if set_reset else 1))
    if set_reset:  # a difference of means on the offset: good to the offset's last digits
        np.testing.assert_allclose(m.volts, means, rtol=0, atol=8 * np.finfo(float).eps * offset)
    else:
        np.testing.assert_allclose(m.volts, means, rtol=1e-12)
    np.testing.assert_allclose(m.sem, np.sqrt(var_of_means), rtol=1e-12)
    assert m.counts.tolist() == [3000] * 4


def test_pieces_do_not_change_the_measurement(monkeypatch: pytest.MonkeyPatch) -> None:
    """Pieces cut inside an angle's run, angles coming back, non-finite and saturated samples
    dropped and counted: the same measurement as in one piece."""
    rng = np.random.default_rng(4)
    cols = _recording(rng, per=40)
    angle = np.concatenate([cols["angle_deg"], cols["angle_deg"][:70]])  # angles come back
    volts = np.concatenate([cols["voltage_V"], cols["voltage_V"][:70]])
    angle[[3, 100]] = np.nan
    volts[[5, 60, 61]] = [np.inf, 0.5, -0.5]  # non-finite; saturated (beyond ±45 mV)
    volts[120:160] = np.nan  # every sample of 5.5 deg
    kwargs: dict[str, Any] = {"nan_policy": "omit", "saturation": "omit", "source": "r"}
    whole = measurement_from_samples(angle, volts, **kwargs)
    assert whole.metadata["dropped"] == {"no_angle": 2, "angles_deg": [5.5], "samples": 40}
    for pieces in (1, 7, 40, 41, angle.size - 1):
        monkeypatch.setattr(reduction, "REDUCE_SAMPLES", pieces)
        _assert_same(measurement_from_samples(angle, volts, **kwargs), whole)


@pytest.mark.parametrize("pieces", [1 << 20, 3], ids=["whole", "3"])
def test_the_first_problem_is_named_as_before(monkeypatch: pytest.MonkeyPatch,
                                              pieces: int) -> None:
    """The checks keep their order across pieces: a far angle before a non-finite sample before
    a saturated one, each named by its sample number in the whole recording."""
    monkeypatch.setattr(reduction, "REDUCE_SAMPLES", pieces)
    angle = np.repeat([0.0, 10.0, 20.0], 4)
    volts = np.repeat([1e-3, 2e-3, 3e-3], 4)
    volts[1] = 0.5  # saturated, in the first piece
    volts[5] = np.nan  # in the second
    angle[10] = 400.0  # in the fourth
    with pytest.raises(mc.MagciliaError, match=r"sample 11 has angle_deg=400, beyond"):
        measurement_from_samples(angle, volts)
    angle[10] = 20.0
    with pytest.raises(mc.MagciliaError, match=r"sample 6 is not finite"):
        measurement_from_samples(angle, volts)
    with pytest.raises(mc.MagciliaError, match=r"sample 2 \(voltage_V=0\.5 at 0 deg\) is beyond"):
        measurement_from_samples(angle, volts, nan_policy="omit")


# -- the fast CSV reader ------------------------------------------------------------------------
@pytest.mark.parametrize(
    "variant", ["plain", "setreset", "crlf", "bom-comments", "nan-inf", "time-first"])
def test_plain_files_are_read_fast(tmp_path: Path, monkeypatch: pytest.MonkeyPatch,
                                   variant: str) -> None:
    """Plain recordings never reach the careful reader, and the fast one gives its columns."""
    cols = _recording(np.random.default_rng(5), set_reset=variant == "setreset")
    if variant == "time-first":
        cols = {"time_s": np.arange(cols["angle_deg"].size) * 1e-3, **cols}
    path = _write(tmp_path / "r.csv", cols, "\r\n" if variant == "crlf" else "\n")
    if variant == "bom-comments":
        path.write_bytes(b"\xef\xbb\xbf# bench 3, \"quoted\" \xc2\xb0C\n\n" + path.read_bytes()
                         + b"\n  \n")
    if variant == "nan-inf":
        path.write_bytes(path.read_bytes() + b"0,nan\n-NaN,1e-3\n10,inf\n")
    assert _same_columns(_fast(path), _careful(path))
    careful = _careful(path)
    monkeypatch.setattr(recordings, "read_csv_carefully", None)  # a call would fail
    m = mc.read_measurements(path, nan_policy="omit")
    assert not isinstance(careful, str)
    ref = measurement_from_samples(careful["angle_deg"], careful["voltage_V"],
                                   setreset=careful.get("setreset"), nan_policy="omit",
                                   source=str(path))
    _assert_same(m, ref)
    assert m.counts.sum() == 300 and m.set_reset == (variant == "setreset")


@pytest.mark.parametrize(
    ("data", "match"),
    [("0,1e-3\n# a note\n10,2e-3\n", None),
     ('"0",1e-3\n10,2e-3\n', None),
     ("0,1e-3\r10,2e-3\r", None),
     ("0,1_0e-3\n10,2e-3\n", r"row 2, column voltage_V: '1_0e-3' is not a number"),
     ("0,1e-3\n10,\n", r"row 3, column voltage_V: '' is not a number"),
     ("0,1e-3\n10,NA\n", r"row 3, column voltage_V: 'NA' is not a number"),
     ("0,1e-3\n10,TRUE\n", r"row 3, column voltage_V: 'TRUE' is not a number"),
     ("0,1e-3,7\n10,2e-3,8\n", r"row 2 has 3 fields, the header has 2"),
     ("0,1e-3\n10,2e-3,8\n", r"row 3 has 3 fields, the header has 2"),
     ("0,1e-3\n10\n", r"row 3 has 1 fields, the header has 2"),
     ("0,1e-3\n10,2\xb5\n", r"row 3, column voltage_V: '2µ' is not a number"),
     ("0,1e-3\n10,2e-3\x00\n", r"row 3, column voltage_V: '2e-3\\x00' is not a number"),
     ("0," + "0" * 140_000 + "\n10,2e-3\n", r"row 2 is not well-formed CSV \(field larger")],
    ids=["comment", "quotes", "lone-cr", "underscore", "empty-field", "NA", "TRUE",
         "long-first-row", "long-row", "short-row", "non-ascii", "nul", "huge-field"],
)
def test_other_files_go_to_the_careful_reader(tmp_path: Path, data: str,
                                              match: str | None) -> None:
    """Anything but a plain file: the fast reader gives up and the careful one reads it, or
    names the row that is wrong, as it always has."""
    path = tmp_path / "r.csv"
    path.write_bytes(("angle_deg,voltage_V\n" + data).encode())
    with pytest.raises(NotPlainCSV):
        _fast(path)
    if match is None:
        assert read_samples(path)["voltage_V"].size == 2
    else:
        with pytest.raises(mc.MagciliaError, match=match):
            read_samples(path)


@pytest.mark.parametrize("content", [b'"angle_deg",voltage_V\n0,1\n', b"angle_deg,voltage_V\r0,1\n",
                                     b"# a\rangle_deg,voltage_V\n0,1\n", b"# \xff\n", b"",
                                     b"\n# only a comment\n"],
                         ids=["quoted", "lone-cr", "cr-in-comment", "not-utf8", "empty",
                              "no-header"])
def test_headers_that_are_not_plain(tmp_path: Path, content: bytes) -> None:
    path = tmp_path / "r.csv"
    path.write_bytes(content)
    with pytest.raises(NotPlainCSV):
        _fast(path)


@pytest.mark.parametrize("rows", [1, 7, 299, 300, 301, 150], ids=str)
def test_blocks_cut_anywhere(tmp_path: Path, monkeypatch: pytest.MonkeyPatch, rows: int) -> None:
    """Blocks of 1, 7, 150 (a whole number of them: the file ends at a block's end), 299, 300
    (the file is one block exactly) and 301 rows, cut inside angles' runs: the careful reader's
    columns and the same measurement."""
    cols = _recording(np.random.default_rng(6), set_reset=True)
    path = _write(tmp_path / "r.csv", cols)
    whole = mc.read_measurements(path)
    monkeypatch.setattr(csvfile, "CSV_BLOCK_ROWS", rows)
    blocks = list(plain_csv_blocks(path, recordings.COLUMNS, REQUIRED, **_limits()))
    assert [b["angle_deg"].size for b in blocks][:-1] == [rows] * (len(blocks) - 1)
    assert _same_columns(_fast(path), _careful(path))
    _assert_same(mc.read_measurements(path), whole)


def test_a_header_without_rows(tmp_path: Path) -> None:
    path = tmp_path / "r.csv"
    path.write_text("angle_deg,voltage_V,setreset\n")
    assert {k: a.size for k, a in _fast(path).items()} == {
        "angle_deg": 0, "voltage_V": 0, "setreset": 0}
    with pytest.raises(mc.MagciliaError, match="no samples"):
        mc.read_measurements(path)


def test_giving_up_after_some_blocks_starts_afresh(tmp_path: Path,
                                                   monkeypatch: pytest.MonkeyPatch) -> None:
    """A comment near the end, met after blocks were reduced: the careful reader's measurement,
    no sample counted twice; a bad value there: its row named."""
    monkeypatch.setattr(csvfile, "CSV_BLOCK_ROWS", 16)
    path = _write(tmp_path / "r.csv", _recording(np.random.default_rng(7)))
    lines = path.read_text().splitlines(keepends=True)
    path.write_text("".join(lines[:290] + ["# the bench was touched\n"] + lines[290:]))
    m = mc.read_measurements(path)
    assert m.counts.tolist() == [50] * 6
    path.write_text("".join(lines[:290] + ["20,1 mV\n"] + lines[290:]))
    with pytest.raises(mc.MagciliaError, match=r"row 291, column voltage_V: '1 mV' is not"):
        mc.read_measurements(path)


def test_the_row_limit_of_the_fast_reader(tmp_path: Path, monkeypatch: pytest.MonkeyPatch
                                          ) -> None:
    path = _write(tmp_path / "r.csv", _recording(np.random.default_rng(8)))
    monkeypatch.setattr(csvfile, "CSV_BLOCK_ROWS", 100)
    monkeypatch.setattr(recordings, "MAX_SAMPLES", 300)  # exactly the rows: read
    assert mc.read_measurements(path).counts.sum() == 300
    monkeypatch.setattr(recordings, "MAX_SAMPLES", 299)
    with pytest.raises(mc.MagciliaError, match=r"the file has more than MAX_SAMPLES = 299"):
        mc.read_measurements(path)


@pytest.mark.parametrize(
    ("pieces", "plain"),
    [([b"0,1\r", b"\n1,2\r\n"], True),  # a CRLF across two reads stays whole
     ([b"0,1\n1,2\r"], False),  # a lone CR at the end
     ([b"0,12345", b"6789\n"], False),  # a line of 11 characters, over two reads
     ([b"0,1234", b"567\n", b"0,1\n"], True),  # 10 characters: at the limit
     ([b"0,1234567", b"89"], False)],  # the last line, without its line end
    ids=["crlf-split", "lone-cr", "long-split", "at-limit", "long-last"],
)
def test_the_checked_byte_stream(pieces: list[bytes], plain: bool) -> None:
    """The fast reader's byte stream, read in pieces as pandas reads it (limit: 10 characters
    per line, with its line end)."""
    stream = csvfile._PlainBytes(io.BytesIO(b"".join(pieces)), 10)
    try:
        got = b"".join(iter(lambda: stream.read(len(pieces[0])), b""))
    except NotPlainCSV:
        assert not plain
    else:
        assert plain and got == b"".join(pieces)


TOKENS = ["0", "10", "-2.5e-3", "1e-3", "+1", "-1", "set", "reset", " Reset ", "nan", "-NaN",
          "inf", "-Infinity", "", " ", "1e", ".", "+nan", "nana", "sett", "1 2", "e5", "1e-400",
          "9" * 30, "\t3", "5.", ".5"]


@settings(max_examples=150, deadline=None, suppress_health_check=[HealthCheck.too_slow,
                                                                  HealthCheck.function_scoped_fixture])
@given(header=st.sampled_from(["angle_deg,voltage_V", "angle_deg,voltage_V,setreset",
                               "voltage_V,time_s,angle_deg", "angle_deg,voltage_V,",
                               "setreset, angle_deg ,voltage_V"]),
       rows=st.lists(st.lists(st.sampled_from(TOKENS), min_size=1, max_size=4), max_size=8),
       newline=st.sampled_from(["\n", "\r\n", "\r"]), block=st.sampled_from([1, 3, 1 << 20]))
def test_the_fast_reader_agrees_with_the_careful_one(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch, header: str, rows: list[list[str]],
        newline: str, block: int) -> None:
    """Wherever the fast reader answers, the careful reader gives the same columns (or the same
    header error)."""
    monkeypatch.setattr(csvfile, "CSV_BLOCK_ROWS", block)
    path = tmp_path / "h.csv"
    path.write_bytes(newline.join([header] + [",".join(r) for r in rows]).encode() + b"\n")
    fast: dict[str, np.ndarray] | str
    try:
        fast = _fast(path)
    except NotPlainCSV:
        return
    except mc.MagciliaError as exc:
        fast = str(exc)
    careful = _careful(path)
    assert fast == careful if isinstance(fast, str) else _same_columns(fast, careful)


def test_the_row_limit_stops_the_fast_reader(tmp_path: Path, monkeypatch: pytest.MonkeyPatch
                                             ) -> None:
    """More rows than MAX_SAMPLES: the fast reader's own error, not a second reading."""
    path = _write(tmp_path / "r.csv", _recording(np.random.default_rng(9)))
    monkeypatch.setattr(csvfile, "CSV_BLOCK_ROWS", 100)
    monkeypatch.setattr(recordings, "MAX_SAMPLES", 150)
    monkeypatch.setattr(recordings, "read_csv_carefully", None)  # a call would fail
    with pytest.raises(mc.MagciliaError, match=r"the file has more than MAX_SAMPLES = 150"):
        mc.read_measurements(path)


@pytest.mark.parametrize("block", [1, 3, 7, 1 << 20])
def test_whole_columns_are_the_blocks_joined(tmp_path: Path, monkeypatch: pytest.MonkeyPatch,
                                             block: int) -> None:
    """The fast reader's whole columns (arrays sized from the first block's share of the file)
    are its blocks joined, also where later rows are shorter than the first (the arrays grow)."""
    monkeypatch.setattr(csvfile, "CSV_BLOCK_ROWS", block)
    rng = np.random.default_rng(8)
    long_rows = [f"{a:.15f},{v:.17e},{t:.12f}" for a, v, t in zip(
        np.repeat([1.0, 2.0], 5), rng.normal(size=10), np.arange(10.0), strict=True)]
    short_rows = [f"{i % 7},{i % 3},{i}" for i in range(200)]
    path = tmp_path / "grow.csv"
    path.write_text("angle_deg,voltage_V,time_s\n" + "\n".join(long_rows + short_rows) + "\n")
    whole = csvfile.plain_csv_columns(path, recordings.COLUMNS, REQUIRED, **_limits())
    joined = _fast(path)
    assert list(whole) == list(joined) and whole["time_s"].size == 210
    assert _same_columns(whole, joined)


@settings(max_examples=200, deadline=None)
@given(lines=st.lists(st.integers(0, 40), min_size=1, max_size=30),
       limit=st.integers(1, 45), read=st.integers(1, 64), tail=st.booleans())
def test_the_line_limit_of_the_byte_stream(lines: list[int], limit: int, read: int,
                                           tail: bool) -> None:
    """The checked byte stream refuses exactly the data with a line longer than the limit (with
    its line end), however pandas cuts its reads: against the longest line measured directly."""
    data = b"".join(b"7" * n + b"\n" for n in lines) + (b"123" if tail else b"")
    longest = max(len(line) + 1 for line in data.split(b"\n")[:-1])
    longest = max(longest, 3 if tail else 0)
    stream = csvfile._PlainBytes(io.BytesIO(data), limit)
    try:
        got = b"".join(iter(lambda: stream.read(read), b""))
    except NotPlainCSV:
        assert longest > limit
    else:
        assert longest <= limit and got == data
